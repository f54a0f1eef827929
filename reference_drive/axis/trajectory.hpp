// The trajectory generator of the profile modes (the "curve generator" between 607Ah and 6062h,
// Festo L6266-6275): one demand position and velocity, moved on one drive cycle at a time, in
// internal units (increments, increments/s, increments/s²).
//
// Positioning (move_to): a trapezoidal profile from the current demand (position, velocity) to
// the target with the limits given (profile velocity, acceleration, deceleration) arriving with
// the end velocity (6082h; 0 = stop at the target). The braking velocity is the exact one of
// the discrete-time motion (p += v·dt each cycle): at every cycle the generator runs at the
// highest velocity from which it can still stop (or reach the end velocity) at the target, so
// the demand lands on the target exactly, with no overshoot, whatever the cycle. A target behind
// a moving demand is reached by braking first and turning back.
//
// Velocity (run_at): ramp the demand velocity to a target velocity with the acceleration (when
// the speed grows) or the deceleration (when it shrinks); the position integrates it.
//
// Jerk limitation (6086h motion profile type ≠ 0: 1 sin² ramp, 2 jerk-free, 3 jerk-limited): the
// trapezoid is smoothed by a moving average over `smoothing` cycles, which limits the jerk to
// acceleration / (smoothing · cycle) and ends on the same target (later by smoothing/2 cycles).
// All three types get this one S-curve (a documented simplification).
#pragma once

#include <cstddef>
#include <vector>

namespace drivecheck::reference_drive {

struct ProfileLimits {
  double velocity = 0.0;  // > 0
  double acceleration = 0.0;
  double deceleration = 0.0;
  double end_velocity = 0.0;  // |velocity| at the target (positioning only)
};

class TrajectoryGenerator {
 public:
  // Demand := (position, velocity), no motion planned, smoothing history cleared.
  void reset(double position, double velocity = 0.0);
  // Plans a positioning to `target`.
  void move_to(double target, const ProfileLimits& limits);
  // Plans a velocity ramp (acceleration/deceleration from `limits`; velocity ignored).
  void run_at(double velocity, const ProfileLimits& limits);
  // Decelerates to standstill with `deceleration` and holds there (halt, quick stop).
  void stop(double deceleration);
  // Moving-average length in cycles for the S-curve (0 or 1: trapezoid).
  void set_smoothing(std::size_t cycles);

  // One cycle of `dt` seconds.
  void step(double dt);

  double position() const { return out_position_; }
  double velocity() const { return out_velocity_; }
  double target() const { return target_; }
  // The unsmoothed profile has reached the target (or its velocity, or standstill).
  bool profile_done() const { return done_; }
  // ... and the smoothed output has settled there too.
  bool done() const;

 private:
  enum class Kind { idle, position, velocity, stop };
  double braking_velocity(double distance, double decel, double end, double dt) const;

  Kind kind_ = Kind::idle;
  ProfileLimits limits_;
  double target_ = 0.0;
  double target_velocity_ = 0.0;
  double position_ = 0.0;  // unsmoothed profile
  double velocity_ = 0.0;
  bool done_ = true;
  // Smoothing.
  std::size_t smoothing_ = 0;
  std::vector<double> history_;
  std::size_t head_ = 0;
  double sum_ = 0.0;
  double out_position_ = 0.0;
  double out_velocity_ = 0.0;
};

}  // namespace drivecheck::reference_drive
