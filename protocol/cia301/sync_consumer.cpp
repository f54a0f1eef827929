#include "protocol/cia301/sync_consumer.hpp"

#include <chrono>

#include "protocol/cia301/cob_id.hpp"

namespace drivecheck::cia301 {

std::string_view to_string(SyncConsumerEventKind kind) {
  switch (kind) {
    case SyncConsumerEventKind::sync:
      return "SYNC";
    case SyncConsumerEventKind::wrong_length:
      return "SYNC with unexpected data length";
    case SyncConsumerEventKind::window_closed:
      return "synchronous window closed";
  }
  return "?";
}

std::optional<SyncConsumerEvent> SyncConsumer::on_frame(const can::Frame& frame,
                                                        can::TimePoint now) {
  if (frame.is_error() || frame.is_remote()) return std::nullopt;
  if (frame.is_extended() != config_.cob_id.extended || frame.id != config_.cob_id.can_id) {
    return std::nullopt;
  }
  const std::uint8_t expected = config_.counter_overflow == 0 ? 0 : 1;
  if (frame.dlc != expected) {
    ++wrong_lengths_;
    return SyncConsumerEvent{SyncConsumerEventKind::wrong_length, now, std::nullopt, frame.dlc};
  }
  ++received_;
  last_sync_ = now;
  last_counter_ = expected == 1 ? std::optional<std::uint8_t>(frame.data[0]) : std::nullopt;
  window_open_ = config_.window > can::Duration::zero();
  return SyncConsumerEvent{SyncConsumerEventKind::sync, now, last_counter_, frame.dlc};
}

can::TimePoint SyncConsumer::next_deadline() const {
  if (!window_open_ || !last_sync_ || config_.window <= can::Duration::zero()) {
    return can::kForever;
  }
  return *last_sync_ + config_.window;
}

std::optional<SyncConsumerEvent> SyncConsumer::on_time(can::TimePoint now) {
  const can::TimePoint deadline = next_deadline();
  if (deadline == can::kForever || now < deadline) return std::nullopt;
  window_open_ = false;
  return SyncConsumerEvent{SyncConsumerEventKind::window_closed, deadline, std::nullopt, 0};
}

bool SyncConsumer::in_window(can::TimePoint now) const {
  if (!last_sync_) return false;
  if (config_.window <= can::Duration::zero()) return true;
  return now < *last_sync_ + config_.window;
}

void SyncConsumer::reset() {
  last_sync_.reset();
  last_counter_.reset();
  window_open_ = false;
}

namespace {

Expected<void, SdoAbort> refuse_if(bool condition, SdoAbort abort) {
  if (condition) return Unexpected(abort);
  return {};
}

}  // namespace

Expected<void, std::string> add_sync_objects(ObjectDictionary& od,
                                             const SyncObjectOptions& options) {
  auto cob = od.add_var(kSyncCobIdIndex, "COB-ID SYNC message", DataType::unsigned32,
                        AccessType::rw, Value::of_unsigned(kSyncCobId));
  if (!cob) return Unexpected(cob.error());
  (*cob)->find(0)->set_write_validator(
      [producer_supported = options.producer_supported](
          const ObjectDictionary&, const Entry& entry,
          std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
        const auto value = static_cast<std::uint32_t>(load_unsigned(data));
        const auto next = decode_sync_cob_id_entry(value);
        if (!next) return Unexpected(SdoAbort::invalid_value);
        if (next->generate && !producer_supported) return Unexpected(SdoAbort::invalid_value);
        if (!next->extended && is_restricted_cob_id(next->can_id)) {
          return Unexpected(SdoAbort::invalid_value);
        }
        const auto current = static_cast<std::uint32_t>(entry.as_unsigned());
        const bool producing = (current & 0x40000000u) != 0;
        return refuse_if(producing && (current & 0x3FFFFFFFu) != (value & 0x3FFFFFFFu),
                         SdoAbort::invalid_value);
      });

  if (auto added = od.add_var(kCommunicationCyclePeriodIndex, "Communication cycle period",
                              DataType::unsigned32, AccessType::rw, Value::of_unsigned(0));
      !added) {
    return Unexpected(added.error());
  }
  if (auto added = od.add_var(kSyncWindowLengthIndex, "Synchronous window length",
                              DataType::unsigned32, AccessType::rw, Value::of_unsigned(0));
      !added) {
    return Unexpected(added.error());
  }
  auto overflow = od.add_var(kSyncCounterOverflowIndex, "Synchronous counter overflow value",
                             DataType::unsigned8, AccessType::rw, Value::of_unsigned(0));
  if (!overflow) return Unexpected(overflow.error());
  (*overflow)->find(0)->set_write_validator(
      [](const ObjectDictionary& dictionary, const Entry& entry,
         std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
        const std::uint8_t value = data[0];
        if (!is_valid_sync_counter_overflow(value)) return Unexpected(SdoAbort::invalid_value);
        const Entry* period = dictionary.find(kCommunicationCyclePeriodIndex, 0);
        const bool running = period != nullptr && period->as_unsigned() != 0;
        return refuse_if(running && value != entry.as_unsigned(),
                         SdoAbort::cannot_transfer_device_state);
      });
  return {};
}

SyncConsumerConfig sync_consumer_config(const ObjectDictionary& od) {
  SyncConsumerConfig config;
  if (const Entry* cob = od.find(kSyncCobIdIndex, 0)) {
    if (auto decoded = decode_sync_cob_id_entry(static_cast<std::uint32_t>(cob->as_unsigned()))) {
      config.cob_id = *decoded;
    }
  }
  if (const Entry* overflow = od.find(kSyncCounterOverflowIndex, 0)) {
    const auto value = static_cast<std::uint8_t>(overflow->as_unsigned());
    config.counter_overflow = is_valid_sync_counter_overflow(value) ? value : 0;
  }
  if (const Entry* window = od.find(kSyncWindowLengthIndex, 0)) {
    config.window = std::chrono::microseconds{window->as_unsigned()};
  }
  return config;
}

std::optional<SyncProducerConfig> sync_producer_config(const ObjectDictionary& od) {
  const SyncConsumerConfig consumer = sync_consumer_config(od);
  const Entry* period = od.find(kCommunicationCyclePeriodIndex, 0);
  if (!consumer.cob_id.generate || period == nullptr || period->as_unsigned() == 0) {
    return std::nullopt;
  }
  SyncProducerConfig config;
  config.period = std::chrono::microseconds{period->as_unsigned()};
  config.counter_overflow = consumer.counter_overflow;
  config.cob_id = consumer.cob_id.can_id;
  return config;
}

}  // namespace drivecheck::cia301
