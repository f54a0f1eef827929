// A classic CAN frame (ISO 11898-1) as a value, and its candump compact text form.
//
// Compact syntax (can-utils `lib.h`, the one way drivecheck prints and parses frames):
//
//   605#2341600000000000     11-bit id: exactly 3 hex digits, then '#', then 0..8 data bytes
//   12345678#DEADBEEF        29-bit id: exactly 8 hex digits
//   704#R                    remote request, DLC 0
//   704#R3                   remote request, DLC 3
//   605#11.22.33             '.' between bytes is allowed when parsing, never printed
//   605#1122334455667788_B   DLC 9..15 (carries 8 bytes), "len8_dlc" of can-utils
//   20000080#0000000000000000  error frame: 8 hex digits with CAN_ERR_FLAG (bit 29) set;
//                            the remaining id bits are the error class (linux/can/error.h)
//
// CAN FD ("##") is not classic CAN and is rejected with a clear message.
#pragma once

#include <fmt/format.h>

#include <array>
#include <cstdint>
#include <initializer_list>
#include <span>
#include <string>
#include <string_view>

#include "protocol/common/expected.hpp"

namespace drivecheck::can {

inline constexpr std::uint32_t kMaxStandardId = 0x7FF;
inline constexpr std::uint32_t kMaxExtendedId = 0x1FFFFFFF;
inline constexpr std::uint32_t kErrorFlag = 0x20000000;  // CAN_ERR_FLAG in a can_id
inline constexpr std::uint32_t kErrorClassMask = 0x1FFFFFFF;

enum class IdFormat : std::uint8_t { standard, extended };
enum class FrameKind : std::uint8_t { data, remote, error };

struct Frame {
  // 11-bit or 29-bit identifier; for error frames the error class bits (CAN_ERR_*).
  std::uint32_t id = 0;
  IdFormat format = IdFormat::standard;
  FrameKind kind = FrameKind::data;
  // Data length code as on the wire: 0..8, or 9..15 meaning 8 bytes (classic CAN).
  std::uint8_t dlc = 0;
  // Payload; bytes past length() are always zero so that == compares the frame, not junk.
  std::array<std::uint8_t, 8> data{};

  // Number of data bytes the frame carries (0 for remote and by DLC for data frames).
  std::size_t length() const { return kind == FrameKind::remote ? 0 : (dlc > 8 ? 8 : dlc); }
  std::span<const std::uint8_t> payload() const { return {data.data(), length()}; }
  bool is_extended() const { return format == IdFormat::extended; }
  bool is_remote() const { return kind == FrameKind::remote; }
  bool is_error() const { return kind == FrameKind::error; }

  // An 11-bit data frame. Precondition: id <= 0x7FF, bytes.size() <= 8.
  static Frame standard(std::uint32_t id, std::span<const std::uint8_t> bytes);
  static Frame standard(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
    return standard(id, std::span<const std::uint8_t>(bytes.begin(), bytes.size()));
  }
  // A 29-bit data frame. Precondition: id <= 0x1FFFFFFF, bytes.size() <= 8.
  static Frame extended(std::uint32_t id, std::span<const std::uint8_t> bytes);
  // A remote transmission request (RTR) frame with the given DLC (0..8).
  static Frame remote(std::uint32_t id, std::uint8_t dlc = 0, IdFormat format = IdFormat::standard);

  friend bool operator==(const Frame&, const Frame&) = default;
};

// Compact candump text of a frame: "605#2341600000000000".
std::string to_candump(const Frame& frame);

// Parses compact candump text. The message of an error says what is wrong and where
// ("data byte 3: 'G' is not a hex digit"); the caller adds file:line.
Expected<Frame, std::string> parse_candump(std::string_view text);

}  // namespace drivecheck::can

template <>
struct fmt::formatter<drivecheck::can::Frame> : fmt::formatter<std::string_view> {
  template <class FormatContext>
  auto format(const drivecheck::can::Frame& frame, FormatContext& ctx) const {
    return fmt::formatter<std::string_view>::format(drivecheck::can::to_candump(frame), ctx);
  }
};
