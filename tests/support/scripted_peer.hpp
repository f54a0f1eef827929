// A scripted CAN peer for protocol tests: the other side of an exchange, written as the list
// of frames it expects and the frames it answers with (python-canopen's test_sdo.py style,
// on the simulated bus).
//
//   can::SimBus bus({.bitrate = 1'000'000});
//   auto master = bus.attach("master");
//   auto server = bus.attach("server");
//   test_support::ScriptedPeer peer(*server, {0x605});
//   peer.expect("605#4041600000000000")    // ccs=2, index 6041h sub 0
//       .reply("585#4B41600034120000");    // scs=2 n=2 e=1 s=1, data 1234h
//   ... run the code under test on *master ...
//   EXPECT_TRUE(peer.finished());
//
// The peer takes frames in push mode (it sets the port's frame handler). Each step expects one
// frame, exactly (identifier, format, DLC, data); when it arrives the step's replies are sent,
// each at once or after its delay. A step without replies leaves the peer silent (to test
// timeouts); reply_after() answers late. A frame that is not the next expected one, or that
// comes after the script ended, fails the current test (ADD_FAILURE, both frames as candump
// text) unless a mismatch handler is set; the step is then not consumed.
//
// With repeat on, the script starts over after its last step (benchmarks); with the
// transcript off, received frames are not kept.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"

namespace drivecheck::test_support {

class ScriptedPeer {
 public:
  // Attaches to `port` (sets its frame handler). With `listen_ids`, the port's filters are set
  // to exactly these 11-bit identifiers; otherwise every frame the port gets is checked.
  explicit ScriptedPeer(can::Bus& port, std::vector<std::uint32_t> listen_ids = {});
  ~ScriptedPeer();
  ScriptedPeer(const ScriptedPeer&) = delete;
  ScriptedPeer& operator=(const ScriptedPeer&) = delete;

  // A new step: the next frame expected (candump compact text, or a frame).
  ScriptedPeer& expect(std::string_view candump);
  ScriptedPeer& expect(const can::Frame& frame);
  // Replies of the last step, in order, sent when its frame arrives. Before any expect(),
  // nothing: use send() to start an exchange from the peer's side.
  ScriptedPeer& reply(std::string_view candump);
  ScriptedPeer& reply(const can::Frame& frame);
  ScriptedPeer& reply_after(can::Duration delay, std::string_view candump);
  ScriptedPeer& reply_after(can::Duration delay, const can::Frame& frame);

  // Sends a frame now, outside the script.
  void send(std::string_view candump);

  void set_repeat(bool repeat) { repeat_ = repeat; }
  void set_transcript(bool keep) { keep_transcript_ = keep; }
  // Replaces the default ADD_FAILURE on a mismatch (text: what came, what was expected).
  void set_mismatch_handler(std::function<void(const std::string&)> handler) {
    on_mismatch_ = std::move(handler);
  }

  // Every step's frame arrived (and, without repeat, nothing unexpected came).
  bool finished() const { return next_ == steps_.size() && mismatches_ == 0; }
  // Steps still waiting for their frame.
  std::size_t remaining() const { return steps_.size() - next_; }
  std::size_t mismatches() const { return mismatches_; }
  // Frames the peer received (not its own), with their bus timestamps.
  const std::vector<can::TimedFrame>& transcript() const { return transcript_; }

 private:
  struct Reply {
    can::Frame frame;
    can::Duration delay{0};
  };
  struct Step {
    can::Frame expected;
    std::vector<Reply> replies;
  };

  void on_frame(const can::TimedFrame& frame);
  void mismatch(const std::string& text);
  static can::Frame parse(std::string_view candump);

  can::Bus& port_;
  std::vector<std::uint32_t> listen_ids_;
  std::vector<Step> steps_;
  std::size_t next_ = 0;
  std::size_t mismatches_ = 0;
  bool repeat_ = false;
  bool keep_transcript_ = true;
  std::vector<can::TimedFrame> transcript_;
  std::vector<can::TimerId> timers_;  // late replies, cancelled when the peer goes
  std::function<void(const std::string&)> on_mismatch_;
};

}  // namespace drivecheck::test_support
