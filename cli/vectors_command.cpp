// drivecheck vectors lint|list [DIR]: the test vectors and drive profiles.
//
//   lint  checks the tree (conformance/vector_lint.hpp); prints "file:line: error: ..." per
//         finding on stderr and a summary on stdout; exit 2 on any error, 0 otherwise.
//   list  prints the catalogue: id, level, family, title, first source; exit 2 if the tree has
//         errors (they are printed as by lint).
// DIR defaults to the shipped vectors (cli/data_dir.hpp: <prefix>/share/drivecheck/vectors).
// `--vectors DIR` (repeatable) adds a user's own vectors, profiles and manual list
// (cli/vector_dirs.hpp); both commands check them with the tree.
// The manuals for the sha256 check: --manuals DIR, else $DRIVECHECK_MANUALS; without either,
// the sha256 check of the shipped manuals is skipped and the summary says so (a user's manuals,
// kept beside their manuals.yaml, are always checked).
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cli/commands.hpp"
#include "cli/data_dir.hpp"
#include "cli/vector_dirs.hpp"
#include "conformance/vector_file.hpp"
#include "conformance/vector_lint.hpp"

namespace drivecheck::cli {
namespace {

struct VectorsOptions {
  std::string dir;
  std::vector<std::string> user;
  std::string manuals;
};

conformance::LintReport lint(const VectorsOptions& options) {
  auto report = cli::lint(vector_dirs(options.user, options.dir), manuals_dir(options.manuals));
  print_lint_findings(report);
  return report;
}

}  // namespace

void add_vectors_command(CLI::App& app) {
  // The callbacks own the option storage: CLI11 writes into it during parse().
  auto options = std::make_shared<VectorsOptions>();
  CLI::App* vectors = app.add_subcommand("vectors", "Check or list the test vectors");
  vectors->require_subcommand(1);

  CLI::App* lint_cmd = vectors->add_subcommand(
      "lint", "Check vectors and drive profiles: schema, ids, sources, references");
  lint_cmd->add_option("DIR", options->dir, "Vector directory (default: the shipped vectors)")
      ->check(CLI::ExistingDirectory);
  lint_cmd
      ->add_option("--manuals", options->manuals,
                   "Directory of the manuals, for the sha256 check (default: "
                   "$DRIVECHECK_MANUALS; without it the check is skipped)")
      ->check(CLI::ExistingDirectory)
      ->type_name("DIR");
  add_vectors_option(*lint_cmd, options->user);
  lint_cmd->callback([options] {
    const auto report = lint(*options);
    fmt::print("{} vectors in {} files, {} drive profiles{}{}: {} error(s), {} warning(s)\n",
               report.vectors.size(), report.files, report.profiles,
               report.manuals_checked ? ", manuals verified" : fmt::format(", {}", kManualsSkipped),
               report.user_manuals > 0
                   ? fmt::format(", {} manual(s) of --vectors checked", report.user_manuals)
                   : std::string(),
               report.errors.size(), report.warnings.size());
    exit_with(report.ok() ? kExitPass : kExitUsage);
  });

  CLI::App* list = vectors->add_subcommand("list", "List the vectors with id, level and source");
  list->add_option("DIR", options->dir, "Vector directory (default: the shipped vectors)")
      ->check(CLI::ExistingDirectory);
  add_vectors_option(*list, options->user);
  list->callback([options] {
    const auto dirs = vector_dirs(options->user, options->dir);
    // The tree alone as before; with --vectors, linted as run lints it (ids, profiles, the
    // user's manuals), so that what list shows is what run would accept.
    conformance::VectorSet set;
    if (dirs.user.empty()) {
      set = conformance::load_vector_tree(dirs.tree);
      for (const auto& error : set.errors)
        fmt::print(stderr, "{}\n", error.to_string());
    } else {
      auto report = cli::lint(dirs, std::nullopt);
      print_lint_findings(report, false);
      set.vectors = std::move(report.vectors);
      set.errors = std::move(report.errors);
    }
    std::size_t id_width = 2;
    std::size_t family_width = 6;
    for (const auto& vector : set.vectors) {
      id_width = std::max(id_width, vector.id.size());
      family_width = std::max(family_width, vector.family().size());
    }
    fmt::print("{:<{}}  {:<6}  {:<{}}  {}  [{}]\n", "ID", id_width, "LEVEL", "FAMILY", family_width,
               "TITLE", "SOURCE");
    for (const auto& vector : set.vectors) {
      fmt::print("{:<{}}  {:<6}  {:<{}}  {}  [{}]\n", vector.id, id_width,
                 conformance::to_string(vector.level), vector.family(), family_width, vector.title,
                 vector.sources.empty() ? std::string() : vector.sources.front().text);
    }
    fmt::print("{} vectors\n", set.vectors.size());
    exit_with(set.ok() ? kExitPass : kExitUsage);
  });
}

}  // namespace drivecheck::cli
