// SIGINT and SIGTERM for the lifetime of a command's run: `handler` is installed on
// construction and whatever was there before is put back on destruction. Both signals are
// unblocked meanwhile (a parent may have started us with them blocked: they would stay pending
// and never stop the run); one already pending is handled at once. The handler itself
// (each command's own) may only touch atomics and call async-signal-safe stops (Bus::stop,
// Engine::interrupt).
#pragma once

#include <pthread.h>

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
    sigset_t signals;
    sigemptyset(&signals);
    for (const int signal : kSignals)
      sigaddset(&signals, signal);
    pthread_sigmask(SIG_UNBLOCK, &signals, &previous_mask_);
  }
  ~SignalScope() {
    pthread_sigmask(SIG_SETMASK, &previous_mask_, nullptr);
    for (int i = 0; i < 2; ++i)
      sigaction(kSignals[i], &previous_[i], nullptr);
  }
  SignalScope(const SignalScope&) = delete;
  SignalScope& operator=(const SignalScope&) = delete;

 private:
  static constexpr int kSignals[2] = {SIGINT, SIGTERM};
  struct sigaction previous_[2]{};
  sigset_t previous_mask_{};
};

}  // namespace drivecheck::cli
