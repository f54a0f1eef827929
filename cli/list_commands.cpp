// drivecheck profiles | deviations: what --profile and --deviation take.
//
//   profiles    the drive profiles shipped in <data>/vectors/drives (or --vectors DIR's):
//               name, title, manual, and how many documented deviations each declares
//   deviations  the reference drive's named deviations (reference_drive/deviations.inc):
//               name, the family whose vectors catch it, kind (fatal: crash, hang or babble),
//               and the description
// Both exit 0; profiles exits 2 when a profile does not load (file:line on stderr).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>

#include "cli/commands.hpp"
#include "cli/data_dir.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/deviations.hpp"

namespace drivecheck::cli {
namespace {

struct ProfilesOptions {
  std::string vectors;
};

void list_profiles(const ProfilesOptions& options) {
  const std::filesystem::path dir =
      (options.vectors.empty() ? shipped_vectors_dir() : std::filesystem::path(options.vectors)) /
      "drives";
  const auto names = profile::list_profiles(dir);
  std::size_t width = 4;
  for (const auto& name : names)
    width = std::max(width, name.size());
  bool ok = true;
  fmt::print("{:<{}}  {}\n", "NAME", width, "TITLE [MANUAL] (DOCUMENTED DEVIATIONS)");
  for (const auto& name : names) {
    const auto loaded = profile::find_profile(name, dir);
    if (!loaded) {
      fmt::print(stderr, "{}\n", loaded.error().to_string());
      ok = false;
      continue;
    }
    fmt::print("{:<{}}  {}{} ({})\n", name, width, loaded->title,
               loaded->manual.empty() ? std::string() : fmt::format(" [{}]", loaded->manual),
               loaded->deviations.size());
  }
  fmt::print("{} profiles in {}\n", names.size(), dir.string());
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
  profiles
      ->add_option("--vectors", options->vectors,
                   "Vector directory whose drives/ to list (default: the shipped vectors)")
      ->check(CLI::ExistingDirectory)
      ->type_name("DIR");
  profiles->callback([options] { list_profiles(*options); });

  CLI::App* deviations = app.add_subcommand(
      "deviations", "List the reference drive's named deviations (what --deviation takes)");
  deviations->callback([] { list_deviations(); });
}

}  // namespace drivecheck::cli
