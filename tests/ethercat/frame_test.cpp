#include "protocol/ethercat/frame.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <set>
#include <string>
#include <vector>

namespace drivecheck::ethercat {
namespace {

using Bytes = std::vector<std::uint8_t>;

// An independent copy of the command codes (ESC Technology Table 6), on purpose: it checks
// the one table in datagram_commands.inc.
TEST(CommandTable, CodesAndMnemonicsMatchTheDatasheet) {
  // Given the 15 command types of the ESC datasheet
  // When the table is read
  // Then every code has its mnemonic, addressing and working-counter rule
  const std::pair<std::uint8_t, const char*> expected[] = {
      {0, "NOP"},  {1, "APRD"}, {2, "APWR"}, {3, "APRW"},  {4, "FPRD"},
      {5, "FPWR"}, {6, "FPRW"}, {7, "BRD"},  {8, "BWR"},   {9, "BRW"},
      {10, "LRD"}, {11, "LWR"}, {12, "LRW"}, {13, "ARMW"}, {14, "FRMW"}};
  ASSERT_EQ(command_table().size(), std::size(expected));
  for (const auto& [code, name] : expected) {
    const auto info = find_command(code);
    ASSERT_TRUE(info) << int{code};
    EXPECT_EQ(info->mnemonic, name);
  }
  EXPECT_FALSE(find_command(15));
  EXPECT_EQ(find_command(12)->wkc, WkcRule::read_write);
  EXPECT_EQ(find_command(13)->access, Access::read_multiple_write);
  EXPECT_EQ(find_command(7)->addressing, Addressing::broadcast);
  EXPECT_EQ(command_name(static_cast<Command>(0x1F)), "CMD 1Fh");
}

TEST(FrameCodec, EncodesOneFprdPaddedTo60Bytes) {
  // Given an FPRD of AL status (0130h, 2 bytes) at station 1001h
  // When the frame is encoded
  // Then the bytes are Ethernet + EtherCAT header + datagram, zero-padded to 60
  Frame frame;
  frame.source = {0x02, 0, 0, 0, 0, 1};
  frame.datagrams.push_back(Datagram::physical(Command::fprd, 0x03, 0x1001, 0x0130, {0, 0}));
  const auto bytes = encode_frame(frame);
  ASSERT_TRUE(bytes) << bytes.error().message();
  const Bytes expected_start = {
      0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF,  // destination broadcast
      0x02, 0x00, 0x00, 0x00, 0x00, 0x01,  // source
      0x88, 0xA4,                          // EtherType
      0x0E, 0x10,                          // EtherCAT header: length 14, type 1
      // cmd=FPRD idx=03 ADP=1001h ADO=0130h len=2 (M=0 C=0) irq=0, data 0000, wkc 0
      0x04, 0x03, 0x01, 0x10, 0x30, 0x01, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00};
  ASSERT_EQ(bytes->size(), kMinFrameSize);
  EXPECT_EQ(Bytes(bytes->begin(), bytes->begin() + expected_start.size()), expected_start);
  for (std::size_t i = expected_start.size(); i < bytes->size(); ++i)
    EXPECT_EQ((*bytes)[i], 0);
}

TEST(FrameCodec, RoundTripsSeveralDatagramsWithMoreFollows) {
  // Given a frame with an LRW, a BRD and an ARMW (circulating, irq set)
  // When it is encoded and decoded
  // Then the decoded frame equals the original, M set on all but the last
  Frame frame;
  frame.source = {0x02, 1, 2, 3, 4, 5};
  frame.datagrams.push_back(Datagram::logical(Command::lrw, 1, 0x00010000, {1, 2, 3, 4}));
  frame.datagrams.push_back(Datagram::physical(Command::brd, 2, 0, 0x0000, {0}));
  auto armw = Datagram::physical(Command::armw, 3, 0xFFFF, 0x0910, Bytes(8, 0));
  armw.circulating = true;
  armw.irq = 0x0102;
  armw.working_counter = 7;
  frame.datagrams.push_back(armw);
  const auto bytes = encode_frame(frame);
  ASSERT_TRUE(bytes);
  const auto decoded = decode_frame(*bytes);
  ASSERT_TRUE(decoded) << decoded.error().message();
  ASSERT_EQ(decoded->datagrams.size(), 3u);
  EXPECT_TRUE(decoded->datagrams[0].more_follows);
  EXPECT_TRUE(decoded->datagrams[1].more_follows);
  EXPECT_FALSE(decoded->datagrams[2].more_follows);
  frame.datagrams[0].more_follows = true;
  frame.datagrams[1].more_follows = true;
  EXPECT_EQ(*decoded, frame);
  EXPECT_EQ(fmt::format("{}", decoded->datagrams[2]),
            "ARMW idx=03 adp=FFFFh ado=0910h len=8 wkc=7 C irq=0102h data=00 00 00 00 00 00 00 00");
  EXPECT_EQ(fmt::format("{}", decoded->datagrams[0]),
            "LRW idx=01 addr=00010000h len=4 wkc=0 data=01 02 03 04");
}

TEST(FrameCodec, KeepsReservedBitsExactly) {
  // Given a frame whose datagram Len has reserved bit 12 set and whose EtherCAT header has
  // bit 11 set (found by the fuzz target: they were lost in the round trip)
  // When it is decoded and encoded again
  // Then the bytes are the same
  Frame frame;
  frame.header_reserved = true;
  frame.datagrams.push_back(Datagram::physical(Command::fprd, 1, 0x1001, 0x0130, {0, 0}));
  frame.datagrams[0].reserved = 0x02;
  const auto bytes = encode_frame(frame);
  ASSERT_TRUE(bytes);
  EXPECT_EQ((*bytes)[15], 0x18);      // type 1, reserved bit 11
  EXPECT_EQ((*bytes)[16 + 7], 0x10);  // Len high byte: bit 12
  const auto decoded = decode_frame(*bytes);
  ASSERT_TRUE(decoded);
  EXPECT_EQ(*decoded, frame);
  EXPECT_EQ(*encode_frame(*decoded), *bytes);
}

TEST(FrameCodec, DecodesVlanTaggedFrame) {
  // Given a frame with a VLAN tag before the EtherType
  // When decoded
  // Then the datagram is found after the tag
  Frame frame;
  frame.datagrams.push_back(Datagram::physical(Command::aprd, 9, 0, 0x0000, {0, 0}));
  auto bytes = *encode_frame(frame);
  const Bytes tag = {0x81, 0x00, 0x00, 0x05};
  bytes.insert(bytes.begin() + 12, tag.begin(), tag.end());
  const auto decoded = decode_frame(bytes);
  ASSERT_TRUE(decoded) << decoded.error().message();
  EXPECT_EQ(decoded->datagrams.at(0).index, 9);
}

TEST(FrameCodec, RefusesOversizedEncodes) {
  // Given a datagram of 2048 bytes and a frame of 1500 datagram bytes
  // When encoded
  // Then the errors say which limit is exceeded
  Frame too_long_datagram;
  too_long_datagram.datagrams.push_back(Datagram::logical(Command::lwr, 0, 0, Bytes(2048)));
  EXPECT_EQ(encode_frame(too_long_datagram).error(), FrameError::frame_too_long);
  Bytes out;
  std::vector<Datagram> one = {Datagram::logical(Command::lwr, 0, 0, Bytes(2048))};
  EXPECT_EQ(encode_datagrams(one, out), FrameError::datagram_too_long);
  Frame too_long_frame;
  too_long_frame.datagrams.push_back(Datagram::logical(Command::lwr, 0, 0, Bytes(1487)));
  EXPECT_EQ(encode_frame(too_long_frame).error(), FrameError::frame_too_long);
  too_long_frame.datagrams[0].data.resize(1486);  // 1486 + 12 = 1498: exactly full
  const auto full = encode_frame(too_long_frame);
  ASSERT_TRUE(full);
  EXPECT_EQ(full->size(), kMaxFrameSize);
}

// A valid frame with one APRD (2 data bytes) to break in the malformed-input tests.
Bytes valid_frame() {
  Frame frame;
  frame.datagrams.push_back(Datagram::physical(Command::aprd, 1, 0, 0x0130, {0, 0}));
  return *encode_frame(frame);
}

struct Malformed {
  const char* what;
  Bytes bytes;
  FrameError error;
  std::size_t offset;
};

TEST(FrameCodec, MalformedFramesGiveErrorsNamingTheOffset) {
  // Given frames broken in each way the decoder knows
  // When decoded
  // Then each gives its own error code and the offset of the problem, never a crash
  std::vector<Malformed> cases;
  cases.push_back({"empty", {}, FrameError::truncated_ethernet_header, 0});
  cases.push_back({"13 bytes", Bytes(13, 0), FrameError::truncated_ethernet_header, 13});
  {
    Bytes b = valid_frame();
    b[12] = 0x08;
    b[13] = 0x00;  // IPv4
    cases.push_back({"IPv4", b, FrameError::wrong_ethertype, 12});
  }
  {
    Bytes b = valid_frame();
    b.resize(15);
    cases.push_back({"half header", b, FrameError::truncated_ethercat_header, 14});
  }
  {
    Bytes b = valid_frame();
    b[15] = 0x50;  // type 5 (mailbox gateway), length 14
    cases.push_back({"type 5", b, FrameError::unsupported_type, 14});
  }
  {
    Bytes b = valid_frame();
    b[14] = 0xFF;
    b[15] = 0x17;  // length 7FFh
    cases.push_back({"length 2047", b, FrameError::length_past_end, 14});
  }
  {
    Bytes b = valid_frame();
    b[14] = 0x00;
    b[15] = 0x10;  // length 0
    cases.push_back({"length 0", b, FrameError::no_datagrams, 16});
  }
  {
    Bytes b = valid_frame();
    b[14] = 0x08;  // length 8: header cut
    cases.push_back({"cut header", b, FrameError::truncated_datagram_header, 16});
  }
  {
    Bytes b = valid_frame();
    b[16 + 6] = 0x10;  // Len 16 inside EtherCAT length 14
    cases.push_back({"Len past end", b, FrameError::datagram_length_past_end, 16});
  }
  {
    Bytes b = valid_frame();
    b[16 + 7] = 0x80;  // M set on the only datagram
    cases.push_back({"M on last", b, FrameError::more_follows_past_end, 16});
  }
  {
    Bytes b = valid_frame();
    b[14] = 0x12;  // length 18: 4 bytes after the datagram with M=0
    cases.push_back({"trailing", b, FrameError::trailing_bytes, 30});
  }
  {
    Bytes b = valid_frame();
    b[16] = 0x0F;  // command 15
    cases.push_back({"cmd 15", b, FrameError::unknown_command, 16});
  }
  for (const Malformed& c : cases) {
    const auto decoded = decode_frame(c.bytes);
    ASSERT_FALSE(decoded) << c.what;
    EXPECT_EQ(decoded.error().code, c.error) << c.what << ": " << decoded.error().message();
    EXPECT_EQ(decoded.error().offset, c.offset) << c.what << ": " << decoded.error().message();
    EXPECT_FALSE(decoded.error().message().empty());
  }
}

TEST(FrameCodec, EveryErrorHasItsOwnMessage) {
  // Given every FrameError
  // When its message is asked for
  // Then the messages are distinct and none is the fallback
  std::set<std::string> messages;
  for (int e = 1; e <= static_cast<int>(FrameError::frame_too_long); ++e) {
    const std::string text = make_error_code(static_cast<FrameError>(e)).message();
    EXPECT_EQ(text.find("unknown ethercat-frame error"), std::string::npos) << e;
    messages.insert(text);
  }
  EXPECT_EQ(messages.size(), static_cast<std::size_t>(FrameError::frame_too_long));
}

TEST(FrameCodec, SurvivesEveryTruncationOfAValidFrame) {
  // Given a valid two-datagram frame
  // When every prefix of it is decoded
  // Then each prefix either decodes (the padding was cut) or gives an error, never a crash
  Frame frame;
  frame.datagrams.push_back(Datagram::physical(Command::fprd, 1, 0x1001, 0x0130, {0, 0}));
  frame.datagrams.push_back(Datagram::logical(Command::lrw, 2, 0x10000, Bytes(8, 0x55)));
  const Bytes bytes = *encode_frame(frame);
  const std::size_t content =
      kEthernetHeaderSize + kEthercatHeaderSize + encoded_size(frame.datagrams);
  for (std::size_t n = 0; n <= bytes.size(); ++n) {
    const auto decoded = decode_frame(std::span(bytes).first(n));
    EXPECT_EQ(decoded.has_value(), n >= content) << n;
  }
}

}  // namespace
}  // namespace drivecheck::ethercat
