#include "protocol/can/replay.hpp"

#include <algorithm>
#include <cstdint>

namespace drivecheck::can {

std::string ReplayError::to_string() const {
  return fmt::format("replay stopped at record {} ({}): {}", record_index + 1, frame,
                     error.message());
}

Replayer::Replayer(Bus& bus, std::vector<LogRecord> records, ReplayOptions options)
    : bus_(bus), records_(std::move(records)), options_(std::move(options)) {
  // A zero or negative retry interval would retry forever at one instant: time would never
  // reach give_up_after.
  options_.retry_interval =
      std::max<Duration>(options_.retry_interval, std::chrono::microseconds(1));
}

Replayer::~Replayer() {
  cancel();
}

void Replayer::start(std::function<void()> on_done) {
  if (started_) return;
  started_ = true;
  on_done_ = std::move(on_done);
  start_ = options_.start.value_or(bus_.now());
  step();
}

void Replayer::cancel() {
  if (timer_ != kNoTimer) bus_.cancel_timer(timer_);
  timer_ = kNoTimer;
  on_done_ = nullptr;
  done_ = true;
}

bool Replayer::selected(const LogRecord& record) const {
  if (record.frame.is_error()) return false;
  if (options_.interface && record.interface != *options_.interface) return false;
  if (options_.direction && record.direction != options_.direction) return false;
  if (options_.filters.empty()) return true;
  return std::any_of(options_.filters.begin(), options_.filters.end(),
                     [&](const Filter& filter) { return filter.matches(record.frame); });
}

TimePoint Replayer::due_time(std::size_t index) const {
  // start + (timestamp - first timestamp), saturating instead of overflowing.
  std::int64_t offset = 0;
  if (__builtin_sub_overflow(records_[index].timestamp.count(), records_.front().timestamp.count(),
                             &offset)) {
    offset = records_[index].timestamp.count() < 0 ? 0 : INT64_MAX;
  }
  if (offset <= 0) return start_;
  std::int64_t due = 0;
  if (__builtin_add_overflow(start_.time_since_epoch().count(), offset, &due)) {
    return TimePoint::max();
  }
  return TimePoint(Duration(due));
}

void Replayer::step() {
  timer_ = kNoTimer;
  while (next_ < records_.size()) {
    const LogRecord& record = records_[next_];
    if (!selected(record)) {
      ++stats_.skipped;
      ++next_;
      continue;
    }
    const TimePoint now = bus_.now();
    if (options_.timing == ReplayTiming::original) {
      const TimePoint due = due_time(next_);
      if (due > now) {
        timer_ = bus_.start_timer(due, [this] { step(); });
        return;
      }
    }
    const std::error_code error = bus_.send(record.frame);
    if (!error) {
      ++stats_.sent;
      ++next_;
      blocked_since_.reset();
      continue;
    }
    if (error == BusError::queue_full) {
      if (!blocked_since_) blocked_since_ = now;
      if (now - *blocked_since_ < options_.give_up_after) {
        timer_ = bus_.start_timer(now + options_.retry_interval, [this] { step(); });
        return;
      }
    }
    error_ = ReplayError{next_, record.frame, error};
    break;
  }
  finish();
}

void Replayer::finish() {
  done_ = true;
  if (on_done_) {
    auto on_done = std::move(on_done_);
    on_done_ = nullptr;
    on_done();
  }
}

Expected<ReplayStats, ReplayError> replay(Bus& bus, std::vector<LogRecord> records,
                                          ReplayOptions options) {
  Replayer replayer(bus, std::move(records), std::move(options));
  bool in_loop = false;
  // stop() only from inside run_until: a replay that ends within start() must not leave a
  // pending stop that would cut the caller's next run_until short.
  replayer.start([&] {
    if (in_loop) bus.stop();
  });
  in_loop = true;
  while (!replayer.done())
    bus.run_until(kForever);
  if (replayer.error()) return Unexpected(*replayer.error());
  return replayer.stats();
}

}  // namespace drivecheck::can
