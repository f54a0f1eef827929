#include "fuzz/support/sdo_server_model.hpp"

#include <algorithm>
#include <utility>
#include <variant>

namespace drivecheck::fuzz {
namespace {

using namespace drivecheck::cia301;

constexpr std::uint32_t kAbortToggle = 0x05030000;            // toggle bit not alternated
constexpr std::uint32_t kAbortCommandSpecifier = 0x05040001;  // ccs not valid or unknown
constexpr std::uint32_t kAbortBlockSize = 0x05040002;         // invalid block size
constexpr std::uint32_t kAbortSequence = 0x05040003;          // invalid sequence number
constexpr std::uint32_t kAbortCrc = 0x05040004;               // CRC error
constexpr std::uint32_t kAbortLength = 0x06070010;            // length does not match

std::size_t segments_needed(std::size_t bytes) {
  return std::max<std::size_t>(1, (bytes + kSdoSegmentDataLength - 1) / kSdoSegmentDataLength);
}

}  // namespace

SdoServerModel::SdoServerModel(SdoCobIds cob_ids, Multiplexer mux, std::vector<std::uint8_t> object,
                               SdoServerModelOptions options)
    : cob_ids_(cob_ids), mux_(mux), object_(std::move(object)), options_(options) {}

void SdoServerModel::send(const SdoPayload& payload) {
  outbox_.push_back(make_sdo_frame(cob_ids_.response, payload, cob_ids_.format));
}

void SdoServerModel::abort(std::uint32_t code, std::string violation) {
  send(encode_payload(AbortTransfer{mux_, code}));
  if (client_violation_.empty()) client_violation_ = std::move(violation);
  phase_ = Phase::idle;
}

void SdoServerModel::on_client_frame(const can::Frame& frame) {
  if (frame.id != cob_ids_.request || frame.format != cob_ids_.format) return;
  const SdoFraming framing =
      phase_ == Phase::block_download_segments ? SdoFraming::block_segment : SdoFraming::command;
  const SdoClientMessage message = decode_client_message(frame, framing);
  if (std::holds_alternative<AbortTransfer>(message)) {
    phase_ = Phase::idle;  // the client ended the transfer; a server does not answer an abort
    return;
  }
  if (const auto* invalid = std::get_if<SdoInvalid>(&message)) {
    return abort(kAbortCommandSpecifier,
                 "client sent an invalid SDO frame: " + std::string(describe(invalid->reason)));
  }
  const auto unexpected = [&] {
    abort(kAbortCommandSpecifier, "client sent " + to_string(message) + " out of turn");
  };

  switch (phase_) {
    case Phase::idle:
      return on_idle(message);

    case Phase::upload_segment: {
      const auto* request = std::get_if<UploadSegmentRequest>(&message);
      if (request == nullptr) return unexpected();
      if (request->toggle != toggle_) {
        return abort(kAbortToggle, "client's upload segment request did not alternate the toggle");
      }
      const std::size_t length = std::min(kSdoSegmentDataLength, object_.size() - offset_);
      const bool last = offset_ + length == object_.size();
      send(encode_payload(UploadSegmentResponse::make(
          toggle_, last, std::span<const std::uint8_t>(object_).subspan(offset_, length))));
      offset_ += length;
      toggle_ = !toggle_;
      if (last) {
        phase_ = Phase::idle;
        complete_ = true;
      }
      return;
    }

    case Phase::download_segment: {
      const auto* segment = std::get_if<DownloadSegmentRequest>(&message);
      if (segment == nullptr) return unexpected();
      if (segment->toggle != toggle_) {
        return abort(kAbortToggle, "client's download segment did not alternate the toggle");
      }
      const auto bytes = segment->segment_data();
      received_.insert(received_.end(), bytes.begin(), bytes.end());
      if (size_known_ && received_.size() > size_) {
        return abort(kAbortLength, "client sent more segment data than it indicated");
      }
      if (segment->last && size_known_ && received_.size() != size_) {
        return abort(kAbortLength, "client's last segment ends short of the indicated size");
      }
      send(encode_payload(DownloadSegmentResponse{toggle_}));
      toggle_ = !toggle_;
      if (segment->last) {
        phase_ = Phase::idle;
        complete_ = true;
      }
      return;
    }

    case Phase::block_upload_start:
      if (!std::holds_alternative<BlockUploadStart>(message)) return unexpected();
      offset_ = 0;
      return send_block_upload_sub_block();

    case Phase::block_upload_ack: {
      const auto* ack = std::get_if<BlockUploadAck>(&message);
      if (ack == nullptr) return unexpected();
      if (ack->ackseq > segments_sent_) {
        return abort(kAbortSequence, "client acknowledged more segments than were sent");
      }
      if (ack->block_size == 0 || ack->block_size > kSdoMaxBlockSize) {
        return abort(kAbortBlockSize, "client asked for an invalid block size");
      }
      offset_ =
          std::min(object_.size(), offset_ + std::size_t{ack->ackseq} * kSdoSegmentDataLength);
      client_block_size_ = ack->block_size;
      if (sub_block_has_last_ && ack->ackseq == segments_sent_) {
        BlockUploadEndRequest end;
        end.unused_bytes = static_cast<std::uint8_t>(
            object_.empty() ? kSdoSegmentDataLength
                            : (kSdoSegmentDataLength - object_.size() % kSdoSegmentDataLength) %
                                  kSdoSegmentDataLength);
        end.crc = crc_ ? crc16_ccitt(object_) : 0;
        send(encode_payload(end));
        phase_ = Phase::block_upload_end;
        return;
      }
      return send_block_upload_sub_block();
    }

    case Phase::block_upload_end:
      if (!std::holds_alternative<BlockUploadEndResponse>(message)) return unexpected();
      phase_ = Phase::idle;
      complete_ = true;
      return;

    case Phase::block_download_segments: {
      const auto* segment = std::get_if<BlockSegment>(&message);
      if (segment == nullptr) return unexpected();
      if (segment->seqno == expected_seqno_) {
        pending_.insert(pending_.end(), segment->data.begin(), segment->data.end());
        ++expected_seqno_;
        last_received_ = segment->last;
      }
      // Out of sequence: dropped; the acknowledgement tells the client where to resume.
      if (segment->seqno == options_.block_size || segment->last) {
        const auto ackseq = static_cast<std::uint8_t>(expected_seqno_ - 1);
        received_.insert(received_.end(), pending_.begin(), pending_.end());
        pending_.clear();
        send(encode_payload(BlockDownloadAck{ackseq, options_.block_size}));
        expected_seqno_ = 1;
        if (last_received_) phase_ = Phase::block_download_end;
      }
      return;
    }

    case Phase::block_download_end: {
      const auto* end = std::get_if<BlockDownloadEndRequest>(&message);
      if (end == nullptr) return unexpected();
      if (end->unused_bytes > received_.size()) {
        return abort(kAbortLength, "client's end request leaves more bytes unused than sent");
      }
      received_.resize(received_.size() - end->unused_bytes);
      if (size_known_ && received_.size() != size_) {
        return abort(kAbortLength, "client's block download differs from the indicated size");
      }
      if (crc_ && crc16_ccitt(received_) != end->crc) {
        return abort(kAbortCrc, "client's block download CRC does not match its data");
      }
      send(encode_payload(BlockDownloadEndResponse{}));
      phase_ = Phase::idle;
      complete_ = true;
      return;
    }
  }
}

void SdoServerModel::on_idle(const SdoClientMessage& message) {
  if (const auto* request = std::get_if<InitiateUploadRequest>(&message)) {
    mux_ = request->mux;
    return answer_upload_initiate();
  }
  if (const auto* request = std::get_if<InitiateDownloadRequest>(&message)) {
    mux_ = request->mux;
    received_.clear();
    if (request->expedited) {
      const auto bytes = request->expedited_data();
      received_.assign(bytes.begin(), bytes.end());
      send(encode_payload(InitiateDownloadResponse{mux_}));
      complete_ = true;
      return;
    }
    size_known_ = request->size_indicated;
    size_ = request->size;
    toggle_ = false;
    send(encode_payload(InitiateDownloadResponse{mux_}));
    phase_ = Phase::download_segment;
    return;
  }
  if (const auto* request = std::get_if<BlockUploadInitiateRequest>(&message)) {
    mux_ = request->mux;
    if (options_.refuse_block) {
      refused_block_ = true;
      send(encode_payload(AbortTransfer{mux_, kAbortCommandSpecifier}));
      return;
    }
    if (request->block_size == 0 || request->block_size > kSdoMaxBlockSize) {
      return abort(kAbortBlockSize, "client offered an invalid block size");
    }
    if (options_.protocol_switch && request->protocol_switch_threshold != 0 &&
        object_.size() <= request->protocol_switch_threshold) {
      return answer_upload_initiate();
    }
    crc_ = request->crc_supported && options_.crc;
    client_block_size_ = request->block_size;
    expected_upload_ = object_;
    BlockUploadInitiateResponse response{
        mux_, options_.crc, options_.upload_size_indicated,
        options_.upload_size_indicated ? static_cast<std::uint32_t>(object_.size()) : 0};
    send(encode_payload(response));
    phase_ = Phase::block_upload_start;
    return;
  }
  if (const auto* request = std::get_if<BlockDownloadInitiateRequest>(&message)) {
    mux_ = request->mux;
    if (options_.refuse_block) {
      refused_block_ = true;
      send(encode_payload(AbortTransfer{mux_, kAbortCommandSpecifier}));
      return;
    }
    received_.clear();
    pending_.clear();
    size_known_ = request->size_indicated;
    size_ = request->size;
    crc_ = request->crc_supported && options_.crc;
    expected_seqno_ = 1;
    last_received_ = false;
    send(encode_payload(BlockDownloadInitiateResponse{mux_, options_.crc, options_.block_size}));
    phase_ = Phase::block_download_segments;
    return;
  }
  abort(kAbortCommandSpecifier, "client sent " + to_string(message) + " with no transfer open");
}

void SdoServerModel::answer_upload_initiate() {
  if (options_.expedited_upload && !object_.empty() && object_.size() <= 4) {
    InitiateUploadResponse response = InitiateUploadResponse::make_expedited(mux_, object_);
    expected_upload_ = object_;
    if (!options_.expedited_size_indicated) {
      response.size_indicated = false;
      response.size = 0;
      expected_upload_.resize(4, 0);  // the client gets all four bytes (padding is zero)
    }
    send(encode_payload(response));
    complete_ = true;
    return;
  }
  expected_upload_ = object_;
  send(encode_payload(InitiateUploadResponse::make_segmented(
      mux_, options_.upload_size_indicated
                ? std::optional<std::uint32_t>(static_cast<std::uint32_t>(object_.size()))
                : std::nullopt)));
  toggle_ = false;
  offset_ = 0;
  phase_ = Phase::upload_segment;
}

void SdoServerModel::send_block_upload_sub_block() {
  const std::size_t needed = segments_needed(object_.size() - offset_);
  const std::size_t count = std::min<std::size_t>(client_block_size_, needed);
  sub_block_has_last_ = count == needed;
  segments_sent_ = static_cast<std::uint8_t>(count);
  std::size_t at = offset_;
  for (std::size_t seqno = 1; seqno <= count; ++seqno) {
    const std::size_t length = std::min(kSdoSegmentDataLength, object_.size() - at);
    send(encode_payload(
        BlockSegment::make(static_cast<std::uint8_t>(seqno), sub_block_has_last_ && seqno == count,
                           std::span<const std::uint8_t>(object_).subspan(at, length))));
    at += length;
  }
  phase_ = Phase::block_upload_ack;
}

}  // namespace drivecheck::fuzz
