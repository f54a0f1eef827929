#include "protocol/cia301/nmt.hpp"

#include <fmt/format.h>

#include <cassert>

namespace drivecheck::cia301 {

std::string_view to_string(NmtCommand command) {
  switch (command) {
    case NmtCommand::start:
      return "start";
    case NmtCommand::stop:
      return "stop";
    case NmtCommand::enter_pre_operational:
      return "enter pre-operational";
    case NmtCommand::reset_node:
      return "reset node";
    case NmtCommand::reset_communication:
      return "reset communication";
  }
  return "?";
}

std::string_view to_string(NmtState state) {
  switch (state) {
    case NmtState::boot_up:
      return "boot-up";
    case NmtState::stopped:
      return "stopped";
    case NmtState::operational:
      return "operational";
    case NmtState::pre_operational:
      return "pre-operational";
  }
  return "?";
}

std::optional<NmtCommand> nmt_command_from_byte(std::uint8_t cs) {
  switch (cs) {
    case 0x01:
      return NmtCommand::start;
    case 0x02:
      return NmtCommand::stop;
    case 0x80:
      return NmtCommand::enter_pre_operational;
    case 0x81:
      return NmtCommand::reset_node;
    case 0x82:
      return NmtCommand::reset_communication;
    default:
      return std::nullopt;
  }
}

std::optional<NmtState> nmt_state_from_byte(std::uint8_t value) {
  switch (value) {
    case 0x00:
      return NmtState::boot_up;
    case 0x04:
      return NmtState::stopped;
    case 0x05:
      return NmtState::operational;
    case 0x7F:
      return NmtState::pre_operational;
    default:
      return std::nullopt;
  }
}

NmtState state_after(NmtCommand command) {
  switch (command) {
    case NmtCommand::start:
      return NmtState::operational;
    case NmtCommand::stop:
      return NmtState::stopped;
    case NmtCommand::enter_pre_operational:
    case NmtCommand::reset_node:
    case NmtCommand::reset_communication:
      return NmtState::pre_operational;
  }
  return NmtState::pre_operational;
}

can::Frame encode(const NmtNodeControl& message) {
  assert(message.node <= 127);
  return can::Frame::standard(kNmtCobId,
                              {static_cast<std::uint8_t>(message.command), message.node});
}

Expected<NmtNodeControl, DecodeError> decode_nmt_node_control(const can::Frame& frame) {
  if (frame.is_error())
    return Unexpected(DecodeError{"NMT: an error frame is not NMT node control"});
  if (frame.is_extended() || frame.id != kNmtCobId) {
    return Unexpected(
        DecodeError{fmt::format("NMT: {} is not CAN-ID 000h", can::to_candump(frame))});
  }
  if (frame.is_remote()) {
    return Unexpected(
        DecodeError{"NMT node control as a remote request: invalid (NMT is a data frame)"});
  }
  if (frame.dlc != 2) {
    return Unexpected(DecodeError{fmt::format(
        "NMT node control with DLC {}: invalid (NMT frames carry 2 bytes)", frame.dlc)});
  }
  const auto command = nmt_command_from_byte(frame.data[0]);
  if (!command) {
    return Unexpected(DecodeError{fmt::format(
        "NMT node control with command specifier {:02X}h: invalid (01h, 02h, 80h, 81h, 82h)",
        frame.data[0])});
  }
  if (frame.data[1] > 127) {
    return Unexpected(
        DecodeError{fmt::format("NMT {} for node {}: invalid (node-ID 1..127, 0 = all nodes)",
                                to_string(*command), frame.data[1])});
  }
  return NmtNodeControl{*command, frame.data[1]};
}

}  // namespace drivecheck::cia301
