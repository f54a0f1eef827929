#include "fuzz/live/liveness_oracle.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <utility>

namespace drivecheck::fuzz_live {
namespace {

constexpr std::array<std::pair<AnomalyKind, std::string_view>, 7> kNames = {{
    {AnomalyKind::babbling, "babbling"},
    {AnomalyKind::device_silent, "device-silent"},
    {AnomalyKind::sdo_no_answer, "sdo-no-answer"},
    {AnomalyKind::no_boot_up, "no-boot-up"},
    {AnomalyKind::unexpected_boot_up, "unexpected-boot-up"},
    {AnomalyKind::heartbeat_lost, "heartbeat-lost"},
    {AnomalyKind::guarding_lost, "guarding-lost"},
}};

constexpr std::size_t kEmcyKept = 8;

// Frames a node sends on its own default identifiers: EMCY 81h..FFh, TPDOs 181h..57Fh
// (x80h + N), SDO responses 580h + N, error control 700h + N.
bool from_node(const can::Frame& frame, std::uint8_t node) {
  if (frame.is_extended() || frame.is_error()) return false;
  const std::uint32_t id = frame.id;
  if ((id & 0x7F) != node) return false;
  const std::uint32_t function = id & 0x780;
  return function == 0x080 || (function >= 0x180 && function <= 0x500) || function == 0x580 ||
         function == 0x700;
}

}  // namespace

std::string_view to_string(AnomalyKind kind) {
  for (const auto& [k, name] : kNames) {
    if (k == kind) return name;
  }
  return "unknown";
}

std::optional<AnomalyKind> anomaly_kind_from_string(std::string_view text) {
  for (const auto& [k, name] : kNames) {
    if (name == text) return k;
  }
  return std::nullopt;
}

void LivenessOracle::begin_case(can::TimePoint) {
  boot_up_expected_ = false;
  observing_ = false;
  observed_ = false;
  node_frames_ = 0;
  heartbeats_ = 0;
  boot_ups_ = 0;
  emcy_ = 0;
  emcy_list_.clear();
  sdo_answered_ = true;
  guarding_answered_ = true;
}

void LivenessOracle::on_frame(const can::TimedFrame& timed) {
  if (timed.own) return;
  const can::Frame& frame = timed.frame;
  if (!from_node(frame, config_.node)) return;
  const std::uint32_t function = frame.id & 0x780;
  if (function == 0x700 && !frame.is_remote() && frame.length() == 1) {
    if (frame.data[0] == 0x00) {
      ++boot_ups_;
    } else if (observing_) {
      ++heartbeats_;
    }
  }
  if (function == 0x080 && !frame.is_remote()) {
    ++emcy_;
    if (emcy_list_.size() < kEmcyKept) emcy_list_.push_back(frame);
  }
  if (observing_) ++node_frames_;
}

void LivenessOracle::begin_observation(can::TimePoint now) {
  observing_ = true;
  observation_start_ = now;
  node_frames_ = 0;
  heartbeats_ = 0;
}

void LivenessOracle::end_observation(can::TimePoint now, bool sdo_answered,
                                     bool guarding_answered) {
  observing_ = false;
  observed_ = true;
  observation_end_ = now;
  sdo_answered_ = sdo_answered;
  guarding_answered_ = guarding_answered;
}

can::Duration LivenessOracle::window() const {
  using namespace std::chrono_literals;
  const can::Duration heartbeat = config_.heartbeat_period * 5 / 2;
  return std::min<can::Duration>(kMaxWindow, std::max<can::Duration>(100ms, heartbeat));
}

std::optional<Anomaly> LivenessOracle::verdict() const {
  if (!observed_) return std::nullopt;
  const double seconds =
      std::chrono::duration<double>(observation_end_ - observation_start_).count();
  const double rate = seconds > 0 ? static_cast<double>(node_frames_) / seconds : 0.0;
  if (rate > config_.babble_limit) {
    return Anomaly{AnomalyKind::babbling,
                   fmt::format("{} frames from node {} in {:.3f} s ({:.0f}/s, limit {:.0f}/s)",
                               node_frames_, config_.node, seconds, rate, config_.babble_limit)};
  }
  if (!sdo_answered_ && node_frames_ == 0) {
    return Anomaly{AnomalyKind::device_silent,
                   fmt::format("no SDO answer to reading 1000h and no frame from node {} in "
                               "{:.3f} s",
                               config_.node, seconds)};
  }
  if (!sdo_answered_) {
    return Anomaly{AnomalyKind::sdo_no_answer,
                   fmt::format("no SDO answer to reading 1000h; node {} sent {} other frame(s)",
                               config_.node, node_frames_)};
  }
  if (boot_up_expected_ && boot_ups_ == 0) {
    return Anomaly{AnomalyKind::no_boot_up,
                   fmt::format("no boot-up from node {} after an NMT reset", config_.node)};
  }
  if (!boot_up_expected_ && boot_ups_ > 0) {
    return Anomaly{AnomalyKind::unexpected_boot_up,
                   fmt::format("{} boot-up message(s) from node {} without an NMT reset: the "
                               "device reset itself",
                               boot_ups_, config_.node)};
  }
  const bool heartbeat_due =
      config_.heartbeat_period.count() > 0 &&
      observation_end_ - observation_start_ >= config_.heartbeat_period * 5 / 2;
  if (heartbeat_due && heartbeats_ == 0) {
    return Anomaly{
        AnomalyKind::heartbeat_lost,
        fmt::format("no heartbeat from node {} in {:.3f} s (producer time {} ms)", config_.node,
                    seconds,
                    std::chrono::duration_cast<std::chrono::milliseconds>(config_.heartbeat_period)
                        .count())};
  }
  if (config_.guarding && !guarding_answered_) {
    return Anomaly{AnomalyKind::guarding_lost,
                   fmt::format("node {} did not answer a node guarding request", config_.node)};
  }
  return std::nullopt;
}

}  // namespace drivecheck::fuzz_live
