// `drivecheck vectors lint`: everything that can be checked about a vector tree without a drive.
//
//  - every vector file parses (vector_file.hpp: schema, unknown keys, values, marks, features);
//  - ids are unique across files;
//  - every manual a source cites is listed in <dir>/manuals.yaml and the line range lies within
//    the manual's line count; when the manuals directory is available, each listed manual
//    exists there and its sha256 is the one in manuals.yaml (the citations point at that text);
//  - abort expectations name a set of protocol/cia301/sdo_abort_sets.inc, or give `clause:`
//    beside a literal list; raw SDO abort frames with a fixed code likewise;
//  - every drive profile in <dir>/drives/ loads (protocol/profile: deviations name exact ids
//    and their observation), its deviation sources cite listed manuals within range, and each
//    deviation's vector id is a vector of the tree or a generated object check (an error);
//  - a profile's commissioning writes cite listed manuals within range, write no object its
//    `objects:` list read-only, and its globs match vectors (a warning otherwise);
//  - every `profiles:` name of a vector is a profile in <dir>/drives/;
//  - user directories (`--vectors DIR`, LintOptions::user_dirs) add their vector files, their
//    drives/ profiles and their own manual list (DIR/manuals.yaml, the format of
//    vectors/manuals.yaml) to the tree, all checked as above: a vector id, profile name or
//    manual file that a user directory defines again (the shipped tree's or an earlier user
//    directory's) is an error at the later definition naming both file:line; a user's manual
//    files are read beside their list (DIR/<file>) and their sha256 is always checked (a
//    missing file or another digest is an error at DIR/manuals.yaml:line);
//  - a `bus_off` step is shorter than its vector's timeout;
//  - every literal time bound of a must-level vector has `clause:` (check_timing_bounds);
//  - every object a vector touches (sdo_read, sdo_write, poll, controlword (6040h),
//    expect_state/expect_statusword (6041h), and SDO requests in raw `send:` frames to 600+N)
//    that the object requirement tables (protocol/cia301/object_requirements.inc,
//    protocol/cia402/object_requirements.inc) class optional is declared in `requires:`
//    (object.IIII, or object.IIII.SS where the table classes single sub-indices), and one they
//    class conditional on a feature is declared or the feature is required (a required
//    `pdo.dynamic-mapping` counts for `pdo`, a mode or `drive_state:` for `cia402`). A step that
//    expects the abort "object/sub-index does not exist" tests absence and needs nothing, and
//    so does an sdo_write with `expect: ok-or-abort` (any abort passes, absence included).
// Findings are file:line messages; errors make the lint fail (exit 2), warnings do not.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "conformance/vector.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::conformance {

// One manual of vectors/manuals.yaml.
struct ManualEntry {
  std::string file;
  std::string device;
  std::string sha256;
  std::size_t lines = 0;
  std::size_t line = 0;  // where manuals.yaml lists it
  std::string title;     // optional: the manual's title, shown with its citations in reports
  std::string edition;   // optional: its edition (document number, revision, date)
};

// Reads manuals.yaml ({file, device, sha256, lines, title?, edition?} per entry, keys
// checked).
Expected<std::vector<ManualEntry>, std::vector<TextError>> load_manuals(
    const std::filesystem::path& path);

struct LintOptions {
  std::filesystem::path dir;                         // the vector tree (vectors/)
  std::optional<std::filesystem::path> manuals_dir;  // where the manuals are, if available
  std::vector<std::filesystem::path> user_dirs;      // --vectors DIR, in order (see above)
};

struct LintReport {
  std::vector<TextError> errors;
  std::vector<TextError> warnings;
  std::vector<Vector> vectors;  // the vectors that loaded
  std::size_t files = 0;
  std::size_t profiles = 0;
  bool manuals_checked = false;  // sha256 of the manuals verified
  std::size_t user_manuals = 0;  // manuals of the user directories' lists (always verified)
  bool ok() const { return errors.empty(); }
};

LintReport lint_vector_tree(const LintOptions& options);

// The 1-based line of a profile file's top-level `name:` key (1 when there is none), for
// file:line messages about a profile as a whole.
int profile_name_line(const std::filesystem::path& path);

// The object-need findings of one vector (see above): file:line errors, empty when fine.
std::vector<TextError> check_object_needs(const Vector& vector);
// "" when the step's abort expectation is fine; else why not: an sdo_read/sdo_write `abort:`
// literal list without `clause:`, or an expect_frame SDO abort (580h+N, byte 0 80h) with a
// fixed code and neither `abort:` nor `clause:`.
std::string check_abort_expectation(const Step& step);

// The literal time bounds of one step of a `level: must` vector that lack their clause (FORMAT.md
// "Timing"): one message per bound, empty when fine. A time bound is `within:` (expect_frame,
// expect_bootup, expect_heartbeat, expect_emcy, expect_state, expect_statusword, poll), `for:`
// (expect_silence), `tolerance:` (expect_periodic) and `min:`/`max:` (measure). A `$timing.KEY`
// bound (and an omitted one: its default is a key) carries the timing table's basis. A literal
// needs `clause:` on the step that begins with a citation parse_source() reads ("CiA 301
// §7.2.8.3.2.2 ..." or "<manual> §x L<a>-<b> ..."; a manual must be listed in `manuals`, within
// its lines). `period:` is the value the vector configured (1017h, 1006h, an event timer), not
// a bound. Vectors of level should/may and `finally:` steps are not checked.
std::vector<std::string> check_timing_bounds(const Vector& vector, const Step& step,
                                             const std::vector<ManualEntry>& manuals);
// A `clause:` text that begins with a citation (up to " (", ";" or ","), checked like a source
// ("" when fine).
std::string check_clause_citation(const std::string& clause,
                                  const std::vector<ManualEntry>& manuals);
// The findings about an sdo_write's `refused_means_not_applicable:` (FORMAT.md "Values the
// device may refuse"), empty when fine: it needs `clause:` beginning with a citation (where
// CiA or the manual lets the device refuse the value), it may not be in `finally:`, and in a
// `level: must` vector the object may not be one the object requirement tables make mandatory
// for it (mandatory, or conditional on a feature the vector requires).
std::vector<std::string> check_refusal_not_applicable(const Vector& vector, const Step& step,
                                                      bool in_finally,
                                                      const std::vector<ManualEntry>& manuals);
// Checks a source citation against the manual list ("" when fine).
std::string check_citation(const Source& source, const std::vector<ManualEntry>& manuals);

}  // namespace drivecheck::conformance
