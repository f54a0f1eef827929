// Node-guarding slave (CiA 301 §7.2.8.3.2.1, objects 100Ch and 100Dh): answers the master's
// guarding requests and watches that they keep coming (life guarding).
//
// Request (master → device): remote frame on 700h + node, DLC 0 (DLC 1 accepted too, as some
//   masters send it; a remote frame with a larger DLC is not a guarding request, see
//   error_control.hpp).
// Response (device → master), CAN-ID 700h + node, DLC 1:
//   byte 0  bit 7 toggle t, bits 6..0 NMT state: 04h stopped, 05h operational,
//           7Fh pre-operational
//   t is 0 in the first response after boot-up (power on, reset node, reset communication) and
//   alternates with every response (Festo 000_33c1d912b8b6010a.txt §3.9.2 L1499: "The
//   toggle bit is reset through the NMT command Reset Communication. It is therefore deleted in
//   the first response of the controller").
//
// 100Ch guard time, VAR UNSIGNED16 rw, ms, default 0.
// 100Dh life time factor, VAR UNSIGNED8 rw, default 0.
// Life time = guard time × life time factor; 0 (either factor 0) = no life guarding.
//
// Rules:
//  - Requests are answered in Pre-operational, Operational and Stopped (error control runs in
//    all three, CiA 301 §7.3.2.2), never while initialising.
//  - Life guarding starts with the first request (Festo L1497: "Monitoring begins with the
//    first received remote request of the master"). When no request arrives within the life
//    time after the last one, the slave reports LifeGuardingEventKind::expired once (the owner
//    raises EMCY 8130h and applies 1029h); the next request reports `resolved` and monitoring
//    goes on.
//  - New 100Ch/100Dh values take effect at once: the deadline becomes last request + new life
//    time (0: monitoring off).
//  - A device whose producer heartbeat time 1017h is not 0 uses the heartbeat protocol: it does
//    not answer guarding requests and does no life guarding (CiA 301 §7.2.8.3.2: a device shall
//    not use both error control protocols at the same time, the heartbeat protocol is used when
//    1017h ≠ 0; Festo §3.8.1/§3.9.1 L1433, L1473: "If both protocols are activated
//    simultaneously, only the Heartbeat protocol is active").
//
// GuardingSlave is pure: fed frames, times and the NMT state; DeviceServices runs it on a bus.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kGuardTimeIndex = 0x100C;
inline constexpr std::uint16_t kLifeTimeFactorIndex = 0x100D;

enum class LifeGuardingEventKind : std::uint8_t {
  expired,   // no guarding request within the life time (CiA 301 "life guarding event")
  resolved,  // a request arrived again after `expired`
};
std::string_view to_string(LifeGuardingEventKind kind);

struct LifeGuardingEvent {
  LifeGuardingEventKind kind = LifeGuardingEventKind::expired;
  can::TimePoint time{};  // the life time deadline, or the request's reception time
  friend bool operator==(const LifeGuardingEvent&, const LifeGuardingEvent&) = default;
};

struct GuardingSlaveResult {
  std::optional<can::Frame> response;  // the answer to send, if any
  std::optional<LifeGuardingEvent> event;
  bool request = false;  // the frame was a guarding request for this node
};

class GuardingSlave {
 public:
  // Precondition: node_id 1..127.
  explicit GuardingSlave(std::uint8_t node_id = 1) : node_id_(node_id) {}

  void set_node_id(std::uint8_t node_id) { node_id_ = node_id; }
  std::uint8_t node_id() const { return node_id_; }

  // 100Ch and 100Dh; take effect at once (see the file comment).
  void configure(std::chrono::milliseconds guard_time, std::uint8_t life_time_factor);
  can::Duration life_time() const { return life_time_; }

  // 1017h ≠ 0: requests are not answered and life guarding stops.
  void set_heartbeat_in_use(bool in_use);
  bool heartbeat_in_use() const { return heartbeat_in_use_; }

  // Boot-up (power on, reset node, reset communication): toggle back to 0, life guarding waits
  // for the first request again.
  void reset();

  // A frame from the bus; anything but a guarding request for this node is ignored.
  GuardingSlaveResult on_frame(const can::Frame& frame, can::TimePoint now, NmtState state);
  // The life guarding event due at `now`, if any.
  std::optional<LifeGuardingEvent> on_time(can::TimePoint now);
  // When on_time() must be called next; kForever when life guarding is not armed.
  can::TimePoint next_deadline() const;

  bool next_toggle() const { return toggle_; }
  bool monitoring() const {
    return last_request_.has_value() && life_time_ > can::Duration::zero();
  }
  bool expired() const { return expired_; }
  std::uint64_t responses() const { return responses_; }

 private:
  std::uint8_t node_id_;
  can::Duration life_time_{0};
  bool heartbeat_in_use_ = false;
  bool toggle_ = false;
  bool expired_ = false;
  std::optional<can::TimePoint> last_request_;
  std::uint64_t responses_ = 0;
};

// Adds 100Ch (UNSIGNED16 rw, ms) and 100Dh (UNSIGNED8 rw), defaults 0. Errors: an index is
// taken.
Expected<void, std::string> add_guarding_slave_objects(ObjectDictionary& od);

// 100Ch and 100Dh, or nullopt when either object does not exist.
struct GuardingParameters {
  std::chrono::milliseconds guard_time{0};
  std::uint8_t life_time_factor = 0;
};
std::optional<GuardingParameters> guarding_parameters(const ObjectDictionary& od);

}  // namespace drivecheck::cia301
