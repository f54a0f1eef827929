// SDO server parameter records (CiA 301 §7.5.2.33): 1200h is the default server channel,
// 1201h..127Fh are further server channels a device may have. Each record:
//
//   sub 00h  highest sub-index supported, UNSIGNED8 ro: 2, or 3 with sub 03h
//   sub 01h  COB-ID client -> server (the requests), UNSIGNED32   (1200h: ro, 600h + node-ID)
//   sub 02h  COB-ID server -> client (the answers), UNSIGNED32    (1200h: ro, 580h + node-ID)
//   sub 03h  node-ID, UNSIGNED8 (optional): see SdoNodeIdSub
//
// COB-ID layout (UNSIGNED32, sub 01h/02h), bit by bit:
//   bit 31     valid: 0 = the SDO exists / is valid, 1 = not valid (the channel is off)
//   bit 30     dyn: 0 = assigned statically, 1 = dynamically (SDO manager); kept, not used
//   bit 29     frame: 0 = 11-bit CAN-ID; 1 = 29-bit (not supported here: abort 06090030h)
//   bits 28-11 0 with an 11-bit CAN-ID (anything else: abort 06090030h)
//   bits 10-0  the 11-bit CAN-ID
// A further channel (1201h..) starts not valid (80000000h) on both COB-IDs. It takes requests
// when both COB-IDs are valid. As for a PDO COB-ID, the CAN-ID of a valid COB-ID cannot be
// changed in one write (abort 06090030h): set bit 31 first, then write the new CAN-ID valid.
// 1200h's COB-IDs are read-only (the node-ID gives them).
//
// sub 03h (SdoNodeIdSub):
//   client  CiA 301: the node-ID of the SDO client of this channel, 1..127, rw, default 0;
//           only recorded (a server answers whoever sends on its request COB-ID).
//   server  ESR (004 §14.1 L930-942, §14.2 L976-993, "SDO2 Node-ID"): the node-ID of this
//           server channel itself, rw, 0..127, default 0, effective at once: 1..127 sets
//           sub 01h = 600h + it and sub 02h = 580h + it, both valid; 0 sets both to 80000000h
//           (not valid), which disables the channel. Above 127: abort 06090031h.
//   none    no sub 03h (sub 00h = 2).
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kSdoServerParameterFirst = 0x1200;
inline constexpr std::uint16_t kSdoServerParameterLast = 0x127F;
inline constexpr std::uint32_t kSdoCobIdNotValid = 0x80000000u;  // bit 31

namespace sdo_server_sub {
inline constexpr std::uint8_t kRequestCobId = 1;   // client -> server
inline constexpr std::uint8_t kResponseCobId = 2;  // server -> client
inline constexpr std::uint8_t kNodeId = 3;
}  // namespace sdo_server_sub

// What sub 03h of a further SDO server record is (see the file comment).
enum class SdoNodeIdSub : std::uint8_t { none, client, server };

// One server channel as its record describes it.
struct SdoServerChannel {
  std::uint32_t request_cob_id = 0;   // 11-bit CAN-ID (client -> server)
  std::uint32_t response_cob_id = 0;  // 11-bit CAN-ID (server -> client)
  bool valid = false;                 // both COB-IDs valid: the channel takes requests
  friend bool operator==(const SdoServerChannel&, const SdoServerChannel&) = default;
};

// Adds the record of a further SDO server channel at `index` (1201h..127Fh), not valid.
// Errors: an index outside 1201h..127Fh, or one the dictionary already has.
Expected<void, std::string> add_sdo_server_parameter(ObjectDictionary& od, std::uint16_t index,
                                                     SdoNodeIdSub node_id_sub);

// The channel record `index` describes now; nullopt when the dictionary has no such record.
std::optional<SdoServerChannel> read_sdo_server_channel(const ObjectDictionary& od,
                                                        std::uint16_t index);

}  // namespace drivecheck::cia301
