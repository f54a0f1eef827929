// Node-guarding master (CiA 301 §7.2.8.3.2.1): polls nodes with remote frames, checks the toggle
// bit of every response and watches each node's life time.
//
// Request (master → node): remote frame on 700h + node, DLC 0 (see error_control.hpp).
// Response (node → master), 700h + node, DLC 1:
//   byte 0  bit 7 toggle t, bits 6..0 NMT state (04h stopped, 05h operational,
//           7Fh pre-operational)
//
// Rules (CiA 301; Festo 000_33c1d912b8b6010a.txt L1469-1505; Kollmorgen 002 L1029-1069):
//  - The master sends a request every guard time (100Ch of the node, ms).
//  - The toggle of the first response after guarding starts, and after reset communication, is
//    0; then it alternates with every response. A response with the same toggle as the
//    previous one is handled as if it had not been received (toggle_error).
//  - Node life time = guard time × life time factor (100Dh). If no valid response came for a
//    node life time, the master reports life_time_expired (once, until a valid response:
//    resumed). Either factor 0 switches guarding off.
//  - A request left unanswered when the next one is due is reported as no_response.
//  - A response while no request is outstanding is reported as unsolicited_response (e.g. the
//    node also produces heartbeats; Festo: "only the Heartbeat protocol is active" then).
//  - A boot-up (00h) restarts the node's toggle at 0.
//
// GuardingMaster is pure (on_time() says which requests to send); GuardingMasterPort sends them
// on a can::Bus with a bus timer.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/deadline_timer.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

enum class GuardingEventKind : std::uint8_t {
  state_changed,         // first valid response, or a response with another state
  toggle_error,          // response with the same toggle as the previous (or 1 as the first)
  no_response,           // a request was not answered before the next one was due
  life_time_expired,     // no valid response for guard time × life time factor
  resumed,               // first valid response after life_time_expired
  unsolicited_response,  // a response with no request outstanding
  boot_up,               // the node sent a boot-up message (toggle restarts at 0)
  invalid_frame,         // a frame on 700h + node that is no valid response
};
std::string_view to_string(GuardingEventKind kind);

struct GuardingEvent {
  GuardingEventKind kind = GuardingEventKind::state_changed;
  std::uint8_t node = 0;
  can::TimePoint time{};
  std::optional<NmtState> state;
  std::optional<NmtState> previous;
  std::optional<bool> toggle;  // the toggle of the response, when the event is about one
  std::string reason;          // invalid_frame only
};

struct GuardingConfig {
  can::Duration guard_time{0};        // 100Ch, > 0
  std::uint8_t life_time_factor = 0;  // 100Dh, > 0
  // true: the first response must carry toggle 0 (CiA 301). false: accept either toggle first
  // (for a master that joins a running network).
  bool first_toggle_zero = true;
};

class GuardingMaster {
 public:
  struct Output {
    std::vector<can::Frame> requests;
    std::vector<GuardingEvent> events;
  };

  // Starts guarding a node; the first request is due at `start`. Errors: node out of 1..127,
  // guard time or life time factor 0.
  Expected<void, std::string> guard(std::uint8_t node, const GuardingConfig& config,
                                    can::TimePoint start);
  void stop_guarding(std::uint8_t node);
  // After the master sent reset communication / reset node to the node: the next response must
  // start again with toggle 0.
  void reset_toggle(std::uint8_t node);

  // Sends the requests due at `now` and reports missed responses and expired life times.
  Output on_time(can::TimePoint now);
  std::optional<GuardingEvent> on_frame(const can::Frame& frame, can::TimePoint time);
  can::TimePoint next_deadline() const;

  // Precondition for the accessors: node 1..127.
  bool is_guarded(std::uint8_t node) const;
  bool is_lost(std::uint8_t node) const;  // life time expired and no valid response since
  std::optional<NmtState> state(std::uint8_t node) const;

 private:
  struct Node {
    GuardingConfig config;
    bool active = false;
    can::TimePoint next_request = can::kForever;
    can::TimePoint life_deadline = can::kForever;
    bool awaiting = false;
    std::optional<bool> expected_toggle;  // nullopt: either (first response, lenient)
    bool lost = false;
    std::optional<NmtState> state;
  };
  std::array<Node, 128> nodes_{};
};

class GuardingMasterPort {
 public:
  using EventHandler = std::function<void(const GuardingEvent&)>;

  GuardingMasterPort(can::Bus& bus, EventHandler on_event);
  GuardingMasterPort(const GuardingMasterPort&) = delete;
  GuardingMasterPort& operator=(const GuardingMasterPort&) = delete;

  // Starts guarding now (first request at once).
  Expected<void, std::string> guard(std::uint8_t node, const GuardingConfig& config);
  void stop_guarding(std::uint8_t node);
  void reset_toggle(std::uint8_t node) { master_.reset_toggle(node); }
  void handle(const can::TimedFrame& frame);

  const GuardingMaster& master() const { return master_; }
  // The last error the bus returned for a request (none when all were queued).
  std::error_code last_send_error() const { return last_send_error_; }

 private:
  void rearm();
  void on_timer();

  can::Bus& bus_;
  EventHandler on_event_;
  GuardingMaster master_;
  can::DeadlineTimer timer_{bus_, [this] { on_timer(); }};
  std::error_code last_send_error_;
};

}  // namespace drivecheck::cia301
