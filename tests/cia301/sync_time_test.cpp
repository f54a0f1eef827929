#include <gtest/gtest.h>

#include "protocol/cia301/sync.hpp"
#include "protocol/cia301/time.hpp"

namespace drivecheck::cia301 {
namespace {

can::Frame frame_of(const char* text) {
  auto frame = can::parse_candump(text);
  EXPECT_TRUE(frame) << text;
  return frame.value_or(can::Frame{});
}

TEST(SyncCodec, WithoutCounterIsEmptyFrame) {
  // Given a SYNC without counter as the Kollmorgen examples send it ("080: SYNC (DLC 0)",
  //   002_953174ea6ca45cdb.txt digest §13.9)
  // When encoded and decoded
  // Then it is 080# and has no counter
  EXPECT_EQ(can::to_candump(encode(Sync{})), "080#");
  const auto sync = decode_sync(frame_of("080#"));
  ASSERT_TRUE(sync) << sync.error().reason;
  EXPECT_FALSE(sync->counter.has_value());
}

TEST(SyncCodec, CounterRange) {
  // Given SYNC frames with counters 1..240 (CiA 301 §7.2.5, 1019h)
  // When encoded and decoded
  // Then they round-trip; 0 and 241..255 are invalid
  for (unsigned counter = 1; counter <= 240; ++counter) {
    const Sync sync{static_cast<std::uint8_t>(counter)};
    const auto back = decode_sync(encode(sync));
    ASSERT_TRUE(back) << counter;
    EXPECT_EQ(*back, sync);
  }
  for (unsigned counter : {0u, 241u, 255u}) {
    const auto bad = decode_sync(can::Frame::standard(0x080, {static_cast<std::uint8_t>(counter)}));
    ASSERT_FALSE(bad) << counter;
    EXPECT_NE(bad.error().reason.find("counter runs 1..240"), std::string::npos);
  }
}

TEST(SyncCodec, RejectsMalformedFrames) {
  // Given SYNC frames with DLC 2, an RTR, another id
  // When decoded
  // Then each is invalid with the reason
  const std::pair<const char*, const char*> cases[] = {
      {"080#0101", "DLC 2"},
      {"080#R", "remote request"},
      {"081#", "not on the SYNC CAN-ID"},
      {"00000080#", "not on the SYNC CAN-ID"},
  };
  for (const auto& [text, expected] : cases) {
    const auto sync = decode_sync(frame_of(text));
    ASSERT_FALSE(sync) << text;
    EXPECT_NE(sync.error().reason.find(expected), std::string::npos) << sync.error().reason;
  }
}

TEST(SyncCodec, ConfiguredCobId) {
  // Given a SYNC COB-ID moved to 090h
  // When a frame on 090h is decoded with that id
  // Then it is a SYNC; on 080h it is not
  EXPECT_TRUE(decode_sync(frame_of("090#05"), 0x090));
  EXPECT_FALSE(decode_sync(frame_of("080#05"), 0x090));
}

TEST(SyncCobIdEntry, FestoRange) {
  // Given 1005h values of the Festo range 80000080h / 00000080h (000 L1228-1245) and a
  //   generating producer 40000080h
  // When decoded
  // Then the CAN-ID is 080h; bit 31 is don't care; bit 30 is gen
  const auto plain = decode_sync_cob_id_entry(0x00000080);
  ASSERT_TRUE(plain);
  EXPECT_EQ(plain->can_id, 0x080u);
  EXPECT_FALSE(plain->generate);
  const auto festo = decode_sync_cob_id_entry(0x80000080);
  ASSERT_TRUE(festo);
  EXPECT_EQ(festo->can_id, 0x080u);
  const auto gen = decode_sync_cob_id_entry(0x40000080);
  ASSERT_TRUE(gen);
  EXPECT_TRUE(gen->generate);
  EXPECT_EQ(gen->encode(), 0x40000080u);
  EXPECT_FALSE(decode_sync_cob_id_entry(0x00000880));  // bit 11 set, 11-bit id
  const auto extended = decode_sync_cob_id_entry(0x20000880);
  ASSERT_TRUE(extended);
  EXPECT_TRUE(extended->extended);
}

TEST(SyncCounterOverflow, ValidValues) {
  // Given 1019h values
  // Then 0 and 2..240 are valid, 1 and 241..255 reserved
  EXPECT_TRUE(is_valid_sync_counter_overflow(0));
  EXPECT_FALSE(is_valid_sync_counter_overflow(1));
  EXPECT_TRUE(is_valid_sync_counter_overflow(2));
  EXPECT_TRUE(is_valid_sync_counter_overflow(240));
  EXPECT_FALSE(is_valid_sync_counter_overflow(241));
}

TEST(TimeCodec, EpochAndKnownDate) {
  // Given 2024-03-01 12:34:56.789 (14670 days after 1984-01-01, 45296789 ms after midnight)
  using namespace std::chrono;
  const auto when =
      sys_days{year{2024} / March / 1} + hours{12} + minutes{34} + seconds{56} + milliseconds{789};
  // When converted to TIME_OF_DAY and encoded
  const TimeOfDay time = TimeOfDay::from_sys_time(when);
  // Then days and ms are right and the frame is little-endian on 100h, DLC 6
  EXPECT_EQ(time.days, 14670);
  EXPECT_EQ(time.ms, 45296789u);
  // ms = 02B32C95h → 95 2C B3 02; days = 394Eh → 4E 39
  EXPECT_EQ(can::to_candump(encode(time)), "100#952CB3024E39");
  EXPECT_EQ(time.to_sys_time(), when);
  EXPECT_EQ(TimeOfDay::from_sys_time(kTimeOfDayEpoch), (TimeOfDay{0, 0}));
}

TEST(TimeCodec, RoundTrip) {
  // Given TIME values at the edges
  // When encoded and decoded
  // Then unchanged
  for (const TimeOfDay time :
       {TimeOfDay{0, 0}, TimeOfDay{kMsPerDay - 1, 0xFFFF}, TimeOfDay{1, 1}}) {
    const auto back = decode_time(encode(time));
    ASSERT_TRUE(back) << back.error().reason;
    EXPECT_EQ(*back, time);
  }
}

TEST(TimeCodec, RejectsMalformedFrames) {
  // Given malformed TIME frames
  // When decoded
  // Then each is invalid and says why
  const std::pair<const char*, const char*> cases[] = {
      {"100#0000000000", "DLC 5"},
      {"100#00000000000000", "DLC 7"},
      {"100#000000100000", "bits 28..31 are reserved"},
      {"100#005C26050000", "a day has 86400000 ms"},  // 05265C00h = 86400000
      {"100#R", "remote request"},
      {"101#000000000000", "not on the TIME CAN-ID"},
  };
  for (const auto& [text, expected] : cases) {
    const auto time = decode_time(frame_of(text));
    ASSERT_FALSE(time) << text;
    EXPECT_NE(time.error().reason.find(expected), std::string::npos)
        << text << ": " << time.error().reason;
  }
}

}  // namespace
}  // namespace drivecheck::cia301
