#include "protocol/can/candump_log.hpp"

#include <fmt/compile.h>

#include <array>
#include <cerrno>
#include <cstdint>
#include <limits>
#include <system_error>

#include "protocol/can/candump_text.hpp"

namespace drivecheck::can {
namespace {

constexpr std::int64_t kNanosPerSecond = 1'000'000'000;
constexpr std::size_t kMaxQuoted = 40;

bool is_blank(char c) {
  return c == ' ' || c == '\t';
}
bool is_digit(char c) {
  return c >= '0' && c <= '9';
}

// Input text for a message: quoted, shortened when long (a huge number must not make a
// huge message).
std::string quote(std::string_view text) {
  if (text.size() <= kMaxQuoted) return fmt::format(FMT_COMPILE("'{}'"), text);
  return fmt::format(FMT_COMPILE("'{}...' ({} characters)"), text.substr(0, kMaxQuoted),
                     text.size());
}

// Appends `value` in decimal with at least `width` digits (fmt's "{:0<width>}").
void append_decimal(std::string& text, std::uint64_t value, int width) {
  char digits[20];
  int count = 0;
  do {
    digits[count++] = static_cast<char>('0' + value % 10);
    value /= 10;
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

std::string_view trim(std::string_view text) {
  while (!text.empty() && (is_blank(text.front()) || text.front() == '\r'))
    text.remove_prefix(1);
  while (!text.empty() && (is_blank(text.back()) || text.back() == '\r'))
    text.remove_suffix(1);
  return text;
}

std::string system_error_text(int error) {
  return std::error_code(error, std::generic_category()).message();
}

}  // namespace

// "1700000000.000100" (the text between the parentheses) -> nanoseconds since the epoch.
Expected<std::chrono::nanoseconds, std::string> parse_candump_timestamp(std::string_view text) {
  if (text.empty()) return Unexpected(std::string("empty timestamp '()'"));
  if (text.front() == '-') {
    return Unexpected(
        fmt::format(FMT_COMPILE("negative timestamp {}: Unix time starts at 0"), quote(text)));
  }
  constexpr std::int64_t kMaxSeconds = std::numeric_limits<std::int64_t>::max() / kNanosPerSecond;
  const auto out_of_range = [&] {
    return Unexpected(
        fmt::format(FMT_COMPILE("timestamp {} is out of range (the latest is {}.999999, in 2262)"),
                    quote(text), kMaxSeconds - 1));
  };
  std::size_t pos = 0;
  std::int64_t seconds = 0;
  while (pos < text.size() && text[pos] != '.') {
    if (!is_digit(text[pos])) {
      return Unexpected(fmt::format(FMT_COMPILE("timestamp {}: {} is not a digit"), quote(text),
                                    describe_char(text[pos])));
    }
    if (seconds > kMaxSeconds / 10) return out_of_range();
    seconds = seconds * 10 + (text[pos] - '0');
    ++pos;
  }
  if (pos == 0) {
    return Unexpected(fmt::format(FMT_COMPILE("timestamp {}: no seconds before '.'"), quote(text)));
  }
  std::int64_t nanos = 0;
  if (pos < text.size()) {  // '.'
    ++pos;
    if (pos == text.size()) {
      return Unexpected(fmt::format(FMT_COMPILE("timestamp {}: no digits after '.'"), quote(text)));
    }
    std::int64_t scale = kNanosPerSecond;
    for (; pos < text.size(); ++pos) {
      if (!is_digit(text[pos])) {
        return Unexpected(fmt::format(FMT_COMPILE("timestamp {}: {} is not a digit"), quote(text),
                                      describe_char(text[pos])));
      }
      if (scale > 1) {  // digits past the 9th (below a nanosecond) are truncated
        scale /= 10;
        nanos += (text[pos] - '0') * scale;
      }
    }
  }
  // Both parts fit: seconds <= kMaxSeconds * 10 + 9 was checked digit by digit; check the sum.
  if (seconds >= kMaxSeconds) return out_of_range();
  return std::chrono::nanoseconds(seconds * kNanosPerSecond + nanos);
}

namespace {

// The fields of a record after its timestamp: a record has at most three (interface, frame,
// direction), so the first four are kept (no allocation per line) and all are counted.
struct Fields {
  std::array<std::string_view, 4> first;
  std::size_t count = 0;

  bool empty() const { return count == 0; }
  std::size_t size() const { return count; }
  std::string_view operator[](std::size_t i) const { return first[i]; }
};

// Splits at runs of blanks.
Fields split_fields(std::string_view text) {
  Fields fields;
  std::size_t pos = 0;
  while (pos < text.size()) {
    while (pos < text.size() && is_blank(text[pos]))
      ++pos;
    const std::size_t start = pos;
    while (pos < text.size() && !is_blank(text[pos]))
      ++pos;
    if (pos > start) {
      if (fields.count < fields.first.size())
        fields.first[fields.count] = text.substr(start, pos - start);
      ++fields.count;
    }
  }
  return fields;
}

}  // namespace

std::string to_candump_log(const LogRecord& record) {
  const std::int64_t ns = record.timestamp.count();
  // Unsigned magnitude: no overflow even for the most negative value.
  const std::uint64_t magnitude =
      ns < 0 ? std::uint64_t{0} - static_cast<std::uint64_t>(ns) : static_cast<std::uint64_t>(ns);
  const std::uint64_t seconds = magnitude / kNanosPerSecond;
  const std::uint64_t micros = (magnitude % kNanosPerSecond) / 1000;
  // "(" sign seconds (at least 10 digits) "." microseconds (6 digits) ") " interface " " frame,
  // built by hand: this runs for every record of a log that is written.
  std::string line;
  line.reserve(1 + 1 + 20 + 1 + 6 + 2 + record.interface.size() + 1 + 30);
  line += '(';
  if (ns < 0) line += '-';
  append_decimal(line, seconds, 10);
  line += '.';
  append_decimal(line, micros, 6);
  line += ") ";
  line += record.interface;
  line += ' ';
  line += to_candump(record.frame);
  if (record.direction) line += *record.direction == TraceDirection::transmit ? " T" : " R";
  return line;
}

Expected<LogRecord, std::string> parse_candump_log_line(std::string_view line) {
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (c == '\t' || (c == '\r' && i + 1 == line.size())) continue;
    if (c < 0x20 || c >= 0x7F) {
      return Unexpected(fmt::format(
          FMT_COMPILE("column {}: {} is not printable ASCII (a candump log is ASCII text)"), i + 1,
          describe_char(c)));
    }
  }
  line = trim(line);
  if (line.empty() || line.front() != '(') {
    return Unexpected(std::string(
        "missing '(' before the timestamp: a record reads '(1700000000.000100) can0 605#00'"));
  }
  const auto close = line.find(')');
  if (close == std::string_view::npos) {
    return Unexpected(std::string("missing ')' after the timestamp"));
  }
  auto timestamp = parse_candump_timestamp(line.substr(1, close - 1));
  if (!timestamp) return Unexpected(std::move(timestamp).error());

  const std::string_view rest = line.substr(close + 1);
  if (!rest.empty() && !is_blank(rest.front())) {
    return Unexpected(fmt::format(FMT_COMPILE("expected a blank after ')', found {}"),
                                  describe_char(rest.front())));
  }
  const auto fields = split_fields(rest);
  if (fields.empty()) {
    return Unexpected(std::string("missing interface name and frame after the timestamp"));
  }
  if (fields[0].find('#') != std::string_view::npos) {
    return Unexpected(
        fmt::format(FMT_COMPILE("missing interface name before the frame {}"), quote(fields[0])));
  }
  if (fields.size() == 1) {
    return Unexpected(
        fmt::format(FMT_COMPILE("missing frame after the interface name {}"), quote(fields[0])));
  }
  if (fields.size() > 3) {
    return Unexpected(
        fmt::format(FMT_COMPILE("unexpected {} after the direction flag"), quote(fields[3])));
  }
  if (fields[0].size() > kMaxInterfaceNameLength) {
    return Unexpected(fmt::format(FMT_COMPILE("interface name {} is longer than {} characters"),
                                  quote(fields[0]), kMaxInterfaceNameLength));
  }
  auto frame = parse_candump(fields[1]);
  if (!frame) return Unexpected(std::move(frame).error());

  LogRecord record;
  record.timestamp = *timestamp;
  record.interface = std::string(fields[0]);
  record.frame = *frame;
  if (fields.size() == 3) {
    if (fields[2] == "R") {
      record.direction = TraceDirection::receive;
    } else if (fields[2] == "T") {
      record.direction = TraceDirection::transmit;
    } else {
      return Unexpected(
          fmt::format(FMT_COMPILE("direction flag {} is not R or T"), quote(fields[2])));
    }
  }
  return record;
}

Expected<std::vector<LogRecord>, TextError> read_candump_log(std::string_view text,
                                                             std::string_view file) {
  std::vector<LogRecord> records;
  // A UTF-8 byte order mark from an editor is not part of the first record.
  if (text.substr(0, 3) == "\xEF\xBB\xBF") text.remove_prefix(3);
  int line_number = 0;
  while (!text.empty()) {
    ++line_number;
    const auto end = text.find('\n');
    const std::string_view line = text.substr(0, end);
    text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
    const std::string_view content = trim(line);
    if (content.empty() || content.front() == '#') continue;
    auto record = parse_candump_log_line(line);
    if (!record) {
      return Unexpected(TextError{std::string(file), line_number, std::move(record).error()});
    }
    records.push_back(std::move(*record));
  }
  return records;
}

Expected<std::vector<LogRecord>, TextError> read_candump_log_file(
    const std::filesystem::path& path) {
  const std::string name = path.string();
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(name.c_str(), "rb"),
                                                       &std::fclose);
  if (!file) {
    return Unexpected(TextError{name, 0, "cannot open: " + system_error_text(errno)});
  }
  std::string text;
  char buffer[1 << 16];
  for (;;) {
    const std::size_t n = std::fread(buffer, 1, sizeof buffer, file.get());
    text.append(buffer, n);
    if (n < sizeof buffer) break;
  }
  if (std::ferror(file.get())) {
    return Unexpected(TextError{name, 0, "cannot read: " + system_error_text(errno)});
  }
  return read_candump_log(text, name);
}

Expected<CandumpLogWriter, std::string> CandumpLogWriter::create(const std::filesystem::path& path,
                                                                 bool flush_each_record) {
  std::FILE* file = std::fopen(path.string().c_str(), "wb");
  if (file == nullptr) {
    return Unexpected(
        fmt::format(FMT_COMPILE("{}: cannot create: {}"), path.string(), system_error_text(errno)));
  }
  return CandumpLogWriter(path, file, flush_each_record);
}

Expected<void, std::string> CandumpLogWriter::write(const LogRecord& record) {
  line_ = to_candump_log(record);
  line_ += '\n';
  if (std::fwrite(line_.data(), 1, line_.size(), file_.get()) != line_.size()) {
    return Unexpected(
        fmt::format(FMT_COMPILE("{}: write failed: {}"), path_.string(), system_error_text(errno)));
  }
  if (flush_each_record_) return flush();
  return {};
}

Expected<void, std::string> CandumpLogWriter::flush() {
  if (std::fflush(file_.get()) != 0) {
    return Unexpected(
        fmt::format(FMT_COMPILE("{}: write failed: {}"), path_.string(), system_error_text(errno)));
  }
  return {};
}

}  // namespace drivecheck::can
