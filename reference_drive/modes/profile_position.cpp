#include "reference_drive/modes/profile_position.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <span>

namespace drivecheck::reference_drive {
namespace {

constexpr std::uint16_t kNewSetPoint = 0x0010;
constexpr std::uint16_t kChangeImmediately = 0x0020;
constexpr std::uint16_t kRelative = 0x0040;
constexpr std::uint16_t kChangeOnSetPoint = 0x0200;

constexpr std::uint16_t kTargetReached = 0x0400;
constexpr std::uint16_t kSetPointAcknowledge = 0x1000;
constexpr std::uint16_t kFollowingError = 0x2000;

constexpr std::uint64_t kRelativeOption = 0x0003;  // 60F2h bits 1..0
constexpr std::uint64_t kRelativeToDemand = 0x0001;
constexpr std::uint64_t kRelativeToActual = 0x0002;
// 60F2h bits 5..4, request-response option: 00 the handshake of controlword bit 4 / statusword
// bit 12; 01 the drive resets bit 4 once the positioning has reached its target; 10 as soon as
// it can (at the acknowledge); 11 reserved.
constexpr std::uint64_t kRequestResponseOption = 0x0030;
constexpr std::uint64_t kReleaseAtTarget = 0x0010;
constexpr std::uint64_t kReleaseAtOnce = 0x0020;
constexpr std::uint64_t kRotaryOption = 0x00C0;  // 60F2h bits 7..6 (axis/position_range.hpp)

double seconds(can::Duration d) {
  return std::chrono::duration<double>(d).count();
}

}  // namespace

Expected<void, std::string> ProfilePositionMode::add_objects(cia301::ObjectDictionary& od) {
  if (od.find(cia402::kPositioningOptionCode.index, 0) == nullptr) {
    auto added = od.add_var(cia402::kPositioningOptionCode.index, "positioning option code",
                            cia301::DataType::unsigned16, cia301::AccessType::rw,
                            cia301::Value::of_unsigned(0), true);
    if (!added) return Unexpected(added.error());
  }
  if (cia301::Entry* e = od.find(cia402::kPositioningOptionCode.index, 0)) {
    const bool reserved_accepted =
        deviations_.has(Deviation::pp_positioning_option_reserved_accepted);
    const std::uint64_t implemented =
        kRelativeOption | kRequestResponseOption | (rotary_option_ ? kRotaryOption : 0);
    e->set_write_validator(
        [reserved_accepted, implemented](
            const cia301::ObjectDictionary&, const cia301::Entry&,
            std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
          const std::uint64_t v = cia301::load_unsigned(data);
          // Deviation pp-positioning-option-reserved-accepted: 11 in bits 1..0 and 5..4 taken.
          if (reserved_accepted && (v & ~implemented) == 0) return {};
          // The relative and request-response options are implemented, 11 is reserved in each;
          // the rotary axis direction option (bits 7..6, all four values) where the drive has
          // 607Bh and takes the direction from 60F2h; the change-immediately option (bits 3..2)
          // is not implemented, bits 8..15 are the ip option and reserved: every other bit must
          // be 0.
          if ((v & ~implemented) != 0 || (v & kRelativeOption) == kRelativeOption ||
              (v & kRequestResponseOption) == kRequestResponseOption) {
            return Unexpected(cia301::SdoAbort::invalid_value);
          }
          return {};
        });
  }
  return {};
}

void ProfilePositionMode::on_reset(ModeContext& ctx) {
  trajectory_.reset(ctx.axis.position());
  running_.reset();
  buffered_.clear();
  previous_bit4_ = false;
  ack_ = false;
  ack_due_ = false;
  ack_countdown_ = 0;
  reached_ = true;
  in_window_since_.reset();
  has_target_ = false;
  last_clamped_ = false;
  enabled_ = false;
  bits_ = 0;
}

void ProfilePositionMode::enter(ModeContext& ctx, const ModeCycle& cycle) {
  on_reset(ctx);
  // An edge already high when the mode starts is not a new set-point.
  previous_bit4_ = (cycle.controlword & kNewSetPoint) != 0;
}

std::optional<double> ProfilePositionMode::running_target() const {
  if (!running_) return std::nullopt;
  return running_->target;
}

std::optional<double> ProfilePositionMode::buffered_target() const {
  if (buffered_.empty()) return std::nullopt;
  return buffered_.front().target;
}

ProfilePositionMode::SetPoint ProfilePositionMode::read_set_point(ModeContext& ctx,
                                                                  std::uint16_t controlword,
                                                                  bool immediately) const {
  const FactorGroup& f = ctx.factors;
  SetPoint sp;
  const double target = static_cast<double>(ctx.read_signed(cia402::kTargetPosition));
  bool relative = false;
  if ((controlword & kRelative) != 0 && !ctx.has(Deviation::pp_relative_as_absolute)) {
    // Relative to the demand position 6062h (Festo L5407-5412), here in internal units; the
    // demand of the buffered set-point's start is the running one's target.
    // The base 60F2h bits 1..0 select (deviation pp-positioning-option-relative-ignored: always
    // the preceding target).
    const std::uint64_t option =
        ctx.has(Deviation::pp_positioning_option_relative_ignored)
            ? 0
            : ctx.read_unsigned(cia402::kPositioningOptionCode) & kRelativeOption;
    const double base = option == kRelativeToDemand   ? trajectory_.position()
                        : option == kRelativeToActual ? ctx.axis.position()
                        : !buffered_.empty()          ? buffered_.back().target
                        : running_                    ? running_->target
                                                      : trajectory_.position();
    // Deviation pp-software-limit-on-relative-distance: 607Dh applied to the distance 607Ah.
    const double distance = ctx.has(Deviation::pp_software_limit_on_relative_distance)
                                ? ctx.clamp_position(f.position_to_internal(target))
                                : f.position_to_internal(target);
    sp.target = base + distance - f.position_to_internal(0.0);
    relative = true;
  } else if (ctx.position_range.active()) {
    // A rotary axis: the target modulo the range, reached from where this set-point starts
    // (the preceding target of a set of set-points, else the demand) the way the rotary axis
    // direction option says.
    const double start = immediately          ? trajectory_.position()
                         : !buffered_.empty() ? buffered_.back().target
                         : running_           ? running_->target
                                              : trajectory_.position();
    RotaryDirection direction = ctx.rotary_direction.value_or(
        rotary_direction_of(ctx.read_unsigned(cia402::kPositioningOptionCode)));
    if (ctx.has(Deviation::pp_rotary_direction_ignored)) direction = RotaryDirection::linear;
    if (ctx.has(Deviation::pp_rotary_direction_swapped)) {
      if (direction == RotaryDirection::negative) {
        direction = RotaryDirection::positive;
      } else if (direction == RotaryDirection::positive) {
        direction = RotaryDirection::negative;
      }
    }
    if (ctx.has(Deviation::pp_rotary_linear_as_shortest) && direction == RotaryDirection::linear)
      direction = RotaryDirection::shortest;
    const double from = f.position_to_user(start);
    sp.target = f.position_to_internal(from + ctx.position_range.travel(from, target, direction));
  } else {
    sp.target = f.position_to_internal(target);
  }
  const bool was_limited = ctx.position_limited;
  ctx.position_limited = false;
  if (!relative || !ctx.has(Deviation::pp_software_limit_on_relative_distance)) {
    sp.target = ctx.clamp_position(sp.target);
  }
  sp.clamped = ctx.position_limited;
  ctx.position_limited = was_limited || sp.clamped;
  double velocity = static_cast<double>(ctx.read_unsigned(cia402::kProfileVelocity));
  const double max_velocity = static_cast<double>(ctx.read_unsigned(cia402::kMaxProfileVelocity));
  // Deviation pp-max-profile-velocity-ignored: 6081h above 607Fh is run as written.
  if (max_velocity > 0.0 && !ctx.has(Deviation::pp_max_profile_velocity_ignored)) {
    velocity = std::min(velocity, max_velocity);
  }
  sp.limits.velocity = std::min(f.speed_to_internal(velocity), ctx.axis.max_speed());
  sp.limits.acceleration = f.acceleration_to_internal(
      static_cast<double>(ctx.read_unsigned(cia402::kProfileAcceleration)));
  sp.limits.deceleration = f.acceleration_to_internal(
      static_cast<double>(ctx.read_unsigned(cia402::kProfileDeceleration)));
  sp.limits.end_velocity =
      f.speed_to_internal(static_cast<double>(ctx.read_unsigned(cia402::kEndVelocity)));
  sp.change_on_set_point = ctx.change_on_set_point && (controlword & kChangeOnSetPoint) != 0;
  return sp;
}

void ProfilePositionMode::cycle(ModeContext& ctx, const ModeCycle& cycle) {
  const bool bit4 = (cycle.controlword & kNewSetPoint) != 0;
  const bool edge = bit4 && !previous_bit4_;
  previous_bit4_ = bit4;
  const double dt = seconds(cycle.period);
  enabled_ = cycle.state == cia402::State::operation_enabled;

  if (!enabled_) {
    // Outside OPERATION ENABLED set-points are dropped and the demand tracks the axis.
    running_.reset();
    buffered_.clear();
    trajectory_.reset(ctx.axis.position());
    ctx.axis.command_position(ctx.axis.position());
  } else {
    if (edge && !ack_ && !ack_due_) {
      // Taken also while halted (it starts when halt is released).
      const bool immediately = (cycle.controlword & kChangeImmediately) != 0 &&
                               !ctx.has(Deviation::pp_change_immediately_ignored);
      const SetPoint sp = read_set_point(ctx, cycle.controlword, immediately);
      if (immediately || !running_) {
        running_ = sp;
        buffered_.clear();
      } else if (buffered_.size() < std::max<std::size_t>(1, ctx.setpoint_buffer)) {
        buffered_.push_back(sp);  // room: an edge while the buffer is full is not taken (ack_)
      } else {
        // Only with pp-set-point-ack-cleared-while-buffer-full: the buffered one is lost.
        buffered_.back() = sp;
      }
      last_target_ = running_->target;
      last_clamped_ = sp.clamped;
      has_target_ = true;
      reached_ = false;
      in_window_since_.reset();
      ack_due_ = true;
      ack_countdown_ = ctx.acknowledge_latency_cycles > 0 ? ctx.acknowledge_latency_cycles - 1 : 0;
    }
    if (!cycle.drive_enabled) {
      // Halt (or a stop ramp) holds the positioning: the PDS stops the axis, the demand tracks
      // it, and the positioning continues from there when halt is released.
      trajectory_.reset(ctx.axis.position(), ctx.axis.velocity());
      ctx.axis.command_position(ctx.axis.position());
    } else {
      trajectory_.set_smoothing(
          ctx.read_signed(cia402::kMotionProfileType) != 0 ? ctx.jerk_smoothing_cycles : 0);
      if (running_) {
        ProfileLimits limits = running_->limits;
        if (!buffered_.empty()) {
          limits.end_velocity = buffered_.front().change_on_set_point
                                    ? limits.velocity
                                    : running_->limits.end_velocity;
        } else {
          limits.end_velocity = 0.0;
        }
        trajectory_.move_to(running_->target, limits);
      }
      trajectory_.step(dt);
      if (running_ && trajectory_.profile_done() && !buffered_.empty()) {
        // Deviation pp-set-point-buffer-newest-first: the last set-point queued runs next.
        if (ctx.has(Deviation::pp_set_point_buffer_newest_first)) {
          running_ = buffered_.back();
          buffered_.pop_back();
        } else {
          running_ = buffered_.front();
          buffered_.pop_front();
        }
        last_target_ = running_->target;
        last_clamped_ = running_->clamped;
        reached_ = false;
        in_window_since_.reset();
        ProfileLimits limits = running_->limits;
        limits.end_velocity = 0.0;
        trajectory_.move_to(running_->target, limits);
      }
      ctx.axis.command_position(trajectory_.position(), trajectory_.velocity());
    }
  }

  // Set-point acknowledge (bit 12): shown for at least one cycle once it rises.
  const bool ack_shown = ack_;
  if (ack_due_) {
    if (ack_countdown_ == 0) {
      ack_ = true;
      ack_due_ = false;
    } else {
      --ack_countdown_;
    }
  }
  // The buffer has room once it holds fewer than setpoint_buffer (1: empty).
  // Deviation pp-set-point-ack-cleared-while-buffer-full: room or not.
  const bool room = buffered_.size() < std::max<std::size_t>(1, ctx.setpoint_buffer) ||
                    ctx.has(Deviation::pp_set_point_ack_cleared_while_buffer_full);
  if (ack_shown && !bit4 && room && !ctx.has(Deviation::pp_set_point_ack_never_cleared)) {
    ack_ = false;
  }

  update_target_reached(ctx, cycle);

  // 60F2h request-response option (deviation pp-request-response-option-ignored: always 00;
  // pp-request-response-release-early: 01 releases at the acknowledge, as 10 does).
  if (enabled_ && bit4 && ack_ && !ctx.has(Deviation::pp_request_response_option_ignored)) {
    const std::uint64_t option =
        ctx.read_unsigned(cia402::kPositioningOptionCode) & kRequestResponseOption;
    const bool at_once =
        option == kReleaseAtOnce ||
        (option == kReleaseAtTarget && ctx.has(Deviation::pp_request_response_release_early));
    const bool at_target = option == kReleaseAtTarget && reached_ && buffered_.empty();
    if (at_once || at_target) ctx.release_controlword_bits |= kNewSetPoint;
  }
  if (has_target_ && last_clamped_) ctx.position_limited = true;

  bits_ = 0;
  if (reached_) bits_ |= kTargetReached;
  if (ack_) bits_ |= kSetPointAcknowledge;
  if (ctx.following_error) bits_ |= kFollowingError;
}

void ProfilePositionMode::update_target_reached(ModeContext& ctx, const ModeCycle& cycle) {
  if (cycle.halt) {
    reached_ = ctx.axis.is_stopped() && !ctx.has(Deviation::pp_halt_target_reached_missing);
    in_window_since_.reset();
    return;
  }
  if (!has_target_ || !cycle.drive_enabled) {
    // No positioning yet (or not enabled): the axis is where it was told to be.
    if (!has_target_) reached_ = true;
    return;
  }
  const bool demand_there = !running_ || trajectory_.done();
  const double window = ctx.factors.distance_to_internal(
      static_cast<double>(ctx.read_unsigned(cia402::kPositionWindow)));
  // Deviation pp-target-reached-on-demand: the demand's arrival is taken for the axis's.
  // Deviation pp-position-window-signed: target - actual <= window, not |target - actual|.
  const double off = ctx.has(Deviation::pp_position_window_signed)
                         ? last_target_ - ctx.axis.position()
                         : std::abs(ctx.axis.position() - last_target_);
  const bool inside =
      demand_there && (ctx.has(Deviation::pp_target_reached_on_demand) || off <= window);
  if (!inside) {
    // Deviation pp-window-time-not-restarted: leaving the window keeps the time of the entry.
    if (!ctx.has(Deviation::pp_window_time_not_restarted)) in_window_since_.reset();
    reached_ = false;
    return;
  }
  if (!in_window_since_) in_window_since_ = cycle.now;
  const auto window_time =
      std::chrono::milliseconds(ctx.read_unsigned(cia402::kPositionWindowTime));
  reached_ = ctx.has(Deviation::pp_target_reached_before_window_time) ||
             cycle.now - *in_window_since_ >= window_time;
}

std::uint16_t ProfilePositionMode::statusword_bits(cia402::State state) const {
  if (state != cia402::State::operation_enabled) return 0;
  return bits_;
}

}  // namespace drivecheck::reference_drive
