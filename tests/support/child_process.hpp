// A program run beside a test (a drive on a veth end, a run against it): started, waited for
// with a bound, stopped. For a program that runs to its end with its output captured, see
// run_command.hpp.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace drivecheck::test_support {

// Starts argv[0] (a path, no PATH search) with stdout and stderr into `log`; its pid.
inline pid_t spawn(const std::vector<std::string>& args, const std::filesystem::path& log) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd >= 0) {
    ::dup2(fd, 1);
    ::dup2(fd, 2);
  }
  std::vector<char*> argv;
  for (const auto& arg : args)
    argv.push_back(const_cast<char*>(arg.c_str()));
  argv.push_back(nullptr);
  ::execv(argv[0], argv.data());
  ::_exit(127);
}

// Sends `stop_signal` first (0: none), then its exit status within `limit`; nullopt: it was
// killed (too slow, or ended by a signal).
inline std::optional<int> wait_for(pid_t pid, std::chrono::steady_clock::duration limit,
                                   int stop_signal = 0) {
  if (stop_signal != 0) ::kill(pid, stop_signal);
  const auto give_up = std::chrono::steady_clock::now() + limit;
  int status = 0;
  while (std::chrono::steady_clock::now() < give_up) {
    if (::waitpid(pid, &status, WNOHANG) == pid)
      return WIFEXITED(status) ? std::optional<int>(WEXITSTATUS(status)) : std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, &status, 0);
  return std::nullopt;
}

}  // namespace drivecheck::test_support
