// The CiA 402 drive application of the reference drive: the power drive system
// (power_drive_system.hpp), its objects, the simulated axis (axis/axis_model.hpp), the factor
// group (axis/factor_group.hpp) and the modes of operation (modes/*.hpp), plugged into a
// ReferenceDrive as its DriveApplication (device.hpp). Wiring, as power_drive_system.hpp's
// recipe says:
//
//   add_objects(od)            PDS objects + the shared drive objects (below) + each mode's own
//   on_reset(application)      pds.power_on(now), binding.reload(), modes forget set-points
//   on_reset(communication)    binding.reload()
//   on_cycle(drive, now)       one drive cycle (modes/operation_mode.hpp: axis, inputs, PDS,
//                              mode, outputs)
//   on_sync(drive, at)         the mode in 6061h (ip, csp, csv, cst take their set-point)
//   on_communication_loss      pds.on_communication_loss() (6007h reaction)
//   FaultReporter              drive.raise_error(code, bits) / drive.clear_error(code)
//
// The shared objects (CiA 402 object definitions; user units through the factor group):
//   6062h position demand value     INTEGER32 ro PDO   6063h position actual internal  INT32 ro
//   6064h position actual value     INTEGER32 ro PDO   6065h following error window    U32 rw
//   6066h following error time out  UNSIGNED16 rw ms   6067h position window           U32 rw
//   6068h position window time      UNSIGNED16 rw ms   606Bh velocity demand value     INT32 ro
//   606Ch velocity actual value     INTEGER32 ro PDO   606Dh velocity window           U16 rw
//   606Eh velocity window time      UNSIGNED16 rw ms   606Fh velocity threshold        U16 rw
//   6070h velocity threshold time   UNSIGNED16 rw ms   6071h target torque             INT16 rw
//   6072h max torque                UNSIGNED16 rw ‰    6074h torque demand             INT16 ro
//   6077h torque actual value       INTEGER16 ro ‰     607Ah target position           INT32 rw
//   607Dh software position limit   ARRAY 1 min, 2 max INTEGER32 rw (min >= max: no limits)
//   607Eh polarity                  UNSIGNED8 rw (00h, 40h, 80h, C0h)
//   607Fh max profile velocity      UNSIGNED32 rw      6080h max motor speed           U32 rw
//   6081h profile velocity          UNSIGNED32 rw      6082h end velocity              U32 rw
//   6083h profile acceleration      UNSIGNED32 rw      (6084h, 6085h: PDS objects)
//   6086h motion profile type       INTEGER16 rw (0 linear; 1, 2, 3 the S-curve)
//   6087h torque slope              UNSIGNED32 rw ‰/s  6088h torque profile type       INT16 rw
//   608Fh position encoder resolution ARRAY 1 increments, 2 motor revolutions U32 ro
//   6091h gear ratio, 6092h feed constant, 6093h position factor, 6094h velocity encoder
//   factor, 6097h acceleration factor: ARRAY 1 numerator, 2 divisor U32 rw (factor_group.hpp)
//   60B0h position offset INT32, 60B1h velocity offset INT32, 60B2h torque offset INT16 rw
//   60C2h interpolation time period RECORD 1 units U8, 2 index INT8 rw (default 1 × 10⁻³ s)
//   60F4h following error actual value INTEGER32 ro    60FCh position demand internal  INT32 ro
//   60FDh digital inputs UNSIGNED32 ro PDO: bit 0 negative limit switch, 1 positive limit
//   switch, 2 home switch, 3 interlock (never set)
//   60FFh target velocity INTEGER32 rw PDO
//
// Reactions of the application (CiA 402 leaves them to the manufacturer; these are the
// reference drive's):
//   - a hardware limit switch active in OPERATION ENABLED while the axis moves toward it, in
//     any mode but homing: fault "limit switch" (8612h reference limit), statusword
//     bit 11 while a limit switch is active;
//   - following error (position control: |60F4h| > 6065h for longer than 6066h ms, 6065h =
//     FFFFFFFFh: off): fault "following error" (8611h) and bit 13 in pp/ip/csp;
//   - software limits 607Dh: position targets are clamped to them, bit 11 while clamped.
//
// simulate(name, value) — the `simulate` step of the vectors (FORMAT.md); positions in user
// position units of the PHYSICAL frame (= 6064h until homing shifts it):
//   hardware-enable 0|1          limit-positive, limit-negative, home-switch  1 on, 0 off,
//                                                                             -1 by the layout
//   limit-positive-at P          limit-negative-at P     home-switch-from P   home-switch-to P
//   switch-layout-clear (any)    index-period N (increments; 0: once per revolution, 608Fh)
//                                index-offset P
//   stop-negative-at P           stop-positive-at P      mechanical end stops (cleared by
//                                                         switch-layout-clear too)
//   axis-position P              load-torque T (‰)
//   axis-coast-to-rest 1         an axis coasting with the power stage off stands still where
//                                it is (what an operator waits for between tests); a powered
//                                axis is left alone
//   fault:following-error | fault:limit-switch | fault:overcurrent | fault:over-voltage |
//   fault:over-temperature   1 the fault occurs (cause present), 0 the cause is gone
//   ("fault NAME" with a space is taken too, as FORMAT.md writes it)
// axis-position while a mode runs: the axis is put there at rest and the mode in 6061h starts
// again from there (its set-points are dropped), as after a mode change.
// Unknown names and out-of-range values are errors (the message names the valid ones).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia402/modes.hpp"
#include "protocol/common/expected.hpp"
#include "reference_drive/axis/axis_model.hpp"
#include "reference_drive/axis/factor_group.hpp"
#include "reference_drive/deviations.hpp"
#include "reference_drive/device.hpp"
#include "reference_drive/modes/operation_mode.hpp"
#include "reference_drive/power_drive_system.hpp"

namespace drivecheck::reference_drive {

// 603Fh as the drive shows it.
enum class ErrorCodeFormat : std::uint8_t {
  standard,      // the CiA 402 / CiA 301 error code (EMCY code)
  error_number,  // IRTSA: error number × 256 + 80h (003_111f14ab1c37c28a.txt Table 8 L212-228)
};

// 6060h/6061h size (CiA 402: INTEGER8; ESR maps them as 16 bit, 004_956552dcd17e975a.txt).
enum class ModeObjectWidth : std::uint8_t { bits8, bits16 };

// 607Bh position range limit (personality key position_range_limit; axis/position_range.hpp).
enum class PositionRangeSupport : std::uint8_t {
  none,    // no 607Bh (a profile's objects file may still add it as a plain stored value)
  cia402,  // 607Bh in effect as set; pp takes the direction from 60F2h bits 7..6
  // Festo (000 §5.7 L3821-3867): 607Bh in effect only while 6510h sub 20h
  // (position_range_limit_enable) selects a round axis: 1, 2 shortest way, 4 only positive,
  // 5 only negative; 0 off, 3 reserved (off). 60F2h refuses bits 7..6 (the direction is
  // 6510h sub 20h's).
  festo,
};

// A manufacturer-specific mode of operation and the logic that runs under it.
struct ManufacturerModeConfig {
  enum class Logic : std::uint8_t {
    behaves_as,  // the standard mode `behaves_as` (modes/manufacturer_mode.hpp)
    irtsa_mpp,   // IRTSA manual profile position (modes/manual_profile_position.hpp)
  };
  std::int8_t value = 0;  // -128..-1
  // 1 pp, 3 pv, 4 tq, 7 ip, 8 csp, 9 csv, 10 cst; 0 (or a mode the drive cannot run, 2, 6):
  // no logic, the axis holds its position and the mode bits are 0.
  std::int8_t behaves_as = 0;
  Logic logic = Logic::behaves_as;
};

struct Cia402ApplicationConfig {
  PowerDriveConfig pds;  // 6502h = pds.supported_modes: only those modes are hosted
  AxisConfig axis;
  // New set-point (pp bit 4 edge) to set-point acknowledge (bit 12), in drive cycles (≥ 1).
  std::uint32_t acknowledge_latency_cycles = 1;
  // pp: set-points buffered behind the running one (personality key setpoint_buffer), 1..8.
  std::uint32_t setpoint_buffer = 1;
  ErrorCodeFormat error_code_format = ErrorCodeFormat::standard;
  // error_number format: EMCY code → error number (unlisted codes: the code's high byte).
  std::vector<std::pair<std::uint16_t, std::uint8_t>> error_numbers;
  ModeObjectWidth mode_object_width = ModeObjectWidth::bits8;
  // Manufacturer-specific 6060h values the drive's manual lists (e.g. IRTSA -127): accepted in
  // 6060h and shown in 6061h (added to pds.manufacturer_modes), each running the logic below
  // (or a mode with that value add_mode()d later).
  std::vector<ManufacturerModeConfig> manufacturer_modes;
  // The deviations of the modes (cia402/pp, pv, tq, ip, csp); merged with pds.deviations both
  // ways, so either place serves the PDS and the modes.
  DeviationSet deviations;
  // Moving-average length (cycles) of the S-curve when 6086h ≠ 0.
  std::size_t jerk_smoothing_cycles = 20;
  // The drive's internal velocity and acceleration units, in increments/s and increments/s²
  // of the axis: what one unit of 6094h × user velocity (6097h × user acceleration) is. 1/1:
  // the factor group converts into increments/s directly (the standard drive). Festo: 4/15
  // (1/4096 min^-1 at 65536 increments per revolution) and 64/15 (1/256 min^-1/s).
  Fraction internal_velocity_unit{};
  Fraction internal_acceleration_unit{};
  // pp controlword bit 9 (change on set-point) evaluated; false: reserved and ignored (Festo
  // 000 §6.1.3 L5326-5424: bits 9..15 reserved).
  bool pp_change_on_set_point = true;
  // 60C0h: the one interpolation sub-mode accepted, also its default (InterpolatedPositionMode).
  std::int16_t ip_submode = 0;
  // ip: 60C4h sub 01h max_buffer_size (personality key ip_max_buffer), 0..16; 0: no buffer,
  // the last 60C1h record written is taken at the next SYNC (Festo 000 §7.4.2 L6620-6638).
  std::uint32_t ip_max_buffer = 16;
  // 6080h max motor speed as UNSIGNED16 in min^-1 (Festo 000 §7.5.2 L6939-6948, default
  // 32768), converted with the axis's encoder_increments; false: UNSIGNED32 in velocity units.
  bool max_motor_speed_rpm = false;
  // 607Bh: added to the dictionary (sub 01h INTEGER32 min, 02h max, defaults the whole
  // INTEGER32 range: no wrap) unless none; positions wrap while a narrower range is set.
  PositionRangeSupport position_range = PositionRangeSupport::cia402;
};

// The factor group as the dictionary holds it: 6093h/6094h/6097h (a fraction with a zero part
// reads as 1/1) and polarity 607Eh. The drive reads it every cycle; a personality that keeps
// parameters in internal units converts with it.
FactorGroup read_factor_group(const cia301::ObjectDictionary& od);

class Cia402Application final : public DriveApplication, private FaultReporter, private ModeStatus {
 public:
  explicit Cia402Application(Cia402ApplicationConfig config = {});
  ~Cia402Application() override;
  Cia402Application(const Cia402Application&) = delete;
  Cia402Application& operator=(const Cia402Application&) = delete;

  // Hosts another mode (homing: modes/homing.hpp). Before the drive is created (add_objects);
  // a mode whose 6502h bit is clear is not hosted, one with the 6060h value of a hosted mode
  // replaces it. One application serves one drive at a time
  // (it must outlive it; a new drive may use it after the old one is destroyed).
  void add_mode(std::unique_ptr<OperationMode> mode);

  // DriveApplication.
  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override;
  void on_reset(ReferenceDrive& drive, cia301::ResetKind kind) override;
  void on_cycle(ReferenceDrive& drive, can::TimePoint now) override;
  void on_sync(ReferenceDrive& drive, can::TimePoint at) override;
  void on_communication_loss(ReferenceDrive& drive) override;
  // The other 6007h events (bus-off, NMT Stopped, reset communication): the same reaction, in
  // OPERATION ENABLED only. CiA 402-2 does not say in which states 6007h acts; a fault signal
  // (6007h = 1) for a reset communication of a drive standing in SWITCH ON DISABLED would make
  // every configuration reset a fault, so the drive takes the narrow reading (the vectors judge
  // the reaction from OPERATION ENABLED only).
  void on_connection_event(ReferenceDrive& drive) override;
  void on_drive_destroyed(ReferenceDrive& drive) override;

  // The `simulate` inputs (see the file comment).
  Expected<void, std::string> simulate(std::string_view name, std::int64_t value);

  PowerDriveSystem& pds() { return pds_; }
  const PowerDriveSystem& pds() const { return pds_; }
  AxisModel& axis() { return axis_; }
  const AxisModel& axis() const { return axis_; }
  const FactorGroup& factors() const { return factors_; }
  const Cia402ApplicationConfig& config() const { return config_; }
  // The mode hosted for a 6060h value (null: none).
  OperationMode* mode(std::int8_t value);
  std::uint64_t cycles() const { return cycles_; }

 private:
  // FaultReporter.
  void fault_raised(std::uint16_t code, std::uint8_t error_register_bits) override;
  void fault_cleared(std::uint16_t code) override;
  // ModeStatus.
  std::uint16_t statusword_bits(cia402::State state, std::int8_t mode_display) const override;

  std::unique_ptr<OperationMode> make_standard_mode(cia402::Mode mode) const;
  Expected<void, std::string> add_shared_objects(cia301::ObjectDictionary& od);
  void bind(cia301::ObjectDictionary& od);
  void read_parameters();
  void read_position_range();
  void check_limits(can::TimePoint now, can::Duration dt);
  void publish();
  std::uint16_t error_code_shown() const;

  Cia402ApplicationConfig config_;
  AxisModel axis_;
  FactorGroup factors_;
  PowerDriveSystem pds_;
  std::vector<std::unique_ptr<OperationMode>> modes_;
  cia301::ObjectDictionary* od_ = nullptr;
  std::unique_ptr<PowerDriveObjects> binding_;
  std::unique_ptr<ModeContext> context_;
  ReferenceDrive* drive_ = nullptr;
  OperationMode* active_ = nullptr;
  std::int8_t active_value_ = 0;
  std::optional<can::TimePoint> last_cycle_;
  std::uint64_t cycles_ = 0;
  std::optional<can::TimePoint> following_error_since_;
  bool limit_active_ = false;
  std::uint32_t inputs_ = 0;
};

}  // namespace drivecheck::reference_drive
