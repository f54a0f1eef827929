#include "conformance/od_checks.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <optional>
#include <utility>

#include "conformance/verdict.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia306/eds_lint.hpp"

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
  // EDS entries only: the entry (its definition and the value the EDS gives) and its object.
  const cia301::Entry* eds_entry = nullptr;
  cia301::ObjectCode code = cia301::ObjectCode::var;
  bool pdo = false;  // PDO-mappable (EDS PDOMapping=1, the profile's `pdo: true`)
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

Source cited(std::string text) {
  return Source{std::move(text), "", "", 0, 0, 0};
}

// CiA 306 ObjFlags (the EDS key of an object or sub-object).
constexpr std::uint32_t kRefuseWriteOnDownload = 0x1;
constexpr std::uint32_t kRefuseReadOnScan = 0x2;

// Why an entry's value is not written back (empty: it is). A write of these has an effect
// beyond storing the value read, or the value read is not one a write takes.
std::string write_back_exclusion(const OdObject& object) {
  if (object.eds_entry != nullptr &&
      (object.eds_entry->definition().obj_flags & kRefuseWriteOnDownload) != 0)
    return "ObjFlags bit 0 (refuse write on download, CiA 306): the EDS says a configuration "
           "tool must not write it";
  if ((object.index == 0x1010 || object.index == 0x1011) && object.sub > 0)
    return "CiA 301 §7.5.2.13, §7.5.2.14: a read gives the storage capability, a write must carry "
           "the signature \"save\"/\"load\" (writing the value read back is no write-back)";
  if (object.index == 0x1003)
    return "CiA 301 §7.5.2.4: only 0 may be written to 1003h sub 0, and it clears the error "
           "history";
  if (object.index == 0x1F51)
    return "CiA 302-3 (1F51h program control): a write is a command to the program (start, stop, "
           "reset, clear)";
  if (object.index == 0x6040)
    return "CiA 402-2 §6040h controlword: a write is a command to the state machine, not a "
           "parameter";
  return {};
}

// Where CiA 301 lets the device refuse a write in the present state whatever the value (so a
// refusal of the value it already holds meets the standard too): the set and why.
std::optional<AbortExpect> write_back_refusal(const OdObject& object) {
  const auto in = [&](std::uint16_t first, std::uint16_t last) {
    return object.index >= first && object.index <= last;
  };
  std::optional<AbortExpect> set;
  if ((in(0x1400, 0x15FF) || in(0x1800, 0x19FF)) && object.sub == 1)
    set = AbortExpect::named("cob-id-while-valid");  // §7.5.2.35, §7.5.2.37
  else if (in(0x1800, 0x19FF) && object.sub == 3)
    set = AbortExpect::named("parameter-while-valid");  // inhibit time, §7.5.2.37
  else if (in(0x1600, 0x17FF) || in(0x1A00, 0x1BFF))
    set = AbortExpect::named("mapping-while-valid");  // §7.5.2.36, §7.5.2.38
  else if (object.index == 0x1005 || object.index == 0x1012 || object.index == 0x1014)
    set = AbortExpect::named("cob-id-while-valid");  // §7.5.2.6, §7.5.2.15, §7.5.2.17
  else if (object.index == 0x1019)
    set = AbortExpect::named("sync-counter-while-producing");  // §7.5.2.22
  return set;
}

bool is_array_or_record(cia301::ObjectCode code) {
  return code == cia301::ObjectCode::array || code == cia301::ObjectCode::record;
}

// Whether an EDS entry's DefaultValue is the value the entry holds after a reset (see the
// header): const, writable, or the "highest sub-index supported" of an ARRAY/RECORD.
bool default_is_reset_value(const OdObject& object) {
  const auto access = object.access;
  if (access == cia301::AccessType::constant || cia301::is_writable(access)) return true;
  return object.sub == 0 && is_array_or_record(object.code);
}

// The TPDO the tpdo-map checks remap (CTT 3.31): the first TPDO whose communication (18xxh) and
// mapping (1Axxh) records the EDS has, else the profile's first default TPDO, else TPDO1 at its
// pre-defined COB-ID 180h + node-ID (CiA 301 §7.3.5). The COB-ID is the one the PDO has after a
// reset (the EDS default, $NODEID resolved), so setting bit 31 only destroys the PDO (CiA 301
// §7.5.2.37: bits 0-29 may not change while it exists).
struct TpdoChoice {
  std::uint16_t number = 1;  // 1..512
  std::uint32_t cob_id = 0;
  std::string why;
};

std::optional<TpdoChoice> tpdo_to_remap(const cia301::ObjectDictionary* eds,
                                        const profile::DriveProfile& profile, std::uint8_t node) {
  if (eds != nullptr) {
    for (std::uint16_t n = 0; n < 512; ++n) {
      const auto* cob_id = eds->find(static_cast<std::uint16_t>(0x1800 + n), 1);
      if (cob_id == nullptr || eds->find(static_cast<std::uint16_t>(0x1A00 + n)) == nullptr)
        continue;
      return TpdoChoice{static_cast<std::uint16_t>(n + 1),
                        static_cast<std::uint32_t>(cia301::load_unsigned(cob_id->bytes())),
                        fmt::format("TPDO{}: the EDS's {:04X}h sub 1 default", n + 1, 0x1800 + n)};
    }
    return std::nullopt;
  }
  for (const auto& pdo : profile.pdo_defaults) {
    if (pdo.kind == profile::PdoKind::tpdo)
      return TpdoChoice{pdo.number, pdo.cob_id.resolve(node),
                        fmt::format("TPDO{}: the profile's default COB-ID {}", pdo.number,
                                    profile::to_string(pdo.cob_id))};
  }
  return TpdoChoice{1, 0x180u + node,
                    "TPDO1: the pre-defined COB-ID 180h + node-ID (CiA 301 §7.3.5)"};
}

// CTT 3.31: a PDO-mappable wo or rww entry mapped into a TPDO. A wo entry cannot be read, so
// a TPDO cannot carry it: CiA 301 §7.5.2.38 (the mapping entry is refused, 06040041h "object
// cannot be mapped to the PDO") at must level. An rww entry can be read: CiA 301 §7.4.5 makes
// rww ("read/write on process output") a hint that it belongs into an RPDO, and the CTT refuses
// it in a TPDO; a device that maps it meets CiA 301, so the check is should level (a warning).
// Accepted: set not-mappable (06020000h, 06040041h: CTT 3.31). The PDO is destroyed (bit 31)
// and its mapping disabled first (the mapping procedure of §7.5.2.38), so the refusal can only
// be for the entry; the engine's restore puts back 18xxh sub 1 and 1Axxh (FORMAT.md
// "Isolation").
void add_tpdo_map_check(const OdObject& object, const TpdoChoice& tpdo,
                        std::vector<Vector>& vectors) {
  const bool wo = object.access == cia301::AccessType::wo;
  const auto& info = cia301::info(object.type);
  const auto comm = static_cast<std::uint16_t>(0x1800 + tpdo.number - 1);
  const auto map = static_cast<std::uint16_t>(0x1A00 + tpdo.number - 1);
  const auto entry = (std::uint32_t{object.index} << 16) | (std::uint32_t{object.sub} << 8) |
                     static_cast<std::uint32_t>(info.bit_size);
  SdoWriteStep destroy;
  destroy.index = comm;
  destroy.sub = 1;
  destroy.value = ValueSpec{static_cast<std::int64_t>(tpdo.cob_id | 0x80000000u), {}};
  destroy.size = 4;
  SdoWriteStep disable;
  disable.index = map;
  disable.sub = 0;
  disable.value = ValueSpec{0, {}};
  disable.size = 1;
  SdoWriteStep write;
  write.index = map;
  write.sub = 1;
  write.value = ValueSpec{entry, {}};
  write.size = 4;
  write.expect.kind = SdoExpect::Kind::abort;
  write.expect.abort = *AbortExpect::named("not-mappable");
  auto vector =
      make(object, "tpdo-map",
           fmt::format("Mapping {} {:04X}h sub {} into TPDO{} ({:04X}h sub 1 := {:08X}h) {} be "
                       "refused ({})",
                       cia301::to_string(object.access), object.index, object.sub, tpdo.number, map,
                       entry, wo ? "MUST" : "SHOULD", write.expect.abort.describe()),
           Step{destroy, fmt::format("{} not valid (bit 31)", tpdo.why), 0, {}});
  vector.steps.push_back(Step{disable, "mapping disabled (CiA 301 §7.5.2.38 step 2)", 0, {}});
  vector.steps.push_back(Step{write, {}, 0, {}});
  vector.level = wo ? Level::must : Level::should;
  vector.requires_features = {"pdo", "pdo.dynamic-mapping"};
  vector.sources.push_back(
      cited(wo ? "CiA 301 §7.5.2.38 (a TPDO carries readable objects: a wo entry cannot be mapped, "
                 "06040041h); §7.4.5 (wo: write only); CTT 3.31 [06020000h, 06040041h]"
               : "CiA 301 §7.4.5 (rww: read/write on process output, meant for RPDOs: a hint); CTT "
                 "3.31 refuses it in a TPDO [06020000h, 06040041h]"));
  vectors.push_back(std::move(vector));
}

void add_eds_entry_checks(const OdObject& object, bool dcf, std::vector<Vector>& vectors) {
  const auto& entry = *object.eds_entry;
  const auto& definition = entry.definition();
  const auto& info = cia301::info(object.type);
  const auto name = fmt::format("{:04X}h sub {}", object.index, object.sub);
  const bool dynamic = object.index == 0x1003;

  // default (CTT 4.2, 4.8): the value after a reset node.
  if (!definition.default_value.empty() && default_is_reset_value(object) && !dynamic &&
      cia301::is_readable(object.access)) {
    const auto expected = std::vector<std::uint8_t>(entry.bytes().begin(), entry.bytes().end());
    SdoReadStep read{object.index, object.sub, Transfer::automatic, {}, false, {}};
    read.expect.kind = SdoExpect::Kind::data;
    read.expect.data = expected;
    const auto shown = info.size != 0 && info.size <= 8
                           ? fmt::format("{:X}h", cia301::load_unsigned(expected))
                           : fmt::format("\"{}\"", std::string(expected.begin(), expected.end()));
    // A string or domain (1008h device name, 1009h/100Ah versions) may name another firmware of
    // the family the EDS describes: should level.
    const bool variable = info.size == 0;
    auto vector =
        make(object, "default",
             fmt::format("{} ({}) {} read its EDS value {} after a reset", name,
                         cia301::to_string(object.access), variable ? "SHOULD" : "MUST", shown),
             Step{read, {}, 0, {}});
    if (variable) vector.level = Level::should;
    vector.sources.push_back(cited(
        "CiA 306 DefaultValue ($NODEID resolved; a DCF's ParameterValue where given); CTT 4.2, "
        "4.8"));
    // A writable entry holds after a reset what was last stored (1010h), which is the EDS's
    // DefaultValue only after a factory restore (1011h, CiA 301 §7.5.2.14): the check restores
    // defaults first, so a commissioned drive is never failed for its own configuration (on a
    // real bus it is N/A without --allow-factory-restore). A DCF's ParameterValue is the
    // configuration itself, which a reset gives back.
    if (cia301::is_writable(object.access) && !dcf) {
      vector.setup = Setup::restore_defaults;
      vector.sources.push_back(cited("CiA 301 §7.5.2.14 (1011h restore default parameters)"));
    }
    if ((definition.obj_flags & kRefuseReadOnScan) != 0) {
      vector.not_applicable =
          "ObjFlags bit 1 (refuse read on scan, CiA 306): the EDS says a configuration tool "
          "must not read it, so its value is no configuration to compare";
    }
    vectors.push_back(std::move(vector));
  }

  // write-back (CTT 4.9): rw entries of a fixed size.
  if (cia301::is_readable(object.access) && cia301::is_writable(object.access) && info.size >= 1 &&
      info.size <= 8) {
    SdoReadStep first{object.index, object.sub, Transfer::automatic, {}, false, "value"};
    first.expect.kind = SdoExpect::Kind::size;
    first.expect.size = info.size;
    SdoWriteStep write;
    write.index = object.index;
    write.sub = object.sub;
    write.value = ValueSpec{0, "value"};
    write.size = info.size;
    write.expect.kind = SdoExpect::Kind::ok;
    write.expect.or_abort = write_back_refusal(object);
    SdoReadStep again{object.index, object.sub, Transfer::automatic, {}, false, {}};
    again.expect.kind = SdoExpect::Kind::value;
    again.expect.value = ValueSpec{0, "value"};
    auto vector =
        make(object, "write-back",
             fmt::format("Writing {} ({}) its own value MUST succeed{} and leave it "
                         "unchanged",
                         name, cia301::to_string(object.access),
                         write.expect.or_abort ? " (or be refused as CiA 301 allows)" : ""),
             Step{first, {}, 0, {}});
    vector.steps.push_back(Step{write, {}, 0, {}});
    vector.steps.push_back(Step{again, {}, 0, {}});
    vector.sources.push_back(
        cited(write.expect.or_abort ? fmt::format("CTT 4.9; {}", write.expect.or_abort->citation)
                                    : std::string("CTT 4.9; CiA 301 §7.4.5 (rw: read and write)")));
    vector.not_applicable = write_back_exclusion(object);
    vectors.push_back(std::move(vector));
  }
}

// Sub-index FFh of an object (CTT 4.5): optional; when present, object code in bits 0-7 and
// the data type in bits 8-23 (CiA 301 §7.4.3).
void add_sub_ff_check(const cia301::Object& object, const std::string& eds_file,
                      std::vector<Vector>& vectors) {
  if (object.entries().empty() || object.find(0xFF) != nullptr) return;
  std::optional<cia301::DataType> type;
  if (object.code() == cia301::ObjectCode::var) {
    type = object.entries().front().type();
  } else if (object.code() == cia301::ObjectCode::array && object.entries().size() > 1) {
    type = object.entries()[1].type();
  }
  const auto code = static_cast<std::uint32_t>(object.code());
  SdoReadStep read{object.index(), 0xFF, Transfer::automatic, {}, false, {}};
  read.expect.kind = SdoExpect::Kind::value;
  read.expect.value.literal =
      type ? static_cast<std::int64_t>((static_cast<std::uint32_t>(*type) << 8) | code) : code;
  read.expect.mask = type ? 0x00FFFFFF : 0xFF;
  read.expect.or_abort = AbortExpect::named("sub-index-does-not-exist");
  OdObject where;
  where.index = object.index();
  where.sub = 0xFF;
  where.source = fmt::format("EDS {} [{:04X}] ObjectType", eds_file, object.index());
  auto vector = make(
      where, "object-type",
      fmt::format("{:04X}h sub FFh, where present, MUST give object code {:X}h ({}){}",
                  object.index(), code, cia301::to_string(object.code()),
                  type ? fmt::format(" and data type {:04X}h ({})",
                                     static_cast<std::uint16_t>(*type), cia301::info(*type).name)
                       : std::string(" (the record's data type is not judged)")),
      Step{read, {}, 0, {}});
  vector.sources.push_back(
      cited("CiA 301 §7.4.3 (sub-index FFh: object code bits 0-7, data type bits 8-23; optional); "
            "CTT 4.5"));
  vectors.push_back(std::move(vector));
}

// CTT 3.21: each object a default PDO mapping of the EDS names (1600h-17FFh / 1A00h-1BFFh sub
// 1..40h, DefaultValue index << 16 | sub << 8 | length) exists in the device with that length:
// read live, a TPDO's must give length/8 bytes (a TPDO reads it); an RPDO's may also be write
// only (abort read-write-only: it exists). Dummy entries (index 0001h-0007h, CiA 301 §7.4.8)
// and empty ones (0) name no object. That the live mapping equals the EDS default is
// `<idx>-<sub>/default` (after a factory restore).
void add_mapped_object_check(const OdObject& object, std::vector<Vector>& vectors) {
  const bool tpdo = object.index >= 0x1A00 && object.index <= 0x1BFF;
  const bool rpdo = object.index >= 0x1600 && object.index <= 0x17FF;
  if ((!tpdo && !rpdo) || object.sub == 0 || object.sub > 0x40 || object.eds_entry == nullptr ||
      object.eds_entry->definition().default_value.empty())
    return;
  const auto value = static_cast<std::uint32_t>(cia301::load_unsigned(object.eds_entry->bytes()));
  const auto index = static_cast<std::uint16_t>(value >> 16);
  const auto sub = static_cast<std::uint8_t>(value >> 8);
  const auto bits = static_cast<std::uint8_t>(value);
  if (value == 0 || index < 0x0008) return;
  SdoReadStep read{index, sub, Transfer::automatic, {}, false, {}};
  if (bits % 8 == 0 && bits != 0) {
    read.expect.kind = SdoExpect::Kind::size;
    read.expect.size = bits / 8;
  }
  if (rpdo) {
    read.expect.kind = SdoExpect::Kind::ok;
    read.expect.or_abort = AbortExpect::named("read-write-only");
  }
  const auto title = fmt::format(
      "The object {:04X}h sub {} that {:04X}h sub {} maps by default ({:08X}h) MUST exist{}", index,
      sub, object.index, object.sub, value,
      tpdo ? fmt::format(" and read {} bit(s)", bits)
           : std::string(" (read, or refused as write only)"));
  auto vector = make(object, "mapped-object", title, Step{read, {}, 0, {}});
  vector.sources.push_back(
      cited("CiA 301 §7.5.2.36, §7.5.2.38 (a mapping entry names an object of the device by "
            "index, sub-index and length); CiA 306 DefaultValue; CTT 3.21"));
  vectors.push_back(std::move(vector));
}

// CTT 9.1: the communication area after reset communication. The entries whose every value of
// the type CiA 301 allows (so a write of another value is valid on any device): the value
// written is chosen to differ from the EDS default.
struct FreeParameter {
  std::uint16_t first;  // index range
  std::uint16_t last;
  std::uint8_t sub;
  std::int64_t value;      // written, unless it is the default: then `otherwise`
  std::int64_t otherwise;  //
  const char* clause;
};
constexpr FreeParameter kFreeParameters[] = {
    {0x100C, 0x100C, 0, 1234, 1000, "CiA 301 §7.5.2.10 (guard time, any UNSIGNED16)"},
    {0x100D, 0x100D, 0, 3, 2, "CiA 301 §7.5.2.11 (life time factor, any UNSIGNED8)"},
    {0x1017, 0x1017, 0, 1000, 500, "CiA 301 §7.5.2.32 (producer heartbeat time, any UNSIGNED16)"},
    {0x1800, 0x19FF, 5, 500, 1000,
     "CiA 301 §7.5.2.37 (TPDO event timer, any UNSIGNED16, changeable while the PDO exists)"},
};

// Why an entry of 1000h-1FFFh takes no part in the reset-communication check (empty: it does).
std::string reset_communication_exclusion(const OdObject& object) {
  if (auto why = write_back_exclusion(object); !why.empty()) return why;
  if (object.index == 0x1013)
    return "CiA 301 §7.5.2.16: 1013h is a running time stamp, not a parameter";
  if (object.eds_entry != nullptr &&
      (object.eds_entry->definition().obj_flags & kRefuseReadOnScan) != 0)
    return "ObjFlags bit 1 (refuse read on scan, CiA 306)";
  return {};
}

// One vector: every readable and writable entry of 1000h-1FFFh of a fixed size is read after
// the reset node (its power-on value: stored, else default), the free parameters above get
// another value, NMT reset communication, and every entry must read its power-on value again
// (CiA 301 §7.3.2.1: reset communication sets the communication area to its power-on values).
// One reset for all entries; the engine's restore puts back whatever a failing device kept.
void add_reset_communication_check(
    const std::map<std::pair<std::uint16_t, std::uint8_t>, OdObject>& objects,
    const std::string& eds_file, std::vector<Vector>& vectors) {
  std::vector<const OdObject*> entries;
  for (const auto& [key, object] : objects) {
    const auto& info = cia301::info(object.type);
    if (object.eds_entry == nullptr || object.index < 0x1000 || object.index > 0x1FFF ||
        !cia301::is_readable(object.access) || !cia301::is_writable(object.access) ||
        info.size < 1 || info.size > 8 || !cia301::is_integer(object.type))
      continue;
    if (reset_communication_exclusion(object).empty()) entries.push_back(&object);
  }
  OdObject where;
  where.source = fmt::format("EDS {} (every rw entry of 1000h-1FFFh)", eds_file);
  Vector vector = make(where, "reset-communication",
                       fmt::format("After reset communication, each of the {} writable entries of "
                                   "1000h-1FFFh MUST hold its power-on value again",
                                   entries.size()),
                       Step{WaitStep{}, {}, 0, {}});
  vector.id = "eds/od/reset-communication";
  vector.steps.clear();
  vector.timeout = DurationSpec{std::chrono::seconds(60), {}};
  std::vector<std::string> written;
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const auto& object = *entries[i];
    const bool is_signed =
        cia301::info(object.type).type_class == cia301::TypeClass::signed_integer;
    SdoReadStep read{object.index, object.sub, Transfer::automatic,
                     {},           is_signed,  fmt::format("e{}", i)};
    vector.steps.push_back(Step{read, "the power-on value (after the setup's reset node)", 0, {}});
  }
  for (const auto* object : entries) {
    for (const auto& free : kFreeParameters) {
      if (object->index < free.first || object->index > free.last || object->sub != free.sub)
        continue;
      const auto default_value =
          object->eds_entry->bytes().empty()
              ? std::int64_t{0}
              : static_cast<std::int64_t>(cia301::load_unsigned(object->eds_entry->bytes()));
      SdoWriteStep write;
      write.index = object->index;
      write.sub = object->sub;
      write.value = ValueSpec{default_value == free.value ? free.otherwise : free.value, {}};
      write.size = cia301::info(object->type).size;
      vector.steps.push_back(Step{write, free.clause, 0, {}});
      written.push_back(fmt::format("{:04X}h sub {}", object->index, object->sub));
    }
  }
  vector.steps.push_back(Step{NmtStep{cia301::NmtCommand::reset_communication, {}}, {}, 0, {}});
  vector.steps.push_back(Step{ExpectBootupStep{}, {}, 0, {}});
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const auto& object = *entries[i];
    const bool is_signed =
        cia301::info(object.type).type_class == cia301::TypeClass::signed_integer;
    SdoReadStep read{object.index, object.sub, Transfer::automatic, {}, is_signed, {}};
    read.expect.kind = SdoExpect::Kind::value;
    read.expect.value = ValueSpec{0, fmt::format("e{}", i)};
    vector.steps.push_back(Step{read, {}, 0, {}});
  }
  vector.note = fmt::format(
      "Written before the reset (values CiA 301 allows on any device): {}",
      written.empty() ? std::string("none") : fmt::format("{}", fmt::join(written, ", ")));
  vector.sources.push_back(
      cited("CiA 301 §7.3.2.1 (reset communication: the parameters of the communication area "
            "1000h-1FFFh are set to their power-on values); CTT 9.1"));
  if (entries.empty())
    vector.not_applicable = "the EDS has no readable and writable integer entry in 1000h-1FFFh";
  vectors.push_back(std::move(vector));
}

void add_identity_checks(const EdsIdentity& identity, const std::string& eds_file,
                         std::vector<Vector>& vectors) {
  struct Item {
    std::uint8_t sub;
    const char* check;
    const char* key;
    std::optional<std::uint32_t> value;
    std::optional<std::uint64_t> mask;
    Level level;
  };
  const Item items[] = {
      {1, "vendor-id", "VendorNumber", identity.vendor_id, std::nullopt, Level::must},
      {2, "product-code", "ProductNumber", identity.product_code, std::nullopt, Level::must},
      {3, "revision-major", "RevisionNumber", identity.revision_number, 0xFFFF0000, Level::must},
      {3, "revision-number", "RevisionNumber", identity.revision_number, std::nullopt,
       Level::should},
  };
  for (const auto& item : items) {
    if (!item.value) continue;
    SdoReadStep read{0x1018, item.sub, Transfer::automatic, {}, false, {}};
    read.expect.kind = SdoExpect::Kind::value;
    read.expect.value.literal = *item.value;
    read.expect.mask = item.mask;
    Vector vector;
    vector.id = fmt::format("eds/identity/{}", item.check);
    vector.title =
        item.mask
            ? fmt::format(
                  "1018h sub {} MUST hold the major revision {:04X}h (bits 16-31) of "
                  "[DeviceInfo] {} {:X}h",
                  item.sub, *item.value >> 16, item.key, *item.value)
            : fmt::format("1018h sub {} {} hold [DeviceInfo] {} {:X}h", item.sub,
                          item.level == Level::must ? "MUST" : "SHOULD", item.key, *item.value);
    vector.sources.push_back(cited(fmt::format("EDS {} [DeviceInfo] {}", eds_file, item.key)));
    vector.sources.push_back(cited(
        item.sub == 3
            ? "CiA 301 §7.5.2.21 (1018h sub 3: major revision bits 16-31 = CANopen behaviour, "
              "minor revision bits 0-15 = versions of the same behaviour); CiA 306 RevisionNumber"
            : "CiA 301 §7.5.2.21; CiA 306 [DeviceInfo] (the numbers 1018h holds)"));
    vector.level = item.level;
    vector.setup = Setup::reset_node;
    vector.nmt = cia301::NmtState::pre_operational;
    vector.timeout = DurationSpec{std::chrono::seconds(5), {}};
    vector.file = "(generated)";
    vector.steps.push_back(Step{read, {}, 0, {}});
    vectors.push_back(std::move(vector));
  }
}

}  // namespace

std::vector<Vector> generate_od_vectors(const cia301::ObjectDictionary* eds,
                                        const std::string& eds_file,
                                        const profile::DriveProfile& profile,
                                        const std::optional<EdsIdentity>& identity,
                                        std::uint8_t node) {
  std::map<std::pair<std::uint16_t, std::uint8_t>, OdObject> objects;
  // A DCF (CiA 306-1 device configuration file) describes one configured device.
  std::string extension = std::filesystem::path(eds_file).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const bool dcf = extension == ".dcf";
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
            fmt::format("EDS {} [{:04X}sub{:X}]", eds_file, object.index(), entry.sub_index()),
            &entry,
            object.code()};
        od.pdo = entry.pdo_mappable();
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
    od.pdo = spec.pdo;
    objects[{od.index, od.sub}] = od;
  }
  std::vector<Vector> vectors;
  for (const auto& [key, object] : objects) {
    const auto& info = cia301::info(object.type);
    const auto range = type_range(object.type);
    const auto name = fmt::format("{:04X}h sub {}", object.index, object.sub);
    // 1003h sub 1..254 exist only while errors are recorded (else 08000024h, CiA 301 §7.5.2.4).
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
    if (object.eds_entry != nullptr) {
      add_eds_entry_checks(object, dcf, vectors);
      add_mapped_object_check(object, vectors);
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
  // CTT 3.31: every PDO-mappable wo/rww entry into a TPDO; with an EDS that has none, one
  // not-applicable result says so.
  const auto tpdo = tpdo_to_remap(eds, profile, node);
  bool any_tpdo_candidate = false;
  for (const auto& [key, object] : objects) {
    const auto bits = cia301::info(object.type).bit_size;
    if (!object.pdo || bits == 0 || bits > 64 ||
        (object.access != cia301::AccessType::wo && object.access != cia301::AccessType::rww))
      continue;
    any_tpdo_candidate = true;
    if (tpdo) {
      add_tpdo_map_check(object, *tpdo, vectors);
    } else {
      Vector vector = make(object, "tpdo-map",
                           fmt::format("Mapping {} {:04X}h sub {} into a TPDO is refused",
                                       cia301::to_string(object.access), object.index, object.sub),
                           Step{WaitStep{}, {}, 0, {}});
      vector.not_applicable = "the EDS has no TPDO (no 1800h-19FFh with its 1A00h-1BFFh)";
      vectors.push_back(std::move(vector));
    }
  }
  if (eds != nullptr && !any_tpdo_candidate) {
    OdObject none;
    none.source = fmt::format("EDS {}", eds_file);
    Vector vector = make(none, "tpdo-map",
                         "A PDO-mappable wo or rww entry mapped into a TPDO is "
                         "refused (CTT 3.31)",
                         Step{WaitStep{}, {}, 0, {}});
    vector.id = "eds/od/tpdo-map";
    vector.not_applicable =
        "no wo or rww entry with PDOMapping=1 in the EDS (nor `pdo: true` in the profile's "
        "objects): nothing a TPDO could wrongly carry";
    vectors.push_back(std::move(vector));
  }
  if (eds != nullptr) {
    add_reset_communication_check(objects, eds_file, vectors);
    for (const auto& object : eds->objects())
      add_sub_ff_check(object, eds_file, vectors);
    if (identity) add_identity_checks(*identity, eds_file, vectors);
  }
  return vectors;
}

std::vector<VectorResult> eds_lint_results(const std::vector<cia306::Diagnostic>& findings,
                                           const std::string& eds_file,
                                           const profile::DriveProfile& profile, bool strict) {
  std::vector<const cia306::LintRule*> rules;
  for (const auto& rule : cia306::lint_rules())
    rules.push_back(&rule);
  rules.push_back(&cia306::reader_rule());
  const auto is_lint_rule = [](const std::string& id) {
    const auto all = cia306::lint_rules();
    return std::any_of(all.begin(), all.end(),
                       [&](const cia306::LintRule& rule) { return rule.id == id; });
  };
  std::vector<VectorResult> results;
  for (const auto* rule : rules) {
    const bool reader = rule == &cia306::reader_rule();
    Vector vector;
    vector.id = fmt::format("eds/lint/{}", rule->id);
    vector.title = fmt::format(
        "The EDS {}: {}",
        rule->severity == cia306::Severity::error ? "MUST be such that" : "SHOULD be such that",
        rule->what);
    vector.level = rule->severity == cia306::Severity::error ? Level::must : Level::should;
    vector.sources = {cited(fmt::format("EDS {}", eds_file)), cited(std::string(rule->clause)),
                      cited("CTT 1.0 (EDS checker)")};
    vector.file = "(generated)";
    VectorResult result = result_for(vector);
    std::vector<std::string> found;
    for (const auto& finding : findings) {
      const bool ours = reader ? !is_lint_rule(finding.id) : finding.id == rule->id;
      if (!ours) continue;
      found.push_back(finding.to_string());
      result.checks.push_back(Check{0,
                                    "eds lint",
                                    fmt::format("no [{}] finding", rule->id),
                                    finding.to_string(),
                                    false,
                                    {},
                                    {}});
    }
    const auto expected = fmt::format("no [{}] finding ({})", rule->id, rule->what);
    if (found.empty()) {
      result.checks.push_back(Check{0, "eds lint", expected, "none", true, {}, {}});
      decide_verdict(result, vector, profile, Outcome::pass, {}, strict);
    } else {
      decide_verdict(result, vector, profile, Outcome::fail,
                     fmt::format("{}: eds lint: Expected {}; Actual {} finding(s)\n  Expected: "
                                 "{}\n  Actual:   {}",
                                 eds_file, expected, found.size(), expected,
                                 fmt::join(found, "\n            ")),
                     strict);
    }
    results.push_back(std::move(result));
  }
  return results;
}

}  // namespace drivecheck::conformance
