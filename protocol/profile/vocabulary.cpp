#include "protocol/profile/vocabulary.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <chrono>
#include <cstddef>
#include <limits>

namespace drivecheck::profile {
namespace {

using namespace std::chrono_literals;

// CiA 402-2 §8.4: the option-code objects.
constexpr std::array<OptionCodeInfo, kOptionCodeCount> kOptionCodes{{
    {OptionCode::quick_stop, "quick-stop", 0x605A},
    {OptionCode::shutdown, "shutdown", 0x605B},
    {OptionCode::disable_operation, "disable-operation", 0x605C},
    {OptionCode::halt, "halt", 0x605D},
    {OptionCode::fault_reaction, "fault-reaction", 0x605E},
    {OptionCode::abort_connection, "abort-connection", 0x6007},
}};

// The closed feature vocabulary (FORMAT.md "Features"), one row each; `detectable`: a generic
// profile may list it under `detect:`, and conformance/capabilities.cpp probes it (a test checks
// that every detectable feature has its probe).
struct FeatureRow {
  std::string_view name;
  bool detectable;
};
constexpr std::array<FeatureRow, 39> kFeatureRows{{
    {"sdo.segmented", true},
    {"sdo.block", true},
    {"sdo.expedited", false},
    {"coe.complete-access", false},  // CoE SDO complete access (ETG.1000.6), EtherCAT only
    {"nmt.guarding", true},
    {"heartbeat.producer", true},
    {"heartbeat.consumer", true},
    {"emcy", true},
    {"emcy.inhibit", true},
    {"emcy.history", true},
    {"sync", true},
    {"sync.producer", true},
    {"sync.counter", true},
    {"time", true},
    {"pdo", true},
    {"pdo.dynamic-mapping", true},
    {"pdo.dummy-mapping", false},  // RPDOs take the dummy entry 0005h (EDS [DummyUsage])
    {"pdo.rtr", true},
    {"pdo.event-timer", true},
    {"pdo.inhibit", true},
    {"pdo.sync-window", true},
    {"store", true},
    {"restore", true},
    {"cia402", true},
    {"hardware-enable", false},
    {"hardware-enable.transition-2", false},
    {"hardware-enable.transition-3", false},
    {"mode.pp", true},
    {"mode.vl", true},
    {"mode.pv", true},
    {"mode.tq", true},
    {"mode.hm", true},
    {"mode.ip", true},
    {"mode.csp", true},
    {"mode.csv", true},
    {"mode.cst", true},
    {"transition.16", false},
    {"simulation", false},
    {"motion", false},
}};

constexpr auto kFixedFeatures = [] {
  std::array<std::string_view, kFeatureRows.size()> names{};
  for (std::size_t i = 0; i < kFeatureRows.size(); ++i)
    names[i] = kFeatureRows[i].name;
  return names;
}();

constexpr std::size_t kDetectableCount = [] {
  std::size_t n = 0;
  for (const FeatureRow& row : kFeatureRows)
    n += row.detectable ? 1 : 0;
  return n;
}();

constexpr auto kDetectableFeatures = [] {
  std::array<std::string_view, kDetectableCount> names{};
  std::size_t i = 0;
  for (const FeatureRow& row : kFeatureRows)
    if (row.detectable) names[i++] = row.name;
  return names;
}();

// FORMAT.md "Timing names": timing_defaults.inc.
const std::array kTimings{
#define DRIVECHECK_TIMING(key, value, meaning, basis) TimingName{#key, value, meaning, basis},
#include "protocol/profile/timing_defaults.inc"
#undef DRIVECHECK_TIMING
};

template <class T>
std::optional<T> parse_decimal(std::string_view text) {
  if (text.empty()) return std::nullopt;
  T value{};
  const char* first = text.data();
  const char* last = text.data() + text.size();
  // from_chars accepts a leading '-' for signed types only; no '+', no spaces.
  auto [ptr, ec] = std::from_chars(first, last, value, 10);
  if (ec != std::errc{} || ptr != last) return std::nullopt;
  return value;
}

}  // namespace

std::span<const OptionCodeInfo> option_code_table() {
  return kOptionCodes;
}
const OptionCodeInfo& info(OptionCode code) {
  return kOptionCodes[static_cast<std::size_t>(code)];
}
std::string_view to_string(OptionCode code) {
  return info(code).name;
}
std::optional<OptionCode> parse_option_code(std::string_view name) {
  for (const auto& row : kOptionCodes)
    if (row.name == name) return row.code;
  return std::nullopt;
}

std::span<const std::string_view> detectable_features() {
  return kDetectableFeatures;
}
bool is_detectable_feature(std::string_view name) {
  return std::find(kDetectableFeatures.begin(), kDetectableFeatures.end(), name) !=
         kDetectableFeatures.end();
}

std::span<const std::string_view> fixed_features() {
  return kFixedFeatures;
}

bool is_known_feature(std::string_view name) {
  for (std::string_view fixed : fixed_features())
    if (fixed == name) return true;
  constexpr std::string_view kHoming = "homing.method.";
  if (name.starts_with(kHoming)) {
    const auto value = parse_decimal<int>(name.substr(kHoming.size()));
    // Canonical spelling only: "homing.method.07" would never match a requires entry.
    return value && *value >= -128 && *value <= 127 && homing_method_feature(*value) == name;
  }
  constexpr std::string_view kOption = "option.";
  if (name.starts_with(kOption)) {
    const std::string_view rest = name.substr(kOption.size());
    const auto dot = rest.rfind('.');
    if (dot == std::string_view::npos) return false;
    const auto code = parse_option_code(rest.substr(0, dot));
    const auto value = parse_decimal<int>(rest.substr(dot + 1));
    return code && value && *value >= -32768 && *value <= 32767 &&
           option_feature(*code, *value) == name;
  }
  return parse_object_need(name).has_value();
}

std::optional<ObjectNeed> parse_object_need(std::string_view token) {
  constexpr std::string_view kObject = "object.";
  if (!token.starts_with(kObject)) return std::nullopt;
  const std::string_view rest = token.substr(kObject.size());
  const auto hex = [](std::string_view digits) -> std::optional<unsigned> {
    unsigned value = 0;
    for (char c : digits) {
      if (c >= '0' && c <= '9') {
        value = value * 16 + static_cast<unsigned>(c - '0');
      } else if (c >= 'A' && c <= 'F') {
        value = value * 16 + static_cast<unsigned>(c - 'A' + 10);
      } else {
        return std::nullopt;  // upper-case only: one spelling per need
      }
    }
    return value;
  };
  if (rest.size() != 4 && !(rest.size() == 7 && rest[4] == '.')) return std::nullopt;
  const auto index = hex(rest.substr(0, 4));
  if (!index || *index == 0) return std::nullopt;
  ObjectNeed need{static_cast<std::uint16_t>(*index), std::nullopt};
  if (rest.size() == 7) {
    const auto sub = hex(rest.substr(5, 2));
    if (!sub) return std::nullopt;
    need.sub = static_cast<std::uint8_t>(*sub);
  }
  return need;
}

std::string object_need_feature(const ObjectNeed& need) {
  return need.sub ? fmt::format("object.{:04X}.{:02X}", need.index, *need.sub)
                  : fmt::format("object.{:04X}", need.index);
}

std::string describe(const ObjectNeed& need) {
  return need.sub ? fmt::format("{:04X}h sub {}", need.index, *need.sub)
                  : fmt::format("{:04X}h", need.index);
}

std::optional<std::string_view> mode_feature(int mode) {
  switch (mode) {
    case 1:
      return "mode.pp";
    case 2:
      return "mode.vl";
    case 3:
      return "mode.pv";
    case 4:
      return "mode.tq";
    case 6:
      return "mode.hm";
    case 7:
      return "mode.ip";
    case 8:
      return "mode.csp";
    case 9:
      return "mode.csv";
    case 10:
      return "mode.cst";
    default:
      return std::nullopt;
  }
}

std::string homing_method_feature(int method) {
  return fmt::format("homing.method.{}", method);
}
std::string option_feature(OptionCode code, int value) {
  return fmt::format("option.{}.{}", to_string(code), value);
}

std::span<const TimingName> timing_table() {
  return kTimings;
}
const TimingName* find_timing(std::string_view name) {
  for (const auto& row : kTimings)
    if (row.name == name) return &row;
  return nullptr;
}

Expected<can::Duration, std::string> parse_duration(std::string_view text, DurationUnits units) {
  struct Unit {
    std::string_view name;
    std::uint64_t nanoseconds;
  };
  constexpr std::array<Unit, 6> kUnits{{{"ns", 1},
                                        {"us", 1'000},
                                        {"ms", 1'000'000},
                                        {"s", 1'000'000'000},
                                        {"min", 60'000'000'000},
                                        {"h", 3'600'000'000'000}}};
  const std::size_t unit_count = units == DurationUnits::up_to_hours ? 6 : 5;
  const std::string_view unit_list =
      units == DurationUnits::up_to_hours ? "ns us ms s min h" : "ns us ms s min";
  std::size_t digits = 0;
  while (digits < text.size() && text[digits] >= '0' && text[digits] <= '9')
    ++digits;
  if (digits == 0) {
    return Unexpected(
        fmt::format("'{}' is not a duration: expected an integer and a unit ({}), e.g. 100ms", text,
                    unit_list));
  }
  const std::string_view unit = text.substr(digits);
  const auto count = parse_decimal<std::uint64_t>(text.substr(0, digits));
  for (std::size_t i = 0; i < unit_count; ++i) {
    if (unit != kUnits[i].name) continue;
    constexpr auto kMax = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
    if (!count || *count > kMax / kUnits[i].nanoseconds) {
      return Unexpected(fmt::format("'{}': duration too large", text));
    }
    return can::Duration(static_cast<std::int64_t>(*count * kUnits[i].nanoseconds));
  }
  if (unit.empty()) return Unexpected(fmt::format("'{}' needs a unit ({})", text, unit_list));
  return Unexpected(fmt::format("'{}': unknown duration unit '{}' ({})", text, unit, unit_list));
}

std::string format_duration(can::Duration duration) {
  const std::int64_t ns = duration.count();
  struct Unit {
    std::int64_t scale;
    std::string_view name;
  };
  constexpr std::array<Unit, 5> kUnits{
      {{60'000'000'000, "min"}, {1'000'000'000, "s"}, {1'000'000, "ms"}, {1'000, "us"}, {1, "ns"}}};
  if (ns == 0) return "0ms";
  for (const auto& unit : kUnits)
    if (ns % unit.scale == 0) return fmt::format("{}{}", ns / unit.scale, unit.name);
  return fmt::format("{}ns", ns);
}

bool glob_match(std::string_view glob, std::string_view id) {
  std::size_t g = 0;
  std::size_t i = 0;
  std::size_t star = std::string_view::npos;  // position of the last '*' in glob
  std::size_t resume = 0;                     // where in id that '*' match resumes
  while (i < id.size()) {
    if (g < glob.size() && (glob[g] == '?' || glob[g] == id[i])) {
      ++g;
      ++i;
    } else if (g < glob.size() && glob[g] == '*') {
      star = g++;
      resume = i;
    } else if (star != std::string_view::npos) {
      g = star + 1;
      i = ++resume;
    } else {
      return false;
    }
  }
  while (g < glob.size() && glob[g] == '*')
    ++g;
  return g == glob.size();
}

namespace {
bool is_id_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '/' || c == '.' || c == '_' ||
         c == '-';
}
}  // namespace

bool is_valid_glob(std::string_view glob) {
  return !glob.empty() && std::all_of(glob.begin(), glob.end(),
                                      [](char c) { return is_id_char(c) || c == '*' || c == '?'; });
}
bool is_valid_vector_id(std::string_view id) {
  return !id.empty() && std::all_of(id.begin(), id.end(), is_id_char);
}

// --- text ---------------------------------------------------------------------------------------

int first_invalid_utf8_line(std::string_view text) {
  int line = 1;
  std::size_t i = 0;
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c == '\n') ++line;
    if (c < 0x80) {
      ++i;
      continue;
    }
    std::size_t length = 0;
    unsigned min_second = 0x80;
    unsigned max_second = 0xBF;
    if (c >= 0xC2 && c <= 0xDF) {
      length = 2;
    } else if (c >= 0xE0 && c <= 0xEF) {
      length = 3;
      if (c == 0xE0) min_second = 0xA0;  // no overlong
      if (c == 0xED) max_second = 0x9F;  // no surrogate
    } else if (c >= 0xF0 && c <= 0xF4) {
      length = 4;
      if (c == 0xF0) min_second = 0x90;  // no overlong
      if (c == 0xF4) max_second = 0x8F;  // not above U+10FFFF
    } else {
      return line;
    }
    if (i + length > text.size()) return line;
    for (std::size_t k = 1; k < length; ++k) {
      const auto b = static_cast<unsigned char>(text[i + k]);
      const unsigned lo = k == 1 ? min_second : 0x80;
      const unsigned hi = k == 1 ? max_second : 0xBF;
      if (b < lo || b > hi) return line;
    }
    i += length;
  }
  return 0;
}

}  // namespace drivecheck::profile
