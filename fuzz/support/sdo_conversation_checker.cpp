#include "fuzz/support/sdo_conversation_checker.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>
#include <variant>

#include "fuzz/support/fuzz_check.hpp"

// Checks whose message is formatted only when they fail (the checker runs on every frame).
#define SDO_CHECK(condition, ...)                                                           \
  do {                                                                                      \
    if (!(condition)) fail(__FILE__, __LINE__, #condition ": " + fmt::format(__VA_ARGS__)); \
  } while (false)

namespace drivecheck::fuzz {
namespace {

using namespace drivecheck::cia301;

constexpr std::size_t kLogSize = 48;
constexpr std::uint32_t kFallbackAbort = 0x05040001;  // ccs not valid: retry segmented

bool valid_block_size(std::uint8_t size) {
  return size >= 1 && size <= kSdoMaxBlockSize;
}

std::string_view state_name(SdoClientTransfer::State state) {
  switch (state) {
    case SdoClientTransfer::State::idle:
      return "idle";
    case SdoClientTransfer::State::running:
      return "running";
    case SdoClientTransfer::State::succeeded:
      return "succeeded";
    case SdoClientTransfer::State::failed:
      return "failed";
  }
  return "?";
}

std::string state_text(const SdoClientTransfer& transfer) {
  std::string text(state_name(transfer.state()));
  if (transfer.failed()) text += " (" + transfer.error().message() + ")";
  return text;
}

bool same_bytes(std::span<const std::uint8_t> a, std::span<const std::uint8_t> b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end());
}

std::string hex(std::span<const std::uint8_t> bytes) {
  std::string text;
  for (std::size_t i = 0; i < bytes.size() && i < 64; ++i)
    text += fmt::format("{:02X}", bytes[i]);
  if (bytes.size() > 64) text += fmt::format("... ({} bytes)", bytes.size());
  return text;
}

std::size_t segments_needed(std::size_t bytes) {
  return std::max<std::size_t>(1, (bytes + kSdoSegmentDataLength - 1) / kSdoSegmentDataLength);
}

}  // namespace

SdoConversationChecker::SdoConversationChecker(SdoTransferSpec spec) : spec_(std::move(spec)) {
  log_.reserve(kLogSize);
}

void SdoConversationChecker::record(char direction, const can::Frame& frame, can::TimePoint time) {
  const Entry entry{direction, frame, time};
  if (log_.size() < kLogSize) {
    log_.push_back(entry);
  } else {
    log_[log_next_] = entry;
  }
  log_next_ = (log_next_ + 1) % kLogSize;
}

void SdoConversationChecker::fail(const char* file, int line, const std::string& what) const {
  std::string detail = fmt::format(
      "transfer: {} {} mode {}{}, timeout {} ns, blksize {}, pst {}, crc {}, fallback "
      "{}, max {}\n  conversation (last {} events, oldest first; > client, < server, t time):",
      spec_.upload ? "upload" : "download", spec_.mux, static_cast<int>(spec_.mode),
      spec_.upload ? std::string() : fmt::format(" of {} bytes", spec_.download_data.size()),
      spec_.timeout.count(), spec_.block_size, spec_.protocol_switch_threshold, spec_.block_crc,
      spec_.block_fallback, spec_.max_upload_size, log_.size());
  const std::size_t start = log_.size() < kLogSize ? 0 : log_next_;
  for (std::size_t i = 0; i < log_.size(); ++i) {
    const Entry& entry = log_[(start + i) % log_.size()];
    const auto time = entry.time.time_since_epoch().count();
    if (entry.direction == 't') {
      detail += fmt::format("\n    {:>14} t  time step", time);
    } else {
      const std::string decoded = entry.direction == '>'
                                      ? to_string(decode_client_message(entry.frame))
                                      : to_string(decode_server_message(entry.frame));
      detail +=
          fmt::format("\n    {:>14} {}  {:<20} {}", time, entry.direction, entry.frame, decoded);
    }
  }
  if (transfer_ != nullptr) detail += "\n  client state: " + state_text(*transfer_);
  oracle_failed(file, line, "SDO client conversation", what, detail);
}

// --- one call -------------------------------------------------------------------------------

std::vector<SdoClientMessage> SdoConversationChecker::decode_sent(SdoFraming framing) {
  std::vector<SdoClientMessage> messages;
  for (const can::Frame& frame : sent_) {
    SDO_CHECK(frame.id == spec_.cob_ids.request && frame.format == spec_.cob_ids.format &&
                  frame.kind == can::FrameKind::data && frame.dlc == kSdoFrameLength,
              "client frame {} is not an 8-byte data frame on the request COB-ID {:03X}", frame,
              spec_.cob_ids.request);
    messages.push_back(decode_client_message(frame, framing));
    SDO_CHECK(!std::holds_alternative<SdoInvalid>(messages.back()),
              "client frame {} is no valid SDO frame", frame);
  }
  return messages;
}

SdoClientMessage SdoConversationChecker::expect_one_sent(const std::string& what) {
  auto messages = decode_sent(SdoFraming::command);
  SDO_CHECK(messages.size() == 1, "client sent {} frames where it must send one {}",
            messages.size(), what);
  return messages.front();
}

void SdoConversationChecker::expect_sent_nothing(const std::string& when) {
  SDO_CHECK(sent_.empty(), "client sent {} frame(s) {} (first {})", sent_.size(), when,
            sent_.empty() ? can::Frame{} : sent_.front());
}

void SdoConversationChecker::expect_protocol_failure(const std::string& reason) {
  const SdoClientTransfer& t = *transfer_;
  SDO_CHECK(t.failed(), "client went on although {}; it is {}", reason, state_text(t));
  SDO_CHECK(t.error().category() == sdo_client_category(),
            "client failed ({}) with an error that is no SdoClientError, although {}",
            t.error().message(), reason);
  const auto expected_code = abort_code_for(static_cast<SdoClientError>(t.error().value()));
  const SdoClientMessage message = expect_one_sent("abort transfer");
  const auto* abort = std::get_if<AbortTransfer>(&message);
  SDO_CHECK(abort != nullptr && abort->mux == spec_.mux && expected_code.has_value() &&
                abort->code == static_cast<std::uint32_t>(*expected_code) &&
                t.sent_abort() == abort->code,
            "client failed ({}) because {} but did not send its abort naming {}: sent {}",
            t.error().message(), reason, spec_.mux, to_string(message));
  phase_ = Phase::ended;
}

void SdoConversationChecker::finish_call(can::TimePoint now) {
  const SdoClientTransfer& t = *transfer_;
  const bool ongoing = phase_ != Phase::ended;
  SDO_CHECK(t.running() == ongoing, "client is {} where the conversation {}", state_text(t),
            ongoing ? "goes on" : "has ended");
  if (t.running()) {
    const can::TimePoint deadline = t.next_deadline();
    SDO_CHECK(deadline > now && deadline - now <= spec_.timeout,
              "running transfer's deadline {} ns is not within (now, now + timeout] at now {} ns",
              deadline.time_since_epoch().count(), now.time_since_epoch().count());
  }
  running_before_ = t.running();
  deadline_before_ = t.next_deadline();
  state_before_ = t.state();
  if (!t.running()) data_before_.assign(t.data().begin(), t.data().end());
}

// --- start ------------------------------------------------------------------------------------

void SdoConversationChecker::expect_upload_initiate_request() {
  const SdoClientMessage message = expect_one_sent("initiate upload request");
  const auto* request = std::get_if<InitiateUploadRequest>(&message);
  SDO_CHECK(request != nullptr && request->mux == spec_.mux,
            "client sent {} where an initiate upload request of {} is due", to_string(message),
            spec_.mux);
  phase_ = Phase::upload_initiate;
}

void SdoConversationChecker::expect_download_initiate_request() {
  const auto& data = spec_.download_data;
  const SdoClientMessage message = expect_one_sent("initiate download request");
  const auto* request = std::get_if<InitiateDownloadRequest>(&message);
  SDO_CHECK(request != nullptr && request->mux == spec_.mux,
            "client sent {} where an initiate download request of {} is due", to_string(message),
            spec_.mux);
  expedited_sent_ =
      effective_mode_ != SdoTransferMode::segmented && !data.empty() && data.size() <= 4;
  if (expedited_sent_) {
    SDO_CHECK(request->expedited && request->size_indicated &&
                  same_bytes(request->expedited_data(), data),
              "expedited download of {} is not {} with size indicated", hex(data),
              to_string(message));
  } else {
    SDO_CHECK(!request->expedited && request->size_indicated && request->size == data.size(),
              "segmented download of {} bytes announced as {}", data.size(), to_string(message));
  }
  phase_ = Phase::download_initiate;
}

void SdoConversationChecker::on_start(std::span<const can::Frame> sent,
                                      const SdoClientTransfer& transfer, can::TimePoint now) {
  transfer_ = &transfer;
  sent_ = sent;
  for (const can::Frame& frame : sent)
    record('>', frame, now);
  const bool block = spec_.mode == SdoTransferMode::block;
  effective_mode_ = spec_.mode;

  if (spec_.upload && block && !valid_block_size(spec_.block_size)) {
    SDO_CHECK(
        transfer.failed() && transfer.error() == make_error_code(SdoClientError::invalid_argument),
        "block upload with blksize option {} started: {}", spec_.block_size, state_text(transfer));
    expect_sent_nothing("for a start rejected for its option");
    phase_ = Phase::ended;
  } else {
    SDO_CHECK(transfer.running(), "transfer did not start: {}", state_text(transfer));
    if (spec_.upload && block) {
      const SdoClientMessage message = expect_one_sent("block upload initiate");
      const auto* request = std::get_if<BlockUploadInitiateRequest>(&message);
      SDO_CHECK(request != nullptr && request->mux == spec_.mux &&
                    request->crc_supported == spec_.block_crc &&
                    request->block_size == spec_.block_size &&
                    request->protocol_switch_threshold == spec_.protocol_switch_threshold,
                "block upload starts with {}", to_string(message));
      phase_ = Phase::block_upload_initiate;
    } else if (spec_.upload) {
      expect_upload_initiate_request();
    } else if (block) {
      const SdoClientMessage message = expect_one_sent("block download initiate");
      const auto* request = std::get_if<BlockDownloadInitiateRequest>(&message);
      SDO_CHECK(request != nullptr && request->mux == spec_.mux &&
                    request->crc_supported == spec_.block_crc && request->size_indicated &&
                    request->size == spec_.download_data.size(),
                "block download of {} bytes starts with {}", spec_.download_data.size(),
                to_string(message));
      phase_ = Phase::block_download_initiate;
    } else {
      expect_download_initiate_request();
    }
  }
  finish_call(now);
}

// --- answers ----------------------------------------------------------------------------------

void SdoConversationChecker::on_upload_initiate_response(const SdoServerMessage& message) {
  const SdoClientTransfer& t = *transfer_;
  const auto* response = std::get_if<InitiateUploadResponse>(&message);
  if (response == nullptr) {
    return expect_protocol_failure(to_string(message) + " answers an initiate upload request");
  }
  if (response->mux != spec_.mux) {
    return expect_protocol_failure(fmt::format("the answer names {}", response->mux));
  }
  if (response->expedited) {
    const auto bytes = response->expedited_data();
    if (bytes.size() > spec_.max_upload_size) {
      return expect_protocol_failure("the expedited data exceed max_upload_size");
    }
    SDO_CHECK(t.succeeded() && same_bytes(t.data(), bytes),
              "expedited upload response {} must end the upload with data {}; client is {} "
              "with data {}",
              to_string(message), hex(bytes), state_text(t), hex(t.data()));
    expect_sent_nothing("after an expedited upload response");
    phase_ = Phase::ended;
    return;
  }
  received_.clear();
  size_indicated_ = response->size_indicated;
  size_ = response->size;
  if (size_indicated_ && size_ > spec_.max_upload_size) {
    return expect_protocol_failure("the indicated size exceeds max_upload_size");
  }
  toggle_ = false;
  const SdoClientMessage request = expect_one_sent("upload segment request");
  const auto* segment = std::get_if<UploadSegmentRequest>(&request);
  SDO_CHECK(segment != nullptr && !segment->toggle,
            "after a segmented upload response the client sent {}, not a request with toggle 0",
            to_string(request));
  phase_ = Phase::upload_segment;
}

void SdoConversationChecker::expect_download_segment() {
  const auto& data = spec_.download_data;
  const std::size_t length = std::min(kSdoSegmentDataLength, data.size() - offset_);
  const bool last = offset_ + length == data.size();
  const SdoClientMessage message = expect_one_sent("download segment");
  const auto* segment = std::get_if<DownloadSegmentRequest>(&message);
  SDO_CHECK(segment != nullptr && segment->toggle == toggle_ && segment->last == last &&
                same_bytes(segment->segment_data(),
                           std::span<const std::uint8_t>(data).subspan(offset_, length)),
            "download segment at offset {} must carry toggle {} {}data {}; client sent {}", offset_,
            toggle_ ? 1 : 0, last ? "last " : "",
            hex(std::span<const std::uint8_t>(data).subspan(offset_, length)), to_string(message));
  offset_ += length;
  last_segment_sent_ = last;
  phase_ = Phase::download_segment;
}

void SdoConversationChecker::expect_block_download_sub_block() {
  const auto& data = spec_.download_data;
  const std::size_t needed = segments_needed(data.size() - offset_);
  const std::size_t count = std::min<std::size_t>(server_block_size_, needed);
  const bool has_last = count == needed;
  const auto messages = decode_sent(SdoFraming::block_segment);
  SDO_CHECK(messages.size() == count,
            "sub-block from offset {} with server blksize {} must have {} segments, client sent "
            "{}",
            offset_, server_block_size_, count, messages.size());
  for (std::size_t i = 0; i < count; ++i) {
    const auto* segment = std::get_if<BlockSegment>(&messages[i]);
    const std::size_t at = std::min(data.size(), offset_ + i * kSdoSegmentDataLength);
    const std::size_t length = std::min(kSdoSegmentDataLength, data.size() - at);
    const auto expected = std::span<const std::uint8_t>(data).subspan(at, length);
    SDO_CHECK(segment != nullptr && segment->seqno == i + 1 &&
                  segment->last == (has_last && i + 1 == count) &&
                  same_bytes(std::span<const std::uint8_t>(segment->data).first(length), expected),
              "block segment {} of the sub-block from offset {} must be seqno {}{} with data {}; "
              "client sent {}",
              i + 1, offset_, i + 1, has_last && i + 1 == count ? " last" : "", hex(expected),
              to_string(messages[i]));
  }
  sub_block_count_ = count;
  sub_block_has_last_ = has_last;
  phase_ = Phase::block_download_ack;
}

void SdoConversationChecker::on_server_frame(const can::Frame& frame,
                                             std::span<const can::Frame> sent,
                                             const SdoClientTransfer& transfer,
                                             can::TimePoint now) {
  transfer_ = &transfer;
  sent_ = sent;
  record('<', frame, now);
  for (const can::Frame& out : sent)
    record('>', out, now);
  const SdoClientTransfer& t = transfer;

  if (!running_before_) {
    SDO_CHECK(sent.empty() && t.state() == state_before_ && same_bytes(t.data(), data_before_),
              "frame {} changed a transfer that had ended ({} -> {})", frame,
              state_name(state_before_), state_text(t));
  } else if (frame.id != spec_.cob_ids.response || frame.format != spec_.cob_ids.format ||
             frame.is_error()) {
    SDO_CHECK(sent.empty() && t.running() && t.next_deadline() == deadline_before_,
              "frame {} on another identifier than the response COB-ID {:03X} was not ignored",
              frame, spec_.cob_ids.response);
  } else {
    const SdoFraming framing =
        phase_ == Phase::block_upload_segments ? SdoFraming::block_segment : SdoFraming::command;
    const SdoServerMessage message = decode_server_message(frame, framing);
    if (const auto* abort = std::get_if<AbortTransfer>(&message)) {
      const bool fallback =
          spec_.block_fallback && abort->code == kFallbackAbort &&
          (phase_ == Phase::block_download_initiate || phase_ == Phase::block_upload_initiate);
      if (fallback) {
        SDO_CHECK(t.running(), "block initiate aborted with 05040001h must fall back: client is {}",
                  state_text(t));
        effective_mode_ = SdoTransferMode::automatic;
        if (spec_.upload) {
          expect_upload_initiate_request();
        } else {
          expect_download_initiate_request();
        }
      } else {
        SDO_CHECK(t.failed() && t.error() == std::error_code(static_cast<int>(abort->code),
                                                             sdo_abort_category()),
                  "server abort {:08X}h must end the transfer with its code; client is {}",
                  abort->code, state_text(t));
        expect_sent_nothing("in answer to a server abort (a client does not answer an abort)");
        phase_ = Phase::ended;
      }
    } else if (const auto* invalid = std::get_if<SdoInvalid>(&message)) {
      expect_protocol_failure(
          fmt::format("{} is no SDO frame ({})", frame, describe(invalid->reason)));
    } else {
      on_answer(message);
    }
  }

  finish_call(now);
}

void SdoConversationChecker::on_answer(const SdoServerMessage& message) {
  const SdoClientTransfer& t = *transfer_;
  const auto& data = spec_.download_data;
  switch (phase_) {
    case Phase::upload_initiate:
      return on_upload_initiate_response(message);

    case Phase::upload_segment: {
      const auto* segment = std::get_if<UploadSegmentResponse>(&message);
      if (segment == nullptr) {
        return expect_protocol_failure(to_string(message) + " answers an upload segment request");
      }
      if (segment->toggle != toggle_) {
        return expect_protocol_failure(
            fmt::format("the segment has toggle {} where the request had {}",
                        segment->toggle ? 1 : 0, toggle_ ? 1 : 0));
      }
      const auto bytes = segment->segment_data();
      received_.insert(received_.end(), bytes.begin(), bytes.end());
      if (size_indicated_ && received_.size() > size_) {
        return expect_protocol_failure(
            fmt::format("{} bytes arrived where {} were indicated", received_.size(), size_));
      }
      if (received_.size() > spec_.max_upload_size) {
        return expect_protocol_failure("the upload exceeds max_upload_size");
      }
      if (segment->last) {
        if (size_indicated_ && received_.size() != size_) {
          return expect_protocol_failure(
              fmt::format("the last segment ends at {} bytes where {} were indicated",
                          received_.size(), size_));
        }
        SDO_CHECK(t.succeeded() && same_bytes(t.data(), received_),
                  "the last segment must end the upload with data {}; client is {} with data {}",
                  hex(received_), state_text(t), hex(t.data()));
        expect_sent_nothing("after the last upload segment");
        phase_ = Phase::ended;
        return;
      }
      toggle_ = !toggle_;
      const SdoClientMessage request = expect_one_sent("upload segment request");
      const auto* next = std::get_if<UploadSegmentRequest>(&request);
      SDO_CHECK(next != nullptr && next->toggle == toggle_,
                "the next upload segment request must have toggle {}; client sent {}",
                toggle_ ? 1 : 0, to_string(request));
      return;
    }

    case Phase::download_initiate: {
      const auto* response = std::get_if<InitiateDownloadResponse>(&message);
      if (response == nullptr) {
        return expect_protocol_failure(to_string(message) +
                                       " answers an initiate download request");
      }
      if (response->mux != spec_.mux) {
        return expect_protocol_failure(fmt::format("the answer names {}", response->mux));
      }
      if (expedited_sent_) {
        SDO_CHECK(t.succeeded(), "confirmed expedited download must succeed; client is {}",
                  state_text(t));
        expect_sent_nothing("after the confirmation of an expedited download");
        phase_ = Phase::ended;
        return;
      }
      offset_ = 0;
      toggle_ = false;
      return expect_download_segment();
    }

    case Phase::download_segment: {
      const auto* response = std::get_if<DownloadSegmentResponse>(&message);
      if (response == nullptr) {
        return expect_protocol_failure(to_string(message) + " answers a download segment");
      }
      if (response->toggle != toggle_) {
        return expect_protocol_failure(
            fmt::format("the confirmation has toggle {} where the segment had {}",
                        response->toggle ? 1 : 0, toggle_ ? 1 : 0));
      }
      if (last_segment_sent_) {
        SDO_CHECK(t.succeeded(),
                  "confirmed last download segment must end the download; client "
                  "is {}",
                  state_text(t));
        expect_sent_nothing("after the confirmation of the last segment");
        phase_ = Phase::ended;
        return;
      }
      toggle_ = !toggle_;
      return expect_download_segment();
    }

    case Phase::block_download_initiate: {
      const auto* response = std::get_if<BlockDownloadInitiateResponse>(&message);
      if (response == nullptr) {
        return expect_protocol_failure(to_string(message) + " answers a block download initiate");
      }
      if (response->mux != spec_.mux) {
        return expect_protocol_failure(fmt::format("the answer names {}", response->mux));
      }
      if (!valid_block_size(response->block_size)) {
        return expect_protocol_failure(
            fmt::format("the server's blksize is {}", response->block_size));
      }
      crc_both_ = spec_.block_crc && response->crc_supported;
      server_block_size_ = response->block_size;
      offset_ = 0;
      return expect_block_download_sub_block();
    }

    case Phase::block_download_ack: {
      const auto* ack = std::get_if<BlockDownloadAck>(&message);
      if (ack == nullptr) {
        return expect_protocol_failure(to_string(message) + " answers a sub-block");
      }
      if (ack->ackseq > sub_block_count_) {
        return expect_protocol_failure(
            fmt::format("ackseq {} acknowledges more than the {} "
                        "segments sent",
                        ack->ackseq, sub_block_count_));
      }
      if (!valid_block_size(ack->block_size)) {
        return expect_protocol_failure(fmt::format("the server's blksize is {}", ack->block_size));
      }
      offset_ = std::min(data.size(), offset_ + std::size_t{ack->ackseq} * kSdoSegmentDataLength);
      server_block_size_ = ack->block_size;
      if (sub_block_has_last_ && ack->ackseq == sub_block_count_) {
        const auto unused = static_cast<std::uint8_t>(
            data.empty() ? kSdoSegmentDataLength
                         : (kSdoSegmentDataLength - data.size() % kSdoSegmentDataLength) %
                               kSdoSegmentDataLength);
        const std::uint16_t crc = crc_both_ ? crc16_ccitt(data) : 0;
        const SdoClientMessage request = expect_one_sent("end block download request");
        const auto* end = std::get_if<BlockDownloadEndRequest>(&request);
        SDO_CHECK(end != nullptr && end->unused_bytes == unused && end->crc == crc,
                  "end of a {}-byte block download must say n={} crc={:04X}; client sent {}",
                  data.size(), unused, crc, to_string(request));
        phase_ = Phase::block_download_end;
        return;
      }
      return expect_block_download_sub_block();
    }

    case Phase::block_download_end:
      if (!std::holds_alternative<BlockDownloadEndResponse>(message)) {
        return expect_protocol_failure(to_string(message) + " answers an end block download");
      }
      SDO_CHECK(t.succeeded(), "confirmed block download end must succeed; client is {}",
                state_text(t));
      expect_sent_nothing("after the end of a block download");
      phase_ = Phase::ended;
      return;

    case Phase::block_upload_initiate: {
      if (std::holds_alternative<InitiateUploadResponse>(message)) {
        if (spec_.protocol_switch_threshold == 0) {
          return expect_protocol_failure("the server switched protocol although pst was 0");
        }
        return on_upload_initiate_response(message);
      }
      const auto* response = std::get_if<BlockUploadInitiateResponse>(&message);
      if (response == nullptr) {
        return expect_protocol_failure(to_string(message) + " answers a block upload initiate");
      }
      if (response->mux != spec_.mux) {
        return expect_protocol_failure(fmt::format("the answer names {}", response->mux));
      }
      size_indicated_ = response->size_indicated;
      size_ = response->size;
      crc_both_ = spec_.block_crc && response->crc_supported;
      if (size_indicated_ && size_ > spec_.max_upload_size) {
        return expect_protocol_failure("the indicated size exceeds max_upload_size");
      }
      const SdoClientMessage request = expect_one_sent("start block upload");
      SDO_CHECK(std::holds_alternative<BlockUploadStart>(request),
                "block upload initiate response must be answered by start; client sent {}",
                to_string(request));
      received_.clear();
      expected_seqno_ = 1;
      last_in_sequence_ = false;
      phase_ = Phase::block_upload_segments;
      return;
    }

    case Phase::block_upload_segments: {
      const auto* segment = std::get_if<BlockSegment>(&message);
      if (segment == nullptr) {
        return expect_protocol_failure(to_string(message) + " inside a sub-block");
      }
      if (segment->seqno == 0 || segment->seqno > spec_.block_size) {
        return expect_protocol_failure(
            fmt::format("seqno {} is outside 1..blksize {}", segment->seqno, spec_.block_size));
      }
      bool may_stop = false;
      if (segment->seqno == expected_seqno_) {
        received_.insert(received_.end(), segment->data.begin(), segment->data.end());
        ++expected_seqno_;
        last_in_sequence_ = segment->last;
        // Data certainly received (the last segment may be all padding).
        const std::size_t certain =
            received_.size() - (segment->last ? kSdoSegmentDataLength : std::size_t{0});
        may_stop = (size_indicated_ && certain > size_) || certain > spec_.max_upload_size;
      }
      if (may_stop && t.failed()) {
        return expect_protocol_failure("the block upload carries more data than allowed");
      }
      SDO_CHECK(t.running(), "in-range block segment {} must not end the transfer; client is {}",
                to_string(message), state_text(t));
      if (segment->seqno == spec_.block_size || segment->last) {
        const SdoClientMessage request = expect_one_sent("block upload acknowledgement");
        const auto* ack = std::get_if<BlockUploadAck>(&request);
        SDO_CHECK(ack != nullptr && ack->ackseq == expected_seqno_ - 1 &&
                      ack->block_size == spec_.block_size,
                  "end of a sub-block must be acknowledged with ackseq {} blksize {}; client "
                  "sent {}",
                  expected_seqno_ - 1, spec_.block_size, to_string(request));
        expected_seqno_ = 1;
        if (last_in_sequence_) phase_ = Phase::block_upload_end;
      } else {
        expect_sent_nothing("inside a sub-block");
      }
      return;
    }

    case Phase::block_upload_end: {
      const auto* end = std::get_if<BlockUploadEndRequest>(&message);
      if (end == nullptr) {
        return expect_protocol_failure(to_string(message) +
                                       " where the end of a block upload "
                                       "is due");
      }
      if (end->unused_bytes > received_.size()) {
        return expect_protocol_failure("n exceeds the data received");
      }
      std::vector<std::uint8_t> result(received_.begin(), received_.end() - end->unused_bytes);
      if (size_indicated_ && result.size() != size_) {
        return expect_protocol_failure(
            fmt::format("{} bytes arrived where {} were indicated", result.size(), size_));
      }
      if (result.size() > spec_.max_upload_size) {
        return expect_protocol_failure("the upload exceeds max_upload_size");
      }
      if (crc_both_ && crc16_ccitt(result) != end->crc) {
        return expect_protocol_failure(
            fmt::format("CRC {:04X} is not the data's {:04X}", end->crc, crc16_ccitt(result)));
      }
      SDO_CHECK(t.succeeded() && same_bytes(t.data(), result),
                "a valid end of block upload must end it with data {}; client is {} with data {}",
                hex(result), state_text(t), hex(t.data()));
      const SdoClientMessage request = expect_one_sent("end block upload response");
      SDO_CHECK(std::holds_alternative<BlockUploadEndResponse>(request),
                "end of block upload must be confirmed; client sent {}", to_string(request));
      phase_ = Phase::ended;
      return;
    }

    case Phase::not_started:
    case Phase::ended:
      SDO_CHECK(false, "answer {} in phase {} of a running transfer", to_string(message),
                static_cast<int>(phase_));
  }
}

// --- time -------------------------------------------------------------------------------------

void SdoConversationChecker::on_time(can::TimePoint now, std::span<const can::Frame> sent,
                                     const SdoClientTransfer& transfer) {
  transfer_ = &transfer;
  sent_ = sent;
  record('t', can::Frame{}, now);
  for (const can::Frame& out : sent)
    record('>', out, now);
  const SdoClientTransfer& t = transfer;
  if (!running_before_) {
    SDO_CHECK(sent.empty() && t.state() == state_before_,
              "a time step changed a transfer that had ended ({} -> {})", state_name(state_before_),
              state_text(t));
  } else if (now >= deadline_before_) {
    SDO_CHECK(t.failed() && t.error() == make_error_code(SdoClientError::timeout),
              "no answer by the deadline must time out; client is {}", state_text(t));
    expect_protocol_failure("no answer came by the deadline");
  } else {
    SDO_CHECK(t.running() && sent.empty() && t.next_deadline() == deadline_before_,
              "a time step {} ns before the deadline changed the transfer (client is {})",
              (deadline_before_ - now).count(), state_text(t));
  }
  finish_call(now);
}

}  // namespace drivecheck::fuzz
