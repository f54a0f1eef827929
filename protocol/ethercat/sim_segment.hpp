// A simulated EtherCAT segment on simulated time: the master's Link and a line of devices
// (emulated slaves) that every frame passes in order and then passes back. Deterministic: one
// thread, events in time order, ties in the order they were scheduled, one seeded generator.
//
// Timing (100BASE-TX, 10 ns per bit):
//  - on the wire a frame of n bytes (padded to 60) occupies (8 preamble/SFD + n + 4 FCS + 12
//    inter-frame gap) × 80 ns; the master's transmitter sends frames back to back, so a frame
//    starts when the one before it has left;
//  - device k sees the frame's first bit at port 0 at t0 + Σ_{j<=k} cable + Σ_{j<k}
//    processing_j, and processes it then (SegmentDevice::on_frame); the frame turns at the last
//    device and comes back through each device's forwarding path (return_delay) and cable;
//    device k's port 1 sees it coming back at the time passed as `return_arrival` (nullopt for
//    the last device, whose port 1 is closed);
//  - the master receives the frame at its end of frame: first bit back + (8 + n + 4) × 80 ns;
//    returning frames keep their order.
// A segment without devices is an open port: send() fails with LinkError::link_down.
//
// Fault hooks pick frames with a FrameFaultRule (a predicate over the frame's bytes as sent,
// a time window on the send time, a probability from the seeded generator, a maximum number
// of hits):
//  - drop(rule, before_device): the frame is lost before device `before_device` (0: no device
//    sees it; ≥ the number of devices: every device processed it, the master never sees it);
//  - corrupt(rule, corruption): the master receives changed bytes (a device that changes a
//    frame and recomputes its FCS; line noise is a drop, since the next port discards a frame
//    with a bad FCS);
//  - delay(rule, by): the frame comes back `by` later (and holds back the frames behind it);
//  - set_link_down(true): send() fails with link_down and frames on the way are lost.
// Monitors see every frame the master sends (at its end of frame on the wire) and every
// frame it receives, for traces (pcap).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <queue>
#include <random>
#include <span>
#include <unordered_map>
#include <vector>

#include "protocol/ethercat/link.hpp"

namespace drivecheck::ethercat {

class Esc;

// An emulated slave on the segment.
class SegmentDevice {
 public:
  virtual ~SegmentDevice() = default;
  // The frame passes: its first bit reached port 0 at `arrival`; it comes back through port 1
  // at `return_arrival` (nullopt: this device closes the line). Process it in place.
  virtual void on_frame(std::span<std::uint8_t> frame, TimePoint arrival,
                        std::optional<TimePoint> return_arrival) = 0;
};

// A bare ESC as a device (no application behind it).
class EscDevice final : public SegmentDevice {
 public:
  explicit EscDevice(Esc& esc) : esc_(esc) {}
  void on_frame(std::span<std::uint8_t> frame, TimePoint arrival,
                std::optional<TimePoint> return_arrival) override;

 private:
  Esc& esc_;
};

struct DeviceTiming {
  Duration processing_delay = std::chrono::nanoseconds(600);  // port 0 -> EPU -> port 1
  Duration return_delay = std::chrono::nanoseconds(300);      // port 1 -> port 0
  Duration cable_delay = std::chrono::nanoseconds(50);        // cable before port 0 (10 m)
};

struct SimSegmentConfig {
  std::uint64_t seed = 1;
  Duration unix_offset{0};
  std::size_t rx_queue_limit = 65536;  // frames waiting for receive(); more are dropped
};

struct FrameFaultRule {
  std::function<bool(std::span<const std::uint8_t>)> match;  // empty: every frame
  double probability = 1.0;
  std::uint64_t max_count = std::numeric_limits<std::uint64_t>::max();
  TimePoint not_before{};
  TimePoint not_after = kForever;
};

// How corrupt() changes a frame: XOR masks at byte offsets; with none, one random bit of the
// EtherCAT part (after the Ethernet header) is flipped.
struct FrameCorruption {
  std::vector<std::pair<std::size_t, std::uint8_t>> flips;
};

using FaultId = std::uint64_t;
using MonitorId = std::uint64_t;

class SimSegment final : public Link {
 public:
  explicit SimSegment(SimSegmentConfig config = {});
  ~SimSegment() override;
  SimSegment(const SimSegment&) = delete;
  SimSegment& operator=(const SimSegment&) = delete;

  // Appends a device to the line (it must outlive the segment or be detached first).
  void attach(SegmentDevice& device, DeviceTiming timing = {});
  void detach_all();
  std::size_t devices() const { return devices_.size(); }

  TimePoint now() const override { return now_; }
  Duration unix_offset() const override { return config_.unix_offset; }
  std::error_code send(std::span<const std::uint8_t> frame) override;
  std::optional<TimedFrame> receive(TimePoint deadline) override;
  void set_frame_handler(FrameHandler handler) override;
  TimerId start_timer(TimePoint at, TimerCallback callback) override;
  void cancel_timer(TimerId id) override;
  void run_until(TimePoint deadline) override;
  void stop() override;

  FaultId drop(FrameFaultRule rule, std::size_t before_device = 0);
  FaultId corrupt(FrameFaultRule rule, FrameCorruption corruption = {});
  FaultId delay(FrameFaultRule rule, Duration by);
  void remove_fault(FaultId id);
  std::uint64_t fault_hits(FaultId id) const;
  void set_link_down(bool down);
  bool link_down() const { return link_down_; }

  MonitorId add_monitor(std::function<void(const TimedFrame&, FrameDirection)> monitor);
  void remove_monitor(MonitorId id);

  std::uint64_t frames_sent() const { return frames_sent_; }
  std::uint64_t frames_received() const { return frames_received_; }
  std::uint64_t frames_lost() const { return frames_lost_; }
  // The time a frame of `size` bytes (before padding) occupies the wire, gap included.
  static Duration wire_time(std::size_t size);

 private:
  struct InFlight {
    std::vector<std::uint8_t> bytes;
    std::vector<TimePoint> arrivals;         // per device, port 0
    std::vector<TimePoint> return_arrivals;  // per device, port 1
    std::size_t drop_before = std::numeric_limits<std::size_t>::max();
    std::optional<FrameCorruption> corruption;
    Duration extra_delay{0};
    std::uint64_t generation = 0;
  };
  enum class EventKind : std::uint8_t { timer, device, deliver };
  struct Event {
    TimePoint at;
    std::uint64_t seq;
    EventKind kind;
    std::uint32_t device;
    TimerId timer;
    std::shared_ptr<InFlight> frame;
    bool operator>(const Event& other) const {
      return at != other.at ? at > other.at : seq > other.seq;
    }
  };
  enum class FaultKind : std::uint8_t { drop, corrupt, delay };
  struct Fault {
    FaultKind kind;
    FrameFaultRule rule;
    std::size_t before_device = 0;
    FrameCorruption corruption;
    Duration by{0};
    std::uint64_t hits = 0;
    bool active = true;
  };
  struct Device {
    SegmentDevice* device;
    DeviceTiming timing;
  };

  void schedule(TimePoint at, EventKind kind, std::uint32_t device, TimerId timer,
                std::shared_ptr<InFlight> frame);
  bool fault_applies(Fault& fault, std::span<const std::uint8_t> bytes);
  void run_event(Event& event);
  void deliver(InFlight& frame, TimePoint at);
  bool take_stop() { return stop_.load(std::memory_order_relaxed) && stop_.exchange(false); }

  SimSegmentConfig config_;
  std::vector<Device> devices_;
  TimePoint now_{};
  TimePoint tx_free_{};
  TimePoint rx_last_{};
  std::uint64_t seq_ = 0;
  std::priority_queue<Event, std::vector<Event>, std::greater<>> events_;
  std::unordered_map<TimerId, TimerCallback> timers_;
  TimerId next_timer_ = 1;
  FrameHandler handler_;
  std::queue<TimedFrame> inbox_;
  std::vector<Fault> faults_;
  std::map<MonitorId, std::function<void(const TimedFrame&, FrameDirection)>> monitors_;
  MonitorId next_monitor_ = 1;
  std::mt19937_64 random_;
  bool link_down_ = false;
  std::uint64_t generation_ = 0;  // bumped when the link goes down: frames on the way are lost
  std::atomic<bool> stop_{false};
  bool running_ = false;
  std::uint64_t frames_sent_ = 0;
  std::uint64_t frames_received_ = 0;
  std::uint64_t frames_lost_ = 0;
};

}  // namespace drivecheck::ethercat
