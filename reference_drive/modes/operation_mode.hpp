// One mode of operation of the reference drive (6060h value), as Cia402Application hosts it
// (reference_drive/cia402_application.hpp). Each mode is one file in this folder:
// profile_position, profile_velocity, profile_torque, interpolated_position, cyclic_sync
// (csp/csv/cst), homing.
//
// One drive cycle of the application, in this order:
//   1. axis.advance(cycle)                  the plant moves with the set-points of the last cycle
//   2. switches → inputs (60FDh), limit reactions, following-error check
//   3. PowerDriveObjects::step(now)         the PDS: controlword, state, 6061h
//   4. the mode displayed in 6061h: cycle(ctx, cycle); on a 6061h change first leave() on the
//      old mode and enter() on the new one
//   5. actual values (6062h, 6064h, 606Bh, 606Ch, 6077h, 60F4h, ...) and 6041h published
// SYNC (the device's SYNC consumer) reaches every mode through on_sync() at the time it came,
// before the next cycle: the interpolated and cyclic synchronous modes take their set-points
// there.
//
// A mode sets the axis's set-points (AxisModel::command_position/velocity/torque) every cycle
// while ModeCycle::drive_enabled; the axis obeys them only while the PDS lets it follow
// (operation enabled, no halt or stop ramp running). While not enabled the mode tracks the
// actual position (demand := actual) so that enabling never jumps.
//
// Statusword bits 10-13 come from statusword_bits() of the mode in 6061h; bit 11 (internal
// limit active) is ORed in by the application when a software or hardware limit is active.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia402/object_ids.hpp"
#include "protocol/cia402/state_machine.hpp"
#include "protocol/common/expected.hpp"
#include "reference_drive/axis/axis_model.hpp"
#include "reference_drive/axis/factor_group.hpp"
#include "reference_drive/axis/position_range.hpp"
#include "reference_drive/deviations.hpp"
#include "reference_drive/power_drive_system.hpp"

namespace drivecheck::reference_drive {

// What every mode may use; lives as long as the application.
struct ModeContext {
  cia301::ObjectDictionary& od;
  AxisModel& axis;
  const FactorGroup& factors;
  const PowerDriveSystem& pds;
  // The deviations to show (null: none, the conformant drive).
  const DeviationSet* deviations = nullptr;
  // Drive cycles from a new set-point (pp bit 4 edge) to the acknowledge (pp bit 12).
  std::uint32_t acknowledge_latency_cycles = 1;
  std::uint32_t setpoint_buffer = 1;  // pp: set-points buffered behind the running one
  // Moving-average length of the S-curve (6086h ≠ 0), cycles.
  std::size_t jerk_smoothing_cycles = 20;
  // pp: controlword bit 9 (change on set-point) is evaluated. false: bit 9 is reserved and
  // ignored, every set-point stops at its target (a personality's: Festo).
  bool change_on_set_point = true;

  // Set by the application every cycle before the mode runs:
  // software position limits 607Dh (actual frame, internal units; min > max: none),
  double min_position = 1.0;
  double max_position = 0.0;
  // the position range limit 607Bh in effect (user units; not active: a linear axis) and, where
  // the drive takes the rotary direction from another object than 60F2h bits 7..6 (Festo
  // 6510h sub 20h), that direction,
  PositionRange position_range{};
  std::optional<RotaryDirection> rotary_direction{};
  // the following error is beyond 6065h for longer than 6066h (bit 13 of pp, ip, csp).
  bool following_error = false;
  // Set by the mode when it clamped a target to the software limits (statusword bit 11);
  // cleared by the application every cycle.
  bool position_limited = false;
  // Set by a torque mode (tq, cst) to its torque demand (‰) for 6074h; cleared by the
  // application every cycle (unset: 6074h shows the motor torque).
  std::optional<double> torque_demand{};
  // Set by a mode to controlword bits the drive resets itself (pp, 60F2h request-response
  // option: bit 4 new set-point); the application clears them in 6040h after the mode's cycle
  // and then resets this to 0.
  std::uint16_t release_controlword_bits = 0;

  bool has(Deviation deviation) const {
    return deviations != nullptr && deviations->has(deviation);
  }
  // A position target (internal) clamped to the software limits.
  double clamp_position(double target) {
    if (min_position > max_position) return target;
    // Deviation software-limit-min-ignored: the min limit is never applied.
    if (target < min_position && !has(Deviation::software_limit_min_ignored)) {
      position_limited = true;
      return min_position;
    }
    if (target > max_position) {
      position_limited = true;
      return max_position;
    }
    return target;
  }
  std::int64_t read_signed(cia402::ObjectId id) const {
    const cia301::Entry* entry = od.find(id.index, id.sub_index);
    return entry != nullptr ? entry->as_signed() : 0;
  }
  std::uint64_t read_unsigned(cia402::ObjectId id) const {
    const cia301::Entry* entry = od.find(id.index, id.sub_index);
    return entry != nullptr ? entry->as_unsigned() : 0;
  }
};

// The cycle at hand.
struct ModeCycle {
  can::TimePoint now{};
  can::Duration period{};  // the drive cycle
  std::uint16_t controlword = 0;
  cia402::State state = cia402::State::not_ready_to_switch_on;
  // OPERATION ENABLED and the drive function follows set-points (no stop ramp, no halt).
  bool drive_enabled = false;
  // Controlword bit 8 (halt) in OPERATION ENABLED: the PDS stops the axis per 605Dh.
  bool halt = false;
};

class OperationMode {
 public:
  virtual ~OperationMode() = default;
  // The 6060h value this mode answers to (1 pp, 3 pv, 4 tq, 6 hm, 7 ip, 8 csp, 9 csv, 10 cst).
  virtual std::int8_t mode() const = 0;
  // The mode's own objects (those no other mode shares; the application adds the shared ones:
  // 6062h-6070h, 607Dh-6080h, 6083h-6086h, factor group, 60F4h, 60FCh, 60FDh).
  virtual Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) {
    (void)od;
    return {};
  }
  // Power on / reset node: forget every set-point and latched edge.
  virtual void on_reset(ModeContext& ctx) { (void)ctx; }
  // 6061h switched to / away from this mode.
  virtual void enter(ModeContext& ctx, const ModeCycle& cycle) {
    (void)ctx;
    (void)cycle;
  }
  virtual void leave(ModeContext& ctx, const ModeCycle& cycle) {
    (void)ctx;
    (void)cycle;
  }
  // A SYNC arrived at `at` (only to the mode in 6061h).
  virtual void on_sync(ModeContext& ctx, can::TimePoint at) {
    (void)ctx;
    (void)at;
  }
  // Step 4 of the drive cycle (see the file comment).
  virtual void cycle(ModeContext& ctx, const ModeCycle& cycle) = 0;
  // Statusword bits 10, 12, 13 (and 11 when the mode has its own limit) for `state`.
  virtual std::uint16_t statusword_bits(cia402::State state) const = 0;
};

}  // namespace drivecheck::reference_drive
