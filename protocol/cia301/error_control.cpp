#include "protocol/cia301/error_control.hpp"

#include <fmt/format.h>

#include <cassert>

#include "protocol/cia301/cob_id.hpp"

namespace drivecheck::cia301 {
namespace {

std::uint16_t cob_id_of(std::uint8_t node) {
  assert(is_valid_node_id(node));
  return static_cast<std::uint16_t>(kErrorControlBase + node);
}

}  // namespace

can::Frame encode(const BootUp& message) {
  return can::Frame::standard(cob_id_of(message.node), {0x00});
}

can::Frame encode(const Heartbeat& message) {
  assert(message.state != NmtState::boot_up);
  return can::Frame::standard(cob_id_of(message.node), {static_cast<std::uint8_t>(message.state)});
}

can::Frame encode(const GuardRequest& message) {
  return can::Frame::remote(cob_id_of(message.node), message.dlc);
}

can::Frame encode(const GuardResponse& message) {
  assert(message.state != NmtState::boot_up);
  const auto byte = static_cast<std::uint8_t>((message.toggle ? 0x80 : 0x00) |
                                              static_cast<std::uint8_t>(message.state));
  return can::Frame::standard(cob_id_of(message.node), {byte});
}

Expected<ErrorControlMessage, DecodeError> decode_error_control(const can::Frame& frame) {
  if (frame.is_error()) {
    return Unexpected(DecodeError{"NMT error control: an error frame is not error control"});
  }
  const CobIdClass cls = classify_cob_id(frame);
  if (cls.function != CobFunction::nmt_error_control) {
    return Unexpected(DecodeError{
        fmt::format("NMT error control: {} is not on CAN-ID 701h..77Fh", can::to_candump(frame))});
  }
  if (frame.is_remote()) {
    if (frame.dlc > 1) {
      return Unexpected(DecodeError{
          fmt::format("node-guarding request with DLC {}: invalid (remote request with DLC 0 or 1)",
                      frame.dlc)});
    }
    return ErrorControlMessage{GuardRequest{cls.node, frame.dlc}};
  }
  if (frame.dlc != 1) {
    return Unexpected(DecodeError{fmt::format(
        "NMT error control with DLC {}: invalid (boot-up, heartbeat and guarding frames carry 1 "
        "byte)",
        frame.dlc)});
  }
  const std::uint8_t byte = frame.data[0];
  if (byte == 0x00) return ErrorControlMessage{BootUp{cls.node}};
  const bool toggle = (byte & 0x80) != 0;
  const auto state = nmt_state_from_byte(static_cast<std::uint8_t>(byte & 0x7F));
  if (!state || *state == NmtState::boot_up) {
    return Unexpected(DecodeError{fmt::format(
        "NMT error control state byte {:02X}h: invalid (state 04h, 05h or 7Fh, toggle in bit 7; "
        "00h is the boot-up)",
        byte)});
  }
  return ErrorControlMessage{NodeStatus{cls.node, toggle, *state}};
}

Expected<Heartbeat, DecodeError> decode_heartbeat(const can::Frame& frame) {
  auto message = decode_error_control(frame);
  if (!message) return Unexpected(std::move(message).error());
  if (const auto* boot = std::get_if<BootUp>(&*message))
    return Heartbeat{boot->node, NmtState::boot_up};
  if (std::holds_alternative<GuardRequest>(*message)) {
    return Unexpected(DecodeError{"heartbeat: a node-guarding request (RTR) is not a heartbeat"});
  }
  const auto& status = std::get<NodeStatus>(*message);
  if (status.toggle) {
    return Unexpected(DecodeError{fmt::format(
        "heartbeat state byte {:02X}h: invalid (bit 7 is reserved and 0 in a heartbeat; a "
        "node-guarding response toggles it)",
        frame.data[0])});
  }
  return Heartbeat{status.node, status.state};
}

Expected<GuardResponse, DecodeError> decode_guard_response(const can::Frame& frame) {
  auto message = decode_error_control(frame);
  if (!message) return Unexpected(std::move(message).error());
  if (std::holds_alternative<BootUp>(*message)) {
    return Unexpected(DecodeError{"node-guarding response 00h: a boot-up message, not a response"});
  }
  if (std::holds_alternative<GuardRequest>(*message)) {
    return Unexpected(DecodeError{"node-guarding response: a request (RTR) is not a response"});
  }
  const auto& status = std::get<NodeStatus>(*message);
  return GuardResponse{status.node, status.toggle, status.state};
}

}  // namespace drivecheck::cia301
