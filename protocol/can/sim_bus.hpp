// A deterministic discrete-event simulation of one classic CAN bus, and the ports (Bus) that
// nodes attach to it with. One thread runs the whole network: whichever port or the SimBus
// itself waits (receive, run_until) advances simulated time from event to event, running every
// node's frame handlers and timers in time order.
//
// The wire:
//  - A frame occupies the wire for frame_bits() bit times (frame_timing.hpp) at the configured
//    bit rate: SOF at t0, end of frame (end of EOF) at t1 = t0 + (bits - 3) bit times, wire free
//    after the intermission at t2 = t0 + bits bit times.
//  - Each port has one FIFO transmit queue (a CAN controller's single TX FIFO). When the wire is
//    free, the heads of all queues contend by arbitration over the real arbitration field,
//    dominant 0 winning bit by bit:
//      base format:     ID(11) RTR IDE=0
//      extended format: ID-A(11) SRR=1 IDE=1 ID-B(18) RTR
//    so a lower identifier wins, a data frame beats a remote frame with the same identifier, and
//    a base-format frame beats an extended one with the same 11 leading identifier bits. Equal
//    arbitration fields from two ports (which on a real bus end in a bit error) are resolved by
//    attach order, earlier port first. Frames queued at the same instant contend together:
//    arbitration at time t happens after every timer and delivery due at t.
//  - At t1 every attached port, in attach order, gets the frame (TimedFrame::timestamp = t1)
//    if it passes the port's filters: through its frame handler if one is set, else into its
//    receive queue. The sender gets it only with loopback on (TimedFrame::own = true).
//    Monitors (SimBus::add_monitor) see every frame that reached the receivers, before the
//    ports do.
//  - Events at the same time run in the order they were scheduled (a sequence number), so
//    the same program with the same seed gives the same trace, bit for bit.
//
// Fault hooks (SimBus::drop, delay, corrupt, duplicate; SimPort::set_bus_off) pick frames with
// a FaultRule: a SocketCAN filter, optionally the sending port's name, a time window, a
// probability drawn from the bus's seeded generator, and a maximum number of hits.
//  - drop:      the frame takes its time on the wire but no receiver and no monitor gets it
//               (the sender's loopback echo still comes: it believes it sent the frame).
//  - delay:     the frame enters arbitration `by` later than it was queued; like a slow
//               controller, it holds back the frames queued behind it on that port.
//  - corrupt:   receivers and monitors get a changed frame (flipped data bits and/or another
//               DLC); the sender's echo is the original.
//  - duplicate: after the frame, the sender transmits it again `copies` times (what a
//               retransmission after a late error looks like to the receivers); the copies
//               arbitrate normally and are exempt from fault rules. The sender's echo comes once.
//  - bus-off:   the port's send() fails with BusError::bus_off, its transmit queue is discarded,
//               and it receives nothing until set_bus_off(false) (recovery, immediate).
// Drop, corrupt and duplicate are decided at the end of the frame, delay when it is queued;
// rules are tried in the order they were added.
//
// Threads: one thread uses a bus and its ports; only stop() may come from elsewhere (another
// thread or a signal handler). run_until() and receive() called from a handler or timer
// (which the Bus contract forbids) return at once without running anything.
//
// Errors are values: send() returns BusError::invalid_frame for error frames, identifiers out
// of range and DLC > 15, BusError::bus_off and BusError::queue_full as above.
//
// Lifetime: the SimBus and its ports share the network; either may be destroyed first.
// Destroying a port detaches it (its queues, filters and timers go); a handler may destroy
// any port, its own included.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/can/frame_timing.hpp"

namespace drivecheck::can {

namespace detail {
class SimNetwork;
}  // namespace detail

struct SimBusConfig {
  std::uint32_t bitrate = 500'000;  // bit/s, 1..1'000'000 (classic CAN)
  BitStuffing stuffing = BitStuffing::exact;
  std::uint64_t seed = 1;              // all randomness (fault probabilities, random bit flips)
  Duration unix_offset{0};             // Clock::unix_offset() of the bus and every port
  std::size_t tx_queue_limit = 1024;   // frames queued per port; more: BusError::queue_full
  std::size_t rx_queue_limit = 65536;  // frames waiting for receive() per port; more: dropped
};

// Which frames a fault hook applies to. The defaults match every frame, every time.
struct FaultRule {
  Filter filter{};           // SocketCAN semantics (bus.hpp); mask 0 matches all frames
  std::string sender{};      // name of the sending port; empty: any
  double probability = 1.0;  // chance per matching frame, drawn from SimBusConfig::seed
  std::uint64_t max_count = std::numeric_limits<std::uint64_t>::max();  // hits, then inert
  TimePoint not_before{};          // active from this simulated time...
  TimePoint not_after = kForever;  // ...up to and including this one
};

// How a corrupt hook changes a frame. With neither a flip mask nor a DLC given, one bit of
// the payload, chosen by the seeded generator, is flipped (frames without payload then do not
// count as hits).
struct Corruption {
  std::array<std::uint8_t, 8> flip{};  // XOR mask over the data bytes
  std::optional<std::uint8_t> dlc{};   // new DLC, 0..15 (bits above are ignored); data past
                                       // the new length reads as zero
};

using FaultId = std::uint64_t;
using MonitorId = std::uint64_t;

class SimBus;

// One node's attachment to a SimBus. See bus.hpp for the contract of each Bus function.
class SimPort final : public Bus {
 public:
  ~SimPort() override;
  SimPort(const SimPort&) = delete;
  SimPort& operator=(const SimPort&) = delete;

  TimePoint now() const override;
  Duration unix_offset() const override;

  std::error_code send(const Frame& frame) override;
  std::size_t queued(std::uint32_t id, IdFormat format) const override;
  // Returns nullopt at `deadline`, with now() == deadline, when nothing came. With kForever
  // and no event left anywhere in the network (nothing could ever arrive), nullopt at once.
  std::optional<TimedFrame> receive(TimePoint deadline) override;
  void set_frame_handler(FrameHandler handler) override;
  void set_filters(std::span<const Filter> filters) override;
  void set_loopback(bool enabled) override;
  // Returns kNoTimer (and never calls `callback`) only when 2^24 timers are pending at once.
  TimerId start_timer(TimePoint at, TimerCallback callback) override;
  void cancel_timer(TimerId id) override;
  void run_until(TimePoint deadline) override;
  void stop() override;

  const std::string& name() const;
  // Bus-off on: sends fail with BusError::bus_off, the transmit queue is discarded, nothing is
  // received. Off: the node is back (recovery).
  void set_bus_off(bool bus_off);
  bool bus_off() const;
  // Frames lost because the receive queue was full (SimBusConfig::rx_queue_limit).
  std::uint64_t rx_dropped() const;

 private:
  friend class SimBus;
  SimPort(std::shared_ptr<detail::SimNetwork> network, std::uint32_t index);

  std::shared_ptr<detail::SimNetwork> network_;
  std::uint32_t index_;
};

class SimBus final : public Clock {
 public:
  // Throws std::invalid_argument when config.bitrate is 0 or above 1'000'000.
  explicit SimBus(SimBusConfig config = {});
  ~SimBus() override;
  SimBus(const SimBus&) = delete;
  SimBus& operator=(const SimBus&) = delete;

  // A new node on the bus. Names need not be unique; FaultRule::sender matches by name.
  std::unique_ptr<SimPort> attach(std::string name);

  TimePoint now() const override;
  Duration unix_offset() const override;
  const SimBusConfig& config() const;

  // Runs the whole network until `deadline` (then now() == deadline), until stop(), or, with
  // deadline kForever, until no event is left.
  void run_until(TimePoint deadline);
  void run_for(Duration duration) { run_until(now() + duration); }
  // Makes the current or next run_until()/receive() on this bus or any port return early.
  // Safe from a signal handler.
  void stop();
  // The bus as a new one with the same configuration and the same ports: time 0, nothing
  // queued, on the wire or waiting in a receive queue, no pending stop, no timer (pending ones
  // are dropped without running; their ids stay invalid, so cancelling one does nothing), the
  // generator at SimBusConfig::seed, frames_on_wire(), busy_time(), fault hits and every
  // port's rx_dropped() at 0, no port in bus-off. Kept: the ports with their names, frame
  // handlers, filters and loopback, the monitors and the fault rules. A network built the
  // same way on a reset bus runs exactly as on a new one (fuzz targets reuse one bus per
  // input). Owners of timers must forget them (DeadlineTimer::disarm()). False, and nothing
  // done, from inside a handler, timer or monitor (which the Bus contract forbids).
  bool reset();

  // `monitor` sees every frame that reaches the receivers, at end-of-frame time, own = false.
  MonitorId add_monitor(std::function<void(const TimedFrame&)> monitor);
  void remove_monitor(MonitorId id);

  FaultId drop(FaultRule rule);
  FaultId delay(FaultRule rule, Duration by);
  FaultId corrupt(FaultRule rule, Corruption corruption = {});
  FaultId duplicate(FaultRule rule, std::uint32_t copies = 1);
  // Deactivates a fault hook; its hit count stays readable.
  void remove_fault(FaultId id);
  // How many frames a fault hook has changed so far (0 for unknown ids).
  std::uint64_t fault_hits(FaultId id) const;

  // Frames transmitted so far (every copy of a duplicated frame counts, dropped ones too).
  std::uint64_t frames_on_wire() const;
  // Total time the wire carried frames (SOF to end of intermission): bus load = busy / elapsed.
  Duration busy_time() const;
  // Timer events held for the future, including some of cancelled timers (diagnostics: stays
  // within about twice the pending timers however many are cancelled).
  std::size_t timer_events() const;

 private:
  std::shared_ptr<detail::SimNetwork> network_;
};

}  // namespace drivecheck::can
