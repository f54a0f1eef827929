#include "protocol/ethercat/raw_link.hpp"

#include <arpa/inet.h>
#include <fmt/format.h>
#include <linux/if_packet.h>
#include <net/if.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace drivecheck::ethercat {
namespace {

#ifndef PACKET_IGNORE_OUTGOING
#define PACKET_IGNORE_OUTGOING 23
#endif

std::int64_t clock_ns(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::error_code system_error(int error) {
  return {error, std::system_category()};
}

struct FdCloser {
  int fd;
  ~FdCloser() {
    if (fd >= 0) ::close(fd);
  }
  int release() {
    const int f = fd;
    fd = -1;
    return f;
  }
};

}  // namespace

Expected<std::unique_ptr<RawLink>, std::error_code> RawLink::open(std::string_view interface,
                                                                  RawLinkOptions options) {
  if (interface.empty() || interface.size() >= IFNAMSIZ) {
    return Unexpected(make_error_code(LinkError::no_such_interface));
  }
  const std::string name(interface);
  // Protocol 0 here and 88A4h at bind(): nothing is queued before the socket is bound.
  FdCloser socket_fd{::socket(AF_PACKET, SOCK_RAW | SOCK_CLOEXEC | SOCK_NONBLOCK, 0)};
  if (socket_fd.fd < 0) {
    const int error = errno;
    if (error == EPERM || error == EACCES) {
      return Unexpected(make_error_code(LinkError::permission_denied));
    }
    if (error == EAFNOSUPPORT || error == EPROTONOSUPPORT) {
      return Unexpected(make_error_code(LinkError::no_packet_sockets));
    }
    return Unexpected(system_error(error));
  }
  const unsigned index = if_nametoindex(name.c_str());
  if (index == 0) return Unexpected(make_error_code(LinkError::no_such_interface));
  ifreq request{};
  std::memcpy(request.ifr_name, name.c_str(), name.size() + 1);
  if (::ioctl(socket_fd.fd, SIOCGIFFLAGS, &request) < 0) return Unexpected(system_error(errno));
  if ((request.ifr_flags & IFF_UP) == 0) {
    return Unexpected(make_error_code(LinkError::interface_down));
  }
  MacAddress mac{};
  if (::ioctl(socket_fd.fd, SIOCGIFHWADDR, &request) == 0) {
    std::memcpy(mac.data(), request.ifr_hwaddr.sa_data, mac.size());
  }
  const int one = 1;
  // Best effort: older kernels lack it; receive() also skips PACKET_OUTGOING frames.
  (void)::setsockopt(socket_fd.fd, SOL_PACKET, PACKET_IGNORE_OUTGOING, &one, sizeof one);
  if (options.receive_buffer_bytes > 0) {
    (void)::setsockopt(socket_fd.fd, SOL_SOCKET, SO_RCVBUF, &options.receive_buffer_bytes,
                       sizeof options.receive_buffer_bytes);
  }
  sockaddr_ll address{};
  address.sll_family = AF_PACKET;
  address.sll_protocol = htons(kEtherType);
  address.sll_ifindex = static_cast<int>(index);
  if (::bind(socket_fd.fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) < 0) {
    const int error = errno;
    if (error == ENETDOWN) return Unexpected(make_error_code(LinkError::interface_down));
    if (error == ENODEV) return Unexpected(make_error_code(LinkError::no_such_interface));
    return Unexpected(system_error(error));
  }
  if (options.promiscuous) {
    packet_mreq membership{};
    membership.mr_ifindex = static_cast<int>(index);
    membership.mr_type = PACKET_MR_PROMISC;
    if (::setsockopt(socket_fd.fd, SOL_PACKET, PACKET_ADD_MEMBERSHIP, &membership,
                     sizeof membership) < 0) {
      return Unexpected(system_error(errno));
    }
  }
  FdCloser stop_fd{::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK)};
  if (stop_fd.fd < 0) return Unexpected(system_error(errno));
  return std::unique_ptr<RawLink>(new RawLink(socket_fd.release(), stop_fd.release(), name, mac));
}

RawLink::RawLink(int socket_fd, int stop_fd, std::string interface, MacAddress mac)
    : socket_fd_(socket_fd),
      stop_fd_(stop_fd),
      interface_(std::move(interface)),
      mac_(mac),
      unix_offset_(std::chrono::nanoseconds(clock_ns(CLOCK_REALTIME) - clock_ns(CLOCK_MONOTONIC))),
      buffer_(9216) {}

RawLink::~RawLink() {
  ::close(socket_fd_);
  ::close(stop_fd_);
}

TimePoint RawLink::now() const {
  return TimePoint(std::chrono::nanoseconds(clock_ns(CLOCK_MONOTONIC)));
}

std::error_code RawLink::send(std::span<const std::uint8_t> frame) {
  if (const std::error_code error = check_frame_size(frame.size())) return error;
  std::uint8_t padded[kMaxFrameSize] = {};
  std::copy(frame.begin(), frame.end(), padded);
  const std::size_t size = std::max(frame.size(), kMinFrameSize);
  const TimePoint give_up = now() + std::chrono::milliseconds(100);
  for (;;) {
    const ssize_t sent = ::send(socket_fd_, padded, size, MSG_DONTWAIT);
    if (sent == static_cast<ssize_t>(size)) {
      ++stats_.frames_sent;
      return {};
    }
    const int error = sent < 0 ? errno : EIO;
    if (error == EINTR) continue;
    if (error == ENETDOWN || error == ENXIO) return LinkError::link_down;
    if (error != EAGAIN && error != ENOBUFS) return system_error(error);
    if (now() >= give_up) return LinkError::io_error;
    ++stats_.send_retries;
    pollfd out{socket_fd_, POLLOUT, 0};
    (void)::poll(&out, 1, 5);
  }
}

bool RawLink::consume_stop() {
  if (!stop_requested_.load(std::memory_order_relaxed)) return false;
  stop_requested_.store(false, std::memory_order_relaxed);
  std::uint64_t value = 0;
  (void)::read(stop_fd_, &value, sizeof value);
  return true;
}

void RawLink::stop() {
  stop_requested_.store(true, std::memory_order_relaxed);
  const std::uint64_t one = 1;
  (void)::write(stop_fd_, &one, sizeof one);
}

TimePoint RawLink::next_timer() const {
  return timer_order_.empty() ? kForever : timer_order_.begin()->first;
}

bool RawLink::fire_due_timers() {
  bool fired = false;
  const TimePoint t = now();
  // Only timers due now that exist at this point: callbacks may start new ones.
  std::vector<TimerId> due;
  for (auto it = timer_order_.begin(); it != timer_order_.end() && it->first <= t; ++it) {
    due.push_back(it->second);
  }
  for (TimerId id : due) {
    const auto it = timers_.find(id);
    if (it == timers_.end()) continue;
    auto [range_begin, range_end] = timer_order_.equal_range(it->second.first);
    for (auto o = range_begin; o != range_end; ++o) {
      if (o->second == id) {
        timer_order_.erase(o);
        break;
      }
    }
    TimerCallback callback = std::move(it->second.second);
    timers_.erase(it);
    callback();
    fired = true;
  }
  return fired;
}

void RawLink::read_frames(TimePoint wait_until) {
  const TimePoint t = now();
  if (wait_until > t) {
    pollfd fds[2] = {{socket_fd_, POLLIN, 0}, {stop_fd_, POLLIN, 0}};
    timespec timeout{};
    timespec* timeout_ptr = nullptr;
    if (wait_until != kForever) {
      const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wait_until - t).count();
      timeout.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
      timeout.tv_nsec = static_cast<long>(ns % 1'000'000'000);
      timeout_ptr = &timeout;
    }
    const int ready = ::ppoll(fds, 2, timeout_ptr, nullptr);
    if (ready <= 0) return;
    if ((fds[0].revents & (POLLERR | POLLHUP | POLLNVAL)) != 0) {
      int error = 0;
      socklen_t length = sizeof error;
      (void)::getsockopt(socket_fd_, SOL_SOCKET, SO_ERROR, &error, &length);
      last_error_ = error == ENETDOWN ? make_error_code(LinkError::link_down)
                                      : system_error(error != 0 ? error : EIO);
    }
    if ((fds[0].revents & POLLIN) == 0) return;
  }
  for (;;) {
    sockaddr_ll from{};
    socklen_t from_length = sizeof from;
    const ssize_t n = ::recvfrom(socket_fd_, buffer_.data(), buffer_.size(), MSG_DONTWAIT,
                                 reinterpret_cast<sockaddr*>(&from), &from_length);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) last_error_ = system_error(errno);
      return;
    }
    if (from.sll_pkttype == PACKET_OUTGOING) {
      ++stats_.own_frames_skipped;
      continue;
    }
    ++stats_.frames_received;
    TimedFrame frame{{buffer_.begin(), buffer_.begin() + n}, now()};
    if (handler_) {
      handler_(frame);
    } else {
      inbox_.push_back(std::move(frame));
    }
  }
}

std::optional<TimedFrame> RawLink::receive(TimePoint deadline) {
  auto pop = [this]() -> std::optional<TimedFrame> {
    if (inbox_.empty()) return std::nullopt;
    TimedFrame frame = std::move(inbox_.front());
    inbox_.pop_front();
    return frame;
  };
  if (running_) return pop();
  running_ = true;
  std::optional<TimedFrame> result;
  for (;;) {
    fire_due_timers();
    read_frames(now());  // what is there already
    if ((result = pop())) break;
    if (consume_stop() || now() >= deadline) break;
    read_frames(std::min(deadline, next_timer()));
    if ((result = pop())) break;
  }
  running_ = false;
  return result;
}

void RawLink::run_until(TimePoint deadline) {
  if (running_) return;
  running_ = true;
  for (;;) {
    fire_due_timers();
    read_frames(now());
    if (consume_stop() || now() >= deadline) break;
    read_frames(std::min(deadline, next_timer()));
  }
  running_ = false;
}

void RawLink::set_frame_handler(FrameHandler handler) {
  handler_ = std::move(handler);
}

TimerId RawLink::start_timer(TimePoint at, TimerCallback callback) {
  const TimerId id = next_timer_id_++;
  timers_.emplace(id, std::make_pair(at, std::move(callback)));
  timer_order_.emplace(at, id);
  return id;
}

void RawLink::cancel_timer(TimerId id) {
  const auto it = timers_.find(id);
  if (it == timers_.end()) return;
  auto [range_begin, range_end] = timer_order_.equal_range(it->second.first);
  for (auto o = range_begin; o != range_end; ++o) {
    if (o->second == id) {
      timer_order_.erase(o);
      break;
    }
  }
  timers_.erase(it);
}

std::string describe_open_error(std::string_view interface, std::error_code error) {
  if (error == LinkError::permission_denied) {
    return fmt::format(
        "{}: raw packet sockets need root or CAP_NET_RAW (run as root, or: sudo setcap "
        "cap_net_raw+ep <program>)",
        interface);
  }
  if (error == LinkError::no_such_interface) {
    return fmt::format(
        "{}: no network interface of that name (list them: ip link; for a test pair: ip link "
        "add {} type veth peer name {}-peer)",
        interface, interface, interface);
  }
  if (error == LinkError::interface_down) {
    return fmt::format("{}: the interface is down (ip link set {} up)", interface, interface);
  }
  if (error == LinkError::no_packet_sockets) {
    return fmt::format("{}: this kernel has no AF_PACKET sockets (CONFIG_PACKET)", interface);
  }
  return fmt::format("{}: {}", interface, error.message());
}

}  // namespace drivecheck::ethercat
