#include "protocol/can/frame.hpp"

#include <gtest/gtest.h>

namespace drivecheck::can {
namespace {

TEST(CandumpCompact, ParsesStandardDataFrame) {
  // Given the Festo SDO example "write 32 bits to 6041h" as candump text
  // When it is parsed
  // Then id, format, DLC and data are those of the text
  // ccs=1 e=1 s=1 n=0, index 6041h sub 0, data 0
  const auto frame = parse_candump("605#2341600000000000");
  ASSERT_TRUE(frame) << frame.error();
  EXPECT_EQ(frame->id, 0x605u);
  EXPECT_FALSE(frame->is_extended());
  EXPECT_EQ(frame->dlc, 8);
  EXPECT_EQ(frame->data[0], 0x23);
  EXPECT_EQ(frame->data[2], 0x60);
  EXPECT_EQ(to_candump(*frame), "605#2341600000000000");
}

TEST(CandumpCompact, RoundTripsEveryShape) {
  // Given one frame text of each kind
  // When each is parsed and printed again
  // Then the text is unchanged
  for (const char* text :
       {"000#", "7FF#01", "704#R", "704#R3", "12345678#DEADBEEF", "00000000#", "1FFFFFFF#R8",
        "20000080#0000000000000000", "123#1122334455667788_C", "080#"}) {
    const auto frame = parse_candump(text);
    ASSERT_TRUE(frame) << text << ": " << frame.error();
    EXPECT_EQ(to_candump(*frame), text);
  }
}

TEST(CandumpCompact, AcceptsDotsAndLowercase) {
  // Given data with '.' separators and lower-case hex
  // When parsed
  // Then the dots are ignored and the frame prints in the canonical form
  const auto frame = parse_candump("18a#de.ad.be.ef");
  ASSERT_TRUE(frame) << frame.error();
  EXPECT_EQ(to_candump(*frame), "18A#DEADBEEF");
}

TEST(CandumpCompact, ErrorFrameKeepsErrorClass) {
  const auto frame = parse_candump("20000004#0004000000000000");
  ASSERT_TRUE(frame) << frame.error();
  EXPECT_TRUE(frame->is_error());
  EXPECT_EQ(frame->id, 0x4u);
}

TEST(CandumpCompact, RejectsMalformedText) {
  // Given malformed frame texts
  // When parsed
  // Then each gives an error that names the problem, never a frame
  const std::pair<const char*, const char*> cases[] = {
      {"605", "no '#'"},
      {"6050#00", "4 hex digits"},
      {"800#00", "above 7FF"},
      {"G05#00", "not a hex digit"},
      {"605#0", "odd number"},
      {"605#0G", "not a hex digit"},
      {"605#001122334455667788", "more than 8"},
      {"605##100", "CAN FD"},
      {"605#R9", "0..8"},
      {"605#RR", "0..8"},
      {"605#0011_9", "after 8 data bytes"},
      {"605#0011223344556677_8", "9..F"},
      {"C0000000#00", "above bit 28"},
      {"E0000000#00", "above bit 29"},
      {"20000000#R", "remote"},
  };
  for (const auto& [text, expected] : cases) {
    const auto frame = parse_candump(text);
    ASSERT_FALSE(frame) << text;
    EXPECT_NE(frame.error().find(expected), std::string::npos) << text << ": " << frame.error();
  }
}

TEST(CandumpCompact, FmtFormatterPrintsCompactText) {
  EXPECT_EQ(fmt::format("{}", Frame::standard(0x605, {0x40, 0x41, 0x60})), "605#404160");
  EXPECT_EQ(fmt::format("{}", Frame::remote(0x705)), "705#R");
}

TEST(FrameEquality, IgnoresNothingButComparesAllFields) {
  EXPECT_EQ(Frame::standard(0x1, {1}), Frame::standard(0x1, {1}));
  EXPECT_NE(Frame::standard(0x1, {1}), Frame::standard(0x1, {2}));
  EXPECT_NE(Frame::standard(0x1, {}), Frame::remote(0x1));
}

}  // namespace
}  // namespace drivecheck::can
