// Plain candump output, as a user copies it from a terminal, besides the `-L` log
// (protocol/can/candump_log.hpp). Each line is told apart by itself, so one file may mix them:
//
//   candump can0       "  can0  605   [8]  40 00 10 00 00 00 00 00"
//                      "  can0  12345678   [2]  DE AD"            (29-bit: 8 hex digits)
//                      "  can0  705   [1]  remote request"        (RTR, DLC 1)
//   candump -ta can0   "(1700000000.123456)  can0  605   [8]  40 00 10 00 00 00 00 00"
//                      (-td and -tz print the same with a relative time; read as such)
//   candump -L can0    "(1700000000.123456) can0 605#4000100000000000", as candump_log.hpp
//
// A plain line: optional "(seconds.fraction)", interface name (1..15 characters), the
// identifier in hex (3 digits: 11-bit, 8 digits: 29-bit), "[N]" with the DLC 0..8 (also
// "[08]"), then N data bytes as two hex digits each or "remote request"; the ASCII column of
// `candump -a` ("'@.......'") after the bytes is accepted and ignored. Blank lines and
// '#' comment lines are skipped, as in the `-L` reader.
#pragma once

#include <chrono>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/candump_log.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::can {

// The text between the parentheses of a candump timestamp, "1700000000.000100", as
// nanoseconds since the Unix epoch (the `-L` reader's rules; defined in candump_log.cpp).
Expected<std::chrono::nanoseconds, std::string> parse_candump_timestamp(std::string_view text);

// Which candump output a line came from.
enum class CandumpLineFormat : std::uint8_t {
  log,         // candump -L
  plain,       // candump (no time)
  timestamped  // candump -ta/-td/-tz
};

struct CandumpLine {
  LogRecord record;  // record.timestamp is 0 for a plain line without time
  CandumpLineFormat format = CandumpLineFormat::log;
  bool has_timestamp() const { return format != CandumpLineFormat::plain; }
};

// One record line in any of the three formats, detected from the line itself. The message of
// an error says what is wrong; the caller adds file:line.
Expected<CandumpLine, std::string> parse_candump_line(std::string_view line);

// Every line of a text: the records read, and each line that could not be read
// (file:line and why), in order. A bad line does not end the read.
struct CandumpText {
  std::vector<CandumpLine> lines;
  std::vector<TextError> bad_lines;
};
CandumpText read_candump_text(std::string_view text, std::string_view file = {});

}  // namespace drivecheck::can
