#include <gtest/gtest.h>

#include <set>

#include "protocol/cia402/modes.hpp"
#include "protocol/cia402/object_ids.hpp"

namespace drivecheck::cia402 {
namespace {

TEST(Cia402Objects, TypedConstants) {
  // Given the object ids named in the CiA 402 object dictionary
  // Then the constants carry index and sub-index
  static_assert(kControlword == ObjectId{0x6040, 0x00});
  static_assert(kStatusword == ObjectId{0x6041, 0x00});
  static_assert(kQuickStopOptionCode == ObjectId{0x605A, 0x00});
  static_assert(kFaultReactionOptionCode == ObjectId{0x605E, 0x00});
  static_assert(kModesOfOperation == ObjectId{0x6060, 0x00});
  static_assert(kModesOfOperationDisplay == ObjectId{0x6061, 0x00});
  static_assert(kPositionActualValue == ObjectId{0x6064, 0x00});
  static_assert(kTargetPosition == ObjectId{0x607A, 0x00});
  static_assert(kProfileVelocity == ObjectId{0x6081, 0x00});
  static_assert(kHomeOffset == ObjectId{0x607C, 0x00});
  static_assert(kHomingMethod == ObjectId{0x6098, 0x00});
  static_assert(kHomingSpeedZero == ObjectId{0x6099, 0x02});
  static_assert(kHomingAcceleration == ObjectId{0x609A, 0x00});
  SUCCEED();
}

TEST(Cia402Objects, LookupByIndex) {
  // Given the name table
  // When entries are looked up
  // Then names and types are CiA 402's; unknown entries give nothing
  const auto display = find_object(0x6061, 0);
  ASSERT_TRUE(display);
  EXPECT_EQ(display->name, "modes of operation display");
  EXPECT_EQ(display->type, ValueType::int8);
  EXPECT_EQ(find_object(0x6040, 0)->type, ValueType::uint16);
  EXPECT_EQ(find_object(0x607D, 2)->name, "software position limit max");
  EXPECT_FALSE(find_object(0x6040, 1));
  EXPECT_FALSE(find_object(0x1000, 0));
  std::set<std::string_view> names;
  for (const ObjectInfo& info : object_table()) {
    EXPECT_TRUE(names.insert(info.name).second) << info.name;
    EXPECT_GE(info.id.index, 0x6000);
    EXPECT_TRUE(find_object(info.id.index, info.id.sub_index));
  }
  EXPECT_EQ(size_of(ValueType::int32), 4u);
  EXPECT_TRUE(is_signed(ValueType::int16));
}

TEST(Cia402Modes, ValuesOfIrtsaTable9) {
  // Given 6060h values of IRTSA Table 9 (003 L236-249) and Festo 6061h (000 L6008-6019)
  // Then known modes decode, negatives are manufacturer modes, 5 and 11.. reserved
  EXPECT_EQ(mode_from_value(1), Mode::profile_position);
  EXPECT_EQ(mode_from_value(3), Mode::profile_velocity);
  EXPECT_EQ(mode_from_value(4), Mode::profile_torque);
  EXPECT_EQ(mode_from_value(6), Mode::homing);
  EXPECT_EQ(mode_from_value(7), Mode::interpolated_position);
  EXPECT_EQ(mode_from_value(8), Mode::cyclic_sync_position);
  EXPECT_EQ(mode_from_value(9), Mode::cyclic_sync_velocity);
  EXPECT_EQ(mode_from_value(10), Mode::cyclic_sync_torque);
  EXPECT_FALSE(mode_from_value(5));
  EXPECT_FALSE(mode_from_value(-1));
  EXPECT_EQ(describe_mode(8), "cyclic synchronous position (csp)");
  EXPECT_EQ(describe_mode(-11), "manufacturer-specific mode -11");
  EXPECT_EQ(describe_mode(-127), "manufacturer-specific mode -127");
  EXPECT_EQ(describe_mode(5), "reserved mode 5");
  EXPECT_EQ(describe_mode(11), "reserved mode 11");
  EXPECT_EQ(describe_mode(0), "no mode");
}

TEST(Cia402Modes, SupportedDriveModesOfIrtsa) {
  // Given the IRTSA 6502h defaults 000000A0h (hm + csp) and 00010021h (pp + hm + mpp bit 16)
  //   (003 Table 26 L770)
  // Then the bits decode to those modes
  EXPECT_TRUE(supports(0x000000A0, Mode::homing));
  EXPECT_TRUE(supports(0x000000A0, Mode::cyclic_sync_position));
  EXPECT_FALSE(supports(0x000000A0, Mode::profile_position));
  EXPECT_EQ(describe_supported_modes(0x000000A0), "hm+csp");
  EXPECT_EQ(describe_supported_modes(0x00010021), "pp+hm (+ manufacturer bits 00010000h)");
  EXPECT_EQ(describe_supported_modes(0), "none");
}

}  // namespace
}  // namespace drivecheck::cia402
