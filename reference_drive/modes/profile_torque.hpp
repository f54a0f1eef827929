// Profile torque mode (6060h = 4; CiA 402-2 §"Profile torque mode"; Festo §7.7
// 000_33c1d912b8b6010a.txt L7027-7211): target torque 6071h (‰ of the rated torque), limited
// by 6072h max torque, ramped at 6087h torque slope (‰/s; 0: a step) into 6074h torque
// demand (6088h torque profile type: 0 linear; 1 sin² ramp as long as the linear one,
// demand = from + (to - from) × sin²(π/2 × t / T)); the axis runs in torque control (speed
// limited by 6080h); 6077h is the torque the motor gives.
//
// Halt (bit 8): the demand 6074h goes to 0 with the slope while the PDS stops the axis
// (605Dh); releasing halt ramps it back to 6071h (Festo L7036-7038).
// Statusword bit 10 target reached: the demand has reached 6071h (with halt: 0), the slope is
// done; bits 12, 13 reserved (0). 6074h is the mode's demand, 6077h the motor's torque.
// Deviations: tq-slope-ignored, tq-target-reached-never-set, tq-torque-profile-type-ignored.
#pragma once

#include <optional>

#include "reference_drive/modes/operation_mode.hpp"

namespace drivecheck::reference_drive {

class ProfileTorqueMode final : public OperationMode {
 public:
  std::int8_t mode() const override { return 4; }
  void on_reset(ModeContext& ctx) override;
  void enter(ModeContext& ctx, const ModeCycle& cycle) override;
  void cycle(ModeContext& ctx, const ModeCycle& cycle) override;
  std::uint16_t statusword_bits(cia402::State state) const override;

  double demand() const { return demand_; }  // ‰

 private:
  struct Segment {  // the sin² ramp under way (6088h = 1)
    double from = 0.0;
    double to = 0.0;
    double elapsed = 0.0;   // s
    double duration = 0.0;  // s
  };
  double demand_ = 0.0;
  std::optional<Segment> segment_;
  std::uint16_t bits_ = 0;
};

}  // namespace drivecheck::reference_drive
