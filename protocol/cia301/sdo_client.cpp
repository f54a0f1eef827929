#include "protocol/cia301/sdo_client.hpp"

#include <algorithm>
#include <limits>
#include <string>
#include <utility>

namespace drivecheck::cia301 {
namespace {

class SdoClientCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "sdo-client"; }
  std::string message(int value) const override {
    switch (static_cast<SdoClientError>(value)) {
      case SdoClientError::timeout:
        return "SDO server did not answer in time";
      case SdoClientError::wrong_multiplexer:
        return "SDO answer names another index/sub-index than the request";
      case SdoClientError::toggle_mismatch:
        return "SDO segment answer has the wrong toggle bit";
      case SdoClientError::unexpected_response:
        return "SDO answer does not fit this phase of the transfer";
      case SdoClientError::invalid_response:
        return "frame on the SDO response COB-ID is not a valid SDO frame";
      case SdoClientError::size_mismatch:
        return "SDO data length differs from the indicated size";
      case SdoClientError::data_too_large:
        return "SDO upload exceeds the client's maximum size";
      case SdoClientError::crc_mismatch:
        return "SDO block transfer CRC does not match the data";
      case SdoClientError::sequence_error:
        return "SDO block transfer sequence number out of range";
      case SdoClientError::invalid_block_size:
        return "SDO block size from the server is out of range (1..127)";
      case SdoClientError::aborted_locally:
        return "SDO transfer aborted by the client";
      case SdoClientError::busy:
        return "an SDO transfer is already running";
      case SdoClientError::invalid_argument:
        return "SDO transfer argument or option out of range";
      case SdoClientError::interrupted:
        return "SDO transfer interrupted (bus stopped)";
    }
    return "unknown SDO client error " + std::to_string(value);
  }
};

constexpr bool valid_block_size(std::uint8_t size) {
  return size >= 1 && size <= kSdoMaxBlockSize;
}

}  // namespace

const std::error_category& sdo_client_category() {
  static const SdoClientCategory category;
  return category;
}

std::error_code make_error_code(SdoClientError error) {
  return {static_cast<int>(error), sdo_client_category()};
}

std::optional<SdoAbort> abort_code_for(SdoClientError error) {
  switch (error) {
    case SdoClientError::timeout:
      return SdoAbort::protocol_timed_out;
    case SdoClientError::toggle_mismatch:
      return SdoAbort::toggle_bit_not_alternated;
    case SdoClientError::unexpected_response:
    case SdoClientError::invalid_response:
      return SdoAbort::invalid_command_specifier;
    case SdoClientError::invalid_block_size:
      return SdoAbort::invalid_block_size;
    case SdoClientError::sequence_error:
      return SdoAbort::invalid_sequence_number;
    case SdoClientError::crc_mismatch:
      return SdoAbort::crc_error;
    case SdoClientError::data_too_large:
      return SdoAbort::out_of_memory;
    case SdoClientError::size_mismatch:
      return SdoAbort::length_mismatch;
    case SdoClientError::wrong_multiplexer:
    case SdoClientError::interrupted:
      return SdoAbort::general_error;
    case SdoClientError::aborted_locally:
    case SdoClientError::busy:
    case SdoClientError::invalid_argument:
      return std::nullopt;
  }
  return std::nullopt;
}

std::optional<std::uint32_t> server_abort_code(const std::error_code& error) {
  if (error.category() != sdo_abort_category()) return std::nullopt;
  return static_cast<std::uint32_t>(error.value());
}

// --- SdoClientTransfer -------------------------------------------------------------------

SdoClientTransfer::SdoClientTransfer(std::uint8_t node_id, SdoClientOptions options)
    : options_(std::move(options)),
      cob_ids_(options_.cob_ids.value_or(SdoCobIds::for_node(node_id))) {
  out_.reserve(kSdoMaxBlockSize + 1);
}

std::span<const can::Frame> SdoClientTransfer::start_upload(Multiplexer mux, can::TimePoint now) {
  return start_upload(mux, now, options_.upload_mode);
}

std::span<const can::Frame> SdoClientTransfer::start_upload(Multiplexer mux, can::TimePoint now,
                                                            SdoTransferMode mode) {
  out_.clear();
  if (!prepare_start()) return out_;
  upload_ = true;
  mux_ = mux;
  mode_ = mode;
  data_.clear();
  if (mode == SdoTransferMode::block) {
    if (!valid_block_size(options_.block_size)) {
      reject_start(SdoClientError::invalid_argument);
      return out_;
    }
    BlockUploadInitiateRequest request{mux, options_.block_crc, options_.block_size,
                                       options_.protocol_switch_threshold};
    emit(encode_payload(request));
    phase_ = Phase::block_upload_initiate;
    expect_answer(now);
    return out_;
  }
  start_initiate_upload(now);
  return out_;
}

std::span<const can::Frame> SdoClientTransfer::start_download(Multiplexer mux,
                                                              std::span<const std::uint8_t> data,
                                                              can::TimePoint now) {
  return start_download(mux, data, now, options_.download_mode);
}

std::span<const can::Frame> SdoClientTransfer::start_download(Multiplexer mux,
                                                              std::span<const std::uint8_t> data,
                                                              can::TimePoint now,
                                                              SdoTransferMode mode) {
  out_.clear();
  if (!prepare_start()) return out_;
  upload_ = false;
  mux_ = mux;
  mode_ = mode;
  if (data.size() > std::numeric_limits<std::uint32_t>::max()) {
    reject_start(SdoClientError::invalid_argument);
    return out_;
  }
  data_.assign(data.begin(), data.end());
  offset_ = 0;
  if (mode == SdoTransferMode::block) {
    BlockDownloadInitiateRequest request{mux, options_.block_crc, true,
                                         static_cast<std::uint32_t>(data_.size())};
    emit(encode_payload(request));
    phase_ = Phase::block_download_initiate;
    expect_answer(now);
    return out_;
  }
  start_initiate_download(now);
  return out_;
}

bool SdoClientTransfer::prepare_start() {
  if (state_ == State::running) {
    // The running transfer goes on; this call only reports that it cannot start.
    return false;
  }
  state_ = State::running;
  error_.clear();
  sent_abort_.reset();
  kind_ = SdoTransferKind::none;
  fell_back_ = false;
  toggle_ = false;
  size_indicated_ = false;
  size_ = 0;
  offset_ = 0;
  last_sent_ = false;
  crc_ = false;
  block_size_ = 0;
  segments_sent_ = 0;
  sub_block_has_last_ = false;
  expected_seqno_ = 1;
  last_received_ = false;
  return true;
}

void SdoClientTransfer::reject_start(SdoClientError error) {
  state_ = State::failed;
  phase_ = Phase::idle;
  deadline_ = can::kForever;
  error_ = make_error_code(error);
}

void SdoClientTransfer::emit(const SdoPayload& payload) {
  out_.push_back(make_sdo_frame(cob_ids_.request, payload, cob_ids_.format));
}

void SdoClientTransfer::expect_answer(can::TimePoint now) {
  deadline_ = now >= can::kForever - options_.timeout ? can::kForever : now + options_.timeout;
}

void SdoClientTransfer::succeed() {
  state_ = State::succeeded;
  phase_ = Phase::idle;
  deadline_ = can::kForever;
}

void SdoClientTransfer::fail(SdoClientError error) {
  if (const auto code = abort_code_for(error)) {
    const auto value = static_cast<std::uint32_t>(*code);
    emit(encode_payload(AbortTransfer{mux_, value}));
    sent_abort_ = value;
  }
  state_ = State::failed;
  phase_ = Phase::idle;
  deadline_ = can::kForever;
  error_ = make_error_code(error);
}

void SdoClientTransfer::fail_with_server_abort(std::uint32_t code) {
  state_ = State::failed;
  phase_ = Phase::idle;
  deadline_ = can::kForever;
  error_ = std::error_code(static_cast<int>(code), sdo_abort_category());
}

void SdoClientTransfer::start_initiate_upload(can::TimePoint now) {
  emit(encode_payload(InitiateUploadRequest{mux_}));
  phase_ = Phase::upload_initiate;
  expect_answer(now);
}

void SdoClientTransfer::start_initiate_download(can::TimePoint now) {
  offset_ = 0;
  if (mode_ != SdoTransferMode::segmented && !data_.empty() && data_.size() <= 4) {
    emit(encode_payload(InitiateDownloadRequest::make_expedited(mux_, data_)));
    kind_ = SdoTransferKind::expedited;
  } else {
    emit(encode_payload(
        InitiateDownloadRequest::make_segmented(mux_, static_cast<std::uint32_t>(data_.size()))));
    kind_ = SdoTransferKind::segmented;
  }
  phase_ = Phase::download_initiate;
  expect_answer(now);
}

std::span<const can::Frame> SdoClientTransfer::on_frame(const can::Frame& frame,
                                                        can::TimePoint now) {
  out_.clear();
  if (state_ != State::running) return out_;
  if (frame.id != cob_ids_.response || frame.format != cob_ids_.format || frame.is_error()) {
    return out_;
  }
  const SdoFraming framing =
      phase_ == Phase::block_upload_sub_block ? SdoFraming::block_segment : SdoFraming::command;
  const SdoServerMessage message = decode_server_message(frame, framing);
  if (handle_common(message)) return out_;
  switch (phase_) {
    case Phase::upload_initiate:
      on_upload_initiate(message, now);
      break;
    case Phase::upload_segment:
      on_upload_segment(message, now);
      break;
    case Phase::download_initiate:
      on_download_initiate(message, now);
      break;
    case Phase::download_segment:
      on_download_segment(message, now);
      break;
    case Phase::block_download_initiate:
      on_block_download_initiate(message, now);
      break;
    case Phase::block_download_sub_block:
      on_block_download_ack(message, now);
      break;
    case Phase::block_download_end:
      on_block_download_end(message);
      break;
    case Phase::block_upload_initiate:
      on_block_upload_initiate(message, now);
      break;
    case Phase::block_upload_sub_block:
      on_block_upload_segment(message, now);
      break;
    case Phase::block_upload_end:
      on_block_upload_end(message);
      break;
    case Phase::idle:
      break;
  }
  return out_;
}

std::span<const can::Frame> SdoClientTransfer::on_time(can::TimePoint now) {
  out_.clear();
  if (state_ == State::running && now >= deadline_) fail(SdoClientError::timeout);
  return out_;
}

std::span<const can::Frame> SdoClientTransfer::abort(std::uint32_t code) {
  out_.clear();
  if (state_ != State::running) return out_;
  emit(encode_payload(AbortTransfer{mux_, code}));
  sent_abort_ = code;
  state_ = State::failed;
  phase_ = Phase::idle;
  deadline_ = can::kForever;
  error_ = make_error_code(SdoClientError::aborted_locally);
  return out_;
}

void SdoClientTransfer::cancel() {
  if (state_ != State::running) return;
  state_ = State::failed;
  phase_ = Phase::idle;
  deadline_ = can::kForever;
  error_ = make_error_code(SdoClientError::aborted_locally);
}

can::TimePoint SdoClientTransfer::next_deadline() const {
  return state_ == State::running ? deadline_ : can::kForever;
}

bool SdoClientTransfer::handle_common(const SdoServerMessage& message) {
  if (const auto* abort = std::get_if<AbortTransfer>(&message)) {
    const bool block_initiate =
        phase_ == Phase::block_download_initiate || phase_ == Phase::block_upload_initiate;
    if (block_initiate && options_.block_fallback &&
        abort->code == static_cast<std::uint32_t>(SdoAbort::invalid_command_specifier)) {
      return false;  // the initiate handler falls back to segmented transfer
    }
    fail_with_server_abort(abort->code);
    return true;
  }
  if (std::holds_alternative<SdoInvalid>(message)) {
    fail(SdoClientError::invalid_response);
    return true;
  }
  return false;
}

bool SdoClientTransfer::check_mux(Multiplexer answered) {
  if (answered == mux_) return true;
  fail(SdoClientError::wrong_multiplexer);
  return false;
}

// Upload ------------------------------------------------------------------------------------

void SdoClientTransfer::on_upload_initiate(const SdoServerMessage& message, can::TimePoint now) {
  const auto* response = std::get_if<InitiateUploadResponse>(&message);
  if (response == nullptr) return fail(SdoClientError::unexpected_response);
  if (!check_mux(response->mux)) return;
  if (response->expedited) {
    const auto bytes = response->expedited_data();
    if (bytes.size() > options_.max_upload_size) return fail(SdoClientError::data_too_large);
    data_.assign(bytes.begin(), bytes.end());
    kind_ = SdoTransferKind::expedited;
    return succeed();
  }
  kind_ = SdoTransferKind::segmented;
  size_indicated_ = response->size_indicated;
  size_ = response->size;
  if (size_indicated_ && size_ > options_.max_upload_size) {
    return fail(SdoClientError::data_too_large);
  }
  if (size_indicated_) data_.reserve(size_);
  toggle_ = false;
  emit(encode_payload(UploadSegmentRequest{toggle_}));
  phase_ = Phase::upload_segment;
  expect_answer(now);
}

void SdoClientTransfer::on_upload_segment(const SdoServerMessage& message, can::TimePoint now) {
  const auto* response = std::get_if<UploadSegmentResponse>(&message);
  if (response == nullptr) return fail(SdoClientError::unexpected_response);
  if (response->toggle != toggle_) return fail(SdoClientError::toggle_mismatch);
  const auto bytes = response->segment_data();
  if (size_indicated_ && data_.size() + bytes.size() > size_) {
    return fail(SdoClientError::size_mismatch);
  }
  if (data_.size() + bytes.size() > options_.max_upload_size) {
    return fail(SdoClientError::data_too_large);
  }
  data_.insert(data_.end(), bytes.begin(), bytes.end());
  if (response->last) {
    if (size_indicated_ && data_.size() != size_) return fail(SdoClientError::size_mismatch);
    return succeed();
  }
  toggle_ = !toggle_;
  emit(encode_payload(UploadSegmentRequest{toggle_}));
  expect_answer(now);
}

// Download ----------------------------------------------------------------------------------

void SdoClientTransfer::on_download_initiate(const SdoServerMessage& message, can::TimePoint now) {
  const auto* response = std::get_if<InitiateDownloadResponse>(&message);
  if (response == nullptr) return fail(SdoClientError::unexpected_response);
  if (!check_mux(response->mux)) return;
  if (kind_ == SdoTransferKind::expedited) return succeed();
  toggle_ = false;
  phase_ = Phase::download_segment;
  send_download_segment(now);
}

void SdoClientTransfer::send_download_segment(can::TimePoint now) {
  const std::size_t length = std::min(kSdoSegmentDataLength, data_.size() - offset_);
  last_sent_ = offset_ + length == data_.size();
  emit(encode_payload(DownloadSegmentRequest::make(
      toggle_, last_sent_, std::span<const std::uint8_t>(data_).subspan(offset_, length))));
  offset_ += length;
  expect_answer(now);
}

void SdoClientTransfer::on_download_segment(const SdoServerMessage& message, can::TimePoint now) {
  const auto* response = std::get_if<DownloadSegmentResponse>(&message);
  if (response == nullptr) return fail(SdoClientError::unexpected_response);
  if (response->toggle != toggle_) return fail(SdoClientError::toggle_mismatch);
  if (last_sent_) return succeed();
  toggle_ = !toggle_;
  send_download_segment(now);
}

// Block download ----------------------------------------------------------------------------

void SdoClientTransfer::on_block_download_initiate(const SdoServerMessage& message,
                                                   can::TimePoint now) {
  if (const auto* abort = std::get_if<AbortTransfer>(&message)) {
    // handle_common() let only the fallback case through.
    static_cast<void>(abort);
    fell_back_ = true;
    mode_ = SdoTransferMode::automatic;
    return start_initiate_download(now);
  }
  const auto* response = std::get_if<BlockDownloadInitiateResponse>(&message);
  if (response == nullptr) return fail(SdoClientError::unexpected_response);
  if (!check_mux(response->mux)) return;
  if (!valid_block_size(response->block_size)) return fail(SdoClientError::invalid_block_size);
  kind_ = SdoTransferKind::block;
  crc_ = options_.block_crc && response->crc_supported;
  block_size_ = response->block_size;
  offset_ = 0;
  phase_ = Phase::block_download_sub_block;
  send_block_sub_block(now);
}

void SdoClientTransfer::send_block_sub_block(can::TimePoint now) {
  const std::size_t remaining = data_.size() - offset_;
  // At least one segment: an empty download still sends one (c=1, n=7 in the end request).
  const std::size_t needed = std::max<std::size_t>(1, (remaining + 6) / 7);
  const std::size_t count = std::min<std::size_t>(block_size_, needed);
  sub_block_has_last_ = count == needed;
  segments_sent_ = static_cast<std::uint8_t>(count);
  std::size_t at = offset_;
  for (std::size_t seqno = 1; seqno <= count; ++seqno) {
    const std::size_t length = std::min(kSdoSegmentDataLength, data_.size() - at);
    const bool last = sub_block_has_last_ && seqno == count;
    emit(encode_payload(
        BlockSegment::make(static_cast<std::uint8_t>(seqno), last,
                           std::span<const std::uint8_t>(data_).subspan(at, length))));
    at += length;
  }
  expect_answer(now);
}

void SdoClientTransfer::on_block_download_ack(const SdoServerMessage& message, can::TimePoint now) {
  const auto* ack = std::get_if<BlockDownloadAck>(&message);
  if (ack == nullptr) return fail(SdoClientError::unexpected_response);
  if (ack->ackseq > segments_sent_) return fail(SdoClientError::sequence_error);
  if (!valid_block_size(ack->block_size)) return fail(SdoClientError::invalid_block_size);
  offset_ = std::min(data_.size(), offset_ + std::size_t{ack->ackseq} * kSdoSegmentDataLength);
  block_size_ = ack->block_size;
  if (sub_block_has_last_ && ack->ackseq == segments_sent_) {
    const std::size_t tail = data_.size() % kSdoSegmentDataLength;
    BlockDownloadEndRequest end;
    end.unused_bytes = static_cast<std::uint8_t>(data_.empty() ? kSdoSegmentDataLength
                                                               : (kSdoSegmentDataLength - tail) %
                                                                     kSdoSegmentDataLength);
    end.crc = crc_ ? crc16_ccitt(data_) : 0;
    emit(encode_payload(end));
    phase_ = Phase::block_download_end;
    return expect_answer(now);
  }
  // Segments after ackseq were lost: they go again, numbered from 1, in the next sub-block.
  send_block_sub_block(now);
}

void SdoClientTransfer::on_block_download_end(const SdoServerMessage& message) {
  if (!std::holds_alternative<BlockDownloadEndResponse>(message)) {
    return fail(SdoClientError::unexpected_response);
  }
  succeed();
}

// Block upload ------------------------------------------------------------------------------

void SdoClientTransfer::on_block_upload_initiate(const SdoServerMessage& message,
                                                 can::TimePoint now) {
  if (std::holds_alternative<AbortTransfer>(message)) {
    fell_back_ = true;
    mode_ = SdoTransferMode::automatic;
    return start_initiate_upload(now);
  }
  if (std::holds_alternative<InitiateUploadResponse>(message)) {
    // Protocol switch (CiA 301 §7.2.4.3.13): allowed only when the client offered a pst.
    if (options_.protocol_switch_threshold == 0) return fail(SdoClientError::unexpected_response);
    return on_upload_initiate(message, now);
  }
  const auto* response = std::get_if<BlockUploadInitiateResponse>(&message);
  if (response == nullptr) return fail(SdoClientError::unexpected_response);
  if (!check_mux(response->mux)) return;
  kind_ = SdoTransferKind::block;
  crc_ = options_.block_crc && response->crc_supported;
  size_indicated_ = response->size_indicated;
  size_ = response->size;
  if (size_indicated_ && size_ > options_.max_upload_size) {
    return fail(SdoClientError::data_too_large);
  }
  if (size_indicated_) data_.reserve(size_ + kSdoSegmentDataLength);
  block_size_ = options_.block_size;
  expected_seqno_ = 1;
  last_received_ = false;
  emit(encode_payload(BlockUploadStart{}));
  phase_ = Phase::block_upload_sub_block;
  expect_answer(now);
}

void SdoClientTransfer::on_block_upload_segment(const SdoServerMessage& message,
                                                can::TimePoint now) {
  const auto* segment = std::get_if<BlockSegment>(&message);
  if (segment == nullptr) return fail(SdoClientError::unexpected_response);
  if (segment->seqno == 0 || segment->seqno > block_size_) {
    return fail(SdoClientError::sequence_error);
  }
  if (segment->seqno == expected_seqno_) {
    // A segment in sequence: all 7 bytes are data except in the last one, which the end
    // request trims by n (n = 7: no data, as in the one segment of an empty transfer).
    const std::size_t least = segment->last ? 0 : kSdoSegmentDataLength;
    if (size_indicated_ && data_.size() + least > size_) return fail(SdoClientError::size_mismatch);
    if (data_.size() + least > options_.max_upload_size) {
      return fail(SdoClientError::data_too_large);
    }
    data_.insert(data_.end(), segment->data.begin(), segment->data.end());
    ++expected_seqno_;
    last_received_ = segment->last;
  }
  // Out of sequence (lost or repeated segments): ignored; ackseq tells the server where to
  // resume. The sub-block ends with its last seqno or with the c bit.
  if (segment->seqno == block_size_ || segment->last) {
    emit(encode_payload(
        BlockUploadAck{static_cast<std::uint8_t>(expected_seqno_ - 1), options_.block_size}));
    block_size_ = options_.block_size;
    expected_seqno_ = 1;
    if (last_received_) phase_ = Phase::block_upload_end;
  }
  expect_answer(now);
}

void SdoClientTransfer::on_block_upload_end(const SdoServerMessage& message) {
  const auto* end = std::get_if<BlockUploadEndRequest>(&message);
  if (end == nullptr) return fail(SdoClientError::unexpected_response);
  if (end->unused_bytes > data_.size()) return fail(SdoClientError::size_mismatch);
  data_.erase(data_.end() - end->unused_bytes, data_.end());
  if (size_indicated_ && data_.size() != size_) return fail(SdoClientError::size_mismatch);
  if (data_.size() > options_.max_upload_size) return fail(SdoClientError::data_too_large);
  if (crc_ && crc16_ccitt(data_) != end->crc) return fail(SdoClientError::crc_mismatch);
  emit(encode_payload(BlockUploadEndResponse{}));
  succeed();
}

// --- SdoClient -----------------------------------------------------------------------------

SdoClient::SdoClient(can::Bus& bus, std::uint8_t node_id, SdoClientOptions options)
    : bus_(bus), transfer_(node_id, std::move(options)) {}

Expected<std::vector<std::uint8_t>, std::error_code> SdoClient::upload(Multiplexer mux) {
  return upload(mux, transfer_.options().upload_mode);
}

Expected<std::vector<std::uint8_t>, std::error_code> SdoClient::upload(Multiplexer mux,
                                                                       SdoTransferMode mode) {
  if (transfer_.running()) return Unexpected(make_error_code(SdoClientError::busy));
  drain();
  if (const std::error_code error = run(transfer_.start_upload(mux, bus_.now(), mode))) {
    return Unexpected(error);
  }
  const auto data = transfer_.data();
  return std::vector<std::uint8_t>(data.begin(), data.end());
}

Expected<void, std::error_code> SdoClient::download(Multiplexer mux,
                                                    std::span<const std::uint8_t> data) {
  return download(mux, data, transfer_.options().download_mode);
}

Expected<void, std::error_code> SdoClient::download(Multiplexer mux,
                                                    std::span<const std::uint8_t> data,
                                                    SdoTransferMode mode) {
  if (transfer_.running()) return Unexpected(make_error_code(SdoClientError::busy));
  drain();
  if (const std::error_code error = run(transfer_.start_download(mux, data, bus_.now(), mode))) {
    return Unexpected(error);
  }
  return {};
}

std::error_code SdoClient::send_all(std::span<const can::Frame> frames) {
  for (const can::Frame& frame : frames) {
    if (const std::error_code error = bus_.send(frame)) return error;
  }
  return {};
}

void SdoClient::pass_on(const can::TimedFrame& frame) {
  if (!frame.own && transfer_.options().other_frames) transfer_.options().other_frames(frame);
}

void SdoClient::drain() {
  // Answers that came after an earlier transfer ended (a late reply after a timeout) must not
  // be taken for answers to the next request.
  const can::TimePoint now = bus_.now();
  while (auto stale = bus_.receive(now)) {
    const bool ours = stale->frame.id == transfer_.cob_ids().response &&
                      stale->frame.format == transfer_.cob_ids().format;
    if (!ours) pass_on(*stale);
  }
}

std::error_code SdoClient::run(std::span<const can::Frame> first) {
  if (const std::error_code error = send_all(first)) {
    // The request never left: nothing to abort on the bus.
    transfer_.cancel();
    return error;
  }
  while (transfer_.running()) {
    const can::TimePoint deadline = transfer_.next_deadline();
    // A timer at the deadline keeps a simulated bus running until then even when no other
    // event is left, so that receive() returning early can only mean stop().
    const can::TimerId keep_alive = bus_.start_timer(deadline, [] {});
    auto received = bus_.receive(deadline);
    bus_.cancel_timer(keep_alive);
    std::span<const can::Frame> reply;
    if (!received) {
      if (bus_.now() < deadline) {
        static_cast<void>(send_all(transfer_.abort(SdoAbort::general_error)));
        return make_error_code(SdoClientError::interrupted);
      }
      reply = transfer_.on_time(bus_.now());
    } else if (received->own || received->frame.id != transfer_.cob_ids().response ||
               received->frame.format != transfer_.cob_ids().format) {
      pass_on(*received);
      continue;
    } else {
      reply = transfer_.on_frame(received->frame, received->timestamp);
    }
    if (const std::error_code error = send_all(reply)) {
      transfer_.cancel();
      return error;
    }
  }
  return transfer_.succeeded() ? std::error_code{} : transfer_.error();
}

}  // namespace drivecheck::cia301
