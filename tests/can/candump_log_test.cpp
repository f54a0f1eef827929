#include "protocol/can/candump_log.hpp"

#include <gtest/gtest.h>

#include <random>
#include <string>

#include "tests/support/temp_dir.hpp"

namespace drivecheck::can {
namespace {

using std::chrono::nanoseconds;
using namespace std::chrono_literals;

TEST(CandumpLogLine, ParsesRecordWithoutDirection) {
  // Given a candump -L line as can-utils writes it
  // When it is parsed
  // Then timestamp, interface and frame are those of the line and there is no direction
  // SDO rx node 5: ccs=1 e=1 s=1 n=0, index 6041h sub 0, data 0
  const auto record = parse_candump_log_line("(1700000000.000100) vcan0 605#2341600000000000");
  ASSERT_TRUE(record) << record.error();
  EXPECT_EQ(record->timestamp, nanoseconds(1'700'000'000'000'100'000));
  EXPECT_EQ(record->interface, "vcan0");
  EXPECT_EQ(record->frame, Frame::standard(0x605, {0x23, 0x41, 0x60, 0, 0, 0, 0, 0}));
  EXPECT_FALSE(record->direction.has_value());
}

TEST(CandumpLogLine, ParsesDirectionFlags) {
  // Given lines with the R and T flags of newer can-utils
  // When parsed
  // Then the flags become receive and transmit
  // heartbeat node 5: state 05h operational
  const auto rx = parse_candump_log_line("(1700000000.000100) can0 705#05 R");
  const auto tx = parse_candump_log_line("(1700000000.000100) can0 705#05 T");
  ASSERT_TRUE(rx) << rx.error();
  ASSERT_TRUE(tx) << tx.error();
  EXPECT_EQ(rx->direction, TraceDirection::receive);
  EXPECT_EQ(tx->direction, TraceDirection::transmit);
}

TEST(CandumpLogLine, WritesExactlySixFractionalDigits) {
  // Given records with nanosecond timestamps
  // When formatted
  // Then seconds are padded to 10 digits and the fraction is 6 digits, truncated (not rounded)
  LogRecord record{nanoseconds(1'700'000'000'000'100'999), "vcan0",
                   Frame::standard(0x080, std::span<const std::uint8_t>{}), std::nullopt};
  // SYNC without counter
  EXPECT_EQ(to_candump_log(record), "(1700000000.000100) vcan0 080#");
  record.timestamp = nanoseconds(1'500'000'000);
  record.direction = TraceDirection::transmit;
  EXPECT_EQ(to_candump_log(record), "(0000000001.500000) vcan0 080# T");
  record.direction = TraceDirection::receive;
  record.timestamp = nanoseconds(0);
  EXPECT_EQ(to_candump_log(record), "(0000000000.000000) vcan0 080# R");
}

TEST(CandumpLogLine, NegativeTimestampIsWrittenVisiblyAndRejectedOnRead) {
  // Given a record with a negative timestamp (a precondition violation)
  // When formatted and parsed again
  // Then the text shows the sign and the reader rejects it
  const LogRecord record{nanoseconds(-1'500'000'000), "vcan0", Frame::standard(0x000, {0x01, 0x05}),
                         std::nullopt};
  const std::string line = to_candump_log(record);
  EXPECT_EQ(line, "(-0000000001.500000) vcan0 000#0105");
  const auto parsed = parse_candump_log_line(line);
  ASSERT_FALSE(parsed);
  EXPECT_NE(parsed.error().find("negative"), std::string::npos) << parsed.error();
}

TEST(CandumpLogLine, FormatThenParseRoundTrips) {
  // Given records of every frame shape, with and without direction, microsecond timestamps
  // When each is formatted and parsed back
  // Then the record is unchanged
  const char* frames[] = {"000#0105",
                          "080#",
                          "704#R",
                          "1FFFFFFF#R8",
                          "12345678#DEADBEEF",
                          "20000080#0000000000000000",
                          "123#1122334455667788_C",
                          "7FF#FF"};
  const std::optional<TraceDirection> directions[] = {std::nullopt, TraceDirection::receive,
                                                      TraceDirection::transmit};
  std::int64_t micros = 1'700'000'000'000'000;
  for (const char* text : frames) {
    for (const auto& direction : directions) {
      const auto frame = parse_candump(text);
      ASSERT_TRUE(frame) << text;
      const LogRecord record{nanoseconds(micros * 1000), "can1", *frame, direction};
      micros += 1234567;
      const auto back = parse_candump_log_line(to_candump_log(record));
      ASSERT_TRUE(back) << to_candump_log(record) << ": " << back.error();
      EXPECT_EQ(*back, record) << to_candump_log(record);
    }
  }
}

TEST(CandumpLogLine, ToleratesOtherFractionDigitCounts) {
  // Given timestamps with 0, 1, 3, 9 and 13 fractional digits
  // When parsed
  // Then each means the same decimal fraction, truncated below a nanosecond
  const std::pair<const char*, std::int64_t> cases[] = {
      {"(1700000000) can0 080#", 1'700'000'000'000'000'000},
      {"(1700000000.1) can0 080#", 1'700'000'000'100'000'000},
      {"(1700000000.123) can0 080#", 1'700'000'000'123'000'000},
      {"(1700000000.123456789) can0 080#", 1'700'000'000'123'456'789},
      {"(1700000000.1234567891234) can0 080#", 1'700'000'000'123'456'789},
      {"(0.000001) can0 080#", 1'000},
      {"(9223372035.999999999) can0 080#", 9'223'372'035'999'999'999},
  };
  for (const auto& [line, ns] : cases) {
    const auto record = parse_candump_log_line(line);
    ASSERT_TRUE(record) << line << ": " << record.error();
    EXPECT_EQ(record->timestamp.count(), ns) << line;
  }
}

TEST(CandumpLogLine, ToleratesBlanksAndCarriageReturn) {
  // Given a line with tabs, runs of spaces, leading/trailing blanks and a CR line end
  // When parsed
  // Then it reads as the plain line does
  const auto record = parse_candump_log_line("  (1.000000)\tcan0   181#0102  T \r");
  ASSERT_TRUE(record) << record.error();
  EXPECT_EQ(record->interface, "can0");
  EXPECT_EQ(to_candump(record->frame), "181#0102");
  EXPECT_EQ(record->direction, TraceDirection::transmit);
}

TEST(CandumpLogLine, RejectsMalformedLines) {
  // Given malformed record lines
  // When parsed
  // Then each gives an error naming the problem, never a record
  const std::pair<std::string, const char*> cases[] = {
      {"", "missing '('"},
      {"1700000000.000100) vcan0 605#00", "missing '('"},
      {"(1700000000.000100 vcan0 605#00", "missing ')'"},
      {"(-1.000000) vcan0 605#00", "negative timestamp"},
      {"() vcan0 605#00", "empty timestamp"},
      {"(.5) vcan0 605#00", "no seconds"},
      {"(1.) vcan0 605#00", "no digits after '.'"},
      {"(1.0x) vcan0 605#00", "'x' is not a digit"},
      {"(1e9) vcan0 605#00", "'e' is not a digit"},
      {"(+1.0) vcan0 605#00", "'+' is not a digit"},
      {"(1.0.0) vcan0 605#00", "'.' is not a digit"},
      {"(99999999999999999999.0) vcan0 605#00", "out of range"},
      {"(9223372036.000000) vcan0 605#00", "out of range"},
      {"(18446744073709551616.000000) vcan0 605#00", "out of range"},
      {"(1.000000)vcan0 605#00", "blank after ')'"},
      {"(1.000000)", "missing interface name and frame"},
      {"(1.000000)   ", "missing interface name and frame"},
      {"(1.000000) 605#00", "missing interface name before the frame"},
      {"(1.000000) 605#00 R", "missing interface name before the frame"},
      {"(1.000000) vcan0", "missing frame after the interface name"},
      {"(1.000000) vcan0 605#0", "odd number of hex digits"},
      {"(1.000000) vcan0 605", "no '#'"},
      {"(1.000000) vcan0 605##0", "CAN FD"},
      {"(1.000000) vcan0 605#00 X", "direction flag 'X' is not R or T"},
      {"(1.000000) vcan0 605#00 r", "direction flag 'r' is not R or T"},
      {"(1.000000) vcan0 605#00 R extra", "unexpected 'extra'"},
      {"(1.000000) averyveryverylongname 605#00", "longer than 15 characters"},
      {"(1.000000) vcan0 605#00\xC3\xA9", "byte 0xC3 is not printable ASCII"},
      {std::string("(1.000000) vcan0\0 605#00", 24), "byte 0x00 is not printable ASCII"},
      {"(1.000000) vcan0 605#00\r\r", "byte 0x0D"},
      {"(1.000000) vcan0 \x7F"
       "605#00",
       "byte 0x7F"},
  };
  for (const auto& [line, expected] : cases) {
    const auto record = parse_candump_log_line(line);
    ASSERT_FALSE(record) << "accepted: " << line;
    EXPECT_NE(record.error().find(expected), std::string::npos)
        << line << "\n  error: " << record.error() << "\n  expected: " << expected;
  }
}

TEST(CandumpLogLine, HugeNumbersGiveShortMessages) {
  // Given a timestamp of a million digits, and one of a million leading zeros
  // When parsed
  // Then the first is out of range with a short message, the second is an ordinary time
  const std::string huge = "(" + std::string(1'000'000, '9') + ".0) can0 080#";
  const auto record = parse_candump_log_line(huge);
  ASSERT_FALSE(record);
  EXPECT_NE(record.error().find("out of range"), std::string::npos);
  EXPECT_LT(record.error().size(), 200u);
  const std::string zeros = "(" + std::string(1'000'000, '0') + "7.5) can0 080#";
  const auto small = parse_candump_log_line(zeros);
  ASSERT_TRUE(small) << small.error();
  EXPECT_EQ(small->timestamp, 7500ms);
}

TEST(CandumpLogLine, RandomBytesNeverCrashAndAcceptedLinesRoundTrip) {
  // Given 20000 lines mutated from a valid record at random (fixed seed)
  // When each is parsed
  // Then the parser answers a record or a non-empty error, and every accepted record
  //      formats to a line that parses to the same record (up to microseconds)
  std::mt19937_64 random(20240601);
  const std::string base = "(1700000000.000100) vcan0 605#2341600000000000 R";
  int accepted = 0;
  for (int i = 0; i < 20000; ++i) {
    std::string line = base;
    const int edits = 1 + static_cast<int>(random() % 4);
    for (int e = 0; e < edits; ++e) {
      const std::size_t pos = random() % (line.size() + 1);
      const char byte = static_cast<char>(random() & 0xFF);
      switch (random() % 3) {
        case 0:
          if (pos < line.size()) line[pos] = byte;
          break;
        case 1:
          line.insert(pos, 1, byte);
          break;
        default:
          if (pos < line.size()) line.erase(pos, 1);
      }
    }
    const auto record = parse_candump_log_line(line);
    if (!record) {
      EXPECT_FALSE(record.error().empty()) << line;
      continue;
    }
    ++accepted;
    LogRecord truncated = *record;
    truncated.timestamp = nanoseconds(record->timestamp.count() / 1000 * 1000);
    const auto again = parse_candump_log_line(to_candump_log(*record));
    ASSERT_TRUE(again) << line << " -> " << to_candump_log(*record);
    EXPECT_EQ(*again, truncated) << line;
  }
  EXPECT_GT(accepted, 100);  // the mutations must not all be fatal, or the round trip is untested
}

TEST(CandumpLog, ReaderSkipsBlankAndCommentLines) {
  // Given a log with comments, blank lines, CRLF and no final newline
  // When read
  // Then only the three records come back, in order
  const auto records = read_candump_log(
      "# drivecheck extension: a comment\r\n"
      "\r\n"
      "(1700000000.000100) vcan0 000#0105\r\n"  // NMT start node 5
      "   # indented comment\n"
      "\t\n"
      "(1700000000.000200) vcan0 705#05 R\n"  // heartbeat node 5 operational
      "(1700000000.000300) vcan1 185#1122");  // TPDO1 node 5
  ASSERT_TRUE(records) << records.error().to_string();
  ASSERT_EQ(records->size(), 3u);
  EXPECT_EQ(to_candump((*records)[0].frame), "000#0105");
  EXPECT_EQ((*records)[1].direction, TraceDirection::receive);
  EXPECT_EQ((*records)[2].interface, "vcan1");
  EXPECT_EQ((*records)[2].timestamp, nanoseconds(1'700'000'000'000'300'000));
}

TEST(CandumpLog, ReaderToleratesByteOrderMark) {
  // Given a log an editor saved with a UTF-8 BOM
  // When read
  // Then the BOM is not part of the first record
  const auto records = read_candump_log("\xEF\xBB\xBF(1.000000) can0 080#\n");
  ASSERT_TRUE(records) << records.error().to_string();
  EXPECT_EQ(records->size(), 1u);
}

TEST(CandumpLog, ReaderNamesFileAndLineOfFirstError) {
  // Given a log whose fourth line lacks the interface, after a comment and a good record
  // When read with a file name
  // Then the error is "trace.log:4: ..." and names the problem
  const auto records = read_candump_log(
      "# header\n"
      "(1.000000) can0 080#\n"
      "\n"
      "(1.000100) 080#\n"
      "(1.000200) can0 080#\n",
      "trace.log");
  ASSERT_FALSE(records);
  EXPECT_EQ(records.error().file, "trace.log");
  EXPECT_EQ(records.error().line, 4);
  EXPECT_EQ(records.error().to_string(),
            "trace.log:4: missing interface name before the frame '080#'");
}

TEST(CandumpLog, ReaderWithoutFileNameSaysLine) {
  const auto records = read_candump_log("(1.0) can0 080#\n(x) can0 080#\n");
  ASSERT_FALSE(records);
  EXPECT_EQ(records.error().to_string(), "line 2: timestamp 'x': 'x' is not a digit");
}

TEST(CandumpLog, EmptyLogHasNoRecords) {
  const auto records = read_candump_log("");
  ASSERT_TRUE(records);
  EXPECT_TRUE(records->empty());
}

TEST(CandumpLogFile, MissingFileIsAnErrorNamingThePath) {
  // Given a path that does not exist, and a directory
  // When read as logs
  // Then each error names the path and says why
  test_support::TempDir dir;
  const auto missing = read_candump_log_file(dir / "nope.log");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().file, (dir / "nope.log").string());
  EXPECT_EQ(missing.error().line, 0);
  EXPECT_NE(missing.error().message.find("cannot open"), std::string::npos);
  const auto directory = read_candump_log_file(dir.path());
  ASSERT_FALSE(directory);
  EXPECT_NE(directory.error().to_string().find(dir.path().string()), std::string::npos);
}

TEST(CandumpLogFile, BadLineInFileNamesPathAndLine) {
  test_support::TempDir dir;
  const auto path = dir.write("bad.log", "(1.000000) can0 080#\n(2.000000) can0 080#0\n");
  const auto records = read_candump_log_file(path);
  ASSERT_FALSE(records);
  EXPECT_EQ(records.error().to_string(),
            path.string() + ":2: data byte 0: odd number of hex digits");
}

TEST(CandumpLogWriter, FileIsValidAfterEveryRecord) {
  // Given a writer on a new file
  // When records are written one by one, the file read back after each (without closing)
  // Then the file always holds exactly the records written so far
  test_support::TempDir dir;
  auto writer = CandumpLogWriter::create(dir / "run.log");
  ASSERT_TRUE(writer) << writer.error();
  std::vector<LogRecord> written;
  for (int i = 0; i < 5; ++i) {
    // TPDO1 node 1, one counter byte
    written.push_back(LogRecord{nanoseconds(1'700'000'000'000'000'000 + i * 1'000'000), "sim",
                                Frame::standard(0x181, {static_cast<std::uint8_t>(i)}),
                                TraceDirection::transmit});
    ASSERT_TRUE(writer->write(written.back()));
    const auto back = read_candump_log_file(dir / "run.log");
    ASSERT_TRUE(back) << back.error().to_string();
    EXPECT_EQ(*back, written);
  }
  EXPECT_EQ(test_support::read_file(dir / "run.log").substr(0, 38),
            "(1700000000.000000) sim 181#00 T\n(1700");
}

TEST(CandumpLogWriter, UncreatableFileIsAnError) {
  test_support::TempDir dir;
  const auto writer = CandumpLogWriter::create(dir / "no-such-dir" / "run.log");
  ASSERT_FALSE(writer);
  EXPECT_NE(writer.error().find("cannot create"), std::string::npos) << writer.error();
}

TEST(CandumpLogTime, BusAndUnixTimeConvertBothWays) {
  // Given a bus clock whose zero is Unix time 1700000000 s
  // When a bus time is converted to Unix time and back
  // Then it is unchanged and the Unix time is offset + bus time
  const Duration offset = 1'700'000'000s;
  const TimePoint bus_time(2500us);
  EXPECT_EQ(to_unix_time(bus_time, offset), nanoseconds(1'700'000'000'002'500'000));
  EXPECT_EQ(to_bus_time(to_unix_time(bus_time, offset), offset), bus_time);
}

}  // namespace
}  // namespace drivecheck::can
