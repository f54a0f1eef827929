// The JSON report (layout in report_writers.hpp) and its reader for `drivecheck report diff`.
#include <fmt/format.h>

#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "reports/report_writers.hpp"

namespace drivecheck::reports {
namespace {

using conformance::DutIdentity;
using conformance::Level;
using conformance::RunResult;
using conformance::VectorResult;
using conformance::Verdict;
using nlohmann::json;

double seconds(can::Duration duration) {
  return static_cast<double>(duration.count()) / 1e9;
}
std::int64_t ns_of(can::TimePoint at) {
  return at.time_since_epoch().count();
}

template <class T>
void put_optional(json& object, const char* key, const std::optional<T>& value) {
  if (value) object[key] = *value;
}

json dut_json(const DutIdentity& dut) {
  json out = json::object();
  put_optional(out, "device_type", dut.device_type);
  put_optional(out, "device_name", dut.device_name);
  put_optional(out, "hardware_version", dut.hardware_version);
  put_optional(out, "software_version", dut.software_version);
  put_optional(out, "vendor_id", dut.vendor_id);
  put_optional(out, "product_code", dut.product_code);
  put_optional(out, "revision", dut.revision);
  put_optional(out, "serial", dut.serial);
  return out;
}

// A summarised repeated pattern starting at an entry (conformance::EvidenceRepeat).
void put_repeat(json& out, const conformance::EvidenceRepeat& repeat) {
  if (repeat.times == 0) return;
  out["repeat"] = {
      {"length", repeat.length}, {"times", repeat.times}, {"until_ns", ns_of(repeat.until)}};
}

json frames_json(const std::vector<conformance::EvidenceFrame>& list) {
  json frames = json::array();
  for (const auto& frame : list) {
    json item = {{"t_ns", ns_of(frame.at)},
                 {"t_s", seconds(frame.at.time_since_epoch())},
                 {"frame", can::to_candump(frame.frame)},
                 {"from_harness", frame.from_harness},
                 {"decoded", frame.decoded}};
    put_repeat(item, frame.repeat);
    frames.push_back(std::move(item));
  }
  return frames;
}

// A failed check's typed observation (conformance::Observation): only the fields the step
// filled, as integers (abort: the 32-bit SDO abort code; value: the value read, signed;
// statusword: 16 bits) and true flags.
json observation_json(const conformance::Observation& observed) {
  json out = json::object();
  if (observed.abort) out["abort"] = *observed.abort;
  if (observed.value) out["value"] = *observed.value;
  if (observed.statusword) out["statusword"] = *observed.statusword;
  if (observed.nothing) out["nothing"] = true;
  if (observed.accepted) out["accepted"] = true;
  return out;
}

json vector_json(const VectorResult& vector) {
  json out;
  out["id"] = vector.id;
  out["family"] = vector.family;
  out["title"] = vector.title;
  out["sources"] = vector.sources;
  out["level"] = std::string(to_string(vector.level));
  out["file"] = vector.file;
  out["line"] = vector.line;
  out["verdict"] = std::string(to_string(vector.verdict));
  out["message"] = vector.message;
  out["deviation_id"] = vector.deviation_id;
  out["deviation_source"] = vector.deviation_source;
  out["warning"] = vector.warning;
  json checks = json::array();
  for (const auto& check : vector.checks) {
    json c = {{"step", check.step},
              {"action", check.action},
              {"expected", check.expected},
              {"actual", check.actual},
              {"ok", check.ok}};
    if (check.at) c["t_ns"] = ns_of(*check.at);
    if (!check.observed.empty()) c["observed"] = observation_json(check.observed);
    if (!check.iterations.empty()) {
      json iterations = json::array();
      for (const auto& iteration : check.iterations)
        iterations.push_back({{"iteration", iteration.number}, {"of", iteration.of}});
      c["iterations"] = std::move(iterations);
    }
    checks.push_back(std::move(c));
  }
  out["checks"] = std::move(checks);
  out["frames"] = frames_json(vector.frames);
  out["between_vectors"] = frames_json(vector.between_vectors);
  out["frames_elided"] = vector.frames_elided;
  out["frames_elided_at"] = vector.frames_elided_at;
  // EtherCAT only (absent on CAN): the datagrams, runs of identical frames counted.
  if (!vector.datagrams.empty() || vector.datagrams_elided != 0) {
    json datagrams = json::array();
    for (const auto& d : vector.datagrams) {
      json item = {{"t_ns", ns_of(d.at)},
                   {"t_s", seconds(d.at.time_since_epoch())},
                   {"last_ns", ns_of(d.last)},
                   {"count", d.count},
                   {"decoded", d.decoded}};
      put_repeat(item, d.repeat);
      datagrams.push_back(std::move(item));
    }
    out["datagrams"] = std::move(datagrams);
    out["datagrams_elided"] = vector.datagrams_elided;
    out["datagrams_elided_at"] = vector.datagrams_elided_at;
  }
  json timings = json::array();
  for (const auto& timing : vector.timings) {
    json t = {{"name", timing.name},
              {"measured_ns", timing.measured.count()},
              {"measured_s", seconds(timing.measured)},
              {"ok", timing.ok}};
    if (timing.min) t["min_ns"] = timing.min->count();
    if (timing.max) t["max_ns"] = timing.max->count();
    timings.push_back(std::move(t));
  }
  out["timings"] = std::move(timings);
  json samples = json::array();
  for (const auto& sample : vector.samples) {
    samples.push_back({{"t_ns", ns_of(sample.at)},
                       {"signal", sample.signal},
                       {"value", sample.value},
                       {"origin", std::string(to_string(sample.origin))}});
  }
  out["samples"] = std::move(samples);
  out["samples_elided"] = vector.samples_elided;
  out["started_ns"] = ns_of(vector.started);
  out["finished_ns"] = ns_of(vector.finished);
  out["duration_s"] = seconds(vector.finished - vector.started);
  out["wall_s"] = vector.wall_seconds;
  return out;
}

// ---- reading ---------------------------------------------------------------------------

// A structural error: where in the document (a JSON path) and what is wrong.
struct ReadError {
  std::string message;
};

class Reader {
 public:
  const json& member(const json& object, const char* key) const {
    const auto it = object.find(key);
    if (it == object.end()) throw ReadError{where(key) + ": missing"};
    return *it;
  }
  std::string string(const json& object, const char* key) const {
    const json& value = member(object, key);
    if (!value.is_string()) throw ReadError{where(key) + ": expected a string"};
    return value.get<std::string>();
  }
  bool boolean(const json& object, const char* key) const {
    const json& value = member(object, key);
    if (!value.is_boolean()) throw ReadError{where(key) + ": expected true or false"};
    return value.get<bool>();
  }
  std::int64_t integer(const json& object, const char* key) const {
    const json& value = member(object, key);
    if (!value.is_number_integer()) throw ReadError{where(key) + ": expected an integer"};
    if (value.is_number_unsigned() &&
        value.get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX)) {
      throw ReadError{where(key) + ": out of range"};
    }
    return value.get<std::int64_t>();
  }
  // A time or duration in ns, limited to ±2^61 ns (±73 years) so that the writers' differences
  // of two times cannot overflow.
  std::int64_t nanoseconds(const json& object, const char* key) const {
    constexpr std::int64_t kLimit = std::int64_t{1} << 61;
    const std::int64_t value = integer(object, key);
    if (value < -kLimit || value > kLimit) throw ReadError{where(key) + ": out of range"};
    return value;
  }
  std::uint64_t unsigned_integer(const json& object, const char* key) const {
    const json& value = member(object, key);
    if (!value.is_number_unsigned()) throw ReadError{where(key) + ": expected an unsigned integer"};
    return value.get<std::uint64_t>();
  }
  double number(const json& object, const char* key) const {
    const json& value = member(object, key);
    if (!value.is_number()) throw ReadError{where(key) + ": expected a number"};
    return value.get<double>();
  }
  const json& array(const json& object, const char* key) const {
    const json& value = member(object, key);
    if (!value.is_array()) throw ReadError{where(key) + ": expected an array"};
    return value;
  }
  const json& object(const json& parent, const char* key) const {
    const json& value = member(parent, key);
    if (!value.is_object()) throw ReadError{where(key) + ": expected an object"};
    return value;
  }
  std::optional<std::uint32_t> optional_u32(const json& object, const char* key) const {
    if (!object.contains(key)) return std::nullopt;
    const std::uint64_t value = unsigned_integer(object, key);
    if (value > UINT32_MAX) throw ReadError{where(key) + ": out of range for 32 bits"};
    return static_cast<std::uint32_t>(value);
  }
  std::optional<std::string> optional_string(const json& object, const char* key) const {
    if (!object.contains(key)) return std::nullopt;
    return string(object, key);
  }

  // The JSON path of the element being read, for messages ("vectors[3].checks[0]").
  void push(std::string part) { path_parts_.push_back(std::move(part)); }
  void pop() { path_parts_.pop_back(); }
  std::string where(std::string_view key) const {
    std::string out;
    for (const auto& part : path_parts_) {
      if (!out.empty() && part.front() != '[') out += '.';
      out += part;
    }
    if (key.empty()) return out.empty() ? std::string("(document)") : out;
    if (!out.empty() && key.front() != '[') out += '.';
    return out + std::string(key);
  }

 private:
  std::vector<std::string> path_parts_;
};

// Pushes a path component for the lifetime of the scope.
class Scope {
 public:
  Scope(Reader& reader, std::string part) : reader_(reader) { reader_.push(std::move(part)); }
  ~Scope() { reader_.pop(); }
  Scope(const Scope&) = delete;
  Scope& operator=(const Scope&) = delete;

 private:
  Reader& reader_;
};

Verdict parse_verdict(const Reader& reader, const json& object) {
  const std::string text = reader.string(object, "verdict");
  for (std::size_t i = 0; i < conformance::kVerdictCount; ++i) {
    const auto verdict = static_cast<Verdict>(i);
    if (text == to_string(verdict)) return verdict;
  }
  throw ReadError{reader.where("verdict") + ": unknown verdict \"" + text + "\""};
}

Level parse_level(const Reader& reader, const json& object) {
  const std::string text = reader.string(object, "level");
  for (const Level level : {Level::must, Level::should, Level::may}) {
    if (text == to_string(level)) return level;
  }
  throw ReadError{reader.where("level") + ": unknown level \"" + text + "\""};
}

can::TimePoint time_at(std::int64_t ns) {
  return can::TimePoint(can::Duration(ns));
}

std::size_t size_of(const Reader& reader, const json& object, const char* key) {
  const std::int64_t value = reader.integer(object, key);
  if (value < 0) throw ReadError{reader.where(key) + ": must not be negative"};
  return static_cast<std::size_t>(value);
}

// `repeat` of an entry (absent before schema 4: nothing summarised). `index` and `size`: the
// entry's place and the list's length (the pattern and its last repetition must be in it).
conformance::EvidenceRepeat read_repeat(Reader& reader, const json& item, std::size_t index,
                                        std::size_t size) {
  conformance::EvidenceRepeat repeat;
  if (!item.contains("repeat")) return repeat;
  Scope scope(reader, "repeat");
  const json& in = reader.object(item, "repeat");
  repeat.length = static_cast<std::size_t>(reader.unsigned_integer(in, "length"));
  repeat.times = static_cast<std::size_t>(reader.unsigned_integer(in, "times"));
  repeat.until = time_at(reader.nanoseconds(in, "until_ns"));
  if (repeat.length == 0 || repeat.times == 0)
    throw ReadError{reader.where("") + ": length and times must be at least 1"};
  if (index + 2 * repeat.length > size)
    throw ReadError{reader.where("length") +
                    ": the pattern and its last repetition run past the list"};
  return repeat;
}

std::vector<conformance::EvidenceFrame> read_frames(Reader& reader, const json& in,
                                                    const char* key) {
  std::vector<conformance::EvidenceFrame> frames;
  std::size_t i = 0;
  for (const json& item : reader.array(in, key)) {
    Scope scope(reader, fmt::format("{}[{}]", key, i++));
    if (!item.is_object()) throw ReadError{reader.where("") + ": expected an object"};
    conformance::EvidenceFrame frame;
    frame.at = time_at(reader.nanoseconds(item, "t_ns"));
    const std::string text = reader.string(item, "frame");
    auto parsed = can::parse_candump(text);
    if (!parsed) throw ReadError{reader.where("frame") + ": " + parsed.error()};
    frame.frame = *parsed;
    frame.from_harness = reader.boolean(item, "from_harness");
    frame.decoded = reader.string(item, "decoded");
    frame.repeat = read_repeat(reader, item, i - 1, reader.array(in, key).size());
    frames.push_back(std::move(frame));
  }
  return frames;
}

// `version`: the report's schema_version (1: steps of checks numbered from 0).
conformance::Observation read_observation(Reader& reader, const json& check) {
  Scope scope(reader, "observed");
  const json& in = reader.object(check, "observed");
  conformance::Observation observed;
  observed.abort = reader.optional_u32(in, "abort");
  if (in.contains("value")) observed.value = reader.integer(in, "value");
  if (const auto word = reader.optional_u32(in, "statusword")) {
    if (*word > 0xFFFF) throw ReadError{reader.where("statusword") + ": out of range for 16 bits"};
    observed.statusword = static_cast<std::uint16_t>(*word);
  }
  if (in.contains("nothing")) observed.nothing = reader.boolean(in, "nothing");
  if (in.contains("accepted")) observed.accepted = reader.boolean(in, "accepted");
  return observed;
}

VectorResult read_vector(Reader& reader, const json& in, std::int64_t version) {
  if (!in.is_object()) throw ReadError{reader.where("") + ": expected an object"};
  VectorResult vector;
  vector.id = reader.string(in, "id");
  vector.family = reader.string(in, "family");
  vector.title = reader.string(in, "title");
  {
    Scope scope(reader, "sources");
    std::size_t i = 0;
    for (const json& source : reader.array(in, "sources")) {
      if (!source.is_string())
        throw ReadError{reader.where(fmt::format("[{}]", i)) + ": expected a string"};
      vector.sources.push_back(source.get<std::string>());
      ++i;
    }
  }
  vector.level = parse_level(reader, in);
  vector.file = reader.string(in, "file");
  vector.line = size_of(reader, in, "line");
  vector.verdict = parse_verdict(reader, in);
  vector.message = reader.string(in, "message");
  vector.deviation_id = reader.string(in, "deviation_id");
  vector.deviation_source = reader.string(in, "deviation_source");
  vector.warning = reader.boolean(in, "warning");
  std::size_t i = 0;
  for (const json& item : reader.array(in, "checks")) {
    Scope scope(reader, fmt::format("checks[{}]", i++));
    if (!item.is_object()) throw ReadError{reader.where("") + ": expected an object"};
    conformance::Check check;
    check.step = size_of(reader, item, "step");
    if (version < 2) ++check.step;  // schema 1 counted steps from 0
    if (item.contains("t_ns")) check.at = time_at(reader.nanoseconds(item, "t_ns"));
    check.action = reader.string(item, "action");
    check.expected = reader.string(item, "expected");
    check.actual = reader.string(item, "actual");
    check.ok = reader.boolean(item, "ok");
    if (item.contains("observed")) check.observed = read_observation(reader, item);
    // Absent for a step outside any `repeat:` (and in reports written before repeats).
    if (item.contains("iterations")) {
      std::size_t k = 0;
      for (const json& pass : reader.array(item, "iterations")) {
        Scope pass_scope(reader, fmt::format("iterations[{}]", k++));
        if (!pass.is_object()) throw ReadError{reader.where("") + ": expected an object"};
        conformance::Iteration iteration{size_of(reader, pass, "iteration"),
                                         size_of(reader, pass, "of")};
        if (iteration.number == 0 || iteration.number > iteration.of)
          throw ReadError{reader.where("iteration") + ": not within 1..of"};
        check.iterations.push_back(iteration);
      }
    }
    vector.checks.push_back(std::move(check));
  }
  vector.frames = read_frames(reader, in, "frames");
  // Absent in schema 1 reports: frames between vectors were not told apart.
  if (in.contains("between_vectors"))
    vector.between_vectors = read_frames(reader, in, "between_vectors");
  // Absent in reports written before the evidence cap: nothing was left out.
  if (in.contains("frames_elided")) {
    vector.frames_elided = static_cast<std::size_t>(reader.unsigned_integer(in, "frames_elided"));
    vector.frames_elided_at =
        static_cast<std::size_t>(reader.unsigned_integer(in, "frames_elided_at"));
    if (vector.frames_elided_at > vector.frames.size()) {
      throw ReadError{reader.where("frames_elided_at") + ": beyond the frames kept"};
    }
  }
  // EtherCAT runs only.
  if (in.contains("datagrams")) {
    i = 0;
    for (const json& item : reader.array(in, "datagrams")) {
      Scope scope(reader, fmt::format("datagrams[{}]", i++));
      if (!item.is_object()) throw ReadError{reader.where("") + ": expected an object"};
      conformance::EvidenceDatagram d;
      d.at = time_at(reader.nanoseconds(item, "t_ns"));
      d.last = time_at(reader.nanoseconds(item, "last_ns"));
      d.count = static_cast<std::size_t>(reader.unsigned_integer(item, "count"));
      if (d.count == 0) throw ReadError{reader.where("count") + ": must be at least 1"};
      d.decoded = reader.string(item, "decoded");
      d.repeat = read_repeat(reader, item, i - 1, reader.array(in, "datagrams").size());
      vector.datagrams.push_back(std::move(d));
    }
    vector.datagrams_elided =
        static_cast<std::size_t>(reader.unsigned_integer(in, "datagrams_elided"));
    vector.datagrams_elided_at =
        static_cast<std::size_t>(reader.unsigned_integer(in, "datagrams_elided_at"));
    if (vector.datagrams_elided_at > vector.datagrams.size())
      throw ReadError{reader.where("datagrams_elided_at") + ": beyond the datagrams kept"};
  }
  i = 0;
  for (const json& item : reader.array(in, "timings")) {
    Scope scope(reader, fmt::format("timings[{}]", i++));
    if (!item.is_object()) throw ReadError{reader.where("") + ": expected an object"};
    conformance::Timing timing;
    timing.name = reader.string(item, "name");
    timing.measured = can::Duration(reader.nanoseconds(item, "measured_ns"));
    if (item.contains("min_ns")) timing.min = can::Duration(reader.nanoseconds(item, "min_ns"));
    if (item.contains("max_ns")) timing.max = can::Duration(reader.nanoseconds(item, "max_ns"));
    timing.ok = reader.boolean(item, "ok");
    vector.timings.push_back(std::move(timing));
  }
  i = 0;
  for (const json& item : reader.array(in, "samples")) {
    Scope scope(reader, fmt::format("samples[{}]", i++));
    if (!item.is_object()) throw ReadError{reader.where("") + ": expected an object"};
    conformance::Sample sample;
    sample.at = time_at(reader.nanoseconds(item, "t_ns"));
    sample.signal = reader.string(item, "signal");
    sample.value = reader.integer(item, "value");
    // Absent in reports written before PDO samples: every sample came from an SDO transfer.
    if (item.contains("origin")) {
      const std::string origin = reader.string(item, "origin");
      bool known = false;
      for (const auto candidate : {conformance::SampleOrigin::sdo, conformance::SampleOrigin::tpdo,
                                   conformance::SampleOrigin::rpdo}) {
        if (origin == to_string(candidate)) {
          sample.origin = candidate;
          known = true;
        }
      }
      if (!known) throw ReadError{reader.where("origin") + ": unknown origin \"" + origin + "\""};
    }
    vector.samples.push_back(std::move(sample));
  }
  if (in.contains("samples_elided"))
    vector.samples_elided = static_cast<std::size_t>(reader.unsigned_integer(in, "samples_elided"));
  vector.started = time_at(reader.nanoseconds(in, "started_ns"));
  vector.finished = time_at(reader.nanoseconds(in, "finished_ns"));
  vector.wall_seconds = reader.number(in, "wall_s");
  return vector;
}

RunResult read_run(Reader& reader, const json& document) {
  if (!document.is_object()) throw ReadError{"the document is not a JSON object"};
  if (!document.contains("schema_version")) {
    throw ReadError{"schema_version: missing (not a drivecheck JSON report?)"};
  }
  const std::int64_t version = reader.integer(document, "schema_version");
  if (version < kOldestJsonSchemaVersion || version > kJsonSchemaVersion) {
    throw ReadError{
        fmt::format("schema_version: {} is not supported (this drivecheck reads {} to {})", version,
                    kOldestJsonSchemaVersion, kJsonSchemaVersion)};
  }
  RunResult result;
  {
    Scope scope(reader, "run");
    const json& run = reader.object(document, "run");
    auto& info = result.info;
    info.tool_version = reader.string(run, "tool_version");
    // Schema 2 (absent in schema 1 reports).
    info.revision = reader.optional_string(run, "revision").value_or("");
    if (run.contains("vector_set")) {
      Scope inner(reader, "vector_set");
      const json& set = reader.object(run, "vector_set");
      info.vector_digest = reader.string(set, "sha256");
      info.vector_files = size_of(reader, set, "files");
    }
    if (run.contains("documents")) {
      std::size_t k = 0;
      for (const json& item : reader.array(run, "documents")) {
        Scope inner(reader, fmt::format("documents[{}]", k++));
        if (!item.is_object()) throw ReadError{reader.where("") + ": expected an object"};
        info.documents.push_back({reader.string(item, "key"), reader.string(item, "title"),
                                  reader.string(item, "edition")});
      }
    }
    info.started_utc = reader.string(run, "started_utc");
    info.bus = reader.string(run, "bus");
    const std::int64_t node = reader.integer(run, "node");
    if (node < 0 || node > 255) throw ReadError{reader.where("node") + ": out of range"};
    info.node = static_cast<int>(node);
    {
      Scope inner(reader, "profile");
      const json& profile = reader.object(run, "profile");
      info.profile_name = reader.string(profile, "name");
      info.profile_title = reader.string(profile, "title");
      info.profile_file = reader.string(profile, "file");
      if (profile.contains("commissioning")) {  // optional: profiles without commissioning
        Scope list(reader, "commissioning");
        std::size_t i = 0;
        for (const json& item : reader.array(profile, "commissioning")) {
          if (!item.is_string())
            throw ReadError{reader.where(fmt::format("[{}]", i)) + ": expected a string"};
          info.commissioning.push_back(item.get<std::string>());
          ++i;
        }
      }
      if (profile.contains("choice")) info.profile_choice = reader.string(profile, "choice");
    }
    if (run.contains("capabilities")) {  // optional: nothing probed
      Scope list(reader, "capabilities");
      std::size_t i = 0;
      for (const json& item : reader.array(run, "capabilities")) {
        if (!item.is_string())
          throw ReadError{reader.where(fmt::format("[{}]", i)) + ": expected a string"};
        info.capabilities.push_back(item.get<std::string>());
        ++i;
      }
    }
    {
      Scope inner(reader, "eds");
      const json& eds = reader.object(run, "eds");
      info.eds_file = reader.string(eds, "file");
      info.eds_sha256 = reader.string(eds, "sha256");
      if (eds.contains("findings")) {  // optional: no EDS or no finding
        Scope list(reader, "findings");
        std::size_t i = 0;
        for (const json& item : reader.array(eds, "findings")) {
          if (!item.is_string())
            throw ReadError{reader.where(fmt::format("[{}]", i)) + ": expected a string"};
          info.eds_findings.push_back(item.get<std::string>());
          ++i;
        }
      }
    }
    if (run.contains("esi")) {  // optional: a run with --esi only
      Scope inner(reader, "esi");
      const json& esi = reader.object(run, "esi");
      info.esi_file = reader.string(esi, "file");
      info.esi_sha256 = reader.string(esi, "sha256");
      if (esi.contains("device")) {
        Scope device_scope(reader, "device");
        const json& device = reader.object(esi, "device");
        conformance::EsiDeviceIdentity identity;
        const auto u32 = [&](const char* key) {
          const auto value = reader.optional_u32(device, key);
          if (!value) throw ReadError{reader.where(key) + ": missing"};
          return *value;
        };
        identity.vendor_id = u32("vendor_id");
        identity.product_code = u32("product_code");
        identity.revision = u32("revision");
        identity.name = reader.string(device, "name");
        info.esi_device = std::move(identity);
      }
    }
    info.personality = reader.string(run, "personality");
    {
      Scope inner(reader, "deviations");
      std::size_t i = 0;
      for (const json& item : reader.array(run, "deviations")) {
        if (!item.is_string())
          throw ReadError{reader.where(fmt::format("[{}]", i)) + ": expected a string"};
        info.deviations.push_back(item.get<std::string>());
        ++i;
      }
    }
    info.seed = reader.unsigned_integer(run, "seed");
    // Optional: older reports ran in file order and do not say so.
    info.order = reader.optional_string(run, "order").value_or("file");
    info.strict = reader.boolean(run, "strict");
    info.allow_motion = reader.boolean(run, "allow_motion");
    // Optional: older reports had no such option (their factory restores ran unasked).
    info.allow_factory_restore =
        run.contains("allow_factory_restore") && reader.boolean(run, "allow_factory_restore");
    info.filter = reader.string(run, "filter");
    {
      Scope inner(reader, "dut");
      const json& dut = reader.object(run, "dut");
      info.dut.device_type = reader.optional_u32(dut, "device_type");
      info.dut.device_name = reader.optional_string(dut, "device_name");
      info.dut.hardware_version = reader.optional_string(dut, "hardware_version");
      info.dut.software_version = reader.optional_string(dut, "software_version");
      info.dut.vendor_id = reader.optional_u32(dut, "vendor_id");
      info.dut.product_code = reader.optional_u32(dut, "product_code");
      info.dut.revision = reader.optional_u32(dut, "revision");
      info.dut.serial = reader.optional_u32(dut, "serial");
    }
    result.interrupted = reader.boolean(run, "interrupted");
    result.dut_lost = reader.boolean(run, "dut_lost");
    if (run.contains("harness_notes")) {  // optional: reports of a simulated run have none
      Scope inner(reader, "harness_notes");
      std::size_t i = 0;
      for (const json& item : reader.array(run, "harness_notes")) {
        if (!item.is_string())
          throw ReadError{reader.where(fmt::format("[{}]", i)) + ": expected a string"};
        result.harness_notes.push_back(item.get<std::string>());
        ++i;
      }
    }
    result.simulated = can::Duration(reader.nanoseconds(run, "simulated_ns"));
    result.wall_seconds = reader.number(run, "wall_s");
  }
  std::size_t i = 0;
  for (const json& item : reader.array(document, "vectors")) {
    Scope scope(reader, fmt::format("vectors[{}]", i++));
    result.vectors.push_back(read_vector(reader, item, version));
  }
  return result;
}

}  // namespace

std::string render_json(const RunResult& result) {
  json run;
  const auto& info = result.info;
  run["tool_version"] = info.tool_version;
  run["revision"] = info.revision;
  run["vector_set"] = {{"sha256", info.vector_digest}, {"files", info.vector_files}};
  json documents = json::array();
  for (const auto& document : info.documents) {
    documents.push_back(
        {{"key", document.key}, {"title", document.title}, {"edition", document.edition}});
  }
  run["documents"] = std::move(documents);
  run["started_utc"] = info.started_utc;
  run["bus"] = info.bus;
  run["node"] = info.node;
  run["profile"] = {
      {"name", info.profile_name}, {"title", info.profile_title}, {"file", info.profile_file}};
  if (!info.commissioning.empty()) run["profile"]["commissioning"] = info.commissioning;
  if (!info.profile_choice.empty()) run["profile"]["choice"] = info.profile_choice;
  if (!info.capabilities.empty()) run["capabilities"] = info.capabilities;
  run["eds"] = {{"file", info.eds_file}, {"sha256", info.eds_sha256}};
  if (!info.eds_findings.empty()) run["eds"]["findings"] = info.eds_findings;
  if (!info.esi_file.empty()) {  // --esi only (EtherCAT)
    run["esi"] = {{"file", info.esi_file}, {"sha256", info.esi_sha256}};
    if (const auto& device = info.esi_device) {
      run["esi"]["device"] = {{"vendor_id", device->vendor_id},
                              {"product_code", device->product_code},
                              {"revision", device->revision},
                              {"name", device->name}};
    }
  }
  run["personality"] = info.personality;
  run["deviations"] = info.deviations;
  run["seed"] = info.seed;
  run["order"] = info.order;
  run["strict"] = info.strict;
  run["allow_motion"] = info.allow_motion;
  run["allow_factory_restore"] = info.allow_factory_restore;
  run["filter"] = info.filter;
  run["dut"] = dut_json(info.dut);
  run["interrupted"] = result.interrupted;
  run["dut_lost"] = result.dut_lost;
  run["harness_notes"] = result.harness_notes;
  run["simulated_ns"] = result.simulated.count();
  run["simulated_s"] = seconds(result.simulated);
  run["wall_s"] = result.wall_seconds;

  const auto counts = result.counts();
  json count_json;
  for (std::size_t i = 0; i < conformance::kTallyCount; ++i) {
    count_json[std::string(to_string(static_cast<conformance::Tally>(i)))] = counts.by_tally[i];
  }
  count_json["total"] = counts.total();

  json vectors = json::array();
  for (const auto& vector : result.vectors)
    vectors.push_back(vector_json(vector));

  json document;
  document["schema_version"] = kJsonSchemaVersion;
  document["generator"] = "drivecheck " + info.tool_version;
  document["run"] = std::move(run);
  document["counts"] = std::move(count_json);
  document["exit_code"] = conformance::exit_code(result);
  document["vectors"] = std::move(vectors);
  // replace: invalid UTF-8 from the DUT becomes U+FFFD instead of an exception.
  return document.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

Expected<void, std::string> write_json_report(const std::filesystem::path& path,
                                              const RunResult& result) {
  return write_file_atomically(path, render_json(result));
}

Expected<RunResult, TextError> parse_json_report(std::string_view text, std::string_view file) {
  json document;
  try {
    document = json::parse(text);
  } catch (const json::parse_error& error) {
    // The byte offset of the error → its line.
    const std::size_t offset = std::min<std::size_t>(error.byte, text.size());
    int line = 1;
    for (std::size_t i = 0; i + 1 < offset; ++i)
      if (text[i] == '\n') ++line;
    std::string message = error.what();
    // "[json.exception.parse_error.101] parse error at line 1, column 2: syntax error ..."
    if (const auto colon = message.find(": "); colon != std::string::npos)
      message = message.substr(colon + 2);
    return Unexpected(TextError{std::string(file), line, "not valid JSON: " + message});
  }
  Reader reader;
  try {
    return read_run(reader, document);
  } catch (const ReadError& error) {
    return Unexpected(TextError{std::string(file), 0, error.message});
  } catch (const json::exception& error) {
    return Unexpected(TextError{std::string(file), 0, error.what()});
  }
}

Expected<RunResult, TextError> read_json_report(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Unexpected(TextError{path.string(), 0, "cannot open the file"});
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) return Unexpected(TextError{path.string(), 0, "cannot read the file"});
  return parse_json_report(text.str(), path.string());
}

}  // namespace drivecheck::reports
