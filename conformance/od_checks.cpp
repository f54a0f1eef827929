#include "conformance/od_checks.hpp"

#include <fmt/format.h>

#include <map>
#include <optional>
#include <utility>

#include "protocol/cia301/object_dictionary.hpp"

namespace drivecheck::conformance {
namespace {

struct OdObject {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  cia301::DataType type = cia301::DataType::unsigned8;
  cia301::AccessType access = cia301::AccessType::ro;
  std::optional<std::int64_t> default_value;
  std::optional<std::int64_t> min;
  std::optional<std::int64_t> max;
  std::string source;
};

std::optional<std::int64_t> integer_of(const cia301::Value& value) {
  switch (value.kind()) {
    case cia301::Value::Kind::unsigned_integer:
      return static_cast<std::int64_t>(value.as_unsigned());
    case cia301::Value::Kind::signed_integer:
      return value.as_signed();
    default:
      return std::nullopt;
  }
}

// The range a fixed-size integer type can hold (bytes ≤ 4 only: enough for limits ± 1).
std::optional<std::pair<std::int64_t, std::int64_t>> type_range(cia301::DataType type) {
  const auto& info = cia301::info(type);
  if (!cia301::is_integer(type) || info.size == 0 || info.size > 4) return std::nullopt;
  const int bits = 8 * info.size;
  if (info.type_class == cia301::TypeClass::signed_integer)
    return std::pair{-(std::int64_t{1} << (bits - 1)), (std::int64_t{1} << (bits - 1)) - 1};
  return std::pair{std::int64_t{0}, (std::int64_t{1} << bits) - 1};
}

// Sub 00h of a PDO mapping record (1600h-17FFh, 1A00h-1BFFh): a count out of range may also
// break the CiA 301 §7.5.2.36/38 mapping procedure: 06040042h (more entries than the record
// has, or longer than 64 bits), or the answer to a write while the PDO is valid, for which CiA
// 301 names no code (06010000h, 06040043h, 08000022h; protocol/cia301/pdo_service.hpp).
bool is_mapping_count(const OdObject& object) {
  return object.sub == 0 && ((object.index >= 0x1600 && object.index <= 0x17FF) ||
                             (object.index >= 0x1A00 && object.index <= 0x1BFF));
}

Vector make(const OdObject& object, std::string check, std::string title, Step step) {
  Vector vector;
  vector.id = fmt::format("eds/od/{:04x}-{:02x}/{}", object.index, object.sub, check);
  vector.title = std::move(title);
  vector.sources.push_back(Source{object.source, "", "", 0, 0, 0});
  vector.level = Level::must;
  // Every check establishes its own state (FORMAT.md "Isolation"): reset node, so that
  // `default` reads the value a reset gives and no NMT state, half-done SDO transfer or value
  // left by the vector before (in whatever order they run) decides the verdict.
  vector.setup = Setup::reset_node;
  vector.nmt = cia301::NmtState::pre_operational;
  vector.timeout = DurationSpec{std::chrono::seconds(5), {}};
  vector.file = "(generated)";
  vector.steps.push_back(std::move(step));
  return vector;
}

}  // namespace

std::vector<Vector> generate_od_vectors(const cia301::ObjectDictionary* eds,
                                        const std::string& eds_file,
                                        const profile::DriveProfile& profile) {
  std::map<std::pair<std::uint16_t, std::uint8_t>, OdObject> objects;
  if (eds != nullptr) {
    for (const auto& object : eds->objects()) {
      for (const auto& entry : object.entries()) {
        OdObject od{
            object.index(),
            entry.sub_index(),
            entry.type(),
            entry.access(),
            std::nullopt,
            integer_of(entry.definition().low_limit),
            integer_of(entry.definition().high_limit),
            fmt::format("EDS {} [{:04X}sub{:X}]", eds_file, object.index(), entry.sub_index())};
        if (entry.access() == cia301::AccessType::constant)
          od.default_value = integer_of(entry.definition().default_value);
        objects[{od.index, od.sub}] = od;
      }
    }
  }
  for (const auto& spec : profile.objects) {  // the manual's table wins over the EDS
    OdObject od{spec.index,
                spec.sub,
                spec.type,
                spec.access,
                spec.default_value,
                spec.min,
                spec.max,
                spec.sources.empty() ? fmt::format("profile {} objects", profile.name)
                                     : spec.sources.front()};
    objects[{od.index, od.sub}] = od;
  }
  std::vector<Vector> vectors;
  for (const auto& [key, object] : objects) {
    const auto& info = cia301::info(object.type);
    const auto range = type_range(object.type);
    const auto name = fmt::format("{:04X}h sub {}", object.index, object.sub);
    // 1003h sub 1..254 exist only while errors are recorded (else 08000024h, CiA 301 §7.5.2.5).
    const bool dynamic = object.index == 0x1003 && object.sub > 0;
    if (cia301::is_readable(object.access) && !dynamic) {
      SdoReadStep read{object.index, object.sub, Transfer::automatic, {}, false, {}};
      if (info.size != 0) {
        read.expect.kind = SdoExpect::Kind::size;
        read.expect.size = info.size;
      }
      vectors.push_back(
          make(object, "read",
               fmt::format("{} ({}) MUST be readable{}", name, info.name,
                           info.size != 0 ? fmt::format(" with {} byte(s)", info.size) : ""),
               Step{read, {}, 0, {}}));
      if (object.default_value && range) {
        SdoReadStep value{object.index,
                          object.sub,
                          Transfer::automatic,
                          {},
                          info.type_class == cia301::TypeClass::signed_integer,
                          {}};
        value.expect.kind = SdoExpect::Kind::value;
        value.expect.value.literal = *object.default_value;
        vectors.push_back(
            make(object, "default",
                 fmt::format("{} MUST read its default {}", name, *object.default_value),
                 Step{value, {}, 0, {}}));
      }
    } else if (!dynamic) {
      SdoReadStep read{object.index, object.sub, Transfer::automatic, {}, false, {}};
      read.expect.kind = SdoExpect::Kind::abort;
      read.expect.abort = *AbortExpect::named("read-write-only");
      vectors.push_back(make(object, "read-wo",
                             fmt::format("A read of write-only {} MUST abort ({})", name,
                                         read.expect.abort.describe()),
                             Step{read, {}, 0, {}}));
    }
    if (!cia301::is_writable(object.access) && info.size != 0 && info.size <= 8) {
      SdoWriteStep write;
      write.index = object.index;
      write.sub = object.sub;
      write.data.assign(info.size, 0);
      write.expect.kind = SdoExpect::Kind::abort;
      write.expect.abort = *AbortExpect::named("write-read-only");
      vectors.push_back(make(object, "write-ro",
                             fmt::format("A write to read-only {} MUST abort ({})", name,
                                         write.expect.abort.describe()),
                             Step{write, {}, 0, {}}));
    }
    if (cia301::is_writable(object.access) && range) {
      const auto limit_vector = [&](std::int64_t value, const char* check, const char* what) {
        SdoWriteStep write;
        write.index = object.index;
        write.sub = object.sub;
        write.value = ValueSpec{value, {}};
        write.size = info.size;
        write.expect.kind = SdoExpect::Kind::abort;
        write.expect.abort = *AbortExpect::named(
            std::string_view(check) == "below-min" ? "value-too-low" : "value-too-high");
        if (is_mapping_count(object)) {
          // The mapping count: the value codes and the CiA 301 mapping procedure's answers.
          write.expect.abort = AbortExpect{};
          write.expect.abort.codes = {0x06010000, 0x06040042, 0x06040043, 0x06090030,
                                      0x06090031, 0x06090032, 0x08000022};
          write.expect.abort.clause =
              "CiA 301 §7.5.2.36, §7.5.2.38 (a count above the entries: 06040042h; refused in "
              "the present state: 06010000h, 06040043h, 08000022h) and §7.2.4.3.17 (0609003xh)";
        }
        vectors.push_back(make(object, check,
                               fmt::format("Writing {} ({}) to {} MUST abort ({})", value, what,
                                           name, write.expect.abort.describe()),
                               Step{write, {}, 0, {}}));
      };
      if (object.min && *object.min > range->first)
        limit_vector(*object.min - 1, "below-min", "min - 1");
      if (object.max && *object.max < range->second)
        limit_vector(*object.max + 1, "above-max", "max + 1");
    }
  }
  return vectors;
}

}  // namespace drivecheck::conformance
