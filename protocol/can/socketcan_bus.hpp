// A Bus port on Linux SocketCAN: one raw CAN socket (PF_CAN, SOCK_RAW, CAN_RAW) bound to a
// named interface (`can0`, `vcan0`). Classic CAN only (CAN FD frames are not enabled).
//
//   auto bus = SocketCanBus::open("can0");
//   if (!bus) fmt::print(stderr, "{}\n", describe_open_error("can0", bus.error()));
//
// What the port does with the socket:
//  - receive filters go to the kernel (CAN_RAW_FILTER, inverted ones with CAN_INV_FILTER) and
//    are applied once more in user space, so a frame already queued under the old filters
//    never slips through after set_filters();
//  - error frames are always enabled (CAN_RAW_ERR_FILTER, every class): the port tracks
//    bus-off from them, and delivers them (FrameKind::error, see error_frame.hpp) to the user
//    when SocketCanOptions::error_frames is set and they pass the filters;
//  - set_loopback() is CAN_RAW_RECV_OWN_MSGS; own frames come back with TimedFrame::own set
//    (MSG_CONFIRM). Other sockets on the same host always see this port's frames
//    (CAN_RAW_LOOPBACK stays on), which is how two programs talk over vcan;
//  - timestamps are the kernel's software receive time (SO_TIMESTAMPING, else SO_TIMESTAMP),
//    which is CLOCK_REALTIME; the port converts it to its own clock, CLOCK_MONOTONIC, with
//    unix_offset() (realtime - monotonic, measured at open; the conversion re-measures it at
//    most every 100 ms and follows a wall-clock step of more than 1 ms);
//  - send() never blocks for long: on ENOBUFS/EAGAIN (the interface's transmit queue is full;
//    txqueuelen is 10 by default) it waits in poll() with exponential back-off (50 us doubling
//    to 5 ms) up to SocketCanOptions::send_timeout, then returns BusError::queue_full (or
//    bus_off when the controller reported bus-off);
//  - waiting (receive, run_until): when nothing is due for a while (the deadline and the next
//    timer are at least 40 ms away) the port waits in a blocking recvmsg() whose SO_RCVTIMEO
//    is one slice (20 ms), so a round trip costs one system call on the receive side, as a
//    plain blocking read() does, and a frame read there goes straight to the caller or the
//    frame handler when nothing is queued before it; otherwise it waits in epoll_wait() on the
//    socket, an eventfd and a timerfd (the deadline), registered in an epoll set (the socket only
//    while the port waits there, so that frames do not run epoll's callback in vain). stop() writes
//    to the eventfd, which is async-signal-safe. A signal interrupts a blocking recvmsg() at once
//    (EINTR: calls with SO_RCVTIMEO are never restarted); a stop() from another thread, or
//    from a handler that ran just before the call, ends the wait within one slice.
//
// Errors from open() and send(): BusError codes for the conditions bus.hpp names. Any other
// system error is returned as std::system_category() code (errno), so its message is errno's
// text.
//
// Not thread-safe, like every Bus: one thread owns the port; only stop() may be called from
// another thread or a signal handler.
#pragma once

#include <time.h>

#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <queue>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::can {

// Where receive timestamps come from.
enum class TimestampSource : std::uint8_t {
  automatic,        // SO_TIMESTAMPING (software receive), else SO_TIMESTAMP, else none
  so_timestamping,  // SO_TIMESTAMPING with SOF_TIMESTAMPING_RX_SOFTWARE (nanoseconds)
  so_timestamp,     // SO_TIMESTAMP (microseconds)
  none,             // the port's clock when the frame is read from the socket
};
std::string_view to_string(TimestampSource source);

struct SocketCanOptions {
  // How long send() retries while the transmit queue is full (ENOBUFS).
  Duration send_timeout = std::chrono::milliseconds(100);
  // Initial receive filters (empty: every frame passes).
  std::vector<Filter> filters;
  // Receive own frames back after transmission (TimedFrame::own), as set_loopback(true).
  bool loopback = false;
  // Deliver error frames to receive()/the handler (they are tracked for bus-off regardless).
  bool error_frames = true;
  TimestampSource timestamps = TimestampSource::automatic;
  // SO_RCVBUF in bytes; 0 keeps the kernel default.
  int receive_buffer_bytes = 0;
};

struct SocketCanStats {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_received = 0;     // read from the socket, before user-space filtering
  std::uint64_t frames_filtered = 0;     // read but dropped by the user-space filter check
  std::uint64_t error_frames = 0;        // error frames read (delivered or not)
  std::uint64_t send_retries = 0;        // send attempts repeated after ENOBUFS/EAGAIN
  std::uint64_t kernel_drops = 0;        // frames the kernel dropped: receive buffer full
  std::uint64_t missing_timestamps = 0;  // frames without a kernel timestamp (clock used)
};

class SocketCanBus final : public Bus {
 public:
  // Opens a raw CAN socket on `interface`. Errors:
  //   BusError::no_can_in_kernel   socket(PF_CAN) failed (EAFNOSUPPORT/EPROTONOSUPPORT)
  //   BusError::no_such_interface  no interface of that name, or it is not a CAN interface
  //   BusError::interface_down     the interface exists but is not up
  //   system_category()            anything else (errno)
  static Expected<std::unique_ptr<SocketCanBus>, std::error_code> open(
      std::string_view interface, SocketCanOptions options = {});

  ~SocketCanBus() override;
  SocketCanBus(const SocketCanBus&) = delete;
  SocketCanBus& operator=(const SocketCanBus&) = delete;

  // Clock: CLOCK_MONOTONIC.
  TimePoint now() const override;
  Duration unix_offset() const override { return unix_offset_; }

  std::error_code send(const Frame& frame) override;
  std::optional<TimedFrame> receive(TimePoint deadline) override;
  void set_frame_handler(FrameHandler handler) override;
  void set_filters(std::span<const Filter> filters) override;
  void set_loopback(bool enabled) override;
  TimerId start_timer(TimePoint at, TimerCallback callback) override;
  void cancel_timer(TimerId id) override;
  void run_until(TimePoint deadline) override;
  void stop() override;

  const std::string& interface_name() const { return interface_; }
  TimestampSource timestamp_source() const { return timestamp_source_; }
  const SocketCanStats& stats() const { return stats_; }
  // Whether the controller reported bus-off (error frame) and no restart since.
  bool bus_off() const { return bus_off_; }
  // The last asynchronous socket error seen while waiting (e.g. interface_down when the
  // interface went down or away), or empty. receive() and run_until() cannot return errors;
  // a master that waits in vain can ask here why.
  std::error_code last_error() const { return last_error_; }

 private:
  SocketCanBus(int socket_fd, int stop_fd, int timer_fd, int epoll_fd, std::string interface,
               SocketCanOptions options, TimestampSource source);

  struct PendingTimer {
    TimePoint at;
    TimerId id;
    bool operator>(const PendingTimer& other) const {
      return at != other.at ? at > other.at : id > other.id;
    }
  };

  bool consume_stop();
  // Makes the timerfd wake the poll at `until` at the latest; false if it cannot.
  bool arm_wakeup(TimePoint until, TimePoint now_time);
  // Waits in epoll until a frame is readable, `until`, or stop(); reads one frame.
  void wait_and_read(TimePoint until, TimePoint now_time);
  // The fallback when the timerfd cannot be armed: ppoll with a timeout (nullptr: none).
  void wait_with_ppoll(const timespec* timeout);
  // Adds the socket to the epoll set or removes it; false (unchanged) when epoll refuses.
  bool watch_socket_in_epoll(bool watch);
  // What a wait found: reads a frame, records a socket error, clears the stop / timer fds.
  void handle_wake(bool readable, bool error, bool stopped, bool timer);
  // Reads every frame available now (non-blocking) into inbox_.
  void read_available();
  // Reads one frame if there is one (non-blocking) into inbox_; false when there was none.
  bool read_one();
  // Whether a wait until `until` may be one blocking recvmsg() (see wait_and_read); takes
  // the socket out of the epoll set for it.
  bool may_block(TimePoint until, TimePoint now_time);
  // Reads one frame from the socket (`flags` 0: waits up to SO_RCVTIMEO; MSG_DONTWAIT: does
  // not wait). False when there was none. When one was read, `out` holds it if it passes the
  // filters (accept()).
  bool read_socket(int flags, std::optional<TimedFrame>& out);
  // Counts the frame, tracks bus-off from error frames; whether it passes the filters.
  bool accept(const TimedFrame& frame);
  bool passes_filters(const Frame& frame) const;
  // Fires the timers due now that were started before this call; returns whether any fired.
  bool fire_due_timers();
  TimePoint next_timer_at();
  void deliver_inbox_to_handler();
  TimePoint to_bus_time(std::int64_t realtime_ns);

  int socket_fd_;
  int stop_fd_;
  int timer_fd_;  // CLOCK_MONOTONIC timerfd: the wait's deadline
  int epoll_fd_;  // stop_fd_ and timer_fd_, and the socket while the port waits in epoll
  bool wakeup_armed_ = false;
  bool blocking_receive_ = false;  // SO_RCVTIMEO is set: blocking recvmsg() may be used
  bool socket_in_epoll_ = false;   // the socket is in epoll_fd_'s set (only while needed)
  TimePoint armed_at_{};
  std::string interface_;
  SocketCanOptions options_;
  TimestampSource timestamp_source_;
  Duration unix_offset_{};
  Duration conversion_offset_{};  // realtime - monotonic used to convert timestamps
  TimePoint last_clock_check_{};

  std::vector<Filter> filters_;
  FrameHandler handler_;
  std::deque<TimedFrame> inbox_;

  std::priority_queue<PendingTimer, std::vector<PendingTimer>, std::greater<>> timer_heap_;
  std::unordered_map<TimerId, TimerCallback> timers_;
  TimerId next_timer_id_ = 1;

  std::atomic<bool> stop_requested_{false};
  bool bus_off_ = false;
  std::error_code last_error_;
  std::uint32_t last_drop_count_ = 0;
  SocketCanStats stats_;
};

// A one-line explanation of an open() error that names the interface and says what to do,
// e.g. "vcan9: no CAN interface of that name (create a virtual one: ip link add dev vcan9
// type vcan && ip link set vcan9 up)".
std::string describe_open_error(std::string_view interface, std::error_code error);

// ---- Conversions between drivecheck's types and the kernel's (pure; tested on any host) ----

// struct can_filter: a frame passes when (frame can_id & can_mask) == (can_id & can_mask);
// CAN_INV_FILTER (bit 29 of can_id) inverts the filter.
struct KernelFilter {
  std::uint32_t can_id = 0;
  std::uint32_t can_mask = 0;
  friend bool operator==(const KernelFilter&, const KernelFilter&) = default;
};
inline constexpr std::uint32_t kKernelInvertFilter = 0x20000000;  // CAN_INV_FILTER

// The kernel filters for `filters`: empty gives one pass-all filter {0, 0} (the kernel takes
// zero filters as "receive nothing"). The ERR bit is taken out of ids and masks: the kernel
// routes error frames by the error mask, never by these filters (its CAN_INV_FILTER shares
// bit 29 with CAN_ERR_FLAG); the port filters error frames in user space.
std::vector<KernelFilter> to_kernel_filters(std::span<const Filter> filters);

// struct can_frame as plain fields: can_id with EFF/RTR/ERR flags, len (for remote frames the
// requested DLC, as can-utils does), len8_dlc (9..15 for a data frame whose DLC exceeds 8).
struct KernelFrame {
  std::uint32_t can_id = 0;
  std::uint8_t len = 0;
  std::uint8_t len8_dlc = 0;
  std::array<std::uint8_t, 8> data{};
};

// invalid_frame for ids or DLCs out of range and for error frames (a port never sends one).
Expected<KernelFrame, std::error_code> to_kernel_frame(const Frame& frame);
// nullopt for a frame a classic CAN socket cannot deliver (len above 8).
std::optional<Frame> from_kernel_frame(const KernelFrame& raw);

}  // namespace drivecheck::can
