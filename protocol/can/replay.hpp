// Replaying a candump log into a Bus port.
//
// Two timings:
//  - original: each frame is sent at `start + (its timestamp - the log's first timestamp)` on
//    the bus clock, by timers (so on the simulated bus a 10 s log replays in microseconds of
//    wall time, and on SocketCAN in 10 s). The log's first record is the time origin even when
//    filters skip it, so a filtered replay keeps the original spacing. Timestamps that go
//    backwards (merged logs) are sent at once, in log order.
//  - as_fast_as_possible: every frame at once, in log order, as fast as the port takes them.
// In both, a full transmit queue (BusError::queue_full) is retried every `retry_interval`
// until the frame goes or `give_up_after` passes; any other send error stops the replay.
//
// Selection: only records passing `filters` (SocketCAN semantics, as can::Filter: a frame
// passes when any filter matches; an inverted filter passes what does not match it; empty:
// all), and optionally only one interface and/or one direction flag. Error frames are never
// sent: they are reports of the receiving controller, not frames a node transmits; they
// count as skipped.
//
// The Replayer is a small state machine on the port's timers: it never blocks and never runs
// the event loop itself. `replay()` is the convenience that also runs the loop to the end.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/candump_log.hpp"

namespace drivecheck::can {

enum class ReplayTiming : std::uint8_t { original, as_fast_as_possible };

struct ReplayOptions {
  ReplayTiming timing = ReplayTiming::original;
  std::vector<Filter> filters{};              // empty: every frame
  std::optional<std::string> interface {};    // only records of this interface
  std::optional<TraceDirection> direction{};  // only records with this flag
  std::optional<TimePoint> start{};           // bus time of the log's first record (default now())
  Duration retry_interval = std::chrono::milliseconds(1);
  Duration give_up_after = std::chrono::seconds(1);
};

// Why a replay stopped early: which record (0-based index into the log) and the send error.
struct ReplayError {
  std::size_t record_index = 0;
  Frame frame;
  std::error_code error;

  std::string to_string() const;
};

struct ReplayStats {
  std::size_t sent = 0;
  std::size_t skipped = 0;  // not selected (filters, interface, direction, error frames)
};

class Replayer {
 public:
  Replayer(Bus& bus, std::vector<LogRecord> records, ReplayOptions options = {});
  ~Replayer();
  Replayer(const Replayer&) = delete;
  Replayer& operator=(const Replayer&) = delete;

  // Schedules the replay on the bus's timers; `on_done` runs once when the last frame has
  // been sent or the replay stopped on an error (possibly from within start()).
  void start(std::function<void()> on_done = {});
  // Stops a running replay (cancels its timer; on_done is not called).
  void cancel();

  bool done() const { return done_; }
  const ReplayStats& stats() const { return stats_; }
  const std::optional<ReplayError>& error() const { return error_; }

 private:
  bool selected(const LogRecord& record) const;
  TimePoint due_time(std::size_t index) const;
  void step();
  void finish();

  Bus& bus_;
  std::vector<LogRecord> records_;
  ReplayOptions options_;
  std::function<void()> on_done_;
  TimePoint start_{};
  TimePoint last_due_{};
  std::size_t next_ = 0;
  std::optional<TimePoint> blocked_since_;  // first queue_full of the current frame
  TimerId timer_ = kNoTimer;
  bool started_ = false;
  bool done_ = false;
  ReplayStats stats_;
  std::optional<ReplayError> error_;
};

// Replays `records` on `bus` and runs the bus's event loop (run_until) until the last frame
// is sent, then returns. The loop is ended with bus.stop(), so other nodes on the bus run
// meanwhile as usual.
Expected<ReplayStats, ReplayError> replay(Bus& bus, std::vector<LogRecord> records,
                                          ReplayOptions options = {});

}  // namespace drivecheck::can
