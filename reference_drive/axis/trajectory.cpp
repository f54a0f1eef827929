#include "reference_drive/axis/trajectory.hpp"

#include <algorithm>
#include <cmath>

namespace drivecheck::reference_drive {
namespace {

constexpr double kArrived = 1e-9;

double sign(double v) {
  return v > 0.0 ? 1.0 : (v < 0.0 ? -1.0 : 0.0);
}

}  // namespace

void TrajectoryGenerator::reset(double position, double velocity) {
  kind_ = Kind::idle;
  position_ = position;
  velocity_ = velocity;
  target_ = position;
  done_ = true;
  std::fill(history_.begin(), history_.end(), position);
  sum_ = position * static_cast<double>(history_.size());
  head_ = 0;
  out_position_ = position;
  out_velocity_ = velocity;
}

void TrajectoryGenerator::move_to(double target, const ProfileLimits& limits) {
  const bool same = (kind_ == Kind::position || kind_ == Kind::idle) && target == target_;
  limits_ = limits;
  if (same && done_) return;  // already there
  kind_ = Kind::position;
  target_ = target;
  done_ = false;
}

void TrajectoryGenerator::run_at(double velocity, const ProfileLimits& limits) {
  kind_ = Kind::velocity;
  limits_ = limits;
  target_velocity_ = velocity;
  done_ = false;
}

void TrajectoryGenerator::stop(double deceleration) {
  kind_ = Kind::stop;
  limits_.deceleration = deceleration;
  target_velocity_ = 0.0;
  done_ = velocity_ == 0.0;
}

void TrajectoryGenerator::set_smoothing(std::size_t cycles) {
  const std::size_t size = cycles <= 1 ? 0 : cycles;
  if (size == smoothing_) return;
  smoothing_ = size;
  history_.assign(size, out_position_);
  sum_ = out_position_ * static_cast<double>(size);
  head_ = 0;
}

bool TrajectoryGenerator::done() const {
  if (!done_) return false;
  return smoothing_ == 0 || std::abs(out_position_ - position_) < 1e-6;
}

// The highest speed at which a cycle can start so that braking with `decel` every further
// cycle (p += v·dt, v -= decel·dt) covers exactly `distance` down to speed `end`.
double TrajectoryGenerator::braking_velocity(double distance, double decel, double end,
                                             double dt) const {
  if (decel <= 0.0) return limits_.velocity;
  const double step = decel * dt;
  const double n = std::sqrt(0.25 + 2.0 * distance / (step * dt)) - 0.5;
  const double v = step * n;
  return end > 0.0 ? std::sqrt(v * v + end * end) : v;
}

void TrajectoryGenerator::step(double dt) {
  if (dt <= 0.0) return;
  const double accel = limits_.acceleration > 0.0 ? limits_.acceleration : 1e18;
  const double decel = limits_.deceleration > 0.0 ? limits_.deceleration : 1e18;
  switch (kind_) {
    case Kind::idle:
      velocity_ = 0.0;
      break;
    case Kind::position: {
      if (done_) break;
      const double s = target_ - position_;
      const double dir = s != 0.0 ? sign(s) : sign(velocity_);
      const double end = std::min(limits_.end_velocity, limits_.velocity);
      if (std::abs(s) <= kArrived && std::abs(std::abs(velocity_) - end) <= kArrived) {
        position_ = target_;
        done_ = true;
        if (end == 0.0) kind_ = Kind::idle;
        break;
      }
      const double allowed =
          std::min(limits_.velocity, braking_velocity(std::abs(s), decel, end, dt));
      const double v = velocity_ * dir;  // speed toward the target (negative: away)
      double next = 0.0;
      if (v < 0.0) {
        next = std::min(v + decel * dt, allowed);
      } else if (allowed > v) {
        next = std::min(v + accel * dt, allowed);
      } else {
        next = std::max(v - decel * dt, allowed);
      }
      if (next > 0.0 && next * dt >= std::abs(s) - kArrived) {
        // Arrives this cycle.
        position_ = target_;
        velocity_ = dir * end;
        done_ = true;
        if (end == 0.0) kind_ = Kind::idle;
        break;
      }
      velocity_ = dir * next;
      position_ += velocity_ * dt;
      break;
    }
    case Kind::velocity:
    case Kind::stop: {
      const double target = target_velocity_;
      double next = velocity_;
      const bool speeding_up = std::abs(target) > std::abs(velocity_) &&
                               (sign(target) == sign(velocity_) || velocity_ == 0.0);
      const double rate = speeding_up ? accel : decel;
      if (std::abs(target - velocity_) <= rate * dt) {
        next = target;
      } else {
        next = velocity_ + sign(target - velocity_) * rate * dt;
      }
      velocity_ = next;
      position_ += velocity_ * dt;
      done_ = velocity_ == target;
      if (kind_ == Kind::stop && done_) {
        kind_ = Kind::idle;
        target_ = position_;
      }
      break;
    }
  }
  // Smoothing (moving average of the profile's positions).
  const double before = out_position_;
  if (smoothing_ == 0) {
    out_position_ = position_;
  } else {
    sum_ += position_ - history_[head_];
    history_[head_] = position_;
    head_ = (head_ + 1) % smoothing_;
    out_position_ = sum_ / static_cast<double>(smoothing_);
  }
  out_velocity_ = (out_position_ - before) / dt;
  if (smoothing_ == 0) out_velocity_ = velocity_;
}

}  // namespace drivecheck::reference_drive
