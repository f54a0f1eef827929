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

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;

const std::filesystem::path kDrivesDir =
    std::filesystem::path(DRIVECHECK_SOURCE_DIR) / "vectors/drives";

class BusOffRig {
 public:
  // `profile_name` empty: the standard drive. The drive is not powered on yet.
  explicit BusOffRig(const std::string& profile_name) {
    if (!profile_name.empty()) {
      auto loaded = profile::find_profile(profile_name, kDrivesDir);
      if (!loaded) {
        ADD_FAILURE() << loaded.error().to_string();
        return;
      }
      profile_ = std::move(*loaded);
    }
    tester_ = bus_.attach("tester");
    port_ = bus_.attach("drive");
    ServoDriveOptions options;
    options.node = 5;
    options.profile = profile_ ? &*profile_ : nullptr;
    auto created = ServoDrive::create(*port_, options);
    if (!created) {
      ADD_FAILURE() << "ServoDrive::create: " << created.error();
      return;
    }
    drive_ = std::move(*created);
  }

  ServoDrive& drive() { return *drive_; }
  void power_on() {
    drive_->power_on();
    bus_.run_for(20ms);
  }
  void bus_off(bool off) {
    port_->set_bus_off(off);
    drive_->device().set_bus_off(off);
  }
  void run(can::Duration d) { bus_.run_for(d); }
  // 6040h := value (expedited download from the tester), then 20 ms.
  void controlword(std::uint16_t value) {
    can::Frame f;
    f.id = 0x605;
    f.dlc = 8;
    f.data = {0x2B,
              0x40,
              0x60,
              0x00,
              static_cast<std::uint8_t>(value),
              static_cast<std::uint8_t>(value >> 8),
              0,
              0};
    EXPECT_FALSE(tester_->send(f));
    bus_.run_for(20ms);
  }
  void enable() {
    for (std::uint16_t cw : {0x0006, 0x0007, 0x000F})
      controlword(cw);
  }
  cia402::State state() const { return drive_->application().pds().state(); }
  std::uint64_t value(std::uint16_t index, std::uint8_t sub) {
    const cia301::Entry* entry = drive_->device().dictionary().find(index, sub);
    EXPECT_NE(entry, nullptr);
    return entry != nullptr ? entry->as_unsigned() : ~std::uint64_t{0};
  }

 private:
  std::optional<profile::DriveProfile> profile_;
  can::SimBus bus_{can::SimBusConfig{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> tester_;
  std::unique_ptr<can::SimPort> port_;
  std::unique_ptr<ServoDrive> drive_;
};

TEST(ServoDriveBusOff, KollmorgenEnabledDriveStopsWithF23) {
  // Given the Kollmorgen drive in OPERATION ENABLED (its boot-up went out)
  // When its controller goes bus-off, then recovers
  // Then the drive is in FAULT with 603Fh = 8182h (F23, 002 §2.9 L206-210, §5.1 L1193)
  BusOffRig rig("kollmorgen-s300-s700");
  rig.power_on();
  rig.enable();
  ASSERT_EQ(rig.state(), cia402::State::operation_enabled);
  rig.bus_off(true);
  rig.run(50ms);
  rig.bus_off(false);
  rig.run(20ms);
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

TEST(ServoDriveBusOff, StandardDriveKeepsRunning) {
  // Given the standard drive in OPERATION ENABLED
  // When its controller goes bus-off and recovers
  // Then the axis state is untouched (CiA 301 reacts in NMT and by EMCY 8140h only)
  BusOffRig rig("");
  rig.power_on();
  rig.enable();
  ASSERT_EQ(rig.state(), cia402::State::operation_enabled);
  rig.bus_off(true);
  rig.run(50ms);
  rig.bus_off(false);
  rig.run(20ms);
  EXPECT_EQ(rig.state(), cia402::State::operation_enabled);
  EXPECT_EQ(rig.value(0x1003, 1) & 0xFFFF, 0x8140u);
}

}  // namespace
}  // namespace drivecheck::reference_drive
