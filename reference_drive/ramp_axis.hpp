// A first-order velocity model of one axis, enough for the power drive system's reactions
// (power_drive_system.hpp Axis): the velocity moves toward a target at a constant rate, the
// position integrates the velocity. Not the axis simulation of the profile modes (that comes
// with them); what it models is exactly this:
//
//   motion      velocity target    rate (user units/s²)
//   free        0                  coast_deceleration (friction; 0: runs on forever)
//   following   the set-point      acceleration (0: the velocity jumps to the set-point)
//   stopping    0                  the stop's deceleration (ramp_to_stop), or the current /
//                                  voltage limit deceleration; holds 0 once reached
//
// Arithmetic is exact: the velocity is kept in 10⁻⁹ units/s, and one advance(dt) changes it by
// rate × dt[ns], so v0 = 1000 units/s at 10000 units/s² is at 0 after exactly 100 ms, whatever
// the step size. is_stopped() means velocity exactly 0.
#pragma once

#include <cstdint>

#include "protocol/can/bus.hpp"
#include "reference_drive/power_drive_system.hpp"

namespace drivecheck::reference_drive {

struct RampAxisConfig {
  std::uint32_t acceleration = 0;           // following; 0: immediate
  std::uint32_t coast_deceleration = 1000;  // drive function off (friction)
  std::uint32_t current_limit_deceleration = 200000;
  std::uint32_t voltage_limit_deceleration = 25000;
};

enum class AxisMotion : std::uint8_t { free, following, stopping };

class RampAxis final : public Axis {
 public:
  explicit RampAxis(RampAxisConfig config = {}) : config_(config) {}

  void disable_power() override;
  void follow_set_points() override;
  void ramp_to_stop(std::uint32_t deceleration) override;
  void stop_at_current_limit() override;
  void stop_at_voltage_limit() override;
  bool is_stopped() const override { return velocity_ == 0; }

  // The mode's velocity demand while following, units/s.
  void set_velocity_set_point(std::int32_t velocity) { set_point_ = velocity; }
  // The velocity now (an initial condition, or a push from outside), units/s.
  void set_velocity(std::int32_t velocity);
  // Moves the model on by `dt` (nothing for dt <= 0).
  void advance(can::Duration dt);

  double velocity() const;  // units/s
  double position() const { return position_; }
  AxisMotion motion() const { return motion_; }
  // The deceleration of the current stop (0 unless stopping).
  std::uint32_t stop_deceleration() const { return motion_ == AxisMotion::stopping ? decel_ : 0; }
  // Axis commands received (the PDS's calls), for "nothing moves" checks.
  std::uint64_t commands() const { return commands_; }
  const RampAxisConfig& config() const { return config_; }

 private:
  void advance_chunk(std::int64_t dt_ns);

  RampAxisConfig config_;
  AxisMotion motion_ = AxisMotion::free;
  std::int32_t set_point_ = 0;
  std::uint32_t decel_ = 0;
  std::int64_t velocity_ = 0;  // 10⁻⁹ units/s
  double position_ = 0.0;
  std::uint64_t commands_ = 0;
};

}  // namespace drivecheck::reference_drive
