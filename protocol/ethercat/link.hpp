// The master's port on an EtherCAT segment, shaped like can::Bus (protocol/can/bus.hpp) and on
// the same clock types: send a frame, receive the next one with a deadline, or let a handler
// take frames while run_until() runs timers. Two implementations: SimSegment (sim_segment.hpp,
// the simulated segment on simulated time) and RawLink (raw_link.hpp, AF_PACKET on a NIC or a
// veth end).
//
// A Link carries whole Ethernet frames without FCS (frame.hpp builds and parses them): what
// the master sends comes back, processed by the slaves, as a received frame. A link never
// delivers the master's own transmission back to it.
//
// Handlers and timer callbacks must not block: they may send and start/cancel timers, but
// must not call receive() or run_until() (which then return at once).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <system_error>
#include <vector>

#include "protocol/can/bus.hpp"

namespace drivecheck::ethercat {

using can::Clock;
using can::Duration;
using can::kForever;
using can::TimePoint;
using can::TimerId;
inline constexpr TimerId kNoTimer = can::kNoTimer;

struct TimedFrame {
  std::vector<std::uint8_t> bytes;  // Ethernet frame without FCS
  TimePoint timestamp;              // end of frame at the master (simulated) or receive time
};

// Which way a frame went, seen from the master: a monitor's or a recorder's view.
enum class FrameDirection : std::uint8_t { sent, received };

// Errors a link reports (std::error_code over LinkError, category "ethercat-link").
enum class LinkError {
  link_down = 1,      // no carrier / the segment is down: the frame was not sent
  frame_too_short,    // fewer than 14 bytes (no Ethernet header)
  frame_too_long,     // more than 1514 bytes
  no_such_interface,  // no network interface of that name
  interface_down,     // the interface exists but is not up
  permission_denied,  // raw sockets need root or CAP_NET_RAW
  no_packet_sockets,  // socket(AF_PACKET) is not supported by this kernel
  io_error,           // any other system error
};
const std::error_category& link_category();
std::error_code make_error_code(LinkError error);

class Link : public Clock {
 public:
  using FrameHandler = std::function<void(const TimedFrame&)>;
  using TimerCallback = std::function<void()>;

  // Queues the frame; returns at once. Frames shorter than 60 bytes are padded with zeros.
  virtual std::error_code send(std::span<const std::uint8_t> frame) = 0;
  // The next received frame, waiting at most until `deadline` (kForever: no limit); nullopt at
  // the deadline. Frames are not queued for receive() while a handler is set.
  virtual std::optional<TimedFrame> receive(TimePoint deadline) = 0;
  // Push delivery (empty: back to receive()).
  virtual void set_frame_handler(FrameHandler handler) = 0;
  // Calls `callback` once at `at` (at once if past). Ids are never reused.
  virtual TimerId start_timer(TimePoint at, TimerCallback callback) = 0;
  virtual void cancel_timer(TimerId id) = 0;
  // Runs handlers and timers until `deadline` or stop().
  virtual void run_until(TimePoint deadline) = 0;
  // Makes the current or next run_until()/receive() return early. Safe from a signal handler.
  virtual void stop() = 0;

  TimerId start_timer_after(Duration delay, TimerCallback callback) {
    return start_timer(now() + delay, std::move(callback));
  }
  void run_for(Duration duration) { run_until(now() + duration); }
};

// Checks a frame's size for send(): too short, too long, or fine (empty).
std::error_code check_frame_size(std::size_t size);

}  // namespace drivecheck::ethercat

template <>
struct std::is_error_code_enum<drivecheck::ethercat::LinkError> : std::true_type {};
