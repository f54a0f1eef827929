#include "reference_drive/modes/cyclic_sync.hpp"

#include <algorithm>
#include <chrono>
#include <limits>

#include "reference_drive/modes/interpolated_position.hpp"

namespace drivecheck::reference_drive {
namespace {

constexpr std::uint16_t kFollows = 0x1000;
constexpr std::uint16_t kFollowingError = 0x2000;

}  // namespace

void CyclicSyncMode::on_reset(ModeContext& ctx) {
  start_ = end_ = ctx.axis.position();
  feed_forward_ = 0.0;
  command_ = 0.0;
  latched_at_.reset();
  last_sync_.reset();
  tracking_ = true;
  bits_ = 0;
  following_error_latched_ = false;
}

void CyclicSyncMode::enter(ModeContext& ctx, const ModeCycle& cycle) {
  (void)cycle;
  on_reset(ctx);
}

void CyclicSyncMode::latch(ModeContext& ctx, can::TimePoint at) {
  const FactorGroup& f = ctx.factors;
  switch (kind_) {
    case CyclicKind::position: {
      // Deviation csp-position-offset-ignored: 60B0h stored, not added.
      const double offset = ctx.has(Deviation::csp_position_offset_ignored)
                                ? 0.0
                                : static_cast<double>(ctx.read_signed(cia402::kPositionOffset));
      const double target = static_cast<double>(ctx.read_signed(cia402::kTargetPosition)) + offset;
      start_ = tracking_ ? ctx.axis.position() : ctx.axis.demand_position();
      // Deviation csp-software-limit-ignored: 607Dh not applied to the set-points.
      end_ = ctx.has(Deviation::csp_software_limit_ignored)
                 ? f.position_to_internal(target)
                 : ctx.clamp_position(f.position_to_internal(target));
      feed_forward_ =
          f.velocity_to_internal(static_cast<double>(ctx.read_signed(cia402::kVelocityOffset)));
      break;
    }
    case CyclicKind::velocity: {
      const double limit = ctx.axis.max_speed();
      // Deviation csv-velocity-offset-ignored: 60B1h stored, not added.
      const double offset = ctx.has(Deviation::csv_velocity_offset_ignored)
                                ? 0.0
                                : static_cast<double>(ctx.read_signed(cia402::kVelocityOffset));
      const double target = static_cast<double>(ctx.read_signed(cia402::kTargetVelocity)) + offset;
      command_ = std::clamp(f.velocity_to_internal(target), -limit, limit);
      break;
    }
    case CyclicKind::torque: {
      const double limit = ctx.axis.torque_limit();
      // Deviation cst-torque-offset-ignored: 60B2h stored, not added.
      const double offset = ctx.has(Deviation::cst_torque_offset_ignored)
                                ? 0.0
                                : static_cast<double>(ctx.read_signed(cia402::kTorqueOffset));
      const double target = static_cast<double>(ctx.read_signed(cia402::kTargetTorque)) + offset;
      // Deviation max-torque-positive-only: 6072h limits positive torques only.
      const double lowest = ctx.has(Deviation::max_torque_positive_only)
                                ? -std::numeric_limits<double>::infinity()
                                : -limit;
      command_ = std::clamp(target, lowest, limit);
      break;
    }
  }
  latched_at_ = at;
  tracking_ = false;
}

void CyclicSyncMode::on_sync(ModeContext& ctx, can::TimePoint at) {
  ++syncs_;
  last_sync_ = at;
  if (ctx.pds.state() == cia402::State::operation_enabled) latch(ctx, at);
}

void CyclicSyncMode::cycle(ModeContext& ctx, const ModeCycle& cycle) {
  const double period = interpolation_period_seconds(ctx.od).value_or(0.001);
  if (!cycle.drive_enabled) {
    tracking_ = true;
    start_ = end_ = ctx.axis.position();
    latched_at_.reset();
    switch (kind_) {
      case CyclicKind::position:
        ctx.axis.command_position(ctx.axis.position());
        break;
      case CyclicKind::velocity:
        ctx.axis.command_velocity(ctx.axis.velocity());
        break;
      case CyclicKind::torque:
        ctx.axis.command_torque(0.0);
        break;
    }
  } else {
    const bool sync_driven = last_sync_.has_value();
    if (!sync_driven || !latched_at_) latch(ctx, cycle.now);
    switch (kind_) {
      case CyclicKind::position: {
        double demand = end_;
        double velocity = feed_forward_;
        if (sync_driven && latched_at_) {
          const double t = std::chrono::duration<double>(cycle.now - *latched_at_).count();
          const double share = std::clamp(t / period, 0.0, 1.0);
          demand = start_ + (end_ - start_) * share;
          if (share < 1.0) velocity += (end_ - start_) / period;
        }
        ctx.axis.command_position(demand, velocity);
        break;
      }
      case CyclicKind::velocity:
        ctx.axis.command_velocity(command_);
        break;
      case CyclicKind::torque:
        ctx.axis.command_torque(command_);
        ctx.torque_demand = command_;
        break;
    }
  }
  bits_ = 0;
  // Deviations csp/csv/cst-follows-bit-never-set.
  const bool hidden =
      (kind_ == CyclicKind::position && ctx.has(Deviation::csp_follows_bit_never_set)) ||
      (kind_ == CyclicKind::velocity && ctx.has(Deviation::csv_follows_bit_never_set)) ||
      (kind_ == CyclicKind::torque && ctx.has(Deviation::cst_follows_bit_never_set));
  const bool follows = cycle.drive_enabled && !hidden;
  if (follows) bits_ |= kFollows;
  // Bit 13 (csp): set once the following error outlasted 6066h; it stays set through the fault
  // reaction that the drive takes on it (FAULT REACTION ACTIVE, FAULT) and clears when the
  // drive is enabled again without a following error. Deviation csp-following-error-bit-never-set:
  // the fault reaction is taken, the bit never shows.
  const bool shown =
      kind_ == CyclicKind::position && !ctx.has(Deviation::csp_following_error_bit_never_set);
  if (shown && ctx.following_error) {
    bits_ |= kFollowingError;
    following_error_latched_ = true;
  } else if (cycle.state != cia402::State::fault_reaction_active &&
             cycle.state != cia402::State::fault) {
    following_error_latched_ = false;
  }
}

std::uint16_t CyclicSyncMode::statusword_bits(cia402::State state) const {
  if ((state == cia402::State::fault_reaction_active || state == cia402::State::fault) &&
      following_error_latched_) {
    return kFollowingError;
  }
  if (state != cia402::State::operation_enabled) return 0;
  return bits_;
}

}  // namespace drivecheck::reference_drive
