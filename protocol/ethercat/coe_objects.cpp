#include "protocol/ethercat/coe_objects.hpp"

#include <fmt/format.h>

#include <iterator>
#include <utility>

namespace drivecheck::ethercat {

using cia301::AccessType;
using cia301::DataType;
using cia301::EntryDefinition;
using cia301::ObjectCode;
using cia301::ObjectDefinition;
using cia301::SdoAbort;

namespace {

constexpr SyncModeInfo kSyncModes[] = {
#define DRIVECHECK_COE_SYNC_MODE(name, value, outputs, inputs, mask, bits, text) \
  {SyncMode::name, #name, outputs, inputs, mask, bits, text},
#include "protocol/ethercat/coe_sync_modes.inc"
#undef DRIVECHECK_COE_SYNC_MODE
};

struct Range {
  std::uint16_t first;
  std::uint16_t last;
};
constexpr Range kRxMappings{0x1600, 0x17FF};
constexpr Range kTxMappings{0x1A00, 0x1BFF};

std::uint64_t little(std::span<const std::uint8_t> data) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < data.size() && i < 8; ++i)
    v |= std::uint64_t{data[i]} << (8 * i);
  return v;
}

ObjectDefinition assignment(std::uint16_t index, std::string name, std::uint8_t capacity,
                            const std::vector<std::uint16_t>& assigned, bool writable) {
  const AccessType access = writable ? AccessType::rw : AccessType::ro;
  ObjectDefinition def{index, std::move(name), ObjectCode::array, {}};
  def.entries.push_back(EntryDefinition::unsigned_entry(
      0, "number of assigned PDOs", DataType::unsigned8, access, assigned.size()));
  for (std::uint8_t i = 1; i <= capacity; ++i) {
    const std::uint16_t value = i <= assigned.size() ? assigned[i - 1] : 0;
    def.entries.push_back(EntryDefinition::unsigned_entry(i, fmt::format("assigned PDO {}", i),
                                                          DataType::unsigned16, access, value));
  }
  return def;
}

ObjectDefinition sync_parameters(std::uint16_t index, std::string name, const SyncParameters& p) {
  auto u16 = [](std::uint8_t sub, const char* n, AccessType a, std::uint64_t v) {
    return EntryDefinition::unsigned_entry(sub, n, DataType::unsigned16, a, v);
  };
  auto u32 = [](std::uint8_t sub, const char* n, AccessType a, std::uint64_t v) {
    return EntryDefinition::unsigned_entry(sub, n, DataType::unsigned32, a, v);
  };
  return {index,
          std::move(name),
          ObjectCode::record,
          {EntryDefinition::highest_sub_index(0x20),
           u16(0x01, "sync mode", AccessType::rw, static_cast<std::uint16_t>(p.mode)),
           u32(0x02, "cycle time", AccessType::rw, p.cycle_time_ns),
           u32(0x03, "shift time", AccessType::ro, 0),
           u16(0x04, "sync modes supported", AccessType::ro, p.supported),
           u32(0x05, "minimum cycle time", AccessType::ro, p.minimum_cycle_time_ns),
           u32(0x06, "calc and copy time", AccessType::ro, 0),
           u32(0x07, "minimum delay time", AccessType::ro, 0),
           u16(0x08, "get cycle time", AccessType::rw, 0),
           u32(0x09, "maximum delay time", AccessType::ro, 0),
           u16(0x0B, "SM event missed counter", AccessType::ro, 0),
           u16(0x0C, "cycle exceeded counter", AccessType::ro, 0),
           u16(0x0D, "shift too short counter", AccessType::ro, 0),
           EntryDefinition::make(0x20, "sync error", DataType::boolean, AccessType::ro,
                                 cia301::Value::of_unsigned(0), false)}};
}

// Puts `rule` in front of the entry's validator.
void guard(cia301::Entry& entry, cia301::WriteValidator rule) {
  cia301::WriteValidator previous = entry.write_validator();
  entry.set_write_validator([rule = std::move(rule), previous = std::move(previous)](
                                const cia301::ObjectDictionary& od, const cia301::Entry& e,
                                std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
    if (auto ok = rule(od, e, data); !ok) return ok;
    if (previous) return previous(od, e, data);
    return {};
  });
}

bool valid_mapping(const cia301::ObjectDictionary& od, Range range, std::uint64_t index) {
  return index >= range.first && index <= range.last &&
         od.find(static_cast<std::uint16_t>(index)) != nullptr;
}

}  // namespace

std::span<const SyncModeInfo> sync_mode_table() {
  return kSyncModes;
}

std::optional<SyncModeInfo> find_sync_mode(std::uint16_t value) {
  for (const auto& row : kSyncModes) {
    if (static_cast<std::uint16_t>(row.mode) == value) return row;
  }
  return std::nullopt;
}

std::vector<ObjectDefinition> coe_object_definitions(const CoeObjectsConfig& config) {
  std::vector<ObjectDefinition> out;
  {
    ObjectDefinition types{0x1C00, "Sync manager communication type", ObjectCode::array, {}};
    types.entries.push_back(EntryDefinition::unsigned_entry(
        0, "number of sync managers", DataType::unsigned8, AccessType::ro, config.sync_managers));
    constexpr std::uint8_t kTypes[] = {1, 2, 3, 4};  // mailbox write/read, outputs, inputs
    for (std::uint8_t i = 1; i <= config.sync_managers; ++i) {
      const std::uint8_t type = i <= std::size(kTypes) ? kTypes[i - 1] : 0;
      types.entries.push_back(
          EntryDefinition::unsigned_entry(i, fmt::format("communication type SM{}", i - 1),
                                          DataType::unsigned8, AccessType::ro, type));
    }
    out.push_back(std::move(types));
  }
  out.push_back(assignment(kRxPdoAssign, "RxPDO assign", config.rx_capacity, config.rx_assigned,
                           config.assignment_writable));
  out.push_back(assignment(kTxPdoAssign, "TxPDO assign", config.tx_capacity, config.tx_assigned,
                           config.assignment_writable));
  out.push_back(sync_parameters(kSmOutputParameter, "SM output parameter", config.outputs));
  out.push_back(sync_parameters(kSmInputParameter, "SM input parameter", config.inputs));
  return out;
}

Expected<void, std::string> install_coe_object_rules(cia301::ObjectDictionary& od,
                                                     std::function<bool()> configurable,
                                                     CoeObjectRuleOptions options) {
  const bool state_rule = options.configuration_only_when_configurable;
  auto in_state = [configurable, state_rule](
                      const cia301::ObjectDictionary&, const cia301::Entry&,
                      std::span<const std::uint8_t>) -> Expected<void, SdoAbort> {
    if (state_rule && !configurable()) return Unexpected(SdoAbort::cannot_transfer_device_state);
    return {};
  };
  for (const auto& [index, range] :
       {std::pair{kRxPdoAssign, kRxMappings}, std::pair{kTxPdoAssign, kTxMappings}}) {
    cia301::Object* object = od.find(index);
    if (object == nullptr) return Unexpected(fmt::format("{:04X}h is missing", index));
    for (cia301::Entry& entry : object->entries()) {
      if (!options.assignment_evaluated) {
        guard(entry, in_state);
      } else if (entry.sub_index() == 0) {
        guard(entry,
              [in_state, mappings = range, assign = index](
                  const cia301::ObjectDictionary& d, const cia301::Entry& e,
                  std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
                if (auto ok = in_state(d, e, data); !ok) return ok;
                const auto count = little(data);
                const cia301::Object* o = d.find(assign);
                std::uint64_t highest = 0;
                for (const auto& sub : o->entries())
                  highest = sub.sub_index();
                if (count > highest) return Unexpected(SdoAbort::value_too_high);
                for (std::uint64_t i = 1; i <= count; ++i) {
                  const cia301::Entry* assigned = o->find(static_cast<std::uint8_t>(i));
                  if (assigned == nullptr || !valid_mapping(d, mappings, assigned->as_unsigned())) {
                    return Unexpected(SdoAbort::invalid_value);
                  }
                }
                return {};
              });
      } else {
        guard(entry,
              [in_state, mappings = range, assign = index](
                  const cia301::ObjectDictionary& d, const cia301::Entry& e,
                  std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
                if (auto ok = in_state(d, e, data); !ok) return ok;
                const cia301::Entry* count = d.find(assign, 0);
                if (count != nullptr && count->as_unsigned() != 0) {
                  return Unexpected(SdoAbort::coe_sub_index_0_must_be_0);
                }
                const auto value = little(data);
                if (value != 0 && !valid_mapping(d, mappings, value)) {
                  return Unexpected(SdoAbort::invalid_value);
                }
                return {};
              });
      }
    }
  }
  // The mapping objects: written only while configurable.
  for (const Range range : {kRxMappings, kTxMappings}) {
    for (unsigned index = range.first; index <= range.last; ++index) {
      cia301::Object* object = od.find(static_cast<std::uint16_t>(index));
      if (object == nullptr) continue;
      for (cia301::Entry& entry : object->entries())
        guard(entry, in_state);
    }
  }
  for (const std::uint16_t index : {kSmOutputParameter, kSmInputParameter}) {
    cia301::Object* object = od.find(index);
    if (object == nullptr) return Unexpected(fmt::format("{:04X}h is missing", index));
    const bool outputs = index == kSmOutputParameter;
    if (cia301::Entry* mode = object->find(0x01)) {
      guard(*mode,
            [in_state, outputs, index](
                const cia301::ObjectDictionary& d, const cia301::Entry& e,
                std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
              if (auto ok = in_state(d, e, data); !ok) return ok;
              const auto row = find_sync_mode(static_cast<std::uint16_t>(little(data)));
              if (!row || !(outputs ? row->outputs : row->inputs)) {
                return Unexpected(SdoAbort::invalid_value);
              }
              const cia301::Entry* supported = d.find(index, 0x04);
              if (supported != nullptr &&
                  (supported->as_unsigned() & row->supported_mask) != row->supported_value) {
                return Unexpected(SdoAbort::invalid_value);
              }
              return {};
            });
    }
    if (cia301::Entry* cycle = object->find(0x02)) {
      guard(*cycle,
            [in_state, index](const cia301::ObjectDictionary& d, const cia301::Entry& e,
                              std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
              if (auto ok = in_state(d, e, data); !ok) return ok;
              const cia301::Entry* minimum = d.find(index, 0x05);
              if (minimum != nullptr && minimum->as_unsigned() != 0 &&
                  little(data) < minimum->as_unsigned()) {
                return Unexpected(SdoAbort::value_too_low);
              }
              return {};
            });
    }
  }
  return {};
}

}  // namespace drivecheck::ethercat
