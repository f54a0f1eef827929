// `drivecheck fuzz` run as a command by the CLI tests (CAN and EtherCAT): its exit code and
// output, a fresh output folder per test, and the summary.json it wrote. DRIVECHECK_EXE is the
// binary (a compile definition of fuzz_live_cli_tests).
#pragma once

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

namespace drivecheck::fuzz_cli {

struct CommandRun {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

inline CommandRun drivecheck(const std::string& arguments, const std::filesystem::path& dir) {
  const auto output = dir / "output.txt";
  const std::string command =
      fmt::format("{} {} > {} 2>&1", DRIVECHECK_EXE, arguments, output.string());
  const int status = std::system(command.c_str());
  CommandRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(output);
  std::stringstream text;
  text << in.rdbuf();
  run.output = text.str();
  return run;
}

// An empty folder under the test's temporary directory, `prefix` + `name`.
inline std::filesystem::path fresh_dir(const std::string& prefix, const std::string& name) {
  const auto dir = std::filesystem::path(::testing::TempDir()) / (prefix + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

inline nlohmann::json summary(const std::filesystem::path& dir) {
  std::ifstream in(dir / "summary.json");
  return nlohmann::json::parse(in, nullptr, false);
}

}  // namespace drivecheck::fuzz_cli
