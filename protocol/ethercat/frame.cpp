#include "protocol/ethercat/frame.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivecheck::ethercat {
namespace {

std::uint16_t read_be16(std::span<const std::uint8_t> bytes, std::size_t at) {
  return static_cast<std::uint16_t>((bytes[at] << 8) | bytes[at + 1]);
}

}  // namespace

Expected<std::vector<std::uint8_t>, std::error_code> encode_frame(const Frame& frame) {
  const std::size_t payload = encoded_size(frame.datagrams);
  if (payload > kMaxDatagramBytes) return Unexpected(make_error_code(FrameError::frame_too_long));
  std::vector<std::uint8_t> bytes;
  bytes.reserve(std::max(kMinFrameSize, kEthernetHeaderSize + kEthercatHeaderSize + payload));
  bytes.insert(bytes.end(), frame.destination.begin(), frame.destination.end());
  bytes.insert(bytes.end(), frame.source.begin(), frame.source.end());
  bytes.push_back(static_cast<std::uint8_t>(kEtherType >> 8));
  bytes.push_back(static_cast<std::uint8_t>(kEtherType & 0xFF));
  const auto header = static_cast<std::uint16_t>(payload | (kTypeDatagrams << 12) |
                                                 (frame.header_reserved ? 0x0800 : 0));
  bytes.push_back(static_cast<std::uint8_t>(header));
  bytes.push_back(static_cast<std::uint8_t>(header >> 8));
  if (const std::error_code error = encode_datagrams(frame.datagrams, bytes)) {
    return Unexpected(error);
  }
  if (bytes.size() < kMinFrameSize) bytes.resize(kMinFrameSize, 0);
  return bytes;
}

Expected<FrameLayout, DecodeError> parse_frame_layout(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < kEthernetHeaderSize) {
    return Unexpected(DecodeError{FrameError::truncated_ethernet_header, bytes.size(),
                                  fmt::format("{} bytes", bytes.size())});
  }
  std::size_t at = 12;
  std::uint16_t ether_type = read_be16(bytes, at);
  if (ether_type == kVlanEtherType) {
    if (bytes.size() < kEthernetHeaderSize + 4) {
      return Unexpected(DecodeError{FrameError::truncated_ethernet_header, bytes.size(),
                                    fmt::format("{} bytes with a VLAN tag", bytes.size())});
    }
    at += 4;
    ether_type = read_be16(bytes, at);
  }
  if (ether_type != kEtherType) {
    return Unexpected(
        DecodeError{FrameError::wrong_ethertype, at, fmt::format("EtherType {:04X}h", ether_type)});
  }
  at += 2;
  if (bytes.size() - at < kEthercatHeaderSize) {
    return Unexpected(DecodeError{FrameError::truncated_ethercat_header, at, {}});
  }
  const auto header = static_cast<std::uint16_t>(bytes[at] | (bytes[at + 1] << 8));
  const unsigned type = header >> 12;
  if (type != kTypeDatagrams) {
    return Unexpected(DecodeError{FrameError::unsupported_type, at, fmt::format("type {}", type)});
  }
  const std::size_t length = header & 0x07FF;
  at += kEthercatHeaderSize;
  if (length > bytes.size() - at) {
    return Unexpected(DecodeError{
        FrameError::length_past_end, at - kEthercatHeaderSize,
        fmt::format("length {}, {} bytes after the header", length, bytes.size() - at)});
  }
  return FrameLayout{at, length};
}

Expected<Frame, DecodeError> decode_frame(std::span<const std::uint8_t> bytes) {
  auto layout = parse_frame_layout(bytes);
  if (!layout) return Unexpected(layout.error());
  auto datagrams = decode_datagrams(bytes.subspan(layout->payload_offset, layout->payload_length),
                                    layout->payload_offset);
  if (!datagrams) return Unexpected(datagrams.error());
  Frame frame;
  std::copy_n(bytes.begin(), 6, frame.destination.begin());
  std::copy_n(bytes.begin() + 6, 6, frame.source.begin());
  frame.datagrams = std::move(*datagrams);
  frame.header_reserved = (bytes[layout->payload_offset - 1] & 0x08) != 0;
  return frame;
}

}  // namespace drivecheck::ethercat
