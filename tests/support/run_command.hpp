// Runs a program for a test and captures its exit code, stdout and stderr.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <string>
#include <string_view>
#include <vector>

#include "tests/support/temp_dir.hpp"

namespace drivecheck::test_support {

struct CommandResult {
  int exit_code = -1;  // the program's exit status; 128 + n when killed by signal n
  std::string out;
  std::string err;
};

// 'text' for /bin/sh, with embedded single quotes escaped.
inline std::string shell_quote(std::string_view text) {
  std::string quoted = "'";
  for (const char c : text) {
    if (c == '\'') {
      quoted += "'\\''";
    } else {
      quoted += c;
    }
  }
  return quoted + "'";
}

// Runs argv[0] with the arguments (no shell interpretation of them), stdin from `input`.
inline CommandResult run_command(const std::vector<std::string>& argv,
                                 std::string_view input = {}) {
  TempDir dir;
  const auto in = dir.write("stdin", input);
  std::string command;
  for (const auto& arg : argv)
    command += shell_quote(arg) + " ";
  command += "<" + shell_quote(in.string()) + " >" + shell_quote((dir / "stdout").string()) +
             " 2>" + shell_quote((dir / "stderr").string());
  const int status = std::system(command.c_str());
  CommandResult result;
  if (status != -1 && WIFEXITED(status)) {
    result.exit_code = WEXITSTATUS(status);
  } else if (status != -1 && WIFSIGNALED(status)) {
    result.exit_code = 128 + WTERMSIG(status);
  }
  result.out = read_file(dir / "stdout");
  result.err = read_file(dir / "stderr");
  return result;
}

}  // namespace drivecheck::test_support
