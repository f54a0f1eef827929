#include "reference_drive/modes/manual_profile_position.hpp"

#include <algorithm>
#include <chrono>

namespace drivecheck::reference_drive {
namespace {

constexpr std::uint16_t kPositiveDirection = 0x0020;
constexpr std::uint16_t kNegativeDirection = 0x0040;
constexpr std::uint16_t kFollowingError = 0x2000;

// The direction after this cycle's bits: the one in force keeps going while its bit is set;
// released, the other bit (if set) takes over; from standstill bit 5 comes first.
int next_direction(int direction, bool positive, bool negative) {
  if (direction > 0 && positive) return 1;
  if (direction < 0 && negative) return -1;
  if (positive && (direction == 0 || !negative)) return 1;
  if (negative) return -1;
  return 0;
}

}  // namespace

void ManualProfilePositionMode::on_reset(ModeContext& ctx) {
  trajectory_.reset(ctx.axis.position());
  direction_ = 0;
  bits_ = 0;
}

void ManualProfilePositionMode::enter(ModeContext& ctx, const ModeCycle& cycle) {
  (void)cycle;
  on_reset(ctx);
}

void ManualProfilePositionMode::cycle(ModeContext& ctx, const ModeCycle& cycle) {
  const bool enabled = cycle.state == cia402::State::operation_enabled;
  bits_ = 0;
  if (!enabled || !cycle.drive_enabled) {
    // Not enabled, halted or stopping: the PDS has the axis, the demand tracks it; a jog
    // starts again from here once the drive follows (the bits are levels, not edges).
    direction_ = enabled ? direction_ : 0;
    trajectory_.reset(ctx.axis.position(), ctx.axis.velocity());
    ctx.axis.command_position(ctx.axis.position());
    if (enabled && ctx.following_error) bits_ |= kFollowingError;
    return;
  }

  const FactorGroup& f = ctx.factors;
  double velocity = static_cast<double>(ctx.read_unsigned(cia402::kProfileVelocity));
  const double max_velocity = static_cast<double>(ctx.read_unsigned(cia402::kMaxProfileVelocity));
  if (max_velocity > 0.0) velocity = std::min(velocity, max_velocity);
  ProfileLimits limits;
  limits.velocity = std::min(f.speed_to_internal(velocity), ctx.axis.max_speed());
  limits.acceleration = f.acceleration_to_internal(
      static_cast<double>(ctx.read_unsigned(cia402::kProfileAcceleration)));
  limits.deceleration = f.acceleration_to_internal(
      static_cast<double>(ctx.read_unsigned(cia402::kProfileDeceleration)));

  direction_ = next_direction(direction_, (cycle.controlword & kPositiveDirection) != 0,
                              (cycle.controlword & kNegativeDirection) != 0);
  trajectory_.set_smoothing(
      ctx.read_signed(cia402::kMotionProfileType) != 0 ? ctx.jerk_smoothing_cycles : 0);
  const bool bounded = ctx.min_position <= ctx.max_position;
  const double end = direction_ > 0 ? ctx.max_position : ctx.min_position;
  // At or beyond the software limit in the jog's direction: no further (and never back).
  const bool at_limit =
      bounded && direction_ != 0 &&
      (direction_ > 0 ? trajectory_.position() >= end : trajectory_.position() <= end);
  if (direction_ == 0 || at_limit) {
    trajectory_.stop(limits.deceleration);
  } else if (bounded) {
    // Toward the software limit as a positioning: it brakes in time and stands there.
    trajectory_.move_to(end, limits);
  } else {
    trajectory_.run_at(direction_ * limits.velocity, limits);
  }
  trajectory_.step(std::chrono::duration<double>(cycle.period).count());
  ctx.axis.command_position(trajectory_.position());
  if (at_limit || (bounded && direction_ != 0 && trajectory_.profile_done())) {
    ctx.position_limited = true;
  }
  if (ctx.following_error) bits_ |= kFollowingError;
}

std::uint16_t ManualProfilePositionMode::statusword_bits(cia402::State state) const {
  return state == cia402::State::operation_enabled ? bits_ : 0;
}

}  // namespace drivecheck::reference_drive
