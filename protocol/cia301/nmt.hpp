// NMT node control (CiA 301 §7.2.8.3.1) and the NMT states (§7.3.2.2).
//
// NMT node control frame, CAN-ID 000h, DLC 2, sent by the NMT master, never acknowledged:
//
//   byte 0  CS    command specifier: 01h start remote node, 02h stop remote node,
//                 80h enter pre-operational, 81h reset node, 82h reset communication
//   byte 1  node  Node-ID 1..127 of the addressed node; 0 = all nodes (broadcast)
//
// Festo CMMP-AS manual §3.6 (000_33c1d912b8b6010a.txt L1346-1376) prints the same CS values and
// the target states; Kollmorgen S300/S700 (002_953174ea6ca45cdb.txt §4.4.1 L671-711) likewise.
//
// The NMT state a node reports in its boot-up, heartbeat and node-guarding frames (bits 6..0):
//
//   00h  boot-up (initialising; only in the boot-up message)
//   04h  stopped
//   05h  operational
//   7Fh  pre-operational
#pragma once

#include <cstdint>
#include <optional>
#include <string_view>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/decode_error.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kNmtCobId = 0x000;

enum class NmtCommand : std::uint8_t {
  start = 0x01,
  stop = 0x02,
  enter_pre_operational = 0x80,
  reset_node = 0x81,
  reset_communication = 0x82,
};

enum class NmtState : std::uint8_t {
  boot_up = 0x00,  // initialising: only ever seen in the boot-up message
  stopped = 0x04,
  operational = 0x05,
  pre_operational = 0x7F,
};

// "start", "stop", "enter pre-operational", "reset node", "reset communication".
std::string_view to_string(NmtCommand command);
// "boot-up", "stopped", "operational", "pre-operational".
std::string_view to_string(NmtState state);

// The command of a CS byte; nullopt for any other value.
std::optional<NmtCommand> nmt_command_from_byte(std::uint8_t cs);
// The state of a state byte (bit 7 must already be masked off by the caller where it is a
// toggle); nullopt for any value that is not one of the four states.
std::optional<NmtState> nmt_state_from_byte(std::uint8_t value);

// The state a node is in after it has obeyed the command (reset node and reset communication
// end in pre-operational after the boot-up message).
NmtState state_after(NmtCommand command);

struct NmtNodeControl {
  NmtCommand command = NmtCommand::start;
  std::uint8_t node = 0;  // 0 = all nodes

  bool is_broadcast() const { return node == 0; }
  friend bool operator==(const NmtNodeControl&, const NmtNodeControl&) = default;
};

// Precondition: node <= 127.
can::Frame encode(const NmtNodeControl& message);

// Decodes a frame sent on CAN-ID 000h. Invalid: another identifier, 29-bit, remote or error
// frame, DLC other than 2, an unknown CS, a node-ID above 127.
Expected<NmtNodeControl, DecodeError> decode_nmt_node_control(const can::Frame& frame);

}  // namespace drivecheck::cia301
