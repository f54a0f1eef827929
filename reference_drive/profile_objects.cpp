#include "reference_drive/profile_objects.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <optional>
#include <utility>

namespace drivecheck::reference_drive {
namespace {

// A listed integer (default or limit) as a value of `type`; empty for types without numbers.
cia301::Value number_of(cia301::DataType type, std::optional<std::int64_t> number) {
  if (!number) return {};
  switch (cia301::value_kind(type)) {
    case cia301::Value::Kind::unsigned_integer:
      if (*number < 0) return {};  // cannot be an unsigned value: left out (add_object refuses)
      return cia301::Value::of_unsigned(static_cast<std::uint64_t>(*number));
    case cia301::Value::Kind::signed_integer:
      return cia301::Value::of_signed(*number);
    case cia301::Value::Kind::real:
      return cia301::Value::of_real(static_cast<double>(*number));
    default:
      return {};
  }
}

cia301::EntryDefinition entry_of(const profile::ObjectSpec& spec, bool with_limits) {
  cia301::Value value = number_of(spec.type, spec.default_value);
  if (spec.default_text && cia301::value_kind(spec.type) == cia301::Value::Kind::bytes) {
    value = cia301::Value::of_string(*spec.default_text);
  }
  cia301::EntryDefinition entry = cia301::EntryDefinition::make(
      spec.sub, spec.name.empty() ? fmt::format("sub {}", spec.sub) : spec.name, spec.type,
      spec.access, std::move(value), spec.pdo);
  if (with_limits) {
    entry.low_limit = number_of(spec.type, spec.min);
    entry.high_limit = number_of(spec.type, spec.max);
  }
  return entry;
}

// The object of one index from its listed entries (sorted by sub-index).
cia301::ObjectDefinition object_of(std::uint16_t index,
                                   const std::vector<const profile::ObjectSpec*>& specs,
                                   bool with_limits) {
  cia301::ObjectDefinition def{
      index, fmt::format("manufacturer object {:04X}h", index), cia301::ObjectCode::var, {}};
  const bool record = specs.back()->sub != 0;
  if (record) def.code = cia301::ObjectCode::record;
  for (const profile::ObjectSpec* spec : specs) {
    cia301::EntryDefinition entry = entry_of(*spec, with_limits);
    if (record && spec->sub == 0) {
      // Sub 0 of a RECORD must be UNSIGNED8 (CiA 301 "highest sub-index supported").
      if (spec->type != cia301::DataType::unsigned8) continue;
      if (!spec->default_value) entry.default_value = cia301::Value::of_unsigned(specs.back()->sub);
    }
    def.entries.push_back(std::move(entry));
  }
  if (record && def.entries.front().sub_index != 0) {
    def.entries.insert(def.entries.begin(),
                       cia301::EntryDefinition::highest_sub_index(specs.back()->sub));
  }
  return def;
}

// The listed limits in front of the existing entry's own checks (a write below min aborts
// 06090032h, above max 06090031h); integer entries only.
void restrict_to_limits(cia301::Entry& entry, const profile::ObjectSpec& spec) {
  if ((!spec.min && !spec.max) || !cia301::is_integer(entry.type()) ||
      !cia301::is_writable(entry.access())) {
    return;
  }
  const bool is_signed = cia301::info(entry.type()).type_class == cia301::TypeClass::signed_integer;
  cia301::WriteValidator inner = entry.write_validator();
  entry.set_write_validator(
      [min = spec.min, max = spec.max, is_signed, inner](
          const cia301::ObjectDictionary& od, const cia301::Entry& e,
          std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
        if (data.size() == e.bytes().size()) {  // a wrong size is the dictionary's to refuse
          const std::int64_t value = is_signed
                                         ? cia301::load_signed(data)
                                         : static_cast<std::int64_t>(cia301::load_unsigned(data));
          if (min && value < *min) return Unexpected(cia301::SdoAbort::value_too_low);
          if (max && value > *max) return Unexpected(cia301::SdoAbort::value_too_high);
        }
        if (inner) return inner(od, e, data);
        return {};
      });
}

// A device profile entry (6000h-9FFFh) the manual lists as ro/const that the drive lets write:
// writes abort 06010002h as on the manual's drive (IRTSA 605Eh). Communication objects keep
// their access (their behaviour is CiA 301's: a manual table's "ro" for a PDO mapping count
// contradicts its own mapping procedure, see the objects files).
void restrict_to_read_only(cia301::Entry& entry, const profile::ObjectSpec& spec) {
  if (spec.index < 0x6000 || spec.index > 0x9FFF || cia301::is_writable(spec.access) ||
      spec.access == cia301::AccessType::wo || !cia301::is_writable(entry.access())) {
    return;
  }
  entry.set_write_validator([](const cia301::ObjectDictionary&, const cia301::Entry&,
                               std::span<const std::uint8_t>) -> Expected<void, cia301::SdoAbort> {
    return Unexpected(cia301::SdoAbort::write_read_only);
  });
}

// An object the drive has, with the listed entries of its index (sorted): its sub-index
// structure as listed where the drive's sub 0 is "highest sub-index supported" (UNSIGNED8,
// ro/const): listed sub 0 default N -> the object ends at N; listed sub-indices it lacks are
// added (profile_objects.hpp). Objects whose sub 0 is writable (PDO mapping counts, 1003h) keep
// their shape.
void reshape(cia301::ObjectDictionary& od, const cia301::Object& object,
             const std::vector<const profile::ObjectSpec*>& specs, std::vector<std::string>& out) {
  std::vector<const profile::ObjectSpec*> lacking;
  for (const profile::ObjectSpec* spec : specs) {
    if (object.find(spec->sub) == nullptr) lacking.push_back(spec);
  }
  const cia301::Entry* count = object.find(0);
  const bool shaped = object.code() != cia301::ObjectCode::var && count != nullptr &&
                      count->type() == cia301::DataType::unsigned8 &&
                      !cia301::is_writable(count->access());
  const profile::ObjectSpec* listed_count = specs.front()->sub == 0 ? specs.front() : nullptr;
  const std::uint8_t drive_highest = object.entries().back().sub_index();
  std::uint8_t highest = drive_highest;
  if (listed_count != nullptr && listed_count->default_value && *listed_count->default_value > 0 &&
      *listed_count->default_value < 0xFF) {
    highest = static_cast<std::uint8_t>(*listed_count->default_value);
  } else if (!lacking.empty()) {
    highest = std::max(highest, lacking.back()->sub);
  }
  if (!shaped ||
      (highest == drive_highest && lacking.empty() && count->as_unsigned() == drive_highest)) {
    for (const profile::ObjectSpec* spec : lacking) {
      out.push_back(fmt::format(
          "objects: {:04X}h sub {}: the drive has {:04X}h without this sub-index; not added",
          spec->index, spec->sub, spec->index));
    }
    return;
  }
  std::vector<cia301::EntryDefinition> added;
  for (const profile::ObjectSpec* spec : lacking) {
    if (spec->sub <= highest) added.push_back(entry_of(*spec, true));
  }
  if (auto r = od.reshape_object(object.index(), highest, std::move(added)); !r) {
    out.push_back("objects: " + r.error());
  }
}

}  // namespace

std::vector<std::string> add_profile_objects(cia301::ObjectDictionary& od,
                                             const std::vector<profile::ObjectSpec>& objects) {
  std::vector<std::string> not_added;
  std::map<std::uint16_t, std::vector<const profile::ObjectSpec*>> missing;
  std::map<std::uint16_t, std::vector<const profile::ObjectSpec*>> present;
  for (const profile::ObjectSpec& spec : objects) {
    (od.find(spec.index) == nullptr ? missing : present)[spec.index].push_back(&spec);
  }
  const auto by_sub = [](const auto* a, const auto* b) { return a->sub < b->sub; };
  for (auto& [index, specs] : present) {
    std::sort(specs.begin(), specs.end(), by_sub);
    reshape(od, *od.find(index), specs, not_added);
    for (const profile::ObjectSpec* spec : specs) {
      if (cia301::Entry* entry = od.find(index, spec->sub); entry != nullptr) {
        restrict_to_limits(*entry, *spec);
        restrict_to_read_only(*entry, *spec);
      }
    }
  }
  for (auto& [index, specs] : missing) {
    std::sort(specs.begin(), specs.end(), by_sub);
    auto added = od.add_object(object_of(index, specs, true));
    if (added) continue;
    // A limit the dictionary refuses (e.g. a default outside the listed range): without limits.
    auto plain = od.add_object(object_of(index, specs, false));
    not_added.push_back(fmt::format("objects: {:04X}h: {}{}", index, added.error(),
                                    plain ? "; added without its limits" : "; not added"));
  }
  return not_added;
}

std::vector<DefaultOverride> profile_default_overrides(
    const std::vector<profile::ObjectSpec>& objects) {
  std::vector<DefaultOverride> out;
  for (const profile::ObjectSpec& spec : objects) {
    const bool option_code = spec.index == 0x6007 || (spec.index >= 0x605A && spec.index <= 0x605E);
    const bool factor = spec.index >= 0x6091 && spec.index <= 0x6097;
    const bool ip_buffer = spec.index == 0x60C4;  // the personality's ip_submode owns the buffer
    // The encoder resolutions are constants of the drive (ro on some), not live values.
    const bool resolution = spec.index == 0x608F || spec.index == 0x6090;
    if (spec.index < 0x6000 || spec.index > 0x9FFF || option_code || factor || ip_buffer ||
        !spec.default_value || !cia301::is_integer(spec.type) ||
        (!cia301::is_writable(spec.access) && !resolution)) {
      continue;
    }
    out.push_back({spec.index, spec.sub, *spec.default_value, cia301::ResetKind::application});
  }
  return out;
}

std::uint8_t listed_mapping_entries(const std::vector<profile::ObjectSpec>& objects) {
  std::uint8_t highest = 0;
  for (const profile::ObjectSpec& spec : objects) {
    const bool mapping = (spec.index >= 0x1600 && spec.index <= 0x17FF) ||
                         (spec.index >= 0x1A00 && spec.index <= 0x1BFF);
    if (mapping) highest = std::max(highest, spec.sub);
  }
  return highest;
}

}  // namespace drivecheck::reference_drive
