#include "reference_drive/modes/profile_torque.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numbers>

namespace drivecheck::reference_drive {

void ProfileTorqueMode::on_reset(ModeContext& ctx) {
  (void)ctx;
  demand_ = 0.0;
  bits_ = 0;
  segment_.reset();
}

void ProfileTorqueMode::enter(ModeContext& ctx, const ModeCycle& cycle) {
  (void)cycle;
  on_reset(ctx);
}

void ProfileTorqueMode::cycle(ModeContext& ctx, const ModeCycle& cycle) {
  const double dt = std::chrono::duration<double>(cycle.period).count();
  const double limit = ctx.axis.torque_limit();
  // Deviation max-torque-positive-only: 6072h limits positive torques only.
  const double lowest = ctx.has(Deviation::max_torque_positive_only)
                            ? -std::numeric_limits<double>::infinity()
                            : -limit;
  const double target =
      std::clamp(static_cast<double>(ctx.read_signed(cia402::kTargetTorque)), lowest, limit);
  if (!cycle.drive_enabled && !cycle.halt) {
    demand_ = 0.0;
    segment_.reset();
    ctx.axis.command_torque(0.0);
    ctx.torque_demand = demand_;
    bits_ = 0;
    return;
  }
  // Halt: the demand goes to 0 with the slope (the PDS stops the axis per 605Dh meanwhile);
  // releasing it ramps back to 6071h (Festo L7036-7038).
  const double wanted = cycle.halt ? 0.0 : target;
  const double slope = static_cast<double>(ctx.read_unsigned(cia402::kTorqueSlope));
  // 6088h = 1: sin² ramp. Deviation tq-torque-profile-type-ignored: 1 is taken, the ramp stays
  // linear.
  const bool sin2 = ctx.read_signed(cia402::kTorqueProfileType) == 1 &&
                    !ctx.has(Deviation::tq_torque_profile_type_ignored);
  if (slope <= 0.0 || ctx.has(Deviation::tq_slope_ignored)) {
    demand_ = wanted;
    segment_.reset();
  } else if (sin2) {
    // A new target starts a segment from the demand where it stands; it lasts as long as the
    // linear ramp would (|delta| / 6087h) and follows sin² of the elapsed share.
    if (!segment_ || segment_->to != wanted) {
      segment_ = Segment{demand_, wanted, 0.0, std::abs(wanted - demand_) / slope};
    }
    segment_->elapsed += dt;
    const double share =
        segment_->duration > 0.0 ? std::min(1.0, segment_->elapsed / segment_->duration) : 1.0;
    const double s = std::sin(share * std::numbers::pi / 2.0);
    demand_ = share >= 1.0 ? wanted : segment_->from + (segment_->to - segment_->from) * s * s;
  } else {
    segment_.reset();
    const double step = slope * dt;
    demand_ =
        std::abs(wanted - demand_) <= step ? wanted : demand_ + (wanted > demand_ ? step : -step);
  }
  ctx.axis.command_torque(demand_);
  ctx.torque_demand = demand_;
  bits_ = 0;
  // Deviation tq-halt-target-reached-missing: with halt the demand is still compared with 6071h.
  const double goal =
      cycle.halt && ctx.has(Deviation::tq_halt_target_reached_missing) ? target : wanted;
  if (demand_ == goal && !ctx.has(Deviation::tq_target_reached_never_set)) bits_ |= 0x0400;
}

std::uint16_t ProfileTorqueMode::statusword_bits(cia402::State state) const {
  if (state != cia402::State::operation_enabled) return 0;
  return bits_;
}

}  // namespace drivecheck::reference_drive
