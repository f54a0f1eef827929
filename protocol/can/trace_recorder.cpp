#include "protocol/can/trace_recorder.hpp"

#include <cstdint>

namespace drivecheck::can {

Expected<std::unique_ptr<TraceRecorder>, std::string> TraceRecorder::open(
    const TraceFiles& files, TraceRecorderOptions options) {
  const std::string& name = options.interface;
  if (name.empty() || name.size() > kMaxInterfaceNameLength) {
    return Unexpected(fmt::format("trace interface name '{}' must have 1..{} characters", name,
                                  kMaxInterfaceNameLength));
  }
  for (const char c : name) {
    if (c <= 0x20 || c >= 0x7F || c == '#') {
      return Unexpected(fmt::format(
          "trace interface name '{}' may only hold printable ASCII without blanks and '#'", name));
    }
  }
  if (files.candump_log.empty() && files.pcap.empty()) {
    return Unexpected(std::string("no trace file given (neither candump log nor pcap)"));
  }
  std::unique_ptr<TraceRecorder> recorder(new TraceRecorder(std::move(options)));
  recorder->scratch_.interface = recorder->options_.interface;
  const bool flush = recorder->options_.flush_each_frame;
  if (!files.candump_log.empty()) {
    auto writer = CandumpLogWriter::create(files.candump_log, flush);
    if (!writer) return Unexpected(std::move(writer).error());
    recorder->candump_.emplace(std::move(*writer));
  }
  if (!files.pcap.empty()) {
    auto writer = PcapWriter::create(files.pcap, flush);
    if (!writer) return Unexpected(std::move(writer).error());
    recorder->pcap_.emplace(std::move(*writer));
  }
  return recorder;
}

Expected<void, std::string> TraceRecorder::record(const Frame& frame, TimePoint at,
                                                  std::optional<TraceDirection> direction) {
  if (error_) return Unexpected(*error_);
  std::int64_t unix_ns = 0;
  if (__builtin_add_overflow(at.time_since_epoch().count(), options_.unix_offset.count(),
                             &unix_ns) ||
      unix_ns < 0) {
    error_ = fmt::format(
        "frame {} at bus time {} ns (Unix offset {} ns) is not a Unix time "
        "from 1970 on: recording stopped",
        frame, at.time_since_epoch().count(), options_.unix_offset.count());
    return Unexpected(*error_);
  }
  scratch_.timestamp = std::chrono::nanoseconds(unix_ns);
  scratch_.frame = frame;
  scratch_.direction = direction;
  if (candump_) {
    if (auto written = candump_->write(scratch_); !written) {
      error_ = written.error();
      return Unexpected(*error_);
    }
  }
  if (pcap_) {
    if (auto written = pcap_->write(PcapRecord{scratch_.timestamp, frame}); !written) {
      error_ = written.error();
      return Unexpected(*error_);
    }
  }
  ++frames_;
  return {};
}

Expected<void, std::string> TraceRecorder::flush() {
  if (error_) return Unexpected(*error_);
  if (candump_) {
    if (auto flushed = candump_->flush(); !flushed) {
      error_ = flushed.error();
      return Unexpected(*error_);
    }
  }
  if (pcap_) {
    if (auto flushed = pcap_->flush(); !flushed) {
      error_ = flushed.error();
      return Unexpected(*error_);
    }
  }
  return {};
}

std::error_code RecordingBus::send(const Frame& frame) {
  const std::error_code error = inner_.send(frame);
  if (!error) (void)recorder_.record(frame, inner_.now(), TraceDirection::transmit);
  return error;
}

std::optional<TimedFrame> RecordingBus::receive(TimePoint deadline) {
  auto frame = inner_.receive(deadline);
  if (frame && !frame->own) (void)recorder_.record(*frame, TraceDirection::receive);
  return frame;
}

void RecordingBus::set_frame_handler(FrameHandler handler) {
  if (!handler) {
    inner_.set_frame_handler({});
    return;
  }
  inner_.set_frame_handler([this, handler = std::move(handler)](const TimedFrame& frame) {
    if (!frame.own) (void)recorder_.record(frame, TraceDirection::receive);
    handler(frame);
  });
}

}  // namespace drivecheck::can
