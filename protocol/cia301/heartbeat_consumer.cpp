#include "protocol/cia301/heartbeat_consumer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cassert>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/error_control.hpp"

namespace drivecheck::cia301 {

Expected<ConsumerHeartbeatEntry, DecodeError> decode_consumer_heartbeat_entry(std::uint32_t value) {
  if ((value & 0xFF000000u) != 0) {
    return Unexpected(DecodeError{fmt::format(
        "consumer heartbeat time {:08X}h: invalid (bits 31..24 are reserved and 0)", value)});
  }
  const auto node = static_cast<std::uint8_t>(value >> 16);
  if (node > kMaxNodeId) {
    return Unexpected(DecodeError{
        fmt::format("consumer heartbeat time {:08X}h: invalid node-ID {} (1..127, 0 = not used)",
                    value, node)});
  }
  return ConsumerHeartbeatEntry{node, static_cast<std::uint16_t>(value)};
}

std::string_view to_string(HeartbeatEventKind kind) {
  switch (kind) {
    case HeartbeatEventKind::boot_up:
      return "boot-up";
    case HeartbeatEventKind::state_changed:
      return "state changed";
    case HeartbeatEventKind::timeout:
      return "heartbeat timeout";
    case HeartbeatEventKind::resumed:
      return "heartbeat resumed";
    case HeartbeatEventKind::invalid_frame:
      return "invalid heartbeat";
  }
  return "?";
}

void HeartbeatConsumer::set_monitored(std::uint8_t node, bool monitored) {
  const std::uint64_t bit = std::uint64_t{1} << (node % 64);
  if (monitored) {
    monitored_[node / 64] |= bit;
  } else {
    monitored_[node / 64] &= ~bit;
  }
}

template <class F>
void HeartbeatConsumer::for_each_monitored(F&& f) const {
  for (std::size_t word = 0; word < monitored_.size(); ++word) {
    for (std::uint64_t bits = monitored_[word]; bits != 0; bits &= bits - 1) {
      f(word * 64 + static_cast<std::size_t>(std::countr_zero(bits)));
    }
  }
}

void HeartbeatConsumer::monitor(std::uint8_t node, can::Duration consumer_time) {
  assert(is_valid_node_id(node));
  assert(consumer_time > can::Duration::zero());
  nodes_[node] = Node{};
  nodes_[node].consumer_time = consumer_time;
  set_monitored(node, true);
}

void HeartbeatConsumer::monitor(const ConsumerHeartbeatEntry& entry) {
  if (!entry.is_used()) return;
  monitor(entry.node, std::chrono::milliseconds{entry.time_ms});
}

void HeartbeatConsumer::stop_monitoring(std::uint8_t node) {
  assert(is_valid_node_id(node));
  nodes_[node] = Node{};
  set_monitored(node, false);
}

std::optional<HeartbeatEvent> HeartbeatConsumer::on_frame(const can::Frame& frame,
                                                          can::TimePoint time) {
  const CobIdClass cls = classify_cob_id(frame);
  if (cls.function != CobFunction::nmt_error_control || frame.is_remote()) return std::nullopt;
  Node& node = nodes_[cls.node];
  if (node.consumer_time == can::Duration::zero()) return std::nullopt;

  const auto heartbeat = decode_heartbeat(frame);
  if (!heartbeat) {
    return HeartbeatEvent{
        HeartbeatEventKind::invalid_frame, cls.node, time, std::nullopt, node.state,
        heartbeat.error().reason};
  }
  const std::optional<NmtState> previous = node.state;
  const bool was_timed_out = node.timed_out;
  node.state = heartbeat->state;
  node.last = time;
  node.deadline = time + node.consumer_time;
  node.timed_out = false;

  HeartbeatEvent event{
      HeartbeatEventKind::state_changed, cls.node, time, heartbeat->state, previous, {}};
  if (was_timed_out) {
    event.kind = HeartbeatEventKind::resumed;
  } else if (heartbeat->state == NmtState::boot_up) {
    event.kind = HeartbeatEventKind::boot_up;
  } else if (previous == heartbeat->state) {
    return std::nullopt;
  }
  return event;
}

std::vector<HeartbeatEvent> HeartbeatConsumer::on_time(can::TimePoint now) {
  std::vector<HeartbeatEvent> events;
  for_each_monitored([&](std::size_t i) {
    Node& node = nodes_[i];
    if (node.deadline > now) return;
    events.push_back(HeartbeatEvent{HeartbeatEventKind::timeout,
                                    static_cast<std::uint8_t>(i),
                                    node.deadline,
                                    std::nullopt,
                                    node.state,
                                    {}});
    node.timed_out = true;
    node.deadline = can::kForever;
  });
  return events;
}

can::TimePoint HeartbeatConsumer::next_deadline() const {
  can::TimePoint next = can::kForever;
  for_each_monitored([&](std::size_t i) { next = std::min(next, nodes_[i].deadline); });
  return next;
}

bool HeartbeatConsumer::is_monitored(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  return nodes_[node].consumer_time != can::Duration::zero();
}

bool HeartbeatConsumer::is_timed_out(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  return nodes_[node].timed_out;
}

std::optional<NmtState> HeartbeatConsumer::state(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  return nodes_[node].state;
}

std::optional<can::TimePoint> HeartbeatConsumer::last_heartbeat(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  return nodes_[node].last;
}

HeartbeatConsumerPort::HeartbeatConsumerPort(can::Bus& bus, EventHandler on_event)
    : bus_(bus), on_event_(std::move(on_event)) {}

void HeartbeatConsumerPort::monitor(std::uint8_t node, can::Duration consumer_time) {
  consumer_.monitor(node, consumer_time);
  rearm();
}

void HeartbeatConsumerPort::stop_monitoring(std::uint8_t node) {
  consumer_.stop_monitoring(node);
  rearm();
}

void HeartbeatConsumerPort::handle(const can::TimedFrame& frame) {
  if (auto event = consumer_.on_frame(frame.frame, frame.timestamp); event && on_event_) {
    on_event_(*event);
  }
  rearm();
}

void HeartbeatConsumerPort::rearm() {
  timer_.arm(consumer_.next_deadline());
}

void HeartbeatConsumerPort::on_timer() {
  for (const HeartbeatEvent& event : consumer_.on_time(bus_.now())) {
    if (on_event_) on_event_(event);
  }
  rearm();
}

}  // namespace drivecheck::cia301
