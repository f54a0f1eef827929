// One timer on a Bus, kept at a moving deadline.
//
// Every adapter that runs a pure protocol state machine on a Bus does the same thing: after
// each frame or expiry it asks the machine for next_deadline() and keeps exactly one timer at
// that time, calling the machine's on_time() when it fires. DeadlineTimer is that, once:
//
//   DeadlineTimer timer{bus, [this] { on_time(); }};
//   ...
//   timer.arm(machine.next_deadline());   // kForever disarms; the same time again is free
//
// The callback runs with the timer already disarmed, so it may arm it again.
#pragma once

#include <functional>

#include "protocol/can/bus.hpp"

namespace drivecheck::can {

class DeadlineTimer {
 public:
  DeadlineTimer(Bus& bus, std::function<void()> on_expiry);
  ~DeadlineTimer();
  DeadlineTimer(const DeadlineTimer&) = delete;
  DeadlineTimer& operator=(const DeadlineTimer&) = delete;

  // Keeps the one timer at `at` (kForever: none). Re-arming to the pending time does nothing.
  void arm(TimePoint at);
  void disarm() { arm(kForever); }
  // The pending expiry, or kForever.
  TimePoint armed_at() const { return armed_at_; }

 private:
  Bus& bus_;
  std::function<void()> on_expiry_;
  TimerId timer_ = kNoTimer;
  TimePoint armed_at_ = kForever;
};

}  // namespace drivecheck::can
