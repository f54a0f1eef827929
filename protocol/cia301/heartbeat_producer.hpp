// Heartbeat producer (CiA 301 §7.2.8.3.2.2, object 1017h): a device announces its NMT state
// every producer heartbeat time.
//
// Heartbeat frame, CAN-ID 700h + node, DLC 1:
//   byte 0  bit 7 reserved (0), bits 6..0 NMT state: 04h stopped, 05h operational,
//           7Fh pre-operational
//
// 1017h producer heartbeat time, VAR UNSIGNED16, rw, ms; 0 = no heartbeat (default 0).
//
// Timing rules:
//  - After initialisation the boot-up message counts as the first heartbeat: the next heartbeat
//    is due one period after the boot-up (Festo 000_33c1d912b8b6010a.txt §3.8.3 L1465: "If the
//    controller starts with a producer_heartbeat_time not equal to zero, the bootup message is
//    considered to be the first Heartbeat").
//  - Heartbeat k is due at anchor + k × period exactly (no drift: the frame's own time on the
//    wire does not move the next one). A call more than a period late skips the missed
//    heartbeats rather than sending a burst.
//  - A new period written at run time takes effect at once and restarts the timer: the next
//    heartbeat is due one new period after the write; 0 stops the heartbeat.
//  - In Initialisation (NmtState::boot_up) no heartbeat is sent; the owner stops the producer
//    at a reset and starts it again with the boot-up message.
//  - A device whose 1017h is not 0 uses the heartbeat protocol and does not answer node-guarding
//    requests (CiA 301 §7.2.8.3.2: one device shall not use both error control protocols at the
//    same time; with a producer heartbeat time other than 0 the heartbeat protocol is used).
//    GuardingSlave (guarding_slave.hpp) applies that side.
//
// HeartbeatProducer is pure: it is told the time and the NMT state and returns the frame to
// send. DeviceServices (device_services.hpp) runs it on a bus.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kProducerHeartbeatTimeIndex = 0x1017;

class HeartbeatProducer {
 public:
  // Precondition: node_id 1..127.
  explicit HeartbeatProducer(std::uint8_t node_id = 1) : node_id_(node_id) {}

  void set_node_id(std::uint8_t node_id) { node_id_ = node_id; }
  std::uint8_t node_id() const { return node_id_; }

  // 1017h. While running, restarts the timer: next heartbeat at now + period (none for 0).
  void set_period(std::chrono::milliseconds period, can::TimePoint now);
  std::chrono::milliseconds period() const { return period_; }

  // The boot-up message went out at `boot_up`: heartbeats follow from there.
  void start(can::TimePoint boot_up);
  // Initialisation: no heartbeat until the next start().
  void stop();
  bool running() const { return running_; }

  // The heartbeat due at or before `now`, carrying `state`, if any (at most one per call).
  // Precondition: state is not boot_up (the owner stops the producer while initialising).
  std::optional<can::Frame> on_time(can::TimePoint now, NmtState state);
  // When on_time() must be called next; kForever when no heartbeat is scheduled.
  can::TimePoint next_deadline() const { return next_; }

  std::uint64_t sent() const { return sent_; }
  std::uint64_t missed() const { return missed_; }

 private:
  void schedule_from(can::TimePoint anchor);

  std::uint8_t node_id_;
  std::chrono::milliseconds period_{0};
  bool running_ = false;
  can::TimePoint next_ = can::kForever;
  std::uint64_t sent_ = 0;
  std::uint64_t missed_ = 0;
};

// Adds 1017h (VAR UNSIGNED16 rw, ms, default `default_ms`). Errors: the index is taken.
Expected<void, std::string> add_heartbeat_producer_objects(ObjectDictionary& od,
                                                           std::uint16_t default_ms = 0);

// The value of 1017h as a period; nullopt when the object does not exist.
std::optional<std::chrono::milliseconds> producer_heartbeat_time(const ObjectDictionary& od);

}  // namespace drivecheck::cia301
