// candump `-L` log files: the one trace format of drivecheck (traces, vectors, seeds, golden
// files).
//
// One record per line, as `candump -L` writes and `canplayer` reads:
//
//   (1700000000.000100) vcan0 605#2341600000000000
//   (1700000000.000350) vcan0 585#4341600000000000 R
//    ^ Unix time: seconds '.' microseconds, in parentheses
//                       ^ interface name (1..15 characters, IFNAMSIZ - 1)
//                             ^ frame in candump compact syntax (protocol/can/frame.hpp)
//                                                  ^ optional direction flag: R received,
//                                                    T transmitted (newer can-utils write it)
//
// Writing: exactly 6 fractional digits (microseconds; the nanoseconds below are truncated,
// as candump truncates the kernel's timestamp), seconds zero-padded to 10 digits, single
// spaces, '\n' line ends.
// Reading is tolerant where it costs nothing: 0..9 fractional digits (more are accepted and
// truncated to nanoseconds), runs of spaces/tabs between fields, leading/trailing spaces,
// CRLF line ends. It rejects, with a message naming the problem: a missing '(' or ')',
// a negative or out-of-range timestamp (beyond 2262-04-11, where int64 nanoseconds end), a
// missing interface name, a bad frame, a direction flag other than R/T, anything after the
// flag, and bytes that are not printable ASCII.
//
// drivecheck extension (not read by canplayer): blank lines, and lines whose first non-blank
// character is '#', are skipped, so that vectors and golden files can carry comments.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::can {

// Longest interface name Linux allows (IFNAMSIZ 16 including the terminating NUL).
inline constexpr std::size_t kMaxInterfaceNameLength = 15;

// The direction flag of newer candump logs: R = received by the interface, T = sent by it.
enum class TraceDirection : std::uint8_t { receive, transmit };

// One line of a candump log.
struct LogRecord {
  // Unix time (since 1970-01-01 00:00 UTC) in nanoseconds; never negative in a log we read.
  // Bus time of a port: `to_bus_time(timestamp, bus.unix_offset())`.
  std::chrono::nanoseconds timestamp{0};
  std::string interface;
  Frame frame;
  std::optional<TraceDirection> direction;

  friend bool operator==(const LogRecord&, const LogRecord&) = default;
};

// Bus time <-> Unix time, with the bus clock's `Clock::unix_offset()`.
inline std::chrono::nanoseconds to_unix_time(TimePoint bus_time, Duration unix_offset) {
  return bus_time.time_since_epoch() + unix_offset;
}
inline TimePoint to_bus_time(std::chrono::nanoseconds unix_time, Duration unix_offset) {
  return TimePoint(unix_time - unix_offset);
}

// "(1700000000.000100) vcan0 605#2341600000000000" plus " R"/" T" when a direction is set;
// no line end. Preconditions: timestamp >= 0 (a negative one is printed with a '-' that
// every reader rejects, never silently changed) and an interface name without blanks.
std::string to_candump_log(const LogRecord& record);

// Parses one record line (a trailing '\r' is tolerated). Blank and '#' lines are not
// records: the whole-log readers skip them. The message names the problem; the caller
// adds file:line.
Expected<LogRecord, std::string> parse_candump_log_line(std::string_view line);

// Reads a whole log held in memory. `file` only names the input in errors ("" gives
// "line 3: ..."). The first bad line ends the read with a TextError naming file:line.
Expected<std::vector<LogRecord>, TextError> read_candump_log(std::string_view text,
                                                             std::string_view file = {});

// Reads a log file (errors name the path and, for a bad line, its number).
Expected<std::vector<LogRecord>, TextError> read_candump_log_file(
    const std::filesystem::path& path);

// Appends records to a candump log file, one line each. With `flush_each_record` (the
// default) every line is handed to the kernel (fflush, not fsync) before write() returns,
// so the file is a complete, valid log after every record even if the process dies.
class CandumpLogWriter {
 public:
  // Creates (truncates) the file.
  static Expected<CandumpLogWriter, std::string> create(const std::filesystem::path& path,
                                                        bool flush_each_record = true);

  // Errors carry the path and the system's reason (e.g. "No space left on device").
  Expected<void, std::string> write(const LogRecord& record);
  Expected<void, std::string> flush();

  const std::filesystem::path& path() const { return path_; }

 private:
  struct FileCloser {
    void operator()(std::FILE* file) const { std::fclose(file); }
  };
  CandumpLogWriter(std::filesystem::path path, std::FILE* file, bool flush_each_record)
      : path_(std::move(path)), file_(file), flush_each_record_(flush_each_record) {}

  std::filesystem::path path_;
  std::unique_ptr<std::FILE, FileCloser> file_;
  bool flush_each_record_ = true;
  std::string line_;  // reused buffer
};

}  // namespace drivecheck::can
