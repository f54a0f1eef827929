#include "protocol/cia301/emcy_consumer.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "protocol/can/sim_bus.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;

can::TimePoint at(can::Duration d) {
  return can::TimePoint{} + d;
}

TEST(EmcyConsumer, FestoErrorThenAcknowledge) {
  // Given the Festo sequence: EMCY 3220h register 05h, then 0000h after the acknowledge
  //   (000_33c1d912b8b6010a.txt Tab. 3.8 L1259-1274, digest vector 20)
  EmcyConsumer consumer;
  // When both arrive from node 1
  const auto error = consumer.on_frame(*can::parse_candump("081#2032050000000000"), at(1ms));
  EXPECT_TRUE(consumer.error_active(1));
  EXPECT_EQ(consumer.error_register(1), 0x05);
  const auto reset = consumer.on_frame(*can::parse_candump("081#0000000000000000"), at(2ms));
  // Then the first is an error, the second a reset; history holds both in order
  ASSERT_TRUE(error && reset);
  EXPECT_EQ(error->kind, EmcyEventKind::error);
  EXPECT_EQ(error->record.emcy.error_code, 0x3220);
  EXPECT_EQ(reset->kind, EmcyEventKind::error_reset);
  EXPECT_FALSE(consumer.error_active(1));
  ASSERT_EQ(consumer.history(1).size(), 2u);
  EXPECT_EQ(consumer.history(1)[0].time, at(1ms));
  EXPECT_EQ(consumer.history(2).size(), 0u);
}

TEST(EmcyConsumer, HistoryIsBounded) {
  // Given a consumer keeping 4 EMCYs per node (like Festo's 1003h depth)
  EmcyConsumer consumer(4);
  // When node 7 sends 6 different errors
  for (std::uint8_t i = 1; i <= 6; ++i) {
    consumer.on_frame(encode(Emcy{static_cast<std::uint16_t>(0x8610 + i), 0x01, {}}, 0x087),
                      at(std::chrono::milliseconds{i}));
  }
  // Then the last 4 are kept, oldest first, and all 6 are counted
  ASSERT_EQ(consumer.history(7).size(), 4u);
  EXPECT_EQ(consumer.history(7).front().emcy.error_code, 0x8613);
  EXPECT_EQ(consumer.history(7).back().emcy.error_code, 0x8616);
  EXPECT_EQ(consumer.count(7), 6u);
  consumer.clear(7);
  EXPECT_TRUE(consumer.history(7).empty());
}

TEST(EmcyConsumer, InvalidAndForeignFrames) {
  // Given a consumer
  EmcyConsumer consumer;
  // When a short EMCY, a SYNC and a TPDO arrive
  const auto short_emcy = consumer.on_frame(*can::parse_candump("085#1043"), at(0ms));
  // Then the short EMCY is invalid; the others are not EMCYs at all
  ASSERT_TRUE(short_emcy);
  EXPECT_EQ(short_emcy->kind, EmcyEventKind::invalid_frame);
  EXPECT_EQ(short_emcy->record.node, 5);
  EXPECT_NE(short_emcy->reason.find("DLC 2"), std::string::npos);
  EXPECT_FALSE(consumer.on_frame(*can::parse_candump("080#"), at(0ms)));
  EXPECT_FALSE(consumer.on_frame(*can::parse_candump("185#0000000000000000"), at(0ms)));
  EXPECT_EQ(consumer.count(5), 0u);
}

TEST(EmcyConsumer, ConfiguredCobId) {
  // Given node 5's EMCY moved to 0F0h (its 1014h)
  EmcyConsumer consumer;
  consumer.set_cob_id(5, 0x0F0);
  // When frames arrive on 0F0h and on the old 085h
  const auto moved = consumer.on_frame(encode(Emcy{0x8611, 0x01, {}}, 0x0F0), at(0ms));
  const auto old = consumer.on_frame(encode(Emcy{0x8611, 0x01, {}}, 0x085), at(0ms));
  // Then 0F0h is node 5's EMCY and 085h nobody's
  ASSERT_TRUE(moved);
  EXPECT_EQ(moved->record.node, 5);
  EXPECT_FALSE(old);
  consumer.set_cob_id(5, std::nullopt);
  EXPECT_TRUE(consumer.on_frame(encode(Emcy{0x8611, 0x01, {}}, 0x085), at(0ms)));
}

TEST(EmcyConsumerPort, DecodesOnSimulatedBus) {
  // Given a drive port that sends an EMCY 8611h (following error)
  can::SimBus bus;
  auto master = bus.attach("master");
  auto drive = bus.attach("drive");
  std::vector<EmcyEvent> events;
  EmcyConsumerPort emcy([&](const EmcyEvent& e) { events.push_back(e); });
  master->set_frame_handler([&](const can::TimedFrame& f) { emcy.handle(f); });
  drive->send(encode(Emcy{0x8611, 0x01, {}}, emcy_cob_id(9)));
  // When the bus runs
  bus.run_until(at(10ms));
  // Then the master has the EMCY of node 9 with the time it arrived
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].record.node, 9);
  EXPECT_EQ(events[0].record.emcy.error_code, 0x8611);
  EXPECT_GT(events[0].record.time, at(0ms));
  EXPECT_TRUE(emcy.consumer().error_active(9));
}

}  // namespace
}  // namespace drivecheck::cia301
