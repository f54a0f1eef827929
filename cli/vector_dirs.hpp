// The vector directories a command reads: the shipped tree (cli/data_dir.hpp:
// <prefix>/share/drivecheck/vectors or $DRIVECHECK_VECTORS; `vectors lint DIR` names another
// tree in its place) and the user's own, `--vectors DIR` (repeatable, in the order given), in
// run, vectors lint, vectors list, profiles, fuzz and drive.
//
// A user directory has the layout of the shipped tree: vector files (`*.yaml`, any depth),
// drive profiles in drives/, and optionally a manual list manuals.yaml (the format of
// vectors/manuals.yaml) with the user's manual files beside it (DIR/<file>); their sha256 is
// always checked. A vector id, profile name or manual file name that a user directory defines
// again is an error naming both file:line (conformance/vector_lint.hpp).
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "conformance/vector_lint.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::cli {

struct VectorDirs {
  std::filesystem::path tree;                      // the shipped tree (or the one named instead)
  std::vector<std::filesystem::path> user;         // --vectors DIR, in order
  std::vector<std::filesystem::path> all() const;  // tree, then user
  std::vector<std::filesystem::path> manual_lists() const;  // each one's manuals.yaml
  // " --vectors DIR" for each user directory: to repeat a command line in a hint.
  std::string user_arguments() const;
};

// `user`: the --vectors values; `tree`: a tree named instead of the shipped one ("" = shipped).
VectorDirs vector_dirs(const std::vector<std::string>& user, const std::string& tree = {});

// Adds `--vectors DIR` (repeatable, an existing directory) to `command`.
void add_vectors_option(CLI::App& command, std::vector<std::string>& dirs);

// A profile by path (contains '/' or ends in .yaml: loaded as is) or by name, looked up in the
// drives/ of every directory. A name in two directories is an error naming both files.
Expected<profile::DriveProfile, TextError> find_profile(std::string_view name_or_path,
                                                        const VectorDirs& dirs);

// A profile name with its file, for every directory's drives/ (tree first, names sorted per
// directory).
struct ProfileFile {
  std::string name;
  std::filesystem::path path;
};
std::vector<ProfileFile> list_profiles(const VectorDirs& dirs);

// The lint of the tree with the user directories (manuals_dir: the shipped manuals, for their
// sha256; nullopt: not checked).
conformance::LintReport lint(const VectorDirs& dirs,
                             const std::optional<std::filesystem::path>& manuals_dir);
// Prints a lint's findings as "file:line: error: ..." / "file:line: warning: ..." on stderr.
void print_lint_findings(const conformance::LintReport& report, bool warnings = true);
// fuzz and drive with --vectors: lints what they load (as run does); on an error prints the
// findings and exits 2 (usage).
void lint_user_dirs_or_exit(const VectorDirs& dirs, std::string_view command);

}  // namespace drivecheck::cli
