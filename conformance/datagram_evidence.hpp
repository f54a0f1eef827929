// The evidence of a vector on EtherCAT: every frame the master exchanges, decoded by the
// EtherCAT dissector (protocol/ethercat/dissector.hpp) into VectorResult::datagrams.
//
// Fed by whatever sees the link's frames (a SimSegment monitor, a tap on a RawLink) with the
// frame and whether it is the master's frame going out or coming back. A returned frame is
// recorded as it came back (working counters, data read); an outgoing frame whose return never
// came (the next outgoing frame arrives first) is recorded as sent, "(no answer)".
//
// Size: consecutive frames with equal shapes (dissector.hpp: no mailbox content, differing at
// most in process data) become one entry per datagram with a count, so a vector that holds OP
// for a second shows "LRW ... x1000", not a thousand lines; every acyclic datagram (mailbox,
// AL control, SM configuration, ...) stays one entry. Repeated patterns of entries (the SII
// read of each bring-up, the mailbox polls of CoE transfers: alike but for the mailbox counter
// and the SII address and data, dissector.hpp patterns) are summarised (repeats.hpp) when the
// entries reach the bound and when the vector ends. A vector keeps its kHead first and
// kTail..kTail + kBatch last entries (datagrams_elided says how many were left out; --pcap has
// every frame); a summarised block is never cut apart.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "conformance/result.hpp"
#include "protocol/ethercat/dissector.hpp"
#include "protocol/ethercat/link.hpp"

namespace drivecheck::conformance {

class DatagramEvidence {
 public:
  // As the CAN frames of a vector (engine.cpp): 150 first, 450 last (up to 600 when a
  // batch is due).
  static constexpr std::size_t kHead = 150;
  static constexpr std::size_t kTail = 450;
  static constexpr std::size_t kBatch = 150;  // entries dropped at a time after the head

  // One frame of the link: `returned` false for the master's frame as sent.
  void on_frame(const ethercat::TimedFrame& frame, bool returned);
  // Where entries go from now on (nullptr: nowhere, the frames are still followed so that the
  // mailboxes are known). Returns the previous sink.
  VectorResult* set_sink(VectorResult* sink);

 private:
  void record(const ethercat::DissectedFrame& frame, can::TimePoint at, bool answered);
  void bound();
  void fold();  // repeated patterns (repeats.hpp) from fold_from_ on
  ethercat::FrameDissector dissector_;
  std::optional<ethercat::TimedFrame> pending_;  // sent, not back yet
  VectorResult* sink_ = nullptr;
  // The last frame recorded into sink_ when it may be summarised: its shapes and the index of
  // its first entry.
  std::vector<std::string> last_shapes_;
  std::size_t last_first_ = 0;
  // The pattern key of every entry of sink_ (the dissector's patterns), in step with them.
  std::vector<std::string> keys_;
  std::size_t fold_from_ = 0;
};

}  // namespace drivecheck::conformance
