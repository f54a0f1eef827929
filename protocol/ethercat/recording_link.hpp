// A Link that hands every frame the master sends and every frame it receives to a recorder,
// and otherwise is the link it wraps: the EtherCAT counterpart of can::RecordingBus
// (protocol/can/trace_recorder.hpp). `drivecheck run --bus ethercat:IF --pcap F` records a
// real link with it; a SimSegment has monitors of its own (SimSegment::add_monitor), which also
// see the frames no one receives.
//
//   PcapWriter pcap("run.pcap", raw->unix_offset());
//   RecordingLink link(*raw, [&](const TimedFrame& f, FrameDirection) { pcap.write(f); });
//   Master master(link, config);
//
// - A sent frame is recorded as given, stamped with now() at send(), after the inner link
//   accepted it (a frame the link refused, e.g. link down, is not on the wire and not recorded).
//   On a RawLink it is not padded to 60 bytes here: the kernel pads it on the wire.
// - A received frame is recorded when receive() returns it or the frame handler is called with
//   it, with the inner link's timestamp.
// - Not thread-safe, like every Link: stop() alone may come from another thread or a signal.
#pragma once

#include <functional>
#include <optional>
#include <span>
#include <system_error>

#include "protocol/ethercat/link.hpp"

namespace drivecheck::ethercat {

class RecordingLink final : public Link {
 public:
  using Recorder = std::function<void(const TimedFrame&, FrameDirection)>;

  RecordingLink(Link& inner, Recorder recorder) : inner_(inner), recorder_(std::move(recorder)) {}

  TimePoint now() const override { return inner_.now(); }
  Duration unix_offset() const override { return inner_.unix_offset(); }
  std::error_code send(std::span<const std::uint8_t> frame) override;
  std::optional<TimedFrame> receive(TimePoint deadline) override;
  void set_frame_handler(FrameHandler handler) override;
  TimerId start_timer(TimePoint at, TimerCallback callback) override {
    return inner_.start_timer(at, std::move(callback));
  }
  void cancel_timer(TimerId id) override { inner_.cancel_timer(id); }
  void run_until(TimePoint deadline) override { inner_.run_until(deadline); }
  void stop() override { inner_.stop(); }

 private:
  Link& inner_;
  Recorder recorder_;
};

}  // namespace drivecheck::ethercat
