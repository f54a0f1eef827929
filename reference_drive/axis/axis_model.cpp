#include "reference_drive/axis/axis_model.hpp"

#include <algorithm>
#include <cmath>

namespace drivecheck::reference_drive {
namespace {

constexpr double kStandstill = 1e-6;       // increments/s: below this the axis is at rest
constexpr double kMaxStepSeconds = 0.001;  // integration step limit (stability of the loops)

double sign(double v) {
  return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
}

std::size_t index_of(AxisSwitch which) {
  return static_cast<std::size_t>(which);
}

}  // namespace

AxisModel::AxisModel(AxisConfig config)
    : config_(config), torque_limit_(config.torque_limit), max_speed_(config.max_speed) {
  // A model without inertia or gain would divide by zero: fall back to the defaults.
  if (!(config_.rated_acceleration > 0.0))
    config_.rated_acceleration = AxisConfig{}.rated_acceleration;
  if (!(config_.position_gain > 0.0)) config_.position_gain = AxisConfig{}.position_gain;
}

// ---------------------------------------------------------------------------------------------
// The PDS's commands

void AxisModel::disable_power() {
  ++commands_;
  torque_ = 0.0;  // the power stage is off from now: 6077h shows no torque
  control_ = AxisControl::free;
  following_ = false;
  holding_ = false;
}

void AxisModel::follow_set_points() {
  ++commands_;
  following_ = true;
  holding_ = false;
  control_ = mode_control_;
  if (control_ == AxisControl::position) {
    // The demand starts where the axis is unless the mode already set one this cycle.
    demand_ = position();
  }
}

void AxisModel::ramp_to_stop(std::uint32_t deceleration) {
  ++commands_;
  stop_with(static_cast<double>(deceleration) * acceleration_factor_);
}

void AxisModel::stop_at_current_limit() {
  ++commands_;
  stop_with(torque_limit_ / 1000.0 * config_.rated_acceleration);
}

void AxisModel::stop_at_voltage_limit() {
  ++commands_;
  stop_with(config_.voltage_limit_deceleration);
}

void AxisModel::stop_with(double deceleration) {
  following_ = false;
  control_ = AxisControl::stopping;
  stop_decel_ = deceleration;
  holding_ = std::abs(velocity_) < kStandstill;
  hold_at_ = position();
}

bool AxisModel::is_stopped() const {
  return std::abs(velocity_) < kStandstill;
}

// ---------------------------------------------------------------------------------------------
// Set-points

void AxisModel::command_position(double demand, double velocity_feed_forward) {
  mode_control_ = AxisControl::position;
  demand_ = demand;
  feed_forward_ = velocity_feed_forward;
  if (following_) control_ = AxisControl::position;
}

void AxisModel::command_velocity(double velocity, double acceleration) {
  mode_control_ = AxisControl::velocity;
  velocity_ref_ = velocity;
  velocity_accel_ = acceleration;
  if (following_) control_ = AxisControl::velocity;
}

void AxisModel::command_torque(double torque) {
  mode_control_ = AxisControl::torque;
  torque_ref_ = torque;
  if (following_) control_ = AxisControl::torque;
}

double AxisModel::demand_velocity() const {
  return last_velocity_ref_;
}

double AxisModel::following_error() const {
  if (control_ != AxisControl::position || !following_) return 0.0;
  return demand_ - position();
}

// ---------------------------------------------------------------------------------------------
// Motion

void AxisModel::advance(can::Duration dt) {
  index_crossed_.reset();
  double left = std::chrono::duration<double>(dt).count();
  while (left > 0.0) {
    const double chunk = std::min(left, kMaxStepSeconds);
    step(chunk);
    left -= chunk;
  }
}

void AxisModel::step(double dt) {
  const double per_mille = config_.rated_acceleration / 1000.0;  // increments/s² per ‰
  const double friction = config_.friction_torque * per_mille;
  const double load = load_ * per_mille;
  const double limit = torque_limit_ * per_mille;
  const double v0 = velocity_;

  // The acceleration the controller wants (nullopt: a torque is commanded directly).
  double wanted = 0.0;
  bool motor_on = true;
  bool torque_direct = false;
  double v_ref = 0.0;
  switch (control_) {
    case AxisControl::free:
      motor_on = false;
      break;
    case AxisControl::position:
      v_ref = feed_forward_ + config_.position_gain * (demand_ - position());
      wanted = (v_ref - v0) / dt;
      break;
    case AxisControl::velocity: {
      // The ramp generator runs on its own (from the velocity the axis had when velocity
      // control began); the controller follows the ramp as far as the torque allows, so a
      // blocked axis (end stop, overload) drives the torque to its limit.
      if (velocity_accel_ > 0.0) {
        const double step_accel = velocity_accel_ * dt;
        ramp_velocity_ += std::clamp(velocity_ref_ - ramp_velocity_, -step_accel, step_accel);
      } else {
        ramp_velocity_ = velocity_ref_;
      }
      v_ref = ramp_velocity_;
      wanted = (v_ref - v0) / dt;
      break;
    }
    case AxisControl::torque:
      torque_direct = true;
      break;
    case AxisControl::stopping:
      if (holding_) {
        v_ref = config_.position_gain * (hold_at_ - position());
        wanted = (v_ref - v0) / dt;
      } else {
        v_ref = 0.0;
        const double step_decel = stop_decel_ * dt;
        wanted = std::abs(v0) <= step_decel ? -v0 / dt : -sign(v0) * stop_decel_;
      }
      break;
  }
  last_velocity_ref_ = v_ref;

  // Motor torque (as an acceleration), limited; friction and load oppose it.
  double motor = 0.0;
  if (motor_on) {
    if (torque_direct) {
      motor = torque_ref_ * per_mille;
    } else {
      // The torque that gives `wanted` against load and friction (ideal compensation).
      const double moving = v0 != 0.0 ? sign(v0) : sign(wanted);
      motor = wanted + load + friction * moving;
    }
    motor = std::clamp(motor, -limit, limit);
  }
  const double drive = motor - load;  // what moves the axis before friction
  double accel = 0.0;
  double v1 = 0.0;
  if (std::abs(v0) < kStandstill && std::abs(drive) <= friction) {
    accel = 0.0;  // static friction holds
    v1 = 0.0;
  } else {
    const double direction = std::abs(v0) >= kStandstill ? sign(v0) : sign(drive);
    accel = drive - friction * direction;
    v1 = v0 + accel * dt;
    // Friction stops the axis, it never reverses it.
    if (std::abs(v0) >= kStandstill && sign(v1) != sign(v0) && std::abs(drive) <= friction) {
      v1 = 0.0;
    }
  }
  v1 = std::clamp(v1, -max_speed_, max_speed_);
  if (!motor_on || control_ == AxisControl::stopping) {
    if (std::abs(v1) < kStandstill) v1 = 0.0;
  }
  accel = (v1 - v0) / dt;
  torque_ = motor / per_mille;
  accel_ = accel;

  const double p0 = physical_;
  physical_ += (v0 + v1) / 2.0 * dt;
  // Mechanical end stops: the axis stops dead there (or stays where it was when it was put
  // beyond one), the motor torque stays what the controller asked for (up to the limit).
  const SwitchLayout& layout = config_.switches;
  if (layout.stop_negative && physical_ < p0 &&
      physical_ < static_cast<double>(*layout.stop_negative)) {
    physical_ = std::min(p0, static_cast<double>(*layout.stop_negative));
    v1 = 0.0;
    accel_ = (v1 - v0) / dt;
  }
  if (layout.stop_positive && physical_ > p0 &&
      physical_ > static_cast<double>(*layout.stop_positive)) {
    physical_ = std::max(p0, static_cast<double>(*layout.stop_positive));
    v1 = 0.0;
    accel_ = (v1 - v0) / dt;
  }
  velocity_ = v1;
  if (control_ != AxisControl::velocity) ramp_velocity_ = v1;  // velocity control starts here

  if (control_ == AxisControl::stopping && !holding_ && v1 == 0.0) {
    holding_ = true;
    hold_at_ = position();
  }

  // Index pulses crossed between p0 and physical_.
  const double period = config_.index_period != 0 ? static_cast<double>(config_.index_period)
                                                  : static_cast<double>(config_.encoder_increments);
  if (period > 0.0 && p0 != physical_) {
    const double origin = static_cast<double>(config_.index_offset);
    if (physical_ > p0) {
      const double k = std::floor((p0 - origin) / period) + 1.0;  // first pulse above p0
      const double at = origin + k * period;
      if (at <= physical_) index_crossed_ = at + offset_;
    } else {
      const double k = std::ceil((p0 - origin) / period) - 1.0;  // first pulse below p0
      const double at = origin + k * period;
      if (at >= physical_) index_crossed_ = at + offset_;
    }
  }
}

bool AxisModel::at_end_stop() const {
  const SwitchLayout& layout = config_.switches;
  return (layout.stop_negative && physical_ <= static_cast<double>(*layout.stop_negative)) ||
         (layout.stop_positive && physical_ >= static_cast<double>(*layout.stop_positive));
}

std::int64_t AxisModel::actual_position() const {
  return static_cast<std::int64_t>(std::floor(position() + 1e-9));
}

// ---------------------------------------------------------------------------------------------
// Homing, switches, simulation

void AxisModel::set_actual_position(double position) {
  const double shift = position - this->position();
  offset_ += shift;
  demand_ += shift;
  hold_at_ += shift;
}

bool AxisModel::switch_active(AxisSwitch which) const {
  switch (forces_[index_of(which)]) {
    case SwitchForce::on:
      return true;
    case SwitchForce::off:
      return false;
    case SwitchForce::layout:
      break;
  }
  const SwitchLayout& layout = config_.switches;
  const double p = physical_;
  switch (which) {
    case AxisSwitch::negative_limit:
      return layout.negative_limit && p <= static_cast<double>(*layout.negative_limit);
    case AxisSwitch::positive_limit:
      return layout.positive_limit && p >= static_cast<double>(*layout.positive_limit);
    case AxisSwitch::home:
      if (!layout.home_present()) return false;
      if (layout.home_from && p < static_cast<double>(*layout.home_from)) return false;
      if (layout.home_to && p > static_cast<double>(*layout.home_to)) return false;
      return true;
  }
  return false;
}

void AxisModel::force_switch(AxisSwitch which, SwitchForce force) {
  forces_[index_of(which)] = force;
}

SwitchForce AxisModel::switch_force(AxisSwitch which) const {
  return forces_[index_of(which)];
}

void AxisModel::place(double physical_position) {
  const double shift = physical_position - physical_;
  physical_ = physical_position;
  velocity_ = 0.0;
  ramp_velocity_ = 0.0;
  accel_ = 0.0;
  demand_ += shift;
  hold_at_ += shift;
}

}  // namespace drivecheck::reference_drive
