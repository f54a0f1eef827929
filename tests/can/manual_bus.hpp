// A one-port Bus for tests, driven by hand: time advances only through run_until/receive,
// frames "from the bus" are injected at chosen times, sent frames are kept with their send
// time, and sends can be made to fail. Not a CAN model (no wire time, no arbitration): use
// SimBus for that; this is for testing decorators and schedulers exactly.
#pragma once

#include <algorithm>
#include <cstdint>
#include <deque>
#include <map>
#include <utility>
#include <variant>
#include <vector>

#include "protocol/can/bus.hpp"

namespace drivecheck::test_support {

using can::Bus;
using can::BusError;
using can::Duration;
using can::Filter;
using can::Frame;
using can::kForever;
using can::kNoTimer;
using can::TimedFrame;
using can::TimePoint;
using can::TimerId;

class ManualBus final : public Bus {
 public:
  struct Sent {
    Frame frame;
    TimePoint at;
  };

  explicit ManualBus(Duration unix_offset = Duration{0}, TimePoint start = TimePoint{})
      : unix_offset_(unix_offset), now_(start) {}

  TimePoint now() const override { return now_; }
  Duration unix_offset() const override { return unix_offset_; }

  std::error_code send(const Frame& frame) override {
    if (failures_left_ > 0) {
      --failures_left_;
      return failure_;
    }
    sent_.push_back({frame, now_});
    if (loopback_) {
      const TimePoint wire = now_ + echo_delay_;
      schedule(wire, TimedFrame{frame, wire, true});
    }
    now_ += send_lag_;
    return {};
  }

  std::optional<TimedFrame> receive(TimePoint deadline) override {
    while (rx_.empty()) {
      if (!run_one(deadline)) {
        if (deadline != kForever && now_ < deadline && !stopped_) now_ = deadline;
        stopped_ = false;
        return std::nullopt;
      }
    }
    TimedFrame frame = rx_.front();
    rx_.pop_front();
    return frame;
  }

  void set_frame_handler(FrameHandler handler) override { handler_ = std::move(handler); }
  void set_filters(std::span<const Filter> filters) override {
    filters_.assign(filters.begin(), filters.end());
  }
  void set_loopback(bool enabled) override { loopback_ = enabled; }

  TimerId start_timer(TimePoint at, TimerCallback callback) override {
    const TimerId id = ++last_timer_;
    schedule(std::max(at, now_), Timer{id, std::move(callback)});
    return id;
  }
  void cancel_timer(TimerId id) override {
    for (auto it = events_.begin(); it != events_.end(); ++it) {
      if (const auto* timer = std::get_if<Timer>(&it->second); timer && timer->id == id) {
        events_.erase(it);
        return;
      }
    }
  }

  // With kForever: runs until no event is left (or stop()).
  void run_until(TimePoint deadline) override {
    while (run_one(deadline)) {
    }
    if (deadline != kForever && now_ < deadline && !stopped_) now_ = deadline;
    stopped_ = false;
  }
  void stop() override { stopped_ = true; }

  // A frame arriving from the bus at `at`.
  void inject(const Frame& frame, TimePoint at) { schedule(at, TimedFrame{frame, at, false}); }
  // A frame that went on the wire at `stamp` but reaches the port's queue only at `deliver`
  // (a busy host: the kernel timestamp is on time, the read is late).
  void inject_late(const Frame& frame, TimePoint stamp, TimePoint deliver) {
    schedule(deliver, TimedFrame{frame, stamp, false});
  }
  // Each sent frame goes on the wire (its echo's timestamp) `delay` after send() was called:
  // a transmit queue that holds it back.
  void set_echo_delay(Duration delay) { echo_delay_ = delay; }
  // Each send() returns `lag` later than it was called: the sender is descheduled.
  void set_send_lag(Duration lag) { send_lag_ = lag; }
  // The next `count` sends fail with `error`.
  void fail_sends(int count, BusError error) {
    failures_left_ = count;
    failure_ = make_error_code(error);
  }
  const std::vector<Sent>& sent() const { return sent_; }
  std::size_t pending_events() const { return events_.size(); }

 private:
  struct Timer {
    TimerId id;
    TimerCallback callback;
  };
  using Event = std::variant<Timer, TimedFrame>;

  void schedule(TimePoint at, Event event) {
    events_.emplace(std::pair(at, ++sequence_), std::move(event));
  }

  // Runs the earliest event due by `deadline`; false when there is none or stop() was called.
  bool run_one(TimePoint deadline) {
    if (stopped_ || events_.empty() || events_.begin()->first.first > deadline) return false;
    const auto first = events_.begin();
    now_ = std::max(now_, first->first.first);
    Event event = std::move(first->second);
    events_.erase(first);
    if (auto* timer = std::get_if<Timer>(&event)) {
      timer->callback();
      return true;
    }
    const TimedFrame& frame = std::get<TimedFrame>(event);
    if (!filters_.empty() && std::none_of(filters_.begin(), filters_.end(), [&](const Filter& f) {
          return f.matches(frame.frame);
        })) {
      return true;
    }
    if (handler_) {
      handler_(frame);
    } else {
      rx_.push_back(frame);
    }
    return true;
  }

  Duration unix_offset_;
  TimePoint now_;
  std::map<std::pair<TimePoint, std::uint64_t>, Event> events_;
  std::uint64_t sequence_ = 0;
  std::deque<TimedFrame> rx_;
  std::vector<Sent> sent_;
  std::vector<Filter> filters_;
  FrameHandler handler_;
  TimerId last_timer_ = kNoTimer;
  int failures_left_ = 0;
  std::error_code failure_;
  bool loopback_ = false;
  bool stopped_ = false;
  Duration echo_delay_{0};
  Duration send_lag_{0};
};

}  // namespace drivecheck::test_support
