#include "protocol/cia301/sync_producer.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "protocol/can/frame_timing.hpp"
#include "protocol/can/sim_bus.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;

can::TimePoint at(can::Duration d) {
  return can::TimePoint{} + d;
}

TEST(SyncProducer, RejectsReservedConfiguration) {
  // Given period 0, 1019h = 1 and 241
  // Then each configuration is refused with a reason naming the object
  EXPECT_FALSE(SyncProducer::create({0ms, 0}));
  const auto one = SyncProducer::create({1ms, 1});
  ASSERT_FALSE(one);
  EXPECT_NE(one.error().find("1019h"), std::string::npos);
  EXPECT_FALSE(SyncProducer::create({1ms, 241}));
  EXPECT_TRUE(SyncProducer::create({1ms, 240}));
}

TEST(SyncProducer, CounterWrapsAtOverflowValue) {
  // Given a producer with 1019h = 3 started at 0
  auto producer = SyncProducer::create({10ms, 3});
  ASSERT_TRUE(producer);
  producer->start(at(0ms));
  // When 7 periods pass
  std::vector<std::string> frames;
  for (int k = 0; k < 7; ++k) {
    auto frame = producer->on_time(at(10ms * k));
    ASSERT_TRUE(frame) << k;
    frames.push_back(can::to_candump(*frame));
  }
  // Then the counter runs 1, 2, 3, 1, 2, 3, 1
  EXPECT_EQ(frames, (std::vector<std::string>{"080#01", "080#02", "080#03", "080#01", "080#02",
                                              "080#03", "080#01"}));
}

TEST(SyncProducer, NoCounterAndNoDriftWhenLate) {
  // Given a producer without counter, 10 ms, started at 0
  auto producer = SyncProducer::create({10ms, 0});
  ASSERT_TRUE(producer);
  producer->start(at(0ms));
  // When it is called early, on time, 3 ms late, and 25 ms late
  EXPECT_EQ(can::to_candump(*producer->on_time(at(0ms))), "080#");
  EXPECT_FALSE(producer->on_time(at(9ms)));
  EXPECT_TRUE(producer->on_time(at(13ms)));
  // Then the next SYNC stays on the grid (20 ms), and a long delay skips slots, not the grid
  EXPECT_EQ(producer->next_deadline(), at(20ms));
  EXPECT_TRUE(producer->on_time(at(45ms)));
  EXPECT_EQ(producer->next_deadline(), at(50ms));
  EXPECT_EQ(producer->missed(), 2u);  // the 20 ms and 30 ms slots; the 40 ms one went late
  EXPECT_EQ(producer->sent(), 3u);
}

TEST(SyncProducerPort, PeriodExactOnSimulatedBus) {
  // Given a SYNC producer port with 1 ms period and 1019h = 5 on an idle simulated bus
  can::SimBus bus({.bitrate = 1'000'000});
  auto master = bus.attach("master");
  std::vector<can::TimedFrame> seen;
  bus.add_monitor([&](const can::TimedFrame& frame) { seen.push_back(frame); });
  auto producer = SyncProducer::create({1ms, 5});
  ASSERT_TRUE(producer);
  SyncProducerPort port(*master, std::move(*producer));
  port.start(at(0ms));
  // When the bus runs for 20.5 ms
  bus.run_until(at(20500us));
  // Then 21 SYNCs went out, each starting (SOF) at exactly k ms, counters 1..5. End-of-frame
  // times differ by the stuff bits of each counter value, so the start is what is compared:
  // SOF = end of frame - (frame bits - 3 intermission bits) bit times.
  ASSERT_EQ(seen.size(), 21u);
  for (std::size_t i = 0; i < seen.size(); ++i) {
    const auto bits = can::frame_bits(seen[i].frame, can::BitStuffing::exact);
    const can::TimePoint sof = seen[i].timestamp - can::bit_duration(bits - 3, 1'000'000);
    EXPECT_EQ(sof, at(std::chrono::milliseconds{i})) << i;
    EXPECT_EQ(seen[i].frame.data[0], static_cast<std::uint8_t>(i % 5 + 1));
  }
  EXPECT_FALSE(port.last_send_error());
  // And after stop() no further SYNC is sent
  port.stop();
  bus.run_until(at(30ms));
  EXPECT_EQ(seen.size(), 21u);
}

TEST(SyncProducerPort, PeriodShorterThanTheFrameSkipsInsteadOfQueueing) {
  // Given a 29-bit SYNC with counter (1019h = 240) every 20 us on a 125 kbit/s bus, where one
  // SYNC frame takes about 0.6 ms, and another node that wants to send a frame later
  can::SimBus bus({.bitrate = 125'000});
  auto master = bus.attach("master");
  auto other = bus.attach("other");
  std::vector<can::TimedFrame> seen;
  bus.add_monitor([&](const can::TimedFrame& frame) { seen.push_back(frame); });
  auto producer = SyncProducer::create({20us, 240, 0x1234'5678});
  ASSERT_TRUE(producer);
  SyncProducerPort port(*master, std::move(*producer));
  port.start(at(0ms));
  // When the bus runs for 50 ms, with the producer's queue checked at every SYNC
  std::size_t most_queued = 0;
  bus.add_monitor([&](const can::TimedFrame&) {
    most_queued = std::max(most_queued, master->queued(0x1234'5678, can::IdFormat::extended));
  });
  bus.run_until(at(50ms));
  // Then at most one SYNC waits at any time, nothing failed for a full queue, the SYNCs that
  // went out count 1, 2, 3... without gaps (the counter counts SYNCs on the bus) and the skipped
  // ones are counted as missed
  EXPECT_LE(most_queued, 1u);
  EXPECT_FALSE(port.last_send_error());
  ASSERT_GT(seen.size(), 50u);
  ASSERT_LT(seen.size(), 100u);
  for (std::size_t i = 0; i < seen.size(); ++i) {
    EXPECT_EQ(seen[i].frame.data[0], static_cast<std::uint8_t>(i % 240 + 1)) << i;
  }
  EXPECT_GT(port.producer().missed(), 2000u);
  // And when the producer stops (as at an NMT reset), another node's frame gets on the bus
  // within two SYNC frame times: no backlog of queued SYNCs is left to drain (a SYNC with a
  // higher priority than the frame keeps the bus while it is produced: that is CAN)
  port.stop();
  const std::size_t before = seen.size();
  ASSERT_FALSE(other->send(can::Frame::standard(0x705, {0x00})));
  bus.run_until(at(51500us));
  bool boot_up_seen = false;
  for (std::size_t i = before; i < seen.size(); ++i)
    boot_up_seen |= seen[i].frame.id == 0x705;
  EXPECT_TRUE(boot_up_seen);
}

}  // namespace
}  // namespace drivecheck::cia301
