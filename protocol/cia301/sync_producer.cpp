#include "protocol/cia301/sync_producer.hpp"

#include <fmt/format.h>

namespace drivecheck::cia301 {

Expected<SyncProducer, std::string> SyncProducer::create(const SyncProducerConfig& config) {
  if (config.period <= can::Duration::zero()) {
    return Unexpected(std::string("SYNC period (1006h) must be above 0"));
  }
  if (!is_valid_sync_counter_overflow(config.counter_overflow)) {
    return Unexpected(
        fmt::format("synchronous counter overflow value (1019h) {} is reserved: use 0 or 2..240",
                    config.counter_overflow));
  }
  if (config.cob_id > can::kMaxExtendedId) {
    return Unexpected(fmt::format("SYNC CAN-ID {:X}h is above 29 bits", config.cob_id));
  }
  return SyncProducer(config);
}

void SyncProducer::start(can::TimePoint first) {
  start_ = first;
  next_ = first;
  slot_ = 0;
  counter_ = 1;
}

void SyncProducer::stop() {
  start_ = can::kForever;
  next_ = can::kForever;
}

std::optional<can::Frame> SyncProducer::on_time(can::TimePoint now) {
  if (next_ == can::kForever || now < next_) return std::nullopt;
  Sync sync;
  if (config_.counter_overflow != 0) {
    sync.counter = counter_;
    counter_ = counter_ >= config_.counter_overflow ? 1 : static_cast<std::uint8_t>(counter_ + 1);
  }
  ++sent_;
  // Next slot on the grid after `now`.
  const auto elapsed = now - start_;
  const auto due_slot =
      static_cast<std::uint64_t>(elapsed / config_.period);  // slot at or before now
  missed_ += due_slot - slot_;
  slot_ = due_slot + 1;
  next_ = start_ + config_.period * static_cast<can::Duration::rep>(slot_);
  return encode(sync, config_.cob_id);
}

bool SyncProducer::skip_due(can::TimePoint now) {
  if (next_ == can::kForever || now < next_) return false;
  const auto due_slot = static_cast<std::uint64_t>((now - start_) / config_.period);
  missed_ += due_slot - slot_ + 1;
  slot_ = due_slot + 1;
  next_ = start_ + config_.period * static_cast<can::Duration::rep>(slot_);
  return true;
}

SyncProducerPort::SyncProducerPort(can::Bus& bus, SyncProducer producer)
    : bus_(bus), producer_(std::move(producer)) {}

SyncProducerPort::~SyncProducerPort() {
  stop();
}

void SyncProducerPort::start(std::optional<can::TimePoint> first) {
  stop();
  producer_.start(first.value_or(bus_.now()));
  arm();
}

void SyncProducerPort::stop() {
  if (timer_ != can::kNoTimer) bus_.cancel_timer(timer_);
  timer_ = can::kNoTimer;
  producer_.stop();
}

void SyncProducerPort::arm() {
  if (!producer_.running()) return;
  timer_ = bus_.start_timer(producer_.next_deadline(), [this] {
    timer_ = can::kNoTimer;
    const auto& config = producer_.config();
    const auto format =
        config.cob_id > can::kMaxStandardId ? can::IdFormat::extended : can::IdFormat::standard;
    if (bus_.queued(config.cob_id, format) > 0) {
      producer_.skip_due(bus_.now());
    } else if (auto frame = producer_.on_time(bus_.now())) {
      if (auto error = bus_.send(*frame)) last_send_error_ = error;
    }
    arm();
  });
}

}  // namespace drivecheck::cia301
