// The typed model of a test vector (vectors/FORMAT.md): what vector_file.cpp makes of the YAML
// and what the engine runs. Every value here is already validated; only the things that depend
// on the run (the DUT's node-ID `N`, `$timing.<key>` durations, saved values) are resolved
// when the vector runs.
//
// A step is one struct per action of the closed vocabulary, held in a std::variant; each step
// keeps its file line so that a harness error or a failed check can point at the YAML.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "conformance/result.hpp"
#include "protocol/can/bus.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/cia402/state_machine.hpp"

namespace drivecheck::conformance {

// A duration: a literal (`100ms`) or a profile timing name (`$timing.sdo_response`).
struct DurationSpec {
  can::Duration value{0};
  std::string timing;  // non-empty: the timing key, resolved against the profile at run time
  bool is_timing() const { return !timing.empty(); }
  friend bool operator==(const DurationSpec&, const DurationSpec&) = default;
};

// A COB-ID: `080` (absolute) or `600+N` (base plus the DUT's node-ID).
struct CobIdSpec {
  std::uint32_t base = 0;
  bool plus_node = false;
  bool extended = false;  // written with 8 hex digits (29-bit)
  std::uint32_t resolve(std::uint8_t node) const { return plus_node ? base + node : base; }
  friend bool operator==(const CobIdSpec&, const CobIdSpec&) = default;
};

// A frame or frame pattern in candump compact syntax with `+N`, `..` and a trailing `*`.
struct FrameSpec {
  std::string text;  // as written, for messages
  CobIdSpec cob;
  bool remote = false;
  std::uint8_t dlc = 0;                            // remote: the DLC; data: byte count
  std::vector<std::optional<std::uint8_t>> bytes;  // nullopt: `..` (patterns only)
  bool any_tail = false;                           // pattern ended in `*`
  // The frame to send (node substituted); patterns with `..` never reach here (loader).
  can::Frame to_frame(std::uint8_t node) const;
  bool matches(const can::Frame& frame, std::uint8_t node) const;
  friend bool operator==(const FrameSpec&, const FrameSpec&) = default;
};

// A value that is a literal or a value saved earlier in the vector (`$name`), optionally plus
// or minus a literal (`$name+400`, `$name-2`: arithmetic on read values, e.g. a distance in
// increments from a position read before a move).
struct ValueSpec {
  std::int64_t literal = 0;
  std::string saved;        // non-empty: the name given to an earlier sdo_read's `save:`
  std::int64_t offset = 0;  // with `saved`: added to the saved value
  // With `saved`: `$name*multiplier/divisor+offset`, the division rounding toward zero (a
  // bound on a measured ratio, e.g. a speed with an acceleration factor of 4/1 against the same
  // speed with 1/1: FORMAT.md "Saved values").
  std::int64_t multiplier = 1;
  std::int64_t divisor = 1;
  friend bool operator==(const ValueSpec&, const ValueSpec&) = default;
};

// `$name*m/d+k` as a vector writes it (`$name`, `$name+k`, `$name*m/d` ...), or the literal.
std::string to_text(const ValueSpec& value);

enum class NodeKind : std::uint8_t { dut, broadcast, other, value };
struct NodeSpec {
  NodeKind kind = NodeKind::dut;
  std::uint8_t value = 0;  // NodeKind::value
  friend bool operator==(const NodeSpec&, const NodeSpec&) = default;
};

// complete_access: CoE SDO with the complete access bit (ETG.1000.6), EtherCAT only: sub-index
// 0 or 1 and every entry of the object in one transfer.
enum class Transfer : std::uint8_t { automatic, expedited, segmented, block, complete_access };

// The abort codes an expectation accepts (vectors/FORMAT.md "Accepted abort sets"): a named
// set of protocol/cia301/sdo_abort_sets.inc (`abort: write-read-only`), or a literal list
// (`abort: [0x06090030]`) that `clause:` justifies (the lint refuses a literal list without it).
struct AbortExpect {
  std::vector<std::uint32_t> codes;  // the set's codes or the literal list; empty: any code
  std::string set;                   // the set's name; empty: a literal list
  std::string citation;              // the set's citation (filled from the table)
  std::string clause;                // `clause:` as written; empty if none
  std::size_t line = 0;              // YAML line of `abort:`
  bool any() const { return codes.empty(); }
  bool accepts(std::uint32_t code) const;
  // "abort in write-read-only {06010000h, 06010002h, 08000000h} (CTT 2.3, 4.3; CiA 301
  // §7.2.4.3.17)", "abort in {06090030h} (CiA 301 §7.5.2.4)", "any abort (...)".
  std::string describe() const;
  // The named set (its codes and citation from the table); nullopt for an unknown name.
  static std::optional<AbortExpect> named(std::string_view set_name);
  // Equal in meaning (the YAML line is not compared).
  friend bool operator==(const AbortExpect& a, const AbortExpect& b) {
    return a.codes == b.codes && a.set == b.set && a.citation == b.citation && a.clause == b.clause;
  }
};

// What an SDO step accepts as the answer.
struct SdoExpect {
  // ok_or_abort: the DUT confirms or aborts, either passes (CiA 301 leaves it the choice: a
  // refusal meets the requirement); only no answer fails. Later steps judge the effect.
  enum class Kind : std::uint8_t { ok, value, range, size, data, abort, ok_or_abort };
  Kind kind = Kind::ok;
  ValueSpec value;
  std::optional<std::uint64_t> mask;
  ValueSpec low;  // Kind::range: each bound a literal or `$name±k`
  ValueSpec high;
  std::size_t size = 0;
  std::vector<std::uint8_t> data;
  AbortExpect abort;  // Kind::abort
  // Generated checks only (conformance/od_checks.hpp; no YAML form): with Kind::ok or
  // Kind::value, an abort in this set also meets the expectation, where CiA lets the device
  // refuse (an optional sub-index such as FFh absent, a parameter not writable while valid).
  std::optional<AbortExpect> or_abort;
  // Generated checks only (esi_checks.hpp; no YAML form): the read is entry `sub` of a PDO
  // mapping object (1600h+/1A00h+), judged against the objects the ESI lets that direction
  // map. Past the mapping's count (sub 0, saved as `count` by an earlier step) the entry is not
  // in use: not read, it passes. In use, its value (index << 16 | sub-index << 8 | bits) MUST
  // name an entry in `mappable` (index << 8 | sub-index, sorted), or be a gap (index 0, or a
  // CiA 301 dummy entry 0001h-0007h).
  struct MappingEntry {
    std::string count;
    std::vector<std::uint32_t> mappable;
    std::string direction;  // for the messages: "RxPDO-mappable (PdoMapping R)"
    friend bool operator==(const MappingEntry&, const MappingEntry&) = default;
  };
  std::optional<MappingEntry> mapping_entry;
  friend bool operator==(const SdoExpect&, const SdoExpect&) = default;
};

// ---- stimuli ----
struct SendStep {
  FrameSpec frame;
  friend bool operator==(const SendStep&, const SendStep&) = default;
};
struct NmtStep {
  cia301::NmtCommand command = cia301::NmtCommand::start;
  NodeSpec node;
  friend bool operator==(const NmtStep&, const NmtStep&) = default;
};
struct SdoWriteStep {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::optional<ValueSpec> value;  // with size
  std::optional<std::size_t> size;
  std::vector<std::uint8_t> data;  // `data:` form (value absent)
  Transfer transfer = Transfer::automatic;
  SdoExpect expect;  // ok or abort
  // `refused_means_not_applicable: <set>`: the value is one CiA lets the device refuse (the
  // step's `clause:` cites where). With `expect: ok` only: an abort in this set makes the
  // vector not applicable, naming the refusal; any other abort fails as usual.
  std::optional<AbortExpect> refused_means_not_applicable;
  friend bool operator==(const SdoWriteStep&, const SdoWriteStep&) = default;
};
struct SdoReadStep {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  Transfer transfer = Transfer::automatic;
  SdoExpect expect;
  bool is_signed = false;
  std::string save;
  // `relative_to: name` (with `signed: true`): the value judged and saved is the value read
  // minus the one saved as `name`, e.g. the distance the axis moved between two reads of 6064h
  // (FORMAT.md "Saved values").
  std::string relative_to{};
  std::uint8_t block_size = 0;  // `block_size:` with transfer: block (1..127); 0 = default
  friend bool operator==(const SdoReadStep&, const SdoReadStep&) = default;
};
struct WaitStep {
  DurationSpec duration;
  friend bool operator==(const WaitStep&, const WaitStep&) = default;
};
struct ControlwordStep {
  std::uint16_t value = 0;
  friend bool operator==(const ControlwordStep&, const ControlwordStep&) = default;
};
struct SimulateStep {
  std::string input;
  std::int64_t value = 0;
  friend bool operator==(const SimulateStep&, const SimulateStep&) = default;
};
// The DUT's CAN controller is bus-off for `duration` (it neither sends nor receives), then
// recovers; the step ends at the recovery. Needs a DUT on the simulated bus (SimulationControl).
struct BusOffStep {
  DurationSpec duration;
  friend bool operator==(const BusOffStep&, const BusOffStep&) = default;
};
struct MarkStep {
  std::string name;
  friend bool operator==(const MarkStep&, const MarkStep&) = default;
};

// ---- expectations ----
struct ExpectFrameStep {
  FrameSpec pattern;
  // `abort:` beside an SDO abort pattern (byte 0 80h, code bytes 4..7 `..`): the frame's code
  // must be in the set. nullopt: the pattern alone decides (then a fixed abort code in it needs
  // `clause:`).
  std::optional<AbortExpect> abort;
  std::string clause;  // `clause:` for a pattern with a literal abort code
  // `or:` other patterns that also meet the expectation (a clause that allows a refusal or a
  // recovery, e.g. an abort with any code or a block acknowledge asking for retransmission).
  // `abort:` judges only a frame that matched `pattern`.
  std::vector<FrameSpec> alternatives;
  DurationSpec within{{}, "response"};
  std::string mark;
  std::string since;
  friend bool operator==(const ExpectFrameStep&, const ExpectFrameStep&) = default;
};
struct ExpectSilenceStep {
  bool any = false;
  std::vector<CobIdSpec> cob_ids;
  // Frame patterns (`1A0#..*`: a frame on 1A0h with at least one data byte): no frame that
  // matches one may come. Lets a vector allow what the standard allows on the same COB-ID.
  std::vector<FrameSpec> patterns;
  DurationSpec duration;  // `for:`
  std::string since;
  friend bool operator==(const ExpectSilenceStep&, const ExpectSilenceStep&) = default;
};
struct ExpectBootupStep {
  DurationSpec within{{}, "bootup"};
  std::string mark;
  std::string since;
  friend bool operator==(const ExpectBootupStep&, const ExpectBootupStep&) = default;
};
struct ExpectHeartbeatStep {
  cia301::NmtState state = cia301::NmtState::pre_operational;
  std::optional<DurationSpec> within;  // default: 1.5 x 1017h when known, else response
  std::string mark;
  std::string since;
  friend bool operator==(const ExpectHeartbeatStep&, const ExpectHeartbeatStep&) = default;
};
struct ExpectEmcyStep {
  std::vector<std::uint16_t> codes;  // empty with any_error
  // `code: error`: any error code but 0000h (the error reset), for a vector whose subject is
  // the EMCY's register, history or timing, not which code the device chose for its error.
  bool any_error = false;
  std::optional<std::uint8_t> register_mask;
  std::uint8_t register_value = 0;
  std::vector<std::optional<std::uint8_t>> manufacturer;  // pattern over bytes 3..7
  DurationSpec within{{}, "response"};
  std::string mark;
  std::string since;
  bool accepts(std::uint16_t code) const {
    return any_error ? code != 0 : std::find(codes.begin(), codes.end(), code) != codes.end();
  }
  friend bool operator==(const ExpectEmcyStep&, const ExpectEmcyStep&) = default;
};
struct ExpectStateStep {
  cia402::State state = cia402::State::switch_on_disabled;
  DurationSpec within{{}, "state_change"};
  friend bool operator==(const ExpectStateStep&, const ExpectStateStep&) = default;
};
struct ExpectStatuswordStep {
  std::uint16_t mask = 0xFFFF;
  std::uint16_t value = 0;
  DurationSpec within{{}, "state_change"};
  friend bool operator==(const ExpectStatuswordStep&, const ExpectStatuswordStep&) = default;
};
struct PollStep {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint64_t value = 0;
  std::uint64_t mask = ~std::uint64_t{0};
  // `range: [lo, hi]` instead of value/mask: read until the value is within both bounds (each
  // a literal or `$name±k`, as sdo_read's); `signed: true` reads it as signed. For a value that
  // moves into a window whatever a status bit says (6064h after a homing the vector started,
  // where bit 12 may still show an earlier one).
  std::optional<std::pair<ValueSpec, ValueSpec>> range;
  bool is_signed = false;
  DurationSpec within;
  DurationSpec every{{}, "poll"};
  friend bool operator==(const PollStep&, const PollStep&) = default;
};
// Between two marks: the time (min/max durations), or with `frames:` the number of frames
// matching that pattern (or any of a list of patterns) on the bus in between, the harness's own
// (by their loopback echo) and the DUT's (min_count/max_count): e.g. the SYNCs between two
// synchronous TPDOs, which judges "every n-th SYNC" by the SYNCs that were on the bus, whenever
// the harness sent them; or the synchronous TPDOs on several COB-IDs after one SYNC.
struct MeasureStep {
  std::string from;
  std::string to;
  std::optional<DurationSpec> min;
  std::optional<DurationSpec> max;
  std::vector<FrameSpec> frames;  // empty: a time measure
  std::optional<std::size_t> min_count;
  std::optional<std::size_t> max_count;
  friend bool operator==(const MeasureStep&, const MeasureStep&) = default;
};
struct ExpectPeriodicStep {
  CobIdSpec cob;
  DurationSpec period;
  DurationSpec tolerance{{}, "heartbeat_tolerance"};
  std::size_t count = 2;
  std::string mark;  // the first frame
  std::string last;  // the last frame (with `mark:`, a measure over all the periods)
  friend bool operator==(const ExpectPeriodicStep&, const ExpectPeriodicStep&) = default;
};

// ---- raw SDO on every link (FORMAT.md "Raw SDO steps") ----

// `sdo_request: "<8 octets>"`: one SDO request exactly as CiA 301 §7.2.4.3 lays it out
// (command, index, sub-index, 4 data octets). On CAN it is the frame 600h+N with these octets
// (`send` is the CAN form, kept here); on EtherCAT a CoE SDO request (ETG.1000.6: the CoE
// header, number 0 and service 2, then the same 8 octets) in the write mailbox.
struct SdoRequestStep {
  SendStep send;  // 600+N#<octets>
  friend bool operator==(const SdoRequestStep&, const SdoRequestStep&) = default;
};
// `expect_sdo_response: "<8-octet pattern>"` (`..` don't care) with the modifiers of
// expect_frame (within, abort, clause, or, mark): on CAN the expect_frame of 580h+N with that
// pattern (kept here, and run by the same code); on EtherCAT a CoE SDO response (service 3)
// from the read mailbox whose first 8 octets after the CoE header match, by the same matcher.
struct ExpectSdoResponseStep {
  ExpectFrameStep expect;  // 580+N#<pattern>; `since:` is refused by the loader
  friend bool operator==(const ExpectSdoResponseStep&, const ExpectSdoResponseStep&) = default;
};
// ---- the cyclic modes' set-points on every link (FORMAT.md "Cyclic set-points") ----

// One set-point of a `cyclic` step: an object the master delivers every cycle (607Ah, 60FFh,
// 6071h, the offsets 60B0h-60B2h, 60C1h:01), `size` octets (its PDO mapping length on EtherCAT).
struct CyclicSetPoint {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  ValueSpec value;
  std::size_t size = 4;
  friend bool operator==(const CyclicSetPoint&, const CyclicSetPoint&) = default;
};
// `cyclic: {cycles: N, period: D}` with `set:` (optional): N synchronisation cycles `period`
// apart, the set-points given from the first one on. On CAN each set-point is an SDO download
// (expect ok) before the first cycle and each cycle a SYNC (080h) and a wait of `period` (the
// frames and timing the vectors had as sdo_write, send "080#", wait). On EtherCAT the
// set-points go into the process data outputs (the setup maps them into the first RxPDO of
// 1C12h in PREOP: ethercat_port.hpp) and the process data cycle carries them for N x `period`.
struct CyclicStep {
  std::size_t cycles = 1;
  DurationSpec period;
  std::vector<CyclicSetPoint> set;
  friend bool operator==(const CyclicStep&, const CyclicStep&) = default;
};

// ---- EtherCAT only (FORMAT.md "EtherCAT steps"): a vector with one is `transports:
// [ethercat]` in effect (not applicable on CAN, verdict.hpp) ----

// What an AL state step accepts: the AL status (0130h) state and error indication, and with the
// error indication the AL status code (0134h) in an accepted set of al_status_codes.inc.
struct AlExpect {
  std::uint8_t state = 0;  // the AL state's value (1 INIT, 2 PREOP, 3 BOOT, 4 SAFEOP, 8 OP)
  bool error = false;
  std::vector<std::uint16_t> codes;  // error: the accepted codes (never empty then)
  std::vector<std::string> names;    // their names as written
  friend bool operator==(const AlExpect&, const AlExpect&) = default;
};
// `al_request: op`: the master requests the AL state. Expecting it reached (the default), the
// master goes there as in a bring-up (mailbox and process data SMs configured on the way up,
// the cycle running from SAFEOP); expecting a refusal (`expect: {error: true}`), the request is
// written to 0120h as it is, from the state the slave is in, and afterwards the error is
// acknowledged and the slave put back where the master held it.
struct AlRequestStep {
  std::uint8_t state = 0;
  AlExpect expect;  // state 0: the requested state, no error
  DurationSpec within{{}, "state_change"};
  friend bool operator==(const AlRequestStep&, const AlRequestStep&) = default;
};
// `expect_al: {state, error, code}`: AL status (0130h) and code (0134h), polled until `within`.
struct ExpectAlStep {
  AlExpect expect;
  DurationSpec within{{}, "state_change"};
  friend bool operator==(const ExpectAlStep&, const ExpectAlStep&) = default;
};
// `process_data: {cycles: N}`: N process data cycles (one LRW each, every 1 ms), each with the
// working counter the configuration gives (outputs +2, inputs +1 per slave) and the AL state
// the master holds, without error.
struct ProcessDataStep {
  std::size_t cycles = 1;
  friend bool operator==(const ProcessDataStep&, const ProcessDataStep&) = default;
};
// `pause_process_data: watchdog | DURATION`: no process data for that long (`watchdog`: twice
// the SM watchdog time the slave's ESC holds, 0400h/0420h); the cycle runs again afterwards.
struct PauseProcessDataStep {
  std::optional<DurationSpec> duration;  // nullopt: `watchdog`
  friend bool operator==(const PauseProcessDataStep&, const PauseProcessDataStep&) = default;
};
// `mailbox_repeat: {index, sub, size, value, repeat}`: a CoE SDO download of `value` with the
// master's next mailbox counter, answered; then a download of `repeat` with the same counter
// (a repeated mailbox request, which the slave must not execute again); then an upload of
// the object must give `value`.
struct MailboxRepeatStep {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::size_t size = 4;
  std::int64_t value = 0;
  std::int64_t repeat = 0;
  friend bool operator==(const MailboxRepeatStep&, const MailboxRepeatStep&) = default;
};
// `power_cycle: {}`: the DUT is switched off and on again, then brought up to PREOP by the
// master (scan, SII, INIT, PREOP): EtherCAT's counterpart of CANopen's reset node for what
// is stored (1010h/1011h). Only the emulated slave of `ethercat:sim` can be power-cycled by
// the harness: a vector with it requires `simulation`.
struct PowerCycleStep {
  friend bool operator==(const PowerCycleStep&, const PowerCycleStep&) = default;
};

using Action =
    std::variant<SendStep, NmtStep, SdoWriteStep, SdoReadStep, WaitStep, ControlwordStep,
                 SimulateStep, MarkStep, ExpectFrameStep, ExpectSilenceStep, ExpectBootupStep,
                 ExpectHeartbeatStep, ExpectEmcyStep, ExpectStateStep, ExpectStatuswordStep,
                 PollStep, MeasureStep, ExpectPeriodicStep, BusOffStep, AlRequestStep, ExpectAlStep,
                 ProcessDataStep, PauseProcessDataStep, MailboxRepeatStep, SdoRequestStep,
                 ExpectSdoResponseStep, CyclicStep, PowerCycleStep>;

// The action key of each alternative, in variant order ("send", "nmt", ...).
std::string_view action_name(const Action& action);

// A `repeat:` a step ran in (FORMAT.md "Repeated steps"): the loader unrolls `repeat: {times,
// steps}` into `times` copies of its steps, each copy knowing the repeat and the pass it is.
struct StepRepeat {
  std::size_t number = 0;     // the repeat's own step number (Step::number)
  std::size_t times = 0;      // 1..kMaxRepeatTimes
  std::size_t iteration = 0;  // 1..times
  std::string note;           // the repeat's `note:`
  std::size_t line = 0;       // YAML line of the repeat
  // Equal in meaning (the YAML line is not compared).
  friend bool operator==(const StepRepeat& a, const StepRepeat& b) {
    return a.number == b.number && a.times == b.times && a.iteration == b.iteration &&
           a.note == b.note;
  }
};
inline constexpr std::size_t kMaxRepeatTimes = 1000;
inline constexpr std::size_t kMaxRepeatDepth = 2;        // a repeat in a repeat, no deeper
inline constexpr std::size_t kMaxUnrolledSteps = 10000;  // per step list, after unrolling

struct Step {
  Action action;
  std::string note;
  std::size_t line = 0;
  // `clause:` on the step: the clause (CiA) or manual line that gives its literal time bound
  // (FORMAT.md "Timing"), and for expect_frame also its literal abort code. Last, so that the
  // aggregate initialisations {action, note, line} keep their meaning.
  std::string clause;
  // The step's number as the file lists the steps, from 1, a `repeat:` and each step in it
  // counted once (in document order); every report and message uses it. 0: not set (a step
  // made in code: its position + 1, see step_number).
  std::size_t number = 0;
  // The repeats it runs in, outermost first (empty: none), with the pass of each.
  std::vector<StepRepeat> repeats = {};
};

// The number of steps[index] as messages and reports give it (Step::number, else index + 1).
std::size_t step_number(const std::vector<Step>& steps, std::size_t index);
// The passes of the repeats a step runs in, outermost first (result.hpp Iteration).
std::vector<Iteration> iterations_of(const Step& step);
// "step 19" or "step 19 (iteration 117 of 254)" (result.hpp step_label).
std::string step_place(const std::vector<Step>& steps, std::size_t index);

// The CAN form of a step: the SendStep of a `send` or an `sdo_request`, the ExpectFrameStep of
// an `expect_frame` or an `expect_sdo_response` (nullptr otherwise).
const SendStep* frame_sent(const Step& step);
const ExpectFrameStep* frame_expected(const Step& step);

// A parsed source citation.
struct Source {
  std::string text;       // as written
  std::string manual;     // manual file, or "" for a CiA clause
  std::string section;    // "3.2.2" / the clause
  std::size_t first = 0;  // manual lines (0 for a CiA clause)
  std::size_t last = 0;
  std::size_t line = 0;  // YAML line of the citation
};

enum class Setup : std::uint8_t { reset_node, reset_communication, restore_defaults, none };

struct Vector {
  std::string id;
  std::string title;
  std::vector<Source> sources;
  Level level = Level::must;
  std::vector<std::string> requires_features;  // `requires:`; `motion` added by motion: true
  // `unless:` features (no object needs): not applicable where the profile has one of them
  // (claimed, or detected present); for a vector whose twin judges such a device at another
  // level (dummy mapping: should without pdo.dummy-mapping, must with it).
  std::vector<std::string> unless_features;
  std::vector<std::string> profiles;
  // `transports:` the links the vector is written for ("can", "ethercat"); empty: any link its
  // steps can run on (a frame-level step makes it CAN-only: verdict.hpp).
  std::vector<std::string> transports;
  bool motion = false;
  Setup setup = Setup::reset_node;
  std::optional<cia301::NmtState> nmt = cia301::NmtState::pre_operational;  // nullopt: `none`
  std::optional<cia402::State> drive_state;
  DurationSpec timeout{std::chrono::seconds(30), {}};  // whole-vector limit
  std::vector<Step> steps;
  // `finally:` (FORMAT.md "Isolation"): steps that always run after `steps:`, whatever the
  // verdict, with their own time budget (the vector's `timeout:` again), before the engine's
  // teardown and restore. Their failures are harness notes, never the vector's verdict.
  std::vector<Step> finally_steps;
  std::string note;
  std::string file;  // as given to the loader
  std::size_t line = 0;
  // Generated vectors only (conformance/od_checks.hpp; no YAML form): not applicable by a cited
  // rule, this the reason (e.g. an entry whose write has side effects is not written back).
  std::string not_applicable;

  // First two id components: "cia301/sdo".
  std::string family() const;
  // Whether a step puts the DUT's controller bus-off (`bus_off`).
  bool has_bus_off_step() const;
  // The first EtherCAT-only step (steps: then finally:) as "steps: step 2 (al_request)", or "".
  std::string ethercat_only_step() const;
  // The set-points of the vector's `cyclic` steps (steps: then finally:), each object once.
  std::vector<CyclicSetPoint> cyclic_set_points() const;
  bool has_cyclic_step() const;
};

}  // namespace drivecheck::conformance
