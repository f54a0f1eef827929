// SYNC (CiA 301 §7.2.5): the synchronisation object, and its configuration objects.
//
// SYNC frame, CAN-ID 080h (configurable in 1005h), sent by the SYNC producer every
// communication cycle period (1006h, µs):
//
//   without counter (1019h = 0):  DLC 0, no data
//   with counter (1019h = 2..240): DLC 1
//     byte 0  counter 1..overflow value: 1 for the first SYNC, +1 per SYNC, back to 1 after
//             the overflow value (1019h)
//
// 1005h COB-ID SYNC (UNSIGNED32):
//   bit 31     reserved (don't care)
//   bit 30     gen: 1 = this device generates SYNC
//   bit 29     frame: 0 = 11-bit CAN-ID, 1 = 29-bit CAN-ID
//   bits 28..0 CAN-ID (bits 28..11 zero for an 11-bit CAN-ID)
//   Festo CMMP-AS: range 80000080h / 00000080h, default 00000080h (000_33c1d912b8b6010a.txt
//   L1228-1245); Kollmorgen S300/S700: "bit30 = 1 → device generates SYNC (not supported)"
//   (002_953174ea6ca45cdb.txt L1388-1423).
//
// 1019h synchronous counter overflow value (UNSIGNED8): 0 = SYNC without counter;
//   1 = reserved; 2..240 = counter overflow value; 241..255 = reserved.
#pragma once

#include <cstdint>
#include <optional>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/decode_error.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kSyncCobId = 0x080;
inline constexpr std::uint8_t kMaxSyncCounter = 240;

struct Sync {
  std::optional<std::uint8_t> counter;  // 1..240 when the producer uses a counter
  friend bool operator==(const Sync&, const Sync&) = default;
};

// Precondition: counter, when given, is 1..240. The CAN-ID is 080h unless given.
can::Frame encode(const Sync& message, std::uint32_t cob_id = kSyncCobId);

// Decodes a SYNC frame on `cob_id` (11-bit unless the frame is 29-bit and cob_id is too).
// Invalid: another identifier, remote or error frame, DLC above 1, a counter of 0 or
// above 240.
Expected<Sync, DecodeError> decode_sync(const can::Frame& frame, std::uint32_t cob_id = kSyncCobId);

// 1005h COB-ID SYNC.
struct SyncCobIdEntry {
  bool generate = false;  // bit 30
  bool extended = false;  // bit 29
  std::uint32_t can_id = kSyncCobId;

  std::uint32_t encode() const;
  friend bool operator==(const SyncCobIdEntry&, const SyncCobIdEntry&) = default;
};
// Invalid: an 11-bit CAN-ID with any of bits 28..11 set.
Expected<SyncCobIdEntry, DecodeError> decode_sync_cob_id_entry(std::uint32_t value);

// 1019h: whether the value is allowed (0 or 2..240).
constexpr bool is_valid_sync_counter_overflow(std::uint8_t value) {
  return value == 0 || (value >= 2 && value <= kMaxSyncCounter);
}

}  // namespace drivecheck::cia301
