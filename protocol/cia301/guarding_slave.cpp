#include "protocol/cia301/guarding_slave.hpp"

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/error_control.hpp"

namespace drivecheck::cia301 {

std::string_view to_string(LifeGuardingEventKind kind) {
  switch (kind) {
    case LifeGuardingEventKind::expired:
      return "life guarding event";
    case LifeGuardingEventKind::resolved:
      return "life guarding resolved";
  }
  return "?";
}

void GuardingSlave::configure(std::chrono::milliseconds guard_time, std::uint8_t life_time_factor) {
  const auto ms = guard_time.count() > 0 ? guard_time.count() : 0;
  life_time_ = std::chrono::milliseconds{ms * life_time_factor};
  if (life_time_ == can::Duration::zero()) expired_ = false;
}

void GuardingSlave::set_heartbeat_in_use(bool in_use) {
  heartbeat_in_use_ = in_use;
  if (in_use) {
    last_request_.reset();
    expired_ = false;
  }
}

void GuardingSlave::reset() {
  toggle_ = false;
  expired_ = false;
  last_request_.reset();
}

GuardingSlaveResult GuardingSlave::on_frame(const can::Frame& frame, can::TimePoint now,
                                            NmtState state) {
  GuardingSlaveResult result;
  if (!frame.is_remote() || frame.is_extended() ||
      frame.id != kErrorControlBase + static_cast<std::uint32_t>(node_id_)) {
    return result;
  }
  const auto decoded = decode_error_control(frame);
  if (!decoded || !std::holds_alternative<GuardRequest>(*decoded)) return result;
  result.request = true;
  if (heartbeat_in_use_ || state == NmtState::boot_up) return result;

  result.response = encode(GuardResponse{node_id_, toggle_, state});
  toggle_ = !toggle_;
  ++responses_;
  last_request_ = now;
  if (expired_) {
    expired_ = false;
    result.event = LifeGuardingEvent{LifeGuardingEventKind::resolved, now};
  }
  return result;
}

can::TimePoint GuardingSlave::next_deadline() const {
  if (!monitoring() || expired_ || heartbeat_in_use_) return can::kForever;
  return *last_request_ + life_time_;
}

std::optional<LifeGuardingEvent> GuardingSlave::on_time(can::TimePoint now) {
  const can::TimePoint deadline = next_deadline();
  if (deadline == can::kForever || now < deadline) return std::nullopt;
  expired_ = true;
  return LifeGuardingEvent{LifeGuardingEventKind::expired, deadline};
}

Expected<void, std::string> add_guarding_slave_objects(ObjectDictionary& od) {
  if (auto added = od.add_var(kGuardTimeIndex, "Guard time", DataType::unsigned16, AccessType::rw,
                              Value::of_unsigned(0));
      !added) {
    return Unexpected(added.error());
  }
  if (auto added = od.add_var(kLifeTimeFactorIndex, "Life time factor", DataType::unsigned8,
                              AccessType::rw, Value::of_unsigned(0));
      !added) {
    return Unexpected(added.error());
  }
  return {};
}

std::optional<GuardingParameters> guarding_parameters(const ObjectDictionary& od) {
  const Entry* guard = od.find(kGuardTimeIndex, 0);
  const Entry* factor = od.find(kLifeTimeFactorIndex, 0);
  if (guard == nullptr || factor == nullptr) return std::nullopt;
  return GuardingParameters{std::chrono::milliseconds{guard->as_unsigned()},
                            static_cast<std::uint8_t>(factor->as_unsigned())};
}

}  // namespace drivecheck::cia301
