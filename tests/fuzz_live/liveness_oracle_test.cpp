#include "fuzz/live/liveness_oracle.hpp"

#include <gtest/gtest.h>

namespace drivecheck::fuzz_live {
namespace {

using namespace std::chrono_literals;

constexpr std::uint8_t kNode = 3;

can::TimedFrame at(can::Duration t, const can::Frame& frame) {
  return {frame, can::TimePoint(t), false};
}
// heartbeat of node 3: 703h, state 7Fh (pre-operational)
const can::Frame kHeartbeat = can::Frame::standard(0x703, {0x7F});
// boot-up of node 3: 703h, 00h
const can::Frame kBootUp = can::Frame::standard(0x703, {0x00});
// EMCY of node 3: error code 8130h (heartbeat/guarding), register 11h
const can::Frame kEmcy = can::Frame::standard(0x083, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0});

// Runs one case: frames during the case, then the observation window 100..200 ms.
std::optional<Anomaly> judge(LivenessOracle& oracle, const std::vector<can::TimedFrame>& in_case,
                             const std::vector<can::TimedFrame>& in_window, bool sdo, bool guard,
                             bool reset = false) {
  oracle.begin_case(can::TimePoint(0ms));
  if (reset) oracle.expect_boot_up();
  for (const auto& f : in_case)
    oracle.on_frame(f);
  oracle.begin_observation(can::TimePoint(100ms));
  for (const auto& f : in_window)
    oracle.on_frame(f);
  oracle.end_observation(can::TimePoint(200ms), sdo, guard);
  return oracle.verdict();
}

TEST(LiveLivenessOracle, HealthyNodeHasNoAnomaly) {
  // Given a node that answers the ping and sends an EMCY during the case
  // When the oracle judges
  // Then there is no anomaly, and the EMCY is counted
  LivenessOracle oracle({.node = kNode});
  EXPECT_FALSE(judge(oracle, {at(10ms, kEmcy)}, {}, true, true));
  EXPECT_EQ(oracle.emcy_frames(), 1U);
}

TEST(LiveLivenessOracle, FloodFromTheNodeIsBabbling) {
  // Given 500 frames from node 3 in the 100 ms window (5000/s, limit 2000/s)
  // When the oracle judges
  // Then the node babbles, even though the ping was answered
  LivenessOracle oracle({.node = kNode});
  std::vector<can::TimedFrame> flood;
  for (int i = 0; i < 500; ++i)
    flood.push_back(at(100ms + i * 200us, kEmcy));
  const auto anomaly = judge(oracle, {}, flood, true, true);
  ASSERT_TRUE(anomaly);
  EXPECT_EQ(anomaly->kind, AnomalyKind::babbling);
}

TEST(LiveLivenessOracle, FloodFromAnotherNodeIsNotBabbling) {
  // Given 500 frames from node 4 in the window
  // When the oracle for node 3 judges
  // Then there is no anomaly
  LivenessOracle oracle({.node = kNode});
  std::vector<can::TimedFrame> flood;
  for (int i = 0; i < 500; ++i)
    flood.push_back(at(100ms + i * 200us, can::Frame::standard(0x084, {0xFF})));
  EXPECT_FALSE(judge(oracle, {}, flood, true, true));
}

TEST(LiveLivenessOracle, NoAnswerAndNoFrameIsSilent) {
  // Given a node that neither answers the ping nor sends anything
  // When the oracle judges
  // Then the device is silent (crashed)
  LivenessOracle oracle({.node = kNode});
  const auto anomaly = judge(oracle, {}, {}, false, false);
  ASSERT_TRUE(anomaly);
  EXPECT_EQ(anomaly->kind, AnomalyKind::device_silent);
}

TEST(LiveLivenessOracle, HeartbeatWithoutSdoAnswerIsSdoHang) {
  // Given a node that sends heartbeats but does not answer the SDO ping
  // When the oracle judges
  // Then its SDO server does not answer
  LivenessOracle oracle({.node = kNode, .heartbeat_period = 50ms});
  const auto anomaly =
      judge(oracle, {}, {at(120ms, kHeartbeat), at(170ms, kHeartbeat)}, false, true);
  ASSERT_TRUE(anomaly);
  EXPECT_EQ(anomaly->kind, AnomalyKind::sdo_no_answer);
}

TEST(LiveLivenessOracle, BootUpWithoutResetIsUnexpected) {
  // Given a boot-up during a case that sent no NMT reset
  // When the oracle judges
  // Then the device reset itself; with a reset expected it is fine
  LivenessOracle oracle({.node = kNode});
  const auto anomaly = judge(oracle, {at(20ms, kBootUp)}, {}, true, true);
  ASSERT_TRUE(anomaly);
  EXPECT_EQ(anomaly->kind, AnomalyKind::unexpected_boot_up);
  EXPECT_FALSE(judge(oracle, {at(20ms, kBootUp)}, {}, true, true, true));
}

TEST(LiveLivenessOracle, ResetWithoutBootUpIsAnAnomaly) {
  // Given an NMT reset sent to the node and no boot-up
  // When the oracle judges
  // Then no-boot-up
  LivenessOracle oracle({.node = kNode});
  const auto anomaly = judge(oracle, {}, {}, true, true, true);
  ASSERT_TRUE(anomaly);
  EXPECT_EQ(anomaly->kind, AnomalyKind::no_boot_up);
}

TEST(LiveLivenessOracle, MissingHeartbeatIsLost) {
  // Given a heartbeat producer (40 ms) whose heartbeats stopped, the SDO still answering
  // When the oracle judges
  // Then heartbeat-lost; with a heartbeat in the window there is none
  LivenessOracle oracle({.node = kNode, .heartbeat_period = 40ms});
  EXPECT_GE(oracle.window(), 100ms);
  const auto anomaly = judge(oracle, {}, {}, true, true);
  ASSERT_TRUE(anomaly);
  EXPECT_EQ(anomaly->kind, AnomalyKind::heartbeat_lost);
  EXPECT_FALSE(judge(oracle, {}, {at(150ms, kHeartbeat)}, true, true));
}

TEST(LiveLivenessOracle, LongHeartbeatTimeDoesNotStretchTheWindow) {
  // Given a case that set 1017h to FFFFh (65.5 s), which the reset did not undo
  LivenessOracle oracle({.node = kNode, .heartbeat_period = 65535ms});
  // When the oracle gives its window and judges a short observation without heartbeat
  // Then the window is capped, and the missing heartbeat is no anomaly within it
  EXPECT_LE(oracle.window(), LivenessOracle::kMaxWindow);
  EXPECT_FALSE(judge(oracle, {}, {}, true, true));
}

TEST(LiveLivenessOracle, GuardingCheckedOnlyWhenAnsweredAtStart) {
  // Given a node that does not answer the guarding request
  // When the oracle judges with and without guarding configured
  // Then guarding-lost only with guarding configured
  LivenessOracle guarded({.node = kNode, .guarding = true});
  const auto anomaly = judge(guarded, {}, {}, true, false);
  ASSERT_TRUE(anomaly);
  EXPECT_EQ(anomaly->kind, AnomalyKind::guarding_lost);
  LivenessOracle unguarded({.node = kNode});
  EXPECT_FALSE(judge(unguarded, {}, {}, true, false));
}

TEST(LiveLivenessOracle, KindNamesRoundTrip) {
  // Given every anomaly kind
  // When its name is parsed back
  // Then it is the same kind; an unknown name is none
  for (auto kind : {AnomalyKind::babbling, AnomalyKind::device_silent, AnomalyKind::sdo_no_answer,
                    AnomalyKind::no_boot_up, AnomalyKind::unexpected_boot_up,
                    AnomalyKind::heartbeat_lost, AnomalyKind::guarding_lost}) {
    EXPECT_EQ(anomaly_kind_from_string(to_string(kind)), kind);
  }
  EXPECT_FALSE(anomaly_kind_from_string("crash"));
}

}  // namespace
}  // namespace drivecheck::fuzz_live
