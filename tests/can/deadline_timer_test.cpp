#include "protocol/can/deadline_timer.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <vector>

#include "protocol/can/sim_bus.hpp"

namespace drivecheck::can {
namespace {

using namespace std::chrono_literals;

TimePoint at(Duration d) {
  return TimePoint(d);
}

TEST(DeadlineTimer, FiresOnceAtTheArmedTime) {
  // Given a timer armed at 10 ms
  // When the bus runs to 50 ms
  // Then the callback ran exactly once, at 10 ms, and the timer is disarmed
  SimBus bus;
  auto port = bus.attach("node");
  std::vector<TimePoint> fired;
  DeadlineTimer timer(*port, [&] { fired.push_back(port->now()); });
  timer.arm(at(10ms));
  EXPECT_EQ(timer.armed_at(), at(10ms));
  bus.run_until(at(50ms));
  EXPECT_EQ(fired, std::vector<TimePoint>{at(10ms)});
  EXPECT_EQ(timer.armed_at(), kForever);
}

TEST(DeadlineTimer, RearmingMovesTheOneTimer) {
  // Given a timer armed at 10 ms, then at 20 ms, then at 5 ms again and again
  // When the bus runs
  // Then only the last deadline fires, once
  SimBus bus;
  auto port = bus.attach("node");
  std::vector<TimePoint> fired;
  DeadlineTimer timer(*port, [&] { fired.push_back(port->now()); });
  timer.arm(at(10ms));
  timer.arm(at(20ms));
  timer.arm(at(5ms));
  timer.arm(at(5ms));
  bus.run_until(at(50ms));
  EXPECT_EQ(fired, std::vector<TimePoint>{at(5ms)});
}

TEST(DeadlineTimer, DisarmAndDestructionCancel) {
  // Given two armed timers
  // When one is disarmed and the other destroyed before their time
  // Then neither callback runs
  SimBus bus;
  auto port = bus.attach("node");
  int fired = 0;
  DeadlineTimer kept(*port, [&] { ++fired; });
  kept.arm(at(10ms));
  kept.disarm();
  {
    DeadlineTimer dropped(*port, [&] { ++fired; });
    dropped.arm(at(10ms));
  }
  bus.run_until(at(50ms));
  EXPECT_EQ(fired, 0);
}

TEST(DeadlineTimer, CallbackMayArmAgain) {
  // Given a callback that re-arms the timer 10 ms later, three times
  // When the bus runs
  // Then it fires at 10, 20 and 30 ms
  SimBus bus;
  auto port = bus.attach("node");
  std::vector<TimePoint> fired;
  std::unique_ptr<DeadlineTimer> timer;
  timer = std::make_unique<DeadlineTimer>(*port, [&] {
    fired.push_back(port->now());
    if (fired.size() < 3) timer->arm(port->now() + 10ms);
  });
  timer->arm(at(10ms));
  bus.run_until(at(100ms));
  EXPECT_EQ(fired, (std::vector<TimePoint>{at(10ms), at(20ms), at(30ms)}));
}

}  // namespace
}  // namespace drivecheck::can
