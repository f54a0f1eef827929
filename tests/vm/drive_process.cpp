#include "tests/vm/drive_process.hpp"

#include <fmt/format.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string_view>

namespace drivecheck::vm {

std::unique_ptr<DriveProcess> DriveProcess::start(const std::string& binary,
                                                  const std::vector<std::string>& args,
                                                  std::string& error) {
  std::vector<std::string> argv_text = {binary};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_text)
    argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) {
    error = fmt::format("fork: {}", std::strerror(errno));
    return nullptr;
  }
  if (pid == 0) {
    ::execvp(binary.c_str(), argv.data());
    fmt::print(stderr, "exec {}: {}\n", binary, std::strerror(errno));
    std::_Exit(127);
  }
  return std::unique_ptr<DriveProcess>(new DriveProcess(pid));
}

DriveProcess::~DriveProcess() {
  if (!reaped_) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
}

int DriveProcess::stop(int signal_number, std::chrono::milliseconds timeout) {
  if (reaped_) return -1;
  ::kill(pid_, signal_number);
  const auto give_up = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      reaped_ = true;
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    if (std::chrono::steady_clock::now() >= give_up) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
      reaped_ = true;
      return -1;
    }
    // Test-side polling for the child's exit; protocol code never waits like this.
    ::poll(nullptr, 0, 5);
  }
}

std::string take_drivecheck_path(int& argc, char** argv) {
  constexpr std::string_view kFlag = "--drivecheck=";
  std::string path = "drivecheck";
  int out = 1;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg.substr(0, kFlag.size()) == kFlag) {
      path = std::string(arg.substr(kFlag.size()));
    } else {
      argv[out++] = argv[i];
    }
  }
  argc = out;
  argv[argc] = nullptr;
  return path;
}

}  // namespace drivecheck::vm
