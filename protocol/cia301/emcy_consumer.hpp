// EMCY consumer (CiA 301 §7.2.7): decodes the emergency messages of the nodes and keeps a
// history per node.
//
// EMCY frame, CAN-ID 080h + node (or the COB-ID configured in the node's 1014h), DLC 8:
//   bytes 0..1 error code (LE), byte 2 error register 1001h, bytes 3..7 manufacturer field
//   (see emcy.hpp). Error code 0000h = error reset / no error: all errors of the node are gone
//   (Festo Tab. 3.8, 000_33c1d912b8b6010a.txt L1259-1274: "EMCY with error code 0000" when the
//   acknowledgement removed every cause).
//
// EmcyConsumer is pure (frames and times in, events out); EmcyConsumerPort is the adapter that
// forwards a port's frames and calls back.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/emcy.hpp"

namespace drivecheck::cia301 {

enum class EmcyEventKind : std::uint8_t {
  error,          // an EMCY with a non-zero error code
  error_reset,    // an EMCY with error code 0000h
  invalid_frame,  // a frame on the node's EMCY COB-ID that is no valid EMCY
};

struct EmcyRecord {
  std::uint8_t node = 0;
  can::TimePoint time{};
  Emcy emcy;
};

struct EmcyEvent {
  EmcyEventKind kind = EmcyEventKind::error;
  EmcyRecord record;   // valid for error and error_reset
  std::string reason;  // invalid_frame only
};

class EmcyConsumer {
 public:
  // Keeps the last `history_depth` EMCYs per node (at least 1).
  explicit EmcyConsumer(std::size_t history_depth = 16);

  // Moves a node's EMCY to another CAN-ID (its 1014h); nullopt restores 80h + node. Frames on a
  // 29-bit COB-ID are matched when `extended` is set. Precondition: node 1..127.
  void set_cob_id(std::uint8_t node, std::optional<std::uint32_t> cob_id, bool extended = false);

  std::optional<EmcyEvent> on_frame(const can::Frame& frame, can::TimePoint time);

  // Precondition for the accessors: node 1..127.
  // The node's last EMCYs, oldest first. Read it again after on_frame(): before a node's first
  // EMCY this is a shared empty deque.
  const std::deque<EmcyRecord>& history(std::uint8_t node) const;
  // Whether the node's last EMCY announced an error (code ≠ 0000h).
  bool error_active(std::uint8_t node) const;
  // The error register of the node's last EMCY (0 when none came).
  std::uint8_t error_register(std::uint8_t node) const;
  // Total EMCYs received from the node, including those pushed out of the history.
  std::uint64_t count(std::uint8_t node) const;
  void clear(std::uint8_t node);

 private:
  struct Node {
    std::uint32_t cob_id = 0;
    bool extended = false;
    // Created by the node's first EMCY: a consumer is built without 127 deque allocations.
    std::optional<std::deque<EmcyRecord>> history;
    std::uint64_t count = 0;
  };
  // The node whose EMCY COB-ID the frame is on, 0 for none.
  std::uint8_t node_of(const can::Frame& frame) const;

  std::size_t depth_;
  std::array<Node, 128> nodes_{};
  bool custom_ids_ = false;
};

class EmcyConsumerPort {
 public:
  using EventHandler = std::function<void(const EmcyEvent&)>;

  explicit EmcyConsumerPort(EventHandler on_event, std::size_t history_depth = 16);
  void handle(const can::TimedFrame& frame);

  EmcyConsumer& consumer() { return consumer_; }
  const EmcyConsumer& consumer() const { return consumer_; }

 private:
  EventHandler on_event_;
  EmcyConsumer consumer_;
};

}  // namespace drivecheck::cia301
