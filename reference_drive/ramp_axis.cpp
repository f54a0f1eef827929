#include "reference_drive/ramp_axis.hpp"

#include <algorithm>

namespace drivecheck::reference_drive {
namespace {

constexpr std::int64_t kNanoPerUnit = 1'000'000'000;  // velocity_ units per unit/s
constexpr std::int64_t kMaxChunkNs = 1'000'000'000;   // rate × dt stays below 2^63

}  // namespace

void RampAxis::disable_power() {
  ++commands_;
  motion_ = AxisMotion::free;
  decel_ = 0;
}

void RampAxis::follow_set_points() {
  ++commands_;
  motion_ = AxisMotion::following;
  decel_ = 0;
}

void RampAxis::ramp_to_stop(std::uint32_t deceleration) {
  ++commands_;
  motion_ = AxisMotion::stopping;
  decel_ = deceleration;
}

void RampAxis::stop_at_current_limit() {
  ++commands_;
  motion_ = AxisMotion::stopping;
  decel_ = config_.current_limit_deceleration;
}

void RampAxis::stop_at_voltage_limit() {
  ++commands_;
  motion_ = AxisMotion::stopping;
  decel_ = config_.voltage_limit_deceleration;
}

void RampAxis::set_velocity(std::int32_t velocity) {
  velocity_ = std::int64_t{velocity} * kNanoPerUnit;
}

double RampAxis::velocity() const {
  return static_cast<double>(velocity_) / static_cast<double>(kNanoPerUnit);
}

void RampAxis::advance(can::Duration dt) {
  std::int64_t left = dt.count();
  while (left > 0) {
    const std::int64_t chunk = std::min(left, kMaxChunkNs);
    advance_chunk(chunk);
    left -= chunk;
  }
}

void RampAxis::advance_chunk(std::int64_t dt_ns) {
  std::int64_t target = 0;
  std::uint32_t rate = 0;
  switch (motion_) {
    case AxisMotion::free:
      rate = config_.coast_deceleration;
      if (rate == 0) target = velocity_;  // no friction: runs on
      break;
    case AxisMotion::following:
      target = std::int64_t{set_point_} * kNanoPerUnit;
      rate = config_.acceleration;
      break;
    case AxisMotion::stopping:
      rate = decel_;
      if (rate == 0) target = velocity_;  // a zero deceleration never stops
      break;
  }
  const std::int64_t before = velocity_;
  if (motion_ == AxisMotion::following && rate == 0) {
    velocity_ = target;
    position_ += static_cast<double>(velocity_) / static_cast<double>(kNanoPerUnit) *
                 static_cast<double>(dt_ns) / 1e9;
    return;
  }
  const std::int64_t gap = target > before ? target - before : before - target;
  const std::int64_t delta = std::int64_t{rate} * dt_ns;
  // Time spent ramping (the rest of the chunk is at the target): exact for a linear ramp.
  std::int64_t ramp_ns = dt_ns;
  if (delta >= gap) {
    velocity_ = target;
    ramp_ns = rate == 0 ? 0 : gap / rate;
  } else {
    velocity_ = before < target ? before + delta : before - delta;
  }
  const double ramp_mean = (static_cast<double>(before) + static_cast<double>(velocity_)) / 2.0;
  const double travel = ramp_mean * static_cast<double>(ramp_ns) +
                        static_cast<double>(velocity_) * static_cast<double>(dt_ns - ramp_ns);
  position_ += travel / static_cast<double>(kNanoPerUnit) / 1e9;
}

}  // namespace drivecheck::reference_drive
