// Profile velocity mode (6060h = 3; CiA 402-2 §"Profile velocity mode"; Festo §7.5
// 000_33c1d912b8b6010a.txt L6731-6963): target velocity 60FFh (limited by 607Fh max profile
// velocity and 6080h max motor speed), ramped with 6083h (speeding up) and 6084h (slowing
// down) into 606Bh velocity demand; the axis follows it in velocity control.
//
// Halt (bit 8): the PDS ramps the axis to 0 (605Dh); releasing halt re-accelerates to 60FFh
// (Festo L5421).
// Statusword bits (OPERATION ENABLED):
//   10 target reached  |606Ch - 60FFh| <= 606Dh velocity window continuously for 606Eh ms
//                      (with halt: the target is 0)
//   12 speed           1 = speed 0: 0 once |606Ch| > 606Fh velocity threshold for longer than
//                      6070h ms, 1 again when it is back inside (Festo L6907, L6922)
//   13 max slippage    |606Bh - 606Ch| > 60F8h max slippage (INTEGER32 rw PDO, this mode's
//                      object; 0 = off, the default) while the drive follows: the axis cannot
//                      follow its demand (e.g. a load beyond the torque limit)
// Deviations: pv-target-reached-outside-window, pv-speed-zero-bit-never-set.
#pragma once

#include <optional>

#include "reference_drive/axis/trajectory.hpp"
#include "reference_drive/modes/operation_mode.hpp"

namespace drivecheck::reference_drive {

class ProfileVelocityMode final : public OperationMode {
 public:
  std::int8_t mode() const override { return 3; }
  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override;
  void on_reset(ModeContext& ctx) override;
  void enter(ModeContext& ctx, const ModeCycle& cycle) override;
  void cycle(ModeContext& ctx, const ModeCycle& cycle) override;
  std::uint16_t statusword_bits(cia402::State state) const override;

 private:
  TrajectoryGenerator ramp_;
  std::optional<can::TimePoint> in_window_since_;
  std::optional<can::TimePoint> above_threshold_since_;
  std::uint16_t bits_ = 0;
};

}  // namespace drivecheck::reference_drive
