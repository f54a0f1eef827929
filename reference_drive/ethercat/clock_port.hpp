// LinkClockPort: the can::Bus the reference drive (a CiA 301 device built for a CAN port) runs on
// when it sits behind the EtherCAT front end. It carries no CAN: the drive gets the EtherCAT
// link's clock and timers (the simulated segment's time, or real time on a RawLink), so its
// control cycle, EMCY inhibit time and the CiA 402 modes run on the same clock as the ESC. Of
// the frames the drive sends, its EMCYs (on the COB-ID in 1014h, CiA 301 §7.2.7) are decoded and
// handed on (the front end turns them into CoE emergencies, ETG.1000.6 / Festo 000 §4.11);
// every other frame (heartbeat, TPDOs, SDO responses) has no EtherCAT meaning and is dropped.
// Nothing is ever received.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/emcy.hpp"
#include "protocol/ethercat/link.hpp"

namespace drivecheck::cia301 {
class ObjectDictionary;
}

namespace drivecheck::reference_drive::ethercat {

class LinkClockPort final : public can::Bus {
 public:
  explicit LinkClockPort(drivecheck::ethercat::Link& link) : link_(link) {}

  // The drive's dictionary (for 1014h; must outlive the port or be reset to nullptr). Without
  // one, EMCYs are looked for on 80h + node 1.
  void set_dictionary(const cia301::ObjectDictionary* od) { od_ = od; }
  // Receives each EMCY the drive sends.
  void set_emcy_handler(std::function<void(const cia301::Emcy&)> handler) {
    emcy_ = std::move(handler);
  }
  std::uint64_t dropped_frames() const { return dropped_; }

  // can::Bus
  can::TimePoint now() const override { return link_.now(); }
  can::Duration unix_offset() const override { return link_.unix_offset(); }
  std::error_code send(const can::Frame& frame) override;
  std::optional<can::TimedFrame> receive(can::TimePoint deadline) override;
  void set_frame_handler(FrameHandler handler) override { (void)handler; }
  void set_filters(std::span<const can::Filter> filters) override { (void)filters; }
  void set_loopback(bool enabled) override { (void)enabled; }
  can::TimerId start_timer(can::TimePoint at, TimerCallback callback) override {
    return link_.start_timer(at, std::move(callback));
  }
  void cancel_timer(can::TimerId id) override { link_.cancel_timer(id); }
  void run_until(can::TimePoint deadline) override { link_.run_until(deadline); }
  void stop() override { link_.stop(); }

 private:
  std::uint32_t emcy_cob_id() const;

  drivecheck::ethercat::Link& link_;
  const cia301::ObjectDictionary* od_ = nullptr;
  std::function<void(const cia301::Emcy&)> emcy_;
  std::uint64_t dropped_ = 0;
};

}  // namespace drivecheck::reference_drive::ethercat
