#include "protocol/cia301/object_dictionary.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <utility>

namespace drivecheck::cia301 {

EntryDefinition EntryDefinition::unsigned_entry(std::uint8_t sub_index, std::string name,
                                                DataType type, AccessType access,
                                                std::uint64_t default_value) {
  EntryDefinition entry;
  entry.sub_index = sub_index;
  entry.name = std::move(name);
  entry.type = type;
  entry.access = access;
  entry.default_value = Value::of_unsigned(default_value);
  return entry;
}

EntryDefinition EntryDefinition::make(std::uint8_t sub_index, std::string name, DataType type,
                                      AccessType access, Value default_value, bool pdo_mappable) {
  EntryDefinition entry;
  entry.sub_index = sub_index;
  entry.name = std::move(name);
  entry.type = type;
  entry.access = access;
  entry.default_value = std::move(default_value);
  entry.pdo_mappable = pdo_mappable;
  return entry;
}

EntryDefinition EntryDefinition::highest_sub_index(std::uint8_t n) {
  return unsigned_entry(0, "highest sub-index supported", DataType::unsigned8, AccessType::ro, n);
}

namespace {

std::uint8_t default_store_group(std::uint16_t index, AccessType access) {
  if (!is_writable(access)) return kStoreNone;
  if (index == 0x1003 || index == 0x1010 || index == 0x1011) return kStoreNone;
  if (index >= 0x1000 && index <= 0x1FFF) return kStoreCommunication;
  if (index >= 0x2000 && index <= 0x5FFF) return kStoreManufacturer;
  if (index >= 0x6000) return kStoreApplication;
  return kStoreNone;
}

bool in_group(std::uint8_t entry_group, std::uint8_t group) {
  if (entry_group == kStoreNone) return false;
  return group == kStoreAll || entry_group == group;
}

// -1 below, 0 inside, +1 above the limits; 2 when the value cannot be compared (NaN).
int compare_to_limits(const EntryDefinition& def, std::span<const std::uint8_t> data) {
  const auto& ti = info(def.type);
  const bool has_low = !def.low_limit.empty();
  const bool has_high = !def.high_limit.empty();
  if (!has_low && !has_high) return 0;
  switch (ti.type_class) {
    case TypeClass::unsigned_integer:
    case TypeClass::boolean: {
      const auto v = load_unsigned(data);
      if (has_low && v < def.low_limit.as_unsigned()) return -1;
      if (has_high && v > def.high_limit.as_unsigned()) return 1;
      return 0;
    }
    case TypeClass::signed_integer: {
      const auto v = load_signed(data);
      if (has_low && v < def.low_limit.as_signed()) return -1;
      if (has_high && v > def.high_limit.as_signed()) return 1;
      return 0;
    }
    case TypeClass::real: {
      double v = 0;
      if (ti.size == 4) {
        v = std::bit_cast<float>(static_cast<std::uint32_t>(load_unsigned(data)));
      } else {
        v = std::bit_cast<double>(load_unsigned(data));
      }
      if (std::isnan(v)) return 2;
      if (has_low && v < def.low_limit.as_real()) return -1;
      if (has_high && v > def.high_limit.as_real()) return 1;
      return 0;
    }
    default:
      return 0;
  }
}

Expected<void, std::string> check_definition(std::uint16_t index, const EntryDefinition& def) {
  const auto where = [&] { return fmt::format("{:04X}h sub {}", index, def.sub_index); };
  if (def.default_adds_node_id && !is_integer(def.type)) {
    return Unexpected(fmt::format("{}: $NODEID default on a non-integer type", where()));
  }
  if (!def.default_value.empty()) {
    if (auto ok = check_value(def.type, def.default_value); !ok) {
      return Unexpected(fmt::format("{}: default: {}", where(), ok.error()));
    }
  }
  for (const Value* limit : {&def.low_limit, &def.high_limit}) {
    if (limit->empty()) continue;
    if (!is_numeric(def.type)) {
      return Unexpected(fmt::format("{}: limits on a non-numeric type", where()));
    }
    if (auto ok = check_value(def.type, *limit); !ok) {
      return Unexpected(fmt::format("{}: limit: {}", where(), ok.error()));
    }
  }
  return {};
}

}  // namespace

// ---- Entry ----------------------------------------------------------------------------------

Value Entry::value() const {
  auto v = decode(def_.type, data_);
  return v ? *v : Value();
}

Expected<void, SdoAbort> Entry::assign_bytes(std::span<const std::uint8_t> bytes) {
  const auto size = info(def_.type).size;
  if (size != 0) {
    if (bytes.size() > size) return Unexpected(SdoAbort::length_too_high);
    if (bytes.size() < size) return Unexpected(SdoAbort::length_too_low);
    std::copy(bytes.begin(), bytes.end(), data_.begin());
    revision_.touch();
    return {};
  }
  if (def_.max_size != 0 && bytes.size() > def_.max_size) {
    return Unexpected(SdoAbort::length_too_high);
  }
  data_.assign(bytes.begin(), bytes.end());
  revision_.touch();
  return {};
}

Expected<void, SdoAbort> Entry::assign(const Value& value) {
  if (!check_value(def_.type, value)) return Unexpected(SdoAbort::invalid_value);
  const auto size = info(def_.type).size;
  if (size != 0 && size <= 8) {
    std::array<std::uint8_t, 8> buf{};
    switch (value.kind()) {
      case Value::Kind::unsigned_integer:
        store_unsigned(value.as_unsigned(), std::span(buf).first(size));
        break;
      case Value::Kind::signed_integer:
        store_unsigned(static_cast<std::uint64_t>(value.as_signed()), std::span(buf).first(size));
        break;
      case Value::Kind::real:
        if (size == 4) {
          store_unsigned(std::bit_cast<std::uint32_t>(static_cast<float>(value.as_real())),
                         std::span(buf).first(4));
        } else {
          store_unsigned(std::bit_cast<std::uint64_t>(value.as_real()), std::span(buf).first(8));
        }
        break;
      default:
        return Unexpected(SdoAbort::invalid_value);
    }
    std::copy(buf.begin(), buf.begin() + size, data_.begin());
    revision_.touch();
    return {};
  }
  return assign_bytes(value.as_bytes());
}

std::vector<std::uint8_t> Entry::default_bytes(std::uint8_t node_id) const {
  std::vector<std::uint8_t> out;
  const auto size = info(def_.type).size;
  if (def_.default_value.empty()) {
    out.assign(size, 0);
    return out;
  }
  Value v = def_.default_value;
  if (def_.default_adds_node_id) {
    ValueText text{def_.default_value, true, false, false};
    auto resolved = resolve(def_.type, text, node_id);
    if (resolved) v = *resolved;
  }
  if (!encode(def_.type, v, out)) out.assign(size, 0);
  return out;
}

// ---- Object ---------------------------------------------------------------------------------

const Entry* Object::find(std::uint8_t sub_index) const {
  const auto it =
      std::lower_bound(entries_.begin(), entries_.end(), sub_index,
                       [](const Entry& e, std::uint8_t sub) { return e.sub_index() < sub; });
  return (it != entries_.end() && it->sub_index() == sub_index) ? &*it : nullptr;
}

Entry* Object::find(std::uint8_t sub_index) {
  return const_cast<Entry*>(std::as_const(*this).find(sub_index));
}

ObjectDefinition Object::definition() const {
  ObjectDefinition def{index_, name_, code_, {}};
  for (const auto& e : entries_)
    def.entries.push_back(e.definition());
  return def;
}

// ---- ObjectDictionary -----------------------------------------------------------------------

ObjectDictionary::ObjectDictionary(const ObjectDictionary& other)
    : objects_(other.objects_), node_id_(other.node_id_), revision_(other.revision_) {
  adopt_entries();
}

ObjectDictionary::ObjectDictionary(ObjectDictionary&& other) noexcept
    : objects_(std::move(other.objects_)), node_id_(other.node_id_), revision_(other.revision_) {
  adopt_entries();
  other.objects_.clear();
}

ObjectDictionary& ObjectDictionary::operator=(const ObjectDictionary& other) {
  if (this == &other) return *this;
  objects_ = other.objects_;
  node_id_ = other.node_id_;
  revision_ = std::max(revision_, other.revision_) + 1;  // every value may have changed
  adopt_entries();
  return *this;
}

ObjectDictionary& ObjectDictionary::operator=(ObjectDictionary&& other) noexcept {
  if (this == &other) return *this;
  objects_ = std::move(other.objects_);
  node_id_ = other.node_id_;
  revision_ = std::max(revision_, other.revision_) + 1;
  adopt_entries();
  other.objects_.clear();
  return *this;
}

void ObjectDictionary::adopt_entries() {
  for (auto& o : objects_) {
    for (auto& e : o.entries_)
      e.revision_.dictionary = &revision_;
  }
}

Expected<Object*, std::string> ObjectDictionary::add_object(ObjectDefinition definition) {
  const auto index = definition.index;
  const auto pos = std::lower_bound(objects_.begin(), objects_.end(), index,
                                    [](const Object& o, std::uint16_t i) { return o.index_ < i; });
  if (pos != objects_.end() && pos->index_ == index) {
    return Unexpected(fmt::format("{:04X}h: object already exists", index));
  }
  auto& entries = definition.entries;
  for (std::size_t i = 1; i < entries.size(); ++i) {
    if (entries[i].sub_index <= entries[i - 1].sub_index) {
      return Unexpected(
          fmt::format("{:04X}h: sub-indices not ascending at sub {}", index, entries[i].sub_index));
    }
  }
  if (definition.code == ObjectCode::null_object) {
    if (!entries.empty())
      return Unexpected(fmt::format("{:04X}h: NULL object with entries", index));
  } else if (has_sub_entries(definition.code)) {
    if (entries.empty() || entries[0].sub_index != 0 || entries[0].type != DataType::unsigned8) {
      return Unexpected(fmt::format("{:04X}h: {} needs sub-index 0 of type UNSIGNED8", index,
                                    to_string(definition.code)));
    }
  } else if (entries.size() != 1 || entries[0].sub_index != 0) {
    return Unexpected(fmt::format("{:04X}h: {} has exactly one entry, sub-index 0", index,
                                  to_string(definition.code)));
  }
  Object object;
  object.index_ = index;
  object.name_ = std::move(definition.name);
  object.code_ = definition.code;
  object.entries_.reserve(entries.size());
  for (auto& def : entries) {
    if (auto ok = check_definition(index, def); !ok) return Unexpected(ok.error());
    object.entries_.push_back(make_entry(index, std::move(def)));
  }
  return &*objects_.insert(pos, std::move(object));
}

Entry ObjectDictionary::make_entry(std::uint16_t index, EntryDefinition def) {
  if (def.default_value.empty()) {  // explicit zero, so that definitions compare by value
    auto zero = decode(def.type, std::vector<std::uint8_t>(info(def.type).size, 0));
    def.default_value = zero ? *zero : Value::of_bytes({});
  }
  Entry entry;
  entry.index_ = index;
  entry.store_group_ = default_store_group(index, def.access);
  entry.def_ = std::move(def);
  entry.data_ = entry.default_bytes(node_id_);
  entry.data_.reserve(std::max(entry.def_.max_size, entry.data_.size()));
  entry.revision_.dictionary = &revision_;
  return entry;
}

Expected<void, std::string> ObjectDictionary::reshape_object(std::uint16_t index,
                                                             std::uint8_t highest,
                                                             std::vector<EntryDefinition> added) {
  Object* object = find(index);
  if (object == nullptr) return Unexpected(fmt::format("{:04X}h: no such object", index));
  if (!has_sub_entries(object->code_) || object->entries_.empty() ||
      object->entries_.front().sub_index() != 0 || highest == 0 || highest == 0xFF) {
    return Unexpected(
        fmt::format("{:04X}h: not an ARRAY/RECORD, or highest {} out of range", index, highest));
  }
  std::vector<Entry> fresh;
  for (auto& def : added) {
    if (def.sub_index == 0 || def.sub_index > highest || object->find(def.sub_index) != nullptr) {
      return Unexpected(fmt::format("{:04X}h sub {}: cannot be added", index, def.sub_index));
    }
    if (auto ok = check_definition(index, def); !ok) return Unexpected(ok.error());
    fresh.push_back(make_entry(index, std::move(def)));
  }
  auto& entries = object->entries_;
  entries.erase(std::remove_if(entries.begin(), entries.end(),
                               [&](const Entry& e) { return e.sub_index() > highest; }),
                entries.end());
  for (auto& entry : fresh)
    entries.push_back(std::move(entry));
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return a.sub_index() < b.sub_index(); });
  Entry& count = entries.front();
  count.def_.default_value = Value::of_unsigned(highest);
  count.data_ = {highest};
  count.revision_.touch();
  return {};
}

Expected<Object*, std::string> ObjectDictionary::add_var(std::uint16_t index, std::string name,
                                                         DataType type, AccessType access,
                                                         Value default_value, bool pdo_mappable) {
  EntryDefinition entry;
  entry.name = name;
  entry.type = type;
  entry.access = access;
  entry.default_value = std::move(default_value);
  entry.pdo_mappable = pdo_mappable;
  return add_object({index, std::move(name), ObjectCode::var, {std::move(entry)}});
}

std::size_t ObjectDictionary::remove_objects(std::uint16_t first, std::uint16_t last) {
  const auto begin =
      std::lower_bound(objects_.begin(), objects_.end(), first,
                       [](const Object& o, std::uint16_t i) { return o.index_ < i; });
  const auto end = std::upper_bound(begin, objects_.end(), last,
                                    [](std::uint16_t i, const Object& o) { return i < o.index_; });
  const auto removed = static_cast<std::size_t>(end - begin);
  objects_.erase(begin, end);
  ++revision_;
  return removed;
}

const Object* ObjectDictionary::find(std::uint16_t index) const {
  const auto it = std::lower_bound(objects_.begin(), objects_.end(), index,
                                   [](const Object& o, std::uint16_t i) { return o.index_ < i; });
  return (it != objects_.end() && it->index_ == index) ? &*it : nullptr;
}

Object* ObjectDictionary::find(std::uint16_t index) {
  return const_cast<Object*>(std::as_const(*this).find(index));
}

const Entry* ObjectDictionary::find(std::uint16_t index, std::uint8_t sub_index) const {
  const Object* object = find(index);
  return object ? object->find(sub_index) : nullptr;
}

Entry* ObjectDictionary::find(std::uint16_t index, std::uint8_t sub_index) {
  Object* object = find(index);
  return object ? object->find(sub_index) : nullptr;
}

Expected<Entry*, SdoAbort> ObjectDictionary::locate(std::uint16_t index, std::uint8_t sub_index) {
  Object* object = find(index);
  if (object == nullptr) return Unexpected(SdoAbort::object_does_not_exist);
  Entry* entry = object->find(sub_index);
  if (entry == nullptr) return Unexpected(SdoAbort::sub_index_does_not_exist);
  return entry;
}

std::size_t ObjectDictionary::entry_count() const {
  std::size_t n = 0;
  for (const auto& o : objects_)
    n += o.entries_.size();
  return n;
}

Expected<std::span<const std::uint8_t>, SdoAbort> ObjectDictionary::read(std::uint16_t index,
                                                                         std::uint8_t sub_index) {
  auto entry = locate(index, sub_index);
  if (!entry) return Unexpected(entry.error());
  Entry& e = **entry;
  if (!is_readable(e.def_.access)) return Unexpected(SdoAbort::read_write_only);
  if (e.read_hook_) {
    if (auto ok = e.read_hook_(*this, e); !ok) return Unexpected(ok.error());
  }
  return std::span<const std::uint8_t>(e.data_);
}

Expected<void, SdoAbort> ObjectDictionary::check_write(const Entry& entry,
                                                       std::span<const std::uint8_t> data) const {
  const auto& def = entry.def_;
  if (!is_writable(def.access)) return Unexpected(SdoAbort::write_read_only);
  const auto& ti = info(def.type);
  if (ti.size != 0) {
    if (data.size() > ti.size) return Unexpected(SdoAbort::length_too_high);
    if (data.size() < ti.size) return Unexpected(SdoAbort::length_too_low);
  } else {
    if (def.max_size != 0 && data.size() > def.max_size) {
      return Unexpected(SdoAbort::length_too_high);
    }
    if (ti.type_class == TypeClass::unicode_string && data.size() % 2 != 0) {
      return Unexpected(SdoAbort::length_mismatch);
    }
  }
  if (ti.type_class == TypeClass::boolean && data[0] > 1) {
    return Unexpected(SdoAbort::invalid_value);
  }
  switch (compare_to_limits(def, data)) {
    case -1:
      return Unexpected(SdoAbort::value_too_low);
    case 1:
      return Unexpected(SdoAbort::value_too_high);
    case 2:
      return Unexpected(SdoAbort::invalid_value);
    default:
      break;
  }
  if (entry.validator_) return entry.validator_(*this, entry, data);
  return {};
}

Expected<void, SdoAbort> ObjectDictionary::write(std::uint16_t index, std::uint8_t sub_index,
                                                 std::span<const std::uint8_t> data) {
  auto entry = locate(index, sub_index);
  if (!entry) return Unexpected(entry.error());
  Entry& e = **entry;
  if (auto ok = check_write(e, data); !ok) return ok;
  if (info(e.def_.type).size != 0) {
    std::copy(data.begin(), data.end(), e.data_.begin());
  } else {
    e.data_.assign(data.begin(), data.end());
  }
  e.revision_.touch();
  if (e.observer_) e.observer_(*this, e);
  return {};
}

Expected<Value, SdoAbort> ObjectDictionary::get(std::uint16_t index, std::uint8_t sub_index) const {
  const Object* object = find(index);
  if (object == nullptr) return Unexpected(SdoAbort::object_does_not_exist);
  const Entry* entry = object->find(sub_index);
  if (entry == nullptr) return Unexpected(SdoAbort::sub_index_does_not_exist);
  return entry->value();
}

Expected<void, SdoAbort> ObjectDictionary::set(std::uint16_t index, std::uint8_t sub_index,
                                               const Value& value) {
  auto entry = locate(index, sub_index);
  if (!entry) return Unexpected(entry.error());
  return (*entry)->assign(value);
}

ObjectDictionary::StoredParameters ObjectDictionary::save(std::uint8_t group) const {
  StoredParameters out;
  for (const auto& o : objects_) {
    for (const auto& e : o.entries_) {
      if (in_group(e.store_group_, group)) out.push_back({o.index_, e.def_.sub_index, e.data_});
    }
  }
  return out;
}

void ObjectDictionary::restore_defaults(std::uint8_t group) {
  for (auto& o : objects_) {
    for (auto& e : o.entries_) {
      if (!in_group(e.store_group_, group)) continue;
      // Still the default this function stored (see the file comment of the header).
      if (e.restored_.revision != 0 && e.revision_.count == e.restored_.revision &&
          (!e.def_.default_adds_node_id || e.restored_.node_id == node_id_)) {
        continue;
      }
      // Fixed-size integer defaults are stored in place, as default_bytes would encode them
      // (little endian, zeros when the value does not fit): no vector per entry at every reset.
      const Value& value = e.def_.default_value;
      const std::size_t size = info(e.def_.type).size;
      const bool integer = value.kind() == Value::Kind::unsigned_integer ||
                           value.kind() == Value::Kind::signed_integer;
      if (integer && !e.def_.default_adds_node_id && size != 0 && size <= 8 &&
          e.data_.size() == size) {
        if (check_value(e.def_.type, value)) {
          store_unsigned(value.kind() == Value::Kind::unsigned_integer
                             ? value.as_unsigned()
                             : static_cast<std::uint64_t>(value.as_signed()),
                         e.data_);
        } else {
          std::fill(e.data_.begin(), e.data_.end(), std::uint8_t{0});
        }
      } else {
        e.data_ = e.default_bytes(node_id_);
      }
      e.revision_.touch();
      e.restored_.revision = e.revision_.count;
      e.restored_.node_id = node_id_;
    }
  }
}

std::size_t ObjectDictionary::load(const StoredParameters& stored) {
  std::size_t applied = 0;
  for (const auto& s : stored) {
    Entry* e = find(s.index, s.sub_index);
    if (e != nullptr && e->assign_bytes(s.bytes)) ++applied;
  }
  return applied;
}

}  // namespace drivecheck::cia301
