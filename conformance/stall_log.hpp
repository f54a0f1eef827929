// The harness's own stalls on a real bus: stretches in which no thread of the harness ran (a
// busy host; a VM whose CPU the host took away). A watcher thread that asks to run every
// `period` ticks the log each time it runs; a gap between two ticks longer than period + slack
// is a stall. A check that fails in a vector during which the harness stalled is not charged
// to the device: the DUT's frames may be stamped late and the harness's requests went out
// late, so nothing timed can be judged (VectorRun::fail: `error: harness late`, and the engine
// runs the vector again, engine.hpp).
//
// StallLog is pure (fed tick times, thread-safe); StallWatcher is the thread that feeds it from
// a clock (the bus's: on SocketCAN CLOCK_MONOTONIC, the clock of the frames' timestamps).
#pragma once

#include <atomic>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>

#include "protocol/can/bus.hpp"

namespace drivecheck::conformance {

struct Stall {
  can::TimePoint from;  // the watcher's last run before the gap
  can::TimePoint to;    // its first run after it
  can::Duration length() const { return to - from; }
};

class StallLog {
 public:
  // A gap between ticks longer than `period + slack` is a stall; at most `capacity` stalls are
  // kept (the oldest go first).
  StallLog(can::Duration period, can::Duration slack, std::size_t capacity = 4096);

  void tick(can::TimePoint at);
  // The longest stall that overlaps [from, to]; nullopt if none.
  std::optional<Stall> longest_between(can::TimePoint from, can::TimePoint to) const;
  std::size_t count() const;

 private:
  can::Duration limit_;
  std::size_t capacity_;
  mutable std::mutex mutex_;
  std::optional<can::TimePoint> last_;
  std::deque<Stall> stalls_;
};

class StallWatcher {
 public:
  // Starts a thread that sleeps `period` at a time and ticks `log` with `now()` when it runs.
  StallWatcher(StallLog& log, std::function<can::TimePoint()> now, can::Duration period);
  ~StallWatcher();  // stops and joins the thread
  StallWatcher(const StallWatcher&) = delete;
  StallWatcher& operator=(const StallWatcher&) = delete;

 private:
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace drivecheck::conformance
