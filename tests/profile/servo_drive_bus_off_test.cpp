// Bus-off as Kollmorgen and ESR document it (personality key `bus_off`), against the standard
// drive: ServoDrive on the simulated bus, node 5, the drive's port put bus-off by the test as
// the embedded drive's simulation control does (port first, then the drive's controller report).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "protocol/can/sim_bus.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/servo_drive.hpp"
#include "tests/profile/servo_rig.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;

// The drive is powered on by the test, after the bus-off set-up it needs.
class BusOffRig : public testing::ServoRig {
 public:
  explicit BusOffRig(const std::string& profile_name) : ServoRig(profile_name, PowerOn::later) {}
};

// The drive put in OPERATION ENABLED, then its controller bus-off for 50 ms and back for 20 ms.
void enable_then_bus_off_and_recover(BusOffRig& rig) {
  rig.enable();
  ASSERT_EQ(rig.state(), cia402::State::operation_enabled);
  rig.bus_off(true);
  rig.run(50ms);
  rig.bus_off(false);
  rig.run(20ms);
}

TEST(ServoDriveBusOff, KollmorgenEnabledDriveStopsWithF23) {
  // Given the Kollmorgen drive in OPERATION ENABLED (its boot-up went out)
  // When its controller goes bus-off, then recovers
  // Then the drive is in FAULT with 603Fh = 8182h (F23, 002 §2.9 L206-210, §5.1 L1193)
  BusOffRig rig("kollmorgen-s300-s700");
  rig.power_on();
  enable_then_bus_off_and_recover(rig);
  if (::testing::Test::HasFatalFailure()) return;
  EXPECT_EQ(rig.state(), cia402::State::fault);
  EXPECT_EQ(rig.value(0x603F, 0), 0x8182u);
}

TEST(ServoDriveBusOff, KollmorgenReportsNothingBeforeItsFirstTransmission) {
  // Given the Kollmorgen drive whose controller is bus-off from power on (no frame went out)
  // When the controller reports bus-off
  // Then no F23: no fault, 603Fh = 0 (002 §2.9 L206-207)
  BusOffRig rig("kollmorgen-s300-s700");
  rig.bus_off(true);
  rig.power_on();
  rig.run(50ms);
  EXPECT_NE(rig.state(), cia402::State::fault);
  EXPECT_NE(rig.state(), cia402::State::fault_reaction_active);
  EXPECT_EQ(rig.value(0x603F, 0), 0u);
}

TEST(ServoDriveBusOff, EsrFaultsWith8180) {
  // Given the ESR drive in OPERATION ENABLED
  // When its controller goes bus-off
  // Then the drive is in FAULT with 603Fh = 8180h (004 §11.4 L789-795)
  BusOffRig rig("esr-triodrive");
  rig.power_on();
  rig.enable();
  ASSERT_EQ(rig.state(), cia402::State::operation_enabled);
  rig.bus_off(true);
  rig.run(50ms);
  EXPECT_EQ(rig.state(), cia402::State::fault);
  EXPECT_EQ(rig.value(0x603F, 0), 0x8180u);
}

TEST(ServoDriveBusOff, StandardDriveWithoutAbortConnectionReactionKeepsRunning) {
  // Given the standard drive in OPERATION ENABLED with 6007h = 0 (no action)
  // When its controller goes bus-off and recovers
  // Then the axis state is untouched (CiA 301 reacts in NMT and by EMCY 8140h only)
  BusOffRig rig("");
  rig.power_on();
  ASSERT_EQ(rig.write(0x6007, 0, 0, 2), 0u);
  enable_then_bus_off_and_recover(rig);
  if (::testing::Test::HasFatalFailure()) return;
  EXPECT_EQ(rig.state(), cia402::State::operation_enabled);
  EXPECT_EQ(rig.value(0x1003, 1) & 0xFFFF, 0x8140u);
}

TEST(ServoDriveBusOff, StandardDriveTakesTheAbortConnectionReaction) {
  // Given the standard drive in OPERATION ENABLED with 6007h = 2 (disable voltage)
  // When its controller goes bus-off and recovers
  // Then it is in SWITCH ON DISABLED: bus-off is an abort connection event (CiA 402-2 6007h)
  BusOffRig rig("");
  rig.power_on();
  ASSERT_EQ(rig.write(0x6007, 0, 2, 2), 0u);
  enable_then_bus_off_and_recover(rig);
  if (::testing::Test::HasFatalFailure()) return;
  EXPECT_EQ(rig.state(), cia402::State::switch_on_disabled);
}

}  // namespace
}  // namespace drivecheck::reference_drive
