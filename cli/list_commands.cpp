// drivecheck profiles | deviations: what --profile and --deviation take.
//
//   profiles    the drive profiles shipped in <data>/vectors/drives and each --vectors DIR's:
//               name, title, manual, and how many documented deviations each declares
//   deviations  the reference drive's named deviations (reference_drive/deviations.inc):
//               name, the family whose vectors catch it, kind (fatal: crash, hang or babble),
//               and the description
// Both exit 0; profiles exits 2 when a profile does not load (file:line on stderr).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.hpp"
#include "cli/data_dir.hpp"
#include "cli/vector_dirs.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/deviations.hpp"

namespace drivecheck::cli {
namespace {

struct ProfilesOptions {
  std::vector<std::string> vectors;
};

void list_profiles(const ProfilesOptions& options) {
  const VectorDirs dirs = vector_dirs(options.vectors);
  const auto profiles = cli::list_profiles(dirs);
  std::size_t width = 4;
  for (const auto& entry : profiles)
    width = std::max(width, entry.name.size());
  bool ok = true;
  fmt::print("{:<{}}  {}\n", "NAME", width, "TITLE [MANUAL] (DOCUMENTED DEVIATIONS)");
  for (const auto& entry : profiles) {
    // By name: a name two directories define is reported (both files) as run would.
    const auto loaded = find_profile(entry.name, dirs);
    if (!loaded) {
      fmt::print(stderr, "{}\n", loaded.error().to_string());
      ok = false;
      continue;
    }
    if (loaded->path != entry.path) continue;  // listed once, from the directory it is in
    fmt::print("{:<{}}  {}{} ({})\n", entry.name, width, loaded->title,
               loaded->manual.empty() ? std::string() : fmt::format(" [{}]", loaded->manual),
               loaded->deviations.size());
  }
  std::vector<std::string> places;
  for (const auto& dir : dirs.all())
    places.push_back((dir / "drives").string());
  fmt::print("{} profiles in {}\n", profiles.size(), fmt::join(places, ", "));
  exit_with(ok ? kExitPass : kExitUsage);
}

void list_deviations() {
  std::size_t name_width = 4;
  std::size_t family_width = 6;
  for (const auto& info : reference_drive::kDeviations) {
    name_width = std::max(name_width, info.name.size());
    family_width = std::max(family_width, info.family.size());
  }
  fmt::print("{:<{}}  {:<{}}  {:<8}  {}\n", "NAME", name_width, "FAMILY", family_width, "KIND",
             "DESCRIPTION");
  for (const auto& info : reference_drive::kDeviations) {
    fmt::print("{:<{}}  {:<{}}  {:<8}  {}\n", info.name, name_width, info.family, family_width,
               info.kind == reference_drive::DeviationKind::fatal ? "fatal" : "ordinary",
               info.description);
  }
  fmt::print("{} deviations (drivecheck run --deviation NAME)\n",
             reference_drive::kDeviations.size());
}

}  // namespace

void add_list_commands(CLI::App& app) {
  auto options = std::make_shared<ProfilesOptions>();
  CLI::App* profiles =
      app.add_subcommand("profiles", "List the drive profiles (what --profile takes)");
  add_vectors_option(*profiles, options->vectors);
  profiles->callback([options] { list_profiles(*options); });

  CLI::App* deviations = app.add_subcommand(
      "deviations", "List the reference drive's named deviations (what --deviation takes)");
  deviations->callback([] { list_deviations(); });
}

}  // namespace drivecheck::cli
