// The harness's stall log (conformance/stall_log.hpp): gaps between the watcher's ticks, and
// what the engine makes of a check that fails while the harness stalled.
#include "conformance/stall_log.hpp"

#include <gtest/gtest.h>

namespace drivecheck::conformance {
namespace {

using namespace std::chrono_literals;

can::TimePoint at(can::Duration d) {
  return can::TimePoint(d);
}

TEST(StallLog, GapsLongerThanPeriodPlusSlackAreStalls) {
  // Given a 1 ms watcher with 2 ms slack that ticked at 0, 1, 2, 5 (3 ms gap: not a stall),
  // 9 (4 ms: a stall) and 60 ms (51 ms: a stall)
  StallLog log(1ms, 2ms);
  for (const auto t : {0ms, 1ms, 2ms, 5ms, 9ms, 60ms})
    log.tick(at(t));
  // When asked about windows
  // Then the two stalls are found where they overlap, the longest first, and nothing else
  EXPECT_EQ(log.count(), 2U);
  const auto all = log.longest_between(at(0ms), at(100ms));
  ASSERT_TRUE(all);
  EXPECT_EQ(all->from, at(9ms));
  EXPECT_EQ(all->length(), 51ms);
  const auto early = log.longest_between(at(6ms), at(7ms));
  ASSERT_TRUE(early);
  EXPECT_EQ(early->length(), 4ms);
  EXPECT_FALSE(log.longest_between(at(0ms), at(4ms)));
  EXPECT_FALSE(log.longest_between(at(61ms), at(100ms)));
}

TEST(StallLog, KeepsAtMostItsCapacityAndIgnoresTimeGoingBack) {
  // Given a log of capacity 2 fed three stalls, and a tick earlier than the last one
  StallLog log(1ms, 0ms, 2);
  for (const auto t : {0ms, 10ms, 20ms, 30ms})
    log.tick(at(t));
  log.tick(at(25ms));
  log.tick(at(31ms));
  // Then the oldest stall is gone and the late tick made no stall of its own
  EXPECT_EQ(log.count(), 2U);
  EXPECT_FALSE(log.longest_between(at(0ms), at(9ms)));
}

TEST(StallWatcher, TicksFromItsThreadUntilDestroyed) {
  // Given a watcher ticking a log from a clock that jumps 100 ms on its third reading
  StallLog log(1ms, 2ms);
  std::atomic<int> readings{0};
  {
    StallWatcher watcher(
        log,
        [&] {
          const int n = readings.fetch_add(1);
          return at(n < 2 ? std::chrono::milliseconds(n) : std::chrono::milliseconds(100 + n));
        },
        1ms);
    while (readings.load() < 5)
      std::this_thread::sleep_for(1ms);
  }
  // Then the jump is one stall, and the thread stopped with the watcher
  EXPECT_EQ(log.count(), 1U);
  const int after = readings.load();
  std::this_thread::sleep_for(5ms);
  EXPECT_EQ(readings.load(), after);
}

}  // namespace
}  // namespace drivecheck::conformance
