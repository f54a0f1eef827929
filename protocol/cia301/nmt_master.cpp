#include "protocol/cia301/nmt_master.hpp"

#include <cassert>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/error_control.hpp"

namespace drivecheck::cia301 {

can::Frame NmtMaster::command(NmtCommand command, std::uint8_t node) {
  assert(node <= kMaxNodeId);
  const NmtState after = state_after(command);
  if (node == 0) {
    for (std::size_t i = kMinNodeId; i <= kMaxNodeId; ++i)
      nodes_[i].commanded = after;
  } else {
    nodes_[node].commanded = after;
  }
  return encode(NmtNodeControl{command, node});
}

std::optional<NmtEvent> NmtMaster::on_frame(const can::Frame& frame, can::TimePoint time) {
  const CobIdClass cls = classify_cob_id(frame);
  if (cls.function != CobFunction::nmt_error_control || frame.is_remote()) return std::nullopt;
  NodeInfo& status = nodes_[cls.node];
  const auto message = decode_error_control(frame);
  if (!message) {
    return NmtEvent{NmtEventKind::invalid_frame, cls.node, time, std::nullopt, status.reported,
                    message.error().reason};
  }
  const std::optional<NmtState> previous = status.reported;
  status.last_seen = time;
  if (std::holds_alternative<BootUp>(*message)) {
    status.reported = NmtState::boot_up;
    ++status.boot_ups;
    return NmtEvent{NmtEventKind::boot_up, cls.node, time, NmtState::boot_up, previous, {}};
  }
  const NmtState state = std::get<cia301::NodeStatus>(*message).state;
  status.reported = state;
  if (previous == state) return std::nullopt;
  return NmtEvent{NmtEventKind::state_changed, cls.node, time, state, previous, {}};
}

const NmtMaster::NodeInfo& NmtMaster::node(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  return nodes_[node];
}

bool NmtMaster::in_commanded_state(std::uint8_t node) const {
  const NodeInfo& status = this->node(node);
  return status.reported && status.commanded && *status.reported == *status.commanded;
}

void NmtMaster::forget(std::uint8_t node) {
  assert(is_valid_node_id(node));
  nodes_[node] = NodeInfo{};
}

NmtMasterPort::NmtMasterPort(can::Bus& bus, EventHandler on_event)
    : bus_(bus), on_event_(std::move(on_event)) {}

std::error_code NmtMasterPort::send(NmtCommand command, std::uint8_t node) {
  if (node > kMaxNodeId) return can::make_error_code(can::BusError::invalid_frame);
  return bus_.send(master_.command(command, node));
}

void NmtMasterPort::handle(const can::TimedFrame& frame) {
  if (auto event = master_.on_frame(frame.frame, frame.timestamp); event && on_event_) {
    on_event_(*event);
  }
}

bool NmtMasterPort::wait_for_state(std::uint8_t node, NmtState state, can::TimePoint deadline) {
  assert(is_valid_node_id(node));
  while (true) {
    if (master_.state(node) == state) return true;
    auto frame = bus_.receive(deadline);
    if (!frame) return master_.state(node) == state;
    handle(*frame);
  }
}

}  // namespace drivecheck::cia301
