#include "protocol/cia301/sdo_server.hpp"

#include <algorithm>
#include <limits>
#include <utility>
#include <variant>

namespace drivecheck::cia301 {
namespace {

constexpr bool valid_block_size(std::uint8_t size) {
  return size >= 1 && size <= kSdoMaxBlockSize;
}

constexpr std::uint8_t clamp_block_size(std::uint8_t size) {
  return size == 0 ? 1 : std::min(size, kSdoMaxBlockSize);
}

constexpr std::uint32_t code_of(SdoAbort abort) {
  return static_cast<std::uint32_t>(abort);
}

// Segments a block transfer of `remaining` bytes needs: at least one, also for no data.
constexpr std::size_t segments_for(std::size_t remaining) {
  return std::max<std::size_t>(1, (remaining + kSdoSegmentDataLength - 1) / kSdoSegmentDataLength);
}

can::TimePoint deadline_after(can::TimePoint now, can::Duration timeout) {
  if (timeout <= can::Duration::zero()) return now;
  return now >= can::kForever - timeout ? can::kForever : now + timeout;
}

}  // namespace

// --- SdoServer -----------------------------------------------------------------------------

SdoServer::SdoServer(ObjectDictionary& dictionary, SdoServerConfig config)
    : od_(dictionary), config_(std::move(config)) {
  config_.block_size = clamp_block_size(config_.block_size);
}

bool SdoServer::is_request(const can::Frame& frame) const {
  return enabled_ && frame.id == config_.rx_cob_id && frame.format == config_.format &&
         !frame.is_error();
}

void SdoServer::set_channel(std::uint32_t rx_cob_id, std::uint32_t tx_cob_id, bool enabled) {
  if (rx_cob_id == config_.rx_cob_id && tx_cob_id == config_.tx_cob_id && enabled == enabled_) {
    return;
  }
  close();
  config_.rx_cob_id = rx_cob_id;
  config_.tx_cob_id = tx_cob_id;
  enabled_ = enabled;
}

void SdoServer::set_block_size(std::uint8_t block_size) {
  config_.block_size = clamp_block_size(block_size);
}

std::span<const can::Frame> SdoServer::on_frame(const can::Frame& frame, can::TimePoint now) {
  out_count_ = 0;
  if (!is_request(frame)) return output();
  ++stats_.requests;
  expire(now);
  if (frame.is_remote()) {
    ++stats_.ignored;
    return output();
  }
  const can::Frame* input = &frame;
  can::Frame padded;
  if (frame.length() < kSdoFrameLength) {
    if (config_.short_frames == ShortFramePolicy::ignore) {
      ++stats_.ignored;
      return output();
    }
    padded = frame;
    std::fill(padded.data.begin() + static_cast<std::ptrdiff_t>(frame.length()), padded.data.end(),
              std::uint8_t{0});
    padded.dlc = static_cast<std::uint8_t>(kSdoFrameLength);
    input = &padded;
  }
  const SdoFraming framing =
      state_ == State::block_download_sub_block ? SdoFraming::block_segment : SdoFraming::command;
  handle(decode_client_message(*input, framing), *input, now);
  return output();
}

std::span<const can::Frame> SdoServer::on_time(can::TimePoint now) {
  out_count_ = 0;
  expire(now);
  return output();
}

std::span<const can::Frame> SdoServer::abort(std::uint32_t code) {
  out_count_ = 0;
  if (state_ != State::idle) {
    send_abort(mux_, code);
    close();
  }
  return output();
}

void SdoServer::reset() {
  close();
}

void SdoServer::emit(const SdoPayload& payload) {
  // Capacity: one abort (a timeout) plus one answer or one sub-block of at most 127 segments;
  // a timeout never precedes a sub-block (a sub-block needs an open transfer).
  if (out_count_ < out_.size()) {
    out_[out_count_++] = make_sdo_frame(config_.tx_cob_id, payload, config_.format);
  }
}

void SdoServer::send_abort(Multiplexer mux, std::uint32_t code) {
  emit(encode_payload(AbortTransfer{mux, code}));
  ++stats_.aborts_sent;
}

void SdoServer::fail(SdoAbort code) {
  send_abort(mux_, code_of(code));
  close();
}

void SdoServer::close() {
  state_ = State::idle;
  deadline_ = can::kForever;
}

void SdoServer::complete() {
  ++stats_.completed;
  close();
}

void SdoServer::arm(can::TimePoint now) {
  deadline_ = deadline_after(now, config_.timeout);
}

void SdoServer::expire(can::TimePoint now) {
  if (state_ == State::idle || now < deadline_) return;
  ++stats_.timeouts;
  fail(SdoAbort::protocol_timed_out);
}

void SdoServer::handle(const SdoClientMessage& message, const can::Frame& frame,
                       can::TimePoint now) {
  if (const auto* invalid = std::get_if<SdoInvalid>(&message)) {
    // Remote, error and short frames were filtered out before: what is left is ccs 7.
    static_cast<void>(invalid);
    if (state_ == State::idle) {
      send_abort({static_cast<std::uint16_t>(frame.data[1] | frame.data[2] << 8), frame.data[3]},
                 code_of(SdoAbort::invalid_command_specifier));
    } else {
      fail(SdoAbort::invalid_command_specifier);
    }
    return;
  }
  if (std::holds_alternative<AbortTransfer>(message)) {
    // CiA 301 §7.2.4.3.17: an abort is never answered; it ends the open transfer.
    if (state_ == State::idle) {
      ++stats_.ignored;
    } else {
      ++stats_.aborts_received;
      close();
    }
    return;
  }
  switch (state_) {
    case State::idle:
      return on_idle(message, now);
    case State::download_segment:
      if (const auto* m = std::get_if<DownloadSegmentRequest>(&message)) {
        return on_download_segment(*m, now);
      }
      break;
    case State::upload_segment:
      if (const auto* m = std::get_if<UploadSegmentRequest>(&message)) {
        return on_upload_segment(*m, now);
      }
      break;
    case State::block_download_sub_block:
      if (const auto* m = std::get_if<BlockSegment>(&message)) {
        return on_block_download_segment(*m, now);
      }
      break;
    case State::block_download_end:
      if (const auto* m = std::get_if<BlockDownloadEndRequest>(&message)) {
        return on_block_download_end(*m);
      }
      break;
    case State::block_upload_start:
      if (std::holds_alternative<BlockUploadStart>(message)) {
        send_sub_block();
        state_ = State::block_upload_ack;
        return arm(now);
      }
      break;
    case State::block_upload_ack:
      if (const auto* m = std::get_if<BlockUploadAck>(&message))
        return on_block_upload_ack(*m, now);
      break;
    case State::block_upload_end:
      if (std::holds_alternative<BlockUploadEndResponse>(message)) return complete();
      break;
  }
  // Not the request this phase of the open transfer admits (a new initiate included): see
  // "One request at a time" in the header.
  fail(SdoAbort::invalid_command_specifier);
}

void SdoServer::on_idle(const SdoClientMessage& message, can::TimePoint now) {
  if (const auto* m = std::get_if<InitiateDownloadRequest>(&message)) {
    return on_initiate_download(*m, now);
  }
  if (const auto* m = std::get_if<InitiateUploadRequest>(&message)) {
    mux_ = m->mux;
    auto data = od_.read(m->mux.index, m->mux.sub_index);
    if (!data) return send_abort(mux_, code_of(data.error()));
    return on_initiate_upload(m->mux, *data, now);
  }
  if (const auto* m = std::get_if<BlockDownloadInitiateRequest>(&message)) {
    return on_block_download_initiate(*m, now);
  }
  if (const auto* m = std::get_if<BlockUploadInitiateRequest>(&message)) {
    return on_block_upload_initiate(*m, now);
  }
  // A segment, an ack, a start or an end with no transfer open (CiA 301: command specifier
  // not valid). It names no object: the abort carries 0000h:00.
  send_abort({}, code_of(SdoAbort::invalid_command_specifier));
}

Expected<void, SdoAbort> SdoServer::check_download(Multiplexer mux, bool size_indicated,
                                                   std::uint32_t size) {
  auto located = od_.locate(mux.index, mux.sub_index);
  if (!located) return Unexpected(located.error());
  const Entry& entry = **located;
  if (!is_writable(entry.access())) return Unexpected(SdoAbort::write_read_only);
  if (!size_indicated) return {};
  const std::size_t type_size = info(entry.type()).size;
  if (type_size != 0) {
    if (size > type_size) return Unexpected(SdoAbort::length_too_high);
    if (size < type_size) return Unexpected(SdoAbort::length_too_low);
  } else if (entry.definition().max_size != 0 && size > entry.definition().max_size) {
    return Unexpected(SdoAbort::length_too_high);
  }
  if (size > config_.max_download_size) return Unexpected(SdoAbort::out_of_memory);
  return {};
}

// Segmented and expedited download ---------------------------------------------------------

void SdoServer::on_initiate_download(const InitiateDownloadRequest& request, can::TimePoint now) {
  mux_ = request.mux;
  if (request.expedited) {
    std::span<const std::uint8_t> data = request.expedited_data();
    if (!request.size_indicated) {
      // s=0: 4 bytes of unspecified length; a 1..4-byte entry takes its own size.
      auto located = od_.locate(mux_.index, mux_.sub_index);
      if (!located) return send_abort(mux_, code_of(located.error()));
      const std::size_t type_size = info((*located)->type()).size;
      if (type_size != 0 && type_size < data.size()) data = data.first(type_size);
    }
    if (auto written = od_.write(mux_.index, mux_.sub_index, data); !written) {
      return send_abort(mux_, code_of(written.error()));
    }
    emit(encode_payload(InitiateDownloadResponse{mux_}));
    ++stats_.completed;
    return;
  }
  if (auto ok = check_download(mux_, request.size_indicated, request.size); !ok) {
    return send_abort(mux_, code_of(ok.error()));
  }
  buffer_.clear();
  size_indicated_ = request.size_indicated;
  size_ = request.size;
  toggle_ = false;
  state_ = State::download_segment;
  emit(encode_payload(InitiateDownloadResponse{mux_}));
  arm(now);
}

void SdoServer::on_download_segment(const DownloadSegmentRequest& request, can::TimePoint now) {
  if (request.toggle != toggle_) return fail(SdoAbort::toggle_bit_not_alternated);
  const auto data = request.segment_data();
  const std::size_t total = buffer_.size() + data.size();
  if (size_indicated_ && total > size_) return fail(SdoAbort::length_mismatch);
  if (total > config_.max_download_size) return fail(SdoAbort::out_of_memory);
  buffer_.insert(buffer_.end(), data.begin(), data.end());
  if (request.last) {
    if (size_indicated_ && total != size_) return fail(SdoAbort::length_mismatch);
    if (auto written = od_.write(mux_.index, mux_.sub_index, buffer_); !written) {
      return fail(written.error());
    }
    emit(encode_payload(DownloadSegmentResponse{toggle_}));
    return complete();
  }
  emit(encode_payload(DownloadSegmentResponse{toggle_}));
  toggle_ = !toggle_;
  arm(now);
}

// Segmented and expedited upload -----------------------------------------------------------

void SdoServer::on_initiate_upload(Multiplexer mux, std::span<const std::uint8_t> data,
                                   can::TimePoint now) {
  mux_ = mux;
  if (!data.empty() && data.size() <= 4) {
    emit(encode_payload(InitiateUploadResponse::make_expedited(mux, data)));
    ++stats_.completed;
    return;
  }
  if (data.size() > std::numeric_limits<std::uint32_t>::max()) {
    return send_abort(mux, code_of(SdoAbort::length_too_high));
  }
  buffer_.assign(data.begin(), data.end());
  offset_ = 0;
  toggle_ = false;
  state_ = State::upload_segment;
  emit(encode_payload(
      InitiateUploadResponse::make_segmented(mux, static_cast<std::uint32_t>(buffer_.size()))));
  arm(now);
}

void SdoServer::on_upload_segment(const UploadSegmentRequest& request, can::TimePoint now) {
  if (request.toggle != toggle_) return fail(SdoAbort::toggle_bit_not_alternated);
  const std::size_t length = std::min(kSdoSegmentDataLength, buffer_.size() - offset_);
  const bool last = offset_ + length == buffer_.size();
  emit(encode_payload(UploadSegmentResponse::make(
      toggle_, last, std::span<const std::uint8_t>(buffer_).subspan(offset_, length))));
  offset_ += length;
  if (last) return complete();
  toggle_ = !toggle_;
  arm(now);
}

// Block download ---------------------------------------------------------------------------

void SdoServer::on_block_download_initiate(const BlockDownloadInitiateRequest& request,
                                           can::TimePoint now) {
  mux_ = request.mux;
  if (!config_.block_transfer) {
    return send_abort(mux_, code_of(SdoAbort::invalid_command_specifier));
  }
  if (auto ok = check_download(mux_, request.size_indicated, request.size); !ok) {
    return send_abort(mux_, code_of(ok.error()));
  }
  buffer_.clear();
  size_indicated_ = request.size_indicated;
  size_ = request.size;
  crc_ = request.crc_supported && config_.block_crc;
  block_size_ = config_.block_size;
  expected_seqno_ = 1;
  last_received_ = false;
  state_ = State::block_download_sub_block;
  emit(encode_payload(BlockDownloadInitiateResponse{mux_, config_.block_crc, block_size_}));
  arm(now);
}

void SdoServer::on_block_download_segment(const BlockSegment& segment, can::TimePoint now) {
  if (segment.seqno == 0 || segment.seqno > block_size_) {
    return fail(SdoAbort::invalid_sequence_number);
  }
  if (segment.seqno == expected_seqno_) {
    if (!segment.last) {
      // Every segment but the last carries 7 data bytes: overrunning is certain now.
      const std::size_t total = buffer_.size() + kSdoSegmentDataLength;
      if (size_indicated_ && total > size_) return fail(SdoAbort::length_mismatch);
      if (total > config_.max_download_size) return fail(SdoAbort::out_of_memory);
    }
    buffer_.insert(buffer_.end(), segment.data.begin(), segment.data.end());
    ++expected_seqno_;
    last_received_ = segment.last;
  }
  // Out of sequence: not stored; the ack's ackseq makes the client resend from there.
  if (segment.seqno == block_size_ || segment.last) {
    const auto ackseq = static_cast<std::uint8_t>(expected_seqno_ - 1);
    block_size_ = config_.block_size;
    expected_seqno_ = 1;
    emit(encode_payload(BlockDownloadAck{ackseq, block_size_}));
    if (last_received_) state_ = State::block_download_end;
  }
  arm(now);
}

void SdoServer::on_block_download_end(const BlockDownloadEndRequest& request) {
  // buffer_ holds whole segments (at least one): n of the last one's 7 bytes are no data.
  if (request.unused_bytes > buffer_.size()) return fail(SdoAbort::length_mismatch);
  buffer_.resize(buffer_.size() - request.unused_bytes);
  if (crc_ && crc16_ccitt(buffer_) != request.crc) return fail(SdoAbort::crc_error);
  if (size_indicated_ && buffer_.size() != size_) return fail(SdoAbort::length_mismatch);
  if (buffer_.size() > config_.max_download_size) return fail(SdoAbort::out_of_memory);
  if (auto written = od_.write(mux_.index, mux_.sub_index, buffer_); !written) {
    return fail(written.error());
  }
  emit(encode_payload(BlockDownloadEndResponse{}));
  complete();
}

// Block upload -----------------------------------------------------------------------------

void SdoServer::on_block_upload_initiate(const BlockUploadInitiateRequest& request,
                                         can::TimePoint now) {
  mux_ = request.mux;
  if (!config_.block_transfer) {
    return send_abort(mux_, code_of(SdoAbort::invalid_command_specifier));
  }
  if (!valid_block_size(request.block_size)) {
    return send_abort(mux_, code_of(SdoAbort::invalid_block_size));
  }
  auto data = od_.read(mux_.index, mux_.sub_index);
  if (!data) return send_abort(mux_, code_of(data.error()));
  const std::uint8_t pst = request.protocol_switch_threshold;
  if (pst != 0 && data->size() <= pst) {
    // Protocol switch (§7.2.4.3.13): a normal upload initiate response, then segmented.
    return on_initiate_upload(mux_, *data, now);
  }
  if (data->size() > std::numeric_limits<std::uint32_t>::max()) {
    return send_abort(mux_, code_of(SdoAbort::length_too_high));
  }
  buffer_.assign(data->begin(), data->end());
  offset_ = 0;
  crc_ = request.crc_supported && config_.block_crc;
  block_size_ = upload_block_size(request.block_size);
  state_ = State::block_upload_start;
  emit(encode_payload(BlockUploadInitiateResponse{mux_, config_.block_crc, true,
                                                  static_cast<std::uint32_t>(buffer_.size())}));
  arm(now);
}

std::uint8_t SdoServer::upload_block_size(std::uint8_t asked) const {
  return config_.upload_block_size != 0 ? config_.upload_block_size : asked;
}

void SdoServer::send_sub_block() {
  const std::size_t needed = segments_for(buffer_.size() - offset_);
  const std::size_t count = std::min<std::size_t>(block_size_, needed);
  sub_block_has_last_ = count == needed;
  segments_sent_ = static_cast<std::uint8_t>(count);
  std::size_t at = offset_;
  for (std::size_t seqno = 1; seqno <= count; ++seqno) {
    const std::size_t length = std::min(kSdoSegmentDataLength, buffer_.size() - at);
    const bool last = sub_block_has_last_ && seqno == count;
    emit(encode_payload(
        BlockSegment::make(static_cast<std::uint8_t>(seqno), last,
                           std::span<const std::uint8_t>(buffer_).subspan(at, length))));
    at += length;
  }
}

void SdoServer::on_block_upload_ack(const BlockUploadAck& ack, can::TimePoint now) {
  if (ack.ackseq > segments_sent_) return fail(SdoAbort::invalid_sequence_number);
  if (!valid_block_size(ack.block_size)) return fail(SdoAbort::invalid_block_size);
  offset_ = std::min(buffer_.size(), offset_ + std::size_t{ack.ackseq} * kSdoSegmentDataLength);
  block_size_ = upload_block_size(ack.block_size);
  if (sub_block_has_last_ && ack.ackseq == segments_sent_) {
    const std::size_t tail = buffer_.size() % kSdoSegmentDataLength;
    BlockUploadEndRequest end;
    end.unused_bytes = static_cast<std::uint8_t>(buffer_.empty() ? kSdoSegmentDataLength
                                                                 : (kSdoSegmentDataLength - tail) %
                                                                       kSdoSegmentDataLength);
    end.crc = crc_ ? crc16_ccitt(buffer_) : 0;
    emit(encode_payload(end));
    state_ = State::block_upload_end;
    return arm(now);
  }
  // Segments after ackseq were lost (or the sub-block was not the last): send on from there.
  send_sub_block();
  arm(now);
}

// --- SdoServerRunner -----------------------------------------------------------------------

SdoServerRunner::SdoServerRunner(can::Bus& bus, SdoServer& server) : bus_(bus), server_(server) {}

SdoServerRunner::~SdoServerRunner() {
  detach();
}

void SdoServerRunner::attach() {
  const can::Filter filter = server_.config().format == can::IdFormat::standard
                                 ? can::Filter::standard(server_.config().rx_cob_id)
                                 : can::Filter::extended(server_.config().rx_cob_id);
  bus_.set_filters(std::span<const can::Filter>(&filter, 1));
  bus_.set_frame_handler([this](const can::TimedFrame& frame) { handle(frame); });
  attached_ = true;
  rearm();
}

void SdoServerRunner::detach() {
  timer_.disarm();
  if (attached_) {
    bus_.set_frame_handler({});
    bus_.set_filters({});
    attached_ = false;
  }
}

void SdoServerRunner::handle(const can::TimedFrame& frame) {
  if (frame.own || !server_.is_request(frame.frame)) return;
  transmit(server_.on_frame(frame.frame, frame.timestamp));
}

void SdoServerRunner::transmit(std::span<const can::Frame> frames) {
  for (const can::Frame& frame : frames) {
    if (const std::error_code error = bus_.send(frame)) {
      ++send_errors_;
      last_send_error_ = error;
    }
  }
  rearm();
}

void SdoServerRunner::rearm() {
  timer_.arm(server_.next_deadline());
}

}  // namespace drivecheck::cia301
