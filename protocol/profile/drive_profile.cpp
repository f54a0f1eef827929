#include "protocol/profile/drive_profile.hpp"

#include <fmt/format.h>
#include <yaml-cpp/depthguard.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <system_error>
#include <utility>

#include "protocol/cia301/sdo_abort.hpp"

namespace drivecheck::profile {
namespace {

namespace fs = std::filesystem;

// Internal unwinding only: every public function catches it (and yaml-cpp's exceptions) and
// returns the TextError as a value.
struct Failure {
  TextError error;
};

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}
  const std::string& file() const { return file_; }

  [[noreturn]] void fail(const YAML::Node& node, std::string message) const {
    throw Failure{TextError{file_, line_of(node), std::move(message)}};
  }
  [[noreturn]] void fail_at(int line, std::string message) const {
    throw Failure{TextError{file_, line, std::move(message)}};
  }
  static int line_of(const YAML::Node& node) {
    if (!node.IsDefined()) return 0;
    const int line = node.Mark().line;
    return line >= 0 ? line + 1 : 0;
  }

 private:
  std::string file_;
};

// A checked YAML map: keys are scalars from an allowed set, none repeated.
class MapView {
 public:
  MapView(const Reader& reader, const YAML::Node& node, std::string_view what,
          std::initializer_list<std::string_view> allowed)
      : reader_(reader), node_(node) {
    if (!node.IsMap()) reader.fail(node, fmt::format("{} must be a map", what));
    for (auto it = node.begin(); it != node.end(); ++it) {
      const YAML::Node key = it->first;
      if (!key.IsScalar()) reader.fail(key, fmt::format("{}: a key must be a plain name", what));
      const std::string& name = key.Scalar();
      if (std::find(allowed.begin(), allowed.end(), name) == allowed.end()) {
        std::string known;
        for (std::string_view a : allowed)
          known += (known.empty() ? "" : ", ") + std::string(a);
        reader.fail(key, fmt::format("{}: unknown key '{}' (known: {})", what, name, known));
      }
      for (const auto& [seen, unused] : entries_) {
        (void)unused;
        if (seen == name) reader.fail(key, fmt::format("{}: duplicate key '{}'", what, name));
      }
      entries_.emplace_back(name, it->second);
    }
  }

  std::optional<YAML::Node> get(std::string_view name) const {
    for (const auto& [key, value] : entries_)
      if (key == name) return value;
    return std::nullopt;
  }
  YAML::Node require(std::string_view name, std::string_view what) const {
    auto value = get(name);
    if (!value) reader_.fail(node_, fmt::format("{}: missing required key '{}'", what, name));
    return *value;
  }
  const YAML::Node& node() const { return node_; }

 private:
  const Reader& reader_;
  YAML::Node node_;
  std::vector<std::pair<std::string, YAML::Node>> entries_;
};

std::optional<std::int64_t> parse_integer_text(std::string_view text) {
  bool negative = false;
  if (!text.empty() && text.front() == '-') {
    negative = true;
    text.remove_prefix(1);
  }
  int base = 10;
  if (text.size() > 2 && text[0] == '0' && (text[1] == 'x' || text[1] == 'X')) {
    base = 16;
    text.remove_prefix(2);
  }
  if (text.empty()) return std::nullopt;
  std::uint64_t magnitude = 0;
  auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), magnitude, base);
  if (ec != std::errc{} || ptr != text.data() + text.size()) return std::nullopt;
  constexpr auto kMax = static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max());
  if (negative) {
    if (magnitude > kMax + 1) return std::nullopt;
    return magnitude == kMax + 1 ? std::numeric_limits<std::int64_t>::min()
                                 : -static_cast<std::int64_t>(magnitude);
  }
  if (magnitude > kMax) return std::nullopt;
  return static_cast<std::int64_t>(magnitude);
}

std::string scalar(const Reader& r, const YAML::Node& node, std::string_view what) {
  if (!node.IsScalar()) r.fail(node, fmt::format("{} must be a text value", what));
  return node.Scalar();
}

std::string nonempty_scalar(const Reader& r, const YAML::Node& node, std::string_view what) {
  std::string text = scalar(r, node, what);
  if (text.empty()) r.fail(node, fmt::format("{} must not be empty", what));
  return text;
}

std::int64_t integer(const Reader& r, const YAML::Node& node, std::string_view what,
                     std::int64_t min, std::int64_t max) {
  if (!node.IsScalar()) r.fail(node, fmt::format("{} must be an integer", what));
  const auto value = parse_integer_text(node.Scalar());
  if (!value) {
    r.fail(node,
           fmt::format("{}: '{}' is not an integer (decimal or 0x hex)", what, node.Scalar()));
  }
  if (*value < min || *value > max) {
    r.fail(node, fmt::format("{}: {} is out of range {}..{}", what, node.Scalar(), min, max));
  }
  return *value;
}

bool boolean(const Reader& r, const YAML::Node& node, std::string_view what) {
  if (node.IsScalar() && node.Scalar() == "true") return true;
  if (node.IsScalar() && node.Scalar() == "false") return false;
  r.fail(node, fmt::format("{} must be true or false", what));
}

void require_sequence(const Reader& r, const YAML::Node& node, std::string_view what) {
  if (!node.IsSequence()) r.fail(node, fmt::format("{} must be a list", what));
}

std::vector<int> int_list(const Reader& r, const YAML::Node& node, std::string_view what, int min,
                          int max) {
  require_sequence(r, node, what);
  std::vector<int> values;
  for (const auto& item : node) {
    const int value = static_cast<int>(integer(r, item, what, min, max));
    if (std::find(values.begin(), values.end(), value) != values.end()) {
      r.fail(item, fmt::format("{}: {} is listed twice", what, value));
    }
    values.push_back(value);
  }
  return values;
}

std::vector<std::string> sources(const Reader& r, const YAML::Node& node, std::string_view what) {
  std::vector<std::string> out;
  if (node.IsSequence()) {
    for (const auto& item : node)
      out.push_back(nonempty_scalar(r, item, what));
    if (out.empty()) r.fail(node, fmt::format("{} must name at least one source", what));
    return out;
  }
  out.push_back(nonempty_scalar(r, node, what));
  return out;
}

can::Duration duration(const Reader& r, const YAML::Node& node, std::string_view what) {
  const std::string text = scalar(r, node, what);
  auto value = parse_duration(text);
  if (!value) r.fail(node, fmt::format("{}: {}", what, value.error()));
  return *value;
}

cia301::DataType data_type(const Reader& r, const YAML::Node& node, std::string_view what) {
  const std::string text = scalar(r, node, what);
  for (const auto& row : cia301::data_type_table())
    if (row.name == text) return row.type;
  r.fail(node,
         fmt::format("{}: unknown data type '{}' (CiA 301 names, e.g. UNSIGNED16)", what, text));
}

bool is_lower_name(std::string_view text, bool allow_dot) {
  return !text.empty() && std::all_of(text.begin(), text.end(), [allow_dot](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '_' ||
           (allow_dot && c == '.');
  });
}

// --- sections ----------------------------------------------------------------------------------

Identity read_identity(const Reader& r, const YAML::Node& node, std::string_view what) {
  const MapView map(r, node, what,
                    {"device_type", "vendor_id", "product_code", "revision_number", "serial_number",
                     "device_name", "hardware_version", "software_version"});
  Identity id;
  auto u32 = [&](std::string_view key, std::optional<std::uint32_t>& out) {
    if (auto v = map.get(key)) {
      out = static_cast<std::uint32_t>(
          integer(r, *v, fmt::format("{}.{}", what, key), 0, 0xFFFFFFFF));
    }
  };
  auto text = [&](std::string_view key, std::optional<std::string>& out) {
    if (auto v = map.get(key)) out = scalar(r, *v, fmt::format("{}.{}", what, key));
  };
  u32("device_type", id.device_type);
  u32("vendor_id", id.vendor_id);
  u32("product_code", id.product_code);
  u32("revision_number", id.revision_number);
  u32("serial_number", id.serial_number);
  text("device_name", id.device_name);
  text("hardware_version", id.hardware_version);
  text("software_version", id.software_version);
  return id;
}

std::map<OptionCode, std::vector<int>> read_option_codes(const Reader& r, const YAML::Node& node,
                                                         std::string_view what) {
  const MapView map(r, node, what,
                    {"quick-stop", "shutdown", "disable-operation", "halt", "fault-reaction",
                     "abort-connection"});
  std::map<OptionCode, std::vector<int>> out;
  for (const auto& row : option_code_table()) {
    if (auto v = map.get(row.name)) {
      out[row.code] = int_list(r, *v, fmt::format("{}.{}", what, row.name), -32768, 32767);
    }
  }
  return out;
}

ObjectSpec read_object(const Reader& r, const YAML::Node& node) {
  const MapView map(
      r, node, "objects entry",
      {"index", "sub", "type", "access", "pdo", "default", "min", "max", "name", "source"});
  ObjectSpec o;
  o.index = static_cast<std::uint16_t>(
      integer(r, map.require("index", "objects entry"), "objects.index", 0x0001, 0xFFFF));
  if (auto v = map.get("sub")) {
    o.sub = static_cast<std::uint8_t>(integer(r, *v, "objects.sub", 0, 255));
  }
  o.type = data_type(r, map.require("type", "objects entry"), "objects.type");
  const YAML::Node access_node = map.require("access", "objects entry");
  const auto access = cia301::parse_access_type(scalar(r, access_node, "objects.access"));
  if (!access) {
    r.fail(access_node, fmt::format("objects.access: '{}' is not one of ro wo rw rwr rww const",
                                    access_node.Scalar()));
  }
  o.access = *access;
  if (auto v = map.get("pdo")) o.pdo = boolean(r, *v, "objects.pdo");
  const bool integral = cia301::is_integer(o.type);
  constexpr auto kMin = std::numeric_limits<std::int64_t>::min();
  constexpr auto kMax = std::numeric_limits<std::int64_t>::max();
  if (auto v = map.get("default")) {
    if (integral)
      o.default_value = integer(r, *v, "objects.default", kMin, kMax);
    else
      o.default_text = scalar(r, *v, "objects.default");
  }
  if (auto v = map.get("min")) {
    if (!integral) r.fail(*v, "objects.min: only integer types have limits here");
    o.min = integer(r, *v, "objects.min", kMin, kMax);
  }
  if (auto v = map.get("max")) {
    if (!integral) r.fail(*v, "objects.max: only integer types have limits here");
    o.max = integer(r, *v, "objects.max", kMin, kMax);
  }
  if (o.min && o.max && *o.min > *o.max) r.fail(node, "objects entry: min is above max");
  if (auto v = map.get("name")) o.name = scalar(r, *v, "objects.name");
  o.sources = sources(r, map.require("source", "objects entry"), "objects.source");
  return o;
}

EmcyCodeSpec read_emcy_code(const Reader& r, const YAML::Node& node) {
  const MapView map(r, node, "emcy_codes entry",
                    {"code", "text", "source", "register", "diagnostic"});
  EmcyCodeSpec e;
  e.code = static_cast<std::uint16_t>(
      integer(r, map.require("code", "emcy_codes entry"), "emcy_codes.code", 0, 0xFFFF));
  e.text = nonempty_scalar(r, map.require("text", "emcy_codes entry"), "emcy_codes.text");
  if (auto v = map.get("register")) {
    e.error_register = static_cast<std::uint8_t>(integer(r, *v, "emcy_codes.register", 0, 0xFF));
  }
  if (auto v = map.get("diagnostic")) e.diagnostic = scalar(r, *v, "emcy_codes.diagnostic");
  e.sources = sources(r, map.require("source", "emcy_codes entry"), "emcy_codes.source");
  return e;
}

PdoDefault read_pdo_default(const Reader& r, const YAML::Node& node) {
  const MapView map(
      r, node, "pdo_defaults entry",
      {"pdo", "cob_id", "transmission", "inhibit_time", "event_timer", "mapping", "source"});
  PdoDefault p;
  const YAML::Node pdo_node = map.require("pdo", "pdo_defaults entry");
  const std::string pdo = scalar(r, pdo_node, "pdo_defaults.pdo");
  std::string_view number_text;
  if (pdo.starts_with("rpdo")) {
    p.kind = PdoKind::rpdo;
    number_text = std::string_view(pdo).substr(4);
  } else if (pdo.starts_with("tpdo")) {
    p.kind = PdoKind::tpdo;
    number_text = std::string_view(pdo).substr(4);
  }
  const auto number = parse_integer_text(number_text);
  if (!number || *number < 1 || *number > 512 || number_text.front() == '0' ||
      number_text.find_first_not_of("0123456789") != std::string_view::npos) {
    r.fail(pdo_node,
           fmt::format("pdo_defaults.pdo: '{}' is not rpdo1..rpdo512 or tpdo1..tpdo512", pdo));
  }
  p.number = static_cast<std::uint16_t>(*number);
  const YAML::Node cob_node = map.require("cob_id", "pdo_defaults entry");
  auto cob = parse_cob_id_spec(scalar(r, cob_node, "pdo_defaults.cob_id"));
  if (!cob) r.fail(cob_node, fmt::format("pdo_defaults.cob_id: {}", cob.error()));
  p.cob_id = *cob;
  if (auto v = map.get("transmission")) {
    p.transmission = static_cast<std::uint8_t>(integer(r, *v, "pdo_defaults.transmission", 0, 255));
  }
  if (auto v = map.get("inhibit_time")) {
    p.inhibit_time =
        static_cast<std::uint16_t>(integer(r, *v, "pdo_defaults.inhibit_time", 0, 0xFFFF));
  }
  if (auto v = map.get("event_timer")) {
    p.event_timer =
        static_cast<std::uint16_t>(integer(r, *v, "pdo_defaults.event_timer", 0, 0xFFFF));
  }
  const YAML::Node mapping = map.require("mapping", "pdo_defaults entry");
  require_sequence(r, mapping, "pdo_defaults.mapping");
  unsigned bits = 0;
  for (const auto& item : mapping) {
    const auto entry =
        static_cast<std::uint32_t>(integer(r, item, "pdo_defaults.mapping", 0, 0xFFFFFFFF));
    bits += entry & 0xFFU;
    if (bits > 64) r.fail(item, "pdo_defaults.mapping: more than 64 bits mapped");
    p.mapping.push_back(entry);
  }
  p.sources = sources(r, map.require("source", "pdo_defaults entry"), "pdo_defaults.source");
  return p;
}

DeviationObservation read_observation(const Reader& r, const YAML::Node& node) {
  const MapView map(
      r, node, "observed",
      {"abort", "value", "missing", "no_answer", "accepted", "state", "statusword", "text"});
  if (map.node().size() != 1)
    r.fail(node,
           "observed: give exactly one of abort, value, missing, no_answer, accepted, "
           "state, statusword, text");
  DeviationObservation o;
  const std::string key = map.node().begin()->first.Scalar();
  const YAML::Node v = map.require(key, "observed");
  if (key == "abort") {
    o.kind = DeviationObservation::Kind::abort;
    o.abort = static_cast<std::uint32_t>(integer(r, v, "observed.abort", 1, 0xFFFFFFFF));
  } else if (key == "value") {
    o.kind = DeviationObservation::Kind::value;
    constexpr auto kMin = std::numeric_limits<std::int64_t>::min();
    constexpr auto kMax = std::numeric_limits<std::int64_t>::max();
    if (v.IsSequence()) {
      if (v.size() != 2) r.fail(v, "observed.value: a value or a range [lo, hi]");
      o.value = integer(r, v[0], "observed.value", kMin, kMax);
      o.value_max = integer(r, v[1], "observed.value", kMin, kMax);
      if (*o.value_max < o.value) r.fail(v, "observed.value: a range [lo, hi] needs lo <= hi");
    } else {
      o.value = integer(r, v, "observed.value", kMin, kMax);
    }
  } else if (key == "missing") {
    if (scalar(r, v, "observed.missing") != "frame")
      r.fail(v, "observed.missing: the only value is 'frame'");
    o.kind = DeviationObservation::Kind::nothing;
  } else if (key == "no_answer") {
    if (!boolean(r, v, "observed.no_answer")) r.fail(v, "observed.no_answer: only 'true'");
    o.kind = DeviationObservation::Kind::nothing;
  } else if (key == "accepted") {
    if (!boolean(r, v, "observed.accepted")) r.fail(v, "observed.accepted: only 'true'");
    o.kind = DeviationObservation::Kind::accepted;
  } else if (key == "state") {
    const std::string name = scalar(r, v, "observed.state");
    bool found = false;
    std::string known;
    for (const auto& pattern : cia402::kStatePatterns) {
      std::string kebab(pattern.name);
      std::replace(kebab.begin(), kebab.end(), ' ', '-');
      known += (known.empty() ? "" : ", ") + kebab;
      if (kebab == name) {
        o.state = pattern.state;
        found = true;
      }
    }
    if (!found) r.fail(v, fmt::format("observed.state: '{}' is not a state ({})", name, known));
    o.kind = DeviationObservation::Kind::state;
  } else if (key == "statusword") {
    const MapView sw(r, v, "observed.statusword", {"mask", "value"});
    o.kind = DeviationObservation::Kind::statusword;
    o.mask = static_cast<std::uint16_t>(integer(r, sw.require("mask", "observed.statusword"),
                                                "observed.statusword.mask", 1, 0xFFFF));
    o.statusword = static_cast<std::uint16_t>(integer(r, sw.require("value", "observed.statusword"),
                                                      "observed.statusword.value", 0, 0xFFFF));
    if ((o.statusword & ~o.mask) != 0)
      r.fail(v, "observed.statusword: value has bits outside the mask");
  } else {
    o.kind = DeviationObservation::Kind::text;
    o.text = nonempty_scalar(r, v, "observed.text");
  }
  return o;
}

std::vector<DeviationObservation> read_observations(const Reader& r, const YAML::Node& node) {
  std::vector<DeviationObservation> out;
  if (node.IsSequence()) {
    for (const auto& item : node)
      out.push_back(read_observation(r, item));
    if (out.empty()) r.fail(node, "observed: the list is empty");
  } else {
    out.push_back(read_observation(r, node));
  }
  return out;
}

Deviation read_deviation(const Reader& r, const YAML::Node& node) {
  const MapView map(r, node, "deviations entry",
                    {"id", "vectors", "observed", "source", "description", "contradiction"});
  Deviation d;
  d.line = Reader::line_of(node);
  const YAML::Node id_node = map.require("id", "deviations entry");
  d.id = scalar(r, id_node, "deviations.id");
  if (!is_lower_name(d.id, true)) {
    r.fail(id_node, fmt::format("deviations.id: '{}' must be [a-z0-9._-]+", d.id));
  }
  if (auto v = map.get("observed")) d.observed = read_observations(r, *v);
  const YAML::Node vectors = map.require("vectors", "deviations entry");
  require_sequence(r, vectors, "deviations.vectors");
  for (const auto& item : vectors) {
    DeviationVector entry;
    YAML::Node id = item;
    if (item.IsMap()) {
      const MapView vector_map(r, item, "deviations.vectors entry", {"id", "observed"});
      id = vector_map.require("id", "deviations.vectors entry");
      if (auto v = vector_map.get("observed")) entry.observed = read_observations(r, *v);
    }
    entry.id = scalar(r, id, "deviations.vectors");
    if (entry.id.find_first_of("*?") != std::string::npos) {
      r.fail(id, fmt::format("deviations.vectors: '{}' is a glob; a deviation names the exact "
                             "vector ids its manual documents",
                             entry.id));
    }
    if (!is_valid_glob(entry.id) || entry.id.empty()) {
      r.fail(id,
             fmt::format("deviations.vectors: '{}' is not a vector id ([a-z0-9/._-])", entry.id));
    }
    for (const auto& seen : d.vectors) {
      if (seen.id == entry.id)
        r.fail(id, fmt::format("deviations.vectors: '{}' is listed twice", entry.id));
    }
    if (entry.observed.empty() && d.observed.empty()) {
      r.fail(id, fmt::format("deviation {}: vector '{}' has no observed: (give the deviation's "
                             "or the vector's, the observation the manual documents)",
                             d.id, entry.id));
    }
    d.vectors.push_back(std::move(entry));
  }
  d.sources = sources(r, map.require("source", "deviations entry"), "deviations.source");
  d.description =
      nonempty_scalar(r, map.require("description", "deviations entry"), "deviations.description");
  if (auto v = map.get("contradiction"))
    d.contradiction = scalar(r, *v, "deviations.contradiction");
  return d;
}

std::vector<std::string> glob_list(const Reader& r, const YAML::Node& node, std::string_view what) {
  require_sequence(r, node, what);
  std::vector<std::string> globs;
  for (const auto& item : node) {
    std::string glob = scalar(r, item, what);
    if (!is_valid_glob(glob)) {
      r.fail(item, fmt::format("{}: '{}' is not a glob of vector ids ([a-z0-9/._-], * and ?)", what,
                               glob));
    }
    globs.push_back(std::move(glob));
  }
  return globs;
}

CommissioningWrite read_commissioning_write(const Reader& r, const YAML::Node& node) {
  const MapView map(r, node, "commissioning.writes entry",
                    {"index", "sub", "value", "size", "source", "why"});
  CommissioningWrite w;
  w.index =
      static_cast<std::uint16_t>(integer(r, map.require("index", "commissioning.writes entry"),
                                         "commissioning.writes.index", 0x0001, 0xFFFF));
  if (auto v = map.get("sub")) {
    w.sub = static_cast<std::uint8_t>(integer(r, *v, "commissioning.writes.sub", 0, 255));
  }
  const YAML::Node size = map.require("size", "commissioning.writes entry");
  w.size = static_cast<std::uint8_t>(integer(r, size, "commissioning.writes.size", 1, 4));
  const YAML::Node value = map.require("value", "commissioning.writes entry");
  // Signed or unsigned: from -2^(8n-1) to 2^(8n)-1.
  const std::int64_t bits = 8 * static_cast<std::int64_t>(w.size);
  w.value = integer(r, value, fmt::format("commissioning.writes.value ({} bytes)", w.size),
                    -(std::int64_t{1} << (bits - 1)), (std::int64_t{1} << bits) - 1);
  w.sources = sources(r, map.require("source", "commissioning.writes entry"),
                      "commissioning.writes.source");
  w.why = nonempty_scalar(r, map.require("why", "commissioning.writes entry"),
                          "commissioning.writes.why");
  return w;
}

Commissioning read_commissioning(const Reader& r, const YAML::Node& node) {
  const MapView map(r, node, "commissioning", {"vectors", "except", "writes"});
  Commissioning c;
  const YAML::Node vectors = map.require("vectors", "commissioning");
  c.vectors = glob_list(r, vectors, "commissioning.vectors");
  if (c.vectors.empty()) r.fail(vectors, "commissioning.vectors must name at least one glob");
  if (auto v = map.get("except")) c.except = glob_list(r, *v, "commissioning.except");
  const YAML::Node writes = map.require("writes", "commissioning");
  require_sequence(r, writes, "commissioning.writes");
  for (const auto& item : writes) {
    CommissioningWrite w = read_commissioning_write(r, item);
    for (const auto& seen : c.writes) {
      if (seen.index == w.index && seen.sub == w.sub) {
        r.fail(item, fmt::format("commissioning.writes: {:04X}h sub {} is written twice", w.index,
                                 w.sub));
      }
    }
    c.writes.push_back(std::move(w));
  }
  if (c.writes.empty()) r.fail(writes, "commissioning.writes must hold at least one write");
  return c;
}

ObjectRule read_object_rule(const Reader& r, const YAML::Node& node) {
  const MapView map(
      r, node, "personality.objects entry",
      {"index", "sub", "type", "access", "default", "min", "max", "values", "action", "source"});
  constexpr auto kMin = std::numeric_limits<std::int64_t>::min();
  constexpr auto kMax = std::numeric_limits<std::int64_t>::max();
  ObjectRule o;
  o.index = static_cast<std::uint16_t>(integer(r, map.require("index", "objects entry"),
                                               "personality.objects.index", 0x0001, 0xFFFF));
  if (auto v = map.get("sub")) {
    o.sub = static_cast<std::uint8_t>(integer(r, *v, "personality.objects.sub", 0, 255));
  }
  if (auto v = map.get("type")) {
    o.type = data_type(r, *v, "personality.objects.type");
    if (!cia301::is_integer(*o.type) || cia301::info(*o.type).size > 4) {
      r.fail(*v, "personality.objects.type: only integer types of 1..4 bytes can be added");
    }
  }
  if (auto v = map.get("access")) {
    const auto access = cia301::parse_access_type(scalar(r, *v, "personality.objects.access"));
    if (!access || (*access != cia301::AccessType::ro && *access != cia301::AccessType::wo &&
                    *access != cia301::AccessType::rw)) {
      r.fail(*v,
             fmt::format("personality.objects.access: '{}' is not one of ro wo rw", v->Scalar()));
    }
    o.access = *access;
  }
  if (auto v = map.get("default")) {
    o.default_value = integer(r, *v, "personality.objects.default", kMin, kMax);
  }
  if (auto v = map.get("min")) o.min = integer(r, *v, "personality.objects.min", kMin, kMax);
  if (auto v = map.get("max")) o.max = integer(r, *v, "personality.objects.max", kMin, kMax);
  if (o.min && o.max && *o.min > *o.max) r.fail(node, "personality.objects: min is above max");
  if (auto v = map.get("values")) {
    require_sequence(r, *v, "personality.objects.values");
    for (const auto& item : *v) {
      o.values.push_back(integer(r, item, "personality.objects.values", kMin, kMax));
    }
  }
  if (auto v = map.get("action")) {
    const std::string text = scalar(r, *v, "personality.objects.action");
    if (text == to_string(ObjectAction::none)) {
      o.action = ObjectAction::none;
    } else if (text == to_string(ObjectAction::set_actual_position)) {
      o.action = ObjectAction::set_actual_position;
    } else {
      r.fail(*v, fmt::format("personality.objects.action: '{}' is not one of none, "
                             "set-actual-position",
                             text));
    }
    if (!o.type) r.fail(*v, "personality.objects.action: only with type (an added object)");
  }
  if (auto v = map.get("source")) {
    o.source = scalar(r, *v, "personality.objects.source");
  }
  return o;
}

// Features of the hardware enable input (FORMAT.md "Features").
constexpr std::string_view kHardwareEnableT2 = "hardware-enable.transition-2";
constexpr std::string_view kHardwareEnableT3 = "hardware-enable.transition-3";

// An SDO abort code of sdo_abort_codes.inc, by value (0x06010002) or by its name
// (write_read_only).
std::uint32_t abort_code(const Reader& r, const YAML::Node& node, std::string_view what) {
  if (!node.IsScalar()) r.fail(node, fmt::format("{} must be an abort code", what));
  const std::string& text = node.Scalar();
  if (!text.empty() && text[0] >= '0' && text[0] <= '9') {
    const auto value = static_cast<std::uint32_t>(integer(r, node, what, 0, 0xFFFFFFFF));
    if (!cia301::find_sdo_abort(value)) {
      r.fail(node, fmt::format("{}: {:08X}h is no abort code of sdo_abort_codes.inc", what, value));
    }
    return value;
  }
  for (const cia301::SdoAbortInfo& row : cia301::sdo_abort_table()) {
    if (row.name == text) return static_cast<std::uint32_t>(row.code);
  }
  r.fail(node, fmt::format("{}: '{}' is no abort code name of sdo_abort_codes.inc", what, text));
}

// A list of object indices and [first, last] ranges (personality.absent_objects,
// coe.absent_objects); the objects every CANopen device has may not be in it.
std::vector<ObjectRange> object_ranges(const Reader& r, const YAML::Node& node,
                                       std::string_view what) {
  require_sequence(r, node, what);
  std::vector<ObjectRange> out;
  for (const YAML::Node& item : node) {
    ObjectRange range;
    if (item.IsSequence()) {
      if (item.size() != 2) r.fail(item, fmt::format("{}: a range is [first, last]", what));
      range.first = static_cast<std::uint16_t>(integer(r, item[0], what, 0x1000, 0xFFFF));
      range.last = static_cast<std::uint16_t>(integer(r, item[1], what, 0x1000, 0xFFFF));
      if (range.last < range.first) {
        r.fail(item, fmt::format("{}: a range's last index is below its first", what));
      }
    } else {
      range.first = static_cast<std::uint16_t>(integer(r, item, what, 0x1000, 0xFFFF));
      range.last = range.first;
    }
    for (std::uint16_t mandatory :
         {std::uint16_t{0x1000}, std::uint16_t{0x1001}, std::uint16_t{0x1018}}) {
      if (mandatory >= range.first && mandatory <= range.last) {
        r.fail(item, fmt::format("{}: {:04X}h is mandatory for every CANopen device (CiA 301 "
                                 "§7.5.1)",
                                 what, mandatory));
      }
    }
    out.push_back(range);
  }
  return out;
}

// The personality keys of issue 17's alternative personalities (personality.hpp).
void read_choice_keys(const Reader& r, const MapView& map, Personality& p) {
  if (auto v = map.get("cia402")) p.cia402 = boolean(r, *v, "personality.cia402");
  if (auto v = map.get("absent_objects")) {
    p.absent_objects = object_ranges(r, *v, "personality.absent_objects");
  }
  if (auto v = map.get("abort_codes")) {
    if (!v->IsMap()) r.fail(*v, "personality.abort_codes must be a map {standard code: code}");
    for (auto it = v->begin(); it != v->end(); ++it) {
      const std::uint32_t from = abort_code(r, it->first, "personality.abort_codes key");
      const std::uint32_t to = abort_code(r, it->second, "personality.abort_codes value");
      if (!p.abort_codes.emplace(from, to).second) {
        r.fail(it->first, fmt::format("personality.abort_codes: {:08X}h is listed twice", from));
      }
    }
  }
  if (auto v = map.get("sdo_response_delay")) {
    ResponseDelay& d = p.sdo_response_delay;
    if (v->IsSequence()) {
      if (v->size() != 2) r.fail(*v, "personality.sdo_response_delay: [min, max] or a duration");
      d.min = duration(r, (*v)[0], "personality.sdo_response_delay");
      d.max = duration(r, (*v)[1], "personality.sdo_response_delay");
    } else {
      d.min = d.max = duration(r, *v, "personality.sdo_response_delay");
    }
    if (d.min > d.max || d.max > std::chrono::seconds(1)) {
      r.fail(*v, "personality.sdo_response_delay must be within 0..1s, min <= max");
    }
  }
  auto choose = [&](std::string_view key, auto& out, auto... options) {
    auto v = map.get(key);
    if (!v) return;
    const std::string text = scalar(r, *v, fmt::format("personality.{}", key));
    std::string known;
    bool found = false;
    (
        [&](auto option) {
          known += (known.empty() ? "" : ", ") + std::string(to_string(option));
          if (!found && to_string(option) == text) {
            out = option;
            found = true;
          }
        }(options),
        ...);
    if (!found) {
      r.fail(*v, fmt::format("personality.{}: '{}' is not one of {}", key, text, known));
    }
  };
  choose("pdo_mapping", p.pdo_mapping, PdoMapping::dynamic, PdoMapping::fixed);
  choose("empty_pdo_valid", p.empty_pdo_valid, EmptyPdoValid::accept, EmptyPdoValid::refuse);
  choose("tpdo_sync_phase", p.tpdo_sync_phase, TpdoSyncPhase::nth_sync, TpdoSyncPhase::first_sync);
  if (auto v = map.get("setpoint_buffer")) {
    p.setpoint_buffer = static_cast<unsigned>(integer(r, *v, "personality.setpoint_buffer", 1, 8));
  }
  if (auto v = map.get("initial_mode")) {
    p.initial_mode =
        static_cast<std::int8_t>(integer(r, *v, "personality.initial_mode", -128, 127));
  }
  if (auto v = map.get("ip_max_buffer")) {
    p.ip_max_buffer = static_cast<unsigned>(integer(r, *v, "personality.ip_max_buffer", 0, 16));
  }
  choose("max_motor_speed", p.max_motor_speed, MaxMotorSpeed::velocity_u32, MaxMotorSpeed::rpm_u16);
  if (auto v = map.get("restore_output_stage_off")) {
    p.restore_output_stage_off = boolean(r, *v, "personality.restore_output_stage_off");
  }
}

Personality read_personality(const Reader& r, const YAML::Node& node) {
  const MapView map(r, node, "personality",
                    {"identity",
                     "modes",
                     "manufacturer_modes",
                     "option_codes",
                     "option_defaults",
                     "hardware_enable",
                     "emcy_follow_up",
                     "error_code_format",
                     "homing",
                     "manufacturer_homing",
                     "homing_default_method",
                     "homing_halt_sets_error",
                     "object_types",
                     "objects",
                     "pdo_mapping_while_valid",
                     "pdo_cob_id_enable_only",
                     "tpdo_transmit_masks",
                     "parameters_internal",
                     "internal_units",
                     "encoder_resolution",
                     "pp_change_on_set_point",
                     "ip_submode",
                     "power_stage_in_switched_on",
                     "nmt_min_spacing",
                     "guarding_loss",
                     "ack_latency_cycles",
                     "control_cycle",
                     "sdo_dlc",
                     "sdo_short_requests",
                     "heartbeat_time_ms",
                     "guard_time_ms",
                     "life_time_factor",
                     "extra_sdo_servers",
                     "sdo_client",
                     "time_consumer",
                     "sdo_server_node_id",
                     "bus_off",
                     "manufacturer_objects",
                     "position_sampling",
                     "position_range_limit",
                     "cia402",
                     "absent_objects",
                     "abort_codes",
                     "sdo_response_delay",
                     "pdo_mapping",
                     "empty_pdo_valid",
                     "tpdo_sync_phase",
                     "setpoint_buffer",
                     "initial_mode",
                     "ip_max_buffer",
                     "max_motor_speed",
                     "restore_output_stage_off",
                     "note"});
  Personality p;
  if (auto v = map.get("identity")) p.identity = read_identity(r, *v, "personality.identity");
  if (auto v = map.get("modes")) p.modes = int_list(r, *v, "personality.modes", -128, 127);
  if (auto v = map.get("manufacturer_modes")) {
    require_sequence(r, *v, "personality.manufacturer_modes");
    for (const auto& item : *v) {
      const MapView m(r, item, "personality.manufacturer_modes entry",
                      {"value", "behaves_as", "logic", "name"});
      ManufacturerMode mode;
      mode.value = static_cast<int>(integer(r, m.require("value", "manufacturer_modes entry"),
                                            "manufacturer_modes.value", -128, -1));
      if (auto b = m.get("behaves_as")) {
        mode.behaves_as = static_cast<int>(integer(r, *b, "manufacturer_modes.behaves_as", 0, 10));
        if (mode.behaves_as != 0 && !mode_feature(mode.behaves_as)) {
          r.fail(*b, fmt::format("manufacturer_modes.behaves_as: {} is not a CiA 402 mode",
                                 mode.behaves_as));
        }
      }
      if (auto l = m.get("logic")) {
        const std::string text = scalar(r, *l, "manufacturer_modes.logic");
        if (text == to_string(ManufacturerModeLogic::irtsa_mpp)) {
          mode.logic = ManufacturerModeLogic::irtsa_mpp;
        } else if (text != to_string(ManufacturerModeLogic::behaves_as)) {
          r.fail(*l,
                 fmt::format("manufacturer_modes.logic: '{}' is not one of behaves-as, irtsa-mpp",
                             text));
        }
      }
      if (auto n = m.get("name")) mode.name = scalar(r, *n, "manufacturer_modes.name");
      for (const auto& seen : p.manufacturer_modes) {
        if (seen.value == mode.value) {
          r.fail(item, fmt::format("manufacturer_modes: {} is listed twice", mode.value));
        }
      }
      p.manufacturer_modes.push_back(std::move(mode));
    }
  }
  if (auto v = map.get("option_codes")) {
    p.option_codes = read_option_codes(r, *v, "personality.option_codes");
  }
  if (auto v = map.get("option_defaults")) {
    const MapView m(r, *v, "personality.option_defaults",
                    {"quick-stop", "shutdown", "disable-operation", "halt", "fault-reaction",
                     "abort-connection"});
    for (const auto& row : option_code_table()) {
      if (auto d = m.get(row.name)) {
        p.option_defaults[row.code] = static_cast<int>(
            integer(r, *d, fmt::format("personality.option_defaults.{}", row.name), -32768, 32767));
      }
    }
  }
  if (auto v = map.get("emcy_follow_up")) {
    p.emcy_follow_up = boolean(r, *v, "personality.emcy_follow_up");
  }
  if (auto v = map.get("sdo_client")) p.sdo_client = boolean(r, *v, "personality.sdo_client");
  if (auto v = map.get("time_consumer")) {
    p.time_consumer = boolean(r, *v, "personality.time_consumer");
  }
  auto choice = [&](std::string_view key, auto& out, auto... options) {
    auto v = map.get(key);
    if (!v) return;
    const std::string text = scalar(r, *v, fmt::format("personality.{}", key));
    std::string known;
    bool found = false;
    (
        [&](auto option) {
          known += (known.empty() ? "" : ", ") + std::string(to_string(option));
          if (!found && to_string(option) == text) {
            out = option;
            found = true;
          }
        }(options),
        ...);
    if (!found) {
      r.fail(*v, fmt::format("personality.{}: '{}' is not one of {}", key, text, known));
    }
  };
  choice("error_code_format", p.error_code_format, ErrorCodeFormat::standard,
         ErrorCodeFormat::error_number);
  choice("homing", p.homing, HomingStyle::standard, HomingStyle::set_position);
  choice("hardware_enable", p.hardware_enable, HardwareEnable::none, HardwareEnable::transition_2,
         HardwareEnable::transition_3);
  choice("manufacturer_homing", p.manufacturer_homing, HomingTable::none, HomingTable::festo,
         HomingTable::kollmorgen, HomingTable::irtsa);
  if (auto v = map.get("homing_default_method")) {
    p.homing_default_method =
        static_cast<int>(integer(r, *v, "personality.homing_default_method", -128, 127));
  }
  if (auto v = map.get("homing_halt_sets_error")) {
    p.homing_halt_sets_error = boolean(r, *v, "personality.homing_halt_sets_error");
  }
  choice("guarding_loss", p.guarding_loss, GuardingLoss::error_behaviour,
         GuardingLoss::pre_operational, GuardingLoss::no_nmt_change);
  choice("manufacturer_objects", p.manufacturer_objects, ManufacturerObjects::none,
         ManufacturerObjects::kollmorgen);
  choice("position_sampling", p.position_sampling, PositionSampling::none, PositionSampling::festo);
  choice("position_range_limit", p.position_range_limit, PositionRangeLimit::none,
         PositionRangeLimit::cia402, PositionRangeLimit::festo);
  choice("sdo_dlc", p.sdo_dlc, SdoDlc::always_8, SdoDlc::minimal);
  choice("sdo_short_requests", p.sdo_short_requests, SdoShortRequests::ignore,
         SdoShortRequests::pad);
  if (auto v = map.get("extra_sdo_servers")) {
    p.extra_sdo_servers =
        static_cast<std::uint8_t>(integer(r, *v, "personality.extra_sdo_servers", 0, 127));
  }
  choice("sdo_server_node_id", p.sdo_server_node_id, cia301::SdoNodeIdSub::none,
         cia301::SdoNodeIdSub::client, cia301::SdoNodeIdSub::server);
  choice("bus_off", p.bus_off, BusOffReaction::cia301, BusOffReaction::kollmorgen_f23,
         BusOffReaction::esr_8180);
  if (auto v = map.get("object_types")) {
    require_sequence(r, *v, "personality.object_types");
    for (const auto& item : *v) {
      const MapView m(r, item, "personality.object_types entry", {"index", "sub", "type"});
      ObjectType t;
      t.index = static_cast<std::uint16_t>(integer(r, m.require("index", "object_types entry"),
                                                   "object_types.index", 0x0001, 0xFFFF));
      if (auto s = m.get("sub")) {
        t.sub = static_cast<std::uint8_t>(integer(r, *s, "object_types.sub", 0, 255));
      }
      t.type = data_type(r, m.require("type", "object_types entry"), "object_types.type");
      if (!cia301::is_integer(t.type) || cia301::info(t.type).size > 4) {
        r.fail(item, "object_types: only integer types of 1..4 bytes can be substituted");
      }
      for (const auto& seen : p.object_types) {
        if (seen.index == t.index && seen.sub == t.sub) {
          r.fail(item, "object_types: the same index and sub-index is listed twice");
        }
      }
      p.object_types.push_back(t);
    }
  }
  if (auto v = map.get("objects")) {
    require_sequence(r, *v, "personality.objects");
    for (const auto& item : *v) {
      ObjectRule o = read_object_rule(r, item);
      for (const auto& seen : p.objects) {
        if (seen.index == o.index && seen.sub == o.sub) {
          r.fail(item, "personality.objects: the same index and sub-index is listed twice");
        }
      }
      p.objects.push_back(std::move(o));
    }
  }
  if (auto v = map.get("pdo_mapping_while_valid")) {
    p.pdo_mapping_while_valid = boolean(r, *v, "personality.pdo_mapping_while_valid");
  }
  if (auto v = map.get("pdo_cob_id_enable_only")) {
    p.pdo_cob_id_enable_only = boolean(r, *v, "personality.pdo_cob_id_enable_only");
  }
  if (auto v = map.get("parameters_internal")) {
    p.parameters_internal = boolean(r, *v, "personality.parameters_internal");
  }
  if (auto v = map.get("pp_change_on_set_point")) {
    p.pp_change_on_set_point = boolean(r, *v, "personality.pp_change_on_set_point");
  }
  if (auto v = map.get("ip_submode")) {
    p.ip_submode = static_cast<std::int16_t>(integer(r, *v, "personality.ip_submode", -32768, 0));
  }
  if (auto v = map.get("power_stage_in_switched_on")) {
    p.power_stage_in_switched_on = boolean(r, *v, "personality.power_stage_in_switched_on");
  }
  if (auto v = map.get("nmt_min_spacing")) {
    p.nmt_min_spacing = duration(r, *v, "personality.nmt_min_spacing");
    if (p.nmt_min_spacing > std::chrono::seconds(1)) {
      r.fail(*v, "personality.nmt_min_spacing must be within 0..1s");
    }
  }
  if (auto v = map.get("internal_units")) {
    const MapView m(r, *v, "personality.internal_units", {"velocity", "acceleration"});
    const auto fraction = [&](std::string_view key, UnitFraction& out) {
      auto f = m.get(key);
      if (!f) return;
      const std::string what = fmt::format("personality.internal_units.{}", key);
      if (!f->IsSequence() || f->size() != 2) {
        r.fail(*f, fmt::format("{} must be [numerator, divisor]", what));
      }
      out.numerator = static_cast<std::uint32_t>(integer(r, (*f)[0], what, 1, 0xFFFFFFFF));
      out.divisor = static_cast<std::uint32_t>(integer(r, (*f)[1], what, 1, 0xFFFFFFFF));
    };
    fraction("velocity", p.internal_units.velocity);
    fraction("acceleration", p.internal_units.acceleration);
  }
  if (auto v = map.get("encoder_resolution")) {
    p.encoder_resolution =
        static_cast<std::uint32_t>(integer(r, *v, "personality.encoder_resolution", 4, 0x7FFFFFFF));
  }
  if (auto v = map.get("tpdo_transmit_masks")) {
    p.tpdo_transmit_masks = static_cast<std::uint16_t>(
        integer(r, *v, "personality.tpdo_transmit_masks", 0x2000, 0x5FFF));
  }
  if (auto v = map.get("ack_latency_cycles")) {
    p.ack_latency_cycles =
        static_cast<unsigned>(integer(r, *v, "personality.ack_latency_cycles", 0, 1000));
  }
  if (auto v = map.get("control_cycle")) {
    p.control_cycle = duration(r, *v, "personality.control_cycle");
    if (*p.control_cycle < std::chrono::microseconds(50) ||
        *p.control_cycle > std::chrono::seconds(1)) {
      r.fail(*v, "personality.control_cycle must be within 50us..1s");
    }
  }
  if (auto v = map.get("heartbeat_time_ms")) {
    p.heartbeat_time_ms =
        static_cast<std::uint16_t>(integer(r, *v, "personality.heartbeat_time_ms", 0, 0xFFFF));
  }
  if (auto v = map.get("guard_time_ms")) {
    p.guard_time_ms =
        static_cast<std::uint16_t>(integer(r, *v, "personality.guard_time_ms", 0, 0xFFFF));
  }
  if (auto v = map.get("life_time_factor")) {
    p.life_time_factor =
        static_cast<std::uint8_t>(integer(r, *v, "personality.life_time_factor", 0, 0xFF));
  }
  read_choice_keys(r, map, p);
  if (auto v = map.get("note")) p.note = scalar(r, *v, "personality.note");
  return p;
}

// An item of a list section with where it was written (for duplicate errors).
template <class Item>
struct Located {
  Item item;
  std::string file;
  int line = 0;
};

// A list section given inline, or as the name of a file next to the profile holding the list.
template <class Item, class ReadItem>
std::vector<Located<Item>> read_list_section(const Reader& r, const YAML::Node& node,
                                             std::string_view key, const ParseOptions& options,
                                             ReadItem read_item) {
  std::vector<Located<Item>> items;
  if (node.IsScalar()) {
    const std::string name = node.Scalar();
    if (!options.base_dir) {
      r.fail(node, fmt::format("{}: '{}' names a file, but this text has no directory", key, name));
    }
    const fs::path relative(name);
    if (name.empty() || relative.is_absolute() ||
        std::any_of(relative.begin(), relative.end(),
                    [](const fs::path& part) { return part == ".."; })) {
      r.fail(node, fmt::format("{}: '{}' must be a relative path without '..'", key, name));
    }
    const fs::path path = *options.base_dir / relative;
    std::ifstream in(path, std::ios::binary);
    std::error_code ec;
    if (!in || fs::is_directory(path, ec)) {
      r.fail(node, fmt::format("{}: cannot read '{}'", key, path.string()));
    }
    std::ostringstream text;
    text << in.rdbuf();
    const Reader inner(path.string());
    if (const int bad = first_invalid_utf8_line(text.str()); bad != 0) {
      inner.fail_at(bad, "the text is not valid UTF-8");
    }
    YAML::Node root;
    try {
      root = YAML::Load(text.str());
    } catch (const YAML::Exception& e) {
      inner.fail_at(e.mark.line >= 0 ? e.mark.line + 1 : 0, e.msg);
    }
    if (!root.IsSequence()) inner.fail(root, fmt::format("{} file must hold a YAML list", key));
    for (const auto& item : root)
      items.push_back({read_item(inner, item), inner.file(), Reader::line_of(item)});
    return items;
  }
  require_sequence(r, node, key);
  for (const auto& item : node)
    items.push_back({read_item(r, item), r.file(), Reader::line_of(item)});
  return items;
}

// The items of a list section, refusing two with the same key (`same`).
template <class Item, class Same, class Describe>
std::vector<Item> unique_items(std::vector<Located<Item>> located, std::string_view section,
                               Same same, Describe describe) {
  std::vector<Item> items;
  for (std::size_t i = 0; i < located.size(); ++i) {
    for (std::size_t j = 0; j < i; ++j) {
      if (same(located[i].item, located[j].item)) {
        throw Failure{TextError{located[i].file, located[i].line,
                                fmt::format("{}: {} is listed twice (first on line {})", section,
                                            describe(located[i].item), located[j].line)}};
      }
    }
    items.push_back(std::move(located[i].item));
  }
  return items;
}

// coe: the drive's CoE rules (drive_profile.hpp CoeRules).
CoeRules read_coe(const Reader& r, const YAML::Node& node) {
  const MapView map(r, node, "coe",
                    {"max_sdo_size", "absent_objects", "pdo_assignment_evaluated",
                     "pdo_configuration_in", "init_loads_saved_values", "source"});
  CoeRules c;
  if (auto v = map.get("max_sdo_size")) {
    c.max_sdo_size = static_cast<std::uint32_t>(integer(r, *v, "coe.max_sdo_size", 1, 0xFFFFFFFF));
  }
  if (auto v = map.get("absent_objects")) {
    c.absent_objects = object_ranges(r, *v, "coe.absent_objects");
  }
  if (auto v = map.get("pdo_assignment_evaluated")) {
    c.pdo_assignment_evaluated = boolean(r, *v, "coe.pdo_assignment_evaluated");
  }
  if (auto v = map.get("pdo_configuration_in")) {
    const std::string text = scalar(r, *v, "coe.pdo_configuration_in");
    if (text == to_string(PdoConfigurationIn::preop)) {
      c.pdo_configuration_in = PdoConfigurationIn::preop;
    } else if (text == to_string(PdoConfigurationIn::any)) {
      c.pdo_configuration_in = PdoConfigurationIn::any;
    } else {
      r.fail(*v, fmt::format("coe.pdo_configuration_in: '{}' is not one of preop, any", text));
    }
  }
  if (auto v = map.get("init_loads_saved_values")) {
    c.init_loads_saved_values = boolean(r, *v, "coe.init_loads_saved_values");
  }
  c.sources = sources(r, map.require("source", "coe"), "coe.source");
  return c;
}

// modes_only_on: [{mode, link, source}]: each a mode of `modes`, listed once.
std::vector<ModeOnlyOn> read_modes_only_on(const Reader& r, const YAML::Node& node,
                                           const std::vector<int>& modes) {
  require_sequence(r, node, "modes_only_on");
  std::vector<ModeOnlyOn> out;
  for (const auto& item : node) {
    const MapView map(r, item, "modes_only_on entry", {"mode", "link", "source"});
    ModeOnlyOn m;
    const YAML::Node mode = map.require("mode", "modes_only_on entry");
    m.mode = static_cast<int>(integer(r, mode, "modes_only_on.mode", -128, 127));
    if (std::find(modes.begin(), modes.end(), m.mode) == modes.end()) {
      r.fail(mode, fmt::format("modes_only_on: {} is not in modes", m.mode));
    }
    for (const auto& seen : out) {
      if (seen.mode == m.mode)
        r.fail(mode, fmt::format("modes_only_on: {} is listed twice", m.mode));
    }
    const YAML::Node link = map.require("link", "modes_only_on entry");
    const std::string text = scalar(r, link, "modes_only_on.link");
    const auto parsed = parse_link(text);
    if (!parsed) {
      r.fail(link, fmt::format("modes_only_on.link: '{}' is not one of can, ethercat", text));
    }
    m.link = *parsed;
    m.sources = sources(r, map.require("source", "modes_only_on entry"), "modes_only_on.source");
    out.push_back(std::move(m));
  }
  return out;
}

DriveProfile read_profile(const Reader& r, const YAML::Node& root, const ParseOptions& options) {
  if (!root.IsDefined() || root.IsNull()) r.fail_at(0, "the profile is empty");
  const MapView map(
      r, root, "profile",
      {"name", "title", "manual", "identity", "features", "detect", "modes", "modes_only_on",
       "homing_methods", "option_codes", "timing", "objects", "emcy_codes", "pdo_defaults",
       "deviations", "commissioning", "coe", "personality"});
  DriveProfile p;
  const YAML::Node name_node = map.require("name", "profile");
  p.name = scalar(r, name_node, "name");
  if (!is_lower_name(p.name, false)) {
    r.fail(name_node, fmt::format("name: '{}' must be [a-z0-9_-]+", p.name));
  }
  if (options.check_name && !options.file_name.empty()) {
    const std::string stem = fs::path(options.file_name).stem().string();
    if (stem != p.name) {
      r.fail(name_node, fmt::format("name: '{}' is not the file name '{}'", p.name, stem));
    }
  }
  p.title = nonempty_scalar(r, map.require("title", "profile"), "title");
  if (auto v = map.get("manual")) p.manual = nonempty_scalar(r, *v, "manual");
  if (auto v = map.get("identity")) p.identity = read_identity(r, *v, "identity");
  if (auto v = map.get("modes")) p.modes = int_list(r, *v, "modes", -128, 127);
  if (auto v = map.get("modes_only_on")) p.modes_only_on = read_modes_only_on(r, *v, p.modes);
  if (auto v = map.get("homing_methods")) {
    p.homing_methods = int_list(r, *v, "homing_methods", -128, 127);
  }
  if (auto v = map.get("option_codes")) p.option_codes = read_option_codes(r, *v, "option_codes");

  // Features: the closed vocabulary, consistent with the lists above, which imply theirs.
  const YAML::Node features = map.require("features", "profile");
  require_sequence(r, features, "features");
  std::set<std::string> implied;
  for (int mode : p.modes)
    if (auto f = mode_feature(mode)) implied.emplace(*f);
  for (int method : p.homing_methods)
    implied.insert(homing_method_feature(method));
  for (const auto& [code, values] : p.option_codes)
    for (int value : values)
      implied.insert(option_feature(code, value));
  for (const auto& item : features) {
    const std::string f = scalar(r, item, "features");
    if (!is_known_feature(f)) {
      r.fail(item,
             fmt::format("features: unknown feature '{}' (vectors/FORMAT.md \"Features\")", f));
    }
    if (p.features.contains(f)) r.fail(item, fmt::format("features: '{}' is listed twice", f));
    if (parse_object_need(f)) {
      r.fail(item, fmt::format("features: '{}' is an object need (vectors only): the device's "
                               "objects come from its EDS or a probe",
                               f));
    }
    const bool family =
        f.starts_with("mode.") || f.starts_with("homing.method.") || f.starts_with("option.");
    if (family && !implied.contains(f)) {
      r.fail(item, fmt::format("features: '{}' needs its value in modes, homing_methods or "
                               "option_codes",
                               f));
    }
    p.features.insert(f);
  }
  p.features.insert(implied.begin(), implied.end());
  if (auto v = map.get("detect")) {
    require_sequence(r, *v, "detect");
    for (const auto& item : *v) {
      const std::string f = scalar(r, item, "detect");
      if (!is_detectable_feature(f)) {
        r.fail(item, fmt::format("detect: '{}' cannot be probed (detectable: {})", f,
                                 fmt::join(detectable_features(), " ")));
      }
      if (p.features.contains(f)) {
        r.fail(item, fmt::format("detect: '{}' is also claimed in features (a feature is either "
                                 "claimed or detected)",
                                 f));
      }
      if (!p.detect.insert(f).second) r.fail(item, fmt::format("detect: '{}' is listed twice", f));
    }
  }
  // Which transition waits for the hardware enable: one of them, and it implies the input.
  if (p.features.contains(std::string(kHardwareEnableT2)) &&
      p.features.contains(std::string(kHardwareEnableT3))) {
    r.fail(features, fmt::format("features: {} and {} exclude each other", kHardwareEnableT2,
                                 kHardwareEnableT3));
  }
  if (p.features.contains(std::string(kHardwareEnableT2)) ||
      p.features.contains(std::string(kHardwareEnableT3))) {
    p.features.insert("hardware-enable");
  }

  if (auto v = map.get("timing")) {
    const YAML::Node& timing = *v;
    if (!timing.IsMap()) r.fail(timing, "timing must be a map");
    std::set<std::string> seen;
    for (auto it = timing.begin(); it != timing.end(); ++it) {
      const std::string key = scalar(r, it->first, "timing key");
      if (!find_timing(key)) {
        std::string known;
        for (const auto& row : timing_table())
          known += (known.empty() ? "" : ", ") + std::string(row.name);
        r.fail(it->first, fmt::format("timing: unknown name '{}' (known: {})", key, known));
      }
      if (!seen.insert(key).second)
        r.fail(it->first, fmt::format("timing: duplicate key '{}'", key));
      p.timing[key] = duration(r, it->second, fmt::format("timing.{}", key));
    }
  }
  if (auto v = map.get("objects")) {
    p.objects = unique_items(
        read_list_section<ObjectSpec>(r, *v, "objects", options, read_object), "objects",
        [](const ObjectSpec& x, const ObjectSpec& y) {
          return x.index == y.index && x.sub == y.sub;
        },
        [](const ObjectSpec& x) { return fmt::format("{:04X}h sub {}", x.index, x.sub); });
  }
  if (auto v = map.get("emcy_codes")) {
    p.emcy_codes = unique_items(
        read_list_section<EmcyCodeSpec>(r, *v, "emcy_codes", options, read_emcy_code), "emcy_codes",
        [](const EmcyCodeSpec& x, const EmcyCodeSpec& y) { return x.code == y.code; },
        [](const EmcyCodeSpec& x) { return fmt::format("{:04X}h", x.code); });
  }
  if (auto v = map.get("pdo_defaults")) {
    p.pdo_defaults = unique_items(
        read_list_section<PdoDefault>(r, *v, "pdo_defaults", options, read_pdo_default),
        "pdo_defaults",
        [](const PdoDefault& x, const PdoDefault& y) {
          return x.kind == y.kind && x.number == y.number;
        },
        [](const PdoDefault& x) {
          return fmt::format("{}{}", x.kind == PdoKind::rpdo ? "rpdo" : "tpdo", x.number);
        });
  }
  if (auto v = map.get("deviations")) {
    require_sequence(r, *v, "deviations");
    for (const auto& item : *v) {
      Deviation d = read_deviation(r, item);
      for (const auto& seen : p.deviations) {
        if (seen.id == d.id) r.fail(item, fmt::format("deviations: id '{}' is used twice", d.id));
      }
      p.deviations.push_back(std::move(d));
    }
  }
  if (auto v = map.get("commissioning")) p.commissioning = read_commissioning(r, *v);
  if (auto v = map.get("coe")) p.coe = read_coe(r, *v);
  if (auto v = map.get("personality")) {
    p.personality = read_personality(r, *v);
    // The transition the personality's hardware enable holds is the profile's feature too.
    if (p.personality.hardware_enable != HardwareEnable::none) {
      const bool t2 = p.personality.hardware_enable == HardwareEnable::transition_2;
      const std::string_view own = t2 ? kHardwareEnableT2 : kHardwareEnableT3;
      const std::string_view other = t2 ? kHardwareEnableT3 : kHardwareEnableT2;
      if (p.features.contains(std::string(other))) {
        r.fail(*v, fmt::format("personality.hardware_enable: {} contradicts the feature {}",
                               to_string(p.personality.hardware_enable), other));
      }
      p.features.emplace(own);
      p.features.insert("hardware-enable");
    }
    // The personality must be able to do what it says with the profile's lists.
    const Personality effective = p.effective_personality();
    const std::vector<int>& modes = *effective.modes;
    for (const auto& m : effective.manufacturer_modes) {
      if (std::find(modes.begin(), modes.end(), m.value) == modes.end()) {
        r.fail(*v,
               fmt::format("personality.manufacturer_modes: {} is not in the modes list", m.value));
      }
    }
    for (const auto& [code, value] : effective.option_defaults) {
      const auto& accepted = *effective.option_codes;
      const auto it = accepted.find(code);
      if (it != accepted.end() &&
          std::find(it->second.begin(), it->second.end(), value) == it->second.end()) {
        r.fail(*v, fmt::format("personality.option_defaults.{}: {} is not an accepted value",
                               to_string(code), value));
      }
    }
  }
  return p;
}

// --- serialisation -----------------------------------------------------------------------------

void emit_sources(YAML::Emitter& out, const std::vector<std::string>& sources) {
  out << YAML::Key << "source";
  if (sources.size() == 1) {
    out << YAML::Value << YAML::DoubleQuoted << sources.front();
  } else {
    out << YAML::Value << YAML::BeginSeq;
    for (const auto& s : sources)
      out << YAML::DoubleQuoted << s;
    out << YAML::EndSeq;
  }
}

std::string hex(std::uint64_t value, int digits) {
  return fmt::format("0x{:0{}X}", value, digits);
}

void emit_observation(YAML::Emitter& out, const DeviationObservation& o) {
  out << YAML::Flow << YAML::BeginMap;
  switch (o.kind) {
    case DeviationObservation::Kind::abort:
      out << YAML::Key << "abort" << YAML::Value << hex(o.abort, 8);
      break;
    case DeviationObservation::Kind::value:
      out << YAML::Key << "value" << YAML::Value;
      if (o.value_max) {
        out << YAML::Flow << YAML::BeginSeq << o.value << *o.value_max << YAML::EndSeq;
      } else {
        out << o.value;
      }
      break;
    case DeviationObservation::Kind::nothing:
      out << YAML::Key << "no_answer" << YAML::Value << "true";
      break;
    case DeviationObservation::Kind::accepted:
      out << YAML::Key << "accepted" << YAML::Value << "true";
      break;
    case DeviationObservation::Kind::state: {
      std::string kebab(cia402::to_string(o.state));
      std::replace(kebab.begin(), kebab.end(), ' ', '-');
      out << YAML::Key << "state" << YAML::Value << kebab;
      break;
    }
    case DeviationObservation::Kind::statusword:
      out << YAML::Key << "statusword" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
          << "mask" << YAML::Value << hex(o.mask, 4) << YAML::Key << "value" << YAML::Value
          << hex(o.statusword, 4) << YAML::EndMap;
      break;
    case DeviationObservation::Kind::text:
      out << YAML::Key << "text" << YAML::Value << YAML::DoubleQuoted << o.text;
      break;
  }
  out << YAML::EndMap;
}

void emit_observations(YAML::Emitter& out, const std::vector<DeviationObservation>& list) {
  if (list.size() == 1) {
    emit_observation(out, list.front());
    return;
  }
  out << YAML::Flow << YAML::BeginSeq;
  for (const auto& o : list)
    emit_observation(out, o);
  out << YAML::EndSeq;
}

void emit_int_list(YAML::Emitter& out, const std::vector<int>& values) {
  out << YAML::Flow << YAML::BeginSeq;
  for (int v : values)
    out << v;
  out << YAML::EndSeq;
}

void emit_identity(YAML::Emitter& out, const Identity& id) {
  out << YAML::BeginMap;
  auto u32 = [&](std::string_view key, const std::optional<std::uint32_t>& v) {
    if (v) out << YAML::Key << std::string(key) << YAML::Value << hex(*v, 8);
  };
  auto text = [&](std::string_view key, const std::optional<std::string>& v) {
    if (v) out << YAML::Key << std::string(key) << YAML::Value << YAML::DoubleQuoted << *v;
  };
  u32("device_type", id.device_type);
  u32("vendor_id", id.vendor_id);
  u32("product_code", id.product_code);
  u32("revision_number", id.revision_number);
  u32("serial_number", id.serial_number);
  text("device_name", id.device_name);
  text("hardware_version", id.hardware_version);
  text("software_version", id.software_version);
  out << YAML::EndMap;
}

void emit_option_codes(YAML::Emitter& out, const std::map<OptionCode, std::vector<int>>& codes) {
  out << YAML::BeginMap;
  for (const auto& [code, values] : codes) {
    out << YAML::Key << std::string(to_string(code)) << YAML::Value;
    emit_int_list(out, values);
  }
  out << YAML::EndMap;
}

void emit_personality(YAML::Emitter& out, const Personality& p) {
  out << YAML::BeginMap;
  if (p.identity) {
    out << YAML::Key << "identity" << YAML::Value;
    emit_identity(out, *p.identity);
  }
  if (p.modes) {
    out << YAML::Key << "modes" << YAML::Value;
    emit_int_list(out, *p.modes);
  }
  if (!p.manufacturer_modes.empty()) {
    out << YAML::Key << "manufacturer_modes" << YAML::Value << YAML::BeginSeq;
    for (const auto& m : p.manufacturer_modes) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "value" << YAML::Value << m.value
          << YAML::Key << "behaves_as" << YAML::Value << m.behaves_as;
      if (m.logic != ManufacturerModeLogic::behaves_as) {
        out << YAML::Key << "logic" << YAML::Value << std::string(to_string(m.logic));
      }
      out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << m.name << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  if (p.option_codes) {
    out << YAML::Key << "option_codes" << YAML::Value;
    emit_option_codes(out, *p.option_codes);
  }
  if (!p.option_defaults.empty()) {
    out << YAML::Key << "option_defaults" << YAML::Value << YAML::BeginMap;
    for (const auto& [code, value] : p.option_defaults)
      out << YAML::Key << std::string(to_string(code)) << YAML::Value << value;
    out << YAML::EndMap;
  }
  out << YAML::Key << "hardware_enable" << YAML::Value << std::string(to_string(p.hardware_enable));
  out << YAML::Key << "emcy_follow_up" << YAML::Value << (p.emcy_follow_up ? "true" : "false");
  out << YAML::Key << "error_code_format" << YAML::Value
      << std::string(to_string(p.error_code_format));
  out << YAML::Key << "homing" << YAML::Value << std::string(to_string(p.homing));
  out << YAML::Key << "manufacturer_homing" << YAML::Value
      << std::string(to_string(p.manufacturer_homing));
  if (p.homing_default_method) {
    out << YAML::Key << "homing_default_method" << YAML::Value << *p.homing_default_method;
  }
  out << YAML::Key << "homing_halt_sets_error" << YAML::Value
      << (p.homing_halt_sets_error ? "true" : "false");
  if (!p.object_types.empty()) {
    out << YAML::Key << "object_types" << YAML::Value << YAML::BeginSeq;
    for (const auto& t : p.object_types) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "index" << YAML::Value << hex(t.index, 4)
          << YAML::Key << "sub" << YAML::Value << static_cast<int>(t.sub) << YAML::Key << "type"
          << YAML::Value << std::string(cia301::info(t.type).name) << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  if (!p.objects.empty()) {
    out << YAML::Key << "objects" << YAML::Value << YAML::BeginSeq;
    for (const auto& o : p.objects) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "index" << YAML::Value << hex(o.index, 4)
          << YAML::Key << "sub" << YAML::Value << static_cast<int>(o.sub);
      if (o.type) {
        out << YAML::Key << "type" << YAML::Value << std::string(cia301::info(*o.type).name);
      }
      if (o.access) {
        out << YAML::Key << "access" << YAML::Value << std::string(cia301::to_string(*o.access));
      }
      if (o.default_value) out << YAML::Key << "default" << YAML::Value << *o.default_value;
      if (o.min) out << YAML::Key << "min" << YAML::Value << *o.min;
      if (o.max) out << YAML::Key << "max" << YAML::Value << *o.max;
      if (!o.values.empty()) {
        out << YAML::Key << "values" << YAML::Value << YAML::Flow << YAML::BeginSeq;
        for (std::int64_t v : o.values)
          out << v;
        out << YAML::EndSeq;
      }
      if (o.action != ObjectAction::none) {
        out << YAML::Key << "action" << YAML::Value << std::string(to_string(o.action));
      }
      if (!o.source.empty()) {
        out << YAML::Key << "source" << YAML::Value << YAML::DoubleQuoted << o.source;
      }
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  if (p.pdo_mapping_while_valid) {
    out << YAML::Key << "pdo_mapping_while_valid" << YAML::Value << "true";
  }
  if (p.pdo_cob_id_enable_only) {
    out << YAML::Key << "pdo_cob_id_enable_only" << YAML::Value << "true";
  }
  if (p.parameters_internal) {
    out << YAML::Key << "parameters_internal" << YAML::Value << "true";
  }
  if (!p.pp_change_on_set_point) {
    out << YAML::Key << "pp_change_on_set_point" << YAML::Value << "false";
  }
  if (p.ip_submode != 0) out << YAML::Key << "ip_submode" << YAML::Value << p.ip_submode;
  if (p.power_stage_in_switched_on) {
    out << YAML::Key << "power_stage_in_switched_on" << YAML::Value << "true";
  }
  if (p.nmt_min_spacing != can::Duration{}) {
    out << YAML::Key << "nmt_min_spacing" << YAML::Value << format_duration(p.nmt_min_spacing);
  }
  if (p.internal_units != InternalUnits{}) {
    out << YAML::Key << "internal_units" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "velocity" << YAML::Value << YAML::Flow << YAML::BeginSeq
        << p.internal_units.velocity.numerator << p.internal_units.velocity.divisor << YAML::EndSeq;
    out << YAML::Key << "acceleration" << YAML::Value << YAML::Flow << YAML::BeginSeq
        << p.internal_units.acceleration.numerator << p.internal_units.acceleration.divisor
        << YAML::EndSeq;
    out << YAML::EndMap;
  }
  if (p.encoder_resolution) {
    out << YAML::Key << "encoder_resolution" << YAML::Value << *p.encoder_resolution;
  }
  if (p.tpdo_transmit_masks != 0) {
    out << YAML::Key << "tpdo_transmit_masks" << YAML::Value << hex(p.tpdo_transmit_masks, 4);
  }
  out << YAML::Key << "guarding_loss" << YAML::Value << std::string(to_string(p.guarding_loss));
  if (p.manufacturer_objects != ManufacturerObjects::none) {
    out << YAML::Key << "manufacturer_objects" << YAML::Value
        << std::string(to_string(p.manufacturer_objects));
  }
  if (p.position_sampling != PositionSampling::none) {
    out << YAML::Key << "position_sampling" << YAML::Value
        << std::string(to_string(p.position_sampling));
  }
  if (p.position_range_limit != PositionRangeLimit::none) {
    out << YAML::Key << "position_range_limit" << YAML::Value
        << std::string(to_string(p.position_range_limit));
  }
  out << YAML::Key << "ack_latency_cycles" << YAML::Value << p.ack_latency_cycles;
  if (p.control_cycle) {
    out << YAML::Key << "control_cycle" << YAML::Value << format_duration(*p.control_cycle);
  }
  out << YAML::Key << "sdo_dlc" << YAML::Value << std::string(to_string(p.sdo_dlc));
  out << YAML::Key << "sdo_short_requests" << YAML::Value
      << std::string(to_string(p.sdo_short_requests));
  if (p.sdo_client) out << YAML::Key << "sdo_client" << YAML::Value << "true";
  if (p.time_consumer) out << YAML::Key << "time_consumer" << YAML::Value << "true";
  if (p.extra_sdo_servers != 0) {
    out << YAML::Key << "extra_sdo_servers" << YAML::Value << static_cast<int>(p.extra_sdo_servers);
    out << YAML::Key << "sdo_server_node_id" << YAML::Value
        << std::string(to_string(p.sdo_server_node_id));
  }
  if (p.bus_off != BusOffReaction::cia301) {
    out << YAML::Key << "bus_off" << YAML::Value << std::string(to_string(p.bus_off));
  }
  if (!p.cia402) out << YAML::Key << "cia402" << YAML::Value << false;
  if (!p.absent_objects.empty()) {
    out << YAML::Key << "absent_objects" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const ObjectRange& range : p.absent_objects) {
      if (range.first == range.last) {
        out << hex(range.first, 4);
      } else {
        out << YAML::Flow << YAML::BeginSeq << hex(range.first, 4) << hex(range.last, 4)
            << YAML::EndSeq;
      }
    }
    out << YAML::EndSeq;
  }
  if (!p.abort_codes.empty()) {
    out << YAML::Key << "abort_codes" << YAML::Value << YAML::BeginMap;
    for (const auto& [from, to] : p.abort_codes)
      out << YAML::Key << hex(from, 8) << YAML::Value << hex(to, 8);
    out << YAML::EndMap;
  }
  if (p.sdo_response_delay.max != can::Duration{}) {
    out << YAML::Key << "sdo_response_delay" << YAML::Value << YAML::Flow << YAML::BeginSeq
        << format_duration(p.sdo_response_delay.min) << format_duration(p.sdo_response_delay.max)
        << YAML::EndSeq;
  }
  if (p.pdo_mapping != PdoMapping::dynamic) {
    out << YAML::Key << "pdo_mapping" << YAML::Value << std::string(to_string(p.pdo_mapping));
  }
  if (p.empty_pdo_valid != EmptyPdoValid::accept) {
    out << YAML::Key << "empty_pdo_valid" << YAML::Value
        << std::string(to_string(p.empty_pdo_valid));
  }
  if (p.tpdo_sync_phase != TpdoSyncPhase::nth_sync) {
    out << YAML::Key << "tpdo_sync_phase" << YAML::Value
        << std::string(to_string(p.tpdo_sync_phase));
  }
  if (p.setpoint_buffer != 1) {
    out << YAML::Key << "setpoint_buffer" << YAML::Value << p.setpoint_buffer;
  }
  if (p.initial_mode != 0) {
    out << YAML::Key << "initial_mode" << YAML::Value << static_cast<int>(p.initial_mode);
  }
  if (p.ip_max_buffer != 16) out << YAML::Key << "ip_max_buffer" << YAML::Value << p.ip_max_buffer;
  if (p.max_motor_speed != MaxMotorSpeed::velocity_u32) {
    out << YAML::Key << "max_motor_speed" << YAML::Value
        << std::string(to_string(p.max_motor_speed));
  }
  if (p.restore_output_stage_off) {
    out << YAML::Key << "restore_output_stage_off" << YAML::Value << "true";
  }
  if (p.heartbeat_time_ms) {
    out << YAML::Key << "heartbeat_time_ms" << YAML::Value << *p.heartbeat_time_ms;
  }
  if (p.guard_time_ms) out << YAML::Key << "guard_time_ms" << YAML::Value << *p.guard_time_ms;
  if (p.life_time_factor) {
    out << YAML::Key << "life_time_factor" << YAML::Value << static_cast<int>(*p.life_time_factor);
  }
  if (!p.note.empty()) out << YAML::Key << "note" << YAML::Value << YAML::DoubleQuoted << p.note;
  out << YAML::EndMap;
}

}  // namespace

std::string to_string(const CobIdSpec& cob_id) {
  return cob_id.plus_node ? fmt::format("{:03X}+N", cob_id.base)
                          : fmt::format("{:03X}", cob_id.base);
}

Expected<CobIdSpec, std::string> parse_cob_id_spec(std::string_view text) {
  CobIdSpec spec;
  std::string_view body = text;
  if (body.ends_with("+N")) {
    spec.plus_node = true;
    body.remove_suffix(2);
  }
  if (body.starts_with("0x") || body.starts_with("0X")) body.remove_prefix(2);
  std::uint64_t value = 0;
  auto [ptr, ec] = std::from_chars(body.data(), body.data() + body.size(), value, 16);
  if (body.empty() || ec != std::errc{} || ptr != body.data() + body.size() || body.size() > 8) {
    return Unexpected(fmt::format("'{}' is not a COB-ID (hex, optionally +N: 180+N)", text));
  }
  if (value > 0xFFFFFFFF) return Unexpected(fmt::format("'{}': COB-ID out of range", text));
  spec.base = static_cast<std::uint32_t>(value);
  return spec;
}

const DeviationVector* Deviation::find(std::string_view vector_id) const {
  for (const auto& v : vectors)
    if (v.id == vector_id) return &v;
  return nullptr;
}

const std::vector<DeviationObservation>& Deviation::observed_for(
    const DeviationVector& vector) const {
  return vector.observed.empty() ? observed : vector.observed;
}

std::string DeviationObservation::describe() const {
  switch (kind) {
    case Kind::abort:
      return fmt::format("abort {:08X}h", abort);
    case Kind::value:
      return value_max ? fmt::format("value in [{}, {}]", value, *value_max)
                       : fmt::format("value {}", value);
    case Kind::nothing:
      return "nothing (no frame or answer in time)";
    case Kind::accepted:
      return "the transfer accepted";
    case Kind::state:
      return fmt::format("state {}", cia402::to_string(state));
    case Kind::statusword:
      return fmt::format("statusword & {:04X}h == {:04X}h", mask, statusword);
    case Kind::text:
      return fmt::format("Actual containing \"{}\"", text);
  }
  return {};
}

std::optional<can::Duration> DriveProfile::timing_value(std::string_view key) const {
  if (auto it = timing.find(std::string(key)); it != timing.end()) return it->second;
  if (const TimingName* row = find_timing(key)) return row->default_value;
  return std::nullopt;
}

std::string_view to_string(Link link) {
  switch (link) {
    case Link::can:
      return "can";
    case Link::ethercat:
      return "ethercat";
  }
  return "?";
}

std::optional<Link> parse_link(std::string_view text) {
  if (text == "can") return Link::can;
  if (text == "ethercat") return Link::ethercat;
  return std::nullopt;
}

std::optional<Link> DriveProfile::only_on(std::string_view feature) const {
  for (const auto& m : modes_only_on) {
    const auto f = mode_feature(m.mode);
    if (f && *f == feature) return m.link;
  }
  return std::nullopt;
}

std::vector<int> DriveProfile::modes_on(Link link) const {
  std::vector<int> out;
  for (int mode : modes) {
    const bool elsewhere =
        std::any_of(modes_only_on.begin(), modes_only_on.end(),
                    [&](const ModeOnlyOn& m) { return m.mode == mode && m.link != link; });
    if (!elsewhere) out.push_back(mode);
  }
  return out;
}

std::string_view to_string(PdoConfigurationIn in) {
  switch (in) {
    case PdoConfigurationIn::preop:
      return "preop";
    case PdoConfigurationIn::any:
      return "any";
  }
  return "?";
}

bool CoeRules::is_absent(std::uint16_t index) const {
  for (const ObjectRange& range : absent_objects) {
    if (index >= range.first && index <= range.last) return true;
  }
  return false;
}

bool Commissioning::applies_to(std::string_view vector_id) const {
  if (writes.empty()) return false;
  const auto match = [&](const std::string& glob) { return glob_match(glob, vector_id); };
  return std::any_of(vectors.begin(), vectors.end(), match) &&
         std::none_of(except.begin(), except.end(), match);
}

std::vector<const Deviation*> DriveProfile::deviations_for(std::string_view vector_id) const {
  std::vector<const Deviation*> found;
  for (const auto& d : deviations)
    if (d.find(vector_id) != nullptr) found.push_back(&d);
  return found;
}

Personality DriveProfile::effective_personality() const {
  Personality p = personality;
  if (!p.identity) p.identity = identity;
  if (!p.modes) p.modes = modes;
  if (!p.option_codes) p.option_codes = option_codes;
  return p;
}

std::string_view to_string(HardwareEnable enable) {
  switch (enable) {
    case HardwareEnable::none:
      return "none";
    case HardwareEnable::transition_2:
      return "transition-2";
    case HardwareEnable::transition_3:
      return "transition-3";
  }
  return "none";
}
std::string_view to_string(HomingTable table) {
  switch (table) {
    case HomingTable::none:
      return "none";
    case HomingTable::festo:
      return "festo";
    case HomingTable::kollmorgen:
      return "kollmorgen";
    case HomingTable::irtsa:
      return "irtsa";
  }
  return "none";
}
std::string_view to_string(ErrorCodeFormat format) {
  return format == ErrorCodeFormat::standard ? "standard" : "error-number";
}
std::string_view to_string(HomingStyle style) {
  return style == HomingStyle::standard ? "standard" : "set-position";
}
std::string_view to_string(SdoShortRequests policy) {
  return policy == SdoShortRequests::ignore ? "ignore" : "pad";
}
std::string_view to_string(BusOffReaction reaction) {
  switch (reaction) {
    case BusOffReaction::cia301:
      return "cia301";
    case BusOffReaction::kollmorgen_f23:
      return "kollmorgen-f23";
    case BusOffReaction::esr_8180:
      return "esr-8180";
  }
  return "?";
}
std::string_view to_string(cia301::SdoNodeIdSub sub) {
  switch (sub) {
    case cia301::SdoNodeIdSub::none:
      return "none";
    case cia301::SdoNodeIdSub::client:
      return "client";
    case cia301::SdoNodeIdSub::server:
      return "server";
  }
  return "?";
}
std::string_view to_string(ObjectAction action) {
  return action == ObjectAction::none ? "none" : "set-actual-position";
}
std::string_view to_string(SdoDlc dlc) {
  return dlc == SdoDlc::always_8 ? "always-8" : "minimal";
}
std::string_view to_string(ManufacturerModeLogic logic) {
  return logic == ManufacturerModeLogic::irtsa_mpp ? "irtsa-mpp" : "behaves-as";
}

std::string_view to_string(ManufacturerObjects objects) {
  switch (objects) {
    case ManufacturerObjects::none:
      return "none";
    case ManufacturerObjects::kollmorgen:
      return "kollmorgen";
  }
  return "none";
}

std::string_view to_string(PositionRangeLimit limit) {
  switch (limit) {
    case PositionRangeLimit::cia402:
      return "cia402";
    case PositionRangeLimit::festo:
      return "festo";
    case PositionRangeLimit::none:
      break;
  }
  return "none";
}

std::string_view to_string(PositionSampling sampling) {
  return sampling == PositionSampling::festo ? "festo" : "none";
}

std::string_view to_string(PdoMapping mapping) {
  return mapping == PdoMapping::fixed ? "static" : "dynamic";
}

std::string_view to_string(EmptyPdoValid policy) {
  return policy == EmptyPdoValid::refuse ? "refuse" : "accept";
}

std::string_view to_string(MaxMotorSpeed speed) {
  return speed == MaxMotorSpeed::rpm_u16 ? "rpm-u16" : "velocity-u32";
}

std::string_view to_string(TpdoSyncPhase phase) {
  return phase == TpdoSyncPhase::first_sync ? "first-sync" : "nth-sync";
}

std::string_view to_string(GuardingLoss loss) {
  switch (loss) {
    case GuardingLoss::error_behaviour:
      return "error-behaviour";
    case GuardingLoss::pre_operational:
      return "pre-operational";
    case GuardingLoss::no_nmt_change:
      return "no-nmt-change";
  }
  return "error-behaviour";
}

Expected<DriveProfile, TextError> parse_profile(std::string_view text,
                                                const ParseOptions& options) {
  const Reader reader(options.file_name);
  if (const int bad = first_invalid_utf8_line(text); bad != 0) {
    return Unexpected(TextError{options.file_name, bad, "the text is not valid UTF-8"});
  }
  try {
    const YAML::Node root = YAML::Load(std::string(text));
    return read_profile(reader, root, options);
  } catch (const Failure& failure) {
    return Unexpected(failure.error);
  } catch (const YAML::DeepRecursion& e) {
    return Unexpected(TextError{options.file_name, e.mark.line >= 0 ? e.mark.line + 1 : 0,
                                "the YAML is nested too deeply"});
  } catch (const YAML::Exception& e) {
    return Unexpected(TextError{options.file_name, e.mark.line >= 0 ? e.mark.line + 1 : 0, e.msg});
  } catch (const std::exception& e) {
    return Unexpected(TextError{options.file_name, 0, e.what()});
  }
}

Expected<DriveProfile, TextError> load_profile(const std::filesystem::path& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    return Unexpected(TextError{path.string(), 0, "is a directory, not a profile"});
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) return Unexpected(TextError{path.string(), 0, "cannot read the file"});
  std::ostringstream text;
  text << in.rdbuf();
  ParseOptions options;
  options.file_name = path.string();
  options.base_dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  auto profile = parse_profile(text.str(), options);
  if (profile) profile->path = path;
  return profile;
}

std::vector<std::string> list_profiles(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& p = it->path();
    if (p.extension() != ".yaml") continue;
    // List files included by profiles live next to them; a profile is a map with `name:`,
    // so only files whose name is a profile name qualify (no '.' in the stem).
    const std::string stem = p.stem().string();
    if (is_lower_name(stem, false)) names.push_back(stem);
  }
  std::sort(names.begin(), names.end());
  return names;
}

Expected<DriveProfile, TextError> find_profile(std::string_view name_or_path,
                                               const std::filesystem::path& dir) {
  const std::string text(name_or_path);
  if (text.find('/') != std::string::npos || text.ends_with(".yaml")) return load_profile(text);
  if (!is_lower_name(text, false)) {
    return Unexpected(TextError{"", 0, fmt::format("'{}' is not a profile name", text)});
  }
  const fs::path path = dir / (text + ".yaml");
  std::error_code ec;
  if (!fs::exists(path, ec)) {
    const auto known = list_profiles(dir);
    return Unexpected(
        TextError{"", 0,
                  fmt::format("no profile '{}' in {} (known: {})", text, dir.string(),
                              known.empty() ? std::string("none")
                                            : fmt::format("{}", fmt::join(known, ", ")))});
  }
  return load_profile(path);
}

std::string to_yaml(const DriveProfile& p) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << p.name;
  out << YAML::Key << "title" << YAML::Value << YAML::DoubleQuoted << p.title;
  if (!p.manual.empty())
    out << YAML::Key << "manual" << YAML::Value << YAML::DoubleQuoted << p.manual;
  if (p.identity != Identity{}) {
    out << YAML::Key << "identity" << YAML::Value;
    emit_identity(out, p.identity);
  }
  out << YAML::Key << "features" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (const auto& f : p.features)
    out << f;
  out << YAML::EndSeq;
  if (!p.detect.empty()) {
    out << YAML::Key << "detect" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& f : p.detect)
      out << f;
    out << YAML::EndSeq;
  }
  out << YAML::Key << "modes" << YAML::Value;
  emit_int_list(out, p.modes);
  if (!p.modes_only_on.empty()) {
    out << YAML::Key << "modes_only_on" << YAML::Value << YAML::BeginSeq;
    for (const auto& m : p.modes_only_on) {
      out << YAML::BeginMap << YAML::Key << "mode" << YAML::Value << m.mode;
      out << YAML::Key << "link" << YAML::Value << std::string(to_string(m.link));
      emit_sources(out, m.sources);
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }
  out << YAML::Key << "homing_methods" << YAML::Value;
  emit_int_list(out, p.homing_methods);
  out << YAML::Key << "option_codes" << YAML::Value;
  emit_option_codes(out, p.option_codes);
  out << YAML::Key << "timing" << YAML::Value << YAML::BeginMap;
  for (const auto& [key, value] : p.timing)
    out << YAML::Key << key << YAML::Value << format_duration(value);
  out << YAML::EndMap;

  out << YAML::Key << "objects" << YAML::Value << YAML::BeginSeq;
  for (const auto& o : p.objects) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "index" << YAML::Value << hex(o.index, 4);
    out << YAML::Key << "sub" << YAML::Value << static_cast<int>(o.sub);
    out << YAML::Key << "type" << YAML::Value << std::string(cia301::info(o.type).name);
    out << YAML::Key << "access" << YAML::Value << std::string(cia301::to_string(o.access));
    out << YAML::Key << "pdo" << YAML::Value << (o.pdo ? "true" : "false");
    if (o.default_value) out << YAML::Key << "default" << YAML::Value << *o.default_value;
    if (o.default_text) {
      out << YAML::Key << "default" << YAML::Value << YAML::DoubleQuoted << *o.default_text;
    }
    if (o.min) out << YAML::Key << "min" << YAML::Value << *o.min;
    if (o.max) out << YAML::Key << "max" << YAML::Value << *o.max;
    if (!o.name.empty()) out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << o.name;
    emit_sources(out, o.sources);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;

  out << YAML::Key << "emcy_codes" << YAML::Value << YAML::BeginSeq;
  for (const auto& e : p.emcy_codes) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "code" << YAML::Value << hex(e.code, 4);
    out << YAML::Key << "text" << YAML::Value << YAML::DoubleQuoted << e.text;
    if (e.error_register) {
      out << YAML::Key << "register" << YAML::Value << hex(*e.error_register, 2);
    }
    if (!e.diagnostic.empty()) {
      out << YAML::Key << "diagnostic" << YAML::Value << YAML::DoubleQuoted << e.diagnostic;
    }
    emit_sources(out, e.sources);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;

  out << YAML::Key << "pdo_defaults" << YAML::Value << YAML::BeginSeq;
  for (const auto& d : p.pdo_defaults) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "pdo" << YAML::Value
        << fmt::format("{}{}", d.kind == PdoKind::rpdo ? "rpdo" : "tpdo", d.number);
    out << YAML::Key << "cob_id" << YAML::Value << to_string(d.cob_id);
    out << YAML::Key << "transmission" << YAML::Value << static_cast<int>(d.transmission);
    if (d.inhibit_time) out << YAML::Key << "inhibit_time" << YAML::Value << *d.inhibit_time;
    if (d.event_timer) out << YAML::Key << "event_timer" << YAML::Value << *d.event_timer;
    out << YAML::Key << "mapping" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (std::uint32_t m : d.mapping)
      out << hex(m, 8);
    out << YAML::EndSeq;
    emit_sources(out, d.sources);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;

  out << YAML::Key << "deviations" << YAML::Value << YAML::BeginSeq;
  for (const auto& d : p.deviations) {
    out << YAML::BeginMap;
    out << YAML::Key << "id" << YAML::Value << YAML::DoubleQuoted << d.id;
    out << YAML::Key << "vectors" << YAML::Value << YAML::BeginSeq;
    for (const auto& v : d.vectors) {
      if (v.observed.empty()) {
        out << YAML::DoubleQuoted << v.id;
        continue;
      }
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "id" << YAML::Value << YAML::DoubleQuoted
          << v.id;
      out << YAML::Key << "observed" << YAML::Value;
      emit_observations(out, v.observed);
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
    if (!d.observed.empty()) {
      out << YAML::Key << "observed" << YAML::Value;
      emit_observations(out, d.observed);
    }
    emit_sources(out, d.sources);
    out << YAML::Key << "description" << YAML::Value << YAML::DoubleQuoted << d.description;
    if (!d.contradiction.empty()) {
      out << YAML::Key << "contradiction" << YAML::Value << YAML::DoubleQuoted << d.contradiction;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;

  if (!p.commissioning.writes.empty()) {
    const Commissioning& c = p.commissioning;
    out << YAML::Key << "commissioning" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "vectors" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& g : c.vectors)
      out << YAML::DoubleQuoted << g;
    out << YAML::EndSeq;
    if (!c.except.empty()) {
      out << YAML::Key << "except" << YAML::Value << YAML::Flow << YAML::BeginSeq;
      for (const auto& g : c.except)
        out << YAML::DoubleQuoted << g;
      out << YAML::EndSeq;
    }
    out << YAML::Key << "writes" << YAML::Value << YAML::BeginSeq;
    for (const auto& w : c.writes) {
      out << YAML::BeginMap;
      out << YAML::Key << "index" << YAML::Value << hex(w.index, 4);
      out << YAML::Key << "sub" << YAML::Value << static_cast<int>(w.sub);
      out << YAML::Key << "value" << YAML::Value << w.value;
      out << YAML::Key << "size" << YAML::Value << static_cast<int>(w.size);
      emit_sources(out, w.sources);
      out << YAML::Key << "why" << YAML::Value << YAML::DoubleQuoted << w.why;
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
    out << YAML::EndMap;
  }

  if (p.coe != CoeRules{}) {
    const CoeRules& c = p.coe;
    out << YAML::Key << "coe" << YAML::Value << YAML::BeginMap;
    if (c.max_sdo_size) out << YAML::Key << "max_sdo_size" << YAML::Value << *c.max_sdo_size;
    if (!c.absent_objects.empty()) {
      out << YAML::Key << "absent_objects" << YAML::Value << YAML::Flow << YAML::BeginSeq;
      for (const ObjectRange& range : c.absent_objects) {
        out << YAML::Flow << YAML::BeginSeq << hex(range.first, 4) << hex(range.last, 4)
            << YAML::EndSeq;
      }
      out << YAML::EndSeq;
    }
    out << YAML::Key << "pdo_assignment_evaluated" << YAML::Value << c.pdo_assignment_evaluated;
    out << YAML::Key << "pdo_configuration_in" << YAML::Value
        << std::string(to_string(c.pdo_configuration_in));
    if (c.init_loads_saved_values)
      out << YAML::Key << "init_loads_saved_values" << YAML::Value << true;
    emit_sources(out, c.sources);
    out << YAML::EndMap;
  }

  out << YAML::Key << "personality" << YAML::Value;
  emit_personality(out, p.personality);
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace drivecheck::profile
