#include "tests/support/scripted_peer.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <utility>

namespace drivecheck::test_support {

ScriptedPeer::ScriptedPeer(can::Bus& port, std::vector<std::uint32_t> listen_ids)
    : port_(port), listen_ids_(std::move(listen_ids)) {
  if (!listen_ids_.empty()) {
    std::vector<can::Filter> filters;
    for (std::uint32_t id : listen_ids_)
      filters.push_back(can::Filter::standard(id));
    port_.set_filters(filters);
  }
  port_.set_frame_handler([this](const can::TimedFrame& frame) { on_frame(frame); });
}

ScriptedPeer::~ScriptedPeer() {
  port_.set_frame_handler({});
  for (can::TimerId timer : timers_)
    port_.cancel_timer(timer);
}

can::Frame ScriptedPeer::parse(std::string_view candump) {
  auto frame = can::parse_candump(candump);
  if (!frame) {
    ADD_FAILURE() << "scripted peer: bad frame text \"" << candump << "\": " << frame.error();
    return {};
  }
  return *frame;
}

ScriptedPeer& ScriptedPeer::expect(std::string_view candump) {
  return expect(parse(candump));
}

ScriptedPeer& ScriptedPeer::expect(const can::Frame& frame) {
  steps_.push_back({frame, {}});
  return *this;
}

ScriptedPeer& ScriptedPeer::reply(std::string_view candump) {
  return reply_after(can::Duration{0}, parse(candump));
}

ScriptedPeer& ScriptedPeer::reply(const can::Frame& frame) {
  return reply_after(can::Duration{0}, frame);
}

ScriptedPeer& ScriptedPeer::reply_after(can::Duration delay, std::string_view candump) {
  return reply_after(delay, parse(candump));
}

ScriptedPeer& ScriptedPeer::reply_after(can::Duration delay, const can::Frame& frame) {
  if (steps_.empty()) {
    ADD_FAILURE() << "scripted peer: reply " << can::to_candump(frame) << " before any expect()";
    return *this;
  }
  steps_.back().replies.push_back({frame, delay});
  return *this;
}

void ScriptedPeer::send(std::string_view candump) {
  if (const std::error_code error = port_.send(parse(candump))) {
    ADD_FAILURE() << "scripted peer: send " << candump << " failed: " << error.message();
  }
}

void ScriptedPeer::mismatch(const std::string& text) {
  ++mismatches_;
  if (on_mismatch_) {
    on_mismatch_(text);
  } else {
    ADD_FAILURE() << "scripted peer: " << text;
  }
}

void ScriptedPeer::on_frame(const can::TimedFrame& frame) {
  if (frame.own) return;
  if (keep_transcript_) transcript_.push_back(frame);
  if (next_ == steps_.size() && repeat_) next_ = 0;
  if (next_ == steps_.size()) {
    return mismatch(fmt::format("unexpected frame {} after the end of the script ({} steps)",
                                frame.frame, steps_.size()));
  }
  const Step& step = steps_[next_];
  if (frame.frame != step.expected) {
    return mismatch(
        fmt::format("step {}: got {}, expected {}", next_ + 1, frame.frame, step.expected));
  }
  ++next_;
  for (const Reply& answer : step.replies) {
    if (answer.delay <= can::Duration{0}) {
      if (const std::error_code error = port_.send(answer.frame)) {
        mismatch(fmt::format("send {} failed: {}", answer.frame, error.message()));
      }
    } else {
      const can::Frame late = answer.frame;
      timers_.push_back(port_.start_timer_after(answer.delay, [this, late] {
        if (const std::error_code error = port_.send(late)) {
          mismatch(fmt::format("send {} failed: {}", late, error.message()));
        }
      }));
    }
  }
}

}  // namespace drivecheck::test_support
