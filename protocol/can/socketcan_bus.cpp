#include "protocol/can/socketcan_bus.hpp"

#include <fmt/format.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <linux/errqueue.h>
#include <linux/net_tstamp.h>
#include <net/if.h>
#include <net/if_arp.h>
#include <poll.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <utility>

#include "protocol/can/error_frame.hpp"

namespace drivecheck::can {

// The ABI values error_frame.hpp and bus.hpp restate, checked against the kernel headers.
static_assert(error_class::kTxTimeout == CAN_ERR_TX_TIMEOUT);
static_assert(error_class::kLostArbitration == CAN_ERR_LOSTARB);
static_assert(error_class::kController == CAN_ERR_CRTL);
static_assert(error_class::kProtocol == CAN_ERR_PROT);
static_assert(error_class::kTransceiver == CAN_ERR_TRX);
static_assert(error_class::kNoAck == CAN_ERR_ACK);
static_assert(error_class::kBusOff == CAN_ERR_BUSOFF);
static_assert(error_class::kBusError == CAN_ERR_BUSERROR);
static_assert(error_class::kRestarted == CAN_ERR_RESTARTED);
static_assert(error_class::kCounters == CAN_ERR_CNT);
static_assert(error_class::kAll == CAN_ERR_MASK);
static_assert(controller_status::kRxOverflow == CAN_ERR_CRTL_RX_OVERFLOW);
static_assert(controller_status::kTxOverflow == CAN_ERR_CRTL_TX_OVERFLOW);
static_assert(controller_status::kRxWarning == CAN_ERR_CRTL_RX_WARNING);
static_assert(controller_status::kTxWarning == CAN_ERR_CRTL_TX_WARNING);
static_assert(controller_status::kRxPassive == CAN_ERR_CRTL_RX_PASSIVE);
static_assert(controller_status::kTxPassive == CAN_ERR_CRTL_TX_PASSIVE);
static_assert(controller_status::kActive == CAN_ERR_CRTL_ACTIVE);
static_assert(protocol_violation::kBit == CAN_ERR_PROT_BIT);
static_assert(protocol_violation::kForm == CAN_ERR_PROT_FORM);
static_assert(protocol_violation::kStuff == CAN_ERR_PROT_STUFF);
static_assert(protocol_violation::kBit0 == CAN_ERR_PROT_BIT0);
static_assert(protocol_violation::kBit1 == CAN_ERR_PROT_BIT1);
static_assert(protocol_violation::kOverload == CAN_ERR_PROT_OVERLOAD);
static_assert(protocol_violation::kActive == CAN_ERR_PROT_ACTIVE);
static_assert(protocol_violation::kTx == CAN_ERR_PROT_TX);
static_assert(kKernelInvertFilter == CAN_INV_FILTER);
static_assert(Filter::kEffFlag == CAN_EFF_FLAG && Filter::kRtrFlag == CAN_RTR_FLAG &&
              Filter::kErrFlag == CAN_ERR_FLAG);
static_assert(kErrorFlag == CAN_ERR_FLAG && kErrorClassMask == CAN_ERR_MASK);

namespace {

constexpr Duration kFirstSendBackoff = std::chrono::microseconds(50);
constexpr Duration kMaxSendBackoff = std::chrono::milliseconds(5);
// A wall-clock step larger than this re-measures the realtime -> monotonic offset.
constexpr Duration kClockStepThreshold = std::chrono::milliseconds(1);
constexpr Duration kClockCheckInterval = std::chrono::milliseconds(100);
// A blocking recvmsg() waits at most one slice (SO_RCVTIMEO), so a stop() from another thread
// is seen within it. The kernel counts the timeout in jiffies, rounded up (a jiffy is 10 ms at
// HZ=100), so the port blocks only when nothing is due within the slice plus that margin.
constexpr Duration kBlockingReceiveSlice = std::chrono::milliseconds(20);
constexpr Duration kBlockingReceiveHorizon = kBlockingReceiveSlice + std::chrono::milliseconds(20);

std::error_code system_error(int error) {
  return {error, std::system_category()};
}

std::int64_t read_clock_ns(clockid_t clock) {
  timespec ts{};
  ::clock_gettime(clock, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// realtime - monotonic, with the realtime reading taken between two monotonic readings.
Duration measure_unix_offset() {
  const std::int64_t before = read_clock_ns(CLOCK_MONOTONIC);
  const std::int64_t real = read_clock_ns(CLOCK_REALTIME);
  const std::int64_t after = read_clock_ns(CLOCK_MONOTONIC);
  return Duration(real - (before + (after - before) / 2));
}

timespec to_timespec(Duration duration) {
  if (duration < Duration::zero()) duration = Duration::zero();
  const auto ns = duration.count();
  return timespec{static_cast<time_t>(ns / 1'000'000'000), static_cast<long>(ns % 1'000'000'000)};
}

// Errors of send() and of a socket's pending error (SO_ERROR).
std::error_code map_io_errno(int error) {
  switch (error) {
    case ENETDOWN:
    case ENODEV:
    case ENXIO:
      return make_error_code(BusError::interface_down);
    case EINVAL:
    case EMSGSIZE:
      return make_error_code(BusError::invalid_frame);
    default:
      return system_error(error);
  }
}

class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }

 private:
  int fd_;
};

template <class T>
bool set_option(int fd, int level, int name, const T& value) {
  return ::setsockopt(fd, level, name, &value, sizeof value) == 0;
}

bool install_kernel_filters(int fd, std::span<const Filter> filters) {
  const auto kernel = to_kernel_filters(filters);
  std::vector<can_filter> raw(kernel.size());
  for (std::size_t i = 0; i < kernel.size(); ++i) {
    raw[i].can_id = kernel[i].can_id;
    raw[i].can_mask = kernel[i].can_mask;
  }
  return ::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, raw.data(),
                      static_cast<socklen_t>(raw.size() * sizeof(can_filter))) == 0;
}

// Pass-all kernel filter: the user-space check still applies the real filters.
void install_pass_all_filter(int fd) {
  const can_filter all{0, 0};
  ::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, &all, sizeof all);
}

}  // namespace

std::string_view to_string(TimestampSource source) {
  switch (source) {
    case TimestampSource::automatic:
      return "automatic";
    case TimestampSource::so_timestamping:
      return "SO_TIMESTAMPING";
    case TimestampSource::so_timestamp:
      return "SO_TIMESTAMP";
    case TimestampSource::none:
      return "none";
  }
  return "unknown";
}

// ---- conversions ----

std::vector<KernelFilter> to_kernel_filters(std::span<const Filter> filters) {
  if (filters.empty()) return {KernelFilter{0, 0}};
  std::vector<KernelFilter> kernel;
  kernel.reserve(filters.size());
  for (const Filter& filter : filters) {
    KernelFilter k;
    k.can_id = filter.id & ~Filter::kErrFlag;
    k.can_mask = filter.mask & ~Filter::kErrFlag;
    if (filter.invert) k.can_id |= kKernelInvertFilter;
    kernel.push_back(k);
  }
  return kernel;
}

Expected<KernelFrame, std::error_code> to_kernel_frame(const Frame& frame) {
  const auto invalid = [] { return Unexpected(make_error_code(BusError::invalid_frame)); };
  if (frame.is_error()) return invalid();
  if (frame.is_extended() ? frame.id > kMaxExtendedId : frame.id > kMaxStandardId) {
    return invalid();
  }
  KernelFrame raw;
  raw.can_id = socketcan_id(frame);
  if (frame.is_remote()) {
    if (frame.dlc > 8) return invalid();
    raw.len = frame.dlc;
    return raw;
  }
  if (frame.dlc > 15) return invalid();
  raw.len = static_cast<std::uint8_t>(frame.length());
  if (frame.dlc > 8) raw.len8_dlc = frame.dlc;
  std::copy_n(frame.data.begin(), raw.len, raw.data.begin());
  return raw;
}

std::optional<Frame> from_kernel_frame(const KernelFrame& raw) {
  if (raw.len > 8) return std::nullopt;
  Frame frame;
  if ((raw.can_id & CAN_ERR_FLAG) != 0) {
    frame.kind = FrameKind::error;
    frame.format = IdFormat::extended;
    frame.id = raw.can_id & CAN_ERR_MASK;
  } else if ((raw.can_id & CAN_EFF_FLAG) != 0) {
    frame.format = IdFormat::extended;
    frame.id = raw.can_id & CAN_EFF_MASK;
  } else {
    frame.id = raw.can_id & CAN_SFF_MASK;
  }
  frame.dlc = raw.len;
  if (!frame.is_error() && (raw.can_id & CAN_RTR_FLAG) != 0) {
    frame.kind = FrameKind::remote;
    return frame;
  }
  std::copy_n(raw.data.begin(), raw.len, frame.data.begin());
  if (frame.kind == FrameKind::data && raw.len == 8 && raw.len8_dlc > 8 && raw.len8_dlc <= 15) {
    frame.dlc = raw.len8_dlc;
  }
  return frame;
}

// ---- open ----

std::string describe_open_error(std::string_view interface, std::error_code error) {
  if (error == BusError::no_can_in_kernel) {
    return fmt::format(
        "{}: this kernel has no SocketCAN support (socket(PF_CAN) failed); load it with "
        "'modprobe can-raw' (and 'modprobe vcan' for a virtual bus)",
        interface);
  }
  if (error == BusError::no_such_interface) {
    return fmt::format(
        "{}: no CAN interface of that name ('ip -details link show' lists them; create a virtual "
        "one with 'ip link add dev {} type vcan && ip link set {} up')",
        interface, interface, interface);
  }
  if (error == BusError::interface_down) {
    return fmt::format(
        "{}: the CAN interface is down (bring it up: 'ip link set {} up type can bitrate "
        "<bit/s>', or 'ip link set {} up' for vcan)",
        interface, interface, interface);
  }
  return fmt::format("{}: cannot open the CAN interface: {}", interface, error.message());
}

Expected<std::unique_ptr<SocketCanBus>, std::error_code> SocketCanBus::open(
    std::string_view interface, SocketCanOptions options) {
  // A blocking socket: every call that must not wait passes MSG_DONTWAIT; the blocking
  // receive (SO_RCVTIMEO below) is the one that waits.
  FileDescriptor socket_fd(::socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW));
  if (socket_fd.get() < 0) {
    const int error = errno;
    if (error == EAFNOSUPPORT || error == EPROTONOSUPPORT || error == ESOCKTNOSUPPORT) {
      return Unexpected(make_error_code(BusError::no_can_in_kernel));
    }
    return Unexpected(system_error(error));
  }
  if (interface.empty() || interface.size() >= IFNAMSIZ ||
      interface.find('\0') != std::string_view::npos) {
    return Unexpected(make_error_code(BusError::no_such_interface));
  }
  ifreq request{};
  std::copy(interface.begin(), interface.end(), request.ifr_name);
  if (::ioctl(socket_fd.get(), SIOCGIFINDEX, &request) < 0) {
    const int error = errno;
    if (error == ENODEV) return Unexpected(make_error_code(BusError::no_such_interface));
    return Unexpected(system_error(error));
  }
  const int ifindex = request.ifr_ifindex;
  // A CAN interface has hardware type ARPHRD_CAN; anything else (lo, eth0) is no CAN interface.
  if (::ioctl(socket_fd.get(), SIOCGIFHWADDR, &request) < 0) return Unexpected(system_error(errno));
  if (request.ifr_hwaddr.sa_family != ARPHRD_CAN) {
    return Unexpected(make_error_code(BusError::no_such_interface));
  }
  if (::ioctl(socket_fd.get(), SIOCGIFFLAGS, &request) < 0) return Unexpected(system_error(errno));
  if ((request.ifr_flags & IFF_UP) == 0) {
    return Unexpected(make_error_code(BusError::interface_down));
  }

  const int fd = socket_fd.get();
  const can_err_mask_t error_mask = CAN_ERR_MASK;
  if (!set_option(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, error_mask)) {
    return Unexpected(system_error(errno));
  }
  const int own = options.loopback ? 1 : 0;
  if (!set_option(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, own)) {
    return Unexpected(system_error(errno));
  }
  if (!install_kernel_filters(fd, options.filters)) install_pass_all_filter(fd);
  // Counts frames the kernel dropped because the receive buffer was full (optional).
  set_option(fd, SOL_SOCKET, SO_RXQ_OVFL, 1);
  if (options.receive_buffer_bytes > 0 &&
      !set_option(fd, SOL_SOCKET, SO_RCVBUF, options.receive_buffer_bytes)) {
    return Unexpected(system_error(errno));
  }

  const int timestamping_flags = SOF_TIMESTAMPING_RX_SOFTWARE | SOF_TIMESTAMPING_SOFTWARE;
  TimestampSource source = TimestampSource::none;
  switch (options.timestamps) {
    case TimestampSource::automatic:
      if (set_option(fd, SOL_SOCKET, SO_TIMESTAMPING, timestamping_flags)) {
        source = TimestampSource::so_timestamping;
      } else if (set_option(fd, SOL_SOCKET, SO_TIMESTAMP, 1)) {
        source = TimestampSource::so_timestamp;
      }
      break;
    case TimestampSource::so_timestamping:
      if (!set_option(fd, SOL_SOCKET, SO_TIMESTAMPING, timestamping_flags)) {
        return Unexpected(system_error(errno));
      }
      source = TimestampSource::so_timestamping;
      break;
    case TimestampSource::so_timestamp:
      if (!set_option(fd, SOL_SOCKET, SO_TIMESTAMP, 1)) return Unexpected(system_error(errno));
      source = TimestampSource::so_timestamp;
      break;
    case TimestampSource::none:
      break;
  }

  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = ifindex;
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) < 0) {
    const int error = errno;
    if (error == ENODEV) return Unexpected(make_error_code(BusError::no_such_interface));
    if (error == ENETDOWN) return Unexpected(make_error_code(BusError::interface_down));
    return Unexpected(system_error(error));
  }

  const timeval slice{
      0, static_cast<suseconds_t>(
             std::chrono::duration_cast<std::chrono::microseconds>(kBlockingReceiveSlice).count())};
  // Without a receive timeout a blocking recvmsg() could outlive every deadline: then the
  // port always waits in epoll.
  const bool blocking_receive =
      ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &slice, sizeof slice) == 0;

  FileDescriptor stop_fd(::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC));
  if (stop_fd.get() < 0) return Unexpected(system_error(errno));
  FileDescriptor timer_fd(::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC));
  if (timer_fd.get() < 0) return Unexpected(system_error(errno));
  // The descriptors are registered in an epoll set, not passed to poll() at every wait:
  // poll() would install and remove a wait-queue entry on each of them every time, which is
  // most of a round trip's cost on a slow (emulated) machine. The socket joins the set when
  // the port first waits in epoll (see wait_and_read).
  FileDescriptor epoll_fd(::epoll_create1(EPOLL_CLOEXEC));
  if (epoll_fd.get() < 0) return Unexpected(system_error(errno));
  const int registered[3] = {-1, stop_fd.get(), timer_fd.get()};
  for (std::uint32_t i = 1; i < 3; ++i) {
    epoll_event event{};
    event.events = EPOLLIN;
    event.data.u32 = i;  // 0 socket, 1 stop, 2 timer
    if (::epoll_ctl(epoll_fd.get(), EPOLL_CTL_ADD, registered[i], &event) != 0)
      return Unexpected(system_error(errno));
  }

  std::string name(interface);
  auto bus = std::unique_ptr<SocketCanBus>(
      new SocketCanBus(socket_fd.release(), stop_fd.release(), timer_fd.release(),
                       epoll_fd.release(), std::move(name), std::move(options), source));
  bus->blocking_receive_ = blocking_receive;
  return bus;
}

SocketCanBus::SocketCanBus(int socket_fd, int stop_fd, int timer_fd, int epoll_fd,
                           std::string interface, SocketCanOptions options, TimestampSource source)
    : socket_fd_(socket_fd),
      stop_fd_(stop_fd),
      timer_fd_(timer_fd),
      epoll_fd_(epoll_fd),
      interface_(std::move(interface)),
      options_(std::move(options)),
      timestamp_source_(source),
      unix_offset_(measure_unix_offset()),
      conversion_offset_(unix_offset_),
      filters_(options_.filters) {}

SocketCanBus::~SocketCanBus() {
  ::close(socket_fd_);
  ::close(stop_fd_);
  ::close(timer_fd_);
  ::close(epoll_fd_);
}

TimePoint SocketCanBus::now() const {
  return TimePoint(Duration(read_clock_ns(CLOCK_MONOTONIC)));
}

// ---- sending ----

std::error_code SocketCanBus::send(const Frame& frame) {
  const auto raw = to_kernel_frame(frame);
  if (!raw) return raw.error();
  if (bus_off_) {
    read_available();  // a restart may be waiting in the receive queue
    if (bus_off_) return make_error_code(BusError::bus_off);
  }
  can_frame out{};
  out.can_id = raw->can_id;
  out.len = raw->len;
  out.len8_dlc = raw->len8_dlc;
  std::copy(raw->data.begin(), raw->data.end(), out.data);

  std::optional<TimePoint> give_up;
  Duration backoff = kFirstSendBackoff;
  for (;;) {
    const ssize_t written = ::send(socket_fd_, &out, sizeof out, MSG_DONTWAIT);
    if (written == static_cast<ssize_t>(sizeof out)) {
      ++stats_.frames_sent;
      return {};
    }
    if (written >= 0) return system_error(EIO);  // a raw CAN socket never writes part of a frame
    const int error = errno;
    if (error == EINTR) continue;
    if (error != ENOBUFS && error != EAGAIN) return map_io_errno(error);

    // The transmit queue (qdisc, txqueuelen) or the socket's send buffer is full.
    const TimePoint t = now();
    if (!give_up) give_up = t + options_.send_timeout;
    if (t >= *give_up) {
      read_available();  // did the controller go bus-off meanwhile?
      return make_error_code(bus_off_ ? BusError::bus_off : BusError::queue_full);
    }
    ++stats_.send_retries;
    const timespec wait = to_timespec(std::min(backoff, *give_up - t));
    if (error == EAGAIN) {
      // Send buffer full: POLLOUT says when there is room again.
      pollfd writable{socket_fd_, POLLOUT, 0};
      ::ppoll(&writable, 1, &wait, nullptr);
    } else {
      // Queue full: POLLOUT would be reported at once (the send buffer has room); wait.
      ::ppoll(nullptr, 0, &wait, nullptr);
    }
    backoff = std::min(backoff * 2, kMaxSendBackoff);
  }
}

// ---- configuration ----

void SocketCanBus::set_frame_handler(FrameHandler handler) {
  handler_ = std::move(handler);
}

void SocketCanBus::set_filters(std::span<const Filter> filters) {
  filters_.assign(filters.begin(), filters.end());
  if (!install_kernel_filters(socket_fd_, filters)) {
    // E.g. more than CAN_RAW_FILTER_MAX filters: let the kernel pass everything, the
    // user-space check keeps the result exact.
    last_error_ = system_error(errno);
    install_pass_all_filter(socket_fd_);
  }
  // Frames read under the old filters must pass the new ones too.
  std::erase_if(inbox_, [this](const TimedFrame& f) { return !passes_filters(f.frame); });
}

void SocketCanBus::set_loopback(bool enabled) {
  options_.loopback = enabled;
  const int own = enabled ? 1 : 0;
  if (!set_option(socket_fd_, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, own)) {
    last_error_ = system_error(errno);
  }
  if (!enabled) std::erase_if(inbox_, [](const TimedFrame& f) { return f.own; });
}

bool SocketCanBus::passes_filters(const Frame& frame) const {
  if (frame.is_error() && !options_.error_frames) return false;
  if (filters_.empty()) return true;
  return std::any_of(filters_.begin(), filters_.end(),
                     [&](const Filter& filter) { return filter.matches(frame); });
}

// ---- timers ----

TimerId SocketCanBus::start_timer(TimePoint at, TimerCallback callback) {
  const TimerId id = next_timer_id_++;
  timers_.emplace(id, std::move(callback));
  timer_heap_.push(PendingTimer{at, id});
  // Cancelled timers stay in the heap until their time; compact when they dominate.
  if (timer_heap_.size() > 64 && timer_heap_.size() > 4 * timers_.size()) {
    std::vector<PendingTimer> live;
    live.reserve(timers_.size());
    while (!timer_heap_.empty()) {
      if (timers_.contains(timer_heap_.top().id)) live.push_back(timer_heap_.top());
      timer_heap_.pop();
    }
    timer_heap_ = decltype(timer_heap_)(std::greater<>(), std::move(live));
  }
  return id;
}

void SocketCanBus::cancel_timer(TimerId id) {
  timers_.erase(id);
}

TimePoint SocketCanBus::next_timer_at() {
  while (!timer_heap_.empty() && !timers_.contains(timer_heap_.top().id))
    timer_heap_.pop();
  return timer_heap_.empty() ? kForever : timer_heap_.top().at;
}

bool SocketCanBus::fire_due_timers() {
  if (timers_.empty()) return false;
  // Only timers started before this call: a callback that restarts itself at a past time
  // fires again on the next pass, after the socket was looked at.
  const TimerId limit = next_timer_id_;
  const TimePoint t = now();
  bool fired = false;
  while (!timer_heap_.empty() && timer_heap_.top().at <= t && timer_heap_.top().id < limit) {
    const TimerId id = timer_heap_.top().id;
    timer_heap_.pop();
    const auto it = timers_.find(id);
    if (it == timers_.end()) continue;
    TimerCallback callback = std::move(it->second);
    timers_.erase(it);
    callback();
    fired = true;
    if (stop_requested_.load(std::memory_order_relaxed)) break;
  }
  return fired;
}

// ---- waiting and receiving ----

void SocketCanBus::stop() {
  stop_requested_.store(true);
  const std::uint64_t one = 1;
  // write() is async-signal-safe; an eventfd counter cannot overflow from a few stops.
  [[maybe_unused]] const auto written = ::write(stop_fd_, &one, sizeof one);
}

bool SocketCanBus::consume_stop() {
  if (!stop_requested_.load(std::memory_order_relaxed) || !stop_requested_.exchange(false)) {
    return false;
  }
  std::uint64_t count = 0;
  [[maybe_unused]] const auto n = ::read(stop_fd_, &count, sizeof count);
  return true;
}

void SocketCanBus::deliver_inbox_to_handler() {
  while (handler_ && !inbox_.empty() && !stop_requested_.load(std::memory_order_relaxed)) {
    const TimedFrame frame = inbox_.front();
    inbox_.pop_front();
    // A copy: the handler may replace itself while it runs.
    const FrameHandler handler = handler_;
    handler(frame);
  }
}

void SocketCanBus::run_until(TimePoint deadline) {
  for (;;) {
    if (consume_stop()) return;
    deliver_inbox_to_handler();
    const bool fired = fire_due_timers();
    if (stop_requested_.load(std::memory_order_relaxed)) continue;
    // With no deadline and no timer nothing can be due: no clock reading is needed.
    const bool endless = deadline == kForever && !fired && next_timer_at() == kForever;
    const TimePoint t = endless ? TimePoint{} : now();
    if (t >= deadline) return;
    const TimePoint until = fired ? t : std::min(deadline, next_timer_at());
    if (handler_ && inbox_.empty() && may_block(until, t)) {
      // Nothing queued, nothing due: wait for a frame and hand it to the handler without
      // the inbox (a stop() that came meanwhile leaves it queued for later).
      std::optional<TimedFrame> frame;
      read_socket(0, frame);
      if (!frame) continue;
      if (stop_requested_.load(std::memory_order_relaxed)) {
        inbox_.push_back(*frame);
        continue;
      }
      // A copy: the handler may replace itself while it runs.
      const FrameHandler handler = handler_;
      handler(*frame);
      continue;
    }
    wait_and_read(until, t);
  }
}

std::optional<TimedFrame> SocketCanBus::receive(TimePoint deadline) {
  const auto pop = [this] {
    TimedFrame frame = inbox_.front();
    inbox_.pop_front();
    return frame;
  };
  for (;;) {
    if (consume_stop()) return std::nullopt;
    if (handler_) {
      deliver_inbox_to_handler();
    } else if (!inbox_.empty()) {
      return pop();
    }
    const bool fired = fire_due_timers();
    if (stop_requested_.load(std::memory_order_relaxed)) continue;
    const TimePoint t = now();
    const bool expired = t >= deadline;
    // At or past the deadline, still look once (without waiting) for a frame already there.
    const TimePoint until = fired || expired ? t : std::min(deadline, next_timer_at());
    if (!handler_ && inbox_.empty() && may_block(until, t)) {
      // Nothing queued, nothing due: the frame read is the answer, without the inbox.
      std::optional<TimedFrame> frame;
      read_socket(0, frame);
      if (frame) return frame;
      continue;
    }
    wait_and_read(until, t);
    if (!handler_ && !inbox_.empty()) return pop();
    if (expired) return std::nullopt;
  }
}

bool SocketCanBus::arm_wakeup(TimePoint until, TimePoint now_time) {
  // An armed wake-up at or before `until` (and still ahead) does: the loop wakes, finds
  // its deadline not reached, and comes back. So a master whose deadlines move forward
  // (now + 1 s on every request) re-arms about once per timeout, not once per frame.
  if (wakeup_armed_ && armed_at_ <= until && armed_at_ > now_time) return true;
  itimerspec spec{};
  spec.it_value = to_timespec(until.time_since_epoch());
  if (spec.it_value.tv_sec == 0 && spec.it_value.tv_nsec == 0) spec.it_value.tv_nsec = 1;
  if (::timerfd_settime(timer_fd_, TFD_TIMER_ABSTIME, &spec, nullptr) != 0) {
    last_error_ = system_error(errno);
    return false;
  }
  wakeup_armed_ = true;
  armed_at_ = until;
  return true;
}

bool SocketCanBus::may_block(TimePoint until, TimePoint now_time) {
  // Nothing is due within the slice: wait and read in one call, as a plain blocking read()
  // does (epoll_wait + recvmsg cost a round trip ~10 % more under QEMU). Outside the epoll
  // set, so that each frame does not also run epoll's wake-up callback. A timeout (EAGAIN)
  // or a signal (EINTR) returns with nothing read; the caller's loop looks at stop and time.
  return blocking_receive_ && until - now_time >= kBlockingReceiveHorizon &&
         (!socket_in_epoll_ || watch_socket_in_epoll(false));
}

void SocketCanBus::wait_and_read(TimePoint until, TimePoint now_time) {
  if (may_block(until, now_time)) {
    std::optional<TimedFrame> frame;
    read_socket(0, frame);
    if (frame) inbox_.push_back(*frame);
    return;
  }
  if (!socket_in_epoll_ && !watch_socket_in_epoll(true)) {
    // No epoll on the socket: wait in ppoll with its own (nanosecond) timeout instead.
    const timespec timeout = to_timespec(std::max(until - now_time, Duration::zero()));
    wait_with_ppoll(until == kForever ? nullptr : &timeout);
    return;
  }
  // The deadline is the timerfd in the epoll set rather than a timeout: arming a kernel timer
  // on every wait is what made waiting slow (10 us per round trip under QEMU), and epoll's
  // timeout has only millisecond resolution.
  int timeout_ms = -1;
  if (until <= now_time) {
    timeout_ms = 0;
  } else if (until != kForever && !arm_wakeup(until, now_time)) {
    // No timerfd deadline: wait in ppoll with its own (nanosecond) timeout instead.
    const timespec timeout = to_timespec(until - now_time);
    wait_with_ppoll(&timeout);
    return;
  }
  epoll_event events[3];
  const int ready = ::epoll_wait(epoll_fd_, events, 3, timeout_ms);
  if (ready <= 0) {
    if (ready < 0 && errno != EINTR) last_error_ = system_error(errno);
    return;
  }
  bool readable = false;
  bool error = false;
  bool stopped = false;
  bool timer = false;
  for (int i = 0; i < ready; ++i) {
    const std::uint32_t which = events[i].data.u32;
    readable |= which == 0 && (events[i].events & EPOLLIN) != 0;
    error |= which == 0 && (events[i].events & EPOLLERR) != 0;
    stopped |= which == 1;
    timer |= which == 2;
  }
  handle_wake(readable, error, stopped, timer);
}

bool SocketCanBus::watch_socket_in_epoll(bool watch) {
  epoll_event event{};
  event.events = EPOLLIN;
  event.data.u32 = 0;  // the socket
  if (::epoll_ctl(epoll_fd_, watch ? EPOLL_CTL_ADD : EPOLL_CTL_DEL, socket_fd_, &event) != 0) {
    return false;
  }
  socket_in_epoll_ = watch;
  return true;
}

void SocketCanBus::wait_with_ppoll(const timespec* timeout) {
  pollfd fds[2] = {{socket_fd_, POLLIN, 0}, {stop_fd_, POLLIN, 0}};
  const int ready = ::ppoll(fds, 2, timeout, nullptr);
  if (ready <= 0) {
    if (ready < 0 && errno != EINTR) last_error_ = system_error(errno);
    return;
  }
  handle_wake((fds[0].revents & POLLIN) != 0, (fds[0].revents & POLLERR) != 0,
              (fds[1].revents & POLLIN) != 0, false);
}

void SocketCanBus::handle_wake(bool readable, bool error, bool stopped, bool timer) {
  if (error) {
    int code = 0;
    socklen_t length = sizeof code;
    if (::getsockopt(socket_fd_, SOL_SOCKET, SO_ERROR, &code, &length) == 0 && code != 0) {
      last_error_ = map_io_errno(code);
    }
  }
  // One frame per wake-up: a round trip costs one wait and one recvmsg, and a burst is
  // read by the callers' loops without an extra failing read at its end.
  if (readable) read_one();
  // A wake-up by stop() is consumed by the caller's consume_stop(); the counter is reset
  // there, or here when stop() came between a check and the wait.
  if (stopped && !stop_requested_.load()) {
    std::uint64_t count = 0;
    [[maybe_unused]] const auto n = ::read(stop_fd_, &count, sizeof count);
  }
  if (timer) {
    std::uint64_t expirations = 0;
    [[maybe_unused]] const auto n = ::read(timer_fd_, &expirations, sizeof expirations);
    wakeup_armed_ = false;
  }
}

void SocketCanBus::read_available() {
  while (read_one()) {
  }
}

bool SocketCanBus::read_one() {
  std::optional<TimedFrame> frame;
  const bool read = read_socket(MSG_DONTWAIT, frame);
  if (frame) inbox_.push_back(*frame);
  return read;
}

bool SocketCanBus::read_socket(int flags, std::optional<TimedFrame>& out) {
  // Room for SCM_TIMESTAMPING (3 timespecs) or SCM_TIMESTAMP, plus SO_RXQ_OVFL.
  alignas(cmsghdr) unsigned char
      control[CMSG_SPACE(sizeof(scm_timestamping)) + CMSG_SPACE(sizeof(std::uint32_t)) + 64];
  can_frame raw_frame{};
  iovec vector{&raw_frame, sizeof raw_frame};
  msghdr header{};
  header.msg_iov = &vector;
  header.msg_iovlen = 1;
  header.msg_control = control;
  header.msg_controllen = sizeof control;
  const ssize_t length = ::recvmsg(socket_fd_, &header, flags);
  if (length < 0) {
    if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
      last_error_ = map_io_errno(errno);
    return false;
  }
  if (length != static_cast<ssize_t>(sizeof raw_frame)) return true;  // not a classic CAN frame

  std::optional<std::int64_t> realtime_ns;
  for (cmsghdr* c = CMSG_FIRSTHDR(&header); c != nullptr; c = CMSG_NXTHDR(&header, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SO_TIMESTAMPING) {
      scm_timestamping stamps{};
      std::memcpy(&stamps, CMSG_DATA(c), sizeof stamps);
      if (stamps.ts[0].tv_sec != 0 || stamps.ts[0].tv_nsec != 0) {
        realtime_ns =
            static_cast<std::int64_t>(stamps.ts[0].tv_sec) * 1'000'000'000 + stamps.ts[0].tv_nsec;
      }
    } else if (c->cmsg_type == SO_TIMESTAMP) {
      timeval stamp{};
      std::memcpy(&stamp, CMSG_DATA(c), sizeof stamp);
      realtime_ns = static_cast<std::int64_t>(stamp.tv_sec) * 1'000'000'000 +
                    static_cast<std::int64_t>(stamp.tv_usec) * 1'000;
    } else if (c->cmsg_type == SO_RXQ_OVFL) {
      std::uint32_t drops = 0;
      std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
      stats_.kernel_drops += drops - last_drop_count_;  // wraps like the kernel's counter
      last_drop_count_ = drops;
    }
  }

  KernelFrame raw;
  raw.can_id = raw_frame.can_id;
  raw.len = raw_frame.len;
  raw.len8_dlc = raw_frame.len8_dlc;
  std::copy(std::begin(raw_frame.data), std::end(raw_frame.data), raw.data.begin());
  const auto frame = from_kernel_frame(raw);
  if (!frame) return true;
  TimedFrame timed;
  timed.frame = *frame;
  timed.own = (header.msg_flags & MSG_CONFIRM) != 0;
  if (realtime_ns) {
    timed.timestamp = to_bus_time(*realtime_ns);
  } else {
    timed.timestamp = now();
    if (timestamp_source_ != TimestampSource::none) ++stats_.missing_timestamps;
  }
  if (accept(timed)) out = timed;
  return true;
}

TimePoint SocketCanBus::to_bus_time(std::int64_t realtime_ns) {
  // Follow a stepped wall clock (settimeofday, an NTP step; slewing moves both clocks alike):
  // at most every 100 ms, re-measure realtime - monotonic and adopt it when it moved by more
  // than 1 ms. Smaller differences are measurement noise and would break monotonicity.
  const TimePoint stamp(Duration(realtime_ns) - conversion_offset_);
  if (stamp - last_clock_check_ < kClockCheckInterval && stamp >= last_clock_check_) return stamp;
  const Duration current = measure_unix_offset();
  if (current - conversion_offset_ > kClockStepThreshold ||
      conversion_offset_ - current > kClockStepThreshold) {
    conversion_offset_ = current;
  }
  last_clock_check_ = TimePoint(Duration(realtime_ns) - conversion_offset_);
  return last_clock_check_;
}

bool SocketCanBus::accept(const TimedFrame& timed) {
  ++stats_.frames_received;
  if (timed.frame.is_error()) {
    ++stats_.error_frames;
    const auto info = decode_error_frame(timed.frame);
    if (info->has(error_class::kBusOff)) bus_off_ = true;
    if (info->has(error_class::kRestarted) ||
        (info->has(error_class::kController) &&
         (info->controller & controller_status::kActive) != 0)) {
      bus_off_ = false;
    }
  }
  if ((timed.own && !options_.loopback) || !passes_filters(timed.frame)) {
    ++stats_.frames_filtered;
    return false;
  }
  return true;
}

}  // namespace drivecheck::can
