#include "protocol/cia301/heartbeat_consumer.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/error_control.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;

can::TimePoint at(can::Duration d) {
  return can::TimePoint{} + d;
}

TEST(ConsumerHeartbeatEntry, KollmorgenLayout) {
  // Given 1016h sub 1 = node 5, 150 ms (bits 23..16 node, 15..0 time; Kollmorgen 002
  //   L1664-1716)
  const auto entry = decode_consumer_heartbeat_entry(0x00050096);
  // When decoded
  // Then node and time are split; reserved bits and node 128 are invalid; 0 is unused
  ASSERT_TRUE(entry) << entry.error().reason;
  EXPECT_EQ(entry->node, 5);
  EXPECT_EQ(entry->time_ms, 150);
  EXPECT_EQ(entry->encode(), 0x00050096u);
  EXPECT_FALSE(decode_consumer_heartbeat_entry(0x01050096));
  EXPECT_FALSE(decode_consumer_heartbeat_entry(0x00800096));
  EXPECT_FALSE(decode_consumer_heartbeat_entry(0)->is_used());
}

TEST(HeartbeatConsumer, MonitoringStartsWithFirstHeartbeat) {
  // Given a consumer of node 1 with 150 ms
  HeartbeatConsumer consumer;
  consumer.monitor(1, 150ms);
  // When no heartbeat came yet
  // Then nothing is due, ever
  EXPECT_EQ(consumer.next_deadline(), can::kForever);
  EXPECT_TRUE(consumer.on_time(at(10s)).empty());
  // When the first heartbeat comes at 10 s
  const auto first = consumer.on_frame(encode(Heartbeat{1, NmtState::pre_operational}), at(10s));
  // Then it is reported as the first state and the deadline is 150 ms later
  ASSERT_TRUE(first);
  EXPECT_EQ(first->kind, HeartbeatEventKind::state_changed);
  EXPECT_FALSE(first->previous.has_value());
  EXPECT_EQ(consumer.next_deadline(), at(10s + 150ms));
}

TEST(HeartbeatConsumer, TimeoutAtExactDeadlineThenResumed) {
  // Given a consumer of node 1 with 150 ms that got a heartbeat at 0
  HeartbeatConsumer consumer;
  consumer.monitor(1, 150ms);
  consumer.on_frame(encode(Heartbeat{1, NmtState::operational}), at(0ms));
  // When time passes to 149.999 ms, then 150 ms, then 1 s
  // Then the timeout is reported once, at 150 ms exactly
  EXPECT_TRUE(consumer.on_time(at(149999us)).empty());
  const auto events = consumer.on_time(at(150ms));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, HeartbeatEventKind::timeout);
  EXPECT_EQ(events[0].time, at(150ms));
  EXPECT_EQ(events[0].previous, NmtState::operational);
  EXPECT_TRUE(consumer.is_timed_out(1));
  EXPECT_TRUE(consumer.on_time(at(1s)).empty());
  // When the node comes back
  const auto back = consumer.on_frame(encode(Heartbeat{1, NmtState::operational}), at(2s));
  // Then it is resumed and monitored again
  ASSERT_TRUE(back);
  EXPECT_EQ(back->kind, HeartbeatEventKind::resumed);
  EXPECT_FALSE(consumer.is_timed_out(1));
  EXPECT_EQ(consumer.next_deadline(), at(2s + 150ms));
}

TEST(HeartbeatConsumer, BootUpCountsAsFirstHeartbeat) {
  // Given a consumer of node 3 (Festo L1465: the boot-up is the first heartbeat)
  HeartbeatConsumer consumer;
  consumer.monitor(3, 100ms);
  // When the boot-up comes and then nothing
  const auto boot = consumer.on_frame(encode(BootUp{3}), at(5ms));
  // Then the boot-up is reported and the timeout is due 100 ms after it
  ASSERT_TRUE(boot);
  EXPECT_EQ(boot->kind, HeartbeatEventKind::boot_up);
  EXPECT_EQ(consumer.next_deadline(), at(105ms));
  const auto state = consumer.on_frame(encode(Heartbeat{3, NmtState::pre_operational}), at(50ms));
  ASSERT_TRUE(state);
  EXPECT_EQ(state->previous, NmtState::boot_up);
}

TEST(HeartbeatConsumer, InvalidFramesDoNotFeedTheTimer) {
  // Given a consumer of node 1 that got a heartbeat at 0
  HeartbeatConsumer consumer;
  consumer.monitor(1, 100ms);
  consumer.on_frame(encode(Heartbeat{1, NmtState::operational}), at(0ms));
  // When a toggled "heartbeat", an empty frame and a guarding RTR arrive at 50 ms
  const auto toggled = consumer.on_frame(*can::parse_candump("701#85"), at(50ms));
  const auto empty = consumer.on_frame(*can::parse_candump("701#"), at(50ms));
  const auto rtr = consumer.on_frame(*can::parse_candump("701#R"), at(50ms));
  // Then the first two are invalid, the RTR is ignored, and the deadline stays at 100 ms
  ASSERT_TRUE(toggled && empty);
  EXPECT_EQ(toggled->kind, HeartbeatEventKind::invalid_frame);
  EXPECT_EQ(empty->kind, HeartbeatEventKind::invalid_frame);
  EXPECT_FALSE(rtr);
  EXPECT_EQ(consumer.next_deadline(), at(100ms));
}

TEST(HeartbeatConsumer, SeveralNodesTimeOutInNodeOrder) {
  // Given nodes 9 and 2 with the same deadline and node 4 unmonitored
  HeartbeatConsumer consumer;
  consumer.monitor(ConsumerHeartbeatEntry{9, 100});
  consumer.monitor(ConsumerHeartbeatEntry{2, 100});
  consumer.on_frame(encode(Heartbeat{9, NmtState::operational}), at(0ms));
  consumer.on_frame(encode(Heartbeat{2, NmtState::operational}), at(0ms));
  EXPECT_FALSE(consumer.on_frame(encode(Heartbeat{4, NmtState::operational}), at(0ms)));
  // When the deadline passes
  const auto events = consumer.on_time(at(100ms));
  // Then both time out, node 2 first
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].node, 2);
  EXPECT_EQ(events[1].node, 9);
}

TEST(HeartbeatConsumerPort, TimeoutFiresAtTheRightSimulatedTime) {
  // Given a simulated bus, a node 1 producing heartbeats every 100 ms for 3 beats, and a
  //   consumer with 150 ms
  can::SimBus bus({.bitrate = 500'000});
  auto master = bus.attach("master");
  auto node = bus.attach("node1");
  std::vector<HeartbeatEvent> events;
  std::vector<can::TimePoint> event_clock;
  HeartbeatConsumerPort consumer(*master, [&](const HeartbeatEvent& event) {
    events.push_back(event);
    event_clock.push_back(master->now());
  });
  master->set_frame_handler([&](const can::TimedFrame& frame) { consumer.handle(frame); });
  consumer.monitor(1, 150ms);
  can::TimePoint last_heartbeat{};
  bus.add_monitor([&](const can::TimedFrame& frame) {
    if (frame.frame.id == 0x701) last_heartbeat = frame.timestamp;
  });
  for (int beat = 0; beat < 3; ++beat) {
    node->start_timer(at(100ms * beat), [&] {
      node->send(encode(Heartbeat{1, NmtState::operational}));
    });
  }
  // When the network runs for 1 s
  bus.run_until(at(1s));
  // Then: first state, then one timeout at exactly last heartbeat (end of frame) + 150 ms
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].kind, HeartbeatEventKind::state_changed);
  EXPECT_EQ(events[1].kind, HeartbeatEventKind::timeout);
  EXPECT_GT(last_heartbeat, at(200ms));
  EXPECT_EQ(events[1].time, last_heartbeat + 150ms);
  EXPECT_EQ(event_clock[1], last_heartbeat + 150ms);
}

}  // namespace
}  // namespace drivecheck::cia301
