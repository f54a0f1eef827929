#include "protocol/can/frame.hpp"

#include <fmt/compile.h>

#include <algorithm>
#include <cassert>

namespace drivecheck::can {
namespace {

constexpr char kHexDigits[] = "0123456789ABCDEF";

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// Appends `value` in upper-case hex with at least `width` digits (fmt's "{:0<width>X}"),
// without going through a format string: to_candump runs for every frame of a log.
void append_hex(std::string& text, std::uint32_t value, int width) {
  char digits[8];
  int count = 0;
  do {
    digits[count++] = kHexDigits[value & 0xF];
    value >>= 4;
  } while (value != 0);
  for (int i = count; i < width; ++i)
    text += '0';
  while (count > 0)
    text += digits[--count];
}

std::string describe_char(char c) {
  if (c >= 0x20 && c < 0x7F) return fmt::format(FMT_COMPILE("'{}'"), c);
  return fmt::format(FMT_COMPILE("byte 0x{:02X}"), static_cast<unsigned char>(c));
}

Frame data_frame(std::uint32_t id, IdFormat format, std::span<const std::uint8_t> bytes) {
  assert(bytes.size() <= 8);
  Frame frame;
  frame.id = id;
  frame.format = format;
  frame.dlc = static_cast<std::uint8_t>(std::min<std::size_t>(bytes.size(), 8));
  std::copy_n(bytes.begin(), frame.dlc, frame.data.begin());
  return frame;
}

}  // namespace

Frame Frame::standard(std::uint32_t id, std::span<const std::uint8_t> bytes) {
  assert(id <= kMaxStandardId);
  return data_frame(id, IdFormat::standard, bytes);
}

Frame Frame::extended(std::uint32_t id, std::span<const std::uint8_t> bytes) {
  assert(id <= kMaxExtendedId);
  return data_frame(id, IdFormat::extended, bytes);
}

Frame Frame::remote(std::uint32_t id, std::uint8_t dlc, IdFormat format) {
  assert(dlc <= 8);
  Frame frame;
  frame.id = id;
  frame.format = format;
  frame.kind = FrameKind::remote;
  frame.dlc = dlc;
  return frame;
}

std::string to_candump(const Frame& frame) {
  std::string text;
  text.reserve(3 + 1 + 16 + 2);
  if (frame.is_error()) {
    append_hex(text, kErrorFlag | (frame.id & kErrorClassMask), 8);
  } else if (frame.is_extended()) {
    append_hex(text, frame.id & kMaxExtendedId, 8);
  } else {
    append_hex(text, frame.id & kMaxStandardId, 3);
  }
  text += '#';
  if (frame.is_remote()) {
    text += 'R';
    if (frame.dlc != 0) text += kHexDigits[frame.dlc & 0xF];
    return text;
  }
  for (std::uint8_t byte : frame.payload()) {
    text += kHexDigits[byte >> 4];
    text += kHexDigits[byte & 0xF];
  }
  if (frame.dlc > 8) {
    text += '_';
    text += kHexDigits[frame.dlc & 0xF];
  }
  return text;
}

Expected<Frame, std::string> parse_candump(std::string_view text) {
  const auto hash = text.find('#');
  if (hash == std::string_view::npos) {
    return Unexpected(
        fmt::format(FMT_COMPILE("'{}' is not a CAN frame: no '#' between id and data"), text));
  }
  const std::string_view id_text = text.substr(0, hash);
  std::string_view rest = text.substr(hash + 1);
  if (!rest.empty() && rest.front() == '#') {
    return Unexpected(
        std::string("CAN FD frames ('##') are not supported: drivecheck is classic CAN"));
  }
  if (id_text.size() != 3 && id_text.size() != 8) {
    return Unexpected(fmt::format(
        FMT_COMPILE(
            "identifier '{}' has {} hex digits: use 3 for an 11-bit id or 8 for a 29-bit id"),
        id_text, id_text.size()));
  }
  std::uint32_t id = 0;
  for (char c : id_text) {
    const int v = hex_value(c);
    if (v < 0)
      return Unexpected(
          fmt::format(FMT_COMPILE("identifier: {} is not a hex digit"), describe_char(c)));
    id = (id << 4) | static_cast<std::uint32_t>(v);
  }

  Frame frame;
  if (id_text.size() == 3) {
    if (id > kMaxStandardId) {
      return Unexpected(fmt::format(FMT_COMPILE("11-bit identifier {:03X} is above 7FF"), id));
    }
    frame.id = id;
  } else if ((id & kErrorFlag) != 0) {
    frame.kind = FrameKind::error;
    frame.format = IdFormat::extended;
    frame.id = id & kErrorClassMask;
    if ((id & ~(kErrorFlag | kErrorClassMask)) != 0) {
      return Unexpected(
          fmt::format(FMT_COMPILE("error frame id {:08X} has flag bits above bit 29 set"), id));
    }
  } else {
    if ((id & ~kMaxExtendedId) != 0) {
      return Unexpected(
          fmt::format(FMT_COMPILE("29-bit identifier {:08X} has bits above bit 28 set"), id));
    }
    frame.id = id;
    frame.format = IdFormat::extended;
  }

  if (!rest.empty() && (rest.front() == 'R' || rest.front() == 'r')) {
    if (frame.is_error())
      return Unexpected(std::string("an error frame cannot be a remote request"));
    frame.kind = FrameKind::remote;
    rest.remove_prefix(1);
    if (rest.empty()) return frame;
    const int v = hex_value(rest.front());
    if (rest.size() != 1 || v < 0 || v > 8) {
      return Unexpected(
          fmt::format(FMT_COMPILE("remote request DLC '{}' is not a single digit 0..8"), rest));
    }
    frame.dlc = static_cast<std::uint8_t>(v);
    return frame;
  }

  std::size_t count = 0;
  std::size_t pos = 0;
  while (pos < rest.size() && rest[pos] != '_') {
    if (rest[pos] == '.') {
      ++pos;
      continue;
    }
    if (count == 8) return Unexpected(std::string("more than 8 data bytes in a classic CAN frame"));
    if (pos + 1 >= rest.size() || rest[pos + 1] == '_' || rest[pos + 1] == '.') {
      return Unexpected(fmt::format(FMT_COMPILE("data byte {}: odd number of hex digits"), count));
    }
    const int hi = hex_value(rest[pos]);
    const int lo = hex_value(rest[pos + 1]);
    if (hi < 0 || lo < 0) {
      return Unexpected(fmt::format(FMT_COMPILE("data byte {}: {} is not a hex digit"), count,
                                    describe_char(hi < 0 ? rest[pos] : rest[pos + 1])));
    }
    frame.data[count++] = static_cast<std::uint8_t>((hi << 4) | lo);
    pos += 2;
  }
  frame.dlc = static_cast<std::uint8_t>(count);
  if (pos < rest.size()) {  // '_' DLC suffix
    const std::string_view suffix = rest.substr(pos + 1);
    const int v = suffix.size() == 1 ? hex_value(suffix.front()) : -1;
    if (v < 9 || count != 8) {
      return Unexpected(fmt::format(
          FMT_COMPILE(
              "DLC suffix '_{}' is only valid after 8 data bytes and must be one hex digit 9..F"),
          suffix));
    }
    frame.dlc = static_cast<std::uint8_t>(v);
  }
  return frame;
}

}  // namespace drivecheck::can
