// A Link that passes everything to another Link and shows every frame sent and received to a
// tap: how the EtherCAT live fuzzer records the frames of a case (for its pcap reproducer) on
// any link, the simulated segment and an AF_PACKET RawLink alike. The master runs on it.
#pragma once

#include <functional>
#include <utility>

#include "protocol/ethercat/link.hpp"

namespace drivecheck::fuzz_live {

class TapLink final : public ethercat::Link {
 public:
  // `sent`: the master's frame as it went out (timestamp: the link's clock at send()).
  using Tap = std::function<void(const ethercat::TimedFrame&, bool sent)>;

  explicit TapLink(ethercat::Link& inner) : inner_(inner) {}
  void set_tap(Tap tap) { tap_ = std::move(tap); }

  ethercat::TimePoint now() const override { return inner_.now(); }
  ethercat::Duration unix_offset() const override { return inner_.unix_offset(); }
  std::error_code send(std::span<const std::uint8_t> frame) override {
    if (tap_) tap_({{frame.begin(), frame.end()}, inner_.now()}, true);
    return inner_.send(frame);
  }
  std::optional<ethercat::TimedFrame> receive(ethercat::TimePoint deadline) override {
    auto frame = inner_.receive(deadline);
    if (frame && tap_) tap_(*frame, false);
    return frame;
  }
  void set_frame_handler(FrameHandler handler) override {
    if (!handler) return inner_.set_frame_handler({});
    inner_.set_frame_handler([this, handler = std::move(handler)](const ethercat::TimedFrame& f) {
      if (tap_) tap_(f, false);
      handler(f);
    });
  }
  ethercat::TimerId start_timer(ethercat::TimePoint at, TimerCallback callback) override {
    return inner_.start_timer(at, std::move(callback));
  }
  void cancel_timer(ethercat::TimerId id) override { inner_.cancel_timer(id); }
  void run_until(ethercat::TimePoint deadline) override { inner_.run_until(deadline); }
  void stop() override { inner_.stop(); }

 private:
  ethercat::Link& inner_;
  Tap tap_;
};

}  // namespace drivecheck::fuzz_live
