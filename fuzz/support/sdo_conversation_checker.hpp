// The oracle of the sdo_client fuzz target: it watches every call into an SdoClientTransfer
// (start, each frame, each time step) and the frames the client sent in return, follows the
// transfer by CiA 301 §7.2.4.3's rules independently of the client's code, and fails
// (DRIVECHECK_FUZZ_CHECK: message, the last frames of the conversation, trap) when the client
//   - accepts an answer CiA 301 forbids: wrong toggle, wrong multiplexer, seqno 0 or above
//     blksize, ackseq above the segments sent, blksize 0 or above 127, a command that does not
//     fit the phase, a frame that is no SDO frame;
//   - succeeds with data other than what the conversation carried, with a size other than the
//     one the server indicated, more than max_upload_size, or a block CRC that does not match;
//   - fails without a reason, or does not send the abort it must (or sends one after a server
//     abort, which a client must not answer);
//   - sends a frame that is not the one the protocol calls for (toggle, segment contents, c
//     bit, seqno numbering, retransmission from ackseq, n and CRC of the end request);
//   - times out early or not at its deadline, or lets a deadline lie beyond now + timeout;
//   - changes in any way after the transfer ended.
// Where CiA 301 lets a client choose (stop a block upload early when more data arrives than
// indicated), both choices pass.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "protocol/cia301/sdo_codec.hpp"

namespace drivecheck::fuzz {

// What the client was asked to do.
struct SdoTransferSpec {
  cia301::SdoCobIds cob_ids;
  cia301::Multiplexer mux;
  bool upload = true;
  cia301::SdoTransferMode mode = cia301::SdoTransferMode::automatic;
  std::vector<std::uint8_t> download_data;
  can::Duration timeout{};
  std::uint8_t block_size = 0;  // option (block upload)
  std::uint8_t protocol_switch_threshold = 0;
  bool block_crc = false;
  bool block_fallback = false;
  std::size_t max_upload_size = 0;
};

class SdoConversationChecker {
 public:
  explicit SdoConversationChecker(SdoTransferSpec spec);

  // After transfer.start_upload/start_download(..., now): `sent` is what it returned.
  void on_start(std::span<const can::Frame> sent, const cia301::SdoClientTransfer& transfer,
                can::TimePoint now);
  // After transfer.on_frame(frame, now).
  void on_server_frame(const can::Frame& frame, std::span<const can::Frame> sent,
                       const cia301::SdoClientTransfer& transfer, can::TimePoint now);
  // After transfer.on_time(now).
  void on_time(can::TimePoint now, std::span<const can::Frame> sent,
               const cia301::SdoClientTransfer& transfer);

 private:
  enum class Phase : std::uint8_t {
    not_started,
    upload_initiate,
    upload_segment,
    download_initiate,
    download_segment,
    block_download_initiate,
    block_download_ack,
    block_download_end,
    block_upload_initiate,
    block_upload_segments,
    block_upload_end,
    ended,
  };

  struct Entry {
    char direction;  // '>' client sent, '<' server sent, 't' time step
    can::Frame frame;
    can::TimePoint time;
  };

  // Failure output: the message, then the conversation's last frames.
  [[noreturn]] void fail(const char* file, int line, const std::string& what) const;
  void check(bool condition, const char* file, int line, const std::string& what) const {
    if (!condition) fail(file, line, what);
  }
  void record(char direction, const can::Frame& frame, can::TimePoint time);

  // The client must have failed because of `reason` (a protocol error it detects): it sends
  // exactly one abort frame naming the transfer.
  void expect_protocol_failure(const std::string& reason);
  void expect_sent_nothing(const std::string& when);
  // Decodes the client's frames, checking the frame format of each.
  std::vector<cia301::SdoClientMessage> decode_sent(cia301::SdoFraming framing);
  // The one message the client must send now.
  cia301::SdoClientMessage expect_one_sent(const std::string& what);

  void expect_upload_initiate_request();
  void expect_download_initiate_request();
  void expect_download_segment();
  void expect_block_download_sub_block();
  void on_upload_initiate_response(const cia301::SdoServerMessage& message);
  // A frame on the response COB-ID of a running transfer, neither abort nor invalid.
  void on_answer(const cia301::SdoServerMessage& message);
  // Common to every call: client state agrees with the conversation, deadline in range;
  // remembers the state for the next call.
  void finish_call(can::TimePoint now);

  SdoTransferSpec spec_;
  Phase phase_ = Phase::not_started;
  std::vector<Entry> log_;  // ring of the last kLogSize entries
  std::size_t log_next_ = 0;

  // The call being checked.
  const cia301::SdoClientTransfer* transfer_ = nullptr;
  std::span<const can::Frame> sent_;
  // State after the previous call.
  bool running_before_ = false;
  can::TimePoint deadline_before_ = can::kForever;
  cia301::SdoClientTransfer::State state_before_ = cia301::SdoClientTransfer::State::idle;
  std::vector<std::uint8_t> data_before_;

  cia301::SdoTransferMode effective_mode_ = cia301::SdoTransferMode::automatic;
  bool toggle_ = false;
  // Download.
  bool expedited_sent_ = false;
  bool last_segment_sent_ = false;
  std::size_t offset_ = 0;  // segmented: bytes sent; block: start of the current sub-block
  std::uint8_t server_block_size_ = 0;
  std::size_t sub_block_count_ = 0;
  bool sub_block_has_last_ = false;
  bool crc_both_ = false;
  // Upload.
  std::vector<std::uint8_t> received_;
  bool size_indicated_ = false;
  std::uint32_t size_ = 0;
  std::uint8_t expected_seqno_ = 1;
  bool last_in_sequence_ = false;
};

}  // namespace drivecheck::fuzz
