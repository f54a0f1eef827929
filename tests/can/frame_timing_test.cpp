#include "protocol/can/frame_timing.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <random>
#include <string>

namespace drivecheck::can {
namespace {

using std::chrono::microseconds;

std::array<std::uint8_t, 8> filled(std::uint8_t value) {
  std::array<std::uint8_t, 8> bytes{};
  bytes.fill(value);
  return bytes;
}

TEST(Crc15Can, MatchesCatalogueCheckValue) {
  // Given the ASCII bytes "123456789"
  // When CRC-15/CAN is computed over them
  // Then it is the catalogued check value 0x059E (poly 0x4599, init 0, no reflection)
  const std::string text = "123456789";
  const std::span<const std::uint8_t> bytes(reinterpret_cast<const std::uint8_t*>(text.data()),
                                            text.size());
  EXPECT_EQ(crc15_can(bytes), 0x059E);
}

TEST(WireBits, AllZeroBaseFrameWorkedByHand) {
  // Given 000# (id 0, data frame, DLC 0): SOF..DLC are 19 dominant bits and the CRC of
  // all-zero bits is 0, so SOF..CRC are 34 dominant bits
  // When the frame is put on the wire
  // Then a recessive stuff bit follows every 5th dominant bit (6 stuff bits), then
  // CRC del 1, ACK 0, ACK del 1, EOF 1111111, IFS 111: 34 + 6 + 13 = 53 bits
  const Frame frame = Frame::standard(0x000, {});
  EXPECT_EQ(frame_crc15(frame), 0);
  // 00000 1 00000 1 00000 1 00000 1 00000 1 00000 1 0000 | 1 0 1 1111111 111
  EXPECT_EQ(wire_bit_string(frame), "00000100000100000100000100000100000100001011111111111");
  EXPECT_EQ(frame_bits(frame, BitStuffing::exact), 53u);
}

TEST(WireBits, MatchesReferenceStreams) {
  // Given frames whose bit streams were computed bit by bit from the ISO 11898-1 layout
  // (SOF, identifier, RTR/SRR, IDE, reserved, DLC, data, CRC-15, stuffing, fixed tail)
  // When each frame's wire bits are computed
  // Then CRC and bit stream are the reference ones
  struct Case {
    Frame frame;
    std::uint16_t crc;
    const char* bits;
  };
  const Case cases[] = {
      // 7FF#: id 7FFh (all recessive: stuffing after each 5 ones), DLC 0
      {Frame::standard(0x7FF, {}), 0x272F, "01111101111101000001000100111001011111011111111111"},
      // 704#R: NMT error control remote request of node 4, RTR recessive, DLC 0
      {Frame::remote(0x704), 0x53BF, "01110000011001000001010100111011111011011111111111"},
      // 701#05: boot-up/heartbeat of node 1, state 05h (operational)
      {Frame::standard(0x701, {0x05}), 0x4D0E,
       "0111000001001000001010000011011001101000011101011111111111"},
      // 605#2341600000000000: SDO download ccs=1 e=1 s=1 n=0, index 6041h sub 0, data 0
      {Frame::standard(0x605, {0x23, 0x41, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00}), 0x07AD,
       "011000001010100010000011000110100000110110000010000010000010000010000010000010000010000"
       "010000010000111101011011011111111111"},
      // 12345678#DEADBEEF: extended, ID-A 48Dh, SRR=1 IDE=1, ID-B 05678h, 4 bytes
      {Frame::extended(0x12345678, std::array<std::uint8_t, 4>{0xDE, 0xAD, 0xBE, 0xEF}), 0x331B,
       "010010001101110001010110011110000010010011011110101011011011111001110111101100110001101"
       "11011111111111"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(to_candump(c.frame));
    EXPECT_EQ(frame_crc15(c.frame), c.crc);
    EXPECT_EQ(wire_bit_string(c.frame), c.bits);
    EXPECT_EQ(frame_bits(c.frame, BitStuffing::exact), std::string(c.bits).size());
  }
}

TEST(FrameBitsExact, ZeroPayloadStuffsFarMoreThanAlternatingBits) {
  // Given 123# with eight 00h bytes and 123# with eight 55h bytes
  // When their exact lengths are computed
  // Then the zeros need 125 bits (a stuff bit every 5 bits) and 55h only 112 bits
  const Frame zeros = Frame::standard(0x123, filled(0x00));
  const Frame alternating = Frame::standard(0x123, filled(0x55));
  EXPECT_EQ(frame_crc15(zeros), 0x044E);
  EXPECT_EQ(frame_crc15(alternating), 0x657F);
  EXPECT_EQ(frame_bits(zeros, BitStuffing::exact), 125u);
  EXPECT_EQ(frame_bits(alternating, BitStuffing::exact), 112u);
}

TEST(FrameBitsExact, AgreesWithBitByBitStreamForRandomFrames) {
  // Given 20000 pseudo-random frames of every shape (base/extended, data/remote, DLC 0..15)
  // When the table-driven exact count is compared with the bit-by-bit stream
  // Then they agree, and never exceed the worst case nor fall below the unstuffed length
  std::mt19937_64 rng(42);
  for (int i = 0; i < 20000; ++i) {
    const std::uint64_t r = rng();
    Frame frame;
    frame.format = (r & 1) != 0 ? IdFormat::extended : IdFormat::standard;
    frame.kind = (r & 2) != 0 && (r & 4) != 0 ? FrameKind::remote : FrameKind::data;
    frame.id = static_cast<std::uint32_t>(r >> 8) &
               (frame.is_extended() ? kMaxExtendedId : kMaxStandardId);
    frame.dlc = static_cast<std::uint8_t>((r >> 40) & 0xF);
    const std::uint64_t payload = (r & 8) != 0 ? rng() : 0;  // zeros stuff the most
    for (std::size_t b = 0; b < frame.length(); ++b) {
      frame.data[b] = static_cast<std::uint8_t>(payload >> (8 * b));
    }
    const std::uint32_t exact = frame_bits(frame, BitStuffing::exact);
    ASSERT_EQ(exact, wire_bit_string(frame).size()) << to_candump(frame);
    ASSERT_LE(exact, frame_bits(frame, BitStuffing::worst_case)) << to_candump(frame);
    const std::uint32_t unstuffed = (frame.is_extended() ? 39u : 19u) +
                                    8 * static_cast<std::uint32_t>(frame.length()) + 15 + 13;
    ASSERT_GE(exact, unstuffed) << to_candump(frame);
  }
}

TEST(FrameBitsWorstCase, MatchesTheKnownFormula) {
  // Given base and extended frames with 0 and 8 data bytes, and remote frames
  // When the worst-case length is computed (stuffable n bits: n + (n-1)/4 + 13)
  // Then base 8 bytes = 135, extended 8 bytes = 160, base 0 bytes = 55, extended 0 = 80,
  // and a remote frame's DLC adds no data bits
  EXPECT_EQ(frame_bits(Frame::standard(0x7FF, filled(0xFF)), BitStuffing::worst_case), 135u);
  EXPECT_EQ(frame_bits(Frame::extended(0x1FFFFFFF, filled(0xFF)), BitStuffing::worst_case), 160u);
  EXPECT_EQ(frame_bits(Frame::standard(0x000, {}), BitStuffing::worst_case), 55u);
  EXPECT_EQ(frame_bits(Frame::extended(0, {}), BitStuffing::worst_case), 80u);
  EXPECT_EQ(frame_bits(Frame::remote(0x704, 8), BitStuffing::worst_case), 55u);
  EXPECT_EQ(frame_bits(Frame::remote(0x1234, 8, IdFormat::extended), BitStuffing::worst_case), 80u);
}

TEST(FrameBits, DlcAboveEightCarriesEightBytes) {
  // Given a data frame with DLC 12 (len8_dlc) and eight data bytes
  // When its worst-case length is computed
  // Then it is that of an 8-byte frame
  Frame frame = Frame::standard(0x123, filled(0xA5));
  frame.dlc = 12;
  EXPECT_EQ(frame_bits(frame, BitStuffing::worst_case), 135u);
}

TEST(FrameBits, ErrorFrameIsFlagDelimiterAndIntermission) {
  // Given an error frame
  // When its length is computed
  // Then it is 6 flag + 8 delimiter + 3 intermission bits (exact), 12 + 8 + 3 (worst case)
  Frame error;
  error.kind = FrameKind::error;
  error.id = 0x4;
  EXPECT_EQ(frame_bits(error, BitStuffing::exact), 17u);
  EXPECT_EQ(frame_bits(error, BitStuffing::worst_case), 23u);
  EXPECT_EQ(wire_bit_string(error), "");
}

TEST(FrameDuration, WorstCaseAtFourBitRates) {
  // Given a worst-case base 8-byte frame (135 bits) and extended 8-byte frame (160 bits)
  // When their durations are computed at 125k, 250k, 500k and 1M bit/s
  // Then they are bits x bit time: 8, 4, 2 and 1 us per bit
  const Frame base = Frame::standard(0x181, filled(0x11));
  const Frame extended = Frame::extended(0x18FF0001, filled(0x11));
  const struct {
    std::uint32_t bitrate;
    microseconds base;
    microseconds extended;
  } cases[] = {
      {125'000, microseconds(1080), microseconds(1280)},
      {250'000, microseconds(540), microseconds(640)},
      {500'000, microseconds(270), microseconds(320)},
      {1'000'000, microseconds(135), microseconds(160)},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.bitrate);
    EXPECT_EQ(frame_duration(base, c.bitrate, BitStuffing::worst_case), c.base);
    EXPECT_EQ(frame_duration(extended, c.bitrate, BitStuffing::worst_case), c.extended);
  }
}

TEST(FrameDuration, ExactAtFourBitRates) {
  // Given 000# (53 bits exact) and 123# with eight zero bytes (125 bits exact)
  // When their durations are computed at 125k, 250k, 500k and 1M bit/s
  // Then they are the exact bit counts times the bit time
  const Frame empty = Frame::standard(0x000, {});
  const Frame zeros = Frame::standard(0x123, filled(0x00));
  for (std::uint32_t bitrate : {125'000u, 250'000u, 500'000u, 1'000'000u}) {
    SCOPED_TRACE(bitrate);
    const auto bit = std::chrono::nanoseconds(1'000'000'000 / bitrate);
    EXPECT_EQ(frame_duration(empty, bitrate, BitStuffing::exact), 53 * bit);
    EXPECT_EQ(frame_duration(zeros, bitrate, BitStuffing::exact), 125 * bit);
  }
}

TEST(BitDuration, RoundsDownAndRejectsZeroBitrate) {
  // Given a bit rate whose bit time is not a whole number of nanoseconds, and bit rate 0
  // When bit durations are computed
  // Then they are rounded down to whole nanoseconds, and bit rate 0 gives Duration::max()
  EXPECT_EQ(bit_duration(3, 3'000'000 / 9), std::chrono::nanoseconds(9000));  // 3000 ns per bit
  EXPECT_EQ(bit_duration(1, 33'333), std::chrono::nanoseconds(30000));        // 30000.3 ns
  EXPECT_EQ(bit_duration(100, 33'333), std::chrono::nanoseconds(3000030));
  EXPECT_EQ(bit_duration(10, 0), Duration::max());
}

}  // namespace
}  // namespace drivecheck::can
