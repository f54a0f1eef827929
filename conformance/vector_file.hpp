// Vector files (vectors/FORMAT.md) → the typed model (vector.hpp).
//
// A vector file is a YAML sequence of vectors. Every key is checked against the format (an
// unknown key is an error: a typo must not silently disable a check), every value is parsed
// and range-checked, and every error names file:line (yaml-cpp's mark of the offending node).
// Loading does not stop at the first error: a linter wants them all. A vector with an error is
// left out of the result.
//
// A vector tree is every `*.yaml` under a directory except `drives/` (drive profiles) and the
// top-level `manuals.yaml` (the manual list), read in path order; ids must be unique across
// all of them.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "conformance/vector.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::conformance {

struct VectorSet {
  std::vector<Vector> vectors;
  std::vector<TextError> errors;   // file:line: message, in file order
  std::vector<std::string> files;  // the files read (display names)
  bool ok() const { return errors.empty(); }
};

// Parses YAML text; `file` is the display name used in errors and Vector::file.
VectorSet parse_vectors(std::string_view text, const std::string& file);
// Reads one file (display name: `display` or, when empty, the path as given).
VectorSet load_vector_file(const std::filesystem::path& path, const std::string& display = {});
// Reads a tree (display names relative to the parent of `dir`, e.g. "vectors/cia301/sdo.yaml",
// or, with `as_given`, `dir` as given joined with the file's relative path, e.g.
// "/home/me/my-vectors/x.yaml"), and checks that ids are unique across files.
VectorSet load_vector_tree(const std::filesystem::path& dir, bool as_given = false);
// Reads several trees: the first (the shipped vectors, or the tree a command names) as
// load_vector_tree(dir), each further one (a user's `--vectors DIR`) with display names as
// given; ids must be unique across all of them: an id defined in two trees is an error at the
// later definition that names both file:line.
VectorSet load_vector_trees(const std::vector<std::filesystem::path>& dirs);

// Writes vectors as a vector file (FORMAT.md) that parse_vectors reads back to vectors of the
// same content (same_content), in the same order. Strings are double-quoted (every byte
// escaped as YAML needs), frames and sources are written as they were read (FrameSpec::text,
// Source::text), durations by profile::format_duration, modifiers always explicitly (also
// defaults such as `within: $timing.response`). Lines and file names are not kept.
std::string to_yaml(const std::vector<Vector>& vectors);
// Whether two vectors say the same: every field but where they were read (Vector::file,
// Vector::line, Step::line, Source::line).
bool same_content(const Vector& a, const Vector& b);

// The keys of the format, from the loader's own tables: the vector keys, then each step
// action followed by its modifiers (FORMAT.md "A vector", "Steps"); for the fuzz dictionary.
std::vector<std::string_view> vector_file_keys();

// Parses a duration literal "100ms", "2s", "1min" (ns us ms s min) or "$timing.<key>" (key
// from the timing table). The error is a message without file:line.
Expected<DurationSpec, std::string> parse_duration_spec(std::string_view text);
// Parses a source citation (FORMAT.md "source").
Expected<Source, std::string> parse_source(std::string_view text);
// Parses a frame (`patterns`: `..` bytes and a trailing `*` allowed).
Expected<FrameSpec, std::string> parse_frame_spec(std::string_view text, bool pattern);
// Parses the 8 octets of an SDO message (sdo_request; with `pattern`, `..` allowed:
// expect_sdo_response) into the CAN frame that carries them on `cob` + N (600h, 580h).
Expected<FrameSpec, std::string> parse_sdo_octets(std::string_view text, bool pattern,
                                                  std::uint32_t cob);
// Parses a COB-ID: `080`, `600+N`.
Expected<CobIdSpec, std::string> parse_cob_id(std::string_view text);

}  // namespace drivecheck::conformance
