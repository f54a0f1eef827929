#include "protocol/can/deadline_timer.hpp"

#include <utility>

namespace drivecheck::can {

DeadlineTimer::DeadlineTimer(Bus& bus, std::function<void()> on_expiry)
    : bus_(bus), on_expiry_(std::move(on_expiry)) {}

DeadlineTimer::~DeadlineTimer() {
  if (timer_ != kNoTimer) bus_.cancel_timer(timer_);
}

void DeadlineTimer::arm(TimePoint at) {
  if (at == armed_at_ && (timer_ != kNoTimer || at == kForever)) return;
  if (timer_ != kNoTimer) bus_.cancel_timer(timer_);
  timer_ = kNoTimer;
  armed_at_ = at;
  if (at == kForever) return;
  timer_ = bus_.start_timer(at, [this] {
    timer_ = kNoTimer;
    armed_at_ = kForever;
    on_expiry_();
  });
}

}  // namespace drivecheck::can
