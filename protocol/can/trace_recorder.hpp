// Recording a bus: every frame to a candump log and/or a pcap file, valid after every frame.
//
//   auto recorder = TraceRecorder::open({.candump_log = "run.log", .pcap = "run.pcap"},
//                                       {.interface = "sim", .unix_offset = bus.unix_offset()});
//   sim_bus.add_monitor((*recorder)->monitor());   // every frame on the simulated wire
//   RecordingBus port(*real_port, **recorder);     // or: what one port sends (T) and gets (R)
//
// Timestamps: a frame's bus TimePoint plus the bus clock's `Clock::unix_offset()` is its
// Unix time in the files. The candump log keeps microseconds (its format), pcap nanoseconds.
// Errors: the first write error (disk full, ...) stops the recording; record() returns it and
// error() keeps it, so a caller that only reads error() at the end still learns that the
// trace is incomplete — a trace with a hole is never presented as complete.
#pragma once

#include <cstddef>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "protocol/can/bus.hpp"
#include "protocol/can/candump_log.hpp"
#include "protocol/can/pcap.hpp"

namespace drivecheck::can {

struct TraceFiles {
  std::filesystem::path candump_log{};  // empty: no candump log
  std::filesystem::path pcap{};         // empty: no pcap
};

struct TraceRecorderOptions {
  std::string interface = "sim";  // interface name in the candump log (1..15 characters, no blanks)
  Duration unix_offset{0};        // Clock::unix_offset() of the recorded bus
  bool flush_each_frame = true;   // false: faster, but an interrupted run may lose the tail
};

class TraceRecorder {
 public:
  // Creates (truncates) the files. Fails on a bad interface name or a file that cannot be
  // created. At least one of the files must be given.
  static Expected<std::unique_ptr<TraceRecorder>, std::string> open(const TraceFiles& files,
                                                                    TraceRecorderOptions options);

  TraceRecorder(const TraceRecorder&) = delete;
  TraceRecorder& operator=(const TraceRecorder&) = delete;

  // Writes one frame seen at bus time `at`. The direction flag goes to the candump log only
  // (pcap of LINKTYPE_CAN_SOCKETCAN has no place for it).
  Expected<void, std::string> record(const Frame& frame, TimePoint at,
                                     std::optional<TraceDirection> direction = std::nullopt);
  Expected<void, std::string> record(const TimedFrame& frame,
                                     std::optional<TraceDirection> direction = std::nullopt) {
    return record(frame.frame, frame.timestamp, direction);
  }

  // A callback for SimBus::add_monitor (no direction: the wire, not a port). The recorder
  // must outlive the bus's use of it; write errors land in error().
  std::function<void(const TimedFrame&)> monitor() {
    return [this](const TimedFrame& frame) { (void)record(frame); };
  }

  Expected<void, std::string> flush();

  // The first write error, if any; after it nothing more is written.
  const std::optional<std::string>& error() const { return error_; }
  std::size_t frames_recorded() const { return frames_; }
  const TraceRecorderOptions& options() const { return options_; }

 private:
  explicit TraceRecorder(TraceRecorderOptions options) : options_(std::move(options)) {}

  TraceRecorderOptions options_;
  std::optional<CandumpLogWriter> candump_;
  std::optional<PcapWriter> pcap_;
  std::optional<std::string> error_;
  std::size_t frames_ = 0;
  LogRecord scratch_;  // reused: the interface name is not copied per frame
};

// A Bus port that records what passes through it: every frame it sends (at send time, when
// the inner port accepted it, flag T) and every frame it receives by receive() or by the
// frame handler (flag R). Received loopback echoes of its own frames (TimedFrame::own) are
// not recorded again: the frame is already in the trace from send time. Frames the port
// receives but nobody takes (no handler, no receive() call) are not seen; to record a whole
// simulated bus use SimBus::add_monitor(recorder.monitor()) instead.
// Recording errors do not change what the bus returns: check recorder.error().
class RecordingBus final : public Bus {
 public:
  RecordingBus(Bus& inner, TraceRecorder& recorder) : inner_(inner), recorder_(recorder) {}

  TimePoint now() const override { return inner_.now(); }
  Duration unix_offset() const override { return inner_.unix_offset(); }
  std::error_code send(const Frame& frame) override;
  std::optional<TimedFrame> receive(TimePoint deadline) override;
  void set_frame_handler(FrameHandler handler) override;
  void set_filters(std::span<const Filter> filters) override { inner_.set_filters(filters); }
  void set_loopback(bool enabled) override { inner_.set_loopback(enabled); }
  std::size_t queued(std::uint32_t id, IdFormat format) const override {
    return inner_.queued(id, format);
  }
  TimerId start_timer(TimePoint at, TimerCallback callback) override {
    return inner_.start_timer(at, std::move(callback));
  }
  void cancel_timer(TimerId id) override { inner_.cancel_timer(id); }
  void run_until(TimePoint deadline) override { inner_.run_until(deadline); }
  void stop() override { inner_.stop(); }

 private:
  Bus& inner_;
  TraceRecorder& recorder_;
};

}  // namespace drivecheck::can
