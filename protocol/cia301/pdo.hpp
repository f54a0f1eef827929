// PDO communication and mapping parameters (CiA 301 §7.2.2, §7.5.2.35-38) and the PDO payload.
//
// Object indices: RPDO n (1..512) communication 1400h + n-1, mapping 1600h + n-1;
//                 TPDO n (1..512) communication 1800h + n-1, mapping 1A00h + n-1.
//
// Communication parameter record (sub-indices):
//   01h  COB-ID used by PDO, UNSIGNED32:
//          bit 31      valid: 0 = PDO exists / is valid, 1 = PDO does not exist / is not valid
//          bit 30      RTR: 0 = RTR allowed on this PDO, 1 = no RTR allowed
//          bit 29      frame: 0 = 11-bit CAN-ID, 1 = 29-bit CAN-ID
//          bits 28..0  CAN-ID (bits 28..11 are 0 for an 11-bit CAN-ID)
//        Festo CMMP-AS Tab. 3.5 (000_33c1d912b8b6010a.txt L878-911): "bit 31 set = PDO
//        deactivated", default C0000181h; bit 30 reads 1 (no RTR). Dunker §14.3.2
//        (004_956552dcd17e975a.txt L1106-1250): "bit31 1 = not valid / 0 = valid; bit30 0 = RTR
//        allowed".
//   02h  transmission type, UNSIGNED8:
//          0        synchronous, acyclic (on the next SYNC after an event)
//          1..240   synchronous, cyclic: every n-th SYNC
//          241..251 reserved
//          252      synchronous, RTR only (TPDO)
//          253      event-driven, RTR only (TPDO)
//          254      event-driven, manufacturer-specific
//          255      event-driven, device-profile / application-profile specific
//        An RPDO accepts 0..240, 254, 255.
//   03h  inhibit time, UNSIGNED16, multiples of 100 µs (TPDO; Festo L1020 "100 µs (10 = 1 ms)")
//   04h  reserved (compatibility entry)
//   05h  event timer, UNSIGNED16, ms, 0 = not used
//   06h  SYNC start value, UNSIGNED8, 0 = not used, 1..240
//
// Mapping parameter record: sub 00h number of mapped objects (0..64), subs 01h..40h entries,
// UNSIGNED32 each:
//   bits 31..16  index, bits 15..8 sub-index, bits 7..0 length in bits
//   e.g. 60410010h = 6041h:00, 16 bit (Festo Tab. 3.6, 000_33c1d912b8b6010a.txt L913-918).
//   Dummy entries (data type indices 0002h..0007h, sub-index 0) reserve room in an RPDO:
//   0002h INTEGER8, 0003h INTEGER16, 0004h INTEGER32, 0005h UNSIGNED8, 0006h UNSIGNED16,
//   0007h UNSIGNED32.
//
// PDO payload: the mapped objects in mapping order, packed from bit 0 of byte 0 upwards, each
// little-endian; at most 64 bits (8 bytes) in total.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/decode_error.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

enum class PdoDirection : std::uint8_t { receive, transmit };  // RPDO, TPDO (device's view)

inline constexpr std::uint16_t kRpdoCommunicationBase = 0x1400;
inline constexpr std::uint16_t kRpdoMappingBase = 0x1600;
inline constexpr std::uint16_t kTpdoCommunicationBase = 0x1800;
inline constexpr std::uint16_t kTpdoMappingBase = 0x1A00;
inline constexpr std::uint16_t kMaxPdoNumber = 512;
inline constexpr std::uint8_t kMaxMappedObjects = 64;
inline constexpr unsigned kMaxPdoBits = 64;

namespace pdo_sub {
inline constexpr std::uint8_t kCobId = 0x01;
inline constexpr std::uint8_t kTransmissionType = 0x02;
inline constexpr std::uint8_t kInhibitTime = 0x03;
inline constexpr std::uint8_t kReserved = 0x04;
inline constexpr std::uint8_t kEventTimer = 0x05;
inline constexpr std::uint8_t kSyncStartValue = 0x06;
}  // namespace pdo_sub

// Object index of PDO number 1..512. Precondition: number in range.
std::uint16_t pdo_communication_index(PdoDirection direction, std::uint16_t number);
std::uint16_t pdo_mapping_index(PdoDirection direction, std::uint16_t number);

// Sub-index 01h of the communication record.
struct PdoCobId {
  bool valid = true;         // bit 31 = 0
  bool rtr_allowed = true;   // bit 30 = 0
  bool extended = false;     // bit 29
  std::uint32_t can_id = 0;  // 11 or 29 bits

  std::uint32_t encode() const;
  friend bool operator==(const PdoCobId&, const PdoCobId&) = default;
};
// Invalid: an 11-bit CAN-ID with any of bits 28..11 set.
Expected<PdoCobId, DecodeError> decode_pdo_cob_id(std::uint32_t value);

enum class TransmissionKind : std::uint8_t {
  synchronous_acyclic,  // 0
  synchronous_cyclic,   // 1..240
  reserved,             // 241..251
  rtr_synchronous,      // 252
  rtr_event,            // 253
  event_manufacturer,   // 254
  event_profile,        // 255
};
TransmissionKind transmission_kind(std::uint8_t type);
std::string_view to_string(TransmissionKind kind);
// Whether the type may be written for a PDO of that direction (RPDO: 0..240, 254, 255;
// TPDO: 0..240, 252..255).
bool is_valid_transmission_type(std::uint8_t type, PdoDirection direction);
// "synchronous cyclic (every 4th SYNC)", "event-driven (profile)", "reserved (245)", ...
std::string describe_transmission_type(std::uint8_t type);

// Sub 03h: multiples of 100 µs.
constexpr std::chrono::microseconds inhibit_time(std::uint16_t value) {
  return std::chrono::microseconds{100} * value;
}
// Sub 05h: ms, 0 = not used.
constexpr std::chrono::milliseconds event_timer(std::uint16_t value) {
  return std::chrono::milliseconds{value};
}
// Sub 06h: 0 (not used) or 1..240.
constexpr bool is_valid_sync_start_value(std::uint8_t value) {
  return value <= 240;
}

struct PdoMappingEntry {
  std::uint16_t index = 0;
  std::uint8_t sub_index = 0;
  std::uint8_t bits = 0;  // length in bits, 1..64

  std::uint32_t encode() const;
  // Index 0002h..0007h with sub-index 0.
  bool is_dummy() const;
  friend bool operator==(const PdoMappingEntry&, const PdoMappingEntry&) = default;
};
// Invalid: length 0 or above 64; a dummy entry (0002h..0007h) with a sub-index or a length other
// than its data type's size; index 0000h or another data type index (0001h, 0008h..0FFFh).
Expected<PdoMappingEntry, DecodeError> decode_pdo_mapping_entry(std::uint32_t value);

// The size in bits of a dummy data type index (8, 16 or 32), nullopt for other indices.
std::optional<unsigned> dummy_bits(std::uint16_t index);

// A whole mapping: entries in PDO order.
struct PdoMapping {
  std::vector<PdoMappingEntry> entries;

  unsigned total_bits() const;
  // Invalid: more than 64 entries or more than 64 bits in total.
  Expected<void, DecodeError> validate() const;
};

// One mapped object's raw value taken from a PDO payload.
struct MappedValue {
  PdoMappingEntry entry;
  unsigned bit_offset = 0;
  std::uint64_t raw = 0;  // little-endian bits, zero-extended

  // The value as a signed integer of `entry.bits` bits.
  std::int64_t as_signed() const;
};

// Unpacks a payload along a mapping (dummy entries included, so offsets stay visible).
// Invalid: a mapping that fails validate(); a payload shorter than the mapping (CiA 301 EMCY
// 8210h). A longer payload is accepted: the extra bytes are ignored (CiA 301 lets a receiver
// use the first bytes; the caller may flag it as 8220h).
Expected<std::vector<MappedValue>, DecodeError> unpack_pdo(const PdoMapping& mapping,
                                                           std::span<const std::uint8_t> payload);
// Packs values (one per entry, in order) into a payload of total_bits() rounded up to bytes.
// Precondition: mapping.validate() succeeds and values.size() == entries.size().
std::vector<std::uint8_t> pack_pdo(const PdoMapping& mapping,
                                   std::span<const std::uint64_t> values);

}  // namespace drivecheck::cia301
