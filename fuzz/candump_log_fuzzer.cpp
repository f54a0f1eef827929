// Fuzz target: candump text (protocol/can/frame.hpp, protocol/can/candump_log.hpp).
//
// Input: any text, read three ways: as a whole log (read_candump_log), line by line as log
// records (parse_candump_log_line) and line by line as compact frames (parse_candump).
// Oracles:
//   - what parses prints (to_candump / to_candump_log) to text that parses to the same value,
//     and printing that again gives the same text (the printed form is canonical);
//   - the whole-log reader agrees with the line parser: a log that reads has one record per
//     line that is neither blank nor a '#' comment, equal to that line's record; a log that
//     does not read names a line that exists and that the line parser rejects too;
//   - the text reader of plain candump output (candump_text.hpp) reads every -L line as the
//     -L parser does, prints a plain line back to text that reads to the same frame, and
//     accounts for every record line: read, or named as bad and rejected by its line parser.
#include <fmt/format.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/can/candump_log.hpp"
#include "protocol/can/candump_text.hpp"
#include "protocol/can/frame.hpp"

namespace {

using namespace drivecheck;

void check_frame_round_trip(std::string_view text) {
  const auto frame = can::parse_candump(text);
  if (!frame) return;
  const std::string printed = can::to_candump(*frame);
  const auto again = can::parse_candump(printed);
  DRIVECHECK_FUZZ_CHECK_DETAIL(again.has_value(), "printed frame does not parse",
                               printed + ": " + again.error());
  DRIVECHECK_FUZZ_CHECK_EQ(*again, *frame, "frame changed in a print/parse round trip");
  DRIVECHECK_FUZZ_CHECK_EQ(can::to_candump(*again), printed, "printed frame is not canonical");
}

// Returns the line's record (parse_candump_log_line is a pure function: the whole-log checks
// below compare against this result instead of parsing the line again).
std::optional<can::LogRecord> check_record_round_trip(std::string_view line) {
  auto record = can::parse_candump_log_line(line);
  if (!record) return std::nullopt;
  const std::string printed = can::to_candump_log(*record);
  const auto again = can::parse_candump_log_line(printed);
  DRIVECHECK_FUZZ_CHECK_DETAIL(again.has_value(), "printed log record does not parse",
                               printed + ": " + again.error());
  DRIVECHECK_FUZZ_CHECK_EQ(can::to_candump_log(*again), printed,
                           "printed log record is not canonical");
  DRIVECHECK_FUZZ_CHECK_EQ(again->frame, record->frame, "record's frame changed in a round trip");
  DRIVECHECK_FUZZ_CHECK_EQ(again->interface, record->interface,
                           "record's interface changed in a round trip");
  // The text keeps microseconds (candump's resolution): below that the reader may keep more.
  DRIVECHECK_FUZZ_CHECK_EQ(again->timestamp.count(), record->timestamp.count() / 1000 * 1000,
                           "record's timestamp changed beyond microsecond truncation");
  DRIVECHECK_FUZZ_CHECK(again->direction == record->direction,
                        "record's direction changed in a round trip");
  return std::move(*record);
}

// A plain or -ta line as candump prints the record.
std::string to_plain_candump(const can::CandumpLine& line) {
  const can::Frame& frame = line.record.frame;
  std::string text;
  if (line.has_timestamp()) {
    const auto ns = line.record.timestamp.count();
    text = fmt::format("({}.{:09})", ns / 1'000'000'000, ns % 1'000'000'000);
  }
  text += fmt::format("  {}  {:0{}X}   [{}]", line.record.interface, frame.id,
                      frame.is_extended() ? 8 : 3, frame.dlc);
  if (frame.is_remote()) return text + "  remote request";
  for (const std::uint8_t byte : frame.payload())
    text += fmt::format(" {:02X}", byte);
  return text;
}

void check_text_line(std::string_view line, const std::optional<can::LogRecord>& log_record) {
  const auto parsed = can::parse_candump_line(line);
  if (log_record) {
    DRIVECHECK_FUZZ_CHECK(parsed.has_value() && parsed->format == can::CandumpLineFormat::log &&
                              parsed->record == *log_record,
                          "text reader reads a -L line otherwise than the -L parser");
  }
  if (!parsed || parsed->format == can::CandumpLineFormat::log) return;
  const std::string printed = to_plain_candump(*parsed);
  const auto again = can::parse_candump_line(printed);
  DRIVECHECK_FUZZ_CHECK_DETAIL(again.has_value(), "printed plain candump line does not parse",
                               printed + ": " + again.error());
  DRIVECHECK_FUZZ_CHECK_EQ(again->record.frame, parsed->record.frame,
                           "plain line's frame changed in a round trip");
  DRIVECHECK_FUZZ_CHECK_EQ(again->record.interface, parsed->record.interface,
                           "plain line's interface changed in a round trip");
  DRIVECHECK_FUZZ_CHECK(
      again->format == parsed->format && again->record.timestamp == parsed->record.timestamp,
      "plain line's time changed in a round trip");
}

std::string_view trim_blanks(std::string_view text) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (!text.empty() && blank(text.front()))
    text.remove_prefix(1);
  while (!text.empty() && blank(text.back()))
    text.remove_suffix(1);
  return text;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = fuzz::as_text({data, size});

  // Lines as the header defines them: '\n' ends a line; a UTF-8 BOM before the first is not
  // part of it.
  std::vector<std::string_view> lines;
  {
    std::string_view rest = text;
    if (rest.substr(0, 3) == "\xEF\xBB\xBF") rest.remove_prefix(3);
    while (!rest.empty()) {
      const auto end = rest.find('\n');
      lines.push_back(rest.substr(0, end));
      rest.remove_prefix(end == std::string_view::npos ? rest.size() : end + 1);
    }
  }
  std::vector<std::optional<can::LogRecord>> line_records;  // one per line
  line_records.reserve(lines.size());
  for (const std::string_view line : lines) {
    check_frame_round_trip(line);
    if (trim_blanks(line).size() != line.size()) check_frame_round_trip(trim_blanks(line));
    line_records.push_back(check_record_round_trip(line));
  }

  std::size_t record_lines = 0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    check_text_line(lines[i], line_records[i]);
    const std::string_view content = trim_blanks(lines[i]);
    if (!content.empty() && content.front() != '#') ++record_lines;
  }
  const can::CandumpText read = can::read_candump_text(text, "fuzz.txt");
  DRIVECHECK_FUZZ_CHECK_EQ(read.lines.size() + read.bad_lines.size(), record_lines,
                           "text reader loses or invents record lines");
  for (const TextError& bad : read.bad_lines) {
    DRIVECHECK_FUZZ_CHECK_DETAIL(
        bad.line >= 1 && static_cast<std::size_t>(bad.line) <= lines.size() &&
            !can::parse_candump_line(lines[static_cast<std::size_t>(bad.line) - 1]),
        "text reader names a line its line parser accepts", bad.to_string());
  }

  const auto log = can::read_candump_log(text, "fuzz.log");
  if (log) {
    std::size_t next = 0;
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const std::string_view content = trim_blanks(lines[i]);
      if (content.empty() || content.front() == '#') continue;
      DRIVECHECK_FUZZ_CHECK(next < log->size(), "log has fewer records than record lines");
      const std::optional<can::LogRecord>& record = line_records[i];
      DRIVECHECK_FUZZ_CHECK(record.has_value() && *record == (*log)[next],
                            "log reader and line parser disagree on a line");
      ++next;
    }
    DRIVECHECK_FUZZ_CHECK_EQ(next, log->size(), "log has more records than record lines");

    std::string printed;
    for (const can::LogRecord& record : *log) {
      printed += can::to_candump_log(record);
      printed += '\n';
    }
    const auto again = can::read_candump_log(printed, "printed.log");
    DRIVECHECK_FUZZ_CHECK_DETAIL(again.has_value(), "printed log does not read",
                                 again.error().to_string());
    DRIVECHECK_FUZZ_CHECK_EQ(again->size(), log->size(), "printed log has another record count");
    std::string reprinted;
    for (const can::LogRecord& record : *again) {
      reprinted += can::to_candump_log(record);
      reprinted += '\n';
    }
    DRIVECHECK_FUZZ_CHECK_EQ(reprinted, printed, "printed log is not canonical");
  } else {
    const TextError& error = log.error();
    DRIVECHECK_FUZZ_CHECK_DETAIL(
        error.line >= 1 && static_cast<std::size_t>(error.line) <= lines.size(),
        "log error names no line of the input", error.to_string());
    DRIVECHECK_FUZZ_CHECK_DETAIL(!line_records[static_cast<std::size_t>(error.line) - 1],
                                 "log reader rejects a line the line parser accepts",
                                 error.to_string());
    DRIVECHECK_FUZZ_CHECK_DETAIL(error.to_string().starts_with("fuzz.log:"),
                                 "log error does not name the file", error.to_string());
  }
  return 0;
}
