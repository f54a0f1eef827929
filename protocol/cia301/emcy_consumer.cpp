#include "protocol/cia301/emcy_consumer.hpp"

#include <algorithm>
#include <cassert>

#include "protocol/cia301/cob_id.hpp"

namespace drivecheck::cia301 {

EmcyConsumer::EmcyConsumer(std::size_t history_depth)
    : depth_(std::max<std::size_t>(history_depth, 1)) {
  for (std::size_t i = kMinNodeId; i <= kMaxNodeId; ++i) {
    nodes_[i].cob_id = kEmcyBase + static_cast<std::uint32_t>(i);
  }
}

void EmcyConsumer::set_cob_id(std::uint8_t node, std::optional<std::uint32_t> cob_id,
                              bool extended) {
  assert(is_valid_node_id(node));
  nodes_[node].cob_id = cob_id.value_or(kEmcyBase + node);
  nodes_[node].extended = cob_id.has_value() && extended;
  custom_ids_ = false;
  for (std::size_t i = kMinNodeId; i <= kMaxNodeId; ++i) {
    if (nodes_[i].cob_id != kEmcyBase + i || nodes_[i].extended) custom_ids_ = true;
  }
}

std::uint8_t EmcyConsumer::node_of(const can::Frame& frame) const {
  if (frame.is_error()) return 0;
  if (!custom_ids_) {
    const CobIdClass cls = classify_cob_id(frame);
    return cls.function == CobFunction::emcy ? cls.node : 0;
  }
  for (std::size_t i = kMinNodeId; i <= kMaxNodeId; ++i) {
    if (nodes_[i].cob_id == frame.id && nodes_[i].extended == frame.is_extended()) {
      return static_cast<std::uint8_t>(i);
    }
  }
  return 0;
}

std::optional<EmcyEvent> EmcyConsumer::on_frame(const can::Frame& frame, can::TimePoint time) {
  const std::uint8_t node = node_of(frame);
  if (node == 0) return std::nullopt;
  const auto emcy = decode_emcy(frame);
  if (!emcy) {
    EmcyEvent event{EmcyEventKind::invalid_frame, EmcyRecord{node, time, {}}, emcy.error().reason};
    return event;
  }
  Node& entry = nodes_[node];
  const EmcyRecord record{node, time, *emcy};
  if (!entry.history) entry.history.emplace();
  entry.history->push_back(record);
  while (entry.history->size() > depth_)
    entry.history->pop_front();
  ++entry.count;
  return EmcyEvent{
      emcy->is_error_reset() ? EmcyEventKind::error_reset : EmcyEventKind::error, record, {}};
}

const std::deque<EmcyRecord>& EmcyConsumer::history(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  static const std::deque<EmcyRecord> kNone;
  return nodes_[node].history ? *nodes_[node].history : kNone;
}

bool EmcyConsumer::error_active(std::uint8_t node) const {
  const auto& records = history(node);
  return !records.empty() && !records.back().emcy.is_error_reset();
}

std::uint8_t EmcyConsumer::error_register(std::uint8_t node) const {
  const auto& records = history(node);
  return records.empty() ? 0 : records.back().emcy.error_register;
}

std::uint64_t EmcyConsumer::count(std::uint8_t node) const {
  assert(is_valid_node_id(node));
  return nodes_[node].count;
}

void EmcyConsumer::clear(std::uint8_t node) {
  assert(is_valid_node_id(node));
  if (nodes_[node].history) nodes_[node].history->clear();
  nodes_[node].count = 0;
}

EmcyConsumerPort::EmcyConsumerPort(EventHandler on_event, std::size_t history_depth)
    : on_event_(std::move(on_event)), consumer_(history_depth) {}

void EmcyConsumerPort::handle(const can::TimedFrame& frame) {
  if (auto event = consumer_.on_frame(frame.frame, frame.timestamp); event && on_event_) {
    on_event_(*event);
  }
}

}  // namespace drivecheck::cia301
