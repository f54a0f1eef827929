#include "tests/support/scripted_peer.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include "protocol/can/sim_bus.hpp"

namespace drivecheck::test_support {
namespace {

using namespace std::chrono_literals;

class ScriptedPeerTest : public ::testing::Test {
 protected:
  can::Frame frame(const char* text) { return *can::parse_candump(text); }
  std::optional<can::TimedFrame> receive(can::Duration within = 10ms) {
    return master_->receive(master_->now() + within);
  }

  can::SimBus bus_{{.bitrate = 500'000}};
  std::unique_ptr<can::SimPort> master_ = bus_.attach("master");
  std::unique_ptr<can::SimPort> server_ = bus_.attach("server");
};

TEST_F(ScriptedPeerTest, RepliesToEachExpectedFrameInOrder) {
  // Given a two-step script
  // When the master sends the expected frames
  // Then each is answered with its reply and the script is finished
  ScriptedPeer peer(*server_);
  peer.expect("605#40").reply("585#41");
  peer.expect("605#42").reply("585#43").reply("585#44");
  ASSERT_FALSE(master_->send(frame("605#40")));
  EXPECT_EQ(receive()->frame, frame("585#41"));
  ASSERT_FALSE(master_->send(frame("605#42")));
  EXPECT_EQ(receive()->frame, frame("585#43"));
  EXPECT_EQ(receive()->frame, frame("585#44"));
  EXPECT_TRUE(peer.finished());
  EXPECT_EQ(peer.transcript().size(), 2u);
}

TEST_F(ScriptedPeerTest, ReportsAnUnexpectedFrame) {
  // Given a script expecting 605#40
  // When the master sends 605#41, and then a frame after the script's end
  // Then both are reported as mismatches naming the frames, and no reply is sent
  ScriptedPeer peer(*server_);
  std::vector<std::string> reports;
  peer.set_mismatch_handler([&](const std::string& text) { reports.push_back(text); });
  peer.expect("605#40").reply("585#41");
  ASSERT_FALSE(master_->send(frame("605#41")));
  EXPECT_FALSE(receive());
  ASSERT_FALSE(master_->send(frame("605#40")));
  EXPECT_TRUE(receive());
  ASSERT_FALSE(master_->send(frame("605#40")));
  EXPECT_FALSE(receive());
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0], "step 1: got 605#41, expected 605#40");
  EXPECT_NE(reports[1].find("after the end of the script"), std::string::npos);
  EXPECT_FALSE(peer.finished());
}

TEST_F(ScriptedPeerTest, SilentAndLateReplies) {
  // Given a step without reply and one answered 50 ms late
  // When the master sends both frames
  // Then the first gets no answer and the second one only after 50 ms
  ScriptedPeer peer(*server_);
  peer.expect("605#01");
  peer.expect("605#02").reply_after(50ms, "585#02");
  ASSERT_FALSE(master_->send(frame("605#01")));
  EXPECT_FALSE(receive());
  ASSERT_FALSE(master_->send(frame("605#02")));
  const auto sent = master_->now();
  const auto answer = receive(100ms);
  ASSERT_TRUE(answer);
  EXPECT_GE(answer->timestamp - sent, 50ms);
  EXPECT_TRUE(peer.finished());
}

TEST_F(ScriptedPeerTest, ListensOnlyToItsIdentifiers) {
  // Given a peer listening to 605h only
  // When a frame on 606h comes before the expected one
  // Then it is not taken as a mismatch
  ScriptedPeer peer(*server_, {0x605});
  peer.expect("605#40").reply("585#41");
  ASSERT_FALSE(master_->send(frame("606#40")));
  ASSERT_FALSE(master_->send(frame("605#40")));
  EXPECT_EQ(receive()->frame, frame("585#41"));
  EXPECT_TRUE(peer.finished());
}

TEST_F(ScriptedPeerTest, RepeatStartsTheScriptOver) {
  // Given a one-step script with repeat on
  // When the master sends the frame three times
  // Then each gets the reply
  ScriptedPeer peer(*server_);
  peer.set_repeat(true);
  peer.set_transcript(false);
  peer.expect("605#40").reply("585#41");
  for (int i = 0; i < 3; ++i) {
    ASSERT_FALSE(master_->send(frame("605#40")));
    EXPECT_EQ(receive()->frame, frame("585#41"));
  }
  EXPECT_EQ(peer.mismatches(), 0u);
  EXPECT_TRUE(peer.transcript().empty());
}

}  // namespace
}  // namespace drivecheck::test_support
