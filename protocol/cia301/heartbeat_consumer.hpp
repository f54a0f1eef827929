// Heartbeat consumer (CiA 301 §7.2.8.3.2.2, object 1016h): watches the heartbeats of other
// nodes and reports timeouts, state changes and boot-ups.
//
// Heartbeat frame (producer → consumers), CAN-ID 700h + node, DLC 1:
//   byte 0  bit 7 reserved (0), bits 6..0 NMT state: 04h stopped, 05h operational,
//           7Fh pre-operational; 00h = boot-up message
//
// 1016h consumer heartbeat time, sub 01h..7Fh, UNSIGNED32 each:
//   bits 31..24 reserved (0), bits 23..16 node-ID of the producer, bits 15..0 consumer time in
//   ms; time 0 or node 0 = entry not used (Kollmorgen §5.2.1.15, 002_953174ea6ca45cdb.txt
//   L1664-1716; "It must be greater than the producer time").
//
// Rules this consumer applies:
//  - Monitoring of a node starts with its first heartbeat or boot-up message (CiA 301; Kollmorgen
//    "Monitoring starts after the first heartbeat is received"). A boot-up counts as a heartbeat
//    for the timer (Festo 000_33c1d912b8b6010a.txt L1465: "the bootup message is considered to
//    be the first Heartbeat").
//  - A timeout is reported once, at exactly last reception + consumer time; the next valid
//    heartbeat reports `resumed` and re-arms the timer.
//  - Invalid frames (DLC ≠ 1, bit 7 set, unknown state) are reported and do not count as
//    heartbeats. Remote requests on 700h + node (node guarding) are ignored.
//
// HeartbeatConsumer is pure (frames and times in, events out; next_deadline() tells when to
// call on_time()). HeartbeatConsumerPort runs it on a can::Bus with a bus timer.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/deadline_timer.hpp"
#include "protocol/cia301/decode_error.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

// One 1016h sub-entry.
struct ConsumerHeartbeatEntry {
  std::uint8_t node = 0;      // 0: entry not used
  std::uint16_t time_ms = 0;  // 0: entry not used

  bool is_used() const { return node != 0 && time_ms != 0; }
  std::uint32_t encode() const { return (static_cast<std::uint32_t>(node) << 16) | time_ms; }
  friend bool operator==(const ConsumerHeartbeatEntry&, const ConsumerHeartbeatEntry&) = default;
};
// Invalid: reserved bits 31..24 set, node-ID above 127.
Expected<ConsumerHeartbeatEntry, DecodeError> decode_consumer_heartbeat_entry(std::uint32_t value);

enum class HeartbeatEventKind : std::uint8_t {
  boot_up,        // boot-up message received (monitoring (re)starts)
  state_changed,  // first heartbeat, or a heartbeat with another state than the last one
  timeout,        // no heartbeat for the consumer time
  resumed,        // first heartbeat after a timeout
  invalid_frame,  // a frame on the node's 700h + node that is no valid heartbeat
};
std::string_view to_string(HeartbeatEventKind kind);

struct HeartbeatEvent {
  HeartbeatEventKind kind = HeartbeatEventKind::state_changed;
  std::uint8_t node = 0;
  can::TimePoint time{};             // reception time, or the deadline for a timeout
  std::optional<NmtState> state;     // reported state (boot_up for a boot-up)
  std::optional<NmtState> previous;  // last reported state before this event
  std::string reason;                // invalid_frame only
};

class HeartbeatConsumer {
 public:
  // Monitors `node` with `consumer_time` (> 0); replaces any previous setting and waits for the
  // node's next heartbeat. Precondition: node 1..127.
  void monitor(std::uint8_t node, can::Duration consumer_time);
  // Applies a 1016h entry (unused entries are ignored).
  void monitor(const ConsumerHeartbeatEntry& entry);
  void stop_monitoring(std::uint8_t node);

  std::optional<HeartbeatEvent> on_frame(const can::Frame& frame, can::TimePoint time);
  // Reports the timeouts due at `now` (deadline <= now), in node order.
  std::vector<HeartbeatEvent> on_time(can::TimePoint now);
  // The earliest pending deadline, kForever when none.
  can::TimePoint next_deadline() const;

  // Precondition for the accessors: node 1..127.
  bool is_monitored(std::uint8_t node) const;
  bool is_timed_out(std::uint8_t node) const;
  std::optional<NmtState> state(std::uint8_t node) const;
  std::optional<can::TimePoint> last_heartbeat(std::uint8_t node) const;

 private:
  struct Node {
    can::Duration consumer_time{0};  // 0: not monitored
    std::optional<can::TimePoint> last;
    can::TimePoint deadline = can::kForever;
    bool timed_out = false;
    std::optional<NmtState> state;
  };
  // Whether node i is monitored is bit i % 64 of word i / 64: time and the next deadline visit
  // the monitored nodes only (a device monitors a few of 127), in node order.
  void set_monitored(std::uint8_t node, bool monitored);
  template <class F>
  void for_each_monitored(F&& f) const;

  std::array<Node, 128> nodes_{};
  std::array<std::uint64_t, 2> monitored_{};
};

// HeartbeatConsumer on a bus port: feed frames with handle() (from the port's frame handler);
// the port keeps one bus timer at the consumer's next deadline.
class HeartbeatConsumerPort {
 public:
  using EventHandler = std::function<void(const HeartbeatEvent&)>;

  HeartbeatConsumerPort(can::Bus& bus, EventHandler on_event);
  HeartbeatConsumerPort(const HeartbeatConsumerPort&) = delete;
  HeartbeatConsumerPort& operator=(const HeartbeatConsumerPort&) = delete;

  void monitor(std::uint8_t node, can::Duration consumer_time);
  void stop_monitoring(std::uint8_t node);
  void handle(const can::TimedFrame& frame);

  const HeartbeatConsumer& consumer() const { return consumer_; }

 private:
  void rearm();
  void on_timer();

  can::Bus& bus_;
  EventHandler on_event_;
  HeartbeatConsumer consumer_;
  can::DeadlineTimer timer_{bus_, [this] { on_timer(); }};
};

}  // namespace drivecheck::cia301
