// SIGINT and SIGTERM for the lifetime of a command's run: `handler` is installed on
// construction and whatever was there before is put back on destruction. The handler itself
// (each command's own) may only touch atomics and call async-signal-safe stops (Bus::stop,
// Engine::interrupt).
#pragma once

#include <csignal>

namespace drivecheck::cli {

class SignalScope {
 public:
  explicit SignalScope(void (*handler)(int)) {
    struct sigaction action {};
    action.sa_handler = handler;
    sigemptyset(&action.sa_mask);
    for (int i = 0; i < 2; ++i)
      sigaction(kSignals[i], &action, &previous_[i]);
  }
  ~SignalScope() {
    for (int i = 0; i < 2; ++i)
      sigaction(kSignals[i], &previous_[i], nullptr);
  }
  SignalScope(const SignalScope&) = delete;
  SignalScope& operator=(const SignalScope&) = delete;

 private:
  static constexpr int kSignals[2] = {SIGINT, SIGTERM};
  struct sigaction previous_[2]{};
};

}  // namespace drivecheck::cli
