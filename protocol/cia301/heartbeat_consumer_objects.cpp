#include "protocol/cia301/heartbeat_consumer_objects.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

namespace drivecheck::cia301 {

Expected<void, std::string> add_heartbeat_consumer_objects(ObjectDictionary& od,
                                                           std::uint8_t entries) {
  if (entries < 1 || entries > 127) {
    return Unexpected(
        fmt::format("1016h: {} consumer heartbeat entries (1..127 supported)", entries));
  }
  ObjectDefinition def;
  def.index = kConsumerHeartbeatTimeIndex;
  def.name = "Consumer heartbeat time";
  def.code = ObjectCode::array;
  def.entries.push_back(EntryDefinition::unsigned_entry(
      0, "Highest sub-index supported", DataType::unsigned8, AccessType::ro, entries));
  for (unsigned sub = 1; sub <= entries; ++sub) {
    def.entries.push_back(EntryDefinition::unsigned_entry(
        static_cast<std::uint8_t>(sub), fmt::format("Consumer heartbeat time {}", sub),
        DataType::unsigned32, AccessType::rw, 0));
  }
  auto added = od.add_object(std::move(def));
  if (!added) return Unexpected(added.error());

  for (Entry& entry : (*added)->entries()) {
    if (entry.sub_index() == 0) continue;
    entry.set_write_validator([](const ObjectDictionary& dictionary, const Entry& target,
                                 std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
      const auto decoded =
          decode_consumer_heartbeat_entry(static_cast<std::uint32_t>(load_unsigned(data)));
      if (!decoded) return Unexpected(SdoAbort::invalid_value);
      if (!decoded->is_used()) return {};
      const Object* object = dictionary.find(kConsumerHeartbeatTimeIndex);
      for (const Entry& other : object->entries()) {
        if (other.sub_index() == 0 || other.sub_index() == target.sub_index()) continue;
        const auto existing =
            decode_consumer_heartbeat_entry(static_cast<std::uint32_t>(other.as_unsigned()));
        if (existing && existing->is_used() && existing->node == decoded->node) {
          return Unexpected(SdoAbort::general_parameter_incompatibility);
        }
      }
      return {};
    });
  }
  return {};
}

std::vector<ConsumerHeartbeatEntry> consumer_heartbeat_entries(const ObjectDictionary& od) {
  std::vector<ConsumerHeartbeatEntry> out;
  const Object* object = od.find(kConsumerHeartbeatTimeIndex);
  if (object == nullptr) return out;
  for (const Entry& entry : object->entries()) {
    if (entry.sub_index() == 0 || entry.type() != DataType::unsigned32) continue;
    const auto decoded =
        decode_consumer_heartbeat_entry(static_cast<std::uint32_t>(entry.as_unsigned()));
    if (decoded && decoded->is_used()) out.push_back(*decoded);
  }
  return out;
}

std::vector<ConsumerHeartbeatEntry> configure_heartbeat_consumer(
    HeartbeatConsumer& consumer, const ObjectDictionary& od,
    std::span<const ConsumerHeartbeatEntry> previous) {
  auto current = consumer_heartbeat_entries(od);
  const auto contains = [](std::span<const ConsumerHeartbeatEntry> list,
                           const ConsumerHeartbeatEntry& entry) {
    return std::find(list.begin(), list.end(), entry) != list.end();
  };
  for (const auto& old_entry : previous) {
    if (!contains(current, old_entry)) consumer.stop_monitoring(old_entry.node);
  }
  for (const auto& new_entry : current) {
    if (!contains(previous, new_entry)) consumer.monitor(new_entry);
  }
  return current;
}

}  // namespace drivecheck::cia301
