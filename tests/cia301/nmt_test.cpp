#include "protocol/cia301/nmt.hpp"

#include <gtest/gtest.h>

namespace drivecheck::cia301 {
namespace {

can::Frame frame_of(const char* text) {
  auto frame = can::parse_candump(text);
  EXPECT_TRUE(frame) << text;
  return frame.value_or(can::Frame{});
}

TEST(NmtNodeControl, EncodesFestoCommandSpecifiers) {
  // Given each command of Festo Tab. 3.10 (000_33c1d912b8b6010a.txt L1361-1376)
  // When encoded for node 1
  // Then byte 0 is the CS and byte 1 the node-ID, DLC 2, CAN-ID 000h
  EXPECT_EQ(can::to_candump(encode(NmtNodeControl{NmtCommand::start, 1})), "000#0101");
  EXPECT_EQ(can::to_candump(encode(NmtNodeControl{NmtCommand::stop, 1})), "000#0201");
  EXPECT_EQ(can::to_candump(encode(NmtNodeControl{NmtCommand::enter_pre_operational, 1})),
            "000#8001");
  EXPECT_EQ(can::to_candump(encode(NmtNodeControl{NmtCommand::reset_node, 1})), "000#8101");
  EXPECT_EQ(can::to_candump(encode(NmtNodeControl{NmtCommand::reset_communication, 1})),
            "000#8201");
}

TEST(NmtNodeControl, DecodesBroadcast) {
  // Given "start all nodes" (digest vector 12: 000: 01 00)
  // cs=01h start, node 0 = all
  const auto message = decode_nmt_node_control(frame_of("000#0100"));
  // When decoded
  // Then it is a broadcast start
  ASSERT_TRUE(message) << message.error().reason;
  EXPECT_EQ(message->command, NmtCommand::start);
  EXPECT_TRUE(message->is_broadcast());
}

TEST(NmtNodeControl, RoundTripsEveryCommandAndNode) {
  // Given every command and node 0..127
  // When encoded and decoded
  // Then the message is unchanged
  for (auto command : {NmtCommand::start, NmtCommand::stop, NmtCommand::enter_pre_operational,
                       NmtCommand::reset_node, NmtCommand::reset_communication}) {
    for (unsigned node = 0; node <= 127; ++node) {
      const NmtNodeControl message{command, static_cast<std::uint8_t>(node)};
      const auto back = decode_nmt_node_control(encode(message));
      ASSERT_TRUE(back) << back.error().reason;
      EXPECT_EQ(*back, message);
    }
  }
}

TEST(NmtNodeControl, RejectsMalformedFrames) {
  // Given NMT frames with wrong DLC, unknown CS, node above 127, RTR, other ids
  // When decoded
  // Then each is invalid with a reason that names the defect
  const std::pair<const char*, const char*> cases[] = {
      {"000#01", "DLC 1: invalid (NMT frames carry 2 bytes)"},
      {"000#010100", "DLC 3"},
      {"000#", "DLC 0"},
      {"000#0301", "command specifier 03h"},
      {"000#0180", "node 128"},
      {"000#01FF", "node 255"},
      {"000#R", "remote request"},
      {"001#0101", "not CAN-ID 000h"},
      {"00000000#0101", "not CAN-ID 000h"},
  };
  for (const auto& [text, expected] : cases) {
    const auto message = decode_nmt_node_control(frame_of(text));
    ASSERT_FALSE(message) << text;
    EXPECT_NE(message.error().reason.find(expected), std::string::npos)
        << text << ": " << message.error().reason;
  }
}

TEST(NmtNodeControl, EveryTwoByteFrameDecodesOrExplains) {
  // Given every 2-byte payload on 000h
  // When decoded
  // Then exactly the 5 CS values with node 0..127 decode (5 * 128 frames), the rest explain
  int valid = 0;
  for (unsigned cs = 0; cs < 256; ++cs) {
    for (unsigned node = 0; node < 256; ++node) {
      const auto frame = can::Frame::standard(
          0x000, {static_cast<std::uint8_t>(cs), static_cast<std::uint8_t>(node)});
      const auto message = decode_nmt_node_control(frame);
      if (message) {
        ++valid;
      } else {
        EXPECT_FALSE(message.error().reason.empty());
      }
    }
  }
  EXPECT_EQ(valid, 5 * 128);
}

TEST(NmtState, ValuesAndNames) {
  // Given the state bytes of Festo §3.8.2 (L1437-1444) and the boot-up (L1419-1425)
  // When converted
  // Then 00h/04h/05h/7Fh are the four states, anything else none
  EXPECT_EQ(nmt_state_from_byte(0x00), NmtState::boot_up);
  EXPECT_EQ(nmt_state_from_byte(0x04), NmtState::stopped);
  EXPECT_EQ(nmt_state_from_byte(0x05), NmtState::operational);
  EXPECT_EQ(nmt_state_from_byte(0x7F), NmtState::pre_operational);
  EXPECT_FALSE(nmt_state_from_byte(0x01));
  EXPECT_FALSE(nmt_state_from_byte(0x85));
  EXPECT_EQ(to_string(NmtState::pre_operational), "pre-operational");
  EXPECT_EQ(to_string(NmtCommand::reset_communication), "reset communication");
  EXPECT_EQ(state_after(NmtCommand::start), NmtState::operational);
  EXPECT_EQ(state_after(NmtCommand::stop), NmtState::stopped);
  EXPECT_EQ(state_after(NmtCommand::reset_node), NmtState::pre_operational);
}

}  // namespace
}  // namespace drivecheck::cia301
