#include "protocol/ethercat/sim_segment.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <vector>

#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

TimePoint at(Duration d) {
  return TimePoint(d);
}

Bytes frame_of(std::vector<Datagram> datagrams) {
  Frame frame;
  frame.source = {0, 0, 0, 0, 0, 1};
  frame.datagrams = std::move(datagrams);
  return *encode_frame(frame);
}

Datagram first(const TimedFrame& frame) {
  auto decoded = decode_frame(frame.bytes);
  EXPECT_TRUE(decoded) << decoded.error().message();
  return decoded ? decoded->datagrams.at(0) : Datagram{};
}

// A device that records when it saw frames.
class Recorder final : public SegmentDevice {
 public:
  void on_frame(std::span<std::uint8_t>, TimePoint arrival,
                std::optional<TimePoint> return_arrival) override {
    arrivals.push_back(arrival);
    returns.push_back(return_arrival);
  }
  std::vector<TimePoint> arrivals;
  std::vector<std::optional<TimePoint>> returns;
};

struct TwoSlaves {
  Esc a;
  Esc b;
  EscDevice da{a};
  EscDevice db{b};
  SimSegment segment;
  TwoSlaves() {
    segment.attach(da);
    segment.attach(db);
  }
};

TEST(SimSegment, FrameTakesWireAndForwardingTime) {
  // Given one device (cable 50 ns, processing 600 ns)
  // When a 60-byte frame is sent at t=0
  // Then the device sees it at 50 ns, and the master gets it at 700 ns + 72 bytes × 80 ns
  Recorder recorder;
  SimSegment segment;
  segment.attach(recorder);
  ASSERT_FALSE(segment.send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0})})));
  const auto back = segment.receive(kForever);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->timestamp, at(700ns + 72 * 80ns));
  EXPECT_EQ(recorder.arrivals, std::vector<TimePoint>{at(50ns)});
  EXPECT_FALSE(recorder.returns[0]);
  EXPECT_EQ(SimSegment::wire_time(60), 84 * 80ns);
}

TEST(SimSegment, FramesPassDevicesInOrderAndComeBack) {
  // Given two devices
  // When a frame is sent
  // Then the second sees it after the first (50 + 600 + 50 ns); the first sees it come back
  // at 1350 ns on port 1; the master receives it at 1700 ns + 5760 ns
  Recorder a;
  Recorder b;
  SimSegment segment;
  segment.attach(a);
  segment.attach(b);
  ASSERT_FALSE(segment.send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0})})));
  const auto back = segment.receive(kForever);
  ASSERT_TRUE(back);
  EXPECT_EQ(a.arrivals.at(0), at(50ns));
  EXPECT_EQ(b.arrivals.at(0), at(700ns));
  EXPECT_EQ(a.returns.at(0), at(1350ns));
  EXPECT_FALSE(b.returns.at(0));
  EXPECT_EQ(back->timestamp, at(1700ns + 5760ns));
}

TEST(SimSegment, AutoIncrementReachesEachSlaveAndCountsWorkingCounters) {
  // Given two ESCs on the segment
  // When a BWR sets AL control, then APRDs with ADP 0 and FFFFh read the type register
  // Then the BWR's WKC is 2 and each APRD's 1
  TwoSlaves s;
  ASSERT_FALSE(
      s.segment.send(frame_of({Datagram::physical(Command::bwr, 0, 0, reg::kAlControl, {2, 0}),
                               Datagram::physical(Command::aprd, 1, 0, reg::kType, {0}),
                               Datagram::physical(Command::aprd, 2, 0xFFFF, reg::kType, {0})})));
  const auto back = s.segment.receive(kForever);
  ASSERT_TRUE(back);
  const auto decoded = decode_frame(back->bytes);
  ASSERT_TRUE(decoded);
  EXPECT_EQ(decoded->datagrams[0].working_counter, 2);
  EXPECT_EQ(decoded->datagrams[1].working_counter, 1);
  EXPECT_EQ(decoded->datagrams[2].working_counter, 1);
  EXPECT_EQ(s.a.al_control(), 2);
  EXPECT_EQ(s.b.al_control(), 2);
}

TEST(SimSegment, BackToBackFramesQueueOnTheWire) {
  // Given one device
  // When two frames are sent at t=0
  // Then the second comes back one wire time (6720 ns) after the first, in order
  TwoSlaves s;
  ASSERT_FALSE(s.segment.send(frame_of({Datagram::physical(Command::brd, 1, 0, 0, {0})})));
  ASSERT_FALSE(s.segment.send(frame_of({Datagram::physical(Command::brd, 2, 0, 0, {0})})));
  const auto one = s.segment.receive(kForever);
  const auto two = s.segment.receive(kForever);
  ASSERT_TRUE(one && two);
  EXPECT_EQ(first(*one).index, 1);
  EXPECT_EQ(first(*two).index, 2);
  EXPECT_EQ(two->timestamp - one->timestamp, 6720ns);
}

TEST(SimSegment, ReceiveReturnsAtTheDeadlineWhenNothingComes) {
  // Given a segment with a device and nothing sent
  // When receive waits until 1 ms
  // Then it returns nothing with the clock at 1 ms; a timer at 3 us runs before a frame at 6 us
  TwoSlaves s;
  EXPECT_FALSE(s.segment.receive(at(1ms)));
  EXPECT_EQ(s.segment.now(), at(1ms));
  std::vector<std::string> order;
  s.segment.start_timer_after(3us, [&] { order.push_back("timer"); });
  s.segment.set_frame_handler([&](const TimedFrame&) { order.push_back("frame"); });
  ASSERT_FALSE(s.segment.send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0})})));
  s.segment.run_for(1ms);
  EXPECT_EQ(order, (std::vector<std::string>{"timer", "frame"}));
}

TEST(SimSegment, DropBeforeTheFirstDeviceReachesNoSlave) {
  // Given a drop rule before device 0 for one frame
  // When an APWR of the station address is sent, then the same again
  // Then the first never comes back and the ESC kept address 0; the second works
  TwoSlaves s;
  const FaultId fault = s.segment.drop({.match = {}, .max_count = 1}, 0);
  const Bytes write =
      frame_of({Datagram::physical(Command::apwr, 0, 0, reg::kStationAddress, {0x01, 0x10})});
  ASSERT_FALSE(s.segment.send(write));
  EXPECT_FALSE(s.segment.receive(at(1ms)));
  EXPECT_EQ(s.a.peek(reg::kStationAddress), 0);
  ASSERT_FALSE(s.segment.send(write));
  const auto back = s.segment.receive(at(2ms));
  ASSERT_TRUE(back);
  EXPECT_EQ(first(*back).working_counter, 1);
  EXPECT_EQ(s.segment.fault_hits(fault), 1u);
  EXPECT_EQ(s.segment.frames_lost(), 1u);
}

TEST(SimSegment, DropOnTheWayBackLeavesTheSlavesChanged) {
  // Given a drop rule after every device
  // When an APWR of the station address is sent
  // Then the master sees nothing, but the ESC took the write
  TwoSlaves s;
  s.segment.drop({}, 2);
  ASSERT_FALSE(s.segment.send(
      frame_of({Datagram::physical(Command::apwr, 0, 0, reg::kStationAddress, {0x01, 0x10})})));
  EXPECT_FALSE(s.segment.receive(at(1ms)));
  EXPECT_EQ(s.a.peek(reg::kStationAddress), 0x01);
}

TEST(SimSegment, CorruptChangesTheReceivedBytes) {
  // Given a corrupt rule that flips the WKC low byte of the only datagram (byte 28)
  // When a BRD is sent through two ESCs
  // Then the master reads WKC 2 XOR 0xFF = FDh
  TwoSlaves s;
  s.segment.corrupt({}, {{{28, 0xFF}}});
  ASSERT_FALSE(s.segment.send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0, 0})})));
  const auto back = s.segment.receive(kForever);
  ASSERT_TRUE(back);
  EXPECT_EQ(first(*back).working_counter, 0xFD);
}

TEST(SimSegment, DelayHoldsTheFrameBack) {
  // Given a delay of 1 ms for frames whose first datagram has index 7
  // When frames with index 7 and 8 are sent
  // Then 7 comes back 1 ms late and 8 after it (order kept)
  TwoSlaves s;
  s.segment.delay({.match = [](std::span<const std::uint8_t> b) { return b[17] == 7; }}, 1ms);
  ASSERT_FALSE(s.segment.send(frame_of({Datagram::physical(Command::brd, 7, 0, 0, {0})})));
  ASSERT_FALSE(s.segment.send(frame_of({Datagram::physical(Command::brd, 8, 0, 0, {0})})));
  const auto one = s.segment.receive(kForever);
  const auto two = s.segment.receive(kForever);
  ASSERT_TRUE(one && two);
  EXPECT_EQ(first(*one).index, 7);
  EXPECT_GT(one->timestamp, at(1ms));
  EXPECT_EQ(first(*two).index, 8);
  EXPECT_GT(two->timestamp, one->timestamp);
}

TEST(SimSegment, LinkDownRefusesSendsAndLosesFramesOnTheWay) {
  // Given a frame on its way
  // When the link goes down before it returns, and a send is tried while down
  // Then the frame is lost, the send fails with link_down; after recovery frames flow again
  TwoSlaves s;
  ASSERT_FALSE(s.segment.send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0})})));
  s.segment.set_link_down(true);
  EXPECT_FALSE(s.segment.receive(at(1ms)));
  EXPECT_EQ(s.segment.send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0})})),
            LinkError::link_down);
  s.segment.set_link_down(false);
  ASSERT_FALSE(s.segment.send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0})})));
  EXPECT_TRUE(s.segment.receive(at(2ms)));
}

TEST(SimSegment, RefusesFramesOfWrongSizeAndSendsWithoutDevices) {
  // Given a segment without devices, and one with
  // When frames of 0, 13 and 1515 bytes, and a valid frame without devices, are sent
  // Then each gets its own error
  SimSegment empty;
  EXPECT_EQ(empty.send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0})})),
            LinkError::link_down);
  TwoSlaves s;
  EXPECT_EQ(s.segment.send(Bytes(13)), LinkError::frame_too_short);
  EXPECT_EQ(s.segment.send(Bytes(1515)), LinkError::frame_too_long);
  EXPECT_EQ(make_error_code(LinkError::permission_denied).message(),
            "raw packet sockets need root or CAP_NET_RAW");
}

TEST(SimSegment, ProbabilisticDropsAreDeterministicPerSeed) {
  // Given two segments with the same seed and a 50 % drop rule
  // When 200 frames go through each
  // Then the same frames are lost on both, and some but not all are
  auto run = [](std::uint64_t seed) {
    Esc esc;
    EscDevice device(esc);
    SimSegment segment({.seed = seed});
    segment.attach(device);
    segment.drop({.match = {}, .probability = 0.5});
    std::vector<int> got;
    for (int i = 0; i < 200; ++i) {
      EXPECT_FALSE(segment.send(
          frame_of({Datagram::physical(Command::brd, static_cast<std::uint8_t>(i), 0, 0, {0})})));
      if (const auto back = segment.receive(segment.now() + 1ms)) got.push_back(first(*back).index);
    }
    return got;
  };
  const auto one = run(7);
  EXPECT_EQ(one, run(7));
  EXPECT_GT(one.size(), 50u);
  EXPECT_LT(one.size(), 150u);
}

TEST(SimSegment, MonitorsSeeSentAndReceivedFrames) {
  // Given a monitor
  // When one frame goes around
  // Then it saw the frame sent (WKC 0) and received (WKC 2), in that order
  TwoSlaves s;
  std::vector<std::pair<FrameDirection, std::uint16_t>> seen;
  s.segment.add_monitor([&](const TimedFrame& f, FrameDirection d) {
    seen.emplace_back(d, first(f).working_counter);
  });
  ASSERT_FALSE(s.segment.send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0})})));
  ASSERT_TRUE(s.segment.receive(kForever));
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0], std::make_pair(FrameDirection::sent, std::uint16_t{0}));
  EXPECT_EQ(seen[1], std::make_pair(FrameDirection::received, std::uint16_t{2}));
}

}  // namespace
}  // namespace drivecheck::ethercat
