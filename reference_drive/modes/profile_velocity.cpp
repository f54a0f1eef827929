#include "reference_drive/modes/profile_velocity.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

namespace drivecheck::reference_drive {
namespace {

constexpr std::uint16_t kTargetReached = 0x0400;
constexpr std::uint16_t kSpeedZero = 0x1000;
constexpr std::uint16_t kMaxSlippage = 0x2000;
constexpr std::uint16_t kMaxSlippageIndex = 0x60F8;

}  // namespace

Expected<void, std::string> ProfileVelocityMode::add_objects(cia301::ObjectDictionary& od) {
  auto added = od.add_var(kMaxSlippageIndex, "max slippage", cia301::DataType::integer32,
                          cia301::AccessType::rw, cia301::Value::of_signed(0), true);
  if (!added) return Unexpected(added.error());
  return {};
}

void ProfileVelocityMode::on_reset(ModeContext& ctx) {
  ramp_.reset(ctx.axis.position(), ctx.axis.velocity());
  in_window_since_.reset();
  above_threshold_since_.reset();
  bits_ = 0;
}

void ProfileVelocityMode::enter(ModeContext& ctx, const ModeCycle& cycle) {
  (void)cycle;
  on_reset(ctx);
}

void ProfileVelocityMode::cycle(ModeContext& ctx, const ModeCycle& cycle) {
  const FactorGroup& f = ctx.factors;
  const double dt = std::chrono::duration<double>(cycle.period).count();
  double limit = ctx.axis.max_speed();
  const double max_profile = static_cast<double>(ctx.read_unsigned(cia402::kMaxProfileVelocity));
  // Deviation pv-max-profile-velocity-replaces-max-motor-speed: 607Fh in place of 6080h.
  if (max_profile > 0.0) {
    limit = ctx.has(Deviation::pv_max_profile_velocity_replaces_max_motor_speed)
                ? f.speed_to_internal(max_profile)
                : std::min(limit, f.speed_to_internal(max_profile));
  }
  const double target_user = static_cast<double>(ctx.read_signed(cia402::kTargetVelocity));
  // Deviation pv-max-velocity-positive-only: the limit is applied to positive velocities only.
  const double lowest = ctx.has(Deviation::pv_max_velocity_positive_only)
                            ? -std::numeric_limits<double>::infinity()
                            : -limit;
  const double target = std::clamp(f.velocity_to_internal(target_user), lowest, limit);

  if (!cycle.drive_enabled) {
    ramp_.reset(ctx.axis.position(), ctx.axis.velocity());
    ctx.axis.command_velocity(ctx.axis.velocity());
  } else {
    ProfileLimits limits;
    limits.acceleration = f.acceleration_to_internal(
        static_cast<double>(ctx.read_unsigned(cia402::kProfileAcceleration)));
    limits.deceleration = f.acceleration_to_internal(
        static_cast<double>(ctx.read_unsigned(cia402::kProfileDeceleration)));
    ramp_.run_at(target, limits);
    ramp_.step(dt);
    ctx.axis.command_velocity(ramp_.velocity());
  }

  // Target reached: the actual velocity inside the window for the window time.
  const double wanted = cycle.halt ? 0.0 : target;
  const double window =
      f.speed_to_internal(static_cast<double>(ctx.read_unsigned(cia402::kVelocityWindow)));
  const double actual = ctx.axis.velocity();
  bool reached = false;
  if (std::abs(actual - wanted) <= window) {
    if (!in_window_since_) in_window_since_ = cycle.now;
    reached = cycle.now - *in_window_since_ >=
              std::chrono::milliseconds(ctx.read_unsigned(cia402::kVelocityWindowTime));
  } else {
    in_window_since_.reset();
  }
  if (ctx.has(Deviation::pv_target_reached_outside_window)) reached = true;
  if (cycle.halt && ctx.has(Deviation::pv_halt_target_reached_missing)) reached = false;

  // Speed = 0: cleared only after the threshold was exceeded for the threshold time.
  const double threshold =
      f.speed_to_internal(static_cast<double>(ctx.read_unsigned(cia402::kVelocityThreshold)));
  bool speed_zero = true;
  // Deviation pv-speed-zero-signed: 606Ch compared with 606Fh signed, not its magnitude.
  const double speed = ctx.has(Deviation::pv_speed_zero_signed) ? actual : std::abs(actual);
  if (speed > threshold) {
    if (!above_threshold_since_) above_threshold_since_ = cycle.now;
    speed_zero = cycle.now - *above_threshold_since_ <
                 std::chrono::milliseconds(ctx.read_unsigned(cia402::kVelocityThresholdTime));
  } else if (!ctx.has(Deviation::pv_speed_zero_timer_not_restarted)) {
    above_threshold_since_.reset();
  }
  if (ctx.has(Deviation::pv_speed_zero_bit_never_set)) speed_zero = false;

  // Max slippage: the actual velocity further from the demand than 60F8h.
  const double slippage =
      f.speed_to_internal(static_cast<double>(std::abs(ctx.read_signed({kMaxSlippageIndex, 0}))));
  const bool slipping =
      cycle.drive_enabled && slippage > 0.0 && std::abs(ramp_.velocity() - actual) > slippage;

  bits_ = 0;
  if (reached) bits_ |= kTargetReached;
  if (speed_zero) bits_ |= kSpeedZero;
  if (slipping) bits_ |= kMaxSlippage;
}

std::uint16_t ProfileVelocityMode::statusword_bits(cia402::State state) const {
  if (state != cia402::State::operation_enabled) return 0;
  return bits_;
}

}  // namespace drivecheck::reference_drive
