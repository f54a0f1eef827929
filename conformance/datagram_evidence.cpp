// The evidence of a vector on EtherCAT (datagram_evidence.hpp).
#include "conformance/datagram_evidence.hpp"

#include <utility>

namespace drivecheck::conformance {

VectorResult* DatagramEvidence::set_sink(VectorResult* sink) {
  last_shapes_.clear();
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
  for (const std::string& line : frame.lines)
    entries.push_back(EvidenceDatagram{at, at, 1, answered ? line : line + " (no answer)"});
  if (summarise) {
    last_shapes_ = frame.shapes;
  } else {
    last_shapes_.clear();
  }
  bound();
}

void DatagramEvidence::bound() {
  auto& entries = sink_->datagrams;
  if (entries.size() < kHead + kTail + kBatch) return;
  // Drop the oldest kBatch entries after the head: the tail keeps kTail..kTail + kBatch.
  const auto from = entries.begin() + static_cast<std::ptrdiff_t>(kHead);
  entries.erase(from, from + static_cast<std::ptrdiff_t>(kBatch));
  sink_->datagrams_elided += kBatch;
  sink_->datagrams_elided_at = kHead;
  if (last_first_ >= kHead + kBatch) {
    last_first_ -= kBatch;
  } else if (last_first_ >= kHead) {
    last_shapes_.clear();
  }
}

}  // namespace drivecheck::conformance
