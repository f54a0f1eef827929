#include "protocol/ethercat/sim_segment.hpp"

#include <algorithm>

#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"

namespace drivecheck::ethercat {
namespace {

constexpr Duration kByteTime = std::chrono::nanoseconds(80);  // 8 bits at 100 Mbit/s
constexpr std::size_t kPreamble = 8;                          // preamble + SFD
constexpr std::size_t kFcs = 4;
constexpr std::size_t kGap = 12;

struct FlagGuard {
  explicit FlagGuard(bool& flag) : flag_(flag) { flag_ = true; }
  ~FlagGuard() { flag_ = false; }
  FlagGuard(const FlagGuard&) = delete;
  FlagGuard& operator=(const FlagGuard&) = delete;
  bool& flag_;
};

std::size_t padded(std::size_t size) {
  return std::max(size, kMinFrameSize);
}

}  // namespace

void EscDevice::on_frame(std::span<std::uint8_t> frame, TimePoint arrival,
                         std::optional<TimePoint> return_arrival) {
  esc_.process_frame(frame, arrival, return_arrival);
}

SimSegment::SimSegment(SimSegmentConfig config) : config_(config), random_(config.seed) {}

SimSegment::~SimSegment() = default;

Duration SimSegment::wire_time(std::size_t size) {
  return kByteTime * static_cast<std::int64_t>(kPreamble + padded(size) + kFcs + kGap);
}

void SimSegment::attach(SegmentDevice& device, DeviceTiming timing) {
  devices_.push_back({&device, timing});
}

void SimSegment::detach_all() {
  devices_.clear();
  ++generation_;
}

void SimSegment::schedule(TimePoint at, EventKind kind, std::uint32_t device, TimerId timer,
                          std::shared_ptr<InFlight> frame) {
  events_.push(Event{at, seq_++, kind, device, timer, std::move(frame)});
}

bool SimSegment::fault_applies(Fault& fault, std::span<const std::uint8_t> bytes) {
  if (!fault.active || fault.hits >= fault.rule.max_count) return false;
  if (now_ < fault.rule.not_before || now_ > fault.rule.not_after) return false;
  if (fault.rule.match && !fault.rule.match(bytes)) return false;
  if (fault.rule.probability < 1.0) {
    std::uniform_real_distribution<double> chance(0.0, 1.0);
    if (chance(random_) >= fault.rule.probability) return false;
  }
  ++fault.hits;
  return true;
}

std::error_code SimSegment::send(std::span<const std::uint8_t> frame) {
  if (const std::error_code error = check_frame_size(frame.size())) return error;
  if (link_down_ || devices_.empty()) return LinkError::link_down;
  auto flight = std::make_shared<InFlight>();
  flight->bytes.assign(frame.begin(), frame.end());
  flight->bytes.resize(padded(frame.size()), 0);
  flight->generation = generation_;
  for (Fault& fault : faults_) {
    if (!fault_applies(fault, flight->bytes)) continue;
    switch (fault.kind) {
      case FaultKind::drop:
        flight->drop_before = std::min(flight->drop_before, fault.before_device);
        break;
      case FaultKind::corrupt:
        flight->corruption = fault.corruption;
        break;
      case FaultKind::delay:
        flight->extra_delay += fault.by;
        break;
    }
  }
  const TimePoint start = std::max(now_, tx_free_);
  const Duration on_wire = wire_time(flight->bytes.size());
  tx_free_ = start + on_wire;
  ++frames_sent_;
  if (!monitors_.empty()) {
    const TimedFrame sent{flight->bytes, start + on_wire - kByteTime * static_cast<int>(kGap)};
    for (const auto& [id, monitor] : monitors_)
      monitor(sent, FrameDirection::sent);
  }
  // Outbound: arrival at each device's port 0.
  const std::size_t n = devices_.size();
  flight->arrivals.resize(n);
  flight->return_arrivals.resize(n);
  TimePoint t = start;
  for (std::size_t k = 0; k < n; ++k) {
    t += devices_[k].timing.cable_delay;
    flight->arrivals[k] = t;
    t += devices_[k].timing.processing_delay;
  }
  // Back: from the last device through each forwarding path to the master.
  for (std::size_t k = n; k-- > 0;) {
    if (k + 1 < n) {
      t += devices_[k + 1].timing.cable_delay;
      flight->return_arrivals[k] = t;
      t += devices_[k].timing.return_delay;
    } else {
      flight->return_arrivals[k] = TimePoint::min();
    }
  }
  t += devices_[0].timing.cable_delay;
  // t: the first bit back at the master; the frame is complete (n + preamble + FCS) later.
  TimePoint done = t +
                   kByteTime * static_cast<std::int64_t>(kPreamble + flight->bytes.size() + kFcs) +
                   flight->extra_delay;
  done = std::max(done,
                  rx_last_ + wire_time(flight->bytes.size()) - kByteTime * static_cast<int>(kGap));
  rx_last_ = done;
  const std::size_t processed = std::min(flight->drop_before, n);
  for (std::size_t k = 0; k < processed; ++k) {
    schedule(flight->arrivals[k], EventKind::device, static_cast<std::uint32_t>(k), kNoTimer,
             flight);
  }
  if (flight->drop_before == std::numeric_limits<std::size_t>::max()) {
    schedule(done, EventKind::deliver, 0, kNoTimer, flight);
  } else {
    ++frames_lost_;
  }
  return {};
}

void SimSegment::deliver(InFlight& frame, TimePoint at) {
  if (frame.generation != generation_ || link_down_) {
    ++frames_lost_;
    return;
  }
  TimedFrame received{std::move(frame.bytes), at};
  if (frame.corruption) {
    if (frame.corruption->flips.empty()) {
      if (received.bytes.size() > kEthernetHeaderSize) {
        std::uniform_int_distribution<std::size_t> pick(kEthernetHeaderSize * 8,
                                                        received.bytes.size() * 8 - 1);
        const std::size_t bit = pick(random_);
        received.bytes[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
      }
    } else {
      for (const auto& [offset, mask] : frame.corruption->flips) {
        if (offset < received.bytes.size()) received.bytes[offset] ^= mask;
      }
    }
  }
  ++frames_received_;
  for (const auto& [id, monitor] : monitors_)
    monitor(received, FrameDirection::received);
  if (handler_) {
    handler_(received);
  } else if (inbox_.size() < config_.rx_queue_limit) {
    inbox_.push(std::move(received));
  } else {
    ++frames_lost_;
  }
}

void SimSegment::run_event(Event& event) {
  switch (event.kind) {
    case EventKind::timer: {
      const auto it = timers_.find(event.timer);
      if (it == timers_.end()) return;
      TimerCallback callback = std::move(it->second);
      timers_.erase(it);
      callback();
      break;
    }
    case EventKind::device: {
      InFlight& frame = *event.frame;
      if (frame.generation != generation_ || link_down_ || event.device >= devices_.size()) {
        return;
      }
      const TimePoint back = frame.return_arrivals[event.device];
      devices_[event.device].device->on_frame(
          frame.bytes, event.at, back == TimePoint::min() ? std::nullopt : std::optional(back));
      break;
    }
    case EventKind::deliver:
      deliver(*event.frame, event.at);
      break;
  }
}

std::optional<TimedFrame> SimSegment::receive(TimePoint deadline) {
  auto pop = [this]() -> std::optional<TimedFrame> {
    if (inbox_.empty()) return std::nullopt;
    TimedFrame frame = std::move(inbox_.front());
    inbox_.pop();
    return frame;
  };
  if (running_) return pop();
  const FlagGuard running(running_);
  for (;;) {
    if (auto frame = pop()) return frame;
    if (take_stop()) return std::nullopt;
    if (events_.empty() || events_.top().at > deadline) {
      if (deadline != kForever) now_ = std::max(now_, deadline);
      return std::nullopt;
    }
    Event event = events_.top();
    events_.pop();
    now_ = std::max(now_, event.at);
    run_event(event);
  }
}

void SimSegment::run_until(TimePoint deadline) {
  if (running_) return;
  const FlagGuard running(running_);
  while (!events_.empty() && events_.top().at <= deadline) {
    if (take_stop()) return;
    Event event = events_.top();
    events_.pop();
    now_ = std::max(now_, event.at);
    run_event(event);
  }
  if (deadline != kForever) now_ = std::max(now_, deadline);
}

void SimSegment::stop() {
  stop_.store(true, std::memory_order_relaxed);
}

void SimSegment::set_frame_handler(FrameHandler handler) {
  handler_ = std::move(handler);
}

TimerId SimSegment::start_timer(TimePoint at, TimerCallback callback) {
  const TimerId id = next_timer_++;
  timers_.emplace(id, std::move(callback));
  schedule(std::max(at, now_), EventKind::timer, 0, id, nullptr);
  return id;
}

void SimSegment::cancel_timer(TimerId id) {
  timers_.erase(id);
}

FaultId SimSegment::drop(FrameFaultRule rule, std::size_t before_device) {
  faults_.push_back({FaultKind::drop, std::move(rule), before_device, {}, {}, 0, true});
  return faults_.size();
}

FaultId SimSegment::corrupt(FrameFaultRule rule, FrameCorruption corruption) {
  faults_.push_back({FaultKind::corrupt, std::move(rule), 0, std::move(corruption), {}, 0, true});
  return faults_.size();
}

FaultId SimSegment::delay(FrameFaultRule rule, Duration by) {
  faults_.push_back({FaultKind::delay, std::move(rule), 0, {}, by, 0, true});
  return faults_.size();
}

void SimSegment::remove_fault(FaultId id) {
  if (id >= 1 && id <= faults_.size()) faults_[id - 1].active = false;
}

std::uint64_t SimSegment::fault_hits(FaultId id) const {
  return id >= 1 && id <= faults_.size() ? faults_[id - 1].hits : 0;
}

void SimSegment::set_link_down(bool down) {
  if (down && !link_down_) ++generation_;
  link_down_ = down;
}

MonitorId SimSegment::add_monitor(std::function<void(const TimedFrame&, FrameDirection)> monitor) {
  const MonitorId id = next_monitor_++;
  monitors_.emplace(id, std::move(monitor));
  return id;
}

void SimSegment::remove_monitor(MonitorId id) {
  monitors_.erase(id);
}

}  // namespace drivecheck::ethercat
