// The evidence of a vector on EtherCAT (datagram_evidence.hpp).
#include "conformance/datagram_evidence.hpp"

#include <utility>

#include "conformance/repeats.hpp"

namespace drivecheck::conformance {

VectorResult* DatagramEvidence::set_sink(VectorResult* sink) {
  if (sink_ != nullptr) fold();
  last_shapes_.clear();
  keys_.clear();
  fold_from_ = 0;
  return std::exchange(sink_, sink);
}

void DatagramEvidence::on_frame(const ethercat::TimedFrame& frame, bool returned) {
  if (!returned) {
    if (pending_) {
      record(dissector_.dissect(pending_->bytes, ethercat::FramePass::outgoing),
             pending_->timestamp, false);
    }
    pending_ = frame;
    return;
  }
  pending_.reset();
  record(dissector_.dissect(frame.bytes, ethercat::FramePass::returned), frame.timestamp, true);
}

void DatagramEvidence::record(const ethercat::DissectedFrame& frame, can::TimePoint at,
                              bool answered) {
  if (sink_ == nullptr) return;
  auto& entries = sink_->datagrams;
  const bool summarise = answered && !frame.shapes.empty();
  if (summarise && frame.shapes == last_shapes_ &&
      last_first_ + frame.shapes.size() == entries.size()) {
    for (std::size_t i = 0; i < frame.shapes.size(); ++i) {
      EvidenceDatagram& entry = entries[last_first_ + i];
      if (entry.count == 1) entry.decoded = frame.shapes[i];  // a run: no one frame's data
      ++entry.count;
      entry.last = at;
    }
    return;
  }
  last_first_ = entries.size();
  for (std::size_t i = 0; i < frame.lines.size(); ++i) {
    const std::string& line = frame.lines[i];
    entries.push_back(EvidenceDatagram{at, at, 1, answered ? line : line + " (no answer)", {}});
    // A datagram that went unanswered is never part of a pattern.
    keys_.push_back(answered && i < frame.patterns.size() ? frame.patterns[i] : std::string());
  }
  if (summarise) {
    last_shapes_ = frame.shapes;
  } else {
    last_shapes_.clear();
  }
  bound();
}

void DatagramEvidence::fold() {
  auto& entries = sink_->datagrams;
  const std::size_t before = entries.size();
  fold_from_ =
      fold_repeats(entries, keys_, fold_from_, [](const EvidenceDatagram& d) { return d.last; });
  if (entries.size() != before) last_shapes_.clear();  // the last frame's entries moved
}

void DatagramEvidence::bound() {
  auto& entries = sink_->datagrams;
  if (entries.size() < kHead + kTail + kBatch) return;
  fold();
  if (entries.size() < kHead + kTail + kBatch) return;
  // Drop the oldest kBatch entries after the head: the tail keeps kTail..kTail + kBatch. Where
  // entries were dropped before, the cut goes on from there.
  const std::size_t at = sink_->datagrams_elided != 0 ? sink_->datagrams_elided_at : kHead;
  const auto [from, to] = safe_cut(entries, at, at + kBatch);
  if (from == to) return;
  if (sink_->datagrams_elided != 0 && from != at) return;  // one place where entries are missing
  entries.erase(entries.begin() + static_cast<std::ptrdiff_t>(from),
                entries.begin() + static_cast<std::ptrdiff_t>(to));
  sink_->datagrams_elided += to - from;
  sink_->datagrams_elided_at = from;
  keys_.erase(keys_.begin() + static_cast<std::ptrdiff_t>(from),
              keys_.begin() + static_cast<std::ptrdiff_t>(to));
  last_shapes_.clear();
  // Nothing folds across the cut: the entries on either side were not consecutive.
  fold_from_ = fold_from_ > to ? fold_from_ - (to - from) : from;
}

}  // namespace drivecheck::conformance
