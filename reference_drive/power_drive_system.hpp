// The device side of the CiA 402 power drive system (PDS, IEC 61800-7-201 §"PDS states and
// transitions"; CiA 402-2 §"Finite state automaton"): a pure state machine fed the controlword,
// the inputs (hardware enable, faults, communication loss) and time, one step(now) per drive
// cycle. It reads its states and transitions from protocol/cia402/state_machine.hpp
// (kTransitions, commanded_transition); nothing here is a second copy of the table. No bus, no
// clock, no threads: the owner calls step() every control cycle (ReferenceDrive's
// DriveConfig::control_cycle, 1 ms by default) and publishes the outputs.
//
// What one step(now) does, in this order; AT MOST ONE state transition per step, so every
// state the drive passes through is visible in the statusword for at least one cycle (e.g.
// 000Fh in READY TO SWITCH ON: transition 3 at one step, 4 at the next; Festo L5249-5250
// allows 3+4 "combined", which this is from the master's side):
//   1. 13  a fault occurred since the last step, or a fault cause is present, in any state but
//          FAULT REACTION ACTIVE and FAULT (a further fault there is reported, the state stays)
//   2. 1   NOT READY TO SWITCH ON and the self-test time since power_on() has passed
//   3. 14  FAULT REACTION ACTIVE and the reaction is complete (axis at standstill, or the
//          reaction disabled the drive function)
//   4. 5/8 a ramped disable operation / shutdown (605Ch = 1 / 605Bh = 1) reaches standstill
//   5. 12  QUICK STOP ACTIVE, 605Ah 0..4, the quick stop is complete
//   6. 7/9/10/12  the hardware enable input was removed while the drive needs it (see below)
//   7. the controlword command: commanded_transition(state, controlword, previous, 605Ah 5..8)
//      - a controlword that commands no transition from the current state is ignored: the
//        state stays and the axis gets no new command ("nothing moves");
//      - fault reset (15) on the RISING EDGE of bit 7 only: set_controlword() latches a 0→1
//        change of bit 7, the next step consumes the latch; a level held high does nothing
//        more. A fault reset while a fault cause is present is consumed and keeps FAULT
//        (Festo L5413-5416, [ctx] L1260-1273: the cause must be removed first);
//      - with remote = false (statusword bit 9 = 0) the controlword is not obeyed at all.
//   8. halt (controlword bit 8) in OPERATION ENABLED: stop per 605Dh, state stays; release:
//      the axis follows the mode's set-points again
//   9. 6061h := the requested 6060h (see modes below)
//
// Ramped transitions (5 with 605Ch = 1, 8 with 605Bh = 1): the drive decelerates in OPERATION
// ENABLED and changes state when the axis reports standstill (statusword 0027h until then).
// Choice, not in CiA 402's text: once started such a stop is latched; a controlword that
// commands no transition (e.g. 000Fh again) does not cancel it, another transition from
// OPERATION ENABLED (9, 11, or 5↔8) replaces it, a fault pre-empts it.
//
// Option codes (CiA 402-2 / IEC 61800-7-201 objects 605Ah..605Eh, 6007h; INTEGER16 rw; the
// values accepted are configurable per drive, OptionCodeSupport; negative (manufacturer-
// specific) and reserved values are refused with 06090030h invalid value):
//   605Ah quick stop, default 2:        0 disable drive function (then 12 at once)
//                                       1 slow down ramp (6084h), 2 quick stop ramp (6085h),
//                                       3 current limit, 4 voltage limit: then 12 at standstill
//                                       5..8 as 1..4 but stay in QUICK STOP ACTIVE; only these
//                                       allow transition 16 (enable operation)
//   605Bh shutdown (transition 8), default 0: 0 disable drive function, 1 slow down ramp then
//                                       disable
//   605Ch disable operation (transition 5), default 1: as 605Bh; -1 (a personality's, Festo):
//                                       quick stop ramp (6085h), then disable
//   605Dh halt (bit 8), default 1:      1 slow down ramp, 2 quick stop ramp, 3 current limit,
//                                       4 voltage limit; the state stays OPERATION ENABLED
//   605Eh fault reaction, default 2:    0 disable drive function (motor free to rotate),
//                                       1 slow down ramp, 2 quick stop ramp, 3 current limit,
//                                       4 voltage limit; then 14 at standstill
//   6007h abort connection, default 1:  what on_communication_loss() does (heartbeat or life
//                                       guarding lost): 0 no action, 1 fault (8130h, transition
//                                       13), 2 disable voltage command, 3 quick stop command.
//                                       The commands act as if the controlword said so
//                                       (0000h / 0002h) until the controlword is written
//                                       again, so a dead master's last 000Fh cannot re-enable
//                                       the drive (605Ah 5..8 + transition 16).
// A reaction uses the option code and deceleration in force when it starts. "Disable drive
// function" switches the torque off: the motor runs down freely.
//
// Hardware enable (HardwareEnable): some drives need an enable input for transition 2 (Festo
// Tab. 6.2 L5218, L5291: "output stage and controller enable" + shutdown) or 3. Without it the
// command is ignored and statusword bit 7 (warning) is set while the controlword keeps asking
// (Festo B.3 84-0 L9224-9229 is a warning). Removing the input in a state that needed it
// disables the voltage (7, 9, 10 or 12 to SWITCH ON DISABLED; Festo L5208: "transition 9 =
// removal of enable: a running motor coasts").
//
// Statusword 6041h (statusword.hpp; exact values with remote = 1 and no mode bits):
//   bits 0-3, 5, 6 the state pattern (state_machine.hpp kStatePatterns; bit 5 = 1 in READY TO
//   SWITCH ON, SWITCHED ON, OPERATION ENABLED, 0 in QUICK STOP ACTIVE and the "x" states);
//   bit 4 voltage enabled = 1 in SWITCHED ON, OPERATION ENABLED, QUICK STOP ACTIVE, FAULT
//   REACTION ACTIVE (high voltage applied to the power stage); bit 7 warning; bit 9 remote;
//   bits 10-13 from the mode logic (ModeStatus), and bit 10 in QUICK STOP ACTIVE with 605Ah
//   5..8 once the axis stands (CiA 402-2 statusword bit 10: the quick stop is finished and
//   the drive is halted); bits 8, 14, 15 (manufacturer) 0 unless a
//   personality sets them (set_manufacturer_bits, e.g. Festo's sample bit 15).
//     NOT READY 0200h  SOD 0240h  RTSO 0221h  SO 0233h  OE 0237h  QSA 0217h  FRA 021Fh
//     FAULT 0208h
//
// Faults: raise_fault() reports the fault at once (FaultReporter: the device maps it onto the
// EMCY producer, 1001h bits, 1003h) and sets 603Fh to its code; the fault stays reported until
// a successful fault reset acknowledges it (FaultReporter::fault_cleared: EMCY 0000h when the
// last error goes; 603Fh := 0000h). clear_fault_cause() only says the cause is gone.
//
// Modes (6060h modes of operation, 6061h display, 6502h supported modes): request_mode()
// refuses values whose 6502h bit is not set (and reserved / manufacturer values) with
// 06090030h; 0 (no mode) is accepted. 6061h takes the requested value at the next step. A
// mode change is allowed in every state, also in OPERATION ENABLED: the mode logic keeps
// running the old mode until 6061h shows the new one (CiA 402 §"Modes of operation": the
// actual mode is the one 6061h displays; Festo L5983, L6021: "a mode change takes time; wait
// until the new mode appears in 6061h").
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia402/object_ids.hpp"
#include "protocol/cia402/state_machine.hpp"
#include "protocol/common/expected.hpp"
#include "reference_drive/deviations.hpp"

namespace drivecheck::reference_drive {

// The motion side the PDS commands (the axis simulation implements it; RampAxis in
// ramp_axis.hpp is the first-order model the tests use). Decelerations in user units/s².
class Axis {
 public:
  virtual ~Axis() = default;
  // Drive function off: no torque, the motor runs down freely (free wheel).
  virtual void disable_power() = 0;
  // Drive function on: the axis follows the set-points of the mode of operation.
  virtual void follow_set_points() = 0;
  // Drive function on: decelerate to standstill with `deceleration` (the slow down ramp 6084h
  // or the quick stop deceleration 6085h), then hold standstill.
  virtual void ramp_to_stop(std::uint32_t deceleration) = 0;
  // Drive function on: decelerate at the current (torque) limit, then hold standstill.
  virtual void stop_at_current_limit() = 0;
  // Drive function on: decelerate at the DC link voltage limit, then hold standstill.
  virtual void stop_at_voltage_limit() = 0;
  virtual bool is_stopped() const = 0;
};

// Statusword bits 10 (target reached), 11 (internal limit active), 12 and 13 (operation-mode
// specific) come from the mode logic.
class ModeStatus {
 public:
  virtual ~ModeStatus() = default;
  // The bits for the current state and displayed mode (6061h); bits outside 3C00h are ignored.
  virtual std::uint16_t statusword_bits(cia402::State state, std::int8_t mode_display) const = 0;
};

// Where faults go: the device maps them onto its EMCY producer (DeviceServices::raise_error /
// clear_error: EMCY, 1001h, 1003h).
class FaultReporter {
 public:
  virtual ~FaultReporter() = default;
  virtual void fault_raised(std::uint16_t code, std::uint8_t error_register_bits) = 0;
  // Acknowledged by a successful fault reset (transition 15).
  virtual void fault_cleared(std::uint16_t code) = 0;
};

// A fault the simulation can raise: error code (603Fh, EMCY) and the 1001h bits it sets
// besides bit 0 (generic, which the EMCY producer sets for every error).
struct FaultDefinition {
  std::uint16_t code = 0;
  std::uint8_t error_register_bits = 0;  // 1001h: bit 1 current, 2 voltage, 3 temperature,
                                         // 4 communication, 5 device profile specific
  std::string_view name;
};

// The simulated faults (codes: CiA 402 error-code table, protocol/cia301/emcy_codes.inc).
namespace faults {
inline constexpr FaultDefinition kFollowingError{
    static_cast<std::uint16_t>(cia301::EmcyCode::following_error), 0x20, "following error"};
inline constexpr FaultDefinition kLimitSwitch{
    static_cast<std::uint16_t>(cia301::EmcyCode::reference_limit), 0x20,
    "reference limit (limit switch)"};
inline constexpr FaultDefinition kOverCurrent{
    static_cast<std::uint16_t>(cia301::EmcyCode::continuous_over_current), 0x02,
    "continuous over-current"};
inline constexpr FaultDefinition kDcLinkOverVoltage{
    static_cast<std::uint16_t>(cia301::EmcyCode::dc_link_over_voltage), 0x04,
    "DC link over-voltage"};
inline constexpr FaultDefinition kMotorOverTemperature{
    static_cast<std::uint16_t>(cia301::EmcyCode::excess_drive_temperature), 0x08,
    "excess temperature drive (motor)"};
// 6007h = 1: heartbeat or life guarding lost (CiA 301 8130h, register bit 4 communication).
inline constexpr FaultDefinition kCommunication{
    static_cast<std::uint16_t>(cia301::EmcyCode::life_guard_or_heartbeat), 0x10,
    "life guard error or heartbeat error"};
}  // namespace faults

enum class OptionCode : std::uint8_t {
  abort_connection,   // 6007h
  quick_stop,         // 605Ah
  shutdown,           // 605Bh
  disable_operation,  // 605Ch
  halt,               // 605Dh
  fault_reaction,     // 605Eh
};
inline constexpr std::size_t kOptionCodeCount = 6;

struct OptionCodeInfo {
  OptionCode code;
  cia402::ObjectId id;            // name: cia402::find_object(id.index, 0)->name
  std::int16_t default_value;     // CiA 402
  std::uint16_t standard_values;  // bit n = value n is defined by CiA 402
};

// clang-format off
inline constexpr std::array<OptionCodeInfo, kOptionCodeCount> kOptionCodes{{
    // code                           object                                default values
    {OptionCode::abort_connection,    cia402::kAbortConnectionOptionCode,   1,      0x000F},  // 0..3
    {OptionCode::quick_stop,          cia402::kQuickStopOptionCode,         2,      0x01FF},  // 0..8
    {OptionCode::shutdown,            cia402::kShutdownOptionCode,          0,      0x0003},  // 0..1
    {OptionCode::disable_operation,   cia402::kDisableOperationOptionCode,  1,      0x0003},  // 0..1
    {OptionCode::halt,                cia402::kHaltOptionCode,              1,      0x001E},  // 1..4
    {OptionCode::fault_reaction,      cia402::kFaultReactionOptionCode,     2,      0x001F},  // 0..4
}};
// clang-format on

constexpr const OptionCodeInfo& info_of(OptionCode code) {
  return kOptionCodes[static_cast<std::size_t>(code)];
}

// The values a drive accepts, bit n = value n (0..15); `manufacturer` bit n = value -(n + 1)
// (-1..-16, CiA 402: -32768..-1 manufacturer specific). Default: every CiA 402 value, no
// manufacturer value. A personality restricts them (Festo: 605Ah {2}, 605Bh {0}, 605Ch {-1}).
// The only manufacturer value with behaviour is 605Ch = -1 (Festo 000 §6.1.6 L5871-5887:
// transition 5 brakes with the quick stop deceleration 6085h, then disables the drive function).
struct OptionCodeSupport {
  std::array<std::uint16_t, kOptionCodeCount> values{
      info_of(OptionCode::abort_connection).standard_values,
      info_of(OptionCode::quick_stop).standard_values,
      info_of(OptionCode::shutdown).standard_values,
      info_of(OptionCode::disable_operation).standard_values,
      info_of(OptionCode::halt).standard_values,
      info_of(OptionCode::fault_reaction).standard_values,
  };
  std::array<std::uint16_t, kOptionCodeCount> manufacturer{};
  bool accepts(OptionCode code, std::int16_t value) const {
    const auto i = static_cast<std::size_t>(code);
    if (value < 0) {
      return value >= -16 && (manufacturer[i] & (1u << static_cast<unsigned>(-value - 1))) != 0;
    }
    return value < 16 && (values[i] & (1u << static_cast<unsigned>(value))) != 0;
  }
};

enum class HardwareEnable : std::uint8_t {
  not_needed,     // the input is ignored
  for_shutdown,   // transition 2 needs it (and every state from READY TO SWITCH ON up)
  for_switch_on,  // transition 3 needs it (and every state from SWITCHED ON up)
};

struct PowerDriveConfig {
  // Power on (transition 0) to transition 1.
  can::Duration self_test{0};
  // Statusword bit 9: the controlword is obeyed. false: local control, 6040h is ignored.
  bool remote = true;
  HardwareEnable hardware_enable = HardwareEnable::not_needed;
  OptionCodeSupport option_code_support;
  // 6502h; default pp, pv, tq, hm, csp, csv, cst.
  std::uint32_t supported_modes = 0x000003AD;
  // Manufacturer-specific 6060h values (-128..-1) the drive also accepts (a personality's,
  // e.g. IRTSA -127); every other negative value is refused.
  std::vector<std::int8_t> manufacturer_modes;
  // 6060h/6061h after power on (0: no mode assigned).
  std::int8_t initial_mode = 0;
  // Defaults of 6084h profile deceleration (the slow down ramp) and 6085h quick stop
  // deceleration, user units/s² (CiA 402 leaves both to the manufacturer).
  std::uint32_t slow_down_deceleration = 10000;
  std::uint32_t quick_stop_deceleration = 100000;
  // A personality's: SWITCHED ON has the power stage enabled (Kollmorgen, 002 §5.4.1.1
  // L3057-3061, L3099-3101: transition 3 "drive has torque"; transition 5 "current position is
  // held"): entering SWITCHED ON by 3 or 5 the axis holds its position (a stop that ends in
  // position control) instead of running free; the drive function (the mode's set-points)
  // stays disabled. false (CiA 402): SWITCHED ON has the drive function and the power off.
  bool power_stage_in_switched_on = false;
  // Named deviations (deviations.inc). The PDS applies those of cia402/fsa, cia402/option-codes
  // and cia402/modes: transition-16-when-forbidden, statusword-bit5-wrong-switched-on,
  // fault-reset-on-level, quick-stop-ignored, enable-operation-from-switch-on-disabled,
  // transition-16-only-with-quick-stop-6, fault-reset-in-stop-states,
  // quick-stop-target-reached-missing (bit 10 in QUICK STOP ACTIVE), abort-connection-ignored,
  // option-code-invalid-accepted (PowerDriveObjects' validators), halt-ignored,
  // mode-display-not-following, unsupported-mode-accepted (validator), supported-modes-wrong
  // (add_power_drive_objects). Empty: the conformant PDS.
  DeviationSet deviations;
};

struct TransitionRecord {
  std::uint8_t number = 0;
  cia402::State from = cia402::State::not_ready_to_switch_on;
  cia402::State to = cia402::State::not_ready_to_switch_on;
  can::TimePoint at{};
  friend bool operator==(const TransitionRecord&, const TransitionRecord&) = default;
};

class PowerDriveSystem {
 public:
  // `axis` must outlive this object; `reporter` and `mode_status` may be null (nothing reported,
  // mode bits 0). The drive starts unpowered in NOT READY TO SWITCH ON: call power_on().
  PowerDriveSystem(Axis& axis, PowerDriveConfig config = {}, FaultReporter* reporter = nullptr,
                   const ModeStatus* mode_status = nullptr);

  // Transition 0 (power on, or NMT reset node): NOT READY TO SWITCH ON, drive function off,
  // controlword 0, option codes and decelerations kept, faults forgotten without reports (the
  // CiA 301 reset clears the EMCY side itself), 6060h/6061h := initial mode. Transition 1
  // follows at the first step at or after now + self_test.
  void power_on(can::TimePoint now);
  // One drive cycle at `now` (see the file comment). Does nothing before power_on().
  void step(can::TimePoint now);

  // Inputs.
  // 6040h as written (SDO or RPDO). Latches a 0→1 change of bit 7 for the next step, and ends
  // a command forced by 6007h.
  void set_controlword(std::uint16_t controlword);
  void set_hardware_enable(bool present);
  // An application warning (statusword bit 7, besides the missing-enable warning).
  void set_warning(bool active) { external_warning_ = active; }
  // Statusword bits 8, 14 and 15 (manufacturer specific, mask C100h) a personality shows, e.g.
  // Festo's "sample event occurred" bit 15 (reference_drive/festo_position_sampling.hpp).
  // Other bits of `bits` are ignored.
  void set_manufacturer_bits(std::uint16_t bits) {
    manufacturer_bits_ = static_cast<std::uint16_t>(bits & kManufacturerBits);
  }
  static constexpr std::uint16_t kManufacturerBits = 0xC100;
  // A fault occurs (its cause is present until clear_fault_cause). Reported at once; transition
  // 13 at the next step.
  void raise_fault(const FaultDefinition& fault);
  void clear_fault_cause(std::uint16_t code);
  // Heartbeat or life guarding lost (the CiA 301 services call this): 6007h's reaction.
  void on_communication_loss();
  // Option codes: invalid_value (06090030h) for a value the drive does not support.
  Expected<void, cia301::SdoAbort> set_option_code(OptionCode code, std::int16_t value);
  Expected<void, cia301::SdoAbort> check_option_code(OptionCode code, std::int16_t value) const;
  // 6060h: invalid_value for an unsupported mode (check without storing: check_mode).
  Expected<void, cia301::SdoAbort> request_mode(std::int8_t mode);
  Expected<void, cia301::SdoAbort> check_mode(std::int8_t mode) const;
  void set_slow_down_deceleration(std::uint32_t deceleration) { slow_down_ = deceleration; }
  void set_quick_stop_deceleration(std::uint32_t deceleration) { quick_stop_ = deceleration; }
  void set_transition_observer(std::function<void(const TransitionRecord&)> observer) {
    observer_ = std::move(observer);
  }

  // Outputs.
  cia402::State state() const { return state_; }
  std::uint16_t statusword() const;
  std::int8_t mode_display() const { return mode_display_; }    // 6061h
  std::int8_t requested_mode() const { return mode_request_; }  // 6060h
  std::uint16_t error_code() const { return error_code_; }      // 603Fh
  std::int16_t option_code(OptionCode code) const {
    return option_codes_[static_cast<std::size_t>(code)];
  }
  std::uint32_t slow_down_deceleration() const { return slow_down_; }
  std::uint32_t quick_stop_deceleration() const { return quick_stop_; }
  std::uint16_t controlword() const { return controlword_; }
  bool hardware_enable() const { return enable_; }
  bool warning() const;
  // Halt (bit 8) is stopping or holding the axis in OPERATION ENABLED.
  bool halted() const { return halted_; }
  // A ramped transition (5 or 8) waiting for standstill.
  std::optional<std::uint8_t> pending_transition() const { return pending_; }
  // The controlword 6007h forces until the next set_controlword().
  std::optional<std::uint16_t> forced_controlword() const { return forced_; }
  bool fault_cause_present() const { return !causes_.empty(); }
  // Faults reported and not yet acknowledged by a fault reset, oldest first.
  const std::vector<std::uint16_t>& unacknowledged_faults() const { return reported_; }
  std::optional<TransitionRecord> last_transition() const { return last_; }
  const PowerDriveConfig& config() const { return config_; }

 private:
  bool try_automatic(can::TimePoint now);
  bool try_enable_loss(can::TimePoint now);
  bool try_command(can::TimePoint now);
  void execute(const cia402::Transition& row, can::TimePoint now);
  void complete_pending(can::TimePoint now);
  void start_quick_stop();
  void start_fault_reaction();
  void stop_with(std::int16_t ramp_code);  // 1 slow down, 2 quick stop, 3 current, 4 voltage
  void update_halt();
  void enter(std::uint8_t number, cia402::State to, can::TimePoint now);
  bool enable_needed_in(cia402::State state) const;
  bool enable_gates(std::uint8_t transition_number) const;
  bool has(Deviation deviation) const { return config_.deviations.has(deviation); }

  Axis& axis_;
  PowerDriveConfig config_;
  FaultReporter* reporter_;
  const ModeStatus* mode_status_;
  std::function<void(const TransitionRecord&)> observer_;

  bool powered_ = false;
  can::TimePoint self_test_done_{};
  cia402::State state_ = cia402::State::not_ready_to_switch_on;
  std::uint16_t controlword_ = 0;
  bool reset_edge_ = false;
  std::optional<std::uint16_t> forced_;
  bool enable_ = false;
  bool enable_blocked_ = false;  // a command waits for the hardware enable (warning)
  bool external_warning_ = false;
  std::uint16_t manufacturer_bits_ = 0;  // set_manufacturer_bits
  std::array<std::int16_t, kOptionCodeCount> option_codes_{};
  std::uint32_t slow_down_ = 0;
  std::uint32_t quick_stop_ = 0;
  std::int8_t mode_request_ = 0;
  std::int8_t mode_display_ = 0;

  bool torque_on_ = false;              // the drive function is enabled (axis under control)
  std::int16_t active_quick_stop_ = 0;  // 605Ah the running quick stop started with
  bool reaction_complete_ = false;      // fault reaction / quick stop done without standstill
  std::optional<std::uint8_t> pending_;
  bool halted_ = false;

  std::vector<std::uint16_t> causes_;    // fault causes present
  std::vector<std::uint16_t> reported_;  // reported, not acknowledged
  bool fault_event_ = false;             // a fault occurred since the last step
  bool skip_reaction_ = false;           // deviation connection-fault-skips-reaction
  std::uint16_t error_code_ = 0;
  std::optional<TransitionRecord> last_;
};

// ---------------------------------------------------------------------------------------------
// The PDS objects in a CiA 301 object dictionary (CiA 402 object definitions; all VAR, sub 0):
//   6007h abort connection option code  INTEGER16  rw          default 1
//   603Fh error code                    UNSIGNED16 ro   PDO    0
//   6040h controlword                   UNSIGNED16 rw   PDO    0   (never stored by 1010h: a
//                                                                  stored 000Fh would enable
//                                                                  the drive at power on)
//   6041h statusword                    UNSIGNED16 ro   PDO    0
//   605Ah quick stop option code        INTEGER16  rw          2
//   605Bh shutdown option code          INTEGER16  rw          0
//   605Ch disable operation option code INTEGER16  rw          1
//   605Dh halt option code              INTEGER16  rw          1
//   605Eh fault reaction option code    INTEGER16  rw          2
//   6060h modes of operation            INTEGER8   rw   PDO    config.initial_mode
//   6061h modes of operation display    INTEGER8   ro   PDO    config.initial_mode
//   6084h profile deceleration          UNSIGNED32 rw   PDO    config.slow_down_deceleration
//                                                              (only with the option below)
//   6085h quick stop deceleration       UNSIGNED32 rw   PDO    config.quick_stop_deceleration
//   6502h supported drive modes         UNSIGNED32 ro          config.supported_modes
// Option-code defaults are CiA 402's; a default the config's support refuses is replaced by the
// lowest accepted value.
struct PowerDriveObjectOptions {
  // 6084h belongs to the profile modes; set false when the mode logic adds it.
  bool profile_deceleration = true;
};
Expected<void, std::string> add_power_drive_objects(cia301::ObjectDictionary& od,
                                                    const PowerDriveConfig& config,
                                                    const PowerDriveObjectOptions& options = {});

// Binds a PowerDriveSystem to those objects. While it lives it owns the write validators of
// 6007h, 605Ah..605Eh and 6060h (unsupported values: 06090030h) and the write observer of
// 6040h (every write, SDO or RPDO, reaches set_controlword: no fault-reset edge is lost between
// cycles); the destructor removes them. Objects that do not exist are skipped. Both must
// outlive the binding.
//
// How the device uses it (reference_drive/device.hpp DriveApplication):
//   add_objects(od)            add_power_drive_objects(od, config)
//   on_reset(application)      pds.power_on(now); binding.reload()
//   on_reset(communication)    binding.reload()
//   on_cycle(drive, now)       axis.advance(...); binding.step(now)
//   heartbeat/guarding lost    pds.on_communication_loss()
//   FaultReporter              drive.raise_error(code, bits) / drive.clear_error(code)
class PowerDriveObjects {
 public:
  PowerDriveObjects(cia301::ObjectDictionary& od, PowerDriveSystem& pds);
  ~PowerDriveObjects();
  PowerDriveObjects(const PowerDriveObjects&) = delete;
  PowerDriveObjects& operator=(const PowerDriveObjects&) = delete;

  // Reads every input from the dictionary (after values changed without hooks: power on,
  // restore, ObjectDictionary::load), controlword included, then publishes the outputs.
  void reload();
  // One drive cycle: option codes, 6060h, 6084h, 6085h from the dictionary, pds.step(now), then
  // 6041h, 6061h, 603Fh to the dictionary.
  void step(can::TimePoint now);
  // 6041h, 6061h, 603Fh := the PDS's outputs (application-side, no hooks).
  void publish();

 private:
  void read_inputs();

  cia301::ObjectDictionary& od_;
  PowerDriveSystem& pds_;
  std::vector<std::uint16_t> bound_;  // indices whose hooks this binding set
};

}  // namespace drivecheck::reference_drive
