// Text helpers every writer shares: untrusted strings made valid UTF-8 and printable, and the
// transcript line of one evidence frame.
#include <fmt/format.h>

#include <cstdint>
#include <string>
#include <string_view>

#include "reports/report_writers.hpp"

namespace drivecheck::reports {
namespace {

constexpr std::string_view kReplacement = "\xEF\xBF\xBD";  // U+FFFD

// Length of the valid UTF-8 sequence starting at text[i], 0 if it is invalid (RFC 3629:
// no overlong forms, no surrogates, nothing above U+10FFFF).
std::size_t utf8_sequence_length(std::string_view text, std::size_t i) {
  const auto byte = [&](std::size_t k) { return static_cast<std::uint8_t>(text[k]); };
  const std::uint8_t lead = byte(i);
  if (lead < 0x80) return 1;
  std::size_t length = 0;
  std::uint8_t low = 0x80;
  std::uint8_t high = 0xBF;
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    if (lead == 0xE0) low = 0xA0;   // overlong
    if (lead == 0xED) high = 0x9F;  // surrogates
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    if (lead == 0xF0) low = 0x90;   // overlong
    if (lead == 0xF4) high = 0x8F;  // above U+10FFFF
  } else {
    return 0;
  }
  if (i + length > text.size()) return 0;
  for (std::size_t k = 1; k < length; ++k) {
    const std::uint8_t b = byte(i + k);
    const std::uint8_t lo = k == 1 ? low : std::uint8_t{0x80};
    const std::uint8_t hi = k == 1 ? high : std::uint8_t{0xBF};
    if (b < lo || b > hi) return 0;
  }
  return length;
}

}  // namespace

std::string to_valid_utf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  std::size_t i = 0;
  while (i < text.size()) {
    const std::size_t length = utf8_sequence_length(text, i);
    if (length == 0) {
      out += kReplacement;
      ++i;
    } else {
      out.append(text.substr(i, length));
      i += length;
    }
  }
  return out;
}

std::string printable_text(std::string_view text) {
  const std::string valid = to_valid_utf8(text);
  std::string out;
  out.reserve(valid.size());
  for (const char c : valid) {
    const auto byte = static_cast<std::uint8_t>(c);
    if ((byte < 0x20 && c != '\n' && c != '\t') || byte == 0x7F) {
      out += fmt::format("\\x{:02X}", byte);
    } else {
      out += c;
    }
  }
  return out;
}

std::string_view first_line(std::string_view text) {
  std::string_view line = text.substr(0, text.find('\n'));
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  return line;
}

std::string transcript_line(const conformance::EvidenceFrame& frame, can::TimePoint start) {
  const std::int64_t ns = (frame.at - start).count();
  const char* sign = ns < 0 ? "-" : "";
  const std::int64_t magnitude = ns < 0 ? -ns : ns;
  const std::string seconds = fmt::format("{}{}", sign, magnitude / 1'000'000'000);
  std::string line =
      fmt::format("({:>4}.{:06}) {} {:<20}", seconds, magnitude % 1'000'000'000 / 1000,
                  frame.from_harness ? "tx" : "rx", can::to_candump(frame.frame));
  if (!frame.decoded.empty()) line += " → " + frame.decoded;
  return line;
}

namespace {
std::string relative_time(can::TimePoint at, can::TimePoint start) {
  const std::int64_t ns = (at - start).count();
  const char* sign = ns < 0 ? "-" : "";
  const std::int64_t magnitude = ns < 0 ? -ns : ns;
  return fmt::format("{}{}.{:06}", sign, magnitude / 1'000'000'000,
                     magnitude % 1'000'000'000 / 1000);
}
}  // namespace

std::string transcript_line(const conformance::EvidenceDatagram& datagram, can::TimePoint start) {
  std::string line =
      fmt::format("({:>11}) {}", relative_time(datagram.at, start), datagram.decoded);
  if (datagram.count > 1)
    line += fmt::format("  ×{} (to {})", datagram.count, relative_time(datagram.last, start));
  return line;
}

std::string repeat_line(const conformance::EvidenceRepeat& repeat, can::TimePoint start,
                        std::string_view entries) {
  return fmt::format(
      "   ↻ the {} {} above came {} more time(s) in a row until ({:>11}), left out; the last "
      "time follows",
      repeat.length, entries, repeat.times, relative_time(repeat.until, start));
}

std::string datagram_transcript(const conformance::VectorResult& vector) {
  std::string out;
  RepeatLines repeats;
  for (std::size_t i = 0; i < vector.datagrams.size(); ++i) {
    if (vector.datagrams_elided != 0 && i == vector.datagrams_elided_at)
      out += fmt::format(
          "   … {} datagram entries not kept in this report (the run's --pcap has every "
          "frame) …\n",
          vector.datagrams_elided);
    if (const auto* repeat = repeats.before(i))
      out += repeat_line(*repeat, vector.started, "datagram entries") + '\n';
    out += transcript_line(vector.datagrams[i], vector.started);
    out += '\n';
    repeats.after(i, vector.datagrams[i].repeat);
  }
  return out;
}

std::string elided_line(std::size_t count) {
  return fmt::format(
      "   … {} frame(s) not kept in this report (the run's --trace log has every "
      "frame) …",
      count);
}

}  // namespace drivecheck::reports

namespace drivecheck::reports {

const conformance::CitedDocument* cited_document(const conformance::RunInfo& info,
                                                 std::string_view source) {
  const conformance::CitedDocument* best = nullptr;
  for (const auto& document : info.documents) {
    const std::string_view key = document.key;
    if (key.empty() || !source.starts_with(key)) continue;
    // "CiA 402" must not claim "CiA 4021": the key ends at a word boundary.
    if (source.size() > key.size() && source[key.size()] != ' ' && source[key.size()] != ',')
      continue;
    if (best == nullptr || best->key.size() < key.size()) best = &document;
  }
  return best;
}

std::string citation_text(const conformance::RunInfo& info, std::string_view source) {
  const conformance::CitedDocument* document = cited_document(info, source);
  if (document == nullptr) return std::string(source);
  std::string text = std::string(source) + " (" + document->title;
  if (!document->edition.empty()) text += ", " + document->edition;
  return text + ")";
}

std::string clause_of(std::string_view source) {
  const auto mark = source.find("§");
  if (mark == std::string_view::npos) {
    const auto end = source.find(" L");
    return std::string(source.substr(0, end));
  }
  std::size_t end = mark + std::string_view("§").size();
  while (end < source.size() && source[end] != ' ' && source[end] != ',' && source[end] != ';')
    ++end;
  std::string_view document = source.substr(0, mark);
  while (!document.empty() && document.back() == ' ')
    document.remove_suffix(1);
  return std::string(document) + " " + std::string(source.substr(mark, end - mark));
}

}  // namespace drivecheck::reports
