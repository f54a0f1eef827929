// CAN identifiers of CANopen: the pre-defined connection set (CiA 301 §7.3.5) and the
// restricted CAN-IDs that no configurable communication object may use.
//
// Pre-defined connection set, 11-bit identifiers (function code = bits 10..7, node = bits 6..0):
//
//   COB        CAN-ID           direction (from the device's view)
//   NMT        000h             master → all nodes (node control)
//   SYNC       080h             producer → consumers
//   EMCY       080h + node      device → master (081h..0FFh)
//   TIME       100h             producer → consumers
//   TPDO1      180h + node      device → bus      RPDO1  200h + node   bus → device
//   TPDO2      280h + node                        RPDO2  300h + node
//   TPDO3      380h + node                        RPDO3  400h + node
//   TPDO4      480h + node                        RPDO4  500h + node
//   SDO tx     580h + node      server → client (device answers)
//   SDO rx     600h + node      client → server (master requests)
//   NMT EC     700h + node      boot-up, heartbeat, node-guarding request (RTR) and response
//   LSS        7E4h             LSS slave → LSS master (CiA 305)
//   LSS        7E5h             LSS master → LSS slaves (CiA 305)
//
// Node-IDs are 1..127; base + 0 is not a node's identifier (180h is restricted, not "TPDO1 of
// node 0"). 29-bit identifiers are outside the pre-defined set.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

#include "protocol/can/frame.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint8_t kMinNodeId = 1;
inline constexpr std::uint8_t kMaxNodeId = 127;

constexpr bool is_valid_node_id(unsigned node) {
  return node >= kMinNodeId && node <= kMaxNodeId;
}

// The communication object a CAN-ID carries in the pre-defined connection set.
enum class CobFunction : std::uint8_t {
  nmt,                  // 000h
  sync,                 // 080h
  emcy,                 // 080h + node
  time,                 // 100h
  tpdo1,                // 180h + node
  rpdo1,                // 200h + node
  tpdo2,                // 280h + node
  rpdo2,                // 300h + node
  tpdo3,                // 380h + node
  rpdo3,                // 400h + node
  tpdo4,                // 480h + node
  rpdo4,                // 500h + node
  sdo_tx,               // 580h + node (server → client)
  sdo_rx,               // 600h + node (client → server)
  nmt_error_control,    // 700h + node
  lss_slave_to_master,  // 7E4h
  lss_master_to_slave,  // 7E5h
  unassigned,           // no object of the pre-defined connection set
};

// A CAN-ID read back as {function, node}; node is 0 for objects that are not node-specific
// (NMT, SYNC, TIME, LSS, unassigned).
struct CobIdClass {
  CobFunction function = CobFunction::unassigned;
  std::uint8_t node = 0;

  friend bool operator==(const CobIdClass&, const CobIdClass&) = default;
};

// Classifies an 11-bit CAN-ID (values above 7FFh are unassigned).
CobIdClass classify_cob_id(std::uint32_t can_id);
// Classifies a frame: 29-bit and error frames are unassigned; RTR frames classify by id.
CobIdClass classify_cob_id(const can::Frame& frame);

// The CAN-ID of a function for a node (the other direction of classify_cob_id). nullopt for
// `unassigned`, and for node-specific functions when the node is not 1..127. The node is
// ignored for NMT, SYNC, TIME and LSS.
std::optional<std::uint16_t> default_cob_id(CobFunction function, std::uint8_t node = 0);

// Whether the function's CAN-ID is base + node.
bool is_node_specific(CobFunction function);

// Short name as a trace column shows it: "NMT", "SYNC", "EMCY", "TIME", "TPDO1".."RPDO4",
// "SDO tx", "SDO rx", "NMT EC", "LSS tx", "LSS rx", "-" for unassigned.
std::string_view to_string(CobFunction function);

// The restricted CAN-IDs of CiA 301 §7.3.5 (Table "Restricted CAN-IDs"): a device must not
// accept them for a configurable COB (PDO, SYNC, TIME, EMCY COB-ID entries), because they belong
// to NMT, SDO, error control or are reserved.
struct RestrictedCobIdRange {
  std::uint16_t first;
  std::uint16_t last;
  std::string_view used_by;
};
std::span<const RestrictedCobIdRange> restricted_cob_ids();
// The range an 11-bit CAN-ID falls in, or nullopt when it may be configured.
std::optional<RestrictedCobIdRange> find_restricted_cob_id(std::uint32_t can_id);
bool is_restricted_cob_id(std::uint32_t can_id);

}  // namespace drivecheck::cia301
