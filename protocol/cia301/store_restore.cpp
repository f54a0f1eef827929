#include "protocol/cia301/store_restore.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

namespace drivecheck::cia301 {
namespace {

Expected<void, std::string> add_array(ObjectDictionary& od, std::uint16_t index, std::string name,
                                      std::uint32_t capabilities) {
  static constexpr const char* kGroups[] = {"Save all parameters", "Save communication parameters",
                                            "Save application parameters",
                                            "Save manufacturer defined parameters"};
  static constexpr const char* kRestoreGroups[] = {
      "Restore all default parameters", "Restore communication default parameters",
      "Restore application default parameters", "Restore manufacturer defined default parameters"};
  ObjectDefinition object;
  object.index = index;
  object.name = std::move(name);
  object.code = ObjectCode::array;
  EntryDefinition count;
  count.sub_index = 0;
  count.name = "Highest sub-index supported";
  count.type = DataType::unsigned8;
  count.access = AccessType::ro;
  count.default_value = Value::of_unsigned(kStoreManufacturer);
  object.entries.push_back(std::move(count));
  for (std::uint8_t group = kStoreAll; group <= kStoreManufacturer; ++group) {
    EntryDefinition e;
    e.sub_index = group;
    e.name = index == kStoreParametersIndex ? kGroups[group - 1] : kRestoreGroups[group - 1];
    e.type = DataType::unsigned32;
    e.access = AccessType::rw;
    e.default_value = Value::of_unsigned(capabilities);
    object.entries.push_back(std::move(e));
  }
  auto added = od.add_object(std::move(object));
  if (!added) return Unexpected(added.error());
  return {};
}

}  // namespace

Expected<void, std::string> MemoryParameterStorage::write(
    const ObjectDictionary::StoredParameters& parameters) {
  if (failing_)
    return Unexpected(std::string("memory storage: write refused (failing on purpose)"));
  stored_ = parameters;
  ++writes_;
  return {};
}

Expected<void, std::string> add_store_restore_objects(ObjectDictionary& od) {
  if (auto ok = add_array(od, kStoreParametersIndex, "Store parameters", kStoreCapabilities); !ok) {
    return ok;
  }
  return add_array(od, kRestoreDefaultParametersIndex, "Restore default parameters",
                   kRestoreCapabilities);
}

Expected<std::unique_ptr<StoreRestore>, std::string> StoreRestore::create(
    ObjectDictionary& od, ParameterStorage& storage) {
  if (od.find(kStoreParametersIndex) == nullptr ||
      od.find(kRestoreDefaultParametersIndex) == nullptr) {
    return Unexpected(std::string("store/restore: 1010h and 1011h must exist"));
  }
  auto stored = storage.read();
  if (!stored) return Unexpected(std::move(stored).error());
  std::unique_ptr<StoreRestore> service(new StoreRestore(od, storage));
  service->stored_ = std::move(*stored);
  service->bind();
  return service;
}

StoreRestore::~StoreRestore() {
  unbind();
}

void StoreRestore::bind() {
  const auto bind_object = [this](std::uint16_t index, std::uint32_t signature,
                                  std::uint32_t capabilities, bool is_save) {
    Object* object = od_.find(index);
    for (Entry& e : object->entries()) {
      if (e.sub_index() == 0) continue;
      const std::uint8_t group = e.sub_index();
      e.set_write_validator([this, signature, group, is_save](
                                const ObjectDictionary&, const Entry&,
                                std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
        if (load_unsigned(data) != signature) return Unexpected(SdoAbort::cannot_transfer);
        if (!is_save && restore_guard_) {
          if (auto allowed = restore_guard_(); !allowed) return allowed;
        }
        return is_save ? save(group) : restore_defaults(group);
      });
      // The signature is a command, not a value: the entry reads its capabilities again.
      e.set_write_observer(
          [capabilities](ObjectDictionary&, Entry& self) { self.assign_unsigned(capabilities); });
    }
  };
  bind_object(kStoreParametersIndex, kSaveSignature, kStoreCapabilities, true);
  bind_object(kRestoreDefaultParametersIndex, kLoadSignature, kRestoreCapabilities, false);
}

void StoreRestore::unbind() {
  for (const std::uint16_t index : {kStoreParametersIndex, kRestoreDefaultParametersIndex}) {
    Object* object = od_.find(index);
    if (object == nullptr) continue;
    for (Entry& e : object->entries()) {
      e.set_write_validator({});
      e.set_write_observer({});
    }
  }
}

bool StoreRestore::in_group(std::uint16_t index, std::uint8_t sub_index, std::uint8_t group) const {
  const Entry* e = od_.find(index, sub_index);
  if (e == nullptr || e->store_group() == kStoreNone) return false;
  return group == kStoreAll || e->store_group() == group;
}

Expected<void, SdoAbort> StoreRestore::commit(ObjectDictionary::StoredParameters next) {
  std::sort(next.begin(), next.end(), [](const auto& a, const auto& b) {
    return std::pair(a.index, a.sub_index) < std::pair(b.index, b.sub_index);
  });
  if (auto written = storage_.write(next); !written) {
    last_error_ = written.error();
    return Unexpected(SdoAbort::hardware_error);
  }
  last_error_.clear();
  stored_ = std::move(next);
  return {};
}

Expected<void, SdoAbort> StoreRestore::save(std::uint8_t group) {
  ObjectDictionary::StoredParameters next;
  for (const auto& s : stored_) {
    // Values of other groups stay; values of entries that no longer exist go.
    if (od_.find(s.index, s.sub_index) != nullptr && !in_group(s.index, s.sub_index, group)) {
      next.push_back(s);
    }
  }
  for (auto& s : od_.save(group))
    next.push_back(std::move(s));
  return commit(std::move(next));
}

Expected<void, SdoAbort> StoreRestore::restore_defaults(std::uint8_t group) {
  ObjectDictionary::StoredParameters next;
  for (const auto& s : stored_) {
    if (od_.find(s.index, s.sub_index) != nullptr && !in_group(s.index, s.sub_index, group)) {
      next.push_back(s);
    }
  }
  return commit(std::move(next));
}

std::size_t StoreRestore::apply(std::uint8_t group) {
  od_.restore_defaults(group);
  ObjectDictionary::StoredParameters selected;
  for (const auto& s : stored_) {
    if (in_group(s.index, s.sub_index, group)) selected.push_back(s);
  }
  return od_.load(selected);
}

}  // namespace drivecheck::cia301
