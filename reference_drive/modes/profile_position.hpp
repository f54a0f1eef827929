// Profile position mode (6060h = 1; CiA 402-2 §"Profile position mode"; Festo §7.3
// 000_33c1d912b8b6010a.txt L6264-6445): target 607Ah, profile velocity 6081h (limited by 607Fh),
// end velocity 6082h, acceleration 6083h, deceleration 6084h, motion profile type 6086h; the
// trajectory generator (axis/trajectory.hpp) makes 6062h, the axis follows it.
//
// Controlword bits (OPERATION ENABLED):
//   4 new set-point   rising edge: take 607Ah (and the profile objects) as a new set-point
//   5 change set immediately  1: the running positioning is abandoned, the new one starts now;
//                      0: set of set-points: it is buffered (ModeContext::setpoint_buffer
//                      deep, 1 by default) and starts when the running one reaches its target
//   6 abs/rel         1: target = 6062h (the demand position, not 6064h) + 607Ah
//   8 halt            the PDS stops the axis (605Dh); the running and buffered set-points are
//                     kept (a new set-point is taken too) and releasing halt continues the
//                     positioning from where the axis stopped (IEC 61800-7-201 table, IRTSA
//                     Table 14 L340 "bit 8 = 0: positioning shall be executed or continued";
//                     Festo L5421 "deletion of the bit has no effect" is Festo's deviation)
//   9 change on set-point  with bit 5 = 0: 1 the running positioning ends at its target at the
//                     profile velocity and the buffered one follows without stopping; 0 it
//                     ends with 6082h end velocity (0: stops)
// Statusword bits:
//   12 set-point acknowledge  set acknowledge_latency_cycles after the bit 4 edge (1: in the
//                     cycle that saw the edge); cleared once bit 4 is 0 AND the buffer has room
//                     (Festo L6429-6433, L5557-5561). A bit 4 edge while bit 12 is still 1 (the
//                     buffer full) is ignored.
//   10 target reached  the demand has reached the target and |6064h - target| <= 6067h for
//                     6068h ms; cleared by a new set-point; with halt: 1 once the axis stands
//   13 following error  |60F4h| > 6065h for 6066h (the application's check)
//   6 with 60F2h     the base of a relative target (bits 1..0): 00 the preceding target (the
//                     buffered or running one; with none yet the demand position, where CiA
//                     402-2 says 0: the vectors give a preceding target first), 01 the demand
//                     position, 10 the actual position 6064h
//   4 with 60F2h bits 5..4 (request-response option): 01 the drive resets 6040h bit 4 when the
//                     last set-point's target is reached (bit 10), 10 when it acknowledges
//                     (bit 12); bit 12 then returns to 0 as after the master's reset
// Rotary axis (607Bh position range limit set, ModeContext::position_range active): an absolute
// target is taken modulo the range and reached the way 60F2h bits 7..6 choose
// (axis/position_range.hpp: 00 as on a linear axis, 01 only negative, 10 only positive, 11 the
// shortest way; ModeContext::rotary_direction instead where the personality has its own
// object); a relative target travels its 607Ah and may pass the limits. The trajectory runs in
// the unwrapped internal frame; the application shows 6062h and 6064h wrapped.
// Targets are clamped to the software position limits 607Dh (bit 11 while clamped; on a rotary
// axis in the unwrapped frame: the default full-range limits never clamp).
// Deviations: pp-set-point-ack-never-cleared, pp-target-reached-before-window-time,
// pp-change-immediately-ignored, pp-relative-as-absolute, pp-halt-target-reached-missing,
// pp-max-profile-velocity-ignored, pp-set-point-ack-cleared-while-buffer-full,
// pp-positioning-option-relative-ignored, pp-set-point-buffer-newest-first (a buffer deeper than
// one: the cia402-alternative personality's 4), pp-request-response-option-ignored,
// pp-request-response-release-early, pp-rotary-direction-ignored, pp-rotary-direction-swapped,
// pp-rotary-linear-as-shortest. (quick-stop-target-reached-missing is the PDS's:
// bit 10 in QUICK STOP ACTIVE, power_drive_system.cpp.)
#pragma once

#include <cstdint>
#include <deque>
#include <optional>

#include "reference_drive/axis/trajectory.hpp"
#include "reference_drive/modes/operation_mode.hpp"

namespace drivecheck::reference_drive {

class ProfilePositionMode final : public OperationMode {
 public:
  // `deviations`: the ones its object's check shows (60F2h's reserved values); the others are
  // read from the ModeContext at run time. `rotary_option`: 60F2h takes bits 7..6 (the drive
  // has 607Bh and takes the direction from 60F2h).
  explicit ProfilePositionMode(DeviationSet deviations = {}, bool rotary_option = false)
      : deviations_(deviations), rotary_option_(rotary_option) {}
  std::int8_t mode() const override { return 1; }
  // 60F2h positioning option code (optional in CiA 402-2): relative option bits 1..0 (00
  // relative to the preceding target, 01 to the position demand value, 10 to the position
  // actual value 6064h) and request-response option bits 5..4 (00 the bit 4 / bit 12
  // handshake; 01 the drive resets controlword bit 4 itself once the positioning reached its
  // target, 10 as soon as it acknowledged the set-point; then bit 12 follows); 11 is reserved
  // in each. The rotary axis direction option 7..6 (every value) with `rotary_option`. Every
  // other bit (change-immediately option 3..2, 7..6 without `rotary_option`, ip option and
  // reserved) must be 0: other values are refused with 06090030h.
  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override;
  void on_reset(ModeContext& ctx) override;
  void enter(ModeContext& ctx, const ModeCycle& cycle) override;
  void cycle(ModeContext& ctx, const ModeCycle& cycle) override;
  std::uint16_t statusword_bits(cia402::State state) const override;

  bool set_point_acknowledge() const { return ack_; }
  bool target_reached() const { return reached_; }
  std::optional<double> running_target() const;
  std::optional<double> buffered_target() const;

 private:
  struct SetPoint {
    double target = 0.0;  // internal, actual frame
    ProfileLimits limits;
    bool change_on_set_point = false;
    bool clamped = false;  // the target was clamped to 607Dh (bit 11 while it is the last one)
  };
  SetPoint read_set_point(ModeContext& ctx, std::uint16_t controlword, bool immediately) const;
  void update_target_reached(ModeContext& ctx, const ModeCycle& cycle);

  DeviationSet deviations_;
  bool rotary_option_ = false;
  TrajectoryGenerator trajectory_;
  std::optional<SetPoint> running_;
  std::deque<SetPoint> buffered_;  // ModeContext::setpoint_buffer deep (1: one)
  bool previous_bit4_ = false;
  bool ack_ = false;
  std::uint32_t ack_countdown_ = 0;  // cycles until bit 12 rises
  bool ack_due_ = false;
  bool reached_ = true;
  std::optional<can::TimePoint> in_window_since_;
  double last_target_ = 0.0;  // the target bit 10 compares with
  bool has_target_ = false;
  bool last_clamped_ = false;
  bool enabled_ = false;
  std::uint16_t bits_ = 0;
};

}  // namespace drivecheck::reference_drive
