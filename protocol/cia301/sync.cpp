#include "protocol/cia301/sync.hpp"

#include <fmt/format.h>

#include <cassert>

namespace drivecheck::cia301 {
namespace {

bool on_id(const can::Frame& frame, std::uint32_t cob_id) {
  const bool want_extended = cob_id > can::kMaxStandardId;
  return frame.is_extended() == want_extended && frame.id == cob_id;
}

}  // namespace

can::Frame encode(const Sync& message, std::uint32_t cob_id) {
  assert(!message.counter || (*message.counter >= 1 && *message.counter <= kMaxSyncCounter));
  can::Frame frame;
  frame.id = cob_id;
  frame.format = cob_id > can::kMaxStandardId ? can::IdFormat::extended : can::IdFormat::standard;
  if (message.counter) {
    frame.dlc = 1;
    frame.data[0] = *message.counter;
  }
  return frame;
}

Expected<Sync, DecodeError> decode_sync(const can::Frame& frame, std::uint32_t cob_id) {
  if (frame.is_error()) return Unexpected(DecodeError{"SYNC: an error frame is not a SYNC"});
  if (!on_id(frame, cob_id)) {
    return Unexpected(DecodeError{
        fmt::format("SYNC: {} is not on the SYNC CAN-ID {:03X}h", can::to_candump(frame), cob_id)});
  }
  if (frame.is_remote()) {
    return Unexpected(DecodeError{"SYNC as a remote request: invalid (SYNC is a data frame)"});
  }
  if (frame.dlc == 0) return Sync{};
  if (frame.dlc != 1) {
    return Unexpected(DecodeError{
        fmt::format("SYNC with DLC {}: invalid (SYNC carries 0 bytes, or 1 byte with the counter)",
                    frame.dlc)});
  }
  const std::uint8_t counter = frame.data[0];
  if (counter == 0 || counter > kMaxSyncCounter) {
    return Unexpected(
        DecodeError{fmt::format("SYNC counter {}: invalid (the counter runs 1..240)", counter)});
  }
  return Sync{counter};
}

std::uint32_t SyncCobIdEntry::encode() const {
  return (generate ? 0x40000000u : 0u) | (extended ? 0x20000000u : 0u) |
         (can_id & (extended ? can::kMaxExtendedId : can::kMaxStandardId));
}

Expected<SyncCobIdEntry, DecodeError> decode_sync_cob_id_entry(std::uint32_t value) {
  SyncCobIdEntry entry;
  entry.generate = (value & 0x40000000u) != 0;
  entry.extended = (value & 0x20000000u) != 0;
  entry.can_id = value & can::kMaxExtendedId;
  if (!entry.extended && entry.can_id > can::kMaxStandardId) {
    return Unexpected(DecodeError{fmt::format(
        "COB-ID SYNC {:08X}h: invalid (bits 28..11 must be 0 for an 11-bit CAN-ID)", value)});
  }
  return entry;
}

}  // namespace drivecheck::cia301
