#include "protocol/ethercat/recording_link.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <vector>

#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/sim_segment.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;

std::vector<std::uint8_t> broadcast_read() {
  Frame frame;
  frame.source = {0, 0, 0, 0, 0, 1};
  Datagram datagram;
  datagram.command = Command::brd;
  datagram.address = 0x0130U << 16;  // ADO: AL status
  datagram.data.assign(2, 0);
  frame.datagrams.push_back(datagram);
  return *encode_frame(frame);
}

struct Seen {
  std::vector<TimedFrame> frames;
  std::vector<FrameDirection> directions;
};

struct OneSlave {
  Esc esc;
  EscDevice device{esc};
  SimSegment segment;
  Seen seen;
  RecordingLink link{segment, [this](const TimedFrame& frame, FrameDirection direction) {
                       seen.frames.push_back(frame);
                       seen.directions.push_back(direction);
                     }};
  OneSlave() { segment.attach(device); }
};

TEST(RecordingLink, RecordsTheSentFrameAndItsReturnByReceive) {
  // Given a recording link on a segment with one slave
  // When the master sends a BRD and receives it back
  // Then the recorder saw the frame as sent, at the send time, and then as it came back
  OneSlave rig;
  const auto bytes = broadcast_read();
  const TimePoint sent_at = rig.link.now();
  ASSERT_FALSE(rig.link.send(bytes));
  const auto back = rig.link.receive(rig.link.now() + 10ms);
  ASSERT_TRUE(back);
  ASSERT_EQ(rig.seen.frames.size(), 2U);
  EXPECT_EQ(rig.seen.directions[0], FrameDirection::sent);
  EXPECT_EQ(rig.seen.frames[0].bytes, bytes);
  EXPECT_EQ(rig.seen.frames[0].timestamp, sent_at);
  EXPECT_EQ(rig.seen.directions[1], FrameDirection::received);
  EXPECT_EQ(rig.seen.frames[1].bytes, back->bytes);
  EXPECT_EQ(rig.seen.frames[1].timestamp, back->timestamp);
  // the slave counted itself in the working counter of the returned frame
  EXPECT_NE(rig.seen.frames[1].bytes, rig.seen.frames[0].bytes);
}

TEST(RecordingLink, RecordsFramesTheHandlerTakes) {
  // Given a recording link with a frame handler set
  // When a frame comes back while run_for() runs
  // Then the recorder saw it before the handler, and once
  OneSlave rig;
  std::size_t handled = 0;
  std::size_t recorded_when_handled = 0;
  rig.link.set_frame_handler([&](const TimedFrame&) {
    ++handled;
    recorded_when_handled = rig.seen.frames.size();
  });
  ASSERT_FALSE(rig.link.send(broadcast_read()));
  rig.link.run_for(10ms);
  EXPECT_EQ(handled, 1U);
  EXPECT_EQ(recorded_when_handled, 2U);
  EXPECT_EQ(rig.seen.frames.size(), 2U);
  rig.link.set_frame_handler({});
  ASSERT_FALSE(rig.link.send(broadcast_read()));
  EXPECT_TRUE(rig.link.receive(rig.link.now() + 10ms));
  EXPECT_EQ(rig.seen.frames.size(), 4U);
}

TEST(RecordingLink, AFrameTheLinkRefusesIsNotRecorded) {
  // Given a recording link whose segment is down
  // When the master sends a frame
  // Then send() reports link_down and the recorder saw nothing
  OneSlave rig;
  rig.segment.set_link_down(true);
  EXPECT_EQ(rig.link.send(broadcast_read()), make_error_code(LinkError::link_down));
  EXPECT_TRUE(rig.seen.frames.empty());
}

}  // namespace
}  // namespace drivecheck::ethercat
