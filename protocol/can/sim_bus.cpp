#include "protocol/can/sim_bus.hpp"

#include <algorithm>
#include <atomic>
#include <bit>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

namespace drivecheck::can {
namespace detail {
namespace {

// stop() stores to an atomic<bool>: async-signal-safe only if it is lock-free.
static_assert(std::atomic<bool>::is_always_lock_free);

constexpr std::uint32_t kMaxBitrate = 1'000'000;
constexpr std::uint32_t kNoPort = std::numeric_limits<std::uint32_t>::max();

// Timer ids: a serial number (never reused) above the index of the slot holding the callback.
constexpr unsigned kTimerSlotBits = 24;
constexpr std::uint64_t kTimerSlotMask = (std::uint64_t{1} << kTimerSlotBits) - 1;
constexpr std::uint64_t kMaxTimerSerial = (std::uint64_t{1} << (64 - kTimerSlotBits)) - 1;

TimePoint saturating_add(TimePoint at, Duration by) {
  if (by > Duration::zero() && at > kForever - by) return kForever;
  return at + by;
}

// A FIFO over a power-of-two ring that grows by doubling and never shrinks: after warm-up,
// pushing and popping allocate nothing.
template <class T>
class RingQueue {
 public:
  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }
  T& front() { return items_[head_]; }
  const T& operator[](std::size_t i) const { return items_[(head_ + i) & (items_.size() - 1)]; }
  void push_back(const T& item) {
    if (size_ == items_.size()) grow();
    items_[(head_ + size_) & (items_.size() - 1)] = item;
    ++size_;
  }
  void push_front(const T& item) {
    if (size_ == items_.size()) grow();
    head_ = (head_ + items_.size() - 1) & (items_.size() - 1);
    items_[head_] = item;
    ++size_;
  }
  void pop_front() {
    head_ = (head_ + 1) & (items_.size() - 1);
    --size_;
  }
  void clear() {
    head_ = 0;
    size_ = 0;
  }

 private:
  void grow() {
    std::vector<T> larger(std::max<std::size_t>(8, items_.size() * 2));
    for (std::size_t i = 0; i < size_; ++i)
      larger[i] = items_[(head_ + i) & (items_.size() - 1)];
    items_.swap(larger);
    head_ = 0;
  }

  std::vector<T> items_;
  std::size_t head_ = 0;
  std::size_t size_ = 0;
};

bool sendable(const Frame& frame) {
  if (frame.is_error() || frame.dlc > 15) return false;
  return frame.id <= (frame.is_extended() ? kMaxExtendedId : kMaxStandardId);
}

// The arbitration field as transmitted, MSB first in a 32-bit word; the lower word wins.
//   base:     ID(11) RTR IDE=0, then zeros (a base frame's arbitration is over after IDE)
//   extended: ID-A(11) SRR=1 IDE=1 ID-B(18) RTR
std::uint32_t arbitration_key(const Frame& frame) {
  const std::uint32_t rtr = frame.is_remote() ? 1 : 0;
  if (!frame.is_extended()) return frame.id << 21 | rtr << 20;
  return (frame.id >> 18) << 21 | 1u << 20 | 1u << 19 | (frame.id & 0x3FFFF) << 1 | rtr;
}

struct TxEntry {
  Frame frame;
  TimePoint eligible_at{};  // may enter arbitration from then on (delay hook)
  std::uint32_t key = 0;    // arbitration_key(frame)
  bool exempt = false;      // a duplicate's copy: no fault rules, no loopback echo
};

struct PortState {
  std::string name;
  bool attached = true;
  bool loopback = false;
  bool bus_off = false;
  bool in_handler = false;
  bool handler_replaced = false;  // set_frame_handler() from inside the handler
  Bus::FrameHandler handler;
  Bus::FrameHandler next_handler;
  std::vector<Filter> filters;
  RingQueue<TxEntry> tx;
  RingQueue<TimedFrame> rx;
  std::uint64_t rx_dropped = 0;
};

struct TimerEvent {
  TimePoint at;
  std::uint64_t seq;
  TimerId id;
};

// Min-heap order for std::push_heap/pop_heap: the earliest (at, seq) on top.
struct LaterTimer {
  bool operator()(const TimerEvent& a, const TimerEvent& b) const {
    return a.at != b.at ? a.at > b.at : a.seq > b.seq;
  }
};

struct TimerSlot {
  TimerId id = kNoTimer;  // kNoTimer: free
  std::uint32_t port = 0;
  bool in_heap = false;  // an event for it is in the timer heap
  Bus::TimerCallback callback;
};

// Cancelled timers leave their events in the heap (skipped when due). Once more than this
// many, and more than half the heap, are stale, the heap is rebuilt without them.
constexpr std::size_t kStaleTimerEventsBeforeCompaction = 1024;

enum class FaultKind : std::uint8_t { drop, delay, corrupt, duplicate };

struct Fault {
  FaultKind kind = FaultKind::drop;
  FaultRule rule;
  Duration delay{};          // FaultKind::delay
  Corruption corruption{};   // FaultKind::corrupt
  std::uint32_t copies = 0;  // FaultKind::duplicate
  FaultId id = 0;
  std::uint64_t hits = 0;
  bool active = true;
};

Fault make_fault(FaultKind kind, FaultRule rule) {
  Fault fault;
  fault.kind = kind;
  fault.rule = std::move(rule);
  return fault;
}

struct Monitor {
  MonitorId id;
  std::function<void(const TimedFrame&)> callback;
};

// Sets a flag for a scope; clears it however the scope is left (handlers may throw).
class FlagGuard {
 public:
  explicit FlagGuard(bool& flag) : flag_(flag) { flag_ = true; }
  ~FlagGuard() { flag_ = false; }
  FlagGuard(const FlagGuard&) = delete;
  FlagGuard& operator=(const FlagGuard&) = delete;

 private:
  bool& flag_;
};

enum class WireState : std::uint8_t {
  idle,          // nothing queued that could start
  arbitration,   // the queue heads contend at wire_event_at_
  transmitting,  // on_wire_ ends at wire_event_at_
};

}  // namespace

class SimNetwork {
 public:
  explicit SimNetwork(SimBusConfig config) : config_(std::move(config)), rng_(config_.seed) {
    if (config_.bitrate == 0 || config_.bitrate > kMaxBitrate) {
      throw std::invalid_argument("SimBusConfig::bitrate must be 1..1000000 bit/s");
    }
    if (1'000'000'000u % config_.bitrate == 0) ns_per_bit_ = 1'000'000'000u / config_.bitrate;
  }

  const SimBusConfig& config() const { return config_; }
  TimePoint now() const { return now_; }

  // ---- ports

  std::uint32_t attach(std::string name) {
    const auto index = static_cast<std::uint32_t>(ports_.size());
    ports_.push_back(std::make_unique<PortState>());
    ports_.back()->name = std::move(name);
    if (pending_words_.size() * 64 < ports_.size()) pending_words_.push_back(0);
    return index;
  }

  void detach(std::uint32_t index) {
    PortState& port = *ports_[index];
    port.attached = false;
    discard_tx(index);
    port.rx.clear();
    port.filters.clear();
    port.next_handler = nullptr;
    port.handler_replaced = port.in_handler;  // then the handler is reset once it returns
    if (!port.in_handler) port.handler = nullptr;
    for (TimerSlot& slot : timers_) {
      if (slot.id != kNoTimer && slot.port == index) release_timer(slot);
    }
  }

  PortState& port(std::uint32_t index) { return *ports_[index]; }

  void set_bus_off(std::uint32_t index, bool bus_off) {
    ports_[index]->bus_off = bus_off;
    if (bus_off) discard_tx(index);
  }

  void set_handler(std::uint32_t index, Bus::FrameHandler handler) {
    PortState& port = *ports_[index];
    if (port.in_handler) {
      port.next_handler = std::move(handler);
      port.handler_replaced = true;
    } else {
      port.handler = std::move(handler);
    }
  }

  // ---- sending

  std::size_t queued(std::uint32_t index, std::uint32_t id, IdFormat format) const {
    const PortState& port = *ports_[index];
    std::size_t count = 0;
    for (std::size_t i = 0; i < port.tx.size(); ++i) {
      const Frame& frame = port.tx[i].frame;
      if (frame.id == id && frame.format == format) ++count;
    }
    return count;
  }

  std::error_code send(std::uint32_t index, const Frame& frame) {
    PortState& port = *ports_[index];
    if (!sendable(frame)) return make_error_code(BusError::invalid_frame);
    if (port.bus_off) return make_error_code(BusError::bus_off);
    if (port.tx.size() >= config_.tx_queue_limit) return make_error_code(BusError::queue_full);

    TxEntry entry;
    entry.frame = frame;
    // Bytes past length() are not on the wire; receivers see them as zero.
    std::fill(entry.frame.data.begin() + static_cast<std::ptrdiff_t>(entry.frame.length()),
              entry.frame.data.end(), std::uint8_t{0});
    entry.key = arbitration_key(entry.frame);
    entry.eligible_at = now_;
    if (!faults_.empty()) {
      for (Fault& fault : faults_) {
        if (fault.kind == FaultKind::delay && applies(fault, index, entry.frame)) {
          ++fault.hits;
          entry.eligible_at = saturating_add(entry.eligible_at, fault.delay);
        }
      }
    }
    const bool was_empty = port.tx.empty();
    port.tx.push_back(entry);
    ++queued_;
    if (was_empty) {
      pending_words_[index / 64] |= std::uint64_t{1} << (index % 64);
      schedule_arbitration(entry.eligible_at);
    }
    return {};
  }

  // ---- timers

  TimerId start_timer(std::uint32_t index, TimePoint at, Bus::TimerCallback callback) {
    std::uint32_t slot_index;
    if (!free_timer_slots_.empty()) {
      slot_index = free_timer_slots_.back();
      free_timer_slots_.pop_back();
    } else {
      if (timers_.size() > kTimerSlotMask || timer_serial_ >= kMaxTimerSerial) return kNoTimer;
      slot_index = static_cast<std::uint32_t>(timers_.size());
      timers_.emplace_back();
    }
    const TimerId id = (++timer_serial_ << kTimerSlotBits) | slot_index;
    TimerSlot& slot = timers_[slot_index];
    slot.id = id;
    slot.port = index;
    slot.callback = std::move(callback);
    // A timer at kForever never fires; it only holds its slot until cancelled.
    slot.in_heap = at != kForever;
    if (slot.in_heap) {
      timer_heap_.push_back({std::max(at, now_), seq_++, id});
      std::push_heap(timer_heap_.begin(), timer_heap_.end(), LaterTimer{});
    }
    return id;
  }

  void cancel_timer(std::uint32_t index, TimerId id) {
    const std::uint64_t slot_index = id & kTimerSlotMask;
    if (slot_index >= timers_.size()) return;
    TimerSlot& slot = timers_[slot_index];
    if (slot.id == id && id != kNoTimer && slot.port == index) release_timer(slot);
  }

  // ---- running

  void run_until(TimePoint deadline) {
    if (running_) return;  // from a handler: the contract forbids it; ignore, never recurse
    bool stopped = false;
    {
      const FlagGuard running(running_);
      while (true) {
        if (take_stop()) {
          stopped = true;
          break;
        }
        if (!step(deadline)) break;
      }
    }
    if (!stopped) advance_to(deadline);
  }

  std::optional<TimedFrame> receive(std::uint32_t index, TimePoint deadline) {
    PortState& port = *ports_[index];
    if (running_) return pop_rx(port);
    std::optional<TimedFrame> frame;
    bool stopped = false;
    {
      const FlagGuard running(running_);
      while (true) {
        if (take_stop()) {
          stopped = true;
          break;
        }
        if ((frame = pop_rx(port)) || !step(deadline)) break;
      }
    }
    if (!frame && !stopped) advance_to(deadline);
    return frame;
  }

  void stop() { stop_.store(true, std::memory_order_relaxed); }

  // SimBus::reset.
  bool reset() {
    if (running_) return false;  // from a handler or timer: the contract forbids it
    now_ = TimePoint{};
    seq_ = 0;
    rng_.seed(config_.seed);
    stop_.store(false, std::memory_order_relaxed);
    for (const auto& port : ports_) {
      port->tx.clear();
      port->rx.clear();
      port->rx_dropped = 0;
      port->bus_off = false;
    }
    std::fill(pending_words_.begin(), pending_words_.end(), std::uint64_t{0});
    queued_ = 0;
    // Pending timers go without running. Serial numbers go on, so that an id from before the
    // reset never names a timer started after it. The free slots are handed out in ascending
    // order again, as a new bus would.
    timer_heap_.clear();
    free_timer_slots_.clear();
    for (std::size_t i = timers_.size(); i-- > 0;) {
      timers_[i].id = kNoTimer;
      timers_[i].in_heap = false;
      timers_[i].callback = nullptr;
      free_timer_slots_.push_back(static_cast<std::uint32_t>(i));
    }
    stale_timer_events_ = 0;
    wire_state_ = WireState::idle;
    wire_event_at_ = TimePoint{};
    wire_seq_ = 0;
    wire_free_at_ = TimePoint{};
    on_wire_ = TxEntry{};
    on_wire_port_ = kNoPort;
    frames_on_wire_ = 0;
    busy_time_ = Duration{};
    for (Fault& fault : faults_)
      fault.hits = 0;
    return true;
  }

  // ---- monitors and faults

  MonitorId add_monitor(std::function<void(const TimedFrame&)> callback) {
    const MonitorId id = ++monitor_serial_;
    monitors_.push_back(std::make_unique<Monitor>(Monitor{id, std::move(callback)}));
    return id;
  }

  void remove_monitor(MonitorId id) {
    for (auto& monitor : monitors_) {
      if (monitor && monitor->id == id) {
        // While frames are being delivered the monitor may be running: reset it afterwards.
        if (delivering_) {
          removed_monitor_ = true;
          monitor->id = 0;
        } else {
          monitor.reset();
        }
      }
    }
    if (!delivering_) std::erase(monitors_, nullptr);
  }

  FaultId add_fault(Fault fault) {
    fault.id = ++fault_serial_;
    faults_.push_back(std::move(fault));
    return faults_.back().id;
  }

  void remove_fault(FaultId id) {
    for (Fault& fault : faults_) {
      if (fault.id == id) fault.active = false;
    }
  }

  std::uint64_t fault_hits(FaultId id) const {
    for (const Fault& fault : faults_) {
      if (fault.id == id) return fault.hits;
    }
    return 0;
  }

  std::uint64_t frames_on_wire() const { return frames_on_wire_; }
  Duration busy_time() const { return busy_time_; }
  std::size_t timer_events() const { return timer_heap_.size(); }

 private:
  bool take_stop() { return stop_.load(std::memory_order_relaxed) && stop_.exchange(false); }

  void advance_to(TimePoint deadline) {
    if (deadline != kForever && deadline > now_) now_ = deadline;
  }

  static std::optional<TimedFrame> pop_rx(PortState& port) {
    if (port.rx.empty()) return std::nullopt;
    TimedFrame frame = port.rx.front();
    port.rx.pop_front();
    return frame;
  }

  Duration bits_to_duration(std::uint32_t bits) const {
    if (ns_per_bit_ != 0) return Duration(static_cast<Duration::rep>(bits) * ns_per_bit_);
    return bit_duration(bits, config_.bitrate);
  }

  void discard_tx(std::uint32_t index) {
    PortState& port = *ports_[index];
    queued_ -= port.tx.size();
    port.tx.clear();
    pending_words_[index / 64] &= ~(std::uint64_t{1} << (index % 64));
  }

  // Frees a timer's slot; a pending event of it becomes stale.
  void release_timer(TimerSlot& slot) {
    if (slot.in_heap) ++stale_timer_events_;
    slot.id = kNoTimer;
    slot.in_heap = false;
    slot.callback = nullptr;
    free_timer_slots_.push_back(static_cast<std::uint32_t>(&slot - timers_.data()));
    if (stale_timer_events_ > kStaleTimerEventsBeforeCompaction &&
        stale_timer_events_ * 2 > timer_heap_.size()) {
      compact_timer_heap();
    }
  }

  // Removes stale events. The order of the rest is unchanged: (at, seq) is unique.
  void compact_timer_heap() {
    std::erase_if(timer_heap_, [this](const TimerEvent& event) {
      return timers_[event.id & kTimerSlotMask].id != event.id;
    });
    std::make_heap(timer_heap_.begin(), timer_heap_.end(), LaterTimer{});
    stale_timer_events_ = 0;
  }

  // A queue head became eligible at `eligible_at`: make sure arbitration happens then (or as
  // soon as the wire is free).
  void schedule_arbitration(TimePoint eligible_at) {
    const TimePoint at = std::max({now_, wire_free_at_, eligible_at});
    if (wire_state_ == WireState::idle) {
      wire_state_ = WireState::arbitration;
      wire_event_at_ = at;
    } else if (wire_state_ == WireState::arbitration && at < wire_event_at_) {
      wire_event_at_ = at;
    }
  }

  // Runs the next event if it is due no later than `limit`. False when there is none.
  bool step(TimePoint limit) {
    const bool have_timer = !timer_heap_.empty();
    const bool have_wire = wire_state_ != WireState::idle;
    bool take_wire;
    if (have_wire && have_timer) {
      const TimerEvent& timer = timer_heap_.front();
      // Arbitration at t comes after everything else due at t; end of frame by sequence.
      take_wire = wire_event_at_ < timer.at ||
                  (wire_event_at_ == timer.at && wire_state_ == WireState::transmitting &&
                   wire_seq_ < timer.seq);
    } else if (have_wire || have_timer) {
      take_wire = have_wire;
    } else {
      return false;
    }
    const TimePoint at = take_wire ? wire_event_at_ : timer_heap_.front().at;
    if (at > limit) return false;
    now_ = at;
    if (!take_wire) {
      fire_timer();
    } else if (wire_state_ == WireState::arbitration) {
      arbitrate();
    } else {
      end_of_frame();
    }
    return true;
  }

  void fire_timer() {
    std::pop_heap(timer_heap_.begin(), timer_heap_.end(), LaterTimer{});
    const TimerId id = timer_heap_.back().id;
    timer_heap_.pop_back();
    TimerSlot& slot = timers_[id & kTimerSlotMask];
    if (slot.id != id) {  // cancelled
      --stale_timer_events_;
      return;
    }
    Bus::TimerCallback callback = std::move(slot.callback);
    slot.in_heap = false;
    release_timer(slot);
    callback();
  }

  void arbitrate() {
    wire_state_ = WireState::idle;
    std::uint32_t winner = kNoPort;
    std::uint32_t winner_key = 0;
    TimePoint next_eligible = kForever;
    for (std::size_t word = 0; word < pending_words_.size(); ++word) {
      for (std::uint64_t bits = pending_words_[word]; bits != 0; bits &= bits - 1) {
        const auto index = static_cast<std::uint32_t>(word * 64 + std::countr_zero(bits));
        const TxEntry& head = ports_[index]->tx.front();
        if (head.eligible_at > now_) {
          next_eligible = std::min(next_eligible, head.eligible_at);
        } else if (winner == kNoPort || head.key < winner_key) {
          winner = index;  // ascending index: on equal keys the earlier port wins
          winner_key = head.key;
        }
      }
    }
    if (winner == kNoPort) {
      if (next_eligible != kForever) schedule_arbitration(next_eligible);
      return;
    }
    PortState& port = *ports_[winner];
    on_wire_ = port.tx.front();
    on_wire_port_ = winner;
    port.tx.pop_front();
    --queued_;
    if (port.tx.empty()) pending_words_[winner / 64] &= ~(std::uint64_t{1} << (winner % 64));

    const std::uint32_t bits = frame_bits(on_wire_.frame, config_.stuffing);
    wire_state_ = WireState::transmitting;
    wire_event_at_ = now_ + bits_to_duration(bits - 3);
    wire_free_at_ = now_ + bits_to_duration(bits);
    wire_seq_ = seq_++;
    busy_time_ += wire_free_at_ - now_;
  }

  void end_of_frame() {
    wire_state_ = WireState::idle;
    ++frames_on_wire_;
    const std::uint32_t sender = on_wire_port_;
    const TxEntry sent = on_wire_;
    const TimedFrame echo{sent.frame, now_, true};
    TimedFrame seen{sent.frame, now_, false};
    bool dropped = false;
    std::uint32_t copies = 0;
    if (!sent.exempt && !faults_.empty()) apply_wire_faults(sender, seen.frame, dropped, copies);

    // Queue the retransmissions and the next arbitration before any handler runs (handlers
    // may queue more, and a throwing handler must not leave frames stranded).
    PortState& sender_port = *ports_[sender];
    if (copies > 0 && sender_port.attached && !sender_port.bus_off) {
      TxEntry copy = sent;
      copy.exempt = true;
      copy.eligible_at = now_;
      for (std::uint32_t i = 0; i < copies; ++i)
        sender_port.tx.push_front(copy);
      queued_ += copies;
      pending_words_[sender / 64] |= std::uint64_t{1} << (sender % 64);
    }
    if (queued_ > 0) schedule_arbitration(wire_free_at_);

    {
      const FlagGuard delivering(delivering_);
      if (!dropped) {
        for (std::size_t i = 0; i < monitors_.size(); ++i) {
          if (monitors_[i] && monitors_[i]->id != 0) monitors_[i]->callback(seen);
        }
      }
      const std::size_t port_count = ports_.size();  // ports attached by a handler: next frame
      for (std::size_t i = 0; i < port_count; ++i) {
        if (i != sender) {
          if (!dropped) deliver(*ports_[i], seen);
        } else if (!sent.exempt && ports_[i]->loopback) {
          deliver(*ports_[i], echo);
        }
      }
    }
    if (removed_monitor_) {
      removed_monitor_ = false;
      std::erase_if(monitors_, [](const auto& monitor) { return !monitor || monitor->id == 0; });
    }
  }

  void deliver(PortState& port, const TimedFrame& frame) {
    if (!port.attached || port.bus_off) return;
    if (!port.filters.empty() &&
        std::none_of(port.filters.begin(), port.filters.end(),
                     [&](const Filter& filter) { return filter.matches(frame.frame); })) {
      return;
    }
    if (port.handler) {
      {
        const FlagGuard in_handler(port.in_handler);
        port.handler(frame);
      }
      if (port.handler_replaced) {
        port.handler = std::move(port.next_handler);
        port.next_handler = nullptr;
        port.handler_replaced = false;
      }
    } else if (port.rx.size() < config_.rx_queue_limit) {
      port.rx.push_back(frame);
    } else {
      ++port.rx_dropped;
    }
  }

  // Uniform in [0, 1) from the top 53 bits of the generator (std::uniform_*_distribution
  // differs between standard libraries; this does not).
  double uniform() { return static_cast<double>(rng_() >> 11) * 0x1.0p-53; }
  // Uniform in [0, n), n > 0, by multiply-shift of 32 random bits.
  std::uint32_t below(std::uint32_t n) {
    return static_cast<std::uint32_t>(((rng_() >> 32) * n) >> 32);
  }

  // Whether `fault` applies to `frame` from `sender` now; draws from the generator only for
  // frames that pass every other condition and only when the probability is below 1.
  bool applies(const Fault& fault, std::uint32_t sender, const Frame& frame) {
    const FaultRule& rule = fault.rule;
    if (!fault.active || fault.hits >= rule.max_count) return false;
    if (now_ < rule.not_before || now_ > rule.not_after) return false;
    if (!rule.filter.matches(frame)) return false;
    if (!rule.sender.empty() && ports_[sender]->name != rule.sender) return false;
    if (rule.probability >= 1.0) return true;
    if (!(rule.probability > 0.0)) return false;  // also NaN
    return uniform() < rule.probability;
  }

  // Applies a corruption; false when the frame came out unchanged.
  bool corrupt(Frame& frame, const Corruption& corruption) {
    const Frame before = frame;
    const bool random =
        !corruption.dlc && std::all_of(corruption.flip.begin(), corruption.flip.end(),
                                       [](std::uint8_t byte) { return byte == 0; });
    if (random) {
      if (frame.length() == 0) return false;
      const std::uint32_t bit = below(static_cast<std::uint32_t>(frame.length() * 8));
      frame.data[bit / 8] ^= static_cast<std::uint8_t>(0x80u >> (bit % 8));
      return true;
    }
    if (corruption.dlc) frame.dlc = *corruption.dlc & 0xFu;
    for (std::size_t i = 0; i < frame.length(); ++i)
      frame.data[i] ^= corruption.flip[i];
    std::fill(frame.data.begin() + static_cast<std::ptrdiff_t>(frame.length()), frame.data.end(),
              std::uint8_t{0});
    return !(frame == before);
  }

  void apply_wire_faults(std::uint32_t sender, Frame& frame, bool& dropped, std::uint32_t& copies) {
    for (Fault& fault : faults_) {
      if (fault.kind == FaultKind::delay || !applies(fault, sender, frame)) continue;
      switch (fault.kind) {
        case FaultKind::drop:
          ++fault.hits;
          dropped = true;
          return;
        case FaultKind::corrupt:
          if (corrupt(frame, fault.corruption)) ++fault.hits;
          break;
        case FaultKind::duplicate:
          ++fault.hits;
          copies += fault.copies;
          break;
        case FaultKind::delay:
          break;
      }
    }
  }

  SimBusConfig config_;
  std::uint64_t ns_per_bit_ = 0;  // when the bit time is a whole number of nanoseconds
  std::mt19937_64 rng_;
  TimePoint now_{};
  std::uint64_t seq_ = 0;
  std::atomic<bool> stop_{false};
  bool running_ = false;
  bool delivering_ = false;
  bool removed_monitor_ = false;

  std::vector<std::unique_ptr<PortState>> ports_;  // by attach order; detached ones stay
  std::vector<std::uint64_t> pending_words_;       // bit i: port i has frames queued
  std::size_t queued_ = 0;                         // frames queued over all ports

  std::vector<TimerEvent> timer_heap_;
  std::vector<TimerSlot> timers_;
  std::vector<std::uint32_t> free_timer_slots_;
  std::uint64_t timer_serial_ = 0;
  std::size_t stale_timer_events_ = 0;

  WireState wire_state_ = WireState::idle;
  TimePoint wire_event_at_{};
  std::uint64_t wire_seq_ = 0;
  TimePoint wire_free_at_{};
  TxEntry on_wire_;
  std::uint32_t on_wire_port_ = kNoPort;
  std::uint64_t frames_on_wire_ = 0;
  Duration busy_time_{};

  std::vector<std::unique_ptr<Monitor>> monitors_;
  MonitorId monitor_serial_ = 0;
  std::vector<Fault> faults_;
  FaultId fault_serial_ = 0;
};

}  // namespace detail

// ---- SimPort

SimPort::SimPort(std::shared_ptr<detail::SimNetwork> network, std::uint32_t index)
    : network_(std::move(network)), index_(index) {}

SimPort::~SimPort() {
  network_->detach(index_);
}

TimePoint SimPort::now() const {
  return network_->now();
}
Duration SimPort::unix_offset() const {
  return network_->config().unix_offset;
}
std::error_code SimPort::send(const Frame& frame) {
  return network_->send(index_, frame);
}
std::size_t SimPort::queued(std::uint32_t id, IdFormat format) const {
  return network_->queued(index_, id, format);
}
std::optional<TimedFrame> SimPort::receive(TimePoint deadline) {
  return network_->receive(index_, deadline);
}
void SimPort::set_frame_handler(FrameHandler handler) {
  network_->set_handler(index_, std::move(handler));
}
void SimPort::set_filters(std::span<const Filter> filters) {
  network_->port(index_).filters.assign(filters.begin(), filters.end());
}
void SimPort::set_loopback(bool enabled) {
  network_->port(index_).loopback = enabled;
}
TimerId SimPort::start_timer(TimePoint at, TimerCallback callback) {
  return network_->start_timer(index_, at, std::move(callback));
}
void SimPort::cancel_timer(TimerId id) {
  network_->cancel_timer(index_, id);
}
void SimPort::run_until(TimePoint deadline) {
  network_->run_until(deadline);
}
void SimPort::stop() {
  network_->stop();
}
const std::string& SimPort::name() const {
  return network_->port(index_).name;
}
void SimPort::set_bus_off(bool bus_off) {
  network_->set_bus_off(index_, bus_off);
}
bool SimPort::bus_off() const {
  return network_->port(index_).bus_off;
}
std::uint64_t SimPort::rx_dropped() const {
  return network_->port(index_).rx_dropped;
}

// ---- SimBus

SimBus::SimBus(SimBusConfig config)
    : network_(std::make_shared<detail::SimNetwork>(std::move(config))) {}

SimBus::~SimBus() = default;

std::unique_ptr<SimPort> SimBus::attach(std::string name) {
  const std::uint32_t index = network_->attach(std::move(name));
  return std::unique_ptr<SimPort>(new SimPort(network_, index));
}

TimePoint SimBus::now() const {
  return network_->now();
}
Duration SimBus::unix_offset() const {
  return network_->config().unix_offset;
}
const SimBusConfig& SimBus::config() const {
  return network_->config();
}
void SimBus::run_until(TimePoint deadline) {
  network_->run_until(deadline);
}
void SimBus::stop() {
  network_->stop();
}
bool SimBus::reset() {
  return network_->reset();
}

MonitorId SimBus::add_monitor(std::function<void(const TimedFrame&)> monitor) {
  return network_->add_monitor(std::move(monitor));
}
void SimBus::remove_monitor(MonitorId id) {
  network_->remove_monitor(id);
}

FaultId SimBus::drop(FaultRule rule) {
  return network_->add_fault(detail::make_fault(detail::FaultKind::drop, std::move(rule)));
}
FaultId SimBus::delay(FaultRule rule, Duration by) {
  detail::Fault fault = detail::make_fault(detail::FaultKind::delay, std::move(rule));
  fault.delay = by;
  return network_->add_fault(std::move(fault));
}
FaultId SimBus::corrupt(FaultRule rule, Corruption corruption) {
  detail::Fault fault = detail::make_fault(detail::FaultKind::corrupt, std::move(rule));
  fault.corruption = corruption;
  return network_->add_fault(std::move(fault));
}
FaultId SimBus::duplicate(FaultRule rule, std::uint32_t copies) {
  detail::Fault fault = detail::make_fault(detail::FaultKind::duplicate, std::move(rule));
  fault.copies = copies;
  return network_->add_fault(std::move(fault));
}
void SimBus::remove_fault(FaultId id) {
  network_->remove_fault(id);
}
std::uint64_t SimBus::fault_hits(FaultId id) const {
  return network_->fault_hits(id);
}

std::uint64_t SimBus::frames_on_wire() const {
  return network_->frames_on_wire();
}
Duration SimBus::busy_time() const {
  return network_->busy_time();
}
std::size_t SimBus::timer_events() const {
  return network_->timer_events();
}

}  // namespace drivecheck::can
