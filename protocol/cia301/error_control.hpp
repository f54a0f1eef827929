// NMT error control (CiA 301 §7.2.8.3.2): boot-up, heartbeat and node guarding. All use
// CAN-ID 700h + node.
//
// Boot-up (device → all, once after initialising), DLC 1:
//   byte 0  00h
//
// Heartbeat (producer → consumers, every producer heartbeat time 1017h), DLC 1:
//   byte 0  bit 7 reserved (0), bits 6..0 NMT state: 04h stopped, 05h operational,
//           7Fh pre-operational
//
// Node-guarding request (NMT master → node): remote frame (RTR) on 700h + node, no data.
//   The DLC of the remote frame is 0 as the Festo manual draws it ("Remote frames have no
//   data", 000_33c1d912b8b6010a.txt L1477-1481); some masters send DLC 1 (the DLC of the
//   answer). Both decode as a request; the DLC is kept.
//
// Node-guarding response (node → master), DLC 1:
//   byte 0  bit 7 toggle t: 0 in the first response after the guarding protocol starts or
//           after reset communication, then alternating with every response;
//           bits 6..0 NMT state as in the heartbeat
//
// Sources: Festo CMMP-AS §3.7-3.9 (000_33c1d912b8b6010a.txt L1415-1499), Kollmorgen S300/S700
// §4.4.7-4.4.8 (002_953174ea6ca45cdb.txt L1029-1109).
//
// A heartbeat and a guarding response with toggle 0 are the same bytes: only the context (was
// a request outstanding?) tells them apart. decode_error_control() therefore returns a neutral
// NodeStatus; decode_heartbeat() and decode_guard_response() apply each protocol's rules.
#pragma once

#include <cstdint>
#include <variant>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/decode_error.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kErrorControlBase = 0x700;

struct BootUp {
  std::uint8_t node = 0;
  friend bool operator==(const BootUp&, const BootUp&) = default;
};

struct Heartbeat {
  std::uint8_t node = 0;
  NmtState state = NmtState::pre_operational;
  friend bool operator==(const Heartbeat&, const Heartbeat&) = default;
};

struct GuardRequest {
  std::uint8_t node = 0;
  std::uint8_t dlc = 0;  // DLC of the remote frame (0 by default)
  friend bool operator==(const GuardRequest&, const GuardRequest&) = default;
};

struct GuardResponse {
  std::uint8_t node = 0;
  bool toggle = false;
  NmtState state = NmtState::pre_operational;
  friend bool operator==(const GuardResponse&, const GuardResponse&) = default;
};

// A 1-byte state report that is not a boot-up: a heartbeat (toggle false) or a guarding
// response (either toggle).
struct NodeStatus {
  std::uint8_t node = 0;
  bool toggle = false;  // bit 7
  NmtState state = NmtState::pre_operational;
  friend bool operator==(const NodeStatus&, const NodeStatus&) = default;
};

using ErrorControlMessage = std::variant<BootUp, GuardRequest, NodeStatus>;

// Preconditions: node 1..127, and for the heartbeat and the response a state other than
// boot-up (use BootUp for that).
can::Frame encode(const BootUp& message);
can::Frame encode(const Heartbeat& message);
can::Frame encode(const GuardRequest& message);
can::Frame encode(const GuardResponse& message);

// Any frame on 701h..77Fh. Invalid: another identifier, 29-bit or error frame, a remote
// request with DLC above 1, a data frame with DLC other than 1, a state value that is not
// 04h/05h/7Fh (00h is a boot-up, 80h a boot-up with the toggle set: invalid).
Expected<ErrorControlMessage, DecodeError> decode_error_control(const can::Frame& frame);

// Strict heartbeat rules on top: also invalid when bit 7 (reserved) is set. A boot-up is
// returned as Heartbeat with state boot_up.
Expected<Heartbeat, DecodeError> decode_heartbeat(const can::Frame& frame);

// Strict guarding-response rules: a data frame with DLC 1 and a valid state; invalid for a
// boot-up (00h) and for requests.
Expected<GuardResponse, DecodeError> decode_guard_response(const can::Frame& frame);

}  // namespace drivecheck::cia301
