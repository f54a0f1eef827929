// The CiA 402 application in the full reference drive on the simulated bus: PDS wiring, every
// mode's bits and timings, windows, faults from the axis, simulate().
#include "reference_drive/cia402_application.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "tests/reference_drive/drive_rig.hpp"

namespace drivecheck::reference_drive::testing {
namespace {

constexpr std::uint16_t kStateMask = 0x006F;
constexpr std::uint16_t kOperationEnabled = 0x0027;
constexpr std::uint16_t kSwitchOnDisabled = 0x0040;
constexpr std::uint16_t kFault = 0x0008;
constexpr std::uint16_t kTargetReached = 0x0400;
constexpr std::uint16_t kInternalLimit = 0x0800;
constexpr std::uint16_t kBit12 = 0x1000;
constexpr std::uint16_t kBit13 = 0x2000;

class Cia402Drive {
 public:
  explicit Cia402Drive(Cia402ApplicationConfig config = {})
      : app_(std::make_unique<Cia402Application>(std::move(config))),
        rig_(std::make_unique<DriveRig>(5, with_app(*app_))) {}

  static DriveConfig with_app(Cia402Application& app) {
    DriveConfig config;
    config.application = &app;
    return config;
  }

  DriveRig& rig() { return *rig_; }
  Cia402Application& app() { return *app_; }

  // The dictionary's current value (what an SDO read would answer now).
  std::int64_t value(std::uint16_t index, std::uint8_t sub = 0) {
    return rig_->drive().dictionary().find(index, sub)->as_signed();
  }
  std::uint64_t uvalue(std::uint16_t index, std::uint8_t sub = 0) {
    return rig_->drive().dictionary().find(index, sub)->as_unsigned();
  }
  std::uint16_t statusword() { return static_cast<std::uint16_t>(uvalue(0x6041)); }

  // Controlword by SDO (expedited, 2 bytes), then 5 ms of bus time.
  void controlword(std::uint16_t cw) { ASSERT_EQ(rig_->write(0x6040, 0, cw, 2), 0u); }
  // Controlword by SDO, sent now; run() moves time on in steps.
  void send_controlword(std::uint16_t cw) {
    // ccs=1 e=1 s=1 n=2, 6040h sub 0, data cw
    rig_->send(fmt::format("605#2B406000{:02X}{:02X}0000", cw & 0xFF, cw >> 8));
  }
  void write(std::uint16_t index, std::uint8_t sub, std::int64_t value, unsigned size) {
    ASSERT_EQ(rig_->write(index, sub, static_cast<std::uint64_t>(value), size), 0u)
        << std::hex << index << ":" << int{sub};
  }

  // Mode, then shutdown, switch on, enable operation: OPERATION ENABLED.
  void enable(std::int8_t mode) {
    write(0x6060, 0, mode, 1);
    controlword(0x0006);
    controlword(0x0007);
    controlword(0x000F);
    ASSERT_EQ(statusword() & kStateMask, kOperationEnabled) << std::hex << statusword();
    ASSERT_EQ(value(0x6061), mode);
  }

  // Runs until (statusword & mask) == want or `limit` passes; returns the time it took.
  std::optional<can::Duration> wait_for(std::uint16_t mask, std::uint16_t want,
                                        can::Duration limit) {
    const can::TimePoint start = rig_->bus().now();
    while (rig_->bus().now() - start <= limit) {
      if ((statusword() & mask) == want) return rig_->bus().now() - start;
      rig_->run(std::chrono::milliseconds(1));
    }
    return std::nullopt;
  }

 private:
  std::unique_ptr<Cia402Application> app_;
  std::unique_ptr<DriveRig> rig_;
};

// ---------------------------------------------------------------------------------------------
// Wiring

TEST(Cia402Application, PowersUpInSwitchOnDisabledAndEnables) {
  // Given a drive with the CiA 402 application after boot-up
  Cia402Drive d;
  d.rig().run(5ms);
  // Then the statusword is SWITCH ON DISABLED with remote (0240h)
  EXPECT_EQ(d.statusword() & 0x02FF, 0x0240);
  // When the standard enable sequence is written in profile position mode
  d.enable(1);
  // Then the drive is OPERATION ENABLED (0237h) and target reached (no set-point yet)
  EXPECT_EQ(d.statusword() & 0x02FF, 0x0237);
  EXPECT_NE(d.statusword() & kTargetReached, 0);
}

TEST(Cia402Application, ObjectsOfTheDriveExist) {
  // Given the drive
  Cia402Drive d;
  // When the shared and mode objects are read by SDO
  // Then each answers (no abort) and 6502h lists pp pv tq csp csv cst ip-less default
  for (std::uint16_t index : {0x6062, 0x6064, 0x6065, 0x6067, 0x606C, 0x6072, 0x607A, 0x607E,
                              0x6081, 0x6083, 0x6086, 0x6087, 0x60F4, 0x60FD, 0x60FF}) {
    const SdoResult r = d.rig().read(static_cast<std::uint16_t>(index), 0);
    EXPECT_TRUE(r.answered && !r.abort) << std::hex << index;
  }
  EXPECT_EQ(d.rig().read(0x607D, 2).value, 0x7FFFFFFFu);
  EXPECT_EQ(d.rig().read(0x6502, 0).value, 0x000003ADu);
}

TEST(Cia402Application, PolarityRefusesUndefinedBits) {
  // Given the drive
  Cia402Drive d;
  // When 607Eh is written with 20h (not 00h/40h/80h/C0h)
  // Then the write is aborted with 06090030h, C0h is accepted
  EXPECT_EQ(d.rig().write(0x607E, 0, 0x20, 1), 0x06090030u);
  EXPECT_EQ(d.rig().write(0x607E, 0, 0xC0, 1), 0u);
}

TEST(Cia402Application, GearRatioRecomputesPositionFactor) {
  // Given 608Fh = 4096 increments per revolution
  Cia402Drive d;
  // When the gear ratio is set to 3:1 and the feed constant to 360 units per shaft revolution
  d.write(0x6091, 1, 3, 4);
  d.write(0x6092, 1, 360, 4);
  // Then 6093h = 4096 × 3 / 360 reduced = 512/15
  EXPECT_EQ(d.value(0x6093, 1), 512);
  EXPECT_EQ(d.value(0x6093, 2), 15);
  // And a zero divisor is refused
  EXPECT_EQ(d.rig().write(0x6093, 2, 0, 4), 0x06090030u);
}

TEST(Cia402Application, SimulateRejectsUnknownInputs) {
  // Given the drive
  Cia402Drive d;
  // When unknown inputs or out-of-range values are simulated
  // Then each is an error naming the input; known ones succeed
  EXPECT_FALSE(d.app().simulate("limit-sideways", 1));
  EXPECT_FALSE(d.app().simulate("fault:meltdown", 1));
  EXPECT_FALSE(d.app().simulate("limit-positive", 7));
  EXPECT_TRUE(d.app().simulate("limit-positive", 1));
  EXPECT_TRUE(d.app().simulate("axis-position", 1234));
  d.rig().run(3ms);
  EXPECT_EQ(d.value(0x6064), 1234);
  EXPECT_EQ(d.value(0x60FD) & 0x2, 0x2);
}

TEST(Cia402Application, CoastToRestStopsOnlyAnUnpoweredAxis) {
  // Given pv running at 10000 increments/s
  Cia402Drive d;
  d.enable(3);
  d.write(0x60FF, 0, 10000, 4);
  d.rig().run(500ms);
  ASSERT_GT(d.value(0x606C), 9000);
  // When axis-coast-to-rest is simulated while the power stage drives the axis
  ASSERT_TRUE(d.app().simulate("axis-coast-to-rest", 1));
  d.rig().run(3ms);
  // Then nothing changes: the drive keeps running
  EXPECT_GT(d.value(0x606C), 9000);
  // When the power stage is switched off (disable voltage: the load coasts on its friction)
  d.controlword(0x0000);
  d.rig().run(50ms);
  ASSERT_GT(d.value(0x606C), 5000);
  const auto coasting_at = d.value(0x6064);
  // And axis-coast-to-rest is simulated
  ASSERT_TRUE(d.app().simulate("axis-coast-to-rest", 1));
  d.rig().run(20ms);
  // Then the axis stands where it was; other values than 1 are refused
  EXPECT_EQ(d.value(0x606C), 0);
  EXPECT_NEAR(static_cast<double>(d.value(0x6064)), static_cast<double>(coasting_at), 200.0);
  EXPECT_FALSE(d.app().simulate("axis-coast-to-rest", 0));
}

TEST(Cia402Application, HardwareEnableGatesSwitchOn) {
  // Given a drive that needs the hardware enable for transition 3
  Cia402ApplicationConfig config;
  config.pds.hardware_enable = HardwareEnable::for_switch_on;
  Cia402Drive d(config);
  d.controlword(0x0006);
  // When switch on is commanded without the enable input
  d.controlword(0x0007);
  // Then the drive stays READY TO SWITCH ON with the warning bit
  EXPECT_EQ(d.statusword() & (kStateMask | 0x80), 0x00A1);
  // When the input is simulated present
  ASSERT_TRUE(d.app().simulate("hardware-enable", 1));
  d.rig().run(3ms);
  // Then transition 3 happens
  EXPECT_EQ(d.statusword() & kStateMask, 0x0023);
}

TEST(Cia402Application, SimulatedFaultGoesThroughEmcyAndFaultReset) {
  // Given an enabled drive
  Cia402Drive d;
  d.enable(1);
  d.rig().take();
  // When an overcurrent fault is simulated
  ASSERT_TRUE(d.app().simulate("fault:overcurrent", 1));
  const auto frames = d.rig().run(20ms);
  // Then EMCY 2310h is sent with register bits 0 and 1, 603Fh shows it, the state is FAULT
  EXPECT_NE(std::find(frames.begin(), frames.end(), emcy_frame(5, 0x2310, 0x03)), frames.end());
  EXPECT_EQ(d.uvalue(0x603F), 0x2310u);
  EXPECT_EQ(d.statusword() & 0x4F, kFault);
  // When the cause goes and a fault reset edge comes
  ASSERT_TRUE(d.app().simulate("fault:overcurrent", 0));
  d.controlword(0x0080);
  // Then the drive is SWITCH ON DISABLED, 603Fh is 0 and the EMCY error reset is sent
  EXPECT_EQ(d.statusword() & 0x4F, kSwitchOnDisabled);
  EXPECT_EQ(d.uvalue(0x603F), 0u);
}

TEST(Cia402Application, IrtsaErrorCodeFormat) {
  // Given an IRTSA-like drive: 603Fh = error number × 256 + 80h, overcurrent = E052
  Cia402ApplicationConfig config;
  config.error_code_format = ErrorCodeFormat::error_number;
  config.error_numbers = {{0x2310, 0x34}};
  Cia402Drive d(config);
  // When the fault occurs
  ASSERT_TRUE(d.app().simulate("fault:overcurrent", 1));
  d.rig().run(5ms);
  // Then 603Fh reads 3480h
  EXPECT_EQ(d.rig().read(0x603F, 0).value, 0x3480u);
}

TEST(Cia402Application, SixteenBitModeObjects) {
  // Given an ESR-like drive: 6060h/6061h INTEGER16
  Cia402ApplicationConfig config;
  config.mode_object_width = ModeObjectWidth::bits16;
  Cia402Drive d(config);
  // When 6060h is written with 2 bytes
  EXPECT_EQ(d.rig().write(0x6060, 0, 3, 2), 0u);
  d.rig().run(3ms);
  // Then 6061h answers 2 bytes with 3; a 1-byte write is a length error
  const SdoResult r = d.rig().read(0x6061, 0);
  EXPECT_EQ(r.value, 3u);
  const std::uint32_t abort = d.rig().write(0x6060, 0, 1, 1);
  EXPECT_TRUE(abort == 0x06070010u || abort == 0x06070013u) << std::hex << abort;
}

TEST(Cia402Application, HeartbeatLossRunsAbortConnectionOption) {
  // Given an enabled drive consuming node 1's heartbeat with 50 ms and 6007h = 1 (fault)
  Cia402Drive d;
  d.write(0x1016, 1, (1u << 16) | 50u, 4);
  d.enable(1);
  d.rig().send("701#05");  // heartbeat of node 1: operational
  d.rig().run(10ms);
  // When node 1 stops sending heartbeats
  d.rig().run(100ms);
  // Then the drive is in FAULT with 603Fh = 8130h
  EXPECT_EQ(d.statusword() & 0x4F, kFault);
  EXPECT_EQ(d.uvalue(0x603F), 0x8130u);
}

// ---------------------------------------------------------------------------------------------
// Profile position

TEST(ProfilePosition, SingleSetPointHandshakeAndTargetReached) {
  // Given pp, OPERATION ENABLED, target 5000, window 10 for 20 ms
  Cia402Drive d;
  d.enable(1);
  d.write(0x607A, 0, 5000, 4);
  d.write(0x6067, 0, 10, 4);
  d.write(0x6068, 0, 20, 2);
  // When bit 4 rises (001Fh)
  d.send_controlword(0x001F);
  d.rig().run(2ms);
  // Then set-point acknowledge is set and target reached cleared
  EXPECT_NE(d.statusword() & kBit12, 0);
  EXPECT_EQ(d.statusword() & kTargetReached, 0);
  // When bit 4 falls
  d.send_controlword(0x000F);
  d.rig().run(2ms);
  // Then the acknowledge falls (buffer free)
  EXPECT_EQ(d.statusword() & kBit12, 0);
  // And target reached comes once the axis has been inside the window for 20 ms
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 2s));
  EXPECT_NEAR(d.value(0x6064), 5000, 10);
  EXPECT_EQ(d.value(0x6062), 5000);
}

// Time from the new set-point to target reached for a move to 2000 with window 5 and the
// window time given.
can::Duration time_to_target_reached(std::uint16_t window_time, Cia402ApplicationConfig config) {
  Cia402Drive d(std::move(config));
  d.enable(1);
  d.write(0x607A, 0, 2000, 4);
  d.write(0x6067, 0, 5, 4);
  d.write(0x6068, 0, window_time, 2);
  d.send_controlword(0x001F);
  d.rig().run(1ms);
  const auto t = d.wait_for(kTargetReached, kTargetReached, 3s);
  EXPECT_TRUE(t);
  EXPECT_NEAR(d.value(0x6064), 2000, 5);
  return t.value_or(can::Duration{});
}

TEST(ProfilePosition, TargetReachedWaitsForTheWindowTime) {
  // Given the same move with position window time 0 and 50 ms
  // When both run to target reached
  const can::Duration immediate = time_to_target_reached(0, {});
  const can::Duration windowed = time_to_target_reached(50, {});
  // Then bit 10 comes 50 ms later with the window time (within a cycle)
  EXPECT_GE(windowed - immediate, 49ms);
  EXPECT_LE(windowed - immediate, 51ms);
}

TEST(ProfilePosition, TargetReachedBeforeWindowTimeDeviation) {
  // Given the deviation pp-target-reached-before-window-time
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_target_reached_before_window_time);
  // When the move runs with a 50 ms window time
  const can::Duration immediate = time_to_target_reached(0, {});
  const can::Duration deviating = time_to_target_reached(50, config);
  // Then bit 10 comes as early as without a window time
  EXPECT_LE(deviating - immediate, 1ms);
}

TEST(ProfilePosition, AcknowledgeLatencyIsConfigurable) {
  // Given an acknowledge latency of 4 drive cycles
  Cia402ApplicationConfig config;
  config.acknowledge_latency_cycles = 4;
  Cia402Drive d(config);
  d.enable(1);
  d.write(0x607A, 0, 1000, 4);
  // When bit 4 rises
  d.send_controlword(0x001F);
  // Then bit 12 comes 4 cycles after the cycle that saw the edge (3..5 ms after the frame)
  const auto latency = d.wait_for(kBit12, kBit12, 20ms);
  ASSERT_TRUE(latency);
  EXPECT_GE(*latency, 3ms);
  EXPECT_LE(*latency, 5ms);
}

TEST(ProfilePosition, AcknowledgeNeverClearedDeviation) {
  // Given the deviation pp-set-point-ack-never-cleared
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_set_point_ack_never_cleared);
  Cia402Drive d(config);
  d.enable(1);
  d.write(0x607A, 0, 1000, 4);
  // When the handshake runs (bit 4 up, then down)
  d.controlword(0x001F);
  d.controlword(0x000F);
  d.rig().run(10ms);
  // Then bit 12 stays 1
  EXPECT_NE(d.statusword() & kBit12, 0);
}

TEST(ProfilePosition, RelativeMoveIsRelativeToTheDemand) {
  // Given pp at rest at 3000 after an absolute move
  Cia402Drive d;
  d.enable(1);
  d.write(0x607A, 0, 3000, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 2s));
  // When 607Ah = 1000 is started relative (bit 6: 005Fh)
  d.write(0x607A, 0, 1000, 4);
  d.controlword(0x005F);
  d.controlword(0x004F);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 2s));
  // Then the axis ends at 4000
  EXPECT_EQ(d.value(0x6062), 4000);
  EXPECT_NEAR(d.value(0x6064), 4000, 2);
}

TEST(ProfilePosition, PositioningOptionCodeTakesTheRelativeAndRequestResponseOptions) {
  // Given the drive with 60F2h (positioning option code)
  Cia402Drive d;
  // When the relative options 00..10, the request-response options 01 and 10, the rotary axis
  // direction options (the drive has 607Bh), the reserved 11 of each and other bits are written
  // Then the options are taken and the rest refused with 06090030h (value range)
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0001, 2), 0u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0002, 2), 0u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0012, 2), 0u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0020, 2), 0u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0040, 2), 0u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0080, 2), 0u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x00C0, 2), 0u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0003, 2), 0x06090030u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0030, 2), 0x06090030u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0004, 2), 0x06090030u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0100, 2), 0x06090030u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0000, 2), 0u);
}

TEST(ProfilePosition, RotaryDirectionOptionRefusedWithoutPositionRange) {
  // Given a drive without 607Bh (position_range none)
  Cia402ApplicationConfig config;
  config.position_range = PositionRangeSupport::none;
  Cia402Drive d(std::move(config));
  // When 607Bh is read and 60F2h bits 7..6 are written
  // Then 607Bh does not exist and the option is refused with 06090030h
  EXPECT_EQ(d.rig().read(0x607B, 0).abort, 0x06020000u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x00C0, 2), 0x06090030u);
}

TEST(ProfilePosition, ReservedPositioningOptionsAcceptedDeviation) {
  // Given the deviation pp-positioning-option-reserved-accepted
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_positioning_option_reserved_accepted);
  Cia402Drive d(std::move(config));
  // When the reserved 11 of the relative and request-response options are written
  // Then both are taken; the options not implemented are still refused
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0003, 2), 0u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0030, 2), 0u);
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0100, 2), 0x06090030u);
}

// --- rotary axis: 607Bh position range limit, 60F2h bits 7..6 --------------------------------

// Range -1000 .. 3000 set, 60F2h = `option`, pp enabled at 2000/s; the axis stands at 0.
void rotary_axis(Cia402Drive& d, std::uint16_t option) {
  d.write(0x607B, 1, -1000, 4);
  d.write(0x607B, 2, 3000, 4);
  d.write(0x60F2, 0, option, 2);
  d.write(0x6081, 0, 2000, 4);
  d.write(0x6083, 0, 20000, 4);
  d.write(0x6084, 0, 20000, 4);
  d.write(0x6067, 0, 10, 4);
  d.enable(1);
}

// An absolute set-point to `target` (change immediately); returns 6064h 300 ms on and the end.
std::pair<std::int64_t, std::int64_t> position_to(Cia402Drive& d, std::int32_t target) {
  d.write(0x607A, 0, target, 4);
  d.controlword(0x003F);
  d.controlword(0x002F);
  d.rig().run(300ms);
  const std::int64_t on_the_way = d.value(0x6064);
  EXPECT_TRUE(d.wait_for(kTargetReached, kTargetReached, 5s));
  return {on_the_way, d.value(0x6064)};
}

TEST(ProfilePosition, PositionRangeDefaultsToTheWholeRangeAndSubZeroTwo) {
  // Given the standard drive
  Cia402Drive d;
  // When 607Bh is read
  // Then sub 00h is 2 and the range the whole INTEGER32 range (no wrap)
  EXPECT_EQ(d.rig().read(0x607B, 0).value, 2u);
  EXPECT_EQ(static_cast<std::int32_t>(d.rig().read(0x607B, 1).value), -2147483647 - 1);
  EXPECT_EQ(d.rig().read(0x607B, 2).value, 0x7FFFFFFFu);
}

TEST(ProfilePosition, RelativeMoveWrapsAtTheMaxLimit) {
  // Given a rotary axis -1000 .. 3000 at 0
  Cia402Drive d;
  rotary_axis(d, 0x0000);
  // When a relative move of +3500 is run
  d.write(0x607A, 0, 3500, 4);
  d.controlword(0x007F);
  d.controlword(0x006F);
  d.rig().run(300ms);
  const std::int64_t on_the_way = d.value(0x6064);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 5s));
  // Then it moved up and 6064h and 6062h show -500 (3500 wrapped); 6063h keeps counting
  EXPECT_GT(on_the_way, 100);
  EXPECT_NEAR(d.value(0x6064), -500, 10);
  EXPECT_EQ(d.value(0x6062), -500);
  EXPECT_NEAR(d.value(0x6063), 3500, 10);
}

TEST(ProfilePosition, RotaryDirectionOptionsChooseTheWay) {
  struct Case {
    std::uint16_t option;
    std::int32_t target;
    bool up;
  };
  // Given a rotary axis -1000 .. 3000 at 0 with each direction option
  for (const Case& c : {Case{0x0000, 2500, true}, Case{0x0040, 1000, false},
                        Case{0x0080, -500, true}, Case{0x00C0, 2500, false}}) {
    Cia402Drive d;
    rotary_axis(d, c.option);
    // When an absolute target is run to
    const auto [on_the_way, end] = position_to(d, c.target);
    // Then the axis went the option's way and ended at the target
    if (c.up) {
      EXPECT_GT(on_the_way, 50) << c.option;
    } else {
      EXPECT_LT(on_the_way, -50) << c.option;
    }
    EXPECT_NEAR(end, c.target, 10) << c.option;
  }
}

TEST(ProfilePosition, RotaryDeviationsPickTheWrongWay) {
  // Given each rotary deviation with the option it spoils
  struct Case {
    Deviation deviation;
    std::uint16_t option;
    std::int32_t target;
    bool up;  // the wrong way it goes
  };
  for (const Case& c : {Case{Deviation::pp_rotary_direction_ignored, 0x0040, 1000, true},
                        Case{Deviation::pp_rotary_direction_swapped, 0x0080, -500, false},
                        Case{Deviation::pp_rotary_linear_as_shortest, 0x0000, 2500, false}}) {
    Cia402ApplicationConfig config;
    config.deviations.add(c.deviation);
    Cia402Drive d(std::move(config));
    rotary_axis(d, c.option);
    // When an absolute target is run to
    const auto [on_the_way, end] = position_to(d, c.target);
    // Then the axis goes the wrong way (and still ends at the target)
    if (c.up) {
      EXPECT_GT(on_the_way, 50) << to_string(c.deviation);
    } else {
      EXPECT_LT(on_the_way, -50) << to_string(c.deviation);
    }
    EXPECT_NEAR(end, c.target, 10) << to_string(c.deviation);
  }
}

TEST(ProfilePosition, PositionRangeNoWrapDeviationRunsPastTheLimit) {
  // Given pp-position-range-no-wrap and a range -1000 .. 3000
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_position_range_no_wrap);
  Cia402Drive d(std::move(config));
  rotary_axis(d, 0x0000);
  // When a relative move of +3500 is run
  d.write(0x607A, 0, 3500, 4);
  d.controlword(0x007F);
  d.controlword(0x006F);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 5s));
  // Then 6064h runs past the limit, and the range still reads back
  EXPECT_NEAR(d.value(0x6064), 3500, 10);
  EXPECT_EQ(d.rig().read(0x607B, 2).value, 3000u);
}

TEST(ProfilePosition, PositionRangeSubZeroWrongDeviation) {
  // Given pp-position-range-sub0-wrong
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_position_range_sub0_wrong);
  Cia402Drive d(std::move(config));
  // When 607Bh sub 00h is read
  // Then it reads 1
  EXPECT_EQ(d.rig().read(0x607B, 0).value, 1u);
}

TEST(ProfilePosition, FestoRoundAxisOnlyWith6510Sub20) {
  // Given the Festo reading: 607Bh in effect only with 6510h sub 20h selecting a round axis
  // (here absent, as off: the festo-cmmp profile's objects file adds it), 60F2h without bits 7..6
  Cia402ApplicationConfig config;
  config.position_range = PositionRangeSupport::festo;
  Cia402Drive d(std::move(config));
  EXPECT_EQ(d.rig().write(0x60F2, 0, 0x0040, 2), 0x06090030u);
  rotary_axis(d, 0x0000);
  // When a relative move of +3500 is run with no round axis selected
  d.write(0x607A, 0, 3500, 4);
  d.controlword(0x007F);
  d.controlword(0x006F);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 5s));
  // Then nothing wraps
  EXPECT_NEAR(d.value(0x6064), 3500, 10);
}

// With 60F2h = `option`, a pp move of 1000 (1.1 s at 1000/s) started with bit 4 left at 1.
void start_move_leaving_bit4(Cia402Drive& d, std::uint16_t option) {
  d.write(0x60F2, 0, option, 2);
  d.write(0x6081, 0, 1000, 4);
  d.enable(1);
  d.write(0x607A, 0, 1000, 4);
  d.controlword(0x001F);
}

TEST(ProfilePosition, RequestResponseReleaseAtOnceResetsBit4AtTheAcknowledge) {
  // Given 60F2h request-response option 10
  Cia402Drive d;
  // When a set-point is started and the master leaves bit 4 at 1
  start_move_leaving_bit4(d, 0x0020);
  d.rig().run(20ms);
  // Then the drive has reset 6040h bit 4 and bit 12 while the axis still moves
  EXPECT_EQ(d.value(0x6040) & 0x0010, 0);
  EXPECT_EQ(d.statusword() & kBit12, 0);
  EXPECT_FALSE(d.statusword() & kTargetReached);
  // And the positioning runs to its target
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 3s));
  EXPECT_NEAR(d.value(0x6064), 1000, 10);
}

TEST(ProfilePosition, RequestResponseReleaseAtTargetWaitsForTheTarget) {
  // Given 60F2h request-response option 01
  Cia402Drive d;
  // When a set-point is started and the master leaves bit 4 at 1
  start_move_leaving_bit4(d, 0x0010);
  d.rig().run(200ms);
  // Then bit 4 and bit 12 stay 1 while the axis moves
  EXPECT_NE(d.value(0x6040) & 0x0010, 0);
  EXPECT_NE(d.statusword() & kBit12, 0);
  // And once the target is reached the drive resets both
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 3s));
  d.rig().run(10ms);
  EXPECT_EQ(d.value(0x6040) & 0x0010, 0);
  EXPECT_EQ(d.statusword() & kBit12, 0);
}

TEST(ProfilePosition, RequestResponseHandshakeByDefault) {
  // Given 60F2h = 0 (request-response option 00)
  Cia402Drive d;
  // When a set-point is started, run to its target, and the master leaves bit 4 at 1
  start_move_leaving_bit4(d, 0x0000);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 3s));
  d.rig().run(10ms);
  // Then bit 4 and bit 12 stay 1: the master resets bit 4
  EXPECT_NE(d.value(0x6040) & 0x0010, 0);
  EXPECT_NE(d.statusword() & kBit12, 0);
}

TEST(ProfilePosition, RequestResponseOptionIgnoredDeviationKeepsBit4) {
  // Given 60F2h request-response option 10 with pp-request-response-option-ignored
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_request_response_option_ignored);
  Cia402Drive d(std::move(config));
  // When a set-point is started and run to its target
  start_move_leaving_bit4(d, 0x0020);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 3s));
  // Then bit 4 is never reset by the drive
  EXPECT_NE(d.value(0x6040) & 0x0010, 0);
}

TEST(ProfilePosition, RequestResponseReleaseEarlyDeviationResetsAtTheAcknowledge) {
  // Given 60F2h request-response option 01 with pp-request-response-release-early
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_request_response_release_early);
  Cia402Drive d(std::move(config));
  // When a set-point is started
  start_move_leaving_bit4(d, 0x0010);
  d.rig().run(20ms);
  // Then bit 4 is reset while the axis still moves
  EXPECT_EQ(d.value(0x6040) & 0x0010, 0);
  EXPECT_FALSE(d.statusword() & kTargetReached);
}

// With 60F2h = `option` (a relative option), a pp move to 20000 at 1000/s for 300 ms, then
// 500 started relative and at once (007Fh); returns `reference` read just before that edge.
std::int64_t move_then_relative_500(Cia402Drive& d, std::uint16_t option, std::uint16_t reference) {
  d.write(0x60F2, 0, option, 2);
  d.write(0x6081, 0, 1000, 4);
  d.enable(1);
  d.write(0x607A, 0, 20000, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  d.rig().run(300ms);
  const std::int64_t at_edge = d.value(reference);
  d.write(0x607A, 0, 500, 4);
  d.controlword(0x007F);
  d.controlword(0x006F);
  return at_edge;
}

TEST(ProfilePosition, RelativeOptionDemandAddsToTheDemandAtTheEdge) {
  // Given 60F2h = 01 (relative to the position demand value) and a move to 20000 running
  Cia402Drive d;
  // When 500 is started relative and at once (007Fh) with the demand at `demand`
  const std::int64_t demand = move_then_relative_500(d, 0x0001, 0x6062);
  // Then the axis ends 500 past that demand (the SDO exchange moves it a few increments on)
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 3s));
  EXPECT_NEAR(d.value(0x6064), demand + 500, 20);
}

TEST(ProfilePosition, RelativeOptionIgnoredDeviationAddsToThePrecedingTarget) {
  // Given 60F2h = 10 (relative to 6064h) with pp-positioning-option-relative-ignored, and a
  // move to 20000 running
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_positioning_option_relative_ignored);
  Cia402Drive d(std::move(config));
  // When 500 is started relative and at once with the axis at `actual`
  const std::int64_t actual = move_then_relative_500(d, 0x0002, 0x6064);
  // Then the axis runs on towards the preceding target + 500 (20500), far past actual + 500
  d.rig().run(1s);
  EXPECT_FALSE(d.statusword() & kTargetReached);
  EXPECT_GT(d.value(0x6064), actual + 900);
}

TEST(ProfilePosition, SetOfSetPointsBuffersTheSecond) {
  // Given a long move A to 20000 running
  Cia402Drive d;
  d.enable(1);
  d.write(0x607A, 0, 20000, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  // When B = 0 is sent with bit 5 = 0 while A runs
  d.write(0x607A, 0, 0, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  // Then the acknowledge stays 1 (B in the buffer) while A runs
  EXPECT_NE(d.statusword() & kBit12, 0);
  EXPECT_GT(d.value(0x6062), 0);
  // And when A is done, B is taken (acknowledge falls) and the axis goes back to 0
  ASSERT_TRUE(d.wait_for(kBit12, 0, 3s));
  EXPECT_GE(d.value(0x6062), 19000);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 3s));
  EXPECT_NEAR(d.value(0x6064), 0, 2);
}

TEST(ProfilePosition, ChangeImmediatelyAbandonsTheRunningMove) {
  // Given a long move A to 20000 running
  Cia402Drive d;
  d.enable(1);
  d.write(0x607A, 0, 20000, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  d.rig().run(20ms);
  // When C = -1000 is sent with bit 5 = 1 (003Fh)
  d.write(0x607A, 0, -1000, 4);
  d.controlword(0x003F);
  d.controlword(0x002F);
  // Then the axis never reaches A's target and ends at C
  std::int64_t highest = 0;
  can::Duration waited{};
  while ((d.statusword() & kTargetReached) == 0) {
    highest = std::max(highest, d.value(0x6064));
    d.rig().run(1ms);
    waited += 1ms;
    ASSERT_LT(waited, 3s);
  }
  EXPECT_LT(highest, 19000);
  EXPECT_NEAR(d.value(0x6064), -1000, 2);
}

TEST(ProfilePosition, HaltStopsAndSetsTargetReached) {
  // Given a long move running
  Cia402Drive d;
  d.enable(1);
  d.write(0x607A, 0, 50000, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  d.rig().run(50ms);
  // When halt is set (010Fh)
  d.controlword(0x010F);
  // Then the axis stops short of the target and bit 10 comes at standstill
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 2s));
  EXPECT_EQ(d.value(0x606C), 0);
  const auto stopped_at = d.value(0x6064);
  EXPECT_LT(stopped_at, 50000);
  // When halt is released
  d.controlword(0x000F);
  // Then the positioning continues to its target
  ASSERT_TRUE(d.wait_for(kTargetReached, 0, 100ms));
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 10s));
  EXPECT_NEAR(d.value(0x6064), 50000, 2);
}

TEST(ProfilePosition, SetPointDuringHaltStartsOnRelease) {
  // Given pp at rest with halt set (010Fh)
  Cia402Drive d;
  d.enable(1);
  d.controlword(0x010F);
  // When a new set-point to 1000 is sent while halted
  d.write(0x607A, 0, 1000, 4);
  d.controlword(0x011F);
  d.controlword(0x010F);
  d.rig().run(200ms);
  // Then it is acknowledged but nothing moves
  EXPECT_EQ(d.value(0x6064), 0);
  // When halt is released the axis moves to 1000
  d.controlword(0x000F);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 2s));
  EXPECT_NEAR(d.value(0x6064), 1000, 2);
}

TEST(ProfileTorque, HaltRampsTheDemandToZeroAndBack) {
  // Given tq at 300 ‰ with slope 1000 ‰/s
  Cia402Drive d;
  d.write(0x6087, 0, 1000, 4);
  d.enable(4);
  d.write(0x6071, 0, 300, 2);
  d.rig().run(400ms);
  ASSERT_EQ(d.value(0x6074), 300);
  // When halt is set
  d.controlword(0x010F);
  // Then 6074h ramps to 0 (0.3 s), the state stays OPERATION ENABLED
  d.rig().run(100ms);
  EXPECT_GT(d.value(0x6074), 0);
  d.rig().run(300ms);
  EXPECT_EQ(d.value(0x6074), 0);
  EXPECT_EQ(d.statusword() & kStateMask, kOperationEnabled);
  // When halt is released the demand ramps back to 300
  d.controlword(0x000F);
  d.rig().run(400ms);
  EXPECT_EQ(d.value(0x6074), 300);
}

TEST(Cia402Application, ResetNodeClearsTheControlword) {
  // Given an enabled drive (6040h = 000Fh)
  Cia402Drive d;
  d.enable(1);
  // When NMT reset node comes
  d.rig().nmt(0x81);
  d.rig().run(10ms);
  // Then 6040h reads 0 and the drive is SWITCH ON DISABLED
  EXPECT_EQ(d.value(0x6040), 0);
  EXPECT_EQ(d.statusword() & kStateMask, kSwitchOnDisabled);
}

TEST(ProfilePosition, SoftwareLimitClampsTheTarget) {
  // Given 607Dh = [-100, 1500]
  Cia402Drive d;
  d.write(0x607D, 1, -100, 4);
  d.write(0x607D, 2, 1500, 4);
  d.enable(1);
  // When a target beyond the max is started
  d.write(0x607A, 0, 9000, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  // Then the axis stops at 1500 and bit 11 (internal limit) was set
  EXPECT_NE(d.statusword() & kInternalLimit, 0);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 2s));
  EXPECT_NEAR(d.value(0x6064), 1500, 2);
}

// ---------------------------------------------------------------------------------------------
// Faults from the axis

TEST(AxisFaults, BlockedAxisRaisesFollowingError) {
  // Given pp, following error window 100 for 10 ms, and a load beyond the torque limit
  Cia402Drive d;
  d.write(0x6065, 0, 100, 4);
  d.write(0x6066, 0, 10, 2);
  d.enable(1);
  ASSERT_TRUE(d.app().simulate("load-torque", 5000));
  d.rig().take();
  // When a move is started
  d.write(0x607A, 0, 10000, 4);
  d.controlword(0x001F);
  const auto frames = d.rig().run(100ms);
  // Then the drive reports following error 8611h (EMCY) and has left OPERATION ENABLED for the
  // fault reaction (which cannot stop an axis the load pushes back: FAULT REACTION ACTIVE)
  EXPECT_NE(std::find(frames.begin(), frames.end(), emcy_frame(5, 0x8611, 0x21)), frames.end());
  EXPECT_EQ(d.statusword() & 0x08, kFault);
  EXPECT_EQ(d.uvalue(0x603F), 0x8611u);
}

TEST(AxisFaults, PositiveLimitSwitchStopsTheDrive) {
  // Given a positive limit switch at 3000 and pv running toward it
  Cia402Drive d;
  ASSERT_TRUE(d.app().simulate("limit-positive-at", 3000));
  d.enable(3);
  d.write(0x60FF, 0, 20000, 4);
  // When the axis reaches the switch
  ASSERT_TRUE(d.wait_for(0x4F, kFault, 2s));
  // Then the drive is in FAULT with the reference limit code and 60FDh bit 1 is set
  EXPECT_EQ(d.uvalue(0x603F), 0x8612u);
  EXPECT_EQ(d.value(0x60FD) & 0x2, 0x2);
  EXPECT_GE(d.value(0x6064), 3000);
}

// ---------------------------------------------------------------------------------------------
// Profile velocity, profile torque

TEST(ProfileVelocity, TargetReachedAfterVelocityWindowTime) {
  // Given pv, velocity window 20 for 30 ms, acceleration 100000 units/s²
  Cia402Drive d;
  d.write(0x606D, 0, 20, 2);
  d.write(0x606E, 0, 30, 2);
  d.enable(3);
  // When 60FFh = 10000 is written (100 ms ramp)
  d.write(0x60FF, 0, 10000, 4);
  EXPECT_EQ(d.statusword() & kTargetReached, 0);
  // Then bit 10 comes about 30 ms after 606Ch is inside the window
  can::Duration waited{};
  while (std::abs(d.value(0x606C) - 10000) > 20) {
    d.rig().run(1ms);
    waited += 1ms;
    ASSERT_LT(waited, 1s);
  }
  const auto after = d.wait_for(kTargetReached, kTargetReached, 200ms);
  ASSERT_TRUE(after);
  EXPECT_GE(*after, 29ms);
  EXPECT_LE(*after, 32ms);
  // And bit 12 (speed = 0) is 0 while moving
  EXPECT_EQ(d.statusword() & kBit12, 0);
}

TEST(ProfileVelocity, SpeedZeroAndHalt) {
  // Given pv running at 5000
  Cia402Drive d;
  d.enable(3);
  EXPECT_NE(d.statusword() & kBit12, 0);  // at rest: speed = 0
  d.write(0x60FF, 0, 5000, 4);
  d.rig().run(200ms);
  EXPECT_EQ(d.statusword() & kBit12, 0);
  // When halt is set
  d.controlword(0x010F);
  // Then the axis ramps to 0 and bits 10 and 12 are set
  ASSERT_TRUE(d.wait_for(kTargetReached | kBit12, kTargetReached | kBit12, 1s));
  d.rig().run(10ms);
  EXPECT_EQ(d.value(0x606C), 0);
  // When halt is released the axis accelerates again
  d.controlword(0x000F);
  d.rig().run(200ms);
  EXPECT_NEAR(d.value(0x606C), 5000, 20);
}

TEST(ProfileTorque, TorqueFollowsTheSlope) {
  // Given tq with slope 1000 ‰/s
  Cia402Drive d;
  d.write(0x6087, 0, 1000, 4);
  d.enable(4);
  // When 6071h = 100 ‰ is written
  d.write(0x6071, 0, 100, 2);
  // Then the demand ramps (not a step): after ~5 ms it is below 100, bit 10 not set
  EXPECT_LT(d.value(0x6077), 100);
  EXPECT_EQ(d.statusword() & kTargetReached, 0);
  // And after 100 ms the demand is 100 with bit 10; the motor follows a cycle later
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 200ms));
  d.rig().run(2ms);
  EXPECT_EQ(d.value(0x6077), 100);
  EXPECT_GT(d.value(0x606C), 0);
}

TEST(ProfileTorque, SlopeIgnoredDeviation) {
  // Given the deviation tq-slope-ignored
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::tq_slope_ignored);
  Cia402Drive d(config);
  d.write(0x6087, 0, 1000, 4);
  d.enable(4);
  // When 6071h = 100 is written
  d.write(0x6071, 0, 100, 2);
  // Then the torque is there at once
  EXPECT_EQ(d.value(0x6077), 100);
}

TEST(ProfileTorque, Sin2RampStartsSoftAndEndsAtTheTarget) {
  // Given tq with slope 1000 ‰/s and 6088h = 1 (sin² ramp)
  Cia402Drive d;
  d.write(0x6087, 0, 1000, 4);
  d.write(0x6088, 0, 1, 2);
  EXPECT_EQ(d.value(0x6088), 1);
  d.enable(4);
  // When 6071h = 500 ‰ is written
  d.write(0x6071, 0, 500, 2);
  // Then after a fifth of the linear ramp's 0.5 s the demand is near 500 × sin²(π/10) = 48, not
  // the linear 100
  d.rig().run(100ms);
  EXPECT_NEAR(d.value(0x6074), 48, 8);
  // And at half time it is half way (sin² is symmetric), and at the end the target
  d.rig().run(150ms);
  EXPECT_NEAR(d.value(0x6074), 250, 10);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 400ms));
  EXPECT_EQ(d.value(0x6074), 500);
}

TEST(ProfileTorque, TorqueProfileTypeIgnoredDeviation) {
  // Given the deviation tq-torque-profile-type-ignored and 6088h = 1
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::tq_torque_profile_type_ignored);
  Cia402Drive d(config);
  d.write(0x6087, 0, 1000, 4);
  d.write(0x6088, 0, 1, 2);
  d.enable(4);
  // When 6071h = 500 is written / Then the ramp is linear: 100 after 100 ms
  d.write(0x6071, 0, 500, 2);
  d.rig().run(100ms);
  EXPECT_NEAR(d.value(0x6074), 100, 8);
  EXPECT_EQ(d.value(0x6088), 1);
}

// ---------------------------------------------------------------------------------------------
// Interpolated position and cyclic synchronous modes

TEST(InterpolatedPosition, RecordsAreInterpolatedAtSync) {
  // Given ip (supported modes incl. ip), OPERATION ENABLED, period 2 ms
  Cia402ApplicationConfig config;
  config.pds.supported_modes |= 0x40;
  Cia402Drive d(config);
  d.write(0x60C2, 1, 2, 1);
  d.enable(7);
  // When enable ip mode (bit 4) is set
  d.controlword(0x001F);
  // Then bit 12 (ip mode active) is set
  EXPECT_NE(d.statusword() & kBit12, 0);
  // When records 100, 200, 300 are written and SYNCs come
  for (std::int32_t p : {100, 200, 300}) {
    d.write(0x60C1, 1, p, 4);
  }
  for (int i = 0; i < 3; ++i)
    d.rig().sync();
  d.rig().run(50ms);
  // Then the demand has gone through them and ends at 300 (the axis settles there)
  EXPECT_EQ(d.value(0x6062), 300);
  EXPECT_NEAR(d.value(0x6064), 300, 2);
  // When bit 4 is cleared, bit 12 falls
  d.controlword(0x000F);
  EXPECT_EQ(d.statusword() & kBit12, 0);
}

TEST(CyclicSyncPosition, FollowsRpdoAndSync) {
  // Given csp with RPDO1 = 607Ah (synchronous), OPERATION ENABLED, NMT operational
  Cia402Drive d;
  d.write(0x1400, 1, 0x80000205, 4);
  d.write(0x1400, 2, 1, 1);
  d.write(0x1600, 0, 0, 1);
  d.write(0x1600, 1, 0x607A0020, 4);
  d.write(0x1600, 0, 1, 1);
  d.write(0x1400, 1, 0x00000205, 4);
  d.rig().nmt(0x01);
  d.enable(8);
  // Then bit 12 (follows the command) is set
  EXPECT_NE(d.statusword() & kBit12, 0);
  // When 607Ah steps of 10 come by RPDO, one per 1 ms SYNC
  for (std::int32_t p = 10; p <= 500; p += 10) {
    // RPDO1: 607Ah = p
    d.rig().send(fmt::format("205#{:02X}{:02X}{:02X}{:02X}", p & 0xFF, (p >> 8) & 0xFF,
                             (p >> 16) & 0xFF, (p >> 24) & 0xFF));
    d.rig().run(200us);
    d.rig().send("080#");
    d.rig().run(800us);
  }
  d.rig().run(50ms);
  // Then the axis follows to 500
  EXPECT_EQ(d.value(0x6062), 500);
  EXPECT_NEAR(d.value(0x6064), 500, 2);
  EXPECT_EQ(d.app().cycles() > 0, true);
}

TEST(CyclicSyncPosition, FollowsBitNeverSetDeviation) {
  // Given the deviation csp-follows-bit-never-set
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::csp_follows_bit_never_set);
  Cia402Drive d(config);
  // When csp is enabled
  d.enable(8);
  // Then bit 12 stays 0
  EXPECT_EQ(d.statusword() & kBit12, 0);
}

TEST(CyclicSyncPosition, FollowingErrorBit13StaysThroughTheFault) {
  // Given csp, following error window 1 for 0 ms
  Cia402Drive d;
  d.enable(8);
  d.write(0x6066, 0, 0, 2);
  d.write(0x6065, 0, 1, 4);
  EXPECT_EQ(d.statusword() & kBit13, 0);
  // When 607Ah steps by 1000 (taken in the next cycles: no SYNC yet)
  d.write(0x607A, 0, d.value(0x6064) + 1000, 4);
  d.rig().run(20ms);
  // Then the drive took its fault reaction (8611h) and bit 13 shows the following error
  EXPECT_EQ(d.statusword() & 0x08, kFault);
  EXPECT_EQ(d.uvalue(0x603F), 0x8611u);
  EXPECT_NE(d.statusword() & kBit13, 0);
  // And it is still there in FAULT, once the reaction is over
  ASSERT_TRUE(d.wait_for(0x4F, kFault, 2s));
  EXPECT_NE(d.statusword() & kBit13, 0);
  // And a fault reset and enabling again clear it
  // (607Ah where the axis coasted to, so that the step is not asked again)
  d.controlword(0x0080);
  d.write(0x6065, 0, 10000, 4);
  ASSERT_TRUE(d.app().simulate("axis-coast-to-rest", 1));
  d.write(0x607A, 0, d.value(0x6064), 4);
  d.enable(8);
  EXPECT_EQ(d.statusword() & kBit13, 0);
}

TEST(CyclicSyncPosition, FollowingErrorBitNeverSetDeviation) {
  // Given the deviation csp-following-error-bit-never-set, csp, window 1 for 0 ms
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::csp_following_error_bit_never_set);
  Cia402Drive d(config);
  d.enable(8);
  d.write(0x6066, 0, 0, 2);
  d.write(0x6065, 0, 1, 4);
  // When 607Ah steps by 1000 / Then the fault comes, bit 13 never
  d.write(0x607A, 0, d.value(0x6064) + 1000, 4);
  d.rig().run(20ms);
  EXPECT_EQ(d.uvalue(0x603F), 0x8611u);
  EXPECT_EQ(d.statusword() & kBit13, 0);
}

TEST(CyclicSyncVelocity, FollowsTargetVelocity) {
  // Given csv enabled
  Cia402Drive d;
  d.enable(9);
  // When 60FFh = 3000 is written
  d.write(0x60FF, 0, 3000, 4);
  d.rig().run(10ms);
  // Then 606Ch is 3000 and bit 12 set
  EXPECT_EQ(d.value(0x606C), 3000);
  EXPECT_NE(d.statusword() & kBit12, 0);
}

// ---------------------------------------------------------------------------------------------
// Option codes with the real axis

// Stop distance of a pv run at 10000 units/s stopped by quick stop (0002h) with 605Ah = code.
std::int64_t quick_stop_distance(std::int16_t code) {
  Cia402Drive d;
  d.write(0x605A, 0, code, 2);
  d.write(0x6084, 0, 50000, 4);   // slow down ramp
  d.write(0x6085, 0, 200000, 4);  // quick stop ramp
  d.enable(3);
  d.write(0x60FF, 0, 10000, 4);
  d.rig().run(300ms);
  EXPECT_EQ(d.value(0x606C), 10000);
  const std::int64_t from = d.value(0x6064);
  d.send_controlword(0x0002);
  d.rig().run(1s);
  EXPECT_EQ(d.value(0x606C), 0);
  return d.value(0x6064) - from;
}

TEST(OptionCodes, QuickStopUsesTheRampTheOptionCodeNames) {
  // Given pv at 10000 units/s, 6084h = 50000, 6085h = 200000 units/s²
  // When quick stop is commanded with 605Ah = 1 (slow down ramp) and 2 (quick stop ramp)
  const std::int64_t slow = quick_stop_distance(1);
  const std::int64_t quick = quick_stop_distance(2);
  // Then the distances are v²/2a: 1000 and 250 units (± a cycle's travel)
  EXPECT_NEAR(slow, 1000, 15);
  EXPECT_NEAR(quick, 250, 15);
}

TEST(OptionCodes, DisableDriveFunctionCoasts) {
  // Given pv at 10000 units/s and 605Ah = 0 (disable drive function)
  // When quick stop is commanded
  const std::int64_t coast = quick_stop_distance(0);
  // Then the motor runs down on friction alone (5 ‰ = 20000 units/s²: 2500 units)
  EXPECT_NEAR(coast, 2500, 30);
}

TEST(OptionCodes, HaltOptionCodeSelectsTheRamp) {
  // Given pv at 10000 units/s with 605Dh = 2 (quick stop ramp, 6085h = 200000)
  Cia402Drive d;
  d.write(0x605D, 0, 2, 2);
  d.write(0x6085, 0, 200000, 4);
  d.enable(3);
  d.write(0x60FF, 0, 10000, 4);
  d.rig().run(300ms);
  // When halt is set
  d.send_controlword(0x010F);
  // Then the axis stops within 50 ms + a cycle (10000 / 200000 s), the state stays OE
  d.rig().run(52ms);
  EXPECT_EQ(d.value(0x606C), 0);
  EXPECT_EQ(d.statusword() & kStateMask, kOperationEnabled);
}

// ---------------------------------------------------------------------------------------------
// Factor group in the drive

TEST(FactorGroupInTheDrive, PositionsInUserUnitsWithPolarity) {
  // Given 6093h = 4096/360 (degrees) and pp
  Cia402Drive d;
  d.write(0x6093, 1, 4096, 4);
  d.write(0x6093, 2, 360, 4);
  d.enable(1);
  // When a move to 90 degrees runs
  d.write(0x607A, 0, 90, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 2s));
  // Then 6064h reads 90 and the axis stands at 1024 increments (6063h)
  EXPECT_EQ(d.value(0x6064), 90);
  EXPECT_NEAR(d.value(0x6063), 1024, 1);
  // When the position polarity is inverted (80h)
  d.write(0x607E, 0, 0x80, 1);
  d.rig().run(2ms);
  // Then 6064h reads -90 for the same axis position
  EXPECT_EQ(d.value(0x6064), -90);
}

// ---------------------------------------------------------------------------------------------
// The remaining mode deviations: each changes exactly the bit or motion its row names

TEST(ModeDeviations, ChangeImmediatelyIgnored) {
  // Given pp-change-immediately-ignored and a long move A to 20000 running
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_change_immediately_ignored);
  Cia402Drive d(config);
  d.enable(1);
  d.write(0x607A, 0, 20000, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  // When C = -1000 is sent with bit 5 = 1
  d.write(0x607A, 0, -1000, 4);
  d.controlword(0x003F);
  d.controlword(0x002F);
  // Then A is completed first (the demand reaches 20000) before C runs
  std::int64_t highest = 0;
  can::Duration waited{};
  while ((d.statusword() & kBit12) != 0 || d.value(0x6062) > 0) {
    highest = std::max(highest, d.value(0x6062));
    d.rig().run(1ms);
    waited += 1ms;
    ASSERT_LT(waited, 5s);
  }
  EXPECT_EQ(highest, 20000);
}

TEST(ModeDeviations, RelativeAsAbsolute) {
  // Given pp-relative-as-absolute and the axis at rest at 3000
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_relative_as_absolute);
  Cia402Drive d(config);
  d.enable(1);
  d.write(0x607A, 0, 3000, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 2s));
  // When a relative move of 1000 is started
  d.write(0x607A, 0, 1000, 4);
  d.controlword(0x005F);
  d.controlword(0x004F);
  ASSERT_TRUE(d.wait_for(kTargetReached, kTargetReached, 2s));
  // Then the axis goes to 1000, not 4000
  EXPECT_EQ(d.value(0x6062), 1000);
}

TEST(ModeDeviations, HaltTargetReachedMissing) {
  // Given pp-halt-target-reached-missing and a move running
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pp_halt_target_reached_missing);
  Cia402Drive d(config);
  d.enable(1);
  d.write(0x607A, 0, 50000, 4);
  d.controlword(0x001F);
  d.controlword(0x000F);
  // When halt stops the axis
  d.controlword(0x010F);
  d.rig().run(500ms);
  // Then the axis is at rest but bit 10 stays 0
  EXPECT_EQ(d.value(0x606C), 0);
  EXPECT_EQ(d.statusword() & kTargetReached, 0);
}

TEST(ModeDeviations, VelocityBitsWrong) {
  // Given pv-target-reached-outside-window and pv-speed-zero-bit-never-set
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::pv_target_reached_outside_window);
  config.deviations.add(Deviation::pv_speed_zero_bit_never_set);
  Cia402Drive d(config);
  d.enable(3);
  // When the drive stands still: bit 12 (speed = 0) is 0
  EXPECT_EQ(d.statusword() & kBit12, 0);
  // When 60FFh = 10000 is written (a 100 ms ramp)
  d.write(0x60FF, 0, 10000, 4);
  // Then bit 10 is already set while 606Ch is far from 10000
  EXPECT_LT(d.value(0x606C), 5000);
  EXPECT_NE(d.statusword() & kTargetReached, 0);
}

TEST(ModeDeviations, TorqueTargetReachedNeverSet) {
  // Given tq-target-reached-never-set
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::tq_target_reached_never_set);
  Cia402Drive d(config);
  d.enable(4);
  // When the torque reaches 6071h
  d.write(0x6071, 0, 50, 2);
  d.rig().run(100ms);
  // Then bit 10 stays 0
  EXPECT_EQ(d.value(0x6077), 50);
  EXPECT_EQ(d.statusword() & kTargetReached, 0);
}

TEST(ModeDeviations, IpActiveBitNeverSet) {
  // Given ip-active-bit-never-set
  Cia402ApplicationConfig config;
  config.pds.supported_modes |= 0x40;
  config.deviations.add(Deviation::ip_active_bit_never_set);
  Cia402Drive d(config);
  d.enable(7);
  // When enable ip mode is set
  d.controlword(0x001F);
  // Then bit 12 stays 0 although records are taken
  EXPECT_EQ(d.statusword() & kBit12, 0);
  d.write(0x60C1, 1, 100, 4);
  d.rig().sync();
  d.rig().run(50ms);
  EXPECT_NEAR(d.value(0x6064), 100, 2);
}

TEST(CyclicSyncTorque, FollowsTargetTorque) {
  // Given cst enabled
  Cia402Drive d;
  d.enable(10);
  // When 6071h = 30 ‰ is written
  d.write(0x6071, 0, 30, 2);
  d.rig().run(5ms);
  // Then the motor torque is 30 ‰ at once (no slope) and the axis accelerates
  EXPECT_EQ(d.value(0x6077), 30);
  EXPECT_GT(d.value(0x606C), 0);
  EXPECT_NE(d.statusword() & kBit12, 0);
}

TEST(Cia402Application, ManufacturerModeValuesAreAccepted) {
  // Given a personality listing the manufacturer mode -127 (IRTSA mpp)
  Cia402ApplicationConfig config;
  config.manufacturer_modes = {{.value = -127}};
  Cia402Drive d(config);
  // When 6060h = -127 (81h) and -126 (82h) are written
  // Then -127 is accepted and shown in 6061h, -126 is refused with 06090030h
  EXPECT_EQ(d.rig().write(0x6060, 0, 0x81, 1), 0u);
  EXPECT_EQ(d.rig().write(0x6060, 0, 0x82, 1), 0x06090030u);
  d.rig().run(2ms);
  EXPECT_EQ(d.value(0x6061), -127);
}

TEST(ManufacturerMode, RunsTheLogicOfItsStandardModeUnderItsOwnValue) {
  // Given Kollmorgen's -128 "digital speed controller" behaving as profile velocity
  Cia402ApplicationConfig config;
  config.manufacturer_modes = {{.value = -128, .behaves_as = 3}};
  Cia402Drive d(config);
  d.enable(-128);
  // When 60FFh = 1000 is asked
  d.write(0x60FF, 0, 1000, 4);
  d.rig().run(500ms);
  // Then the axis runs at 1000, 6061h still shows -128 and pv's target reached bit is set
  EXPECT_NEAR(d.value(0x606C), 1000, 20);
  EXPECT_EQ(d.value(0x6061), -128);
  EXPECT_NE(d.statusword() & kTargetReached, 0);
  // And the mode's pv-only object 60F8h exists once (pv is hosted too)
  EXPECT_NE(d.rig().drive().dictionary().find(0x60F8, 0), nullptr);
}

TEST(ManufacturerMode, BringsTheObjectsOfAStandardModeTheDriveDoesNotHost) {
  // Given a drive that hosts only pp, with -128 behaving as pv
  Cia402ApplicationConfig config;
  config.pds.supported_modes = 0x1;
  config.manufacturer_modes = {{.value = -128, .behaves_as = 3}};
  Cia402Drive d(config);
  // Then pv's own object 60F8h exists and 6060h = 3 is refused
  EXPECT_NE(d.rig().drive().dictionary().find(0x60F8, 0), nullptr);
  EXPECT_EQ(d.rig().write(0x6060, 0, 3, 1), 0x06090030u);
  // And -128 runs pv's logic
  d.enable(-128);
  d.write(0x60FF, 0, -500, 4);
  d.rig().run(500ms);
  EXPECT_NEAR(d.value(0x606C), -500, 20);
}

TEST(ManufacturerMode, WithoutLogicTheAxisHolds) {
  // Given Kollmorgen's -127 "analogue speed controller" (no bus set-point: behaves_as 0)
  Cia402ApplicationConfig config;
  config.manufacturer_modes = {{.value = -127, .behaves_as = 0}};
  Cia402Drive d(config);
  d.enable(-127);
  const auto start = d.value(0x6064);
  // When the set-points of pv, tq and pp are written
  d.write(0x60FF, 0, 1000, 4);
  d.write(0x6071, 0, 100, 2);
  d.write(0x607A, 0, 5000, 4);
  d.controlword(0x001F);
  d.rig().run(500ms);
  // Then the axis has not moved and the mode bits are 0
  EXPECT_EQ(d.value(0x606C), 0);
  EXPECT_EQ(d.value(0x6064), start);
  EXPECT_EQ(d.statusword() & (kTargetReached | kBit12 | kBit13), 0);
}

namespace {

Cia402ApplicationConfig irtsa_mpp() {
  Cia402ApplicationConfig config;
  config.manufacturer_modes = {
      {.value = -127, .behaves_as = 1, .logic = ManufacturerModeConfig::Logic::irtsa_mpp}};
  return config;
}

}  // namespace

TEST(IrtsaManualPositioning, JogsWhileADirectionBitIsSet) {
  // Given IRTSA mpp (-127) in OPERATION ENABLED, 6081h = 2000
  Cia402Drive d(irtsa_mpp());
  d.enable(-127);
  d.write(0x6081, 0, 2000, 4);
  // When bit 5 (positive direction) is set
  d.controlword(0x002F);
  d.rig().run(500ms);
  // Then the axis runs positive at the profile velocity
  EXPECT_NEAR(d.value(0x606C), 2000, 20);
  EXPECT_GT(d.value(0x6064), 500);
  // When bit 5 is released
  d.controlword(0x000F);
  d.rig().run(300ms);
  // Then the axis stops and stays
  EXPECT_EQ(d.value(0x606C), 0);
  const auto stopped = d.value(0x6064);
  d.rig().run(300ms);
  EXPECT_EQ(d.value(0x6064), stopped);
  // When bit 6 (negative direction) is set
  d.controlword(0x004F);
  d.rig().run(500ms);
  // Then it runs negative
  EXPECT_NEAR(d.value(0x606C), -2000, 20);
  EXPECT_LT(d.value(0x6064), stopped);
}

TEST(IrtsaManualPositioning, TheDirectionSetFirstWinsWhileBothBitsAreSet) {
  // Given IRTSA mpp (-127) jogging positive (bit 5)
  Cia402Drive d(irtsa_mpp());
  d.enable(-127);
  d.write(0x6081, 0, 2000, 4);
  d.controlword(0x002F);
  d.rig().run(200ms);
  ASSERT_GT(d.value(0x606C), 1900);
  // When bit 6 is set in addition: still positive (L489)
  d.controlword(0x006F);
  d.rig().run(200ms);
  EXPECT_GT(d.value(0x606C), 1900);
  // When bit 5 is released: negative (L489-490)
  d.controlword(0x004F);
  d.rig().run(300ms);
  EXPECT_LT(d.value(0x606C), -1900);
  // When bit 5 is set again in addition: still negative (L490)
  d.controlword(0x006F);
  d.rig().run(200ms);
  EXPECT_LT(d.value(0x606C), -1900);
  // When both are released: it stops (L490)
  d.controlword(0x000F);
  d.rig().run(300ms);
  EXPECT_EQ(d.value(0x606C), 0);
}

TEST(IrtsaManualPositioning, BeyondASoftwareLimitItDoesNotJogBack) {
  // Given IRTSA mpp at rest at 6064h = 1000 and a software limit max 500 set afterwards
  Cia402Drive d(irtsa_mpp());
  ASSERT_TRUE(d.app().simulate("axis-position", 1000));
  d.enable(-127);
  d.write(0x607D, 1, -500, 4);
  d.write(0x607D, 2, 500, 4);
  d.write(0x6081, 0, 2000, 4);
  // When bit 5 (positive) is set for 500 ms
  d.controlword(0x002F);
  d.rig().run(500ms);
  // Then the axis stays where it is (bit 11), it is not pulled back to the limit
  EXPECT_NEAR(d.value(0x6064), 1000, 5);
  EXPECT_NE(d.statusword() & kInternalLimit, 0);
  // And bit 6 (negative, back inside) jogs
  d.controlword(0x004F);
  d.rig().run(300ms);
  EXPECT_LT(d.value(0x606C), -1900);
}

TEST(IrtsaManualPositioning, StopsAtTheSoftwareLimitAndHalts) {
  // Given IRTSA mpp with software limits -1000..3000
  Cia402Drive d(irtsa_mpp());
  d.write(0x607D, 1, -1000, 4);
  d.write(0x607D, 2, 3000, 4);
  d.enable(-127);
  d.write(0x6081, 0, 5000, 4);
  // When bit 5 stays set for 3 s
  d.controlword(0x002F);
  d.rig().run(3s);
  // Then the axis stands at the limit with bit 11
  EXPECT_NEAR(d.value(0x6064), 3000, 5);
  EXPECT_EQ(d.value(0x606C), 0);
  EXPECT_NE(d.statusword() & kInternalLimit, 0);
  // When bit 6 with halt (bit 8)
  d.controlword(0x014F);
  d.rig().run(300ms);
  // Then the axis does not move; released, it jogs negative
  EXPECT_NEAR(d.value(0x6064), 3000, 5);
  d.controlword(0x004F);
  d.rig().run(300ms);
  EXPECT_LT(d.value(0x606C), -4900);
}

TEST(ProfileVelocity, MaxSlippageWhenTheAxisCannotFollow) {
  // Given pv with 60F8h max slippage = 500 and a load beyond the torque limit
  Cia402Drive d;
  d.write(0x60F8, 0, 500, 4);
  d.write(0x6065, 0, 0xFFFFFFFF, 4);
  d.enable(3);
  EXPECT_EQ(d.statusword() & kBit13, 0);
  ASSERT_TRUE(d.app().simulate("load-torque", 5000));
  // When 60FFh = 10000 is asked
  d.write(0x60FF, 0, 10000, 4);
  d.rig().run(100ms);
  // Then bit 13 (max slippage) is set
  EXPECT_NE(d.statusword() & kBit13, 0);
  // And without the load the axis follows and bit 13 clears
  ASSERT_TRUE(d.app().simulate("load-torque", 0));
  d.rig().run(500ms);
  EXPECT_EQ(d.statusword() & kBit13, 0);
}

TEST(Cia402Application, AxisPositionWhileEnabledHoldsTheNewPlace) {
  // Given pp in OPERATION ENABLED at rest at 0
  Cia402Drive d;
  d.enable(1);
  // When the axis is put at 6000 by simulate
  ASSERT_TRUE(d.app().simulate("axis-position", 6000));
  d.rig().run(100ms);
  // Then it stays there (no jump back to the old demand), no following error fault
  EXPECT_NEAR(d.value(0x6064), 6000, 1);
  EXPECT_EQ(d.statusword() & kStateMask, kOperationEnabled);
}

TEST(InterpolatedPosition, BufferRefusesRecordsWhenClearedOrFull) {
  // Given ip with the buffer cleared (60C4h sub 6 = 0)
  Cia402ApplicationConfig config;
  config.pds.supported_modes |= 0x40;
  Cia402Drive d(config);
  d.write(0x60C4, 6, 0, 1);
  // When a record is written
  // Then it is refused with 08000022h
  EXPECT_EQ(d.rig().write(0x60C1, 1, 10, 4), 0x08000022u);
  // When the buffer is enabled with 2 places and 3 records are written
  d.write(0x60C4, 6, 1, 1);
  d.write(0x60C4, 2, 2, 4);
  EXPECT_EQ(d.rig().write(0x60C1, 1, 10, 4), 0u);
  EXPECT_EQ(d.rig().write(0x60C1, 1, 20, 4), 0u);
  // Then the third is refused, and 60C0h accepts only 0 (linear)
  EXPECT_EQ(d.rig().write(0x60C1, 1, 30, 4), 0x08000022u);
  EXPECT_EQ(d.rig().write(0x60C0, 0, 1, 2), 0x06090030u);
}

TEST(ProfilePosition, JerkLimitedProfileEndsOnTheTargetLater) {
  // Given the same move with 6086h = 0 (linear ramps) and 6086h = 3 (jerk-limited)
  const auto run = [](std::int16_t profile_type) {
    Cia402Drive d;
    d.write(0x6086, 0, profile_type, 2);
    d.enable(1);
    d.write(0x607A, 0, 4000, 4);
    d.send_controlword(0x001F);
    d.rig().run(1ms);
    const auto t = d.wait_for(kTargetReached, kTargetReached, 3s);
    EXPECT_TRUE(t);
    EXPECT_EQ(d.value(0x6062), 4000);
    return t.value_or(can::Duration{});
  };
  // When both run to target reached
  const can::Duration linear = run(0);
  const can::Duration smooth = run(3);
  // Then the S-curve (20-cycle smoothing) arrives later by about half its length, not more
  // than its whole length
  EXPECT_GE(smooth - linear, 5ms);
  EXPECT_LE(smooth - linear, 25ms);
}

TEST(Cia402Application, PdsDeviationsGivenWithTheApplicationReachThePds) {
  // Given the deviation fault-reset-on-level set in the application's config only
  Cia402ApplicationConfig config;
  config.deviations.add(Deviation::fault_reset_on_level);
  Cia402Drive d(config);
  // Then the PDS has it too
  EXPECT_TRUE(d.app().pds().config().deviations.has(Deviation::fault_reset_on_level));
}

TEST(ProfileVelocity, RampFollowsProfileAcceleration) {
  // Given pv with 6083h = 2000 units/s², window 20, window time 0
  Cia402Drive d;
  d.write(0x6060, 0, 3, 1);
  d.write(0x6083, 0, 2000, 4);
  d.write(0x6084, 0, 10000, 4);
  d.write(0x606D, 0, 20, 2);
  d.write(0x606E, 0, 0, 2);
  d.controlword(0x0006);
  d.controlword(0x000F);
  // When 60FFh = 1000 is written
  d.send_controlword(0x000F);
  d.write(0x60FF, 0, 1000, 4);
  // Then target reached comes after about 490 ms (the ramp to 980)
  const auto t = d.wait_for(kTargetReached, kTargetReached, 2s);
  ASSERT_TRUE(t);
  EXPECT_GE(*t, 470ms);
  EXPECT_LE(*t, 500ms);
}

TEST(CyclicSyncPosition, NewTargetWaitsForTheNextSync) {
  // Given csp enabled, NMT operational, driven by SYNC (10 ms interpolation period)
  Cia402Drive d;
  d.rig().nmt(0x01);
  d.write(0x60C2, 1, 10, 1);
  d.enable(8);
  d.rig().sync();
  d.rig().run(10ms);
  // When 607Ah = 20 is written with no SYNC for 100 ms
  d.write(0x607A, 0, 20, 4);
  d.rig().run(100ms);
  // Then the demand has not moved
  EXPECT_EQ(d.value(0x6062), 0);
  // When the next SYNC comes, the demand moves to 20 over the period
  d.rig().sync();
  d.rig().run(20ms);
  EXPECT_EQ(d.value(0x6062), 20);
}

}  // namespace
}  // namespace drivecheck::reference_drive::testing
