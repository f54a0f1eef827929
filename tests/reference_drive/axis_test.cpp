// The axis parts alone: motor + load model, encoder index, switches, trajectory generator,
// factor group.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "reference_drive/axis/axis_model.hpp"
#include "reference_drive/axis/factor_group.hpp"
#include "reference_drive/axis/position_range.hpp"
#include "reference_drive/axis/trajectory.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;

// A powered axis following set-points, commanded to `velocity` for `cycles` steps of 1 ms.
AxisModel axis_running_at(double velocity, int cycles) {
  AxisModel axis;
  axis.follow_set_points();
  for (int i = 0; i < cycles; ++i) {
    axis.command_velocity(velocity);
    axis.advance(1ms);
  }
  return axis;
}

TEST(AxisModel, PositionControlHoldsTheDemand) {
  // Given a powered axis following set-points
  AxisModel axis;
  axis.follow_set_points();
  // When the demand is 1000 for 100 ms
  for (int i = 0; i < 100; ++i) {
    axis.command_position(1000.0);
    axis.advance(1ms);
  }
  // Then the axis is at 1000 (within an increment) and at rest
  EXPECT_NEAR(axis.position(), 1000.0, 0.5);
  EXPECT_NEAR(axis.velocity(), 0.0, 1.0);
  EXPECT_NEAR(axis.following_error(), 0.0, 0.5);
}

TEST(AxisModel, RampToStopUsesTheDecelerationGiven) {
  // Given an axis running at 10000 increments/s
  AxisModel axis = axis_running_at(10000.0, 50);
  ASSERT_NEAR(axis.velocity(), 10000.0, 1e-6);
  // When it is stopped at 100000 increments/s²
  axis.ramp_to_stop(100000);
  // Then it is still moving after 99 ms and stopped at 100 ms, 500 increments further
  const double from = axis.position();
  for (int i = 0; i < 99; ++i)
    axis.advance(1ms);
  EXPECT_FALSE(axis.is_stopped());
  axis.advance(1ms);
  EXPECT_TRUE(axis.is_stopped());
  EXPECT_NEAR(axis.position() - from, 500.0, 5.0);
}

TEST(AxisModel, FreeAxisCoastsOnFriction) {
  // Given an axis at 1000 increments/s with 5 ‰ friction (20000 increments/s²)
  AxisModel axis = axis_running_at(1000.0, 10);
  // When the power is removed
  axis.disable_power();
  // Then it coasts to rest within 50 ms + a cycle
  for (int i = 0; i < 51; ++i)
    axis.advance(1ms);
  EXPECT_TRUE(axis.is_stopped());
}

TEST(AxisModel, RemovingThePowerTakesTheTorqueAtOnce) {
  // Given an axis braking on a stop ramp (the motor gives torque)
  AxisModel axis = axis_running_at(1000.0, 10);
  axis.ramp_to_stop(100000);
  axis.advance(1ms);
  ASSERT_NE(axis.torque(), 0.0);
  // When the power is removed, before the next step
  axis.disable_power();
  // Then the motor torque (6077h) is 0 already
  EXPECT_EQ(axis.torque(), 0.0);
  EXPECT_EQ(axis.control(), AxisControl::free);
}

TEST(AxisModel, IndexPulseIsReportedWhereCrossed) {
  // Given an index every 1000 increments from 250
  AxisConfig config;
  config.index_period = 1000;
  config.index_offset = 250;
  AxisModel axis(config);
  axis.follow_set_points();
  // When the axis runs from 0 upward at 100000 increments/s
  std::optional<double> seen;
  for (int i = 0; i < 10 && !seen; ++i) {
    axis.command_velocity(100000.0);
    axis.advance(1ms);
    seen = axis.index_pulse_crossed();
  }
  // Then the first pulse reported is at 250
  ASSERT_TRUE(seen);
  EXPECT_DOUBLE_EQ(*seen, 250.0);
  // And after set_actual_position the pulse is reported in the new frame
  axis.set_actual_position(0.0);
  const double physical = axis.physical_position();
  std::optional<double> next;
  for (int i = 0; i < 20 && !next; ++i) {
    axis.command_velocity(100000.0);
    axis.advance(1ms);
    next = axis.index_pulse_crossed();
  }
  ASSERT_TRUE(next);
  EXPECT_NEAR(*next, 1250.0 - physical, 1e-6);
}

TEST(AxisModel, SwitchesFollowTheLayoutUnlessForced) {
  // Given limits at -100 / +100 and a home switch over [20, 40]
  AxisConfig config;
  config.switches.negative_limit = -100;
  config.switches.positive_limit = 100;
  config.switches.home_from = 20;
  config.switches.home_to = 40;
  AxisModel axis(config);
  // When the axis is placed at 30, 100, -100, 0
  axis.place(30);
  EXPECT_TRUE(axis.switch_active(AxisSwitch::home));
  EXPECT_FALSE(axis.switch_active(AxisSwitch::positive_limit));
  axis.place(100);
  EXPECT_TRUE(axis.switch_active(AxisSwitch::positive_limit));
  EXPECT_FALSE(axis.switch_active(AxisSwitch::home));
  axis.place(-100);
  EXPECT_TRUE(axis.switch_active(AxisSwitch::negative_limit));
  axis.place(0);
  // Then forcing overrides the layout, and -1 returns to it
  axis.force_switch(AxisSwitch::home, SwitchForce::on);
  EXPECT_TRUE(axis.switch_active(AxisSwitch::home));
  axis.force_switch(AxisSwitch::home, SwitchForce::layout);
  EXPECT_FALSE(axis.switch_active(AxisSwitch::home));
}

TEST(AxisModel, LoadBeyondTheTorqueLimitStallsTheAxis) {
  // Given a load of 4000 ‰ against a 3000 ‰ torque limit
  AxisModel axis;
  axis.set_load_torque(4000.0);
  axis.follow_set_points();
  // When the axis is told to go to +1000
  for (int i = 0; i < 100; ++i) {
    axis.command_position(1000.0);
    axis.advance(1ms);
  }
  // Then it is pushed back instead, the following error grows, the torque is at its limit
  EXPECT_LT(axis.position(), 0.0);
  EXPECT_GT(axis.following_error(), 1000.0);
  EXPECT_DOUBLE_EQ(axis.torque(), 3000.0);
}

// Mechanical end stops: layout with a negative stop at -1000 and a positive stop at +2000.
AxisModel axis_with_stops() {
  AxisConfig config;
  config.switches.stop_negative = -1000;
  config.switches.stop_positive = 2000;
  return AxisModel(config);
}

TEST(AxisEndStop, VelocityControlStopsDeadAtTheStopAndTorqueRisesToTheLimit) {
  // Given stops at -1000 / +2000 and an axis at 0 in velocity control
  AxisModel axis = axis_with_stops();
  axis.follow_set_points();
  EXPECT_FALSE(axis.at_end_stop());
  // When it is driven at 20000 increments/s toward the positive stop for 200 ms (4000 ahead)
  for (int i = 0; i < 200; ++i) {
    axis.command_velocity(20000.0, 1'000'000.0);
    axis.advance(1ms);
  }
  // Then it stands exactly at the stop, velocity 0, the torque at the limit (3000 ‰)
  EXPECT_DOUBLE_EQ(axis.physical_position(), 2000.0);
  EXPECT_DOUBLE_EQ(axis.velocity(), 0.0);
  EXPECT_TRUE(axis.at_end_stop());
  EXPECT_DOUBLE_EQ(axis.torque(), 3000.0);
  // When it is driven the other way, Then it leaves the stop freely
  for (int i = 0; i < 20; ++i) {
    axis.command_velocity(-5000.0);
    axis.advance(1ms);
  }
  EXPECT_LT(axis.physical_position(), 1950.0);
  EXPECT_FALSE(axis.at_end_stop());
}

TEST(AxisEndStop, PositionControlBuildsUpFollowingError) {
  // Given stops at -1000 / +2000 and position control
  AxisModel axis = axis_with_stops();
  axis.follow_set_points();
  // When the demand runs to -5000 at 10000 increments/s (500 ms)
  for (int i = 1; i <= 500; ++i) {
    const double demand = -10.0 * i;
    axis.command_position(demand, -10000.0);
    axis.advance(1ms);
  }
  // Then the axis is held at -1000 and the following error is the rest of the way: -4000
  EXPECT_DOUBLE_EQ(axis.physical_position(), -1000.0);
  EXPECT_NEAR(axis.following_error(), -4000.0, 1e-6);
  EXPECT_DOUBLE_EQ(axis.torque(), -3000.0);
}

TEST(AxisEndStop, AxisPutBeyondAStopCannotGoFurtherOut) {
  // Given an axis put at -1500 (beyond the negative stop at -1000)
  AxisModel axis = axis_with_stops();
  axis.place(-1500.0);
  axis.follow_set_points();
  // When driven negative, Then it stays at -1500; When driven positive, Then it moves
  for (int i = 0; i < 50; ++i) {
    axis.command_velocity(-5000.0);
    axis.advance(1ms);
  }
  EXPECT_DOUBLE_EQ(axis.physical_position(), -1500.0);
  for (int i = 0; i < 50; ++i) {
    axis.command_velocity(5000.0);
    axis.advance(1ms);
  }
  EXPECT_GT(axis.physical_position(), -1300.0);
}

TEST(AxisEndStop, NoStopsMeansFreeTravel) {
  // Given the default layout (no stops), When driven to 5000, Then it gets there
  AxisModel axis;
  axis.follow_set_points();
  for (int i = 0; i < 500; ++i) {
    axis.command_position(std::min(5000.0, 20.0 * i));
    axis.advance(1ms);
  }
  EXPECT_NEAR(axis.physical_position(), 5000.0, 1.0);
  EXPECT_FALSE(axis.at_end_stop());
}

TEST(Trajectory, TrapezoidLandsExactlyWithinTheLimits) {
  // Given a move of 100000 at 20000/s, 100000/s² (trapezoid: 0.2 s ramps, 4.8 s cruise... )
  TrajectoryGenerator t;
  t.reset(0.0);
  t.move_to(10000.0, ProfileLimits{2000.0, 10000.0, 20000.0, 0.0});
  // When it is stepped at 1 ms
  double peak = 0.0;
  double last = 0.0;
  int steps = 0;
  while (!t.done() && steps < 100000) {
    t.step(0.001);
    peak = std::max(peak, t.velocity());
    EXPECT_GE(t.position(), last - 1e-9);  // never turns back
    EXPECT_LE(t.position(), 10000.0 + 1e-9);
    last = t.position();
    ++steps;
  }
  // Then it ends exactly on the target, never faster than 2000/s, in the trapezoid's time
  // (0.2 s + 0.1 s ramps, 4.85 s cruise: 5.15 s)
  EXPECT_EQ(t.position(), 10000.0);
  EXPECT_LE(peak, 2000.0);
  EXPECT_NEAR(steps, 5150, 5);
}

TEST(Trajectory, TurnsBackToATargetBehind) {
  // Given a demand moving up at 1000/s
  TrajectoryGenerator t;
  t.reset(0.0, 1000.0);
  // When the target is -100
  t.move_to(-100.0, ProfileLimits{1000.0, 10000.0, 10000.0, 0.0});
  int steps = 0;
  double highest = 0.0;
  while (!t.done() && steps < 10000) {
    t.step(0.001);
    highest = std::max(highest, t.position());
    ++steps;
  }
  // Then it brakes (about 50 increments further up), turns, and lands on -100
  EXPECT_NEAR(highest, 50.0, 2.0);
  EXPECT_EQ(t.position(), -100.0);
}

// The largest change of acceleration from one 1 ms cycle to the next, and the end position.
std::pair<double, double> run_profile(std::size_t smoothing) {
  TrajectoryGenerator t;
  t.reset(0.0);
  t.set_smoothing(smoothing);
  t.move_to(5000.0, ProfileLimits{5000.0, 50000.0, 50000.0, 0.0});
  double v0 = 0.0;
  double a0 = 0.0;
  double max_jerk_step = 0.0;
  for (int steps = 0; !t.done() && steps < 10000; ++steps) {
    t.step(0.001);
    const double a = (t.velocity() - v0) / 0.001;
    max_jerk_step = std::max(max_jerk_step, std::abs(a - a0));
    v0 = t.velocity();
    a0 = a;
  }
  return {max_jerk_step, t.position()};
}

TEST(Trajectory, SmoothingLimitsTheJerkAndKeepsTheTarget) {
  // Given the same move as a trapezoid and as an S-curve over 20 cycles
  // When both run
  const auto [trapezoid_jerk, trapezoid_end] = run_profile(0);
  const auto [smooth_jerk, smooth_end] = run_profile(20);
  // Then the trapezoid's acceleration jumps by the full 50000/s² in one cycle, the S-curve's
  // by at most a twentieth of it, and both end on the target
  EXPECT_NEAR(trapezoid_jerk, 50000.0, 1.0);
  EXPECT_LE(smooth_jerk, 50000.0 / 20.0 + 1.0);
  EXPECT_NEAR(trapezoid_end, 5000.0, 1e-9);
  EXPECT_NEAR(smooth_end, 5000.0, 1e-6);
}

TEST(FactorGroup, PositionFactorAndPolarity) {
  // Given 6093h = 4096/360 (4096 increments per 360 units)
  FactorGroup f;
  f.position = Fraction{4096, 360};
  // Then 90 units are 1024 increments and back
  EXPECT_DOUBLE_EQ(f.position_to_internal(90.0), 1024.0);
  EXPECT_DOUBLE_EQ(f.position_to_user(1024.0), 90.0);
  // When the position polarity is set (80h)
  f.polarity = FactorGroup::kPositionPolarity;
  // Then positions change sign, velocities do not
  EXPECT_DOUBLE_EQ(f.position_to_internal(90.0), -1024.0);
  EXPECT_DOUBLE_EQ(f.velocity_to_internal(5.0), 5.0);
  // And fractions reduce or refuse
  Fraction out;
  EXPECT_TRUE(reduce_fraction(4096 * 3, 360, out));
  EXPECT_EQ(out, (Fraction{512, 15}));
  EXPECT_FALSE(reduce_fraction(1, 0, out));
}

// --- 607Bh position range limit and the 60F2h rotary axis direction option ---------------------

TEST(PositionRange, DefaultsAndZeroLeaveALinearAxis) {
  // Given the whole INTEGER32 range (the default) and 0 / 0
  const PositionRange whole = PositionRange::from_limits(-2147483648LL, 2147483647LL);
  const PositionRange zero = PositionRange::from_limits(0, 0);
  // When positions beyond any narrower range are wrapped and travelled to
  // Then nothing wraps and an absolute positioning goes straight there
  EXPECT_FALSE(whole.active());
  EXPECT_FALSE(zero.active());
  EXPECT_DOUBLE_EQ(whole.wrap(5000.0), 5000.0);
  EXPECT_DOUBLE_EQ(zero.travel(100.0, -900.0, RotaryDirection::positive), -1000.0);
}

TEST(PositionRange, WrapsIntoMinInclusiveMaxExclusive) {
  // Given a range of 0 .. 3600 (max and min the same physical position)
  const PositionRange range = PositionRange::from_limits(0, 3600);
  // When values at and beyond the limits are wrapped
  // Then they lie in [0, 3600): reaching max is min, below min comes from max
  EXPECT_TRUE(range.active());
  EXPECT_DOUBLE_EQ(range.wrap(3600.0), 0.0);
  EXPECT_DOUBLE_EQ(range.wrap(3700.0), 100.0);
  EXPECT_DOUBLE_EQ(range.wrap(-100.0), 3500.0);
  EXPECT_DOUBLE_EQ(range.wrap(7250.0), 50.0);
  EXPECT_DOUBLE_EQ(range.wrap(1800.0), 1800.0);
}

TEST(PositionRange, LinearOptionNeverPassesTheLimits) {
  // Given a range of -1000 .. 3000 and option 00
  const PositionRange range = PositionRange::from_limits(-1000, 3000);
  // When absolute targets on either side are travelled to from 0
  // Then the axis moves as on a linear axis, inside the range
  EXPECT_DOUBLE_EQ(range.travel(0.0, 2500.0, RotaryDirection::linear), 2500.0);
  EXPECT_DOUBLE_EQ(range.travel(0.0, -500.0, RotaryDirection::linear), -500.0);
  EXPECT_DOUBLE_EQ(range.travel(0.0, 6500.0, RotaryDirection::linear), 2500.0);  // target wrapped
}

TEST(PositionRange, NegativeOptionOnlyMovesDown) {
  // Given a range of -1000 .. 3000 and option 01
  const PositionRange range = PositionRange::from_limits(-1000, 3000);
  // When a higher and a lower target are travelled to from 0
  // Then both are reached moving down, the higher one through the min limit
  EXPECT_DOUBLE_EQ(range.travel(0.0, 1000.0, RotaryDirection::negative), -3000.0);
  EXPECT_DOUBLE_EQ(range.travel(0.0, -500.0, RotaryDirection::negative), -500.0);
  // And a target where the axis stands (a fraction off) is no full turn
  EXPECT_NEAR(range.travel(-0.001, 0.0, RotaryDirection::negative), 0.001, 1e-9);
}

TEST(PositionRange, PositiveOptionOnlyMovesUp) {
  // Given a range of -1000 .. 3000 and option 10
  const PositionRange range = PositionRange::from_limits(-1000, 3000);
  // When a lower and a higher target are travelled to from 0
  // Then both are reached moving up, the lower one through the max limit
  EXPECT_DOUBLE_EQ(range.travel(0.0, -500.0, RotaryDirection::positive), 3500.0);
  EXPECT_DOUBLE_EQ(range.travel(0.0, 1000.0, RotaryDirection::positive), 1000.0);
}

TEST(PositionRange, ShortestOptionTakesTheShorterWayPositiveOnATie) {
  // Given a range of -1000 .. 3000 (period 4000) and option 11
  const PositionRange range = PositionRange::from_limits(-1000, 3000);
  // When targets are travelled to whose shorter way passes a limit, and one half a period away
  // Then the shorter way is taken; half a period away goes positive
  EXPECT_DOUBLE_EQ(range.travel(0.0, 2500.0, RotaryDirection::shortest), -1500.0);
  EXPECT_DOUBLE_EQ(range.travel(2500.0, -500.0, RotaryDirection::shortest), 1000.0);
  EXPECT_DOUBLE_EQ(range.travel(0.0, 1000.0, RotaryDirection::shortest), 1000.0);
  EXPECT_DOUBLE_EQ(range.travel(0.0, 2000.0, RotaryDirection::shortest), 2000.0);
  EXPECT_DOUBLE_EQ(range.travel(2000.0, 0.0, RotaryDirection::shortest), 2000.0);
}

TEST(PositionRange, DirectionOptionIsBitsSevenAndSixOf60F2h) {
  // Given 60F2h values with other options set too
  // When the rotary axis direction option is taken from them
  // Then bits 7..6 decide
  EXPECT_EQ(rotary_direction_of(0x0001), RotaryDirection::linear);
  EXPECT_EQ(rotary_direction_of(0x0042), RotaryDirection::negative);
  EXPECT_EQ(rotary_direction_of(0x0090), RotaryDirection::positive);
  EXPECT_EQ(rotary_direction_of(0x00C0), RotaryDirection::shortest);
}

}  // namespace
}  // namespace drivecheck::reference_drive
