#include "cli/vector_dirs.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <system_error>

#include "cli/commands.hpp"
#include "cli/data_dir.hpp"
#include "conformance/vector_lint.hpp"

namespace drivecheck::cli {

std::vector<std::filesystem::path> VectorDirs::all() const {
  std::vector<std::filesystem::path> dirs{tree};
  dirs.insert(dirs.end(), user.begin(), user.end());
  return dirs;
}

std::vector<std::filesystem::path> VectorDirs::manual_lists() const {
  std::vector<std::filesystem::path> lists;
  for (const auto& dir : all())
    lists.push_back(dir / "manuals.yaml");
  return lists;
}

std::string VectorDirs::user_arguments() const {
  std::string text;
  for (const auto& dir : user)
    text += " --vectors " + dir.string();
  return text;
}

VectorDirs vector_dirs(const std::vector<std::string>& user, const std::string& tree) {
  VectorDirs dirs;
  dirs.tree = tree.empty() ? shipped_vectors_dir() : std::filesystem::path(tree);
  for (const auto& dir : user)
    dirs.user.emplace_back(dir);
  return dirs;
}

void add_vectors_option(CLI::App& command, std::vector<std::string>& dirs) {
  command
      .add_option("--vectors", dirs,
                  "A directory of your own vectors, drives/ profiles and manuals.yaml, read "
                  "beside the shipped ones (repeatable; vectors/FORMAT.md \"Your own vectors\")")
      ->check(CLI::ExistingDirectory)
      ->allow_extra_args(false)
      ->type_name("DIR");
}

Expected<profile::DriveProfile, TextError> find_profile(std::string_view name_or_path,
                                                        const VectorDirs& dirs) {
  const std::string text(name_or_path);
  if (text.find('/') != std::string::npos || text.ends_with(".yaml"))
    return profile::load_profile(text);
  std::vector<std::filesystem::path> found;
  for (const auto& dir : dirs.all()) {
    const auto path = dir / "drives" / (text + ".yaml");
    std::error_code ec;
    if (std::filesystem::exists(path, ec)) found.push_back(path);
  }
  if (found.size() > 1) {
    return Unexpected(TextError{
        found[1].string(), conformance::profile_name_line(found[1]),
        fmt::format("profile '{}' is already defined at {}:{} (profile names are unique across "
                    "the shipped profiles and every --vectors DIR)",
                    text, found[0].string(), conformance::profile_name_line(found[0]))});
  }
  if (found.size() == 1) return profile::load_profile(found.front());
  // Not found: find_profile names the known profiles (of every directory).
  if (dirs.user.empty()) return profile::find_profile(text, dirs.tree / "drives");
  std::vector<std::string> known;
  for (const auto& profile : list_profiles(dirs))
    known.push_back(profile.name);
  std::vector<std::string> places;
  for (const auto& dir : dirs.all())
    places.push_back((dir / "drives").string());
  return Unexpected(
      TextError{"", 0,
                fmt::format("no profile '{}' in {} (known: {})", text, fmt::join(places, ", "),
                            known.empty() ? std::string("none")
                                          : fmt::format("{}", fmt::join(known, ", ")))});
}

std::vector<ProfileFile> list_profiles(const VectorDirs& dirs) {
  std::vector<ProfileFile> profiles;
  for (const auto& dir : dirs.all()) {
    const auto drives = dir / "drives";
    for (auto& name : profile::list_profiles(drives))
      profiles.push_back({name, drives / (name + ".yaml")});
  }
  return profiles;
}

conformance::LintReport lint(const VectorDirs& dirs,
                             const std::optional<std::filesystem::path>& manuals_dir) {
  return conformance::lint_vector_tree({dirs.tree, manuals_dir, dirs.user});
}

void print_lint_findings(const conformance::LintReport& report, bool warnings) {
  for (const auto& error : report.errors) {
    const auto text = error.to_string();
    const auto colon = error.line > 0 || !error.file.empty() ? text.find(": ") : std::string::npos;
    if (colon == std::string::npos) {
      fmt::print(stderr, "error: {}\n", text);
    } else {
      fmt::print(stderr, "{}: error: {}\n", text.substr(0, colon), text.substr(colon + 2));
    }
  }
  if (!warnings) return;
  for (const auto& warning : report.warnings) {
    const auto where =
        warning.line > 0 ? fmt::format("{}:{}", warning.file, warning.line) : warning.file;
    fmt::print(stderr, "{}: warning: {}\n", where, warning.message);
  }
}

void lint_user_dirs_or_exit(const VectorDirs& dirs, std::string_view command) {
  if (dirs.user.empty()) return;
  const auto report = lint(dirs, std::nullopt);
  if (report.ok()) return;
  print_lint_findings(report, false);
  fmt::print(stderr, "drivecheck {}: {} error(s) in the vectors (drivecheck vectors lint{})\n",
             command, report.errors.size(), dirs.user_arguments());
  exit_with(kExitUsage);
}

}  // namespace drivecheck::cli
