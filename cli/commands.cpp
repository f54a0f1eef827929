#include "cli/commands.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>

namespace drivecheck::cli {

void exit_with(int code) {
  if (code != kExitPass) throw CLI::RuntimeError(code);
}

void usage_error(std::string_view command, std::string_view message) {
  fmt::print(stderr, "drivecheck {}: {}\n", command, message);
  throw CLI::RuntimeError(kExitUsage);
}

void not_built_yet(std::string_view command, std::string_view what) {
  usage_error(command, what);
}

}  // namespace drivecheck::cli
