// The two interfaces every drivecheck component talks through: a Clock that tells the time,
// and a Bus port that sends and receives CAN frames and runs timers.
//
// A Bus here is one node's port on a CAN bus (a SocketCAN socket, or one attachment to the
// simulated bus), not the wire itself. Two styles of use share one port:
//  - pull: a master sends, then `receive(deadline)` the answer;
//  - push: a device sets `set_frame_handler` and starts timers, and whoever owns the event
//    loop calls `run_until`.
// On the simulated bus, waiting (receive or run_until) advances simulated time to the next
// event and runs every other node's handlers and timers on the way, so one thread runs the
// whole network deterministically. On SocketCAN, waiting blocks in poll().
//
// Handlers and timer callbacks must not block: they may send, start and cancel timers, but
// must not call receive() or run_until().
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <system_error>

#include "protocol/can/frame.hpp"

namespace drivecheck::can {

// Time on a bus clock: nanoseconds since that clock's epoch. Simulated clocks start at 0;
// a SocketCAN clock is CLOCK_MONOTONIC. `Clock::unix_offset()` maps it to wall time for logs.
struct BusClockTag {};
using Duration = std::chrono::nanoseconds;
using TimePoint = std::chrono::time_point<BusClockTag, Duration>;

inline constexpr TimePoint kForever = TimePoint::max();

class Clock {
 public:
  virtual ~Clock() = default;
  virtual TimePoint now() const = 0;
  // Unix time (since 1970-01-01 UTC) at this clock's TimePoint zero, for candump/pcap logs.
  virtual Duration unix_offset() const = 0;
};

// A frame as a port saw it: received from the bus, or (with loopback) its own frame coming
// back after transmission.
struct TimedFrame {
  Frame frame;
  TimePoint timestamp;  // end of frame on the wire (simulated) or kernel receive time
  bool own = false;     // this port sent it (loopback echo)
};

// A receive filter with SocketCAN semantics: a frame passes when
// (frame_can_id & mask) == (id & mask), where can_id carries the EFF (bit 31), RTR (bit 30)
// and ERR (bit 29) flags. `invert` passes the frames that do not match.
struct Filter {
  static constexpr std::uint32_t kEffFlag = 0x80000000;
  static constexpr std::uint32_t kRtrFlag = 0x40000000;
  static constexpr std::uint32_t kErrFlag = 0x20000000;

  std::uint32_t id = 0;
  std::uint32_t mask = 0;
  bool invert = false;

  // Exactly this 11-bit data/remote identifier.
  static Filter standard(std::uint32_t id) { return {id, kEffFlag | 0x7FF, false}; }
  // Exactly this 29-bit identifier.
  static Filter extended(std::uint32_t id) { return {kEffFlag | id, kEffFlag | 0x1FFFFFFF, false}; }

  // Inline: every port checks every frame it reads against its filters.
  bool matches(const Frame& frame) const;
};

// The SocketCAN can_id word of a frame: identifier plus EFF/RTR/ERR flags.
inline std::uint32_t socketcan_id(const Frame& frame) {
  if (frame.is_error()) return Filter::kErrFlag | (frame.id & kErrorClassMask);
  std::uint32_t id = frame.id;
  if (frame.is_extended()) id |= Filter::kEffFlag;
  if (frame.is_remote()) id |= Filter::kRtrFlag;
  return id;
}

inline bool Filter::matches(const Frame& frame) const {
  const bool hit = (socketcan_id(frame) & mask) == (id & mask);
  return hit != invert;
}

// Errors a port reports (std::error_code over BusError, category "can-bus").
enum class BusError {
  bus_off = 1,        // the node is bus-off: it may not transmit
  queue_full,         // the transmit queue stayed full (ENOBUFS) past the send timeout
  interface_down,     // the network interface is down or gone
  no_such_interface,  // no interface of that name
  no_can_in_kernel,   // socket(PF_CAN) failed: the kernel has no CAN support
  invalid_frame,      // the frame cannot be sent (id or DLC out of range)
  io_error,           // any other system error (the message carries errno's text)
};
const std::error_category& bus_category();
std::error_code make_error_code(BusError error);

using TimerId = std::uint64_t;
inline constexpr TimerId kNoTimer = 0;

class Bus : public Clock {
 public:
  using FrameHandler = std::function<void(const TimedFrame&)>;
  using TimerCallback = std::function<void()>;

  // Queues a frame for transmission; returns at once. The frame goes on the wire when the
  // port wins arbitration. Errors: bus-off, queue full, interface down, invalid frame.
  virtual std::error_code send(const Frame& frame) = 0;

  // The next frame for this port that passes its filters, waiting at most until `deadline`
  // (kForever: no limit). Returns nullopt at the deadline. Frames are not queued for
  // receive() while a frame handler is set.
  virtual std::optional<TimedFrame> receive(TimePoint deadline) = 0;

  // Push delivery: every frame for this port goes to `handler` (empty: back to receive()).
  virtual void set_frame_handler(FrameHandler handler) = 0;

  // Replaces the receive filters (empty: every frame passes).
  virtual void set_filters(std::span<const Filter> filters) = 0;

  // How many frames with this identifier this port has queued that have not yet started on the
  // wire. 0 when the bus cannot tell (SocketCAN: the kernel's and controller's queues are not
  // visible; ENOBUFS on send() is all it says). A producer uses it to skip a periodic frame
  // whose predecessor is still waiting, as a CAN controller with one transmit buffer per
  // message object does, instead of building an unbounded backlog.
  virtual std::size_t queued(std::uint32_t id, IdFormat format) const {
    (void)id;
    (void)format;
    return 0;
  }

  // Whether this port also sees its own frames after they were sent (default: no).
  virtual void set_loopback(bool enabled) = 0;

  // Calls `callback` once, at `at` (or at once if `at` has passed). Ids are never reused.
  virtual TimerId start_timer(TimePoint at, TimerCallback callback) = 0;
  // Cancels a pending timer; unknown or fired timers are ignored.
  virtual void cancel_timer(TimerId id) = 0;

  // Runs handlers and timers until `deadline` or until stop() is called.
  virtual void run_until(TimePoint deadline) = 0;
  // Makes the current or next run_until()/receive() return early. Safe from a signal handler.
  virtual void stop() = 0;

  TimerId start_timer_after(Duration delay, TimerCallback callback) {
    return start_timer(now() + delay, std::move(callback));
  }
  void run_for(Duration duration) { run_until(now() + duration); }
};

}  // namespace drivecheck::can

template <>
struct std::is_error_code_enum<drivecheck::can::BusError> : std::true_type {};
