// A drive profile (vectors/drives/<name>.yaml, format in vectors/FORMAT.md): what one drive
// supports, what its manual documents where it deviates from CiA 301/402, and the personality
// the reference drive takes to impersonate it.
//
//   name: festo-cmmp                       = the file name without .yaml (required)
//   title: "Festo CMMP-AS-...-M3/-M0"      (required)
//   manual: 000_33c1d912b8b6010a.txt       (optional: the standard profile has none)
//   identity: {device_type, vendor_id, product_code, revision_number, serial_number,
//              device_name, hardware_version, software_version}      every key optional
//   features: [...]                        closed vocabulary (vocabulary.hpp); the loader adds
//                                          mode.* of `modes`, homing.method.<n> of
//                                          `homing_methods` and option.<object>.<v> of
//                                          `option_codes`; a listed mode.*, homing.method.* or
//                                          option.* feature that those lists lack is an error
//   detect: [...]                          features decided by probing the device once per run
//                                          (generic profiles: cia301-device, cia402-device);
//                                          vocabulary.hpp detectable_features(); none may also be
//                                          in `features` (those are claims, tested as claimed)
//   modes: [1, 3, 6, -1]                   6060h values, -128..127, no duplicates
//   modes_only_on: [{mode, link, source}]  a mode of `modes` the drive has on one link only
//                                          (link can | ethercat; source required); its mode.*
//                                          feature is then supported on that link only
//   homing_methods: [1, 2, 35, -1]         -128..127, no duplicates
//   option_codes: {quick-stop: [0, 1, 2]}  object name -> accepted values (-32768..32767)
//   timing: {response: 100ms}              overrides of the timing table, durations
//   objects: [...] or "file.yaml"          the manual's object list (below)
//   emcy_codes: [...] or "file.yaml"       the manual's EMCY table (below)
//   pdo_defaults: [...] or "file.yaml"     the default PDO configuration (below)
//   deviations: [...]                      (below); ids unique
//   commissioning: {...}                   SDO writes the engine makes after setup (below)
//   coe: {...}                             the drive's own CoE rules (below, CoeRules)
//   personality: {...}                     personality.hpp / reference_drive/personality.hpp
//
// coe: {max_sdo_size (octets 1..4294967295), absent_objects: [index or [first, last], ...]
//   (0x1000..0xFFFF, not 1000h/1001h/1018h), pdo_assignment_evaluated (bool),
//   pdo_configuration_in (preop | any), source (text or list, required)}; every key but source
//   optional, defaults as the standard drive (no limit, none absent, evaluated, preop).
// objects[i]: {index, sub (default 0), type (CiA 301 name, e.g. UNSIGNED16), access (ro wo rw
//   rwr rww const), pdo (bool, default false), default, min, max (integers; `default` may be a
//   string for string types), name, source}; index+sub unique.
// emcy_codes[i]: {code (0..FFFFh), text, source, register (0..FFh), diagnostic (the manual's
//   own error number, text)}; code unique.
// pdo_defaults[i]: {pdo (rpdo1..rpdo512, tpdo1..tpdo512), cob_id ("180+N", "0x180+N", "201",
//   or an integer), transmission (0..255), inhibit_time (100 us units), event_timer (ms),
//   mapping: [0x60410010, ...] (index << 16 | sub << 8 | bits), source}; pdo unique.
// deviations[i]: {id ([a-z0-9._-]+), vectors: [exact vector ids, or {id, observed}],
//   observed (a map or a list of maps, DeviationObservation below), source (text or list),
//   description, contradiction}; id, vectors, source and description required, and every
//   vector needs an observation (its own or the deviation's). A `*` or `?` in a vector id is
//   an error: a deviation names the vectors it covers. `vectors: []` documents the manual's
//   deviation without covering any verdict (the lint warns).
// commissioning: {vectors: [globs] (required, at least one), except: [globs], writes: [{index
//   (1..FFFFh), sub (default 0), value (integer, must fit `size`), size (bytes 1..4, required),
//   source (text or list, required), why (text, required)}] (required, at least one)};
//   index+sub unique. What an integrator writes to make the drive use the units the vectors
//   are written in (e.g. Festo's velocity factor for increments/s).
//
// A string for objects/emcy_codes/pdo_defaults names a YAML file relative to the profile (no
// "..") that holds the list; its errors carry its own file:line. Keep such files in
// vectors/drives/<name>/: list_profiles() takes only the *.yaml files of drives/ itself.
//
// Every error is a TextError with the file and 1-based line of the offending node: unknown and
// duplicate keys, wrong types, values out of range, unknown features and timing names, bad
// durations, globs and frames, missing required keys, a name that is not the file name.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/data_type.hpp"
#include "protocol/cia402/state_machine.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/profile/personality.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::profile {

// A COB-ID of the profile: a base plus the node-ID or a fixed value.
struct CobIdSpec {
  std::uint32_t base = 0;
  bool plus_node = false;  // "<hex>+N"
  std::uint32_t resolve(std::uint8_t node_id) const { return plus_node ? base + node_id : base; }
  friend bool operator==(const CobIdSpec&, const CobIdSpec&) = default;
};
std::string to_string(const CobIdSpec& cob_id);  // "180+N", "080"
// "180+N", "0x180+N", "180", "0x080"; hex digits only.
Expected<CobIdSpec, std::string> parse_cob_id_spec(std::string_view text);

struct ObjectSpec {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  cia301::DataType type = cia301::DataType::unsigned8;
  cia301::AccessType access = cia301::AccessType::ro;
  bool pdo = false;
  std::optional<std::int64_t> default_value;
  std::optional<std::string> default_text;  // string types
  std::optional<std::int64_t> min;
  std::optional<std::int64_t> max;
  std::string name;
  std::vector<std::string> sources;
  friend bool operator==(const ObjectSpec&, const ObjectSpec&) = default;
};

struct EmcyCodeSpec {
  std::uint16_t code = 0;
  std::string text;
  std::optional<std::uint8_t> error_register;
  std::string diagnostic;
  std::vector<std::string> sources;
  friend bool operator==(const EmcyCodeSpec&, const EmcyCodeSpec&) = default;
};

enum class PdoKind : std::uint8_t { rpdo, tpdo };
struct PdoDefault {
  PdoKind kind = PdoKind::tpdo;
  std::uint16_t number = 1;  // 1..512
  CobIdSpec cob_id;
  std::uint8_t transmission = 255;
  std::optional<std::uint16_t> inhibit_time;  // 100 us units
  std::optional<std::uint16_t> event_timer;   // ms
  std::vector<std::uint32_t> mapping;
  std::vector<std::string> sources;
  friend bool operator==(const PdoDefault&, const PdoDefault&) = default;
};

// The deviant observation a manual documents (vectors/FORMAT.md "Deviations"), compared with
// the failing check's typed observation (conformance/result.hpp Observation) by the verdict:
//   {abort: 0x06090030}        the SDO transfer was aborted with this code
//   {value: 2}                 the value read (or polled) was this
//   {missing: frame} / {no_answer: true}   nothing came (no frame, no SDO answer) in time
//   {accepted: true}           the SDO transfer succeeded where an abort was expected
//   {state: switch-on-disabled}  the last statusword showed this CiA 402 state
//   {statusword: {mask: 0x6F, value: 0x27}}  the last statusword, masked, was this
//   {text: "substring"}        last resort: the failing check's Actual contains this text
//                              ("580+N#..": a DUT frame at any node-ID, see FORMAT.md)
struct DeviationObservation {
  enum class Kind : std::uint8_t { abort, value, nothing, accepted, state, statusword, text };
  Kind kind = Kind::text;
  std::uint32_t abort = 0;
  std::int64_t value = 0;
  // `value: [lo, hi]`: any value from `value` to `value_max` (a position on a moving axis,
  // where the manual documents where it stands, not the increment it reads at the check).
  std::optional<std::int64_t> value_max;
  cia402::State state = cia402::State::switch_on_disabled;
  std::uint16_t mask = 0xFFFF;  // statusword
  std::uint16_t statusword = 0;
  std::string text;
  // "abort 06090030h", "value 2", "value in [1000, 1100]", "nothing (no frame or answer)", "state
  // switch on disabled", "statusword & 006Fh == 0027h", "Actual containing \"...\"".
  std::string describe() const;
  friend bool operator==(const DeviationObservation&, const DeviationObservation&) = default;
};

// One vector a deviation covers: an exact id, with its own documented observation(s) where
// they differ from the deviation's.
struct DeviationVector {
  std::string id;
  std::vector<DeviationObservation> observed;  // empty: the deviation's `observed`
  friend bool operator==(const DeviationVector&, const DeviationVector&) = default;
};

struct Deviation {
  std::string id;
  std::vector<DeviationVector> vectors;        // exact vector ids (no globs)
  std::vector<DeviationObservation> observed;  // what the manual documents (any one of them)
  std::vector<std::string> sources;
  std::string description;
  std::string contradiction;  // both readings and the one chosen; empty if none
  int line = 0;               // YAML line of the entry (not serialised, not compared)
  // The entry for `vector_id`; nullptr if the deviation does not list it.
  const DeviationVector* find(std::string_view vector_id) const;
  // The observations documented for `vector` (its own, else the deviation's).
  const std::vector<DeviationObservation>& observed_for(const DeviationVector& vector) const;
  friend bool operator==(const Deviation& a, const Deviation& b) {
    return a.id == b.id && a.vectors == b.vectors && a.observed == b.observed &&
           a.sources == b.sources && a.description == b.description &&
           a.contradiction == b.contradiction;
  }
};

// One SDO write of the commissioning (vectors/FORMAT.md "Commissioning").
struct CommissioningWrite {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::int64_t value = 0;  // fits `size` bytes (signed or unsigned)
  std::uint8_t size = 4;   // bytes, 1..4 (expedited)
  std::vector<std::string> sources;
  std::string why;
  friend bool operator==(const CommissioningWrite&, const CommissioningWrite&) = default;
};

// What the engine writes after each vector's setup (reset and boot-up), before the NMT state
// and the CiA 402 state, for the vectors it applies to. Empty `writes`: no commissioning.
struct Commissioning {
  std::vector<std::string> vectors;  // globs of the vector ids it applies to
  std::vector<std::string> except;   // globs of vector ids excluded from them
  std::vector<CommissioningWrite> writes;
  bool applies_to(std::string_view vector_id) const;
  friend bool operator==(const Commissioning&, const Commissioning&) = default;
};

// What the drive's CANopen over EtherCAT does differently from the same drive on CAN and from
// ETG.1000.6's rules (profile key `coe:`; vectors/FORMAT.md "CoE rules"). The reference drive
// behind its emulated EtherCAT slave applies them (reference_drive/ethercat/coe_rules.hpp); on
// CAN they mean nothing. Defaults: the standard drive.
enum class PdoConfigurationIn : std::uint8_t {
  preop,  // 1C12h/1C13h, 1600h+/1A00h+ and 1C32h/1C33h written only in PREOP (else 08000022h)
  any,    // written in any state
};
std::string_view to_string(PdoConfigurationIn in);
struct CoeRules {
  // The most octets one SDO transfer carries over CoE (Festo: 4); more: aborted. nullopt: none.
  std::optional<std::uint32_t> max_sdo_size;
  // Objects of the drive's dictionary that do not exist over CoE (06020000h), e.g. Festo's
  // 1008h-100Ah.
  std::vector<ObjectRange> absent_objects;
  // false: 1C12h/1C13h take any value (in the states pdo_configuration_in allows) and are not
  // checked against the mapping objects (Festo 000 L1931 "not evaluated further").
  bool pdo_assignment_evaluated = true;
  PdoConfigurationIn pdo_configuration_in = PdoConfigurationIn::preop;
  // true: entering AL INIT (from any state) loads the saved parameters, as power on does
  // (Festo 000 §4.7 Tab. 4.9 L2056 Init: "The configuration starts, saved values are loaded").
  bool init_loads_saved_values = false;
  std::vector<std::string> sources;  // required when the section is given
  bool is_absent(std::uint16_t index) const;
  friend bool operator==(const CoeRules&, const CoeRules&) = default;
};

// The links a drive is reached over (vectors/FORMAT.md "Transports").
enum class Link : std::uint8_t { can, ethercat };
std::string_view to_string(Link link);
std::optional<Link> parse_link(std::string_view text);

// A mode of operation the drive has on one link only (profile key `modes_only_on`), e.g.
// Festo's csp, "only for EtherCAT" (000 §7.1.2 L5979).
struct ModeOnlyOn {
  int mode = 0;
  Link link = Link::can;
  std::vector<std::string> sources;  // required
  friend bool operator==(const ModeOnlyOn&, const ModeOnlyOn&) = default;
};

struct DriveProfile {
  std::string name;
  std::string title;
  std::string manual;
  Identity identity;
  std::set<std::string> features;  // with the features implied by modes/homing/option codes
  std::set<std::string> detect;    // features the engine decides by probing (`detect:`)
  std::vector<int> modes;
  std::vector<ModeOnlyOn> modes_only_on;  // each one of `modes`
  std::vector<int> homing_methods;
  std::map<OptionCode, std::vector<int>> option_codes;
  std::map<std::string, can::Duration> timing;  // overrides only
  std::vector<ObjectSpec> objects;
  std::vector<EmcyCodeSpec> emcy_codes;
  std::vector<PdoDefault> pdo_defaults;
  std::vector<Deviation> deviations;
  Commissioning commissioning;
  CoeRules coe;
  Personality personality;

  // The file it was loaded from (empty for parsed text; not serialised, not compared).
  std::filesystem::path path;

  // Claimed (features:). A detected feature is not claimed: see conformance/capabilities.hpp.
  bool supports(std::string_view feature) const { return features.contains(std::string(feature)); }
  bool detects(std::string_view feature) const { return detect.contains(std::string(feature)); }
  // The one link a claimed feature is limited to (a mode of `modes_only_on`); nullopt: every
  // link that has what the feature needs.
  std::optional<Link> only_on(std::string_view feature) const;
  // The modes the drive has on `link` (`modes` less those of `modes_only_on` for another link).
  std::vector<int> modes_on(Link link) const;
  // The profile's value of a timing name, else its default; nullopt for an unknown name.
  std::optional<can::Duration> timing_value(std::string_view name) const;
  // The deviations that list `vector_id`, in file order (several may: the verdict takes the
  // first whose observation matches).
  std::vector<const Deviation*> deviations_for(std::string_view vector_id) const;
  // The personality with its defaults resolved from the profile (identity, modes, option codes).
  Personality effective_personality() const;

  friend bool operator==(const DriveProfile& a, const DriveProfile& b) {
    return a.name == b.name && a.title == b.title && a.manual == b.manual &&
           a.identity == b.identity && a.features == b.features && a.detect == b.detect &&
           a.modes == b.modes && a.modes_only_on == b.modes_only_on &&
           a.homing_methods == b.homing_methods && a.option_codes == b.option_codes &&
           a.timing == b.timing && a.objects == b.objects && a.emcy_codes == b.emcy_codes &&
           a.pdo_defaults == b.pdo_defaults && a.deviations == b.deviations &&
           a.commissioning == b.commissioning && a.coe == b.coe && a.personality == b.personality;
  }
};

struct ParseOptions {
  // For error messages; also `name` must equal its stem when set (and check_name is true).
  std::string file_name;
  // Where list files named by a string are looked up; nullopt: such strings are errors
  // (in-memory text, the fuzzer).
  std::optional<std::filesystem::path> base_dir;
  bool check_name = true;
};

// Parses profile text. Never throws, never crashes on any input.
Expected<DriveProfile, TextError> parse_profile(std::string_view text,
                                                const ParseOptions& options = {});
// Reads and parses vectors/drives/<name>.yaml (or any path).
Expected<DriveProfile, TextError> load_profile(const std::filesystem::path& path);
// `name_or_path`: a path (contains '/' or ends with .yaml) is loaded as is; a name is looked up
// as <dir>/<name>.yaml. Error: no such profile (the message lists the known names).
Expected<DriveProfile, TextError> find_profile(std::string_view name_or_path,
                                               const std::filesystem::path& dir);
// The names of the profiles in `dir` (sorted).
std::vector<std::string> list_profiles(const std::filesystem::path& dir);

// The profile as YAML that parse_profile reads back to an equal DriveProfile (lists inline,
// implied features included, `path` not kept).
std::string to_yaml(const DriveProfile& profile);

}  // namespace drivecheck::profile
