// Homing mode (hm, 6060h = 6) of the reference drive: CiA 402-2 §"Homing mode" (IEC 61800-7-201
// §"Homing mode"), every standard method 1..14, 17..30, 33..35, 37 and the manufacturer methods
// the manuals define (Festo -1 -2 -17 -18 -23 -27, Kollmorgen -1 -2 -3 -6 -7, IRTSA -127 -126).
// The methods are data (homing_methods.inc); one engine runs them all. A pure state machine:
// the owner calls step(now, inputs, axis) once per drive cycle; no bus, no clock, no threads.
//
// Objects (read at the start of a homing run and kept until it ends):
//   607Ch home offset                        INTEGER32  rw PDO  default 0
//   6098h homing method                      INTEGER8   rw PDO  config.default_method
//   6099h homing speeds  sub 1 search for switch   UNSIGNED32 rw PDO  config.search_speed
//                        sub 2 search for zero     UNSIGNED32 rw PDO  config.zero_speed
//   609Ah homing acceleration (every acceleration and deceleration of the run; 0: velocity
//         steps, Kollmorgen's default)        UNSIGNED32 rw PDO  config.acceleration
//
// Control (controlword 6040h; Festo Tab. 7.2 L6246-6254, Kollmorgen §5.10.5 L4627-4631):
//   bit 4 0→1 in OPERATION ENABLED with 6061h = 6 and bit 8 = 0: start (a new start clears the
//         previous result: IRTSA L475 "with the next homing request will be reset again");
//   bit 4 1→0 while running: interrupted (the axis stops with 609Ah);
//   bit 8 (halt) while running: interrupted, no resume when bit 8 clears (Festo L5422);
//         a start edge while bit 8 = 1 is ignored (IRTSA Tab. 19 L452-456: "bit 8 = 0 enables
//         bit 4"). The power drive system stops the axis per 605Dh; the mode commands 0 too.
//   leaving OPERATION ENABLED while running: homing error (Festo 11-1 L7805-7856: "enable
//         withdrawn"). Changing 6061h away from 6 while running: the run ends, interrupted.
//
// Statusword bits 13 12 10 in hm (CiA 402-2 table "homing status"; IRTSA Tab. 20
// 003_111f14ab1c37c28a.txt L464-473 reprints it):
//   0 0 0  homing procedure is in progress
//   0 0 1  homing procedure is interrupted or not started
//   0 1 0  homing is attained, but target is not reached   (decelerating after the home event)
//   0 1 1  homing procedure is completed successfully        (home found, axis at standstill)
//   1 0 0  homing error occurred, velocity is not 0
//   1 0 1  homing error occurred, velocity is 0
//   1 1 x  reserved (never shown)
// Interrupted while the axis still decelerates shows 0 0 0 (bit 10 = target reached = "halt:
// velocity 0", CiA 402 §"Statusword" bit 10), then 0 0 1 at standstill. The result stays after
// the run (also after bit 4 falls) until the next start.
//
// The engine (for every row of homing_methods.inc; "search" = 6099h sub 1, "crawl" = sub 2):
//   single-edge switches (limit switch, positive/negative home switch): if the switch shows the
//     level it has AFTER the home edge in the approach direction, first travel the opposite way
//     at search speed until it changes; then travel in the approach direction at crawl speed
//     until it changes: that is the edge.
//   home switch over a part of the travel (window, 7..14, 23..30): switch active: as above;
//     inactive: travel `first` at search speed; on the limit switch (or stop) ahead reverse
//     once; entering the switch in the approach direction over the home edge: back out and
//     re-approach at crawl speed; otherwise go on as from "switch active". Festo -23/-27
//     (via_limit) go to the limit or stop in `first` direction first, whatever the switch shows.
//   index pulse (1..14, 33, 34, Festo -1/-2): after the edge, on in the approach direction at
//     crawl speed to the first index pulse: home is that pulse.
//   mechanical stop (Festo -1 -2 -17 -18, Kollmorgen -3 -6 -7): search speed to the stop
//     (limit switches ignored, Festo footnote 2 L6196); home is the stop or, with the index
//     pulse (Festo -1/-2, Kollmorgen -3 "mit Nullpunktsuche"), the first index pulse crawling
//     back off it. Kollmorgen -3 sets NREF = 7 only: its direction is DREF (352Ch, §6.1.1 L5276) as
//     the last 6098h write left it (0 negative after 1 12 17 28 33 -7, 1 positive after 2 8 18 24
//     34 -6; L4527-4562); 2 (after -1) or never set: negative (the manual gives no rule).
//   The stop is detected as the manuals describe it, by the following error: Kollmorgen
//     -6/-7 "Schleppfehler setzt Referenz" (002_953174ea6ca45cdb.txt §5.10.4.2 L4527-4528),
//     Festo error 11-5 "Homing: I2t / following error", cause "end stop reached"
//     (000_33c1d912b8b6010a.txt Annex B L7845-7848). The mode integrates the velocity profile it
//     commands into a demand position; when demand − actual exceeds the following error
//     window (6065h, read with the other objects; HomingConfig::stop_window without a
//     dictionary) in the direction of travel, the axis is blocked. The home position is the
//     actual position at that moment (the axis stands at the stop), and the time from
//     touching the stop to the home event is window / search speed. The axis is not driven
//     off the stop afterwards (no travel to zero under CANopen, Festo L6040; Festo footnote 3
//     L6197 asks the user to parameterise it: the travel to zero below).
//   current position (35, 37, Kollmorgen -2, IRTSA -127): home is where the axis stands, no
//     motion, completed at the start step. IRTSA -126: 6064h := the value nearest 607Ch that
//     keeps the position within the index period (whole periods of 607Ch only, L421).
// The home event latches the position (the index pulse exactly; a switch edge at the first
// cycle that shows the new level, i.e. within crawl speed × cycle), then 6064h is shifted so
// that the home position reads 607Ch, and the axis decelerates with 609Ah. No travel to zero
// (Festo L6040: "the drive to the zero position under CANopen is normally not a component of
// the reference travel"), so 6064h ends at 607Ch ± the braking distance crawl²/(2·609Ah), in
// the approach direction.
// Travel to zero (HomingConfig::travel_to_zero_bit; Festo 6510h:F0h bit 6 homing_to_zero,
// 000_33c1d912b8b6010a.txt §5.2 L2560-2566, §7.2.2 L6149-6151): when the bit is set at the
// start, the run goes on after the home event at search speed (6099h sub 1, 'the speed for the
// travel to zero', L6151) to the axis zero point, 6064h = 0 (home_offset shifts it from the
// reference position, L6061), and brakes with 609Ah to stand there (0 ± one cycle's travel);
// 0/0/0 until it brakes, then 0/1/0 and 0/1/1 at standstill. It is what takes the axis off a
// stop (Tab. 7.1 footnote 3, L6196-6197: "the axis is not to remain at the stop, the travel to
// the axis zero point must be parameterised and the axis zero point offset must be ≠ 0"):
// with 607Ch = 0 home is the zero point and nothing moves; a zero point beyond the stop makes
// the axis block again, which is a homing error. Without the bit the axis stays where it
// braked, at a stop on the stop itself, with no torque pressing into it.
// Errors (bit 13; the axis stops with 609Ah): a limit switch ahead that the phase does not
// seek (both limit switches at once included; Festo 11-4 / 11-5), a blocked axis (following
// error as above) in a switch or index method or while crawling off a stop, no index pulse
// configured for an index method, the run exceeding config.timeout (Festo 2045h, error 11-3),
// leaving OPERATION ENABLED.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/common/expected.hpp"
#include "reference_drive/modes/operation_mode.hpp"

namespace drivecheck::reference_drive {

// What homing needs from the simulated axis (the axis model implements it through an adapter).
// Positions are position actual values (6064h units), velocities units/s.
class HomingAxis {
 public:
  virtual ~HomingAxis() = default;
  virtual double position() const = 0;
  virtual double velocity() const = 0;
  // Ramp the velocity to `velocity` with `acceleration` (units/s²; 0: at once).
  virtual void command_velocity(double velocity, double acceleration) = 0;
  virtual bool limit_negative() const = 0;
  virtual bool limit_positive() const = 0;
  virtual bool home_switch() const = 0;
  // The first index pulse passed travelling from `from` to `to` (from excluded, to included),
  // as a position actual value; nullopt when none (or the axis has no index pulse).
  virtual std::optional<double> index_pulse_between(double from, double to) const = 0;
  // Distance between index pulses (one encoder period); 0: no index pulse.
  virtual double index_period() const = 0;
  // 6064h := 6064h + delta (homing moves the coordinate system, not the axis).
  virtual void shift_position(double delta) = 0;
};

enum class HomingVendor : std::uint8_t { cia402, festo, kollmorgen, irtsa };
enum class HomingSignal : std::uint8_t {
  limit_negative,
  limit_positive,
  home_positive,
  home_negative,
  home_window,
  index_pulse,
  hard_stop_negative,
  hard_stop_positive,
  hard_stop_dref,  // Kollmorgen -3: the stop in DREF's direction
  current_position,
  current_position_tolerant,
  nearest_index,
};
enum class SwitchEdge : std::uint8_t { none, lower, upper };

// One row of homing_methods.inc.
struct HomingMethod {
  std::int8_t number = 0;
  HomingVendor vendor = HomingVendor::cia402;
  HomingSignal signal = HomingSignal::current_position;
  SwitchEdge edge = SwitchEdge::none;
  std::int8_t approach = 0;  // +1 / -1 / 0
  std::int8_t first = 0;     // +1 / -1 / 0 (by the switch state)
  bool index = false;
  bool via_limit = false;
  std::string_view source;
  std::string_view text;
};

// clang-format off
inline constexpr HomingMethod kHomingMethods[] = {
#define DRIVECHECK_HOMING_METHOD(num, vendor, signal, edge, approach, first, index, via, source, text) \
    {num, HomingVendor::vendor, HomingSignal::signal, SwitchEdge::edge, approach, first, index, via, source, text},
#include "reference_drive/modes/homing_methods.inc"
#undef DRIVECHECK_HOMING_METHOD
};
// clang-format on

// The row of `number` for a drive of `vendor`: standard rows (positive numbers) for everyone,
// negative rows only for their vendor. nullptr: no such method.
const HomingMethod* find_homing_method(std::int8_t number, HomingVendor vendor);
// Every method number a drive of `vendor` can run (standard + its own), table order.
std::vector<std::int8_t> homing_methods_of(HomingVendor vendor);

// Behaviour the deviation set (deviations.inc, family cia402/homing) or a personality switches
// on; all false: CiA 402. HomingOperationMode adds (ORs) all but halt_sets_error from
// ctx.deviations.
struct HomingDeviations {
  // homing-wrong-edge: a window method ends at the other edge of the home switch; the other
  // methods approach the edge / search the index pulse on the wrong side.
  bool wrong_edge = false;
  // homing-halt-not-reported: after a halt the bits stay "in progress" (0/0/0).
  bool halt_not_reported = false;
  // homing-error-bit-never-set: an error shows 0/0/x (bit 10 = standstill), never bit 13.
  // Also IRTSA's documented behaviour (footnote 9, 003_111f14ab1c37c28a.txt L493).
  bool no_error_bit = false;
  // homing-offset-ignored: 6064h reads 0 at home instead of 607Ch.
  bool offset_ignored = false;
  // Festo: halt sets bit 13 (homing error) instead of "interrupted" (L5584-5589).
  bool halt_sets_error = false;
  // homing-reserved-methods-accepted: 6098h writes of 16, 31, 32, 36 are confirmed, the
  // method in force stays.
  bool reserved_methods_accepted = false;
  // homing-start-ignores-halt: a rising edge of bit 4 starts homing while halt is set.
  bool start_ignores_halt = false;
  // homing-attained-cleared-on-bit4-low: a completed homing shows 0/0/1 once bit 4 is 0.
  bool attained_cleared_on_bit4_low = false;
  // homing-bit4-falling-ignored: bit 4 1 -> 0 during a homing does not interrupt it.
  bool bit4_falling_ignored = false;
  // homing-acceleration-from-profile-acceleration: the ramps use 6083h, not 609Ah.
  bool acceleration_from_profile = false;
};

struct HomingConfig {
  HomingVendor vendor = HomingVendor::cia402;
  // 6098h accepts these (empty: every method of homing_methods_of(vendor)).
  std::vector<std::int8_t> supported_methods;
  std::int8_t default_method = 17;     // Festo's default (L6096); CiA leaves it to the maker
  std::uint32_t search_speed = 2000;   // 6099h sub 1, units/s
  std::uint32_t zero_speed = 200;      // 6099h sub 2, units/s
  std::uint32_t acceleration = 20000;  // 609Ah, units/s²
  // The longest run (Festo 2045h homing_timeout, default 60000 ms, L6170-6183); 0: no limit.
  can::Duration timeout = std::chrono::seconds(60);
  // IRTSA: homing "may be executed in any state except the fault states" (L268, L423).
  bool start_outside_operation_enabled = false;
  // The following error (units) beyond which the axis counts as blocked (mechanical stop);
  // HomingObjects replaces it with 6065h while 6065h is set (not FFFFFFFFh = off).
  std::uint32_t stop_window = 500;
  // Kollmorgen DREF (352Ch) at power on: the direction of -3 until a 6098h write sets it.
  std::uint8_t kollmorgen_dref = 0;
  // The object bit that asks for the travel to zero after homing (read at each start by
  // HomingObjects); none: never (CiA 402: "homing" ends at home). Festo: 6510h:F0h mask 40h.
  struct ObjectBit {
    std::uint16_t index = 0;
    std::uint8_t sub = 0;
    std::uint32_t mask = 0;
  };
  std::optional<ObjectBit> travel_to_zero_bit;
  HomingDeviations deviations;
};

enum class HomingStatus : std::uint8_t { not_started, running, attained, interrupted, error };

struct HomingInputs {
  std::uint16_t controlword = 0;
  bool operation_enabled = false;  // PDS state OPERATION ENABLED
  bool fault = false;              // PDS state FAULT REACTION ACTIVE or FAULT
  bool mode_active = false;        // 6061h = 6
};

// The parameters of one run (the objects at the start edge).
struct HomingParameters {
  std::int8_t method = 17;
  std::int32_t home_offset = 0;
  std::uint32_t search_speed = 0;
  std::uint32_t zero_speed = 0;
  std::uint32_t acceleration = 0;
  std::uint32_t stop_window = 500;  // following error that means "blocked" (6065h)
  bool travel_to_zero = false;      // after the home event, on to 6064h = 0 (config above)
};

class HomingMode {
 public:
  explicit HomingMode(HomingConfig config = {});

  // 6098h: invalid_value for a method the drive does not support, cannot_transfer_device_state
  // while a run is active (Festo L6119: "can only be set when homing is not active").
  Expected<void, cia301::SdoAbort> check_method(std::int8_t method) const;
  Expected<void, cia301::SdoAbort> set_method(std::int8_t method);
  void set_home_offset(std::int32_t offset) { params_.home_offset = offset; }
  void set_search_speed(std::uint32_t speed) { params_.search_speed = speed; }
  void set_zero_speed(std::uint32_t speed) { params_.zero_speed = speed; }
  void set_acceleration(std::uint32_t acceleration) { params_.acceleration = acceleration; }
  void set_stop_window(std::uint32_t window) { params_.stop_window = window; }
  void set_travel_to_zero(bool on) { params_.travel_to_zero = on; }
  // Kollmorgen DREF (direction of -3): 0 negative, 1 positive, 2 by distance (method -1).
  std::uint8_t kollmorgen_dref() const { return dref_; }
  const HomingParameters& parameters() const { return params_; }

  // One drive cycle. Commands the axis only while it runs or stops a run it started.
  void step(can::TimePoint now, const HomingInputs& inputs, HomingAxis& axis);
  // Power on / reset: not started, nothing homed; parameters kept.
  void reset();

  HomingStatus status() const { return status_; }
  bool running() const { return status_ == HomingStatus::running; }
  // Bits 10, 12, 13 as tabulated above (call with 6061h = 6; other modes own these bits).
  std::uint16_t statusword_bits() const;
  // A run ended successfully since power on (IRTSA bit 8 "home position set", Festo bit 15).
  bool homed() const { return homed_; }
  // Where the last home event was (6064h value after the shift = the home offset then).
  std::optional<double> home_position() const { return home_position_; }
  can::TimePoint started_at() const { return started_; }
  std::optional<can::TimePoint> finished_at() const { return finished_; }
  // demand − actual of the velocity profile the mode commands (the stop detection), units.
  double following_error() const { return following_error_; }
  const HomingConfig& config() const { return config_; }
  void set_deviations(const HomingDeviations& deviations) { config_.deviations = deviations; }

 private:
  enum class Phase : std::uint8_t {
    to_limit,     // travel dir_ to the limit switch / stop (window reversal, via_limit, stop)
    seek_window,  // outside the window: travel dir_ until the home switch turns active
    leave,        // travel dir_ until the signal shows the level before the edge
    approach,     // travel dir_ (the approach direction) until the signal changes: the edge
    index,        // travel dir_ to the first index pulse
    to_zero,      // home found: travel dir_ to 6064h = 0 (travel_to_zero)
    stopping,     // home found: decelerate
  };
  void start(can::TimePoint now, HomingAxis& axis);
  void begin_switch_search(HomingAxis& axis);
  void inside_window(HomingAxis& axis);
  void after_edge(double edge_position, HomingAxis& axis);
  void home_found(double position, HomingAxis& axis);
  bool zero_reached(const HomingAxis& axis) const;  // travel to zero: brake now
  void fail(HomingAxis& axis);
  void interrupt(bool as_error, HomingAxis& axis);
  void move(Phase phase, int direction, bool crawl, HomingAxis& axis);
  bool signal_level(const HomingAxis& axis) const;
  bool level_after_edge() const;  // the signal level after crossing the edge in approach_
  void track_demand(const HomingAxis& axis);  // following error of the commanded profile
  void run_phase(HomingAxis& axis);

  HomingConfig config_;
  HomingParameters params_;
  HomingParameters active_;  // latched at the start
  const HomingMethod* method_ = nullptr;
  int approach_ = 0;  // after deviations
  SwitchEdge edge_ = SwitchEdge::none;

  HomingStatus status_ = HomingStatus::not_started;
  Phase phase_ = Phase::to_limit;
  int dir_ = 0;
  bool reversed_ = false;  // window search reversed once at a limit
  double last_position_ = 0.0;
  bool mode_was_active_ = false;
  can::TimePoint now_{};
  bool standstill_ = true;
  bool homed_ = false;
  bool halted_ = false;  // the run ended by halt
  bool previous_bit4_ = false;
  std::uint8_t dref_ = 0;
  int stop_direction_ = 0;  // first travel of a stop method (Kollmorgen -3: from DREF)
  // The commanded velocity profile (the stop detection): target, ramp, demand position.
  double target_velocity_ = 0.0;
  double ramp_velocity_ = 0.0;
  double demand_position_ = 0.0;
  double following_error_ = 0.0;
  can::TimePoint demand_at_{};
  std::optional<double> home_position_;
  can::TimePoint started_{};
  std::optional<can::TimePoint> finished_;
};

// ---------------------------------------------------------------------------------------------
// The homing objects (607Ch, 6098h, 6099h sub 0..2, 609Ah) in an object dictionary, with the
// config's defaults. 6098h's range is the supported set (validator in HomingObjects).
Expected<void, std::string> add_homing_objects(cia301::ObjectDictionary& od,
                                               const HomingConfig& config);

// Binds a HomingMode to those objects: 6098h's write validator (check_method), and each step()
// reads 607Ch, 6098h, 6099h, 609Ah into the mode before HomingMode::step. The validator stays
// in the dictionary (it refers to `mode`): the dictionary must not outlive the mode. In the
// reference drive it does not (the drive owns the dictionary; the application, which owns the
// mode, outlives the drive: device.hpp DriveConfig::application), and the destructor must not
// touch the dictionary, which is gone by then.
class HomingObjects {
 public:
  HomingObjects(cia301::ObjectDictionary& od, HomingMode& mode);
  HomingObjects(const HomingObjects&) = delete;
  HomingObjects& operator=(const HomingObjects&) = delete;

  void read_parameters();
  void step(can::TimePoint now, const HomingInputs& inputs, HomingAxis& axis);

 private:
  cia301::ObjectDictionary& od_;
  HomingMode& mode_;
};

// ---------------------------------------------------------------------------------------------
// HomingAxis over the simulated axis (axis_model.hpp) in user units (the factor group): the
// switches of its SwitchLayout, its index pulses (index_offset + k·index_period, physical
// frame), set_actual_position() for the shift. The mechanical end stops of the layout block
// the axis (axis_model.hpp); the mode sees them only through the following error.
class AxisModelHomingAxis final : public HomingAxis {
 public:
  AxisModelHomingAxis(AxisModel& axis, const FactorGroup& factors)
      : axis_(axis), factors_(factors) {}
  double position() const override;
  double velocity() const override;
  void command_velocity(double velocity, double acceleration) override;
  bool limit_negative() const override { return axis_.switch_active(AxisSwitch::negative_limit); }
  bool limit_positive() const override { return axis_.switch_active(AxisSwitch::positive_limit); }
  bool home_switch() const override { return axis_.switch_active(AxisSwitch::home); }
  std::optional<double> index_pulse_between(double from, double to) const override;
  double index_period() const override;
  void shift_position(double delta) override;

 private:
  double internal_period() const;
  AxisModel& axis_;
  const FactorGroup& factors_;
};

// The homing mode as the Cia402Application hosts it (operation_mode.hpp): 6060h = 6.
class HomingOperationMode final : public OperationMode {
 public:
  explicit HomingOperationMode(HomingConfig config = {})
      : base_deviations_(config.deviations), mode_(std::move(config)) {}
  std::int8_t mode() const override { return 6; }
  // 607Ch, 6098h, 6099h, 609Ah, and the binding (6098h validator).
  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override;
  void on_reset(ModeContext& ctx) override;
  void enter(ModeContext& ctx, const ModeCycle& cycle) override;
  void leave(ModeContext& ctx, const ModeCycle& cycle) override;
  void cycle(ModeContext& ctx, const ModeCycle& cycle) override;
  std::uint16_t statusword_bits(cia402::State state) const override;

  const HomingMode& homing() const { return mode_; }

 private:
  void apply_deviations(const ModeContext& ctx);
  HomingDeviations base_deviations_;  // the config's (personality), before ctx.deviations
  HomingMode mode_;
  std::optional<HomingObjects> objects_;
};

}  // namespace drivecheck::reference_drive
