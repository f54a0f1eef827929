// The simulated axis of the reference drive: one motor with its load, an incremental encoder
// with an index pulse, and the switches along the travel (negative limit, positive limit, home
// switch). It is the Axis the power drive system commands (power_drive_system.hpp) and the
// plant every mode of operation drives (reference_drive/modes/).
//
// Units: everything here is in INTERNAL units, the motor side of the factor group
// (factor_group.hpp converts to and from the user units of 6064h, 606Ch, ...):
//   position      encoder increments (double; actual_position() rounds toward -inf)
//   velocity      increments/s
//   acceleration  increments/s²
//   torque        per thousand of the rated torque (‰, as 6071h/6077h)
//
// Two frames of position: the PHYSICAL frame (where the axis really is; the switch layout, the
// index pulses and simulate("axis-position") are in it; 0 at power on) and the ACTUAL frame
// (what the encoder count shows, 6063h/6064h): actual = physical + offset. set_actual_position()
// (homing: "6064h := 607Ch at home") changes only the offset; the switches do not move.
//
// The motor + load model, integrated exactly for a constant acceleration over each advance(dt):
//   J·a = T_motor − T_load − T_friction·sign(v)    (J: the acceleration one rated torque gives,
//                                                    AxisConfig::rated_acceleration)
//   |T_motor| ≤ torque_limit (6072h max torque, ‰), |v| ≤ max_speed (6080h max motor speed)
// What the motor torque is, by command (the last one wins; the PDS's commands override the
// mode's while the drive function is off or stopping):
//   free (disable_power)         T_motor = 0: the load coasts on friction (coast_deceleration)
//   position (command_position)  a cascaded controller: v_ref = v_ff + kp·(p_demand − p), the
//                                torque that reaches v_ref within one cycle, limited; the
//                                following error is p_demand − p (60F4h)
//   velocity (command_velocity)  a ramp generator moves v_ref to the velocity asked for with the
//                                acceleration given (0: a step), the torque follows the ramp
//                                (limited: a blocked axis drives it to the torque limit)
//   torque (command_torque)      T_motor = the demand (limited); speed limited to max_speed
//   stopping (ramp_to_stop, stop_at_current_limit, stop_at_voltage_limit)
//                                decelerate to 0 with the deceleration given, then hold the
//                                position where it stopped (position control)
//
// Switches (SwitchLayout, physical frame; absent switch = never active): limit switches are
// active at and beyond their position, the home switch over [home_from, home_to] (either end may
// be open, as for homing methods 3..6: the switch stays active up to the end of travel). Each
// input may be forced on/off (simulate "limit-positive" = 1/0) or follow the layout (-1).
// Index pulse: at every physical position index_offset + k·index_period (k integer); advance()
// reports the crossing (index_pulse_crossed, at its actual-frame position). A limit switch does
// not stop the axis by itself: the application reacts (fault "limit switch" or a quick stop).
//
// Mechanical end stops (SwitchLayout::stop_negative / stop_positive, physical frame; absent =
// none): hard blocks the axis cannot pass, as Festo's homing methods -1 -2 -17 -18 and
// Kollmorgen's -3 -6 -7 need them (000_33c1d912b8b6010a.txt §7.2.3 L6224-6227,
// 002_953174ea6ca45cdb.txt §5.10.4.2 L4527-4530). Travelling into one, the axis stops dead at
// the stop (velocity 0 in that step, no rebound, no elasticity); whatever the controller then
// asks, it does not move further out: the torque rises to the torque limit (the current
// limit) and, under position control, the following error grows with the demand. Moving away
// from the stop is free. An axis put beyond a stop (place()) cannot move further out either.
// The stops are not inputs (60FDh has no bit for them): a drive sees them only through the
// following error or the current, as the manuals say (homing.hpp).
#pragma once

#include <cstdint>
#include <optional>

#include "protocol/can/bus.hpp"
#include "reference_drive/power_drive_system.hpp"

namespace drivecheck::reference_drive {

// Where the switches are, in physical increments. nullopt: no such switch.
struct SwitchLayout {
  std::optional<std::int64_t> negative_limit;  // active at position <= negative_limit
  std::optional<std::int64_t> positive_limit;  // active at position >= positive_limit
  // The home switch is present when either end is set; active over [home_from, home_to]
  // (an open end extends to infinity).
  std::optional<std::int64_t> home_from;
  std::optional<std::int64_t> home_to;
  // Mechanical end stops: the axis cannot go below stop_negative / above stop_positive.
  std::optional<std::int64_t> stop_negative;
  std::optional<std::int64_t> stop_positive;
  bool home_present() const { return home_from.has_value() || home_to.has_value(); }
  friend bool operator==(const SwitchLayout&, const SwitchLayout&) = default;
};

struct AxisConfig {
  // 608Fh position encoder resolution: increments per motor revolution (the index pulse comes
  // once per revolution unless index_period says otherwise).
  std::uint32_t encoder_increments = 4096;
  // Increments between two index pulses (0: encoder_increments); first pulse at index_offset.
  std::uint32_t index_period = 0;
  std::int64_t index_offset = 0;
  // Acceleration at rated torque (1000 ‰), increments/s² (the motor + load inertia).
  double rated_acceleration = 4'000'000.0;
  // Max torque 6072h (‰); the current limit deceleration of the PDS uses it.
  std::uint16_t torque_limit = 3000;
  // 6080h max motor speed, increments/s.
  double max_speed = 600'000.0;
  // Friction torque (‰) opposing the motion; with the power off the load coasts on it.
  double friction_torque = 5.0;
  // Position controller gain kp (1/s) of the position loop.
  double position_gain = 300.0;
  // The deceleration stop_at_voltage_limit uses (increments/s²).
  double voltage_limit_deceleration = 500'000.0;
  SwitchLayout switches;
};

enum class AxisControl : std::uint8_t { free, position, velocity, torque, stopping };

// An input that can be forced by simulate().
enum class SwitchForce : std::int8_t { layout = -1, off = 0, on = 1 };

enum class AxisSwitch : std::uint8_t { negative_limit, positive_limit, home };

class AxisModel final : public Axis {
 public:
  explicit AxisModel(AxisConfig config = {});

  // --- Axis (the power drive system) -----------------------------------------------------
  void disable_power() override;
  void follow_set_points() override;
  // `deceleration` as the PDS has it: 6084h/6085h in user acceleration units, converted with
  // set_acceleration_factor().
  void ramp_to_stop(std::uint32_t deceleration) override;
  void stop_at_current_limit() override;
  void stop_at_voltage_limit() override;
  bool is_stopped() const override;

  // --- Set-points (the modes) --------------------------------------------------------------
  // Taken only while following (after follow_set_points(), until the next PDS command); while
  // free or stopping they are remembered but do nothing.
  // Position control: demand position and velocity feed-forward (physical increments are not
  // used here: the demand is in the ACTUAL frame, as 6062h/60FCh).
  void command_position(double demand, double velocity_feed_forward = 0.0);
  // Velocity control: reach `velocity` with `acceleration` (0: as fast as torque allows).
  void command_velocity(double velocity, double acceleration = 0.0);
  // Torque control: the motor torque (‰), limited by the torque limit.
  void command_torque(double torque);

  // Moves the model on by `dt` (nothing for dt <= 0). Index pulses crossed are reported.
  void advance(can::Duration dt);

  // --- Actual values -----------------------------------------------------------------------
  double position() const { return physical_ + offset_; }  // actual frame, increments
  std::int64_t actual_position() const;                    // 6063h (floor)
  double physical_position() const { return physical_; }
  double velocity() const { return velocity_; }  // increments/s
  double acceleration() const { return accel_; }
  double torque() const { return torque_; }           // ‰, the motor torque of the last step
  double demand_position() const { return demand_; }  // actual frame (position control)
  double demand_velocity() const;                     // what the axis is asked to run at
  double following_error() const;                     // demand − actual, position control only
  AxisControl control() const { return control_; }
  bool following() const { return following_; }  // the drive function follows set-points
  bool powered() const { return control_ != AxisControl::free; }

  // --- Homing / encoder --------------------------------------------------------------------
  // The actual position becomes `position` here (the switches stay where they are).
  void set_actual_position(double position);
  // Whether the last advance() crossed an index pulse, and where (actual frame, exact).
  std::optional<double> index_pulse_crossed() const { return index_crossed_; }

  // --- Switches and simulation -------------------------------------------------------------
  bool switch_active(AxisSwitch which) const;
  void force_switch(AxisSwitch which, SwitchForce force);
  SwitchForce switch_force(AxisSwitch which) const;
  const SwitchLayout& layout() const { return config_.switches; }
  void set_layout(const SwitchLayout& layout) { config_.switches = layout; }
  // Index pulses every `period` increments (0: encoder_increments) from physical `offset`.
  void set_index(std::uint32_t period, std::int64_t offset) {
    config_.index_period = period;
    config_.index_offset = offset;
  }
  // Puts the axis somewhere (physical frame), at rest; position control holds it there.
  void place(double physical_position);
  // An external load torque (‰, signed: positive pushes toward negative positions).
  void set_load_torque(double torque) { load_ = torque; }
  double load_torque() const { return load_; }

  // Limits the modes and the PDS set (6072h, 6080h in internal units).
  void set_torque_limit(double torque) { torque_limit_ = torque; }
  double torque_limit() const { return torque_limit_; }
  void set_max_speed(double speed) { max_speed_ = speed; }
  double max_speed() const { return max_speed_; }

  // Internal increments/s² per user acceleration unit (the factor group's 6097h, for the
  // decelerations the PDS passes to ramp_to_stop). Default 1.
  void set_acceleration_factor(double factor) { acceleration_factor_ = factor; }

  // The axis stands against a mechanical end stop (at or beyond it; either direction).
  bool at_end_stop() const;

  // PDS commands received (for "nothing moves" checks).
  std::uint64_t commands() const { return commands_; }
  const AxisConfig& config() const { return config_; }

 private:
  void step(double dt);
  void stop_with(double deceleration);

  AxisConfig config_;
  AxisControl control_ = AxisControl::free;
  bool following_ = false;
  // Set-points of the mode.
  AxisControl mode_control_ = AxisControl::position;
  double demand_ = 0.0;
  double feed_forward_ = 0.0;
  double velocity_ref_ = 0.0;
  double velocity_accel_ = 0.0;
  double torque_ref_ = 0.0;
  // Stopping.
  double stop_decel_ = 0.0;
  bool holding_ = false;
  double hold_at_ = 0.0;
  // State.
  double physical_ = 0.0;
  double offset_ = 0.0;
  double velocity_ = 0.0;
  double accel_ = 0.0;
  double torque_ = 0.0;
  double load_ = 0.0;
  double torque_limit_ = 0.0;
  double max_speed_ = 0.0;
  double acceleration_factor_ = 1.0;
  double last_velocity_ref_ = 0.0;
  double ramp_velocity_ = 0.0;  // the velocity ramp generator (velocity control)
  std::optional<double> index_crossed_;
  SwitchForce forces_[3] = {SwitchForce::layout, SwitchForce::layout, SwitchForce::layout};
  std::uint64_t commands_ = 0;
};

}  // namespace drivecheck::reference_drive
