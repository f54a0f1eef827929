#include "conformance/stall_log.hpp"

#include <algorithm>

namespace drivecheck::conformance {

StallLog::StallLog(can::Duration period, can::Duration slack, std::size_t capacity)
    : limit_(period + slack), capacity_(std::max<std::size_t>(capacity, 1)) {}

void StallLog::tick(can::TimePoint at) {
  std::lock_guard lock(mutex_);
  if (last_ && at - *last_ > limit_) {
    if (stalls_.size() == capacity_) stalls_.pop_front();
    stalls_.push_back(Stall{*last_, at});
  }
  if (!last_ || at > *last_) last_ = at;
}

std::optional<Stall> StallLog::longest_between(can::TimePoint from, can::TimePoint to) const {
  std::lock_guard lock(mutex_);
  std::optional<Stall> longest;
  for (const Stall& stall : stalls_) {
    if (stall.to < from || stall.from > to) continue;
    if (!longest || stall.length() > longest->length()) longest = stall;
  }
  return longest;
}

std::size_t StallLog::count() const {
  std::lock_guard lock(mutex_);
  return stalls_.size();
}

StallWatcher::StallWatcher(StallLog& log, std::function<can::TimePoint()> now, can::Duration period)
    : thread_([this, &log, now = std::move(now), period] {
        while (!stop_.load()) {
          log.tick(now());
          std::this_thread::sleep_for(period);
        }
      }) {}

StallWatcher::~StallWatcher() {
  stop_.store(true);
  thread_.join();
}

}  // namespace drivecheck::conformance
