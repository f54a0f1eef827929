// Festo's position sampling (reference_drive/festo_position_sampling.hpp, 000 §5.15
// L4705-4816): 204Ah on the simulated bus as scripted SDO exchanges against ServoDrive with the
// festo-cmmp profile, the sample input driven through ServoDrive::simulate.
#include "reference_drive/festo_position_sampling.hpp"

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>

#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/servo_drive.hpp"
#include "tests/profile/servo_rig.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;
using testing::kNoAnswer;

constexpr std::uint16_t kSample = 0x204A;
constexpr std::uint32_t kReadWriteOnly = 0x06010001;
constexpr std::uint32_t kWriteReadOnly = 0x06010002;
constexpr std::uint32_t kValueTooHigh = 0x06090031;
constexpr std::uint16_t kBit15 = 0x8000;

// The Festo drive with the sample input low and the axis at `position` (increments, factor 1/1).
class SamplingRig : public testing::ServoRig {
 public:
  SamplingRig() : ServoRig("festo-cmmp") {}

  void input(int level) {
    ASSERT_TRUE(drive().simulate("sample-input", level)) << "sample-input " << level;
    run(2ms);
  }
  void place(std::int64_t position) {
    ASSERT_TRUE(drive().simulate("axis-position", position));
    run(2ms);
  }
  std::int32_t signed_read(std::uint8_t sub) {
    return static_cast<std::int32_t>(read(kSample, sub));
  }
};

TEST(FestoSampling, ObjectShapeAsTheManualLists) {
  // Given the Festo drive
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  // When 204Ah is read and written (L4717-4724)
  std::uint32_t abort = 0;
  // Then sub 0 is 6, the status reads 0, sample_control is write-only, the status read-only
  EXPECT_EQ(rig.read(kSample, 0), 6U);
  EXPECT_EQ(rig.read(kSample, 2), 0U);
  EXPECT_EQ(rig.read(kSample, 4, &abort), kNoAnswer);
  EXPECT_EQ(abort, kReadWriteOnly);
  EXPECT_EQ(rig.write(kSample, 2, 1, 1), kWriteReadOnly);
  EXPECT_EQ(rig.write(kSample, 1, 2, 2), kValueTooHigh);
  EXPECT_EQ(rig.write(kSample, 1, 1, 2), 0U);
}

TEST(FestoSampling, RisingEdgeLatchesActualPosition) {
  // Given both edges enabled and the axis at 12345
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(kSample, 4, 0x03, 1), 0U);
  rig.place(12345);
  // When the sample input rises, then the axis moves on
  rig.input(1);
  rig.place(20000);
  // Then 204Ah:05 holds 12345, sample_status is 02h, the falling position untouched
  EXPECT_EQ(rig.signed_read(5), 12345);
  EXPECT_EQ(rig.read(kSample, 2), 0x02U);
  EXPECT_EQ(rig.signed_read(6), 0);
}

TEST(FestoSampling, FallingEdgeLatchesIntoSubSix) {
  // Given the input high, both edges enabled, the axis at -5000
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  rig.input(1);
  ASSERT_EQ(rig.write(kSample, 4, 0x03, 1), 0U);
  rig.place(-5000);
  // When the input falls
  rig.input(0);
  // Then 204Ah:06 = -5000, sample_status = 01h
  EXPECT_EQ(rig.signed_read(6), -5000);
  EXPECT_EQ(rig.read(kSample, 2), 0x01U);
}

TEST(FestoSampling, NoSamplingBeforeControlEnablesTheEdge) {
  // Given a drive after power on (no sample_control written), the axis at 700
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  rig.place(700);
  // When the input rises
  rig.input(1);
  // Then nothing is sampled (the chosen start state, festo_position_sampling.hpp)
  EXPECT_EQ(rig.read(kSample, 2), 0U);
  EXPECT_EQ(rig.signed_read(5), 0);
}

TEST(FestoSampling, SameLevelIsNoEdge) {
  // Given the rising edge enabled and the input already high after a sample at 100
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(kSample, 4, 0x02, 1), 0U);
  rig.place(100);
  rig.input(1);
  // When the input is set high again at 200
  rig.place(200);
  rig.input(1);
  // Then the position is still 100
  EXPECT_EQ(rig.signed_read(5), 100);
}

TEST(FestoSampling, ControlClearsOnlyItsStatusBit) {
  // Given both edges occurred
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(kSample, 4, 0x03, 1), 0U);
  rig.input(1);
  rig.input(0);
  ASSERT_EQ(rig.read(kSample, 2), 0x03U);
  // When sample_control bit 0 (falling) is set
  ASSERT_EQ(rig.write(kSample, 4, 0x01, 1), 0U);
  // Then only the falling bit is cleared
  EXPECT_EQ(rig.read(kSample, 2), 0x02U);
}

TEST(FestoSampling, AutolockBlocksUntilReleased) {
  // Given autolock and the rising edge enabled, a first sample at 1000
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(kSample, 1, 1, 2), 0U);
  ASSERT_EQ(rig.write(kSample, 4, 0x02, 1), 0U);
  rig.place(1000);
  rig.input(1);
  ASSERT_EQ(rig.signed_read(5), 1000);
  // When a second rising edge comes at 2000
  rig.input(0);
  rig.place(2000);
  rig.input(1);
  // Then it is blocked; after the release a third edge at 3000 is sampled
  EXPECT_EQ(rig.signed_read(5), 1000);
  ASSERT_EQ(rig.write(kSample, 4, 0x02, 1), 0U);
  EXPECT_EQ(rig.read(kSample, 2), 0U);
  rig.input(0);
  rig.place(3000);
  rig.input(1);
  EXPECT_EQ(rig.signed_read(5), 3000);
  EXPECT_EQ(rig.read(kSample, 2), 0x02U);
}

TEST(FestoSampling, AutolockIsPerEdge) {
  // Given autolock, both edges enabled, a rising sample taken (rising now locked)
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(kSample, 1, 1, 2), 0U);
  ASSERT_EQ(rig.write(kSample, 4, 0x03, 1), 0U);
  rig.place(10);
  rig.input(1);
  // When the input falls at 20
  rig.place(20);
  rig.input(0);
  // Then the falling edge is still sampled
  EXPECT_EQ(rig.signed_read(6), 20);
  EXPECT_EQ(rig.read(kSample, 2), 0x03U);
}

TEST(FestoSampling, ContinuousSamplesEveryEdge) {
  // Given continuous sampling (default) with the rising edge enabled, a sample at 1000
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(kSample, 4, 0x02, 1), 0U);
  rig.place(1000);
  rig.input(1);
  // When another rising edge comes at 2000 without a sample_control write
  rig.input(0);
  rig.place(2000);
  rig.input(1);
  // Then the new position is latched
  EXPECT_EQ(rig.signed_read(5), 2000);
}

TEST(FestoSampling, StatuswordBit15FollowsMaskedStatus) {
  // Given mask 00h and a rising sample
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(kSample, 4, 0x03, 1), 0U);
  rig.input(1);
  // When the mask is 00h, then 02h (rising: bit by bit over sample_status), then 01h
  // Then bit 15 is 0, 1, 0; clearing the status with the mask set clears it again
  EXPECT_EQ(rig.statusword() & kBit15, 0);
  ASSERT_EQ(rig.write(kSample, 3, 0x02, 1), 0U);
  rig.run(2ms);
  EXPECT_EQ(rig.statusword() & kBit15, kBit15);
  ASSERT_EQ(rig.write(kSample, 3, 0x01, 1), 0U);
  rig.run(2ms);
  EXPECT_EQ(rig.statusword() & kBit15, 0);
  ASSERT_EQ(rig.write(kSample, 3, 0x03, 1), 0U);
  rig.run(2ms);
  EXPECT_EQ(rig.statusword() & kBit15, kBit15);
  ASSERT_EQ(rig.write(kSample, 4, 0x02, 1), 0U);
  rig.run(2ms);
  EXPECT_EQ(rig.statusword() & kBit15, 0);
}

TEST(FestoSampling, PositionInPositionUnits) {
  // Given position factor 4096/225 (1/10 degree) and the axis at one revolution (3600)
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(0x6093, 1, 4096, 4), 0U);
  ASSERT_EQ(rig.write(0x6093, 2, 225, 4), 0U);
  ASSERT_EQ(rig.write(kSample, 4, 0x02, 1), 0U);
  rig.place(3600);
  ASSERT_EQ(static_cast<std::int32_t>(rig.read(0x6064)), 3600);
  // When the input rises
  rig.input(1);
  // Then 204Ah:05 reads 3600, as 6064h (not 65536 increments)
  EXPECT_EQ(rig.signed_read(5), 3600);
}

TEST(FestoSampling, ResetNodeClearsEvents) {
  // Given a rising sample with bit 15 visible
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(kSample, 3, 0x03, 1), 0U);
  ASSERT_EQ(rig.write(kSample, 4, 0x03, 1), 0U);
  rig.place(55);
  rig.input(1);
  ASSERT_EQ(rig.statusword() & kBit15, kBit15);
  // When the node is reset (NMT 81h) and the input falls afterwards
  // NMT: command 81h reset node, node 5
  rig.send(can::Frame::standard(0x000, std::array<std::uint8_t, 2>{0x81, testing::kNode}));
  rig.run(50ms);
  rig.input(0);
  // Then status, positions and bit 15 are 0 and the falling edge is not sampled (not enabled)
  EXPECT_EQ(rig.read(kSample, 2), 0U);
  EXPECT_EQ(rig.signed_read(5), 0);
  EXPECT_EQ(rig.signed_read(6), 0);
  EXPECT_EQ(rig.statusword() & kBit15, 0);
}

TEST(FestoSampling, InputValueOutOfRangeIsAnError) {
  // Given the Festo drive and the standard drive
  SamplingRig rig;
  ASSERT_TRUE(rig.ok());
  testing::ServoRig standard;
  ASSERT_TRUE(standard.ok());
  // When sample-input is driven with 2, and on the standard drive with 1
  // Then both are errors (a value out of range; an input the standard drive lacks)
  EXPECT_FALSE(rig.drive().simulate("sample-input", 2));
  EXPECT_FALSE(standard.drive().simulate("sample-input", 1));
  EXPECT_EQ(standard.drive().position_sampling(), nullptr);
  EXPECT_EQ(standard.drive().device().dictionary().find(kSample), nullptr);
}

}  // namespace
}  // namespace drivecheck::reference_drive
