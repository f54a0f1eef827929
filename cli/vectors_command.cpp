// drivecheck vectors lint|list [DIR]: the test vectors and drive profiles.
//
//   lint  checks the tree (conformance/vector_lint.hpp); prints "file:line: error: ..." per
//         finding on stderr and a summary on stdout; exit 2 on any error, 0 otherwise.
//   list  prints the catalogue: id, level, family, title, first source; exit 2 if the tree has
//         errors (they are printed as by lint).
// DIR defaults to the shipped vectors (cli/data_dir.hpp: <prefix>/share/drivecheck/vectors).
// The manuals for the sha256 check: --manuals DIR, else $DRIVECHECK_MANUALS; without either,
// the sha256 check is skipped and the summary says so.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "cli/commands.hpp"
#include "cli/data_dir.hpp"
#include "conformance/vector_file.hpp"
#include "conformance/vector_lint.hpp"

namespace drivecheck::cli {
namespace {

struct VectorsOptions {
  std::string dir;
  std::string manuals;
};

std::string default_vectors_dir() {
  return shipped_vectors_dir().string();
}

conformance::LintReport lint(const VectorsOptions& options) {
  const std::string dir = options.dir.empty() ? default_vectors_dir() : options.dir;
  auto report = conformance::lint_vector_tree({dir, manuals_dir(options.manuals)});
  for (const auto& error : report.errors) {
    const auto text = error.to_string();
    const auto colon = error.line > 0 || !error.file.empty() ? text.find(": ") : std::string::npos;
    if (colon == std::string::npos) {
      fmt::print(stderr, "error: {}\n", text);
    } else {
      fmt::print(stderr, "{}: error: {}\n", text.substr(0, colon), text.substr(colon + 2));
    }
  }
  for (const auto& warning : report.warnings) {
    const auto where =
        warning.line > 0 ? fmt::format("{}:{}", warning.file, warning.line) : warning.file;
    fmt::print(stderr, "{}: warning: {}\n", where, warning.message);
  }
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
  lint_cmd->callback([options] {
    const auto report = lint(*options);
    fmt::print("{} vectors in {} files, {} drive profiles{}: {} error(s), {} warning(s)\n",
               report.vectors.size(), report.files, report.profiles,
               report.manuals_checked ? ", manuals verified" : fmt::format(", {}", kManualsSkipped),
               report.errors.size(), report.warnings.size());
    exit_with(report.ok() ? kExitPass : kExitUsage);
  });

  CLI::App* list = vectors->add_subcommand("list", "List the vectors with id, level and source");
  list->add_option("DIR", options->dir, "Vector directory (default: the shipped vectors)")
      ->check(CLI::ExistingDirectory);
  list->callback([options] {
    const std::string dir = options->dir.empty() ? default_vectors_dir() : options->dir;
    const auto set = conformance::load_vector_tree(dir);
    for (const auto& error : set.errors)
      fmt::print(stderr, "{}\n", error.to_string());
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
