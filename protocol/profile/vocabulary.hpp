// The closed vocabularies of drive profiles and vectors (vectors/FORMAT.md): feature names,
// option-code objects, timing names, durations, and the glob syntax of deviation vector lists.
// One table each, here; the profile loader, the vector loader and the linter use these.
//
// Features (FORMAT.md "Features"):
//   sdo.segmented sdo.block sdo.expedited nmt.guarding heartbeat.producer heartbeat.consumer
//   emcy emcy.inhibit emcy.history sync sync.producer sync.counter time pdo
//   pdo.dynamic-mapping pdo.dummy-mapping pdo.rtr pdo.event-timer pdo.inhibit pdo.sync-window store
//   restore cia402 hardware-enable hardware-enable.transition-2 hardware-enable.transition-3
//   mode.pp mode.vl mode.pv mode.tq mode.hm mode.ip mode.csp mode.csv mode.cst transition.16
//   simulation motion homing.method.<n>            n: decimal integer -128..127 (CiA 402 or
//   manufacturer method) option.<object>.<value>      object: an option-code name below; value:
//   decimal -32768..32767 object.IIII object.IIII.SS          an object need (vectors only): index
//   IIII, sub-index SS,
//                                       upper-case hex, 4 and 2 digits ("object.1029",
//                                       "object.1018.02"). The vector is N/A where the device
//                                       lacks it (EDS or SDO probe, conformance/capabilities.hpp)
//
// Option-code objects (CiA 402-2 §8.4, INTEGER16 each):
//   quick-stop 605Ah   shutdown 605Bh   disable-operation 605Ch   halt 605Dh
//   fault-reaction 605Eh   abort-connection 6007h
//
// Durations: an integer and a unit, no space: "100ms", "2s", "250us", "5ns", "1min"; a value
// of 0 is allowed ("0ms"). Negative durations and fractions are errors.
//
// Globs (deviation `vectors:`): `*` matches any run of characters (including '/'), `?` one
// character; every other character matches itself. A vector id is [a-z0-9/._-]+.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "protocol/can/bus.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::profile {

// --- option codes ------------------------------------------------------------------------------

enum class OptionCode : std::uint8_t {
  quick_stop,         // 605Ah
  shutdown,           // 605Bh
  disable_operation,  // 605Ch
  halt,               // 605Dh
  fault_reaction,     // 605Eh
  abort_connection,   // 6007h
};
inline constexpr std::size_t kOptionCodeCount = 6;

struct OptionCodeInfo {
  OptionCode code;
  std::string_view name;  // "quick-stop"
  std::uint16_t index;    // 605Ah
};
std::span<const OptionCodeInfo> option_code_table();
const OptionCodeInfo& info(OptionCode code);
std::string_view to_string(OptionCode code);
std::optional<OptionCode> parse_option_code(std::string_view name);

// --- features ----------------------------------------------------------------------------------

// The fixed feature names (without the homing.method.<n> and option.<object>.<value> families).
std::span<const std::string_view> fixed_features();
// Whether `name` belongs to the closed vocabulary (fixed names and the two families).
bool is_known_feature(std::string_view name);
// The features a generic profile may leave to probing (`detect:`): each has a probe in
// conformance/capabilities.cpp (present, absent or unknown, decided once per run).
std::span<const std::string_view> detectable_features();
bool is_detectable_feature(std::string_view name);
// The feature name of a mode of operation (1 -> "mode.pp"); nullopt for values without one.
std::optional<std::string_view> mode_feature(int mode);
std::string homing_method_feature(int method);           // "homing.method.35"
std::string option_feature(OptionCode code, int value);  // "option.quick-stop.6"

// An object need of a vector's `requires:` ("object.1029", "object.1018.02").
struct ObjectNeed {
  std::uint16_t index = 0;
  std::optional<std::uint8_t> sub;  // nullopt: the object (probed and looked up at sub 0)
  friend bool operator==(const ObjectNeed&, const ObjectNeed&) = default;
  friend auto operator<=>(const ObjectNeed&, const ObjectNeed&) = default;
};
// The need a token names, in its canonical spelling only; nullopt for anything else.
std::optional<ObjectNeed> parse_object_need(std::string_view token);
std::string object_need_feature(const ObjectNeed& need);  // "object.1018.02"
// "1029h", "1018h sub 2": for messages.
std::string describe(const ObjectNeed& need);

// --- timing ------------------------------------------------------------------------------------

struct TimingName {
  std::string_view name;  // "sdo_response"
  can::Duration default_value;
  std::string_view meaning;
  // The clause that gives the bound, or why it is a timeout / tolerance / harness value
  // (timing_defaults.inc).
  std::string_view basis;
};
std::span<const TimingName> timing_table();
const TimingName* find_timing(std::string_view name);

// Which units a duration may use: files (vectors, profiles) count up to minutes; the command
// line (--duration of a fuzz or soak run) also takes hours.
enum class DurationUnits { up_to_minutes, up_to_hours };
// "100ms" -> 100 ms: a whole number and a unit (ns us ms s min, and h if asked).
// Error: a message without location ("'10 ms': ...").
Expected<can::Duration, std::string> parse_duration(
    std::string_view text, DurationUnits units = DurationUnits::up_to_minutes);
// The shortest exact text: 1500ms -> "1500ms", 2000ms -> "2s", 0 -> "0ms".
std::string format_duration(can::Duration duration);

// --- globs -------------------------------------------------------------------------------------

// `*` any run of characters, `?` one character. Linear in practice (no backtracking blow-up:
// the classic two-pointer algorithm, O(|glob| * |id|) worst case).
bool glob_match(std::string_view glob, std::string_view id);
// Whether every character is a vector-id character or a glob operator.
bool is_valid_glob(std::string_view glob);
bool is_valid_vector_id(std::string_view id);

// --- text ------------------------------------------------------------------------------------

// The 1-based line of the first byte that is not well-formed UTF-8 (RFC 3629: no overlongs, no
// surrogates, nothing above U+10FFFF); 0 when the text is valid. YAML text is UTF-8 and
// yaml-cpp does not check: a bad byte would be changed on the way back out (the profile and
// vector writers), so both loaders refuse such text with this line.
int first_invalid_utf8_line(std::string_view text);

}  // namespace drivecheck::profile
