#include "cli/commands.hpp"

#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <ctime>

namespace drivecheck::cli {

void exit_with(int code) {
  if (code != kExitPass) throw CLI::RuntimeError(code);
}

void usage_error(std::string_view command, std::string_view message) {
  fmt::print(stderr, "drivecheck {}: {}\n", command, message);
  throw CLI::RuntimeError(kExitUsage);
}

void warn_deprecated_option(std::string_view command, std::string_view old_name,
                            std::string_view new_name) {
  fmt::print(stderr, "drivecheck {}: warning: {} is deprecated, use {}\n", command, old_name,
             new_name);
}

std::string utc_now() {
  const auto now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z", tm.tm_year + 1900, tm.tm_mon + 1,
                     tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec);
}

}  // namespace drivecheck::cli
