#include "protocol/cia301/heartbeat_producer.hpp"

#include <cassert>

#include "protocol/cia301/error_control.hpp"

namespace drivecheck::cia301 {

void HeartbeatProducer::schedule_from(can::TimePoint anchor) {
  next_ = running_ && period_.count() > 0 ? anchor + period_ : can::kForever;
}

void HeartbeatProducer::set_period(std::chrono::milliseconds period, can::TimePoint now) {
  period_ = period.count() > 0 ? period : std::chrono::milliseconds{0};
  schedule_from(now);
}

void HeartbeatProducer::start(can::TimePoint boot_up) {
  running_ = true;
  schedule_from(boot_up);
}

void HeartbeatProducer::stop() {
  running_ = false;
  next_ = can::kForever;
}

std::optional<can::Frame> HeartbeatProducer::on_time(can::TimePoint now, NmtState state) {
  if (next_ == can::kForever || now < next_) return std::nullopt;
  assert(state != NmtState::boot_up);
  const can::Duration period = period_;
  // Skip the heartbeats that are already a whole period late.
  const auto late = (now - next_) / period;
  missed_ += static_cast<std::uint64_t>(late);
  next_ += period * (late + 1);
  ++sent_;
  return encode(Heartbeat{node_id_, state});
}

Expected<void, std::string> add_heartbeat_producer_objects(ObjectDictionary& od,
                                                           std::uint16_t default_ms) {
  auto added = od.add_var(kProducerHeartbeatTimeIndex, "Producer heartbeat time",
                          DataType::unsigned16, AccessType::rw, Value::of_unsigned(default_ms));
  if (!added) return Unexpected(added.error());
  return {};
}

std::optional<std::chrono::milliseconds> producer_heartbeat_time(const ObjectDictionary& od) {
  const Entry* entry = od.find(kProducerHeartbeatTimeIndex, 0);
  if (entry == nullptr) return std::nullopt;
  return std::chrono::milliseconds{entry->as_unsigned()};
}

}  // namespace drivecheck::cia301
