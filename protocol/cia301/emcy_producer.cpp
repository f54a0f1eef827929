#include "protocol/cia301/emcy_producer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <chrono>
#include <utility>

#include "protocol/cia301/cob_id.hpp"

namespace drivecheck::cia301 {

EmcyProducer::EmcyProducer(std::uint8_t node_id, std::size_t history_size)
    : cob_id_{true, false, emcy_cob_id(node_id)},
      history_size_(std::clamp<std::size_t>(history_size, 1, 254)) {}

void EmcyProducer::set_cob_id(const EmcyCobIdEntry& cob_id) {
  cob_id_ = cob_id;
  if (!producing()) drop_queue();
}

void EmcyProducer::set_enabled(bool enabled) {
  enabled_ = enabled;
  if (!producing()) drop_queue();
}

void EmcyProducer::drop_queue() {
  suppressed_ += queue_.size();
  queue_.clear();
}

void EmcyProducer::enqueue(const Emcy& message, can::TimePoint now) {
  if (!producing()) {
    ++suppressed_;
    return;
  }
  if (queue_.size() >= kEmcyQueueLimit) {
    queue_.pop_front();
    ++dropped_;
  }
  queue_.push_back({message, now});
}

std::uint8_t EmcyProducer::error_register() const {
  if (active_.empty()) return 0;
  std::uint8_t value = static_cast<std::uint8_t>(ErrorRegisterBit::generic);
  for (const auto& error : active_)
    value |= error.register_bits;
  return static_cast<std::uint8_t>(value & ~static_cast<std::uint8_t>(ErrorRegisterBit::reserved));
}

bool EmcyProducer::is_active(std::uint16_t code) const {
  return std::any_of(active_.begin(), active_.end(),
                     [code](const ActiveError& error) { return error.code == code; });
}

bool EmcyProducer::raise(std::uint16_t code, std::uint8_t register_bits,
                         const std::array<std::uint8_t, 5>& manufacturer, can::TimePoint now) {
  if (code == 0x0000 || is_active(code)) return false;
  active_.push_back({code, register_bits, manufacturer});
  // Newest first: shift the history down by one, the oldest falls off when it is full.
  if (history_.size() < history_size_ || shift_when_full_) {
    if (history_.size() < history_size_) history_.push_back(0);
    std::move_backward(history_.begin(), history_.end() - 1, history_.end());
    history_.front() = code;
  }
  enqueue(Emcy{code, error_register(), manufacturer}, now);
  return true;
}

bool EmcyProducer::clear(std::uint16_t code, can::TimePoint now) {
  const auto it = std::find_if(active_.begin(), active_.end(),
                               [code](const ActiveError& error) { return error.code == code; });
  if (it == active_.end()) return false;
  active_.erase(it);
  if (active_.empty()) enqueue(Emcy{0x0000, error_register(), {}}, now);
  return true;
}

void EmcyProducer::reset() {
  active_.clear();
  history_.clear();
  queue_.clear();
  last_sent_.reset();
}

void EmcyProducer::discard_pending() {
  queue_.clear();
  last_sent_.reset();
}

can::TimePoint EmcyProducer::next_deadline() const {
  if (queue_.empty()) return can::kForever;
  can::TimePoint due = queue_.front().queued_at;
  if (last_sent_ && inhibit_ > can::Duration::zero()) due = std::max(due, *last_sent_ + inhibit_);
  return due;
}

std::optional<can::Frame> EmcyProducer::on_time(can::TimePoint now) {
  if (queue_.empty() || now < next_deadline()) return std::nullopt;
  const Emcy message = queue_.front().message;
  queue_.pop_front();
  last_sent_ = now;
  ++sent_;
  return encode(message, cob_id_.can_id,
                cob_id_.extended ? can::IdFormat::extended : can::IdFormat::standard);
}

namespace {

Expected<void, SdoAbort> validate_emcy_cob_id(const ObjectDictionary&, const Entry& entry,
                                              std::span<const std::uint8_t> data) {
  const auto value = static_cast<std::uint32_t>(load_unsigned(data));
  if ((value & 0x40000000u) != 0) return Unexpected(SdoAbort::invalid_value);
  const auto next = decode_emcy_cob_id_entry(value);
  if (!next) return Unexpected(SdoAbort::invalid_value);
  if (next->valid && !next->extended && is_restricted_cob_id(next->can_id)) {
    return Unexpected(SdoAbort::invalid_value);
  }
  const auto current = static_cast<std::uint32_t>(entry.as_unsigned());
  const bool current_valid = (current & 0x80000000u) == 0;
  if (current_valid && next->valid && (current & 0x3FFFFFFFu) != (value & 0x3FFFFFFFu)) {
    return Unexpected(SdoAbort::invalid_value);
  }
  return {};
}

}  // namespace

Expected<void, std::string> add_emcy_producer_objects(ObjectDictionary& od,
                                                      const EmcyObjectOptions& options) {
  if (options.history_size < 1 || options.history_size > 254) {
    return Unexpected(
        fmt::format("1003h: {} error history entries (1..254 supported)", options.history_size));
  }
  if (auto added = od.add_var(kErrorRegisterIndex, "Error register", DataType::unsigned8,
                              AccessType::ro, Value::of_unsigned(0), true);
      !added) {
    return Unexpected(added.error());
  }

  ObjectDefinition field;
  field.index = kPreDefinedErrorFieldIndex;
  field.name = "Pre-defined error field";
  field.code = ObjectCode::array;
  field.entries.push_back(EntryDefinition::unsigned_entry(0, "Number of errors",
                                                          DataType::unsigned8, AccessType::rw, 0));
  for (unsigned sub = 1; sub <= options.history_size; ++sub) {
    field.entries.push_back(EntryDefinition::unsigned_entry(
        static_cast<std::uint8_t>(sub), fmt::format("Standard error field {}", sub),
        DataType::unsigned32, AccessType::ro, 0));
  }
  auto added_field = od.add_object(std::move(field));
  if (!added_field) return Unexpected(added_field.error());
  for (Entry& entry : (*added_field)->entries()) {
    if (entry.sub_index() == 0) {
      entry.set_write_validator([](const ObjectDictionary&, const Entry&,
                                   std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
        if (data[0] != 0) return Unexpected(SdoAbort::invalid_value);
        return {};
      });
      // Without an owner that keeps the history elsewhere, clearing means zeroing the entries.
      entry.set_write_observer(
          [](ObjectDictionary& dictionary, Entry&) { clear_pre_defined_error_field(dictionary); });
    } else {
      entry.set_read_hook(
          [](ObjectDictionary& dictionary, Entry& self) -> Expected<void, SdoAbort> {
            const Entry* count = dictionary.find(kPreDefinedErrorFieldIndex, 0);
            if (count == nullptr || self.sub_index() > count->as_unsigned()) {
              return Unexpected(SdoAbort::no_data_available);
            }
            return {};
          });
    }
  }

  ObjectDefinition cob;
  cob.index = kEmcyCobIdIndex;
  cob.name = "COB-ID EMCY";
  cob.code = ObjectCode::var;
  cob.entries.push_back(EntryDefinition::unsigned_entry(0, "COB-ID EMCY", DataType::unsigned32,
                                                        AccessType::rw, kEmcyBase));
  cob.entries.back().default_adds_node_id = true;  // $NODEID+0x80
  auto added_cob = od.add_object(std::move(cob));
  if (!added_cob) return Unexpected(added_cob.error());
  (*added_cob)->find(0)->set_write_validator(validate_emcy_cob_id);

  if (auto added = od.add_var(kEmcyInhibitTimeIndex, "Inhibit time EMCY", DataType::unsigned16,
                              AccessType::rw, Value::of_unsigned(0));
      !added) {
    return Unexpected(added.error());
  }
  return {};
}

void clear_pre_defined_error_field(ObjectDictionary& od) {
  Object* field = od.find(kPreDefinedErrorFieldIndex);
  if (field == nullptr) return;
  for (Entry& entry : field->entries())
    entry.assign_unsigned(0);
}

void mirror_error_objects(const EmcyProducer& producer, ObjectDictionary& od) {
  if (Entry* reg = od.find(kErrorRegisterIndex, 0)) reg->assign_unsigned(producer.error_register());
  Object* field = od.find(kPreDefinedErrorFieldIndex);
  if (field == nullptr) return;
  const auto history = producer.history();
  std::size_t recorded = 0;
  for (Entry& entry : field->entries()) {
    if (entry.sub_index() == 0) continue;
    const std::size_t position = entry.sub_index() - 1u;
    if (position < history.size()) {
      entry.assign_unsigned(history[position]);
      recorded = std::max<std::size_t>(recorded, entry.sub_index());
    } else {
      entry.assign_unsigned(0);
    }
  }
  if (Entry* count = field->find(0)) count->assign_unsigned(recorded);
}

std::optional<EmcyCobIdEntry> configured_emcy_cob_id(const ObjectDictionary& od) {
  const Entry* entry = od.find(kEmcyCobIdIndex, 0);
  if (entry == nullptr) return std::nullopt;
  const auto decoded = decode_emcy_cob_id_entry(static_cast<std::uint32_t>(entry->as_unsigned()));
  if (!decoded) return std::nullopt;
  return *decoded;
}

std::optional<can::Duration> configured_emcy_inhibit_time(const ObjectDictionary& od) {
  const Entry* entry = od.find(kEmcyInhibitTimeIndex, 0);
  if (entry == nullptr) return std::nullopt;
  return std::chrono::microseconds{100 * entry->as_unsigned()};
}

}  // namespace drivecheck::cia301
