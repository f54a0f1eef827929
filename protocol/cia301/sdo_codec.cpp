#include "protocol/cia301/sdo_codec.hpp"

#include <algorithm>
#include <cassert>
#include <iterator>
#include <type_traits>

namespace drivecheck::cia301 {
namespace {

// Command specifiers (byte 0 bits 7..5).
constexpr std::uint8_t kCcsDownloadSegment = 0;
constexpr std::uint8_t kCcsInitiateDownload = 1;
constexpr std::uint8_t kCcsInitiateUpload = 2;
constexpr std::uint8_t kCcsUploadSegment = 3;
constexpr std::uint8_t kCsAbort = 4;
constexpr std::uint8_t kCcsBlockUpload = 5;
constexpr std::uint8_t kCcsBlockDownload = 6;

constexpr std::uint8_t kScsUploadSegment = 0;
constexpr std::uint8_t kScsDownloadSegment = 1;
constexpr std::uint8_t kScsInitiateUpload = 2;
constexpr std::uint8_t kScsInitiateDownload = 3;
constexpr std::uint8_t kScsBlockDownload = 5;
constexpr std::uint8_t kScsBlockUpload = 6;

// Block sub-commands: cs/ss in bits 1..0 (ccs 5, scs 5) or bit 0 (ccs 6, scs 6).
constexpr std::uint8_t kBlockInitiate = 0;
constexpr std::uint8_t kBlockEnd = 1;
constexpr std::uint8_t kBlockAck = 2;
constexpr std::uint8_t kBlockStart = 3;

constexpr std::uint8_t kAbortByte = 0x80;

constexpr std::uint8_t command(std::uint8_t specifier) {
  return static_cast<std::uint8_t>(specifier << 5);
}

std::uint32_t get_u32(const std::array<std::uint8_t, 8>& bytes, std::size_t at) {
  return static_cast<std::uint32_t>(bytes[at]) | static_cast<std::uint32_t>(bytes[at + 1]) << 8 |
         static_cast<std::uint32_t>(bytes[at + 2]) << 16 |
         static_cast<std::uint32_t>(bytes[at + 3]) << 24;
}

std::uint16_t get_u16(const std::array<std::uint8_t, 8>& bytes, std::size_t at) {
  return static_cast<std::uint16_t>(bytes[at] | bytes[at + 1] << 8);
}

void put_u32(SdoPayload& bytes, std::size_t at, std::uint32_t value) {
  bytes[at] = static_cast<std::uint8_t>(value);
  bytes[at + 1] = static_cast<std::uint8_t>(value >> 8);
  bytes[at + 2] = static_cast<std::uint8_t>(value >> 16);
  bytes[at + 3] = static_cast<std::uint8_t>(value >> 24);
}

void put_u16(SdoPayload& bytes, std::size_t at, std::uint16_t value) {
  bytes[at] = static_cast<std::uint8_t>(value);
  bytes[at + 1] = static_cast<std::uint8_t>(value >> 8);
}

Multiplexer get_mux(const std::array<std::uint8_t, 8>& bytes) {
  return {get_u16(bytes, 1), bytes[3]};
}

void put_mux(SdoPayload& bytes, Multiplexer mux) {
  put_u16(bytes, 1, mux.index);
  bytes[3] = mux.sub_index;
}

// The fields shared by initiate download request and initiate upload response.
struct InitiateFields {
  Multiplexer mux;
  bool expedited = false;
  bool size_indicated = false;
  std::uint32_t size = 0;
  std::array<std::uint8_t, 4> data{};
};

InitiateFields decode_initiate(const std::array<std::uint8_t, 8>& bytes) {
  InitiateFields fields;
  fields.mux = get_mux(bytes);
  fields.expedited = (bytes[0] & 0x02) != 0;
  fields.size_indicated = (bytes[0] & 0x01) != 0;
  if (fields.expedited) {
    std::copy_n(bytes.begin() + 4, 4, fields.data.begin());
    if (fields.size_indicated) fields.size = 4u - ((bytes[0] >> 2) & 0x03u);
  } else if (fields.size_indicated) {
    fields.size = get_u32(bytes, 4);
  }
  return fields;
}

SdoPayload encode_initiate(std::uint8_t specifier, const InitiateFields& fields) {
  SdoPayload bytes{};
  bytes[0] = command(specifier);
  put_mux(bytes, fields.mux);
  if (fields.expedited) {
    bytes[0] |= 0x02;
    if (fields.size_indicated) {
      bytes[0] |= static_cast<std::uint8_t>(0x01 | ((4u - fields.size) & 0x03u) << 2);
    }
    std::copy_n(fields.data.begin(), 4, bytes.begin() + 4);
  } else if (fields.size_indicated) {
    bytes[0] |= 0x01;
    put_u32(bytes, 4, fields.size);
  }
  return bytes;
}

std::span<const std::uint8_t> expedited_span(const std::array<std::uint8_t, 4>& data,
                                             bool size_indicated, std::uint32_t size) {
  const std::size_t length = size_indicated ? std::min<std::uint32_t>(size, 4) : 4;
  return {data.data(), length};
}

std::array<std::uint8_t, 4> expedited_bytes(std::span<const std::uint8_t> bytes) {
  assert(!bytes.empty() && bytes.size() <= 4);
  std::array<std::uint8_t, 4> data{};
  std::copy_n(bytes.begin(), std::min<std::size_t>(bytes.size(), 4), data.begin());
  return data;
}

// Segment layout shared by download segment request and upload segment response:
// 0ttt... byte 0 = cs | t << 4 | n << 1 | c.
template <class Segment>
Segment decode_segment(const std::array<std::uint8_t, 8>& bytes) {
  Segment segment;
  segment.toggle = (bytes[0] & 0x10) != 0;
  segment.last = (bytes[0] & 0x01) != 0;
  segment.length = static_cast<std::uint8_t>(7 - ((bytes[0] >> 1) & 0x07));
  std::copy_n(bytes.begin() + 1, segment.length, segment.data.begin());
  return segment;
}

template <class Segment>
SdoPayload encode_segment(std::uint8_t specifier, const Segment& segment) {
  SdoPayload bytes{};
  const std::uint8_t length = std::min<std::uint8_t>(segment.length, 7);
  bytes[0] = static_cast<std::uint8_t>(command(specifier) | (segment.toggle ? 0x10 : 0) |
                                       (7 - length) << 1 | (segment.last ? 0x01 : 0));
  std::copy_n(segment.data.begin(), length, bytes.begin() + 1);
  return bytes;
}

template <class Segment>
Segment make_segment(bool toggle, bool last, std::span<const std::uint8_t> bytes) {
  assert(bytes.size() <= 7);
  Segment segment;
  segment.toggle = toggle;
  segment.last = last;
  segment.length = static_cast<std::uint8_t>(std::min<std::size_t>(bytes.size(), 7));
  std::copy_n(bytes.begin(), segment.length, segment.data.begin());
  return segment;
}

BlockSegment decode_block_segment(const std::array<std::uint8_t, 8>& bytes) {
  BlockSegment segment;
  segment.last = (bytes[0] & 0x80) != 0;
  segment.seqno = bytes[0] & 0x7F;
  std::copy_n(bytes.begin() + 1, 7, segment.data.begin());
  return segment;
}

AbortTransfer decode_abort(const std::array<std::uint8_t, 8>& bytes) {
  return {get_mux(bytes), get_u32(bytes, 4)};
}

// Checks that apply to a frame from either side; nullopt when the frame is an 8-byte data frame.
std::optional<SdoInvalid> check_frame(const can::Frame& frame) {
  if (frame.is_error()) return SdoInvalid{SdoInvalidReason::error_frame};
  if (frame.is_remote()) return SdoInvalid{SdoInvalidReason::remote_frame};
  if (frame.length() < kSdoFrameLength) return SdoInvalid{SdoInvalidReason::short_frame};
  return std::nullopt;
}

std::string hex_bytes(std::span<const std::uint8_t> bytes) {
  std::string text;
  for (std::uint8_t byte : bytes) {
    if (!text.empty()) text += ' ';
    fmt::format_to(std::back_inserter(text), "{:02X}", byte);
  }
  return text.empty() ? "(none)" : text;
}

std::string initiate_text(std::string_view name, const InitiateFields& f) {
  if (f.expedited) {
    const auto data = expedited_span(f.data, f.size_indicated, f.size);
    return fmt::format("{} {} expedited{} data {}", name, f.mux,
                       f.size_indicated ? fmt::format(" size {}", f.size) : " size not indicated",
                       hex_bytes(data));
  }
  return fmt::format("{} {} segmented{}", name, f.mux,
                     f.size_indicated ? fmt::format(" size {}", f.size) : " size not indicated");
}

template <class Segment>
std::string segment_text(std::string_view name, const Segment& s) {
  return fmt::format("{} toggle {}{} data {}", name, s.toggle ? 1 : 0, s.last ? " last" : "",
                     hex_bytes(s.segment_data()));
}

std::string abort_text(const AbortTransfer& m) {
  return fmt::format("abort transfer {} code {:08X}h", m.mux, m.code);
}

std::string block_segment_text(const BlockSegment& m) {
  return fmt::format("block segment seqno {}{} data {}", m.seqno, m.last ? " last" : "",
                     hex_bytes(m.data));
}

// CRC-16/CCITT table for polynomial 1021h, MSB first.
constexpr std::array<std::uint16_t, 256> make_crc_table() {
  std::array<std::uint16_t, 256> table{};
  for (unsigned i = 0; i < 256; ++i) {
    unsigned crc = i << 8;
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x8000) ? (crc << 1) ^ 0x1021 : crc << 1;
    }
    table[i] = static_cast<std::uint16_t>(crc);
  }
  return table;
}
constexpr auto kCrcTable = make_crc_table();

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

}  // namespace

// --- helpers of the message types ---------------------------------------------------------

std::span<const std::uint8_t> InitiateDownloadRequest::expedited_data() const {
  return expedited_span(data, size_indicated, size);
}

InitiateDownloadRequest InitiateDownloadRequest::make_expedited(
    Multiplexer mux, std::span<const std::uint8_t> bytes) {
  return {mux, true, true, static_cast<std::uint32_t>(std::min<std::size_t>(bytes.size(), 4)),
          expedited_bytes(bytes)};
}

InitiateDownloadRequest InitiateDownloadRequest::make_segmented(Multiplexer mux,
                                                                std::optional<std::uint32_t> size) {
  return {mux, false, size.has_value(), size.value_or(0), {}};
}

DownloadSegmentRequest DownloadSegmentRequest::make(bool toggle, bool last,
                                                    std::span<const std::uint8_t> bytes) {
  return make_segment<DownloadSegmentRequest>(toggle, last, bytes);
}

UploadSegmentResponse UploadSegmentResponse::make(bool toggle, bool last,
                                                  std::span<const std::uint8_t> bytes) {
  return make_segment<UploadSegmentResponse>(toggle, last, bytes);
}

std::span<const std::uint8_t> InitiateUploadResponse::expedited_data() const {
  return expedited_span(data, size_indicated, size);
}

InitiateUploadResponse InitiateUploadResponse::make_expedited(Multiplexer mux,
                                                              std::span<const std::uint8_t> bytes) {
  return {mux, true, true, static_cast<std::uint32_t>(std::min<std::size_t>(bytes.size(), 4)),
          expedited_bytes(bytes)};
}

InitiateUploadResponse InitiateUploadResponse::make_segmented(Multiplexer mux,
                                                              std::optional<std::uint32_t> size) {
  return {mux, false, size.has_value(), size.value_or(0), {}};
}

BlockSegment BlockSegment::make(std::uint8_t seqno, bool last,
                                std::span<const std::uint8_t> bytes) {
  assert(bytes.size() <= 7);
  BlockSegment segment;
  segment.seqno = seqno;
  segment.last = last;
  std::copy_n(bytes.begin(), std::min<std::size_t>(bytes.size(), 7), segment.data.begin());
  return segment;
}

std::string_view describe(SdoInvalidReason reason) {
  switch (reason) {
    case SdoInvalidReason::remote_frame:
      return "remote frame: SDO frames are data frames";
    case SdoInvalidReason::error_frame:
      return "error frame, not an SDO frame";
    case SdoInvalidReason::short_frame:
      return "DLC below 8: CiA 301 requires 8 data bytes in every SDO frame";
    case SdoInvalidReason::reserved_command_specifier:
      return "command specifier 7 is reserved";
    case SdoInvalidReason::reserved_subcommand:
      return "block download response sub-command 3 is reserved";
  }
  return "unknown reason";
}

// --- decoding ------------------------------------------------------------------------------

SdoClientMessage decode_client_message(const can::Frame& frame, SdoFraming framing) {
  if (auto invalid = check_frame(frame)) return *invalid;
  const auto& bytes = frame.data;
  if (framing == SdoFraming::block_segment) {
    if (bytes[0] == kAbortByte) return decode_abort(bytes);
    return decode_block_segment(bytes);
  }
  switch (bytes[0] >> 5) {
    case kCcsDownloadSegment:
      return decode_segment<DownloadSegmentRequest>(bytes);
    case kCcsInitiateDownload: {
      const InitiateFields f = decode_initiate(bytes);
      return InitiateDownloadRequest{f.mux, f.expedited, f.size_indicated, f.size, f.data};
    }
    case kCcsInitiateUpload:
      return InitiateUploadRequest{get_mux(bytes)};
    case kCcsUploadSegment:
      return UploadSegmentRequest{(bytes[0] & 0x10) != 0};
    case kCsAbort:
      return decode_abort(bytes);
    case kCcsBlockUpload:
      switch (bytes[0] & 0x03) {
        case kBlockInitiate:
          return BlockUploadInitiateRequest{get_mux(bytes), (bytes[0] & 0x04) != 0, bytes[4],
                                            bytes[5]};
        case kBlockEnd:
          return BlockUploadEndResponse{};
        case kBlockAck:
          return BlockUploadAck{bytes[1], bytes[2]};
        default:  // kBlockStart
          return BlockUploadStart{};
      }
    case kCcsBlockDownload:
      if ((bytes[0] & 0x01) == kBlockInitiate) {
        const bool size_indicated = (bytes[0] & 0x02) != 0;
        return BlockDownloadInitiateRequest{get_mux(bytes), (bytes[0] & 0x04) != 0, size_indicated,
                                            size_indicated ? get_u32(bytes, 4) : 0};
      }
      return BlockDownloadEndRequest{static_cast<std::uint8_t>((bytes[0] >> 2) & 0x07),
                                     get_u16(bytes, 1)};
    default:
      return SdoInvalid{SdoInvalidReason::reserved_command_specifier};
  }
}

SdoServerMessage decode_server_message(const can::Frame& frame, SdoFraming framing) {
  if (auto invalid = check_frame(frame)) return *invalid;
  const auto& bytes = frame.data;
  if (framing == SdoFraming::block_segment) {
    if (bytes[0] == kAbortByte) return decode_abort(bytes);
    return decode_block_segment(bytes);
  }
  switch (bytes[0] >> 5) {
    case kScsUploadSegment:
      return decode_segment<UploadSegmentResponse>(bytes);
    case kScsDownloadSegment:
      return DownloadSegmentResponse{(bytes[0] & 0x10) != 0};
    case kScsInitiateUpload: {
      const InitiateFields f = decode_initiate(bytes);
      return InitiateUploadResponse{f.mux, f.expedited, f.size_indicated, f.size, f.data};
    }
    case kScsInitiateDownload:
      return InitiateDownloadResponse{get_mux(bytes)};
    case kCsAbort:
      return decode_abort(bytes);
    case kScsBlockDownload:
      switch (bytes[0] & 0x03) {
        case kBlockInitiate:
          return BlockDownloadInitiateResponse{get_mux(bytes), (bytes[0] & 0x04) != 0, bytes[4]};
        case kBlockEnd:
          return BlockDownloadEndResponse{};
        case kBlockAck:
          return BlockDownloadAck{bytes[1], bytes[2]};
        default:
          return SdoInvalid{SdoInvalidReason::reserved_subcommand};
      }
    case kScsBlockUpload:
      if ((bytes[0] & 0x01) == kBlockInitiate) {
        const bool size_indicated = (bytes[0] & 0x02) != 0;
        return BlockUploadInitiateResponse{get_mux(bytes), (bytes[0] & 0x04) != 0, size_indicated,
                                           size_indicated ? get_u32(bytes, 4) : 0};
      }
      return BlockUploadEndRequest{static_cast<std::uint8_t>((bytes[0] >> 2) & 0x07),
                                   get_u16(bytes, 1)};
    default:
      return SdoInvalid{SdoInvalidReason::reserved_command_specifier};
  }
}

// --- encoding ------------------------------------------------------------------------------

SdoPayload encode_payload(const InitiateDownloadRequest& m) {
  return encode_initiate(kCcsInitiateDownload,
                         {m.mux, m.expedited, m.size_indicated, m.size, m.data});
}

SdoPayload encode_payload(const DownloadSegmentRequest& m) {
  return encode_segment(kCcsDownloadSegment, m);
}

SdoPayload encode_payload(const InitiateUploadRequest& m) {
  SdoPayload bytes{};
  bytes[0] = command(kCcsInitiateUpload);
  put_mux(bytes, m.mux);
  return bytes;
}

SdoPayload encode_payload(const UploadSegmentRequest& m) {
  SdoPayload bytes{};
  bytes[0] = static_cast<std::uint8_t>(command(kCcsUploadSegment) | (m.toggle ? 0x10 : 0));
  return bytes;
}

SdoPayload encode_payload(const BlockDownloadInitiateRequest& m) {
  SdoPayload bytes{};
  bytes[0] = static_cast<std::uint8_t>(command(kCcsBlockDownload) | (m.crc_supported ? 0x04 : 0) |
                                       (m.size_indicated ? 0x02 : 0) | kBlockInitiate);
  put_mux(bytes, m.mux);
  if (m.size_indicated) put_u32(bytes, 4, m.size);
  return bytes;
}

SdoPayload encode_payload(const BlockDownloadEndRequest& m) {
  SdoPayload bytes{};
  bytes[0] = static_cast<std::uint8_t>(command(kCcsBlockDownload) | (m.unused_bytes & 0x07) << 2 |
                                       kBlockEnd);
  put_u16(bytes, 1, m.crc);
  return bytes;
}

SdoPayload encode_payload(const BlockUploadInitiateRequest& m) {
  SdoPayload bytes{};
  bytes[0] = static_cast<std::uint8_t>(command(kCcsBlockUpload) | (m.crc_supported ? 0x04 : 0) |
                                       kBlockInitiate);
  put_mux(bytes, m.mux);
  bytes[4] = m.block_size;
  bytes[5] = m.protocol_switch_threshold;
  return bytes;
}

SdoPayload encode_payload(const BlockUploadStart&) {
  SdoPayload bytes{};
  bytes[0] = command(kCcsBlockUpload) | kBlockStart;
  return bytes;
}

SdoPayload encode_payload(const BlockUploadAck& m) {
  SdoPayload bytes{};
  bytes[0] = command(kCcsBlockUpload) | kBlockAck;
  bytes[1] = m.ackseq;
  bytes[2] = m.block_size;
  return bytes;
}

SdoPayload encode_payload(const BlockUploadEndResponse&) {
  SdoPayload bytes{};
  bytes[0] = command(kCcsBlockUpload) | kBlockEnd;
  return bytes;
}

SdoPayload encode_payload(const UploadSegmentResponse& m) {
  return encode_segment(kScsUploadSegment, m);
}

SdoPayload encode_payload(const DownloadSegmentResponse& m) {
  SdoPayload bytes{};
  bytes[0] = static_cast<std::uint8_t>(command(kScsDownloadSegment) | (m.toggle ? 0x10 : 0));
  return bytes;
}

SdoPayload encode_payload(const InitiateUploadResponse& m) {
  return encode_initiate(kScsInitiateUpload,
                         {m.mux, m.expedited, m.size_indicated, m.size, m.data});
}

SdoPayload encode_payload(const InitiateDownloadResponse& m) {
  SdoPayload bytes{};
  bytes[0] = command(kScsInitiateDownload);
  put_mux(bytes, m.mux);
  return bytes;
}

SdoPayload encode_payload(const BlockDownloadInitiateResponse& m) {
  SdoPayload bytes{};
  bytes[0] = static_cast<std::uint8_t>(command(kScsBlockDownload) | (m.crc_supported ? 0x04 : 0) |
                                       kBlockInitiate);
  put_mux(bytes, m.mux);
  bytes[4] = m.block_size;
  return bytes;
}

SdoPayload encode_payload(const BlockDownloadAck& m) {
  SdoPayload bytes{};
  bytes[0] = command(kScsBlockDownload) | kBlockAck;
  bytes[1] = m.ackseq;
  bytes[2] = m.block_size;
  return bytes;
}

SdoPayload encode_payload(const BlockDownloadEndResponse&) {
  SdoPayload bytes{};
  bytes[0] = command(kScsBlockDownload) | kBlockEnd;
  return bytes;
}

SdoPayload encode_payload(const BlockUploadInitiateResponse& m) {
  SdoPayload bytes{};
  bytes[0] = static_cast<std::uint8_t>(command(kScsBlockUpload) | (m.crc_supported ? 0x04 : 0) |
                                       (m.size_indicated ? 0x02 : 0) | kBlockInitiate);
  put_mux(bytes, m.mux);
  if (m.size_indicated) put_u32(bytes, 4, m.size);
  return bytes;
}

SdoPayload encode_payload(const BlockUploadEndRequest& m) {
  SdoPayload bytes{};
  bytes[0] = static_cast<std::uint8_t>(command(kScsBlockUpload) | (m.unused_bytes & 0x07) << 2 |
                                       kBlockEnd);
  put_u16(bytes, 1, m.crc);
  return bytes;
}

SdoPayload encode_payload(const AbortTransfer& m) {
  SdoPayload bytes{};
  bytes[0] = kAbortByte;
  put_mux(bytes, m.mux);
  put_u32(bytes, 4, m.code);
  return bytes;
}

SdoPayload encode_payload(const BlockSegment& m) {
  SdoPayload bytes{};
  bytes[0] = static_cast<std::uint8_t>((m.last ? 0x80 : 0) | (m.seqno & 0x7F));
  std::copy_n(m.data.begin(), 7, bytes.begin() + 1);
  return bytes;
}

can::Frame make_sdo_frame(std::uint32_t cob_id, const SdoPayload& payload, can::IdFormat format) {
  can::Frame frame;
  frame.format = format;
  frame.id =
      cob_id & (format == can::IdFormat::standard ? can::kMaxStandardId : can::kMaxExtendedId);
  frame.dlc = static_cast<std::uint8_t>(kSdoFrameLength);
  frame.data = payload;
  return frame;
}

std::optional<can::Frame> encode(const SdoClientMessage& message, std::uint32_t cob_id,
                                 can::IdFormat format) {
  return std::visit(
      [&](const auto& m) -> std::optional<can::Frame> {
        if constexpr (std::is_same_v<std::decay_t<decltype(m)>, SdoInvalid>) {
          return std::nullopt;
        } else {
          return encode(m, cob_id, format);
        }
      },
      message);
}

std::optional<can::Frame> encode(const SdoServerMessage& message, std::uint32_t cob_id,
                                 can::IdFormat format) {
  return std::visit(
      [&](const auto& m) -> std::optional<can::Frame> {
        if constexpr (std::is_same_v<std::decay_t<decltype(m)>, SdoInvalid>) {
          return std::nullopt;
        } else {
          return encode(m, cob_id, format);
        }
      },
      message);
}

// --- text ----------------------------------------------------------------------------------

std::string to_string(const SdoClientMessage& message) {
  return std::visit(
      Overloaded{
          [](const SdoInvalid& m) {
            return fmt::format("invalid SDO frame: {}", describe(m.reason));
          },
          [](const InitiateDownloadRequest& m) {
            return initiate_text("initiate download request",
                                 {m.mux, m.expedited, m.size_indicated, m.size, m.data});
          },
          [](const DownloadSegmentRequest& m) {
            return segment_text("download segment request", m);
          },
          [](const InitiateUploadRequest& m) {
            return fmt::format("initiate upload request {}", m.mux);
          },
          [](const UploadSegmentRequest& m) {
            return fmt::format("upload segment request toggle {}", m.toggle ? 1 : 0);
          },
          [](const BlockDownloadInitiateRequest& m) {
            return fmt::format(
                "block download initiate request {}{}{}", m.mux,
                m.crc_supported ? " crc" : " no-crc",
                m.size_indicated ? fmt::format(" size {}", m.size) : " size not indicated");
          },
          [](const BlockDownloadEndRequest& m) {
            return fmt::format("block download end request n {} crc {:04X}h", m.unused_bytes,
                               m.crc);
          },
          [](const BlockUploadInitiateRequest& m) {
            return fmt::format("block upload initiate request {}{} blksize {} pst {}", m.mux,
                               m.crc_supported ? " crc" : " no-crc", m.block_size,
                               m.protocol_switch_threshold);
          },
          [](const BlockUploadStart&) { return std::string("block upload start"); },
          [](const BlockUploadAck& m) {
            return fmt::format("block upload response ackseq {} blksize {}", m.ackseq,
                               m.block_size);
          },
          [](const BlockUploadEndResponse&) { return std::string("block upload end response"); },
          [](const BlockSegment& m) { return block_segment_text(m); },
          [](const AbortTransfer& m) { return abort_text(m); },
      },
      message);
}

std::string to_string(const SdoServerMessage& message) {
  return std::visit(
      Overloaded{
          [](const SdoInvalid& m) {
            return fmt::format("invalid SDO frame: {}", describe(m.reason));
          },
          [](const UploadSegmentResponse& m) { return segment_text("upload segment response", m); },
          [](const DownloadSegmentResponse& m) {
            return fmt::format("download segment response toggle {}", m.toggle ? 1 : 0);
          },
          [](const InitiateUploadResponse& m) {
            return initiate_text("initiate upload response",
                                 {m.mux, m.expedited, m.size_indicated, m.size, m.data});
          },
          [](const InitiateDownloadResponse& m) {
            return fmt::format("initiate download response {}", m.mux);
          },
          [](const BlockDownloadInitiateResponse& m) {
            return fmt::format("block download initiate response {}{} blksize {}", m.mux,
                               m.crc_supported ? " crc" : " no-crc", m.block_size);
          },
          [](const BlockDownloadAck& m) {
            return fmt::format("block download response ackseq {} blksize {}", m.ackseq,
                               m.block_size);
          },
          [](const BlockDownloadEndResponse&) {
            return std::string("block download end response");
          },
          [](const BlockUploadInitiateResponse& m) {
            return fmt::format(
                "block upload initiate response {}{}{}", m.mux,
                m.crc_supported ? " crc" : " no-crc",
                m.size_indicated ? fmt::format(" size {}", m.size) : " size not indicated");
          },
          [](const BlockUploadEndRequest& m) {
            return fmt::format("block upload end request n {} crc {:04X}h", m.unused_bytes, m.crc);
          },
          [](const BlockSegment& m) { return block_segment_text(m); },
          [](const AbortTransfer& m) { return abort_text(m); },
      },
      message);
}

// --- CRC -----------------------------------------------------------------------------------

std::uint16_t crc16_ccitt(std::span<const std::uint8_t> data, std::uint16_t crc) {
  for (std::uint8_t byte : data) {
    crc = static_cast<std::uint16_t>((crc << 8) ^ kCrcTable[((crc >> 8) ^ byte) & 0xFF]);
  }
  return crc;
}

}  // namespace drivecheck::cia301
