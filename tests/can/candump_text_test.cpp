// Plain candump output (candump, candump -ta) beside the -L log, told apart per line, and a
// whole text read past its bad lines.
#include "protocol/can/candump_text.hpp"

#include <gtest/gtest.h>

#include <string>

namespace drivecheck::can {
namespace {

using std::chrono::nanoseconds;

TEST(CandumpTextLine, ReadsPlainCandumpOutput) {
  // Given a line as `candump can0` prints it
  // When it is parsed
  // Then it is a plain record: interface, 11-bit frame, no time, no direction
  const auto line = parse_candump_line("  can0  605   [8]  40 00 10 00 00 00 00 00");
  ASSERT_TRUE(line) << line.error();
  EXPECT_EQ(line->format, CandumpLineFormat::plain);
  EXPECT_FALSE(line->has_timestamp());
  EXPECT_EQ(line->record.interface, "can0");
  EXPECT_EQ(line->record.frame, Frame::standard(0x605, {0x40, 0x00, 0x10, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(line->record.direction.has_value());
}

TEST(CandumpTextLine, ReadsAbsoluteTimestampOutput) {
  // Given a line as `candump -ta can0` prints it
  // When it is parsed / Then the time in front is the record's timestamp
  const auto line =
      parse_candump_line("(1700000000.123456)  can0  605   [8]  40 00 10 00 00 00 00 00");
  ASSERT_TRUE(line) << line.error();
  EXPECT_EQ(line->format, CandumpLineFormat::timestamped);
  EXPECT_EQ(line->record.timestamp, nanoseconds(1'700'000'000'123'456'000));
  EXPECT_EQ(line->record.frame, Frame::standard(0x605, {0x40, 0x00, 0x10, 0, 0, 0, 0, 0}));
}

TEST(CandumpTextLine, ReadsTheLogFormatAsBefore) {
  // Given a candump -L line / When parsed / Then it is the -L reader's record
  const auto line = parse_candump_line("(1700000000.000100) vcan0 605#2341600000000000 R");
  ASSERT_TRUE(line) << line.error();
  EXPECT_EQ(line->format, CandumpLineFormat::log);
  EXPECT_EQ(line->record,
            *parse_candump_log_line("(1700000000.000100) vcan0 605#2341600000000000 R"));
}

TEST(CandumpTextLine, ReadsExtendedRemoteEmptyAndAsciiColumn) {
  // Given 29-bit, RTR, zero-length and `candump -a` lines
  // When parsed / Then each is the frame it shows
  const auto extended = parse_candump_line("  can0  12345678   [2]  DE ad");
  ASSERT_TRUE(extended) << extended.error();
  EXPECT_EQ(extended->record.frame,
            Frame::extended(0x12345678, std::array<std::uint8_t, 2>{0xDE, 0xAD}));
  const auto remote = parse_candump_line("  can0  705   [1]  remote request");
  ASSERT_TRUE(remote) << remote.error();
  EXPECT_EQ(remote->record.frame, Frame::remote(0x705, 1));
  const auto empty = parse_candump_line("  can0  080   [0]");
  ASSERT_TRUE(empty) << empty.error();
  EXPECT_EQ(empty->record.frame, Frame::standard(0x080, {}));
  const auto ascii = parse_candump_line("  can0  185   [2]  41 20   'A '");
  ASSERT_TRUE(ascii) << ascii.error();
  EXPECT_EQ(ascii->record.frame, Frame::standard(0x185, {0x41, 0x20}));
}

TEST(CandumpTextLine, BadPlainLinesSayWhy) {
  // Given plain lines with a bad field each
  // When parsed / Then each error names the problem
  const std::pair<std::string, std::string> cases[] = {
      {"  can0  605   [8]  40 00 10", "3 data byte(s) after [8], 8 expected"},
      {"  can0  605   [2]  40 0G", "data byte 1: '0G' is not two hex digits"},
      {"  can0  805   [0]", "above 7FF"},
      {"  can0  6050  [0]", "3 hex digits (11-bit) or 8 hex digits (29-bit)"},
      {"  can0  605   [9]  00", "more than 8 bytes"},
      {"  can0  605   [1]  00 01", "unexpected '01' after the 1 data byte(s)"},
      {"hello world", "not a candump line"},
      {"(1700000000.1)  can0  605   [x]", "'x' is not a digit"},
      {"(17x)  can0  605   [0]", "timestamp"},
      {"(1700000000.000100) vcan0 605#0G", "data byte 0: 'G' is not a hex digit"},
  };
  for (const auto& [text, expected] : cases) {
    const auto line = parse_candump_line(text);
    ASSERT_FALSE(line) << text;
    EXPECT_NE(line.error().find(expected), std::string::npos) << text << " -> " << line.error();
  }
}

TEST(CandumpText, GoesOnPastBadLinesAndNamesThem) {
  // Given a text mixing the three formats, a comment and two bad lines
  const std::string text =
      "# from a terminal\n"
      "  can0  000   [2]  01 05\n"
      "(1700000000.000210)  can0  705   [1]  05\n"
      "  can0  705   [1]  0G\n"
      "(1700000000.001000) can0 080#\n"
      "garbage\n";
  // When read
  const auto read = read_candump_text(text, "t.txt");
  // Then the three good lines are records in order and the bad ones are t.txt:4 and t.txt:6
  ASSERT_EQ(read.lines.size(), 3u);
  EXPECT_EQ(read.lines[0].format, CandumpLineFormat::plain);
  EXPECT_EQ(read.lines[1].format, CandumpLineFormat::timestamped);
  EXPECT_EQ(read.lines[2].format, CandumpLineFormat::log);
  EXPECT_EQ(read.lines[2].record.frame, Frame::standard(0x080, {}));
  ASSERT_EQ(read.bad_lines.size(), 2u);
  EXPECT_EQ(read.bad_lines[0].to_string(), "t.txt:4: data byte 0: '0G' is not two hex digits");
  EXPECT_EQ(read.bad_lines[1].line, 6);
}

}  // namespace
}  // namespace drivecheck::can
