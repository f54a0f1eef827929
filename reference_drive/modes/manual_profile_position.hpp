// IRTSA's manual profile position mode "mpp" (6060h = -127, manufacturer specific;
// 003_111f14ab1c37c28a.txt §4.5.4 L481-507, Table 21): the axis jogs through the trajectory
// generator while a direction bit of the controlword is set, also when it is not homed.
//
// Controlword bits (OPERATION ENABLED; bits 0-4 and 7-15 as in every mode, Table 3):
//   5 positive direction, 6 negative direction. The direction whose bit was set first wins
//   while both are set (L489-490): bit 5 → positive; bit 6 added → still positive; bit 5
//   released → negative; bit 5 set again → still negative until bit 6 is released; both
//   released → the axis stops. From standstill both bits at once: positive (the manual's
//   first case).
// Profile (L491): velocity 6081h (limited by 607Fh and the motor's speed), acceleration 6083h,
// deceleration 6084h (also when the bits are released). The demand stops at the software
// position limits 607Dh (bit 11 while it stands there).
// Halt (bit 8): the PDS stops the axis (605Dh); released, the jog goes on if a bit is set.
// Statusword: the manual names no mode bits for mpp; bit 13 shows the following error of the
// position control (§4.6.2, as in pp), bits 10 and 12 stay 0.
#pragma once

#include <cstdint>

#include "reference_drive/axis/trajectory.hpp"
#include "reference_drive/modes/operation_mode.hpp"

namespace drivecheck::reference_drive {

class ManualProfilePositionMode final : public OperationMode {
 public:
  explicit ManualProfilePositionMode(std::int8_t value = -127) : value_(value) {}
  std::int8_t mode() const override { return value_; }
  void on_reset(ModeContext& ctx) override;
  void enter(ModeContext& ctx, const ModeCycle& cycle) override;
  void cycle(ModeContext& ctx, const ModeCycle& cycle) override;
  std::uint16_t statusword_bits(cia402::State state) const override;

  // The jog direction in force: +1, -1 or 0 (stopping or standing).
  int direction() const { return direction_; }

 private:
  std::int8_t value_;
  TrajectoryGenerator trajectory_;
  int direction_ = 0;
  std::uint16_t bits_ = 0;
};

}  // namespace drivecheck::reference_drive
