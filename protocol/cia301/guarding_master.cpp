#include "protocol/cia301/guarding_master.hpp"

#include <algorithm>
#include <cassert>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/error_control.hpp"

namespace drivecheck::cia301 {

std::string_view to_string(GuardingEventKind kind) {
  switch (kind) {
    case GuardingEventKind::state_changed:
      return "state changed";
    case GuardingEventKind::toggle_error:
      return "toggle error";
    case GuardingEventKind::no_response:
      return "no response";
    case GuardingEventKind::life_time_expired:
      return "life time expired";
    case GuardingEventKind::resumed:
      return "guarding resumed";
    case GuardingEventKind::unsolicited_response:
      return "unsolicited response";
    case GuardingEventKind::boot_up:
      return "boot-up";
    case GuardingEventKind::invalid_frame:
      return "invalid guarding response";
  }
  return "?";
}

Expected<void, std::string> GuardingMaster::guard(std::uint8_t node, const GuardingConfig& config,
                                                  can::TimePoint start) {
  if (!is_valid_node_id(node)) return Unexpected(std::string("node-ID must be 1..127"));
  if (config.guard_time <= can::Duration::zero()) {
    return Unexpected(std::string("guard time 0 switches node guarding off"));
  }
  if (config.life_time_factor == 0) {
    return Unexpected(std::string("life time factor 0 switches node guarding off"));
  }
  Node& entry = nodes_[node];
  entry = Node{};
  entry.config = config;
  entry.active = true;
  entry.next_request = start;
  entry.life_deadline = start + config.guard_time * config.life_time_factor;
  if (config.first_toggle_zero) entry.expected_toggle = false;
  return {};
}

void GuardingMaster::stop_guarding(std::uint8_t node) {
  assert(is_valid_node_id(node));
  nodes_[node] = Node{};
}

void GuardingMaster::reset_toggle(std::uint8_t node) {
  assert(is_valid_node_id(node));
  nodes_[node].expected_toggle = false;
}

GuardingMaster::Output GuardingMaster::on_time(can::TimePoint now) {
  Output out;
  for (std::size_t i = kMinNodeId; i <= kMaxNodeId; ++i) {
    Node& node = nodes_[i];
    if (!node.active) continue;
    const auto id = static_cast<std::uint8_t>(i);
    if (!node.lost && node.life_deadline <= now) {
      out.events.push_back(GuardingEvent{GuardingEventKind::life_time_expired,
                                         id,
                                         node.life_deadline,
                                         std::nullopt,
                                         node.state,
                                         std::nullopt,
                                         {}});
      node.lost = true;
    }
    if (node.next_request <= now) {
      if (node.awaiting) {
        out.events.push_back(GuardingEvent{GuardingEventKind::no_response,
                                           id,
                                           node.next_request,
                                           std::nullopt,
                                           node.state,
                                           std::nullopt,
                                           {}});
      }
      out.requests.push_back(encode(GuardRequest{id, 0}));
      node.awaiting = true;
      // Next request one guard time after this one; if the caller was late by more than a
      // guard time, skip the missed slots rather than sending a burst.
      do {
        node.next_request += node.config.guard_time;
      } while (node.next_request <= now);
    }
  }
  return out;
}

std::optional<GuardingEvent> GuardingMaster::on_frame(const can::Frame& frame,
                                                      can::TimePoint time) {
  const CobIdClass cls = classify_cob_id(frame);
  if (cls.function != CobFunction::nmt_error_control || frame.is_remote()) return std::nullopt;
  Node& node = nodes_[cls.node];
  if (!node.active) return std::nullopt;

  const auto message = decode_error_control(frame);
  if (!message) {
    return GuardingEvent{GuardingEventKind::invalid_frame,
                         cls.node,
                         time,
                         std::nullopt,
                         node.state,
                         std::nullopt,
                         message.error().reason};
  }
  if (std::holds_alternative<BootUp>(*message)) {
    node.expected_toggle = false;
    const auto previous = node.state;
    node.state = NmtState::boot_up;
    return GuardingEvent{
        GuardingEventKind::boot_up, cls.node, time, NmtState::boot_up, previous, std::nullopt, {}};
  }
  const auto& status = std::get<NodeStatus>(*message);
  if (!node.awaiting) {
    return GuardingEvent{GuardingEventKind::unsolicited_response,
                         cls.node,
                         time,
                         status.state,
                         node.state,
                         status.toggle,
                         {}};
  }
  if (node.expected_toggle && *node.expected_toggle != status.toggle) {
    // Handled as if not received: no refresh of the life time, still awaiting.
    return GuardingEvent{GuardingEventKind::toggle_error,
                         cls.node,
                         time,
                         status.state,
                         node.state,
                         status.toggle,
                         {}};
  }
  const auto previous = node.state;
  const bool was_lost = node.lost;
  node.awaiting = false;
  node.expected_toggle = !status.toggle;
  node.lost = false;
  node.state = status.state;
  node.life_deadline = time + node.config.guard_time * node.config.life_time_factor;
  if (was_lost) {
    return GuardingEvent{
        GuardingEventKind::resumed, cls.node, time, status.state, previous, status.toggle, {}};
  }
  if (previous == status.state) return std::nullopt;
  return GuardingEvent{
      GuardingEventKind::state_changed, cls.node, time, status.state, previous, status.toggle, {}};
}

can::TimePoint GuardingMaster::next_deadline() const {
  can::TimePoint next = can::kForever;
  for (const Node& node : nodes_) {
    if (!node.active) continue;
    next = std::min(next, node.next_request);
    if (!node.lost) next = std::min(next, node.life_deadline);
  }
  return next;
}

bool GuardingMaster::is_guarded(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  return nodes_[node].active;
}

bool GuardingMaster::is_lost(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  return nodes_[node].lost;
}

std::optional<NmtState> GuardingMaster::state(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  return nodes_[node].state;
}

GuardingMasterPort::GuardingMasterPort(can::Bus& bus, EventHandler on_event)
    : bus_(bus), on_event_(std::move(on_event)) {}

Expected<void, std::string> GuardingMasterPort::guard(std::uint8_t node,
                                                      const GuardingConfig& config) {
  auto result = master_.guard(node, config, bus_.now());
  rearm();
  return result;
}

void GuardingMasterPort::stop_guarding(std::uint8_t node) {
  master_.stop_guarding(node);
  rearm();
}

void GuardingMasterPort::handle(const can::TimedFrame& frame) {
  if (auto event = master_.on_frame(frame.frame, frame.timestamp); event && on_event_) {
    on_event_(*event);
  }
  rearm();
}

void GuardingMasterPort::rearm() {
  timer_.arm(master_.next_deadline());
}

void GuardingMasterPort::on_timer() {
  GuardingMaster::Output out = master_.on_time(bus_.now());
  for (const can::Frame& request : out.requests) {
    if (auto error = bus_.send(request)) last_send_error_ = error;
  }
  for (const GuardingEvent& event : out.events) {
    if (on_event_) on_event_(event);
  }
  rearm();
}

}  // namespace drivecheck::cia301
