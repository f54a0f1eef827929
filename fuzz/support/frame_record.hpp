// The binary frame record of the frame-stream fuzz targets (emcy, dissector, sdo_client's
// injected frames): fixed 13 bytes per frame, so that mutations keep the frames aligned and
// dictionary tokens land in the data bytes.
//
//   byte 0     bits 3..0  DLC 0..15 (9..15: 8 data bytes; a remote frame's DLC is clamped to 8)
//              bits 5..4  kind: 0 data, 1 remote, 2 error, 3 data
//              bit 6      29-bit identifier (error frames always are)
//              bit 7      unused
//   bytes 1..4 identifier, little-endian, masked to 11 or 29 bits
//   bytes 5..12 data bytes 0..7 (bytes past the frame's length are dropped)
//
// decode_frame_record() gives only frames that can::parse_candump could also produce, so a
// finding is never an impossible frame. encode_frame_record() is its inverse (the corpus
// generator writes seeds with it).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>

#include "fuzz/support/fuzz_input.hpp"
#include "protocol/can/frame.hpp"

namespace drivecheck::fuzz {

inline constexpr std::size_t kFrameRecordSize = 13;

inline can::Frame decode_frame_record(FuzzInput& input) {
  const std::uint8_t flags = input.u8();
  const std::uint32_t raw_id = input.u32();
  std::array<std::uint8_t, 8> data{};
  for (auto& byte : data)
    byte = input.u8();

  can::Frame frame;
  frame.dlc = flags & 0x0F;
  switch ((flags >> 4) & 0x3) {
    case 1:
      frame.kind = can::FrameKind::remote;
      frame.dlc = std::min<std::uint8_t>(frame.dlc, 8);
      break;
    case 2:
      frame.kind = can::FrameKind::error;
      break;
    default:
      frame.kind = can::FrameKind::data;
      break;
  }
  const bool extended = (flags & 0x40) != 0 || frame.kind == can::FrameKind::error;
  frame.format = extended ? can::IdFormat::extended : can::IdFormat::standard;
  frame.id = raw_id & (extended ? can::kMaxExtendedId : can::kMaxStandardId);
  std::copy_n(data.begin(), frame.length(), frame.data.begin());
  return frame;
}

inline std::array<std::uint8_t, kFrameRecordSize> encode_frame_record(const can::Frame& frame) {
  std::array<std::uint8_t, kFrameRecordSize> record{};
  std::uint8_t kind = 0;
  if (frame.is_remote()) kind = 1;
  if (frame.is_error()) kind = 2;
  record[0] = static_cast<std::uint8_t>((frame.dlc & 0x0F) | (kind << 4) |
                                        (frame.is_extended() ? 0x40 : 0));
  for (std::size_t i = 0; i < 4; ++i)
    record[1 + i] = static_cast<std::uint8_t>(frame.id >> (8 * i));
  std::copy(frame.data.begin(), frame.data.end(), record.begin() + 5);
  return record;
}

}  // namespace drivecheck::fuzz
