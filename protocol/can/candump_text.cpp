#include "protocol/can/candump_text.hpp"

#include <fmt/format.h>

#include <array>
#include <cstdint>
#include <optional>

namespace drivecheck::can {
namespace {

constexpr std::size_t kMaxQuoted = 40;

bool is_blank(char c) {
  return c == ' ' || c == '\t';
}

std::string quote(std::string_view text) {
  if (text.size() <= kMaxQuoted) return fmt::format("'{}'", text);
  return fmt::format("'{}...' ({} characters)", text.substr(0, kMaxQuoted), text.size());
}

std::string_view trim(std::string_view text) {
  while (!text.empty() && (is_blank(text.front()) || text.front() == '\r'))
    text.remove_prefix(1);
  while (!text.empty() && (is_blank(text.back()) || text.back() == '\r'))
    text.remove_suffix(1);
  return text;
}

std::optional<unsigned> hex_digit(char c) {
  if (c >= '0' && c <= '9') return static_cast<unsigned>(c - '0');
  if (c >= 'A' && c <= 'F') return static_cast<unsigned>(c - 'A' + 10);
  if (c >= 'a' && c <= 'f') return static_cast<unsigned>(c - 'a' + 10);
  return std::nullopt;
}

// The next blank-separated field of `text` from `pos` ("" at the end).
std::string_view next_field(std::string_view text, std::size_t& pos) {
  while (pos < text.size() && is_blank(text[pos]))
    ++pos;
  const std::size_t start = pos;
  while (pos < text.size() && !is_blank(text[pos]))
    ++pos;
  return text.substr(start, pos - start);
}

constexpr std::string_view kFormats =
    "a candump line reads '  can0  605   [2]  40 00' (candump), the same after "
    "'(1700000000.000100)' (candump -ta) or '(1700000000.000100) can0 605#4000' (candump -L)";

// "  can0  605   [8]  40 00 ..." after the optional timestamp.
Expected<Frame, std::string> parse_plain_frame(std::string_view text, std::string& interface) {
  std::size_t pos = 0;
  const auto name = next_field(text, pos);
  if (name.empty()) return Unexpected(std::string("missing interface name"));
  if (name.size() > kMaxInterfaceNameLength) {
    return Unexpected(fmt::format("interface name {} is longer than {} characters", quote(name),
                                  kMaxInterfaceNameLength));
  }
  interface = std::string(name);
  const auto id_text = next_field(text, pos);
  if (id_text.empty()) {
    return Unexpected(fmt::format("missing identifier after the interface name {}", quote(name)));
  }
  if (id_text.size() != 3 && id_text.size() != 8) {
    return Unexpected(fmt::format(
        "identifier {}: 3 hex digits (11-bit) or 8 hex digits (29-bit) expected", quote(id_text)));
  }
  std::uint32_t id = 0;
  for (char c : id_text) {
    const auto digit = hex_digit(c);
    if (!digit) {
      return Unexpected(fmt::format("identifier {}: '{}' is not a hex digit", quote(id_text), c));
    }
    id = id << 4 | *digit;
  }
  const bool extended = id_text.size() == 8;
  if (!extended && id > kMaxStandardId) {
    return Unexpected(
        fmt::format("identifier {} is above 7FF, the largest 11-bit one", quote(id_text)));
  }
  if (extended && id > kMaxExtendedId) {
    return Unexpected(
        fmt::format("identifier {} is above 1FFFFFFF, the largest 29-bit one", quote(id_text)));
  }
  const auto dlc_text = next_field(text, pos);
  if (dlc_text.size() < 3 || dlc_text.size() > 4 || dlc_text.front() != '[' ||
      dlc_text.back() != ']') {
    return Unexpected(
        fmt::format("expected the length '[N]' after the identifier, found {}",
                    dlc_text.empty() ? std::string("the end of the line") : quote(dlc_text)));
  }
  unsigned dlc = 0;
  for (char c : dlc_text.substr(1, dlc_text.size() - 2)) {
    if (c < '0' || c > '9') {
      return Unexpected(fmt::format("length {}: '{}' is not a digit", quote(dlc_text), c));
    }
    dlc = dlc * 10 + static_cast<unsigned>(c - '0');
  }
  if (dlc > 8) {
    return Unexpected(
        fmt::format("length {}: more than 8 bytes (CAN FD) is not read", quote(dlc_text)));
  }
  const auto format = extended ? IdFormat::extended : IdFormat::standard;
  const std::size_t after_dlc = pos;
  if (next_field(text, pos) == "remote" && next_field(text, pos) == "request") {
    if (!trim(text.substr(pos)).empty()) {
      return Unexpected(
          fmt::format("unexpected {} after 'remote request'", quote(trim(text.substr(pos)))));
    }
    return Frame::remote(id, static_cast<std::uint8_t>(dlc), format);
  }
  pos = after_dlc;
  std::array<std::uint8_t, 8> bytes{};
  for (unsigned i = 0; i < dlc; ++i) {
    const auto byte = next_field(text, pos);
    if (byte.empty()) {
      return Unexpected(fmt::format("{} data byte(s) after {}, {} expected", i, dlc_text, dlc));
    }
    const auto high = byte.size() == 2 ? hex_digit(byte[0]) : std::nullopt;
    const auto low = byte.size() == 2 ? hex_digit(byte[1]) : std::nullopt;
    if (!high || !low) {
      return Unexpected(fmt::format("data byte {}: {} is not two hex digits", i, quote(byte)));
    }
    bytes[i] = static_cast<std::uint8_t>(*high << 4 | *low);
  }
  const auto rest = trim(text.substr(pos));
  // candump -a: the bytes as ASCII in quotes.
  if (!rest.empty() && !(rest.size() >= 2 && rest.front() == '\'' && rest.back() == '\'')) {
    return Unexpected(
        fmt::format("unexpected {} after the {} data byte(s) of {}", quote(rest), dlc, dlc_text));
  }
  const std::span<const std::uint8_t> payload(bytes.data(), dlc);
  return extended ? Frame::extended(id, payload) : Frame::standard(id, payload);
}

}  // namespace

Expected<CandumpLine, std::string> parse_candump_line(std::string_view line) {
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (c == '\t' || (c == '\r' && i + 1 == line.size())) continue;
    if (c < 0x20 || c >= 0x7F) {
      // The -L reader's own message (column and byte).
      auto error = parse_candump_log_line(line);
      return Unexpected(error ? std::string("not printable ASCII") : std::move(error).error());
    }
  }
  const std::string_view content = trim(line);
  CandumpLine result;
  std::string_view rest = content;
  if (!content.empty() && content.front() == '(') {
    const auto close = content.find(')');
    rest = close == std::string_view::npos ? std::string_view() : content.substr(close + 1);
    // candump -L has the frame as "ID#DATA" in its second field; -ta has "[N]" in its third.
    std::size_t pos = 0;
    next_field(rest, pos);
    next_field(rest, pos);
    const auto third = next_field(rest, pos);
    if (close == std::string_view::npos || third.empty() || third.front() != '[') {
      auto record = parse_candump_log_line(line);
      if (!record) return Unexpected(std::move(record).error());
      result.record = std::move(*record);
      result.format = CandumpLineFormat::log;
      return result;
    }
    if (!rest.empty() && !is_blank(rest.front())) {
      return Unexpected(fmt::format("expected a blank after ')', found '{}'", rest.front()));
    }
    auto timestamp = parse_candump_timestamp(content.substr(1, close - 1));
    if (!timestamp) return Unexpected(std::move(timestamp).error());
    result.record.timestamp = *timestamp;
    result.format = CandumpLineFormat::timestamped;
  } else {
    result.format = CandumpLineFormat::plain;
    std::size_t pos = 0;
    next_field(rest, pos);
    next_field(rest, pos);
    const auto third = next_field(rest, pos);
    if (third.empty() || third.front() != '[') {
      return Unexpected(fmt::format("not a candump line: {}", kFormats));
    }
  }
  auto frame = parse_plain_frame(rest, result.record.interface);
  if (!frame) return Unexpected(std::move(frame).error());
  result.record.frame = *frame;
  return result;
}

CandumpText read_candump_text(std::string_view text, std::string_view file) {
  CandumpText result;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  int line_number = 0;
  while (!text.empty()) {
    ++line_number;
    const auto end = text.find('\n');
    const std::string_view line = text.substr(0, end);
    text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
    const std::string_view content = trim(line);
    if (content.empty() || content.front() == '#') continue;
    auto parsed = parse_candump_line(line);
    if (!parsed) {
      result.bad_lines.push_back(
          TextError{std::string(file), line_number, std::move(parsed).error()});
      continue;
    }
    result.lines.push_back(std::move(*parsed));
  }
  return result;
}

}  // namespace drivecheck::can
