#include "tests/vm/vm_peer.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <linux/net_tstamp.h>
#include <net/if.h>
#include <poll.h>
#include <signal.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/timerfd.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>

#include "protocol/can/socketcan_bus.hpp"

namespace drivecheck::vm {
namespace {

using namespace std::chrono_literals;

void signal_ready(int ready_fd) {
  const char ready = 'R';
  [[maybe_unused]] const auto n = ::write(ready_fd, &ready, 1);
  ::close(ready_fd);
}

std::unique_ptr<can::SocketCanBus> open_bus(const std::string& interface) {
  auto bus = can::SocketCanBus::open(interface);
  if (!bus) {
    fmt::print(stderr, "peer: {}\n", can::describe_open_error(interface, bus.error()));
    return nullptr;
  }
  return std::move(*bus);
}

can::Frame answer_to(const can::Frame& request) {
  can::Frame reply = request;
  reply.id = request.id + 1;
  if (!request.is_extended()) reply.id &= can::kMaxStandardId;
  if (request.is_extended()) reply.id &= can::kMaxExtendedId;
  return reply;
}

int role_echo(int ready_fd, const std::vector<std::string>& args) {
  if (args.empty()) return 2;
  auto bus = open_bus(args[0]);
  if (!bus) return 3;
  if (args.size() > 1) {
    const can::Filter only[] = {can::Filter::standard(std::stoul(args[1], nullptr, 0)),
                                can::Filter::extended(quit_frame().id)};
    bus->set_filters(only);
  }
  int failures = 0;
  bus->set_frame_handler([&](const can::TimedFrame& timed) {
    if (timed.frame == quit_frame()) {
      bus->stop();
      return;
    }
    if (timed.frame.is_error()) return;
    if (const auto error = bus->send(answer_to(timed.frame))) {
      fmt::print(stderr, "peer echo: send failed: {}\n", error.message());
      ++failures;
    }
  });
  signal_ready(ready_fd);
  bus->run_until(can::kForever);
  return failures == 0 ? 0 : 1;
}

int role_raw_echo(int ready_fd, const std::vector<std::string>& args) {
  if (args.size() < 2) return 2;
  const int fd = open_raw_socket(args[0], static_cast<int>(std::stoul(args[1], nullptr, 0)));
  if (fd < 0) {
    fmt::print(stderr, "peer raw-echo: {}: {}\n", args[0], std::strerror(errno));
    return 3;
  }
  // The quit frame passes too.
  const can_filter filters[] = {
      {static_cast<canid_t>(std::stoul(args[1], nullptr, 0)), CAN_EFF_FLAG | CAN_SFF_MASK},
      {CAN_EFF_FLAG | quit_frame().id, CAN_EFF_FLAG | CAN_EFF_MASK}};
  ::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters, sizeof filters);
  signal_ready(ready_fd);
  can_frame frame{};
  for (;;) {
    const ssize_t n = ::read(fd, &frame, sizeof frame);
    if (n != static_cast<ssize_t>(sizeof frame)) {
      fmt::print(stderr, "peer raw-echo: read: {}\n", n < 0 ? std::strerror(errno) : "short frame");
      return 1;
    }
    if (frame.can_id == (CAN_EFF_FLAG | quit_frame().id)) return 0;
    frame.can_id = (frame.can_id + 1) & CAN_SFF_MASK;
    if (::write(fd, &frame, sizeof frame) != static_cast<ssize_t>(sizeof frame)) {
      fmt::print(stderr, "peer raw-echo: write: {}\n", std::strerror(errno));
      return 1;
    }
  }
}

int role_stamped_echo(int ready_fd, const std::vector<std::string>& args) {
  if (args.size() < 2) return 2;
  auto socket = StampedRawSocket::open(args[0], static_cast<int>(std::stoul(args[1], nullptr, 0)));
  if (!socket) {
    fmt::print(stderr, "peer stamped-echo: {}: {}\n", args[0], std::strerror(errno));
    return 3;
  }
  signal_ready(ready_fd);
  can_frame frame{};
  for (;;) {
    if (!socket->receive(frame, false)) {
      fmt::print(stderr, "peer stamped-echo: receive: {}\n", std::strerror(errno));
      return 1;
    }
    if (frame.can_id == (CAN_EFF_FLAG | quit_frame().id)) return 0;
    frame.can_id = (frame.can_id + 1) & CAN_SFF_MASK;
    if (!socket->send(frame)) {
      fmt::print(stderr, "peer stamped-echo: send: {}\n", std::strerror(errno));
      return 1;
    }
  }
}

int role_send(int ready_fd, const std::vector<std::string>& args, bool raw) {
  if (args.empty()) return 2;
  std::vector<can::Frame> frames;
  for (std::size_t i = 1; i < args.size(); ++i) {
    const auto frame = can::parse_candump(args[i]);
    if (!frame) {
      fmt::print(stderr, "peer send: {}: {}\n", args[i], frame.error());
      return 2;
    }
    frames.push_back(*frame);
  }
  if (raw) {
    const int fd = open_raw_socket(args[0]);
    if (fd < 0) {
      fmt::print(stderr, "peer raw-send: {}: {}\n", args[0], std::strerror(errno));
      return 3;
    }
    signal_ready(ready_fd);
    for (const can::Frame& frame : frames) {
      can_frame out{};
      out.can_id = can::socketcan_id(frame);
      out.len = static_cast<std::uint8_t>(frame.is_remote() ? frame.dlc : frame.length());
      std::memcpy(out.data, frame.data.data(), 8);
      if (::write(fd, &out, sizeof out) != static_cast<ssize_t>(sizeof out)) {
        fmt::print(stderr, "peer raw-send: {}: {}\n", can::to_candump(frame), std::strerror(errno));
        return 1;
      }
    }
    ::close(fd);
    return 0;
  }
  auto bus = open_bus(args[0]);
  if (!bus) return 3;
  signal_ready(ready_fd);
  for (const can::Frame& frame : frames) {
    if (const auto error = bus->send(frame)) {
      fmt::print(stderr, "peer send: {}: {}\n", can::to_candump(frame), error.message());
      return 1;
    }
  }
  return 0;
}

int role_count(int ready_fd, const std::vector<std::string>& args) {
  if (args.size() < 3) return 2;
  can::SocketCanOptions options;
  options.receive_buffer_bytes = 1 << 20;
  auto opened = can::SocketCanBus::open(args[0], options);
  if (!opened) {
    fmt::print(stderr, "peer count: {}\n", can::describe_open_error(args[0], opened.error()));
    return 3;
  }
  auto& bus = *opened;
  const std::uint32_t expected = static_cast<std::uint32_t>(std::stoul(args[1]));
  const auto silence = std::chrono::milliseconds(std::stoul(args[2]));
  signal_ready(ready_fd);
  std::uint32_t count = 0;
  bool in_order = true;
  while (count < expected) {
    const auto timed = bus->receive(bus->now() + silence);
    if (!timed) break;
    const auto& d = timed->frame.data;
    const std::uint32_t sequence = (std::uint32_t{d[0]} << 24) | (std::uint32_t{d[1]} << 16) |
                                   (std::uint32_t{d[2]} << 8) | d[3];
    if (sequence != count) {
      if (in_order) fmt::print(stderr, "peer count: frame {} has sequence {}\n", count, sequence);
      in_order = false;
    }
    ++count;
  }
  fmt::print("peer count: {} of {} frames, {}, kernel drops {}\n", count, expected,
             in_order ? "in order" : "OUT OF ORDER", bus->stats().kernel_drops);
  return count == expected && in_order ? 0 : 1;
}

}  // namespace

can::Frame quit_frame() {
  return can::Frame::extended(0x1FFFFFFF, {});
}

int open_raw_socket(const std::string& interface, int filter_id) {
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) return -1;
  const unsigned index = ::if_nametoindex(interface.c_str());
  if (index == 0) {
    ::close(fd);
    return -1;
  }
  if (filter_id >= 0) {
    const can_filter filter{static_cast<canid_t>(filter_id), CAN_EFF_FLAG | CAN_SFF_MASK};
    ::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, &filter, sizeof filter);
  }
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(index);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) < 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

std::unique_ptr<StampedRawSocket> StampedRawSocket::open(const std::string& interface,
                                                         int filter_id) {
  const int fd = open_raw_socket(interface, filter_id);
  if (fd < 0) return nullptr;
  // The quit frame passes too.
  const can_filter filters[] = {{static_cast<canid_t>(filter_id), CAN_EFF_FLAG | CAN_SFF_MASK},
                                {CAN_EFF_FLAG | quit_frame().id, CAN_EFF_FLAG | CAN_EFF_MASK}};
  ::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters, sizeof filters);
  const int flags = SOF_TIMESTAMPING_RX_SOFTWARE | SOF_TIMESTAMPING_SOFTWARE;
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPING, &flags, sizeof flags);
  ::setsockopt(fd, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one);
  const timeval slice{0, 20'000};  // SocketCanBus's receive slice
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &slice, sizeof slice);
  return std::unique_ptr<StampedRawSocket>(new StampedRawSocket(fd));
}

StampedRawSocket::~StampedRawSocket() {
  ::close(socket_fd_);
}

bool StampedRawSocket::send(const can_frame& frame) {
  return ::send(socket_fd_, &frame, sizeof frame, MSG_DONTWAIT) ==
         static_cast<ssize_t>(sizeof frame);
}

bool StampedRawSocket::receive(can_frame& frame, bool limited) {
  alignas(cmsghdr) unsigned char control[256];
  iovec vector{&frame, sizeof frame};
  msghdr header{};
  header.msg_iov = &vector;
  header.msg_iovlen = 1;
  // Timeouts of one slice are retried, 50 of them (1 s) end a limited wait.
  for (int slices = 0; !limited || slices < 50; ++slices) {
    header.msg_control = control;
    header.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(socket_fd_, &header, 0);
    if (n == static_cast<ssize_t>(sizeof frame)) return true;
    if (n >= 0 || (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) return false;
  }
  errno = ETIMEDOUT;
  return false;
}

std::unique_ptr<PeerProcess> PeerProcess::start(const std::string& role,
                                                const std::vector<std::string>& args,
                                                std::string& error) {
  int ready[2];
  if (::pipe2(ready, O_CLOEXEC) != 0) {
    error = fmt::format("pipe: {}", std::strerror(errno));
    return nullptr;
  }
  std::vector<std::string> argv_text = {"/proc/self/exe", "--peer", role, std::to_string(ready[1])};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_text)
    argv.push_back(a.data());
  argv.push_back(nullptr);

  const pid_t pid = ::fork();
  if (pid < 0) {
    error = fmt::format("fork: {}", std::strerror(errno));
    ::close(ready[0]);
    ::close(ready[1]);
    return nullptr;
  }
  if (pid == 0) {
    ::fcntl(ready[1], F_SETFD, 0);  // the write end survives exec
    ::execv("/proc/self/exe", argv.data());
    std::_Exit(127);
  }
  ::close(ready[1]);
  std::unique_ptr<PeerProcess> peer(new PeerProcess(pid));
  pollfd wait_ready{ready[0], POLLIN, 0};
  char byte = 0;
  const bool ok =
      ::poll(&wait_ready, 1, 5000) == 1 && ::read(ready[0], &byte, 1) == 1 && byte == 'R';
  ::close(ready[0]);
  if (!ok) {
    const int status = peer->wait(1000ms);
    error = fmt::format("peer '{}' did not get ready (exit status {})", role, status);
    return nullptr;
  }
  return peer;
}

PeerProcess::~PeerProcess() {
  if (!reaped_) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
}

int PeerProcess::wait(std::chrono::milliseconds timeout) {
  if (reaped_) return -1;
  const auto give_up = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t done = ::waitpid(pid_, &status, WNOHANG);
    if (done == pid_) {
      reaped_ = true;
      return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    if (std::chrono::steady_clock::now() >= give_up) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
      reaped_ = true;
      return -1;
    }
    // Test-side polling for the peer's exit; protocol code never waits like this.
    ::poll(nullptr, 0, 5);
  }
}

int run_peer_if_asked(int argc, char** argv) {
  if (argc < 4 || std::string_view(argv[1]) != "--peer") return -1;
  const std::string role = argv[2];
  const int ready_fd = std::atoi(argv[3]);
  const std::vector<std::string> args(argv + 4, argv + argc);
  try {
    if (role == "echo") return role_echo(ready_fd, args);
    if (role == "raw-echo") return role_raw_echo(ready_fd, args);
    if (role == "stamped-echo") return role_stamped_echo(ready_fd, args);
    if (role == "send") return role_send(ready_fd, args, false);
    if (role == "raw-send") return role_send(ready_fd, args, true);
    if (role == "count") return role_count(ready_fd, args);
  } catch (const std::exception& e) {
    fmt::print(stderr, "peer {}: {}\n", role, e.what());
    return 2;
  }
  fmt::print(stderr, "peer: unknown role '{}'\n", role);
  return 2;
}

RoundTrips summarize(std::vector<double>& latencies_us,
                     std::chrono::steady_clock::duration elapsed) {
  RoundTrips round;
  if (latencies_us.empty()) return round;
  std::sort(latencies_us.begin(), latencies_us.end());
  round.per_second =
      static_cast<double>(latencies_us.size()) / std::chrono::duration<double>(elapsed).count();
  round.p50_us = latencies_us[latencies_us.size() / 2];
  round.p99_us = latencies_us[latencies_us.size() * 99 / 100];
  return round;
}

}  // namespace drivecheck::vm
