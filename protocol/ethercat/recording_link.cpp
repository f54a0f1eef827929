#include "protocol/ethercat/recording_link.hpp"

#include <utility>
#include <vector>

namespace drivecheck::ethercat {

std::error_code RecordingLink::send(std::span<const std::uint8_t> frame) {
  const TimePoint at = inner_.now();
  const std::error_code error = inner_.send(frame);
  if (!error && recorder_)
    recorder_(TimedFrame{std::vector<std::uint8_t>(frame.begin(), frame.end()), at},
              FrameDirection::sent);
  return error;
}

std::optional<TimedFrame> RecordingLink::receive(TimePoint deadline) {
  auto frame = inner_.receive(deadline);
  if (frame && recorder_) recorder_(*frame, FrameDirection::received);
  return frame;
}

void RecordingLink::set_frame_handler(FrameHandler handler) {
  if (!handler) {
    inner_.set_frame_handler({});
    return;
  }
  inner_.set_frame_handler([this, handler = std::move(handler)](const TimedFrame& frame) {
    if (recorder_) recorder_(frame, FrameDirection::received);
    handler(frame);
  });
}

}  // namespace drivecheck::ethercat
