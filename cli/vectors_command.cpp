// drivecheck vectors lint|list [DIR]: the test vectors and drive profiles.
#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "cli/commands.hpp"

namespace drivecheck::cli {

void add_vectors_command(CLI::App& app) {
  // The callbacks own the option storage: CLI11 writes into it during parse().
  auto dir = std::make_shared<std::string>("vectors");
  CLI::App* vectors = app.add_subcommand("vectors", "Check or list the test vectors");
  vectors->require_subcommand(1);

  CLI::App* lint = vectors->add_subcommand(
      "lint", "Check vectors and drive profiles: schema, ids, sources, references");
  lint->add_option("DIR", *dir, "Vector directory")
      ->check(CLI::ExistingDirectory)
      ->capture_default_str();
  lint->callback([dir] { not_built_yet("vectors lint", "the vector loader is not built yet"); });

  CLI::App* list = vectors->add_subcommand("list", "List the vectors with id, level and source");
  list->add_option("DIR", *dir, "Vector directory")
      ->check(CLI::ExistingDirectory)
      ->capture_default_str();
  list->callback([dir] { not_built_yet("vectors list", "the vector loader is not built yet"); });
}

}  // namespace drivecheck::cli
