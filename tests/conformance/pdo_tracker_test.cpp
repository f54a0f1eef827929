// The PDO configuration the harness follows from the bus (conformance/pdo_tracker.hpp), the
// decoding of PDO payloads into timing-diagram samples, and the thinning of samples
// (conformance/samples.hpp). Frames are fed directly: no bus, no drive.
#include "conformance/pdo_tracker.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <vector>

#include "conformance/samples.hpp"

namespace drivecheck::conformance {
namespace {

using namespace std::chrono_literals;
using cia301::PdoDirection;

constexpr std::uint8_t kNode = 5;

profile::DriveProfile make_profile(const std::string& pdo_defaults) {
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [pdo, pdo.dynamic-mapping]\npdo_defaults:\n" + pdo_defaults,
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return parsed ? *parsed : profile::DriveProfile{};
}

// TPDO1 on 180h+N with statusword and position; RPDO1 on 200h+N with controlword; TPDO2 not
// valid (bit 31) with statusword and mode display.
profile::DriveProfile standard_profile() {
  return make_profile(
      "  - {pdo: tpdo1, cob_id: \"180+N\", transmission: 255, mapping: [0x60410010, 0x60640020],"
      " source: \"CiA 301 §7.5.2.36\"}\n"
      "  - {pdo: tpdo2, cob_id: \"C0000280+N\", transmission: 255, mapping: [0x60410010, "
      "0x60610008], source: \"CiA 301 §7.5.2.36\"}\n"
      "  - {pdo: rpdo1, cob_id: \"200+N\", transmission: 255, mapping: [0x60400010],"
      " source: \"CiA 301 §7.5.2.36\"}\n");
}

can::Frame frame(const std::string& text) {
  auto parsed = can::parse_candump(text);
  EXPECT_TRUE(parsed) << text;
  return parsed ? *parsed : can::Frame{};
}

can::TimePoint at_ms(int ms) {
  return can::TimePoint{} + std::chrono::milliseconds(ms);
}

class PdoTrackerTest : public ::testing::Test {
 protected:
  // A frame the harness sends (its echo) / one the DUT sends.
  void harness(const std::string& text, int ms = 0) {
    tracker_.on_frame(frame(text), true, at_ms(ms), samples_);
  }
  void dut(const std::string& text, int ms = 0) {
    tracker_.on_frame(frame(text), false, at_ms(ms), samples_);
  }
  // A confirmed expedited download of 4 bytes.
  void write_u32(std::uint16_t index, std::uint8_t sub, std::uint32_t value) {
    harness(fmt::format("605#23{:02X}{:02X}{:02X}{:08X}", index & 0xFF, index >> 8, sub,
                        __builtin_bswap32(value)));
    dut(fmt::format("585#60{:02X}{:02X}{:02X}00000000", index & 0xFF, index >> 8, sub));
  }
  // A confirmed expedited download of 1 byte.
  void write_u8(std::uint16_t index, std::uint8_t sub, std::uint8_t value) {
    harness(
        fmt::format("605#2F{:02X}{:02X}{:02X}{:02X}000000", index & 0xFF, index >> 8, sub, value));
    dut(fmt::format("585#60{:02X}{:02X}{:02X}00000000", index & 0xFF, index >> 8, sub));
  }

  profile::DriveProfile profile_ = standard_profile();
  PdoTracker tracker_{profile_, kNode};
  std::vector<Sample> samples_;
};

TEST_F(PdoTrackerTest, ProfileDefaultsGiveCanIdAndMapping) {
  // Given the profile's defaults for node 5
  // When nothing was written yet
  // Then TPDO1 is on 185h with 6041h/6064h, RPDO1 on 205h, TPDO2 is not valid
  EXPECT_EQ(tracker_.can_id(PdoDirection::transmit, 1), 0x185U);
  ASSERT_TRUE(tracker_.mapping(PdoDirection::transmit, 1));
  EXPECT_EQ(tracker_.mapping(PdoDirection::transmit, 1)->entries.size(), 2U);
  EXPECT_EQ(tracker_.can_id(PdoDirection::receive, 1), 0x205U);
  EXPECT_EQ(tracker_.can_id(PdoDirection::transmit, 2), std::nullopt);
  // and a TPDO never configured (TPDO3) has no mapping
  EXPECT_EQ(tracker_.mapping(PdoDirection::transmit, 3), std::nullopt);
}

TEST_F(PdoTrackerTest, TpdoFromTheDutBecomesSamplesAtItsTime) {
  // Given TPDO1 by default
  // When the DUT sends 185#3702 18FCFFFF (statusword 0237h, position -1000) at 12 ms
  dut("185#370218FCFFFF", 12);
  // Then two TPDO samples at 12 ms: statusword 0237h and position -1000 (sign extended)
  ASSERT_EQ(samples_.size(), 2U);
  EXPECT_EQ(samples_[0].signal, "statusword");
  EXPECT_EQ(samples_[0].value, 0x0237);
  EXPECT_EQ(samples_[0].origin, SampleOrigin::tpdo);
  EXPECT_EQ(samples_[0].at, at_ms(12));
  EXPECT_EQ(samples_[1].signal, "position");
  EXPECT_EQ(samples_[1].value, -1000);
}

TEST_F(PdoTrackerTest, NotValidTpdoAndShortFramesGiveNoSamples) {
  // Given TPDO2 not valid by default; When the DUT sends on 285h
  dut("285#3702FA");
  // Then nothing is decoded
  EXPECT_TRUE(samples_.empty());
  // When TPDO1 arrives with 3 bytes for a 48-bit mapping
  dut("185#370218");
  // Then no sample, and it is counted as short
  EXPECT_TRUE(samples_.empty());
  EXPECT_EQ(tracker_.short_frames(), 1U);
}

TEST_F(PdoTrackerTest, RpdoIsDecodedOnlyWhenTheHarnessSendsIt) {
  // Given RPDO1 (controlword) by default
  // When the harness sends 205#0F00 (controlword 000Fh)
  harness("205#0F00", 3);
  // Then one RPDO sample of the controlword
  ASSERT_EQ(samples_.size(), 1U);
  EXPECT_EQ(samples_[0].signal, "controlword");
  EXPECT_EQ(samples_[0].value, 0x000F);
  EXPECT_EQ(samples_[0].origin, SampleOrigin::rpdo);
  // When the same identifier comes from another node: it is not the harness's RPDO
  dut("205#0600");
  EXPECT_EQ(samples_.size(), 1U);
}

TEST_F(PdoTrackerTest, RemapSequenceFollowsConfirmedWrites) {
  // Given TPDO1 by default
  // When the vector runs the CiA 301 mapping procedure: COB-ID not valid, sub 0 := 0,
  //      sub 1 := 606C0020h (velocity), sub 2 := 60770010h (torque), sub 0 := 2, COB-ID 1A5h
  write_u32(0x1800, 1, 0x80000185);
  write_u8(0x1A00, 0, 0);
  write_u32(0x1A00, 1, 0x606C0020);
  write_u32(0x1A00, 2, 0x60770010);
  write_u8(0x1A00, 0, 2);
  write_u32(0x1800, 1, 0x000001A5);
  // Then TPDO1 is on 1A5h and its frames are velocity and torque
  EXPECT_EQ(tracker_.can_id(PdoDirection::transmit, 1), 0x1A5U);
  dut("185#370218FCFFFF");
  EXPECT_TRUE(samples_.empty());
  dut("1A5#E8030000FEFF");  // velocity 1000, torque -2
  ASSERT_EQ(samples_.size(), 2U);
  EXPECT_EQ(samples_[0].signal, "velocity");
  EXPECT_EQ(samples_[0].value, 1000);
  EXPECT_EQ(samples_[1].signal, "torque");
  EXPECT_EQ(samples_[1].value, -2);
}

TEST_F(PdoTrackerTest, AbortedOrUnconfirmedWritesAreNotApplied) {
  // Given TPDO1 by default
  // When sub 0 := 0 is aborted (585#80 ... 06010000h), and a COB-ID write gets no answer
  harness("605#2F001A0000000000");  // ccs=1 e=1 s=1 n=3, 1A00h sub 0, data 00
  dut("585#80001A0000000106");      // abort 1A00h sub 0, 06010000h
  harness("605#2300180185010080");  // ccs=1 e=1 s=1 n=0, 1800h sub 1, 80000185h
  harness("605#4041600000000000");  // ccs=2: upload 6041h sub 0 (the write is never answered)
  dut("585#4B41600037020000");      // scs=2 e=1 s=1 n=2, 6041h sub 0, 0237h
  // Then the mapping and the COB-ID are the defaults still
  EXPECT_EQ(tracker_.can_id(PdoDirection::transmit, 1), 0x185U);
  ASSERT_TRUE(tracker_.mapping(PdoDirection::transmit, 1));
  EXPECT_EQ(tracker_.mapping(PdoDirection::transmit, 1)->entries.size(), 2U);
}

TEST_F(PdoTrackerTest, InvalidMappingDecodesNothing) {
  // Given TPDO1 remapped by a deviant DUT that accepts a 0-bit entry (60410000h)
  write_u8(0x1A00, 0, 0);
  write_u32(0x1A00, 1, 0x60410000);
  write_u8(0x1A00, 0, 1);
  // Then the mapping is unusable and TPDO1 gives no samples
  EXPECT_EQ(tracker_.mapping(PdoDirection::transmit, 1), std::nullopt);
  dut("185#3702");
  EXPECT_TRUE(samples_.empty());
  // And a mapping of more than 64 bits (3 x 32) is unusable too
  write_u8(0x1A00, 0, 0);
  write_u32(0x1A00, 1, 0x60640020);
  write_u32(0x1A00, 2, 0x606C0020);
  write_u32(0x1A00, 3, 0x607A0020);
  write_u8(0x1A00, 0, 3);
  EXPECT_EQ(tracker_.mapping(PdoDirection::transmit, 1), std::nullopt);
  // And sub 0 := 2 over entries never written or read (TPDO3, not in the profile) is unknown
  write_u8(0x1A02, 0, 2);
  EXPECT_EQ(tracker_.mapping(PdoDirection::transmit, 3), std::nullopt);
}

TEST_F(PdoTrackerTest, ResetReturnsToWhatWasStored) {
  // Given TPDO1 remapped to velocity only
  const auto remap = [&] {
    write_u8(0x1A00, 0, 0);
    write_u32(0x1A00, 1, 0x606C0020);
    write_u8(0x1A00, 0, 1);
  };
  const auto entries = [&] {
    const auto mapping = tracker_.mapping(PdoDirection::transmit, 1);
    return mapping ? mapping->entries.size() : 0U;
  };
  remap();
  ASSERT_EQ(entries(), 1U);
  // When the harness sends NMT reset communication to the DUT (000#8205)
  harness("000#8205");
  // Then the profile's default mapping holds again
  EXPECT_EQ(entries(), 2U);
  // When remapped, stored (1010h sub 1 := "save") and reset by a boot-up of the DUT
  remap();
  write_u32(0x1010, 1, 0x65766173);  // "save"
  dut("705#00");
  // Then the stored mapping survives
  EXPECT_EQ(entries(), 1U);
  // When defaults are restored (1011h sub 1 := "load") and the node reset (broadcast 000#8100)
  write_u32(0x1011, 1, 0x64616F6C);  // "load"
  EXPECT_EQ(entries(), 1U);          // takes effect at the reset only
  harness("000#8100");
  // Then the profile's defaults hold
  EXPECT_EQ(entries(), 2U);
  // And a reset of another node changes nothing
  remap();
  harness("000#8106");
  EXPECT_EQ(entries(), 1U);
}

TEST_F(PdoTrackerTest, ReadBackIsApplied) {
  // Given TPDO3, which the profile does not list
  // When the harness reads 1A02h sub 1 (60410010h), sub 0 (1) and 1802h sub 1 (00000385h)
  harness("605#40021A0100000000");
  dut("585#43021A0110004160");  // scs=2 e=1 s=1 n=0, 1A02h sub 1, 60410010h
  harness("605#40021A0000000000");
  dut("585#4F021A0001000000");  // scs=2 e=1 s=1 n=3, 1A02h sub 0, 01h
  harness("605#4002180100000000");
  dut("585#4302180185030000");  // 1802h sub 1, 00000385h
  // Then TPDO3 decodes on 385h
  dut("385#4002");
  ASSERT_EQ(samples_.size(), 1U);
  EXPECT_EQ(samples_[0].signal, "statusword");
  EXPECT_EQ(samples_[0].value, 0x0240);
}

TEST(PdoDecode, SignsAndSizesFollowTheMapping) {
  // Given a mapping of 6041h (16 bit), 6061h (8 bit, signed), 6077h (16 bit, signed), 1001h
  //       (8 bit, not a signal) and 6060h (8 bit, signed)
  cia301::PdoMapping mapping;
  mapping.entries = {
      {0x6041, 0, 16}, {0x6061, 0, 8}, {0x6077, 0, 16}, {0x1001, 0, 8}, {0x6060, 0, 8}};
  std::vector<Sample> out;
  // When FFFF FA FEFF 01 FF is decoded
  const std::vector<std::uint8_t> payload{0xFF, 0xFF, 0xFA, 0xFE, 0xFF, 0x01, 0xFF};
  ASSERT_TRUE(decode_pdo_samples(mapping, payload, at_ms(1), SampleOrigin::tpdo, out));
  // Then statusword 65535 (unsigned), mode -6, torque -2, mode command -1; 1001h gives none
  ASSERT_EQ(out.size(), 4U);
  EXPECT_EQ(out[0].value, 65535);
  EXPECT_EQ(out[1].signal, "mode");
  EXPECT_EQ(out[1].value, -6);
  EXPECT_EQ(out[2].signal, "torque");
  EXPECT_EQ(out[2].value, -2);
  EXPECT_EQ(out[3].signal, "mode command");
  EXPECT_EQ(out[3].value, -1);
  // And a payload one byte short decodes to nothing
  out.clear();
  EXPECT_FALSE(
      decode_pdo_samples(mapping, std::span(payload).first(6), at_ms(1), SampleOrigin::tpdo, out));
  EXPECT_TRUE(out.empty());
}

TEST(SampleThinning, KeepsEveryBitEdgeAndTheAnalogShape) {
  // Given 10,000 samples over 10 s: a statusword toggling bit 10 every 1000 samples, and a
  //       position ramp 0..4999 with one spike of 1,000,000 at sample 2001
  std::vector<Sample> samples;
  for (int i = 0; i < 5000; ++i) {
    samples.push_back(
        {at_ms(2 * i), "statusword", (i / 500) % 2 == 0 ? 0x0237 : 0x0637, SampleOrigin::tpdo});
    samples.push_back(
        {at_ms(2 * i + 1), "position", i == 2001 ? 1'000'000 : i, SampleOrigin::tpdo});
  }
  // When thinned to about 1000
  const std::size_t elided = thin_samples(samples, 1000);
  // Then most are left out, every statusword edge (9 edges + first + last) is kept, and the
  //      spike, the first and the last position are kept
  EXPECT_GT(elided, 8000U);
  EXPECT_EQ(elided + samples.size(), 10'000U);
  std::vector<std::int64_t> statuswords;
  bool spike = false;
  for (const auto& sample : samples) {
    if (sample.signal == "statusword") statuswords.push_back(sample.value);
    if (sample.signal == "position" && sample.value == 1'000'000) spike = true;
  }
  std::size_t edges = 0;
  for (std::size_t i = 1; i < statuswords.size(); ++i)
    if (statuswords[i] != statuswords[i - 1]) ++edges;
  EXPECT_EQ(edges, 9U);
  EXPECT_TRUE(spike);
  EXPECT_EQ(samples.back().value, 4999);
  // And samples stay in time order
  for (std::size_t i = 1; i < samples.size(); ++i)
    EXPECT_LE(samples[i - 1].at, samples[i].at);
}

TEST(SampleThinning, FewSamplesAreKept) {
  // Given 3 samples; When thinned to 1000; Then none is left out
  std::vector<Sample> samples{{at_ms(0), "statusword", 1, SampleOrigin::sdo},
                              {at_ms(1), "statusword", 1, SampleOrigin::sdo},
                              {at_ms(2), "position", 5, SampleOrigin::tpdo}};
  EXPECT_EQ(thin_samples(samples, 1000), 0U);
  EXPECT_EQ(samples.size(), 3U);
}

}  // namespace
}  // namespace drivecheck::conformance
