// A Link on a real network interface: one AF_PACKET raw socket bound to the interface for
// EtherType 88A4h, for a NIC wired to EtherCAT slaves or one end of a veth pair.
//
//   auto link = RawLink::open("eth1");
//   if (!link) fmt::print(stderr, "{}\n", describe_open_error("eth1", link.error()));
//
// - The master's own frames never come back: the socket is bound to EtherType 88A4h (the
//   kernel copies outgoing frames only to ETH_P_ALL sockets), PACKET_IGNORE_OUTGOING (Linux
//   4.20+) is set as well, and frames the kernel marks PACKET_OUTGOING are skipped
//   (own_frames_skipped()). The veth test fails for a link bound to ETH_P_ALL without these.
// - Opening needs root or CAP_NET_RAW; without it open() says so (LinkError::
//   permission_denied) and describe_open_error() tells what to do.
// - The socket is bound with the protocol only at bind() time, so no frame of another
//   interface slips in between socket() and bind().
// - Frames shorter than 60 bytes are padded; send() waits (poll, at most 100 ms) while the
//   transmit queue is full, then returns LinkError::io_error.
// - Clock: CLOCK_MONOTONIC; receive timestamps are the clock when the frame was read.
// - Waiting (receive, run_until) is ppoll() on the socket and an eventfd that stop() writes
//   (async-signal-safe), with the deadline or the next timer as timeout.
// Not thread-safe, like every Link: only stop() may come from another thread or a signal.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "protocol/common/expected.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/link.hpp"

namespace drivecheck::ethercat {

struct RawLinkOptions {
  bool promiscuous = false;      // also receive frames not addressed to the broadcast/our MAC
  int receive_buffer_bytes = 0;  // SO_RCVBUF; 0 keeps the kernel default
};

struct RawLinkStats {
  std::uint64_t frames_sent = 0;
  std::uint64_t frames_received = 0;
  std::uint64_t own_frames_skipped = 0;  // PACKET_OUTGOING frames read and dropped
  std::uint64_t send_retries = 0;
};

class RawLink final : public Link {
 public:
  // Errors: LinkError::permission_denied (no root / CAP_NET_RAW), no_packet_sockets,
  // no_such_interface, interface_down; system_category() for anything else.
  static Expected<std::unique_ptr<RawLink>, std::error_code> open(std::string_view interface,
                                                                  RawLinkOptions options = {});
  ~RawLink() override;
  RawLink(const RawLink&) = delete;
  RawLink& operator=(const RawLink&) = delete;

  TimePoint now() const override;
  Duration unix_offset() const override { return unix_offset_; }
  std::error_code send(std::span<const std::uint8_t> frame) override;
  std::optional<TimedFrame> receive(TimePoint deadline) override;
  void set_frame_handler(FrameHandler handler) override;
  TimerId start_timer(TimePoint at, TimerCallback callback) override;
  void cancel_timer(TimerId id) override;
  void run_until(TimePoint deadline) override;
  void stop() override;

  const std::string& interface_name() const { return interface_; }
  const MacAddress& mac() const { return mac_; }
  const RawLinkStats& stats() const { return stats_; }
  // The last socket error seen while waiting (e.g. the interface went down), or empty.
  std::error_code last_error() const { return last_error_; }

 private:
  RawLink(int socket_fd, int stop_fd, std::string interface, MacAddress mac);
  bool fire_due_timers();
  TimePoint next_timer() const;
  // Reads every frame available now; with `wait_until`, first waits for one (or the time).
  void read_frames(TimePoint wait_until);
  bool consume_stop();

  int socket_fd_;
  int stop_fd_;
  std::string interface_;
  MacAddress mac_;
  Duration unix_offset_{};
  FrameHandler handler_;
  std::deque<TimedFrame> inbox_;
  std::multimap<TimePoint, TimerId> timer_order_;
  std::map<TimerId, std::pair<TimePoint, TimerCallback>> timers_;
  TimerId next_timer_id_ = 1;
  std::atomic<bool> stop_requested_{false};
  bool running_ = false;
  std::error_code last_error_;
  RawLinkStats stats_;
  std::vector<std::uint8_t> buffer_;
};

// One line naming the interface and what to do, e.g. "eth9: raw packet sockets need root or
// CAP_NET_RAW (run as root, or: sudo setcap cap_net_raw+ep <program>)".
std::string describe_open_error(std::string_view interface, std::error_code error);

}  // namespace drivecheck::ethercat
