#include "protocol/cia301/error_control.hpp"

#include <gtest/gtest.h>

namespace drivecheck::cia301 {
namespace {

can::Frame frame_of(const char* text) {
  auto frame = can::parse_candump(text);
  EXPECT_TRUE(frame) << text;
  return frame.value_or(can::Frame{});
}

TEST(ErrorControlEncode, FestoFrames) {
  // Given boot-up, heartbeat, guarding request and response of node 1 (Festo §3.7-3.9,
  //   000_33c1d912b8b6010a.txt L1415-1499; digest vectors 11-13)
  // When encoded
  // Then they are 701#00, 701#7F, 701#R and 701#FF (toggle 1 + pre-operational)
  EXPECT_EQ(can::to_candump(encode(BootUp{1})), "701#00");
  EXPECT_EQ(can::to_candump(encode(Heartbeat{1, NmtState::pre_operational})), "701#7F");
  EXPECT_EQ(can::to_candump(encode(Heartbeat{1, NmtState::operational})), "701#05");
  EXPECT_EQ(can::to_candump(encode(GuardRequest{1})), "701#R");
  EXPECT_EQ(can::to_candump(encode(GuardRequest{1, 1})), "701#R1");
  EXPECT_EQ(can::to_candump(encode(GuardResponse{1, true, NmtState::pre_operational})), "701#FF");
  EXPECT_EQ(can::to_candump(encode(GuardResponse{1, false, NmtState::operational})), "701#05");
  EXPECT_EQ(can::to_candump(encode(GuardResponse{1, true, NmtState::stopped})), "701#84");
}

TEST(ErrorControlDecode, KollmorgenBootUp) {
  // Given the Kollmorgen boot-up example "703: 00" (002_953174ea6ca45cdb.txt L7411)
  const auto message = decode_error_control(frame_of("703#00"));
  // When decoded
  // Then it is node 3's boot-up
  ASSERT_TRUE(message) << message.error().reason;
  EXPECT_EQ(std::get<BootUp>(*message), BootUp{3});
}

TEST(ErrorControlDecode, GuardingToggleSequence) {
  // Given the guarding responses of digest vector 13: 7F, FF, 7F (toggle starts at 0)
  // When decoded as guarding responses
  // Then the toggle alternates and the state stays pre-operational
  const char* texts[] = {"701#7F", "701#FF", "701#7F"};
  bool expected_toggle = false;
  for (const char* text : texts) {
    const auto response = decode_guard_response(frame_of(text));
    ASSERT_TRUE(response) << response.error().reason;
    EXPECT_EQ(response->toggle, expected_toggle) << text;
    EXPECT_EQ(response->state, NmtState::pre_operational);
    expected_toggle = !expected_toggle;
  }
}

TEST(ErrorControlDecode, RequestsKeepTheirDlc) {
  // Given remote frames on 705h with DLC 0, 1 and 2
  // When decoded
  // Then 0 and 1 are requests, 2 is invalid
  EXPECT_EQ(std::get<GuardRequest>(*decode_error_control(frame_of("705#R"))), (GuardRequest{5, 0}));
  EXPECT_EQ(std::get<GuardRequest>(*decode_error_control(frame_of("705#R1"))),
            (GuardRequest{5, 1}));
  const auto bad = decode_error_control(frame_of("705#R2"));
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().reason.find("DLC 2"), std::string::npos);
}

TEST(ErrorControlDecode, HeartbeatRules) {
  // Given heartbeat candidates
  // When decoded strictly as heartbeats
  // Then states decode, boot-up is state boot_up, bit 7 set and RTRs are rejected
  EXPECT_EQ(*decode_heartbeat(frame_of("77F#04")), (Heartbeat{127, NmtState::stopped}));
  EXPECT_EQ(*decode_heartbeat(frame_of("701#00")), (Heartbeat{1, NmtState::boot_up}));
  const auto toggled = decode_heartbeat(frame_of("701#85"));
  ASSERT_FALSE(toggled);
  EXPECT_NE(toggled.error().reason.find("bit 7 is reserved"), std::string::npos);
  EXPECT_FALSE(decode_heartbeat(frame_of("701#R")));
  EXPECT_FALSE(decode_guard_response(frame_of("701#00")));
}

TEST(ErrorControlDecode, RejectsMalformedFrames) {
  // Given malformed error-control frames
  // When decoded
  // Then each is invalid and the reason names the defect
  const std::pair<const char*, const char*> cases[] = {
      {"701#", "DLC 0: invalid"},
      {"701#7F00", "DLC 2: invalid"},
      {"701#03", "state byte 03h"},
      {"701#80", "state byte 80h"},
      {"701#FE", "state byte FEh"},
      {"700#7F", "not on CAN-ID 701h..77Fh"},
      {"780#7F", "not on CAN-ID 701h..77Fh"},
      {"00000701#7F", "not on CAN-ID 701h..77Fh"},
  };
  for (const auto& [text, expected] : cases) {
    const auto message = decode_error_control(frame_of(text));
    ASSERT_FALSE(message) << text;
    EXPECT_NE(message.error().reason.find(expected), std::string::npos)
        << text << ": " << message.error().reason;
  }
}

TEST(ErrorControlDecode, EveryStateByteIsTotal) {
  // Given every 1-byte payload on 701h
  // When decoded
  // Then exactly 00h (boot-up) and 04h/05h/7Fh with either toggle decode: 7 values
  int valid = 0;
  for (unsigned byte = 0; byte < 256; ++byte) {
    if (decode_error_control(can::Frame::standard(0x701, {static_cast<std::uint8_t>(byte)})))
      ++valid;
  }
  EXPECT_EQ(valid, 7);
}

}  // namespace
}  // namespace drivecheck::cia301
