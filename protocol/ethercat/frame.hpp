// EtherCAT frames: Ethernet II with EtherType 88A4h carrying an EtherCAT header and datagrams
// (IEC 61158-4-12 / ETG.1000.4; ESC Technology §2.1-2.2).
//
//   bytes 0..5    destination MAC (EtherCAT slaves ignore it; masters use broadcast)
//   bytes 6..11   source MAC (an ESC sets bit 1 of byte 6, "locally administered", on frames
//                 it processed; the master matches answers by their datagram index)
//   bytes 12..13  EtherType 88A4h, big-endian (optionally after a VLAN tag 8100h + TCI)
//   bytes 14..15  EtherCAT header, little-endian u16: bits 0..10 length of the datagrams
//                 that follow, bit 11 reserved (0), bits 12..15 type (1 = DLPDU/datagrams)
//   16..          datagrams (datagram.hpp), back to back, M set on all but the last
//   then          padding with zeros up to the 60-byte Ethernet minimum (no FCS here: the NIC
//                 adds and checks it)
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "protocol/common/expected.hpp"
#include "protocol/ethercat/datagram.hpp"

namespace drivecheck::ethercat {

using MacAddress = std::array<std::uint8_t, 6>;

inline constexpr std::uint16_t kEtherType = 0x88A4;
inline constexpr std::uint16_t kVlanEtherType = 0x8100;
inline constexpr std::size_t kEthernetHeaderSize = 14;
inline constexpr std::size_t kEthercatHeaderSize = 2;
inline constexpr std::size_t kMinFrameSize = 60;    // Ethernet minimum without FCS
inline constexpr std::size_t kMaxFrameSize = 1514;  // Ethernet maximum without FCS
// The most datagram bytes one untagged frame holds (1514 - 14 - 2).
inline constexpr std::size_t kMaxDatagramBytes =
    kMaxFrameSize - kEthernetHeaderSize - kEthercatHeaderSize;
inline constexpr std::uint8_t kTypeDatagrams = 1;

inline constexpr MacAddress kBroadcastMac = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};

struct Frame {
  MacAddress destination = kBroadcastMac;
  MacAddress source{};
  std::vector<Datagram> datagrams;
  bool header_reserved = false;  // EtherCAT header bit 11 (0 on the wire; kept as decoded)

  friend bool operator==(const Frame&, const Frame&) = default;
};

// The frame's bytes, padded with zeros to 60. Errors: datagram_too_long, frame_too_long.
Expected<std::vector<std::uint8_t>, std::error_code> encode_frame(const Frame& frame);

// Where the EtherCAT payload of a raw frame lies: after the Ethernet header (and a VLAN tag)
// and the EtherCAT header, `length` bytes. Checks EtherType, type and length only.
struct FrameLayout {
  std::size_t payload_offset = 0;
  std::size_t payload_length = 0;
};
Expected<FrameLayout, DecodeError> parse_frame_layout(std::span<const std::uint8_t> bytes);

// Decodes a whole frame; every structural problem is a DecodeError naming the byte offset,
// never undefined behaviour (the fuzz target `ethercat_datagram` holds it to that).
Expected<Frame, DecodeError> decode_frame(std::span<const std::uint8_t> bytes);

}  // namespace drivecheck::ethercat
