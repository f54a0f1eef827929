#include "reference_drive/modes/profile_torque.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace drivecheck::reference_drive {

void ProfileTorqueMode::on_reset(ModeContext& ctx) {
  (void)ctx;
  demand_ = 0.0;
  bits_ = 0;
}

void ProfileTorqueMode::enter(ModeContext& ctx, const ModeCycle& cycle) {
  (void)cycle;
  on_reset(ctx);
}

void ProfileTorqueMode::cycle(ModeContext& ctx, const ModeCycle& cycle) {
  const double dt = std::chrono::duration<double>(cycle.period).count();
  const double limit = ctx.axis.torque_limit();
  const double target =
      std::clamp(static_cast<double>(ctx.read_signed(cia402::kTargetTorque)), -limit, limit);
  if (!cycle.drive_enabled && !cycle.halt) {
    demand_ = 0.0;
    ctx.axis.command_torque(0.0);
    ctx.torque_demand = demand_;
    bits_ = 0;
    return;
  }
  // Halt: the demand goes to 0 with the slope (the PDS stops the axis per 605Dh meanwhile);
  // releasing it ramps back to 6071h (Festo L7036-7038).
  const double wanted = cycle.halt ? 0.0 : target;
  const double slope = static_cast<double>(ctx.read_unsigned(cia402::kTorqueSlope));
  if (slope <= 0.0 || ctx.has(Deviation::tq_slope_ignored)) {
    demand_ = wanted;
  } else {
    const double step = slope * dt;
    demand_ =
        std::abs(wanted - demand_) <= step ? wanted : demand_ + (wanted > demand_ ? step : -step);
  }
  ctx.axis.command_torque(demand_);
  ctx.torque_demand = demand_;
  bits_ = 0;
  if (demand_ == wanted && !ctx.has(Deviation::tq_target_reached_never_set)) bits_ |= 0x0400;
}

std::uint16_t ProfileTorqueMode::statusword_bits(cia402::State state) const {
  if (state != cia402::State::operation_enabled) return 0;
  return bits_;
}

}  // namespace drivecheck::reference_drive
