#include "conformance/esi_checks.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <optional>
#include <string_view>
#include <utility>

#include "conformance/verdict.hpp"

namespace drivecheck::conformance {
namespace {

using ethercat::EsiAccess;
using ethercat::EsiDevice;
using ethercat::EsiFile;
using ethercat::EsiObject;
using ethercat::EsiPdo;
using ethercat::EsiSubItem;

Source cited(std::string text) {
  return Source{std::move(text), "", "", 0, 0, 0};
}

std::string esi_source(const EsiFile& esi, int line, std::string_view what) {
  return line > 0 ? fmt::format("ESI {}:{} ({})", esi.file, line, what)
                  : fmt::format("ESI {} ({})", esi.file, what);
}

Vector base(std::string id, std::string title, Level level, Setup setup) {
  Vector vector;
  vector.id = std::move(id);
  vector.title = std::move(title);
  vector.level = level;
  vector.transports = {"ethercat"};
  // Every check establishes its own state (FORMAT.md "Isolation"): INIT then PREOP (a power
  // cycle first where the harness can), so no value left by another vector decides it.
  vector.setup = setup;
  vector.nmt = cia301::NmtState::pre_operational;
  vector.timeout = DurationSpec{std::chrono::seconds(5), {}};
  vector.file = "(generated)";
  return vector;
}

// ESI (IEC 61131-3) integer types whose value DefaultData gives and an upload compares.
bool integer_type(std::string_view type) {
  static constexpr std::array<std::string_view, 20> kIntegers = {
      "BOOL",  "BIT",  "SINT",   "INT",   "INT24",  "DINT",   "INT40",  "INT48", "INT56", "LINT",
      "USINT", "UINT", "UINT24", "UDINT", "UINT40", "UINT48", "UINT56", "ULINT", "BYTE",  "WORD"};
  return std::find(kIntegers.begin(), kIntegers.end(), type) != kIntegers.end() || type == "DWORD";
}

// The octets an upload of the entry carries, where the ESI fixes them (0: it does not).
std::size_t fixed_octets(const EsiSubItem& entry) {
  if (entry.bit_size == 0 || entry.bit_size % 8 != 0 || entry.bit_size > 64) return 0;
  if (!integer_type(entry.type) && entry.type != "REAL" && entry.type != "LREAL") return 0;
  return entry.bit_size / 8;
}

std::string entry_name(std::uint16_t index, std::uint8_t sub) {
  return fmt::format("{:04X}h sub {}", index, sub);
}

std::string od_id(std::uint16_t index, std::uint8_t sub, std::string_view check) {
  return fmt::format("esi/od/{:04x}-{:02x}/{}", index, sub, check);
}

void add_entry_checks(const EsiFile& esi, const EsiObject& object, const EsiSubItem& entry,
                      std::vector<Vector>& out) {
  const auto name = entry_name(object.index, entry.sub_index);
  const auto access_source = [&] {
    return cited(
        esi_source(esi, entry.line,
                   fmt::format("{} Flags/Access {}", name,
                               entry.access ? to_string(*entry.access) : "not given: ro")));
  };
  const EsiAccess access = entry.access.value_or(EsiAccess::ro);
  // 1003h sub 1..FEh exist only while errors are recorded (CiA 301 §7.5.2.4).
  const bool dynamic = object.index == 0x1003 && entry.sub_index > 0;
  const std::size_t octets = fixed_octets(entry);
  if (access != EsiAccess::wo && !dynamic) {
    SdoReadStep read{object.index, entry.sub_index, Transfer::automatic, {}, false, {}};
    if (octets != 0) {
      read.expect.kind = SdoExpect::Kind::size;
      read.expect.size = octets;
    }
    auto vector =
        base(od_id(object.index, entry.sub_index, "read"),
             fmt::format("{} ({}, {}) MUST be readable{}", name, entry.type, to_string(access),
                         octets != 0 ? fmt::format(" with {} octet(s)", octets) : ""),
             Level::must, Setup::reset_communication);
    vector.sources = {access_source(),
                      cited("CiA 301 §7.4.5 (access: ro and rw entries are read by SDO)")};
    vector.steps.push_back(Step{read, {}, 0, {}});
    vector.note =
        "The ESI's Flags/Access says the entry can be read (ETG.2000 .../Dictionary/Objects/"
        "Object/Flags/Access, or DataType/SubItem/Flags/Access: the access an SDO has; the "
        "ETG.2000 section is unconfirmed, its text not public to us); "
        "its BitSize the octets an upload carries.";
    out.push_back(std::move(vector));
  }
  if (access == EsiAccess::wo && !dynamic) {
    SdoReadStep read{object.index, entry.sub_index, Transfer::automatic, {}, false, {}};
    read.expect.kind = SdoExpect::Kind::abort;
    read.expect.abort = *AbortExpect::named("read-write-only");
    auto vector = base(
        od_id(object.index, entry.sub_index, "read-wo"),
        fmt::format("A read of write-only {} MUST abort ({})", name, read.expect.abort.describe()),
        Level::must, Setup::reset_communication);
    vector.sources = {access_source(), cited("CiA 301 §7.2.4.3.17 (06010001h)")};
    vector.steps.push_back(Step{read, {}, 0, {}});
    out.push_back(std::move(vector));
  }
  if (access == EsiAccess::ro && octets != 0) {
    SdoWriteStep write;
    write.index = object.index;
    write.sub = entry.sub_index;
    write.data.assign(octets, 0);
    write.expect.kind = SdoExpect::Kind::abort;
    write.expect.abort = *AbortExpect::named("write-read-only");
    auto vector = base(
        od_id(object.index, entry.sub_index, "write-ro"),
        fmt::format("A write to read-only {} MUST abort ({})", name, write.expect.abort.describe()),
        Level::must, Setup::reset_communication);
    vector.sources = {access_source(), cited("CiA 301 §7.2.4.3.17 (06010002h)")};
    vector.steps.push_back(Step{write, {}, 0, {}});
    out.push_back(std::move(vector));
  }
  // default: integer entries with DefaultData of the entry's size.
  const bool capability = (object.index == 0x1010 || object.index == 0x1011) &&
                          entry.sub_index > 0;  // a read gives the capability
  if (entry.default_data && octets != 0 && entry.default_data->size() == octets &&
      integer_type(entry.type) && access != EsiAccess::wo && !dynamic && object.index != 0x1003 &&
      !capability) {
    // Sub 0 of an ARRAY/RECORD that is read-only: the highest sub-index, fixed by the
    // structure. A writable sub 0 (1C12h/1C13h, 1600h+/1A00h+: a count of entries in use) is a
    // setting like any other.
    const bool structure = object.structured && entry.sub_index == 0 && access == EsiAccess::ro;
    SdoReadStep read{object.index, entry.sub_index, Transfer::automatic, {}, false, {}};
    read.expect.kind = SdoExpect::Kind::data;
    read.expect.data = *entry.default_data;
    std::uint64_t value = 0;
    for (std::size_t i = 0; i < entry.default_data->size(); ++i)
      value |= std::uint64_t{(*entry.default_data)[i]} << (8 * i);
    auto vector = base(
        od_id(object.index, entry.sub_index, "default"),
        fmt::format("{} {} read the ESI's DefaultData {:X}h{}", name, structure ? "MUST" : "SHOULD",
                    value, access == EsiAccess::rw ? " after a restore of the defaults" : ""),
        structure ? Level::must : Level::should,
        access == EsiAccess::rw ? Setup::restore_defaults : Setup::reset_node);
    vector.sources = {cited(esi_source(esi, entry.line, fmt::format("{} DefaultData", name)))};
    if (structure) {
      vector.sources.push_back(
          cited("CiA 301 §7.4.3 (sub-index 0 of an ARRAY/RECORD: the highest sub-index "
                "supported, fixed by the structure)"));
      vector.note =
          "Sub 0 of a structured object is the structure's size, not a setting: the ESI that "
          "gives it describes the device's structure, so it binds (as eds/od's sub 0 default).";
    } else {
      if (access == EsiAccess::rw)
        vector.sources.push_back(cited("CiA 301 §7.5.2.14 (1011h restore default parameters)"));
      vector.note =
          "A warning, not a failure: the ESI's DefaultData is the value a configuration tool "
          "starts from, and neither ETG.2000 nor CiA 301 binds the device's value to it (a "
          "commissioned or newer firmware may differ); a writable entry is read after a "
          "restore of the defaults (1011h; on a real link only with --allow-factory-restore).";
    }
    vector.steps.push_back(Step{read, {}, 0, {}});
    out.push_back(std::move(vector));
  }
}

void add_identity_checks(const EsiFile& esi, const EsiDevice& device, std::vector<Vector>& out) {
  struct Item {
    std::uint8_t sub;
    const char* check;
    const char* what;
    std::uint32_t value;
    std::optional<std::uint64_t> mask;
    Level level;
    int line;
  };
  const Item items[] = {
      {1, "vendor-id", "Vendor/Id", esi.vendor_id, std::nullopt, Level::must, 0},
      {2, "product-code", "Type@ProductCode", device.product_code, std::nullopt, Level::must,
       device.line},
      {3, "revision-major", "Type@RevisionNo", device.revision_number, 0xFFFF0000, Level::must,
       device.line},
      {3, "revision-number", "Type@RevisionNo", device.revision_number, std::nullopt, Level::should,
       device.line},
  };
  for (const Item& item : items) {
    SdoReadStep read{0x1018, item.sub, Transfer::automatic, {}, false, {}};
    read.expect.kind = SdoExpect::Kind::value;
    read.expect.value.literal = item.value;
    read.expect.mask = item.mask;
    auto vector = base(
        fmt::format("esi/identity/{}", item.check),
        item.mask
            ? fmt::format("1018h sub {} MUST hold the major revision {:04X}h (bits 16-31) "
                          "of the ESI's {} {:X}h",
                          item.sub, item.value >> 16, item.what, item.value)
            : fmt::format("1018h sub {} {} hold the ESI's {} {:X}h", item.sub,
                          item.level == Level::must ? "MUST" : "SHOULD", item.what, item.value),
        item.level, Setup::reset_communication);
    vector.sources = {
        cited(esi_source(esi, item.line, item.what)),
        cited(item.sub == 3 ? "CiA 301 §7.5.2.21 (1018h sub 3: major revision bits 16-31 = "
                              "the behaviour, minor revision bits 0-15 = versions of it)"
                            : "CiA 301 §7.5.2.21 (1018h identity)")};
    vector.note =
        "The ESI describes the device with these numbers (ETG.2000 Vendor/Id, Device/Type); "
        "1018h is where CoE gives them. The minor revision (bits 0-15) is a warning only: the "
        "same behaviour in another firmware, as eds/identity judges it.";
    vector.steps.push_back(Step{read, {}, 0, {}});
    out.push_back(std::move(vector));
  }
}

// The checks of one PDO's mapping object against the ESI's entries.
void add_mapping_check(const EsiFile& esi, const EsiDevice& device, const EsiPdo& pdo, bool rx,
                       std::vector<Vector>& out) {
  const bool configurable = device.coe && device.coe->pdo_config && !pdo.fixed;
  auto vector = base(fmt::format("esi/pdo/{:04x}/mapping", pdo.index),
                     fmt::format("{}PDO {:04X}h {} map the ESI's {} entr{} by default",
                                 rx ? "Rx" : "Tx", pdo.index, configurable ? "SHOULD" : "MUST",
                                 pdo.entries.size(), pdo.entries.size() == 1 ? "y" : "ies"),
                     configurable ? Level::should : Level::must, Setup::reset_node);
  vector.sources = {cited(esi_source(esi, pdo.line,
                                     fmt::format("{} {:04X}h", rx ? "RxPdo" : "TxPdo", pdo.index))),
                    cited("CiA 301 §7.5.2.36, §7.5.2.38 (mapping: sub 0 the number of mapped "
                          "objects, sub n index << 16 | sub-index << 8 | length)")};
  SdoReadStep count{pdo.index, 0, Transfer::automatic, {}, false, {}};
  count.expect.kind = SdoExpect::Kind::value;
  count.expect.value.literal = static_cast<std::int64_t>(pdo.entries.size());
  vector.steps.push_back(Step{count, {}, 0, {}});
  for (std::size_t i = 0; i < pdo.entries.size(); ++i) {
    SdoReadStep entry{pdo.index, static_cast<std::uint8_t>(i + 1), Transfer::automatic, {}, false,
                      {}};
    entry.expect.kind = SdoExpect::Kind::value;
    entry.expect.value.literal = pdo.entries[i].mapping_value();
    vector.steps.push_back(Step{entry, {}, 0, {}});
  }
  vector.note =
      configurable
          ? "A warning, not a failure: the ESI offers PDO configuration (CoE PdoConfig, the PDO "
            "not Fixed), so a master downloads the mapping it wants in PREOP (ETG.1000.6) and "
            "does not rely on the default."
          : "Binding: the mapping cannot be written (the PDO is Fixed, or the ESI's CoE has no "
            "PdoConfig), so a master takes the process data layout from the ESI; a device "
            "whose mapping differs exchanges other data than the master expects.";
  out.push_back(std::move(vector));
}

void add_assignment_check(const EsiFile& esi, const EsiDevice& device, bool rx,
                          std::vector<Vector>& out) {
  const auto assigned = rx ? device.default_rx_assignment() : device.default_tx_assignment();
  const std::uint16_t index = rx ? 0x1C12 : 0x1C13;
  const bool configurable = device.coe && device.coe->pdo_assign;
  std::vector<std::string> names;
  for (const EsiPdo* pdo : assigned)
    names.push_back(fmt::format("{:04X}h", pdo->index));
  auto vector = base(
      fmt::format("esi/pdo/{}-assignment", rx ? "rx" : "tx"),
      fmt::format("{:04X}h {} assign the {}PDOs the ESI assigns by default ({})", index,
                  configurable ? "SHOULD" : "MUST", rx ? "Rx" : "Tx",
                  names.empty() ? std::string("none") : fmt::format("{}", fmt::join(names, ", "))),
      configurable ? Level::should : Level::must, Setup::reset_node);
  vector.sources = {
      cited(esi_source(esi, device.line,
                       fmt::format("{} with @Sm: assigned by default", rx ? "RxPdo" : "TxPdo"))),
      cited("CiA 301 §7.4.3 (sub 0: the number of entries)")};
  SdoReadStep count{index, 0, Transfer::automatic, {}, false, {}};
  count.expect.kind = SdoExpect::Kind::value;
  count.expect.value.literal = static_cast<std::int64_t>(assigned.size());
  vector.steps.push_back(Step{count, {}, 0, {}});
  for (std::size_t i = 0; i < assigned.size(); ++i) {
    SdoReadStep entry{index, static_cast<std::uint8_t>(i + 1), Transfer::automatic, {}, false, {}};
    entry.expect.kind = SdoExpect::Kind::value;
    entry.expect.value.literal = assigned[i]->index;
    vector.steps.push_back(Step{entry, {}, 0, {}});
  }
  vector.note =
      configurable
          ? "A warning, not a failure: the ESI's CoE has PdoAssign, so a master downloads the "
            "assignment it wants in PREOP (ETG.1000.6) and does not rely on the default."
          : "Binding: the ESI's CoE has no PdoAssign, so the master cannot download an "
            "assignment and takes the ESI's; a device assigning others exchanges other data.";
  out.push_back(std::move(vector));
}

// ---- PdoMapping (Flags/PdoMapping, ETG.2000 EtherCATBase.xsd) -------------------------------

// Whether the ESI's Dictionary flags any entry with PdoMapping: without one it says nothing
// about mappability (the element is optional), and the checks are not applicable.
bool gives_pdo_mapping(const EsiDevice& device) {
  for (const EsiObject& object : device.objects) {
    for (const EsiSubItem& entry : object.entries) {
      if (entry.pdo_mapping) return true;
    }
  }
  return false;
}

const char* direction_text(bool rx) {
  return rx ? "RxPDO-mappable (PdoMapping R)" : "TxPDO-mappable (PdoMapping T)";
}

// index << 8 | sub of every entry the ESI lets a PDO of that direction map, sorted.
std::vector<std::uint32_t> mappable_entries(const EsiDevice& device, bool rx) {
  std::vector<std::uint32_t> out;
  for (const EsiObject& object : device.objects) {
    for (const EsiSubItem& entry : object.entries) {
      if (entry.pdo_mapping && (rx ? entry.pdo_mapping->rx : entry.pdo_mapping->tx))
        out.push_back(std::uint32_t{object.index} << 8 | entry.sub_index);
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

constexpr const char* kMappingNote =
    "A warning, not a failure: the ESI's Flags/PdoMapping (R, T, RT, TR; ETG.2000 "
    "EtherCATBase.xsd) says in which direction an entry may be mapped, and a PDO that maps an "
    "entry its own ESI does not flag so contradicts it (CiA 301 lets only mappable objects be "
    "mapped: abort 06040041h). Which side is wrong, and whether ETG.2000 binds the device's "
    "mappings to the flags (or only a configuration tool's offer), its text would say; that "
    "text is not public to us (the ETG.2000 section is unconfirmed), so the rule is not "
    "confirmed and the check warns. Lower-case flags (r, t) are read as their upper case: the "
    "schema allows them, their distinct meaning is not confirmed.";

// The PDO mapping objects the ESI knows: its RxPdo/TxPdo and the Dictionary's objects in
// 1600h-17FFh / 1A00h-1BFFh, with the number of mapping entries the ESI gives each.
std::vector<std::pair<std::uint16_t, std::size_t>> mapping_objects(const EsiDevice& device,
                                                                   bool rx) {
  const std::uint16_t first = rx ? 0x1600 : 0x1A00;
  const std::uint16_t last = rx ? 0x17FF : 0x1BFF;
  std::vector<std::pair<std::uint16_t, std::size_t>> out;
  const auto add = [&](std::uint16_t index, std::size_t entries) {
    for (auto& [i, n] : out) {
      if (i == index) {
        n = std::max(n, entries);
        return;
      }
    }
    out.emplace_back(index, entries);
  };
  for (const EsiPdo& pdo : rx ? device.rx_pdos : device.tx_pdos)
    add(pdo.index, pdo.entries.size());
  for (const EsiObject& object : device.objects) {
    if (object.index < first || object.index > last) continue;
    std::size_t highest = 0;
    for (const EsiSubItem& entry : object.entries)
      highest = std::max<std::size_t>(highest, entry.sub_index);
    add(object.index, highest);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// esi/pdo/<idx>/mappable: the mapping the device holds after a reset, read live, against the
// ESI's flags.
void add_live_mappable_checks(const EsiFile& esi, const EsiDevice& device, bool rx,
                              std::vector<Vector>& out) {
  const auto mappable = mappable_entries(device, rx);
  for (const auto& [index, entries] : mapping_objects(device, rx)) {
    if (entries == 0) continue;
    auto vector = base(fmt::format("esi/pdo/{:04x}/mappable", index),
                       fmt::format("{}PDO mapping {:04X}h SHOULD map only entries its ESI flags {}",
                                   rx ? "Rx" : "Tx", index, direction_text(rx)),
                       Level::should, Setup::reset_node);
    const EsiObject* object = device.find(index);
    vector.sources = {
        cited(esi_source(esi, object != nullptr ? object->line : device.line,
                         fmt::format("Flags/PdoMapping of the Dictionary; {:04X}h", index))),
        cited("CiA 301 §7.5.2.36, §7.5.2.38 (mapping entry: index << 16 | sub-index << 8 | "
              "length); CiA 301 §7.2.4.3.17 (06040041h: object cannot be mapped)")};
    SdoReadStep count{index, 0, Transfer::automatic, {}, false, "count"};
    count.expect.kind = SdoExpect::Kind::range;
    count.expect.low.literal = 0;
    count.expect.high.literal = static_cast<std::int64_t>(entries);
    vector.steps.push_back(
        Step{count, "the entries in use (the ESI describes up to this many)", 0, {}});
    for (std::size_t sub = 1; sub <= entries; ++sub) {
      SdoReadStep entry{index, static_cast<std::uint8_t>(sub), Transfer::automatic, {}, false, {}};
      entry.expect.mapping_entry = SdoExpect::MappingEntry{"count", mappable, direction_text(rx)};
      vector.steps.push_back(Step{entry, {}, 0, {}});
    }
    vector.note = kMappingNote;
    out.push_back(std::move(vector));
  }
}

}  // namespace

std::vector<VectorResult> esi_pdo_mapping_results(const EsiFile& esi, const EsiDevice& device,
                                                  const profile::DriveProfile& profile,
                                                  bool strict) {
  std::vector<VectorResult> results;
  const bool flags = gives_pdo_mapping(device);
  for (const bool rx : {true, false}) {
    for (const EsiPdo& pdo : rx ? device.rx_pdos : device.tx_pdos) {
      Vector vector = base(fmt::format("esi/pdo/{:04x}/entries-mappable", pdo.index),
                           fmt::format("The ESI's {} {:04X}h SHOULD list only entries it flags {}",
                                       rx ? "RxPdo" : "TxPdo", pdo.index, direction_text(rx)),
                           Level::should, Setup::none);
      vector.sources = {
          cited(
              esi_source(esi, pdo.line,
                         fmt::format("{} {:04X}h Entry list", rx ? "RxPdo" : "TxPdo", pdo.index))),
          cited("ETG.2000 EtherCATInfo/Descriptions/Devices/Device/Profile/Dictionary/Objects/"
                "Object/Flags/PdoMapping (section unconfirmed)")};
      vector.note = std::string(kMappingNote) +
                    " Judged from the file alone: an ESI that contradicts itself is an ESI "
                    "defect.";
      VectorResult result = result_for(vector);
      if (!flags) {
        result.verdict = Verdict::not_applicable;
        result.message =
            "the ESI's Dictionary gives no Flags/PdoMapping: it says nothing about which "
            "entries may be mapped";
        results.push_back(std::move(result));
        continue;
      }
      std::vector<std::string> wrong;
      std::size_t step = 0;
      for (const auto& entry : pdo.entries) {
        ++step;
        const std::string what = fmt::format("{} {:04X}h entry {} ({}:{})", rx ? "RxPdo" : "TxPdo",
                                             pdo.index, step, esi.file, entry.line);
        const std::string expected = fmt::format("{:04X}h sub {} {}, or a gap", entry.index,
                                                 entry.sub_index, direction_text(rx));
        std::string actual;
        bool ok = true;
        if (entry.index == 0) {
          actual = "a gap";
        } else if (const EsiSubItem* item = device.find(entry.index, entry.sub_index)) {
          ok = item->pdo_mapping && (rx ? item->pdo_mapping->rx : item->pdo_mapping->tx);
          actual = item->pdo_mapping ? fmt::format("PdoMapping {} ({}:{})", item->pdo_mapping->text,
                                                   esi.file, item->pdo_mapping->line)
                                     : fmt::format("no PdoMapping ({}:{})", esi.file, item->line);
        } else {
          ok = false;
          actual = "not in the ESI's Dictionary";
        }
        result.checks.push_back(Check{step, "esi", what + ": " + expected, actual, ok, {}, {}});
        if (!ok)
          wrong.push_back(fmt::format("{:04X}h sub {} ({})", entry.index, entry.sub_index, actual));
      }
      if (wrong.empty()) {
        decide_verdict(result, vector, profile, Outcome::pass, {}, strict);
      } else {
        decide_verdict(result, vector, profile, Outcome::fail,
                       fmt::format("ESI {}:{}: {} {:04X}h: Expected every entry {}; Actual {}",
                                   esi.file, pdo.line, rx ? "RxPdo" : "TxPdo", pdo.index,
                                   direction_text(rx), fmt::join(wrong, ", ")),
                       strict);
      }
      results.push_back(std::move(result));
    }
  }
  return results;
}

std::vector<Vector> generate_esi_vectors(const EsiFile& esi, const EsiDevice& device) {
  std::vector<Vector> out;
  add_identity_checks(esi, device, out);
  for (const EsiObject& object : device.objects) {
    for (const EsiSubItem& entry : object.entries)
      add_entry_checks(esi, object, entry, out);
  }
  add_assignment_check(esi, device, true, out);
  add_assignment_check(esi, device, false, out);
  for (const EsiPdo& pdo : device.rx_pdos)
    add_mapping_check(esi, device, pdo, true, out);
  for (const EsiPdo& pdo : device.tx_pdos)
    add_mapping_check(esi, device, pdo, false, out);
  if (gives_pdo_mapping(device)) {
    add_live_mappable_checks(esi, device, true, out);
    add_live_mappable_checks(esi, device, false, out);
  }
  return out;
}

std::vector<VectorResult> esi_sii_results(const EsiFile& esi, const EsiDevice& device,
                                          const ethercat::SiiHeader& sii,
                                          const profile::DriveProfile& profile, bool strict) {
  struct Item {
    const char* check;
    const char* what;
    const char* word;
    std::uint32_t expected;
    std::uint32_t actual;
    int line;
  };
  const Item items[] = {
      {"sii-vendor-id", "Vendor/Id", "words 08h-09h (vendor ID)", esi.vendor_id, sii.vendor_id, 0},
      {"sii-product-code", "Type@ProductCode", "words 0Ah-0Bh (product code)", device.product_code,
       sii.product_code, device.line},
      {"sii-revision-number", "Type@RevisionNo", "words 0Ch-0Dh (revision number)",
       device.revision_number, sii.revision, device.line},
  };
  std::vector<VectorResult> results;
  for (const Item& item : items) {
    Vector vector = base(fmt::format("esi/identity/{}", item.check),
                         fmt::format("The SII's {} MUST hold the ESI's {} {:X}h", item.word,
                                     item.what, item.expected),
                         Level::must, Setup::none);
    vector.sources = {cited(esi_source(esi, item.line, item.what)),
                      cited("ETG.2000 EtherCATInfo/Vendor/Id, Descriptions/Devices/Device/"
                            "Type@ProductCode, @RevisionNo (section unconfirmed; the schema's "
                            "Type@CheckProductCode, @CheckRevisionNo: how a configuration tool "
                            "compares them with the slave's)")};
    vector.note =
        "A configuration tool finds a slave's ESI by the vendor ID, product code and revision "
        "its SII holds (the ESI schema's Type@CheckProductCode/@CheckRevisionNo say how they "
        "are compared); the ETG.2000 section that says so is unconfirmed (not public to us), so "
        "the citation gives the element path.";
    VectorResult result = result_for(vector);
    const std::string expected = fmt::format("{:08X}h", item.expected);
    const std::string actual = fmt::format("{:08X}h", item.actual);
    const bool ok = item.expected == item.actual;
    result.checks.push_back(Check{0, "sii", expected, actual, ok, {}, {}});
    if (ok) {
      decide_verdict(result, vector, profile, Outcome::pass, {}, strict);
    } else {
      decide_verdict(result, vector, profile, Outcome::fail,
                     fmt::format("SII {}: Expected {} (ESI {}); Actual {}", item.word, expected,
                                 item.what, actual),
                     strict);
    }
    results.push_back(std::move(result));
  }
  return results;
}

}  // namespace drivecheck::conformance
