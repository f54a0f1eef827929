// SDO frames (CiA 301 §7.2.4.3): one typed message per frame of every SDO protocol, in both
// directions, with its encoder, and decoders that turn any CAN frame into one of them or into
// an explicit SdoInvalid. Pure functions: no state, no allocation, total over their input.
//
// Every SDO frame carries exactly 8 data bytes (CiA 301 §7.2.4.3.1). Byte 0 is the command
// byte; its bits 7..5 are the command specifier: ccs in frames the client sends (to the server,
// COB-ID 600h + node by default), scs in frames the server sends (580h + node). Numbers are
// little-endian. "x" bits are not used: encoders write 0, decoders ignore them.
//
//   ccs (client → server)                      scs (server → client)
//   0  download segment request                0  upload segment response
//   1  initiate download request               1  download segment response
//   2  initiate upload request                 2  initiate upload response
//   3  upload segment request                  3  initiate download response
//   4  abort transfer                          4  abort transfer
//   5  block upload (cs in bits 1..0)          5  block download (ss in bits 1..0)
//   6  block download (cs in bit 0)            6  block upload (ss in bit 0)
//   7  reserved: SdoInvalid                    7  reserved: SdoInvalid
//
// The segments of a block sub-block (byte 0 = c | seqno) have no command specifier at all: only
// the protocol state tells them apart from command frames, so a decoder is told which framing
// it expects (SdoFraming::block_segment while a sub-block is being transferred).
//
// Frames that are not SDO frames decode to SdoInvalid with a reason: remote and error frames,
// and frames with DLC < 8. CiA 301 requires DLC 8 for every SDO frame, so a short frame is
// invalid even when the bytes it has would make sense (some manuals print only the significant
// bytes; a drive that really sends short frames deviates from CiA 301). DLC 9..15 is a classic
// CAN frame with 8 data bytes (ISO 11898-1) and is accepted.
//
// Values the protocol forbids but a peer may still send (blksize 0 or > 127, seqno 0, n bits
// that leave no data) decode to their raw value: the state machine that receives them answers
// with the abort code CiA 301 names for them, which it could not do if the codec dropped them.
#pragma once

#include <fmt/format.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>

#include "protocol/can/frame.hpp"

namespace drivecheck::cia301 {

inline constexpr std::size_t kSdoFrameLength = 8;
inline constexpr std::uint32_t kSdoRequestBase = 0x600;   // client → server: 600h + node-ID
inline constexpr std::uint32_t kSdoResponseBase = 0x580;  // server → client: 580h + node-ID
inline constexpr std::uint8_t kSdoMaxBlockSize = 127;     // blksize and seqno: 1..127
inline constexpr std::size_t kSdoSegmentDataLength = 7;   // data bytes of any segment

// An object dictionary entry as an SDO addresses it: index (bytes 1..2, little-endian) and
// sub-index (byte 3) of every initiate and abort frame.
struct Multiplexer {
  std::uint16_t index = 0;
  std::uint8_t sub_index = 0;
  friend bool operator==(const Multiplexer&, const Multiplexer&) = default;
};

// ---------------------------------------------------------------------------------------------
// Frames the client sends
// ---------------------------------------------------------------------------------------------

// Initiate SDO download request (ccs = 1), CiA 301 §7.2.4.3.3.
//   byte 0   001x nnes   n (bits 3..2): bytes of 4..7 that hold no data (valid when e=1, s=1)
//                        e (bit 1): expedited; s (bit 0): size indicated
//   byte 1-2 index (LE)  byte 3 sub-index
//   byte 4-7 e=1: the data (4 - n bytes when s=1; 4 bytes of unspecified length when s=0)
//            e=0, s=1: size of the data to download, UNSIGNED32 (segmented transfer follows)
//            e=0, s=0: reserved (0); segmented transfer of unindicated size follows
// Example (Festo 000 L747): 2F 01 14 02 EF 00 00 00 = expedited, n=3, 1401h:02, data EFh.
struct InitiateDownloadRequest {
  Multiplexer mux;
  bool expedited = false;
  bool size_indicated = false;
  // s=1: the size (e=1: 4 - n, i.e. 1..4; e=0: bytes 4..7). s=0: 0. Encoding an expedited
  // frame with s=1 writes n = (4 - size) & 3, so size must be 1..4 there.
  std::uint32_t size = 0;
  // e=1: bytes 4..7 as carried, all four (bytes past `size` are padding). e=0: zero.
  std::array<std::uint8_t, 4> data{};

  // The data an expedited request carries: `size` bytes when indicated, else all 4.
  std::span<const std::uint8_t> expedited_data() const;

  // Expedited with size indicated. Precondition: 1 <= bytes.size() <= 4.
  static InitiateDownloadRequest make_expedited(Multiplexer mux,
                                                std::span<const std::uint8_t> bytes);
  // Segmented, announcing `size` bytes (s=1), or of unindicated size (nullopt, s=0).
  static InitiateDownloadRequest make_segmented(Multiplexer mux, std::optional<std::uint32_t> size);

  friend bool operator==(const InitiateDownloadRequest&, const InitiateDownloadRequest&) = default;
};

// Download SDO segment request (ccs = 0), CiA 301 §7.2.4.3.4.
//   byte 0   000t nnnc   t: toggle (0 in the first segment, then alternating)
//                        n (bits 3..1): bytes of 1..7 that hold no data; c: last segment
//   byte 1-7 segment data (7 - n bytes, the rest padding)
struct DownloadSegmentRequest {
  bool toggle = false;
  bool last = false;
  std::uint8_t length = 0;  // 7 - n: 0..7 data bytes
  std::array<std::uint8_t, 7> data{};

  std::span<const std::uint8_t> segment_data() const { return {data.data(), length}; }
  // Precondition: bytes.size() <= 7.
  static DownloadSegmentRequest make(bool toggle, bool last, std::span<const std::uint8_t> bytes);

  friend bool operator==(const DownloadSegmentRequest&, const DownloadSegmentRequest&) = default;
};

// Initiate SDO upload request (ccs = 2), CiA 301 §7.2.4.3.6.
//   byte 0   010x xxxx
//   byte 1-2 index (LE)  byte 3 sub-index  byte 4-7 reserved (0)
// Example (Festo 000 L751): 40 41 60 00 00 00 00 00 = read 6041h:00.
struct InitiateUploadRequest {
  Multiplexer mux;
  friend bool operator==(const InitiateUploadRequest&, const InitiateUploadRequest&) = default;
};

// Upload SDO segment request (ccs = 3), CiA 301 §7.2.4.3.7.
//   byte 0   011t xxxx   t: toggle (0 in the first request, then alternating)
//   byte 1-7 reserved (0)
struct UploadSegmentRequest {
  bool toggle = false;
  friend bool operator==(const UploadSegmentRequest&, const UploadSegmentRequest&) = default;
};

// Initiate SDO block download request (ccs = 6, cs = 0), CiA 301 §7.2.4.3.9.
//   byte 0   110x xcs0   c (bit 2): client supports CRC; s (bit 1): size indicated
//   byte 1-2 index (LE)  byte 3 sub-index
//   byte 4-7 s=1: size of the data, UNSIGNED32; s=0: reserved (0)
struct BlockDownloadInitiateRequest {
  Multiplexer mux;
  bool crc_supported = false;
  bool size_indicated = false;
  std::uint32_t size = 0;  // s=1: bytes 4..7; s=0: 0
  friend bool operator==(const BlockDownloadInitiateRequest&,
                         const BlockDownloadInitiateRequest&) = default;
};

// End SDO block download request (ccs = 6, cs = 1), CiA 301 §7.2.4.3.11.
//   byte 0   110n nnx1   n (bits 4..2): bytes of the last segment of the last block that hold
//                        no data
//   byte 1-2 CRC-16 of the whole data (LE; 0 when either side does not support CRC)
//   byte 3-7 reserved (0)
struct BlockDownloadEndRequest {
  std::uint8_t unused_bytes = 0;  // n: 0..7
  std::uint16_t crc = 0;
  friend bool operator==(const BlockDownloadEndRequest&, const BlockDownloadEndRequest&) = default;
};

// Initiate SDO block upload request (ccs = 5, cs = 0), CiA 301 §7.2.4.3.13.
//   byte 0   101x xc00   c (bit 2): client supports CRC
//   byte 1-2 index (LE)  byte 3 sub-index
//   byte 4   blksize: segments per sub-block, 1..127
//   byte 5   pst: protocol switch threshold; 0 = the server may not switch, otherwise the
//            server may answer with a normal upload (scs = 2) when size <= pst bytes
//   byte 6-7 reserved (0)
struct BlockUploadInitiateRequest {
  Multiplexer mux;
  bool crc_supported = false;
  std::uint8_t block_size = 0;
  std::uint8_t protocol_switch_threshold = 0;
  friend bool operator==(const BlockUploadInitiateRequest&,
                         const BlockUploadInitiateRequest&) = default;
};

// Start SDO block upload (ccs = 5, cs = 3), CiA 301 §7.2.4.3.13: the client is ready for the
// first sub-block.
//   byte 0   101x xx11   byte 1-7 reserved (0)
struct BlockUploadStart {
  friend bool operator==(const BlockUploadStart&, const BlockUploadStart&) = default;
};

// SDO block upload response (ccs = 5, cs = 2), CiA 301 §7.2.4.3.14: the client acknowledges
// a sub-block.
//   byte 0   101x xx10
//   byte 1   ackseq: seqno of the last segment received in sequence (0: none)
//   byte 2   blksize: segments in the next sub-block, 1..127
//   byte 3-7 reserved (0)
struct BlockUploadAck {
  std::uint8_t ackseq = 0;
  std::uint8_t block_size = 0;
  friend bool operator==(const BlockUploadAck&, const BlockUploadAck&) = default;
};

// End SDO block upload response (ccs = 5, cs = 1), CiA 301 §7.2.4.3.15.
//   byte 0   101x xx01   byte 1-7 reserved (0)
struct BlockUploadEndResponse {
  friend bool operator==(const BlockUploadEndResponse&, const BlockUploadEndResponse&) = default;
};

// ---------------------------------------------------------------------------------------------
// Frames the server sends
// ---------------------------------------------------------------------------------------------

// Upload SDO segment response (scs = 0), CiA 301 §7.2.4.3.7.
//   byte 0   000t nnnc   t: the toggle of the request; n (bits 3..1): bytes of 1..7 that
//                        hold no data; c: last segment
//   byte 1-7 segment data (7 - n bytes, the rest padding)
struct UploadSegmentResponse {
  bool toggle = false;
  bool last = false;
  std::uint8_t length = 0;  // 7 - n
  std::array<std::uint8_t, 7> data{};

  std::span<const std::uint8_t> segment_data() const { return {data.data(), length}; }
  // Precondition: bytes.size() <= 7.
  static UploadSegmentResponse make(bool toggle, bool last, std::span<const std::uint8_t> bytes);

  friend bool operator==(const UploadSegmentResponse&, const UploadSegmentResponse&) = default;
};

// Download SDO segment response (scs = 1), CiA 301 §7.2.4.3.4.
//   byte 0   001t xxxx   t: the toggle of the request
//   byte 1-7 reserved (0)
struct DownloadSegmentResponse {
  bool toggle = false;
  friend bool operator==(const DownloadSegmentResponse&, const DownloadSegmentResponse&) = default;
};

// Initiate SDO upload response (scs = 2), CiA 301 §7.2.4.3.6; same fields as the initiate
// download request.
//   byte 0   010x nnes   n (bits 3..2): bytes of 4..7 that hold no data (valid when e=1, s=1)
//                        e: expedited; s: size indicated
//   byte 1-2 index (LE)  byte 3 sub-index
//   byte 4-7 e=1: the data; e=0, s=1: size of the data, UNSIGNED32; e=0, s=0: reserved
// Examples (Festo 000 L748, L752, L756): 4F 61 60 00 01 = 6061h:00 is 01h (1 byte);
// 4B 41 60 00 34 12 = 6041h:00 is 1234h; 43 93 60 01 78 56 34 12 = 6093h:01 is 12345678h.
struct InitiateUploadResponse {
  Multiplexer mux;
  bool expedited = false;
  bool size_indicated = false;
  std::uint32_t size = 0;  // as InitiateDownloadRequest::size
  std::array<std::uint8_t, 4> data{};

  std::span<const std::uint8_t> expedited_data() const;

  // Expedited with size indicated. Precondition: 1 <= bytes.size() <= 4.
  static InitiateUploadResponse make_expedited(Multiplexer mux,
                                               std::span<const std::uint8_t> bytes);
  static InitiateUploadResponse make_segmented(Multiplexer mux, std::optional<std::uint32_t> size);

  friend bool operator==(const InitiateUploadResponse&, const InitiateUploadResponse&) = default;
};

// Initiate SDO download response (scs = 3), CiA 301 §7.2.4.3.3.
//   byte 0   011x xxxx   byte 1-2 index (LE)  byte 3 sub-index  byte 4-7 reserved (0)
// Example (Festo 000 L748): 60 01 14 02 00 00 00 00 = 1401h:02 written.
struct InitiateDownloadResponse {
  Multiplexer mux;
  friend bool operator==(const InitiateDownloadResponse&,
                         const InitiateDownloadResponse&) = default;
};

// Initiate SDO block download response (scs = 5, ss = 0), CiA 301 §7.2.4.3.9.
//   byte 0   101x xc00   c (bit 2): server supports CRC
//   byte 1-2 index (LE)  byte 3 sub-index
//   byte 4   blksize: segments per sub-block, 1..127
//   byte 5-7 reserved (0)
struct BlockDownloadInitiateResponse {
  Multiplexer mux;
  bool crc_supported = false;
  std::uint8_t block_size = 0;
  friend bool operator==(const BlockDownloadInitiateResponse&,
                         const BlockDownloadInitiateResponse&) = default;
};

// SDO block download response (scs = 5, ss = 2), CiA 301 §7.2.4.3.10: the server
// acknowledges a sub-block.
//   byte 0   101x xx10
//   byte 1   ackseq: seqno of the last segment received in sequence (0: none)
//   byte 2   blksize: segments in the next sub-block, 1..127
//   byte 3-7 reserved (0)
struct BlockDownloadAck {
  std::uint8_t ackseq = 0;
  std::uint8_t block_size = 0;
  friend bool operator==(const BlockDownloadAck&, const BlockDownloadAck&) = default;
};

// End SDO block download response (scs = 5, ss = 1), CiA 301 §7.2.4.3.11.
//   byte 0   101x xx01   byte 1-7 reserved (0)
struct BlockDownloadEndResponse {
  friend bool operator==(const BlockDownloadEndResponse&,
                         const BlockDownloadEndResponse&) = default;
};

// Initiate SDO block upload response (scs = 6, ss = 0), CiA 301 §7.2.4.3.13.
//   byte 0   110x xcs0   c (bit 2): server supports CRC; s (bit 1): size indicated
//   byte 1-2 index (LE)  byte 3 sub-index
//   byte 4-7 s=1: size of the data, UNSIGNED32; s=0: reserved (0)
struct BlockUploadInitiateResponse {
  Multiplexer mux;
  bool crc_supported = false;
  bool size_indicated = false;
  std::uint32_t size = 0;
  friend bool operator==(const BlockUploadInitiateResponse&,
                         const BlockUploadInitiateResponse&) = default;
};

// End SDO block upload request (scs = 6, ss = 1), CiA 301 §7.2.4.3.15.
//   byte 0   110n nnx1   n (bits 4..2): bytes of the last segment of the last block that hold
//                        no data
//   byte 1-2 CRC-16 of the whole data (LE; 0 when either side does not support CRC)
//   byte 3-7 reserved (0)
struct BlockUploadEndRequest {
  std::uint8_t unused_bytes = 0;  // n: 0..7
  std::uint16_t crc = 0;
  friend bool operator==(const BlockUploadEndRequest&, const BlockUploadEndRequest&) = default;
};

// ---------------------------------------------------------------------------------------------
// Frames either side sends
// ---------------------------------------------------------------------------------------------

// Abort SDO transfer (cs = 4), CiA 301 §7.2.4.3.17.
//   byte 0   1000 0000   (bits 4..0 x)
//   byte 1-2 index (LE)  byte 3 sub-index of the aborted transfer
//   byte 4-7 abort code, UNSIGNED32 (LE); see sdo_abort_codes.inc
// Example (Festo 000 L768-769): 80 41 60 00 02 00 01 06 = 6041h:00 aborted, 06010002h.
struct AbortTransfer {
  Multiplexer mux;
  std::uint32_t code = 0;
  friend bool operator==(const AbortTransfer&, const AbortTransfer&) = default;
};

// A segment of a block sub-block (CiA 301 §7.2.4.3.10 download, §7.2.4.3.14 upload).
//   byte 0   cSSS SSSS   c (bit 7): no more segments follow; seqno (bits 6..0): 1..blksize
//   byte 1-7 segment data (all 7 bytes; the last segment's unused bytes are given by n in the
//            end request)
// Byte 0 = 80h (c=1, seqno 0) is not a segment but an abort transfer frame.
struct BlockSegment {
  bool last = false;
  std::uint8_t seqno = 0;
  std::array<std::uint8_t, 7> data{};

  // Precondition: bytes.size() <= 7 (shorter data is padded with 0).
  static BlockSegment make(std::uint8_t seqno, bool last, std::span<const std::uint8_t> bytes);

  friend bool operator==(const BlockSegment&, const BlockSegment&) = default;
};

// Why a frame is not a valid SDO frame.
enum class SdoInvalidReason : std::uint8_t {
  remote_frame = 1,            // RTR frame: SDOs are data frames
  error_frame,                 // an error frame, not a data frame
  short_frame,                 // DLC < 8: CiA 301 requires 8 data bytes
  reserved_command_specifier,  // ccs/scs = 7
  reserved_subcommand,         // block download response with ss = 3
};
std::string_view describe(SdoInvalidReason reason);

struct SdoInvalid {
  SdoInvalidReason reason = SdoInvalidReason::short_frame;
  friend bool operator==(const SdoInvalid&, const SdoInvalid&) = default;
};

// What a frame sent by an SDO client decodes to.
using SdoClientMessage =
    std::variant<SdoInvalid, InitiateDownloadRequest, DownloadSegmentRequest, InitiateUploadRequest,
                 UploadSegmentRequest, BlockDownloadInitiateRequest, BlockDownloadEndRequest,
                 BlockUploadInitiateRequest, BlockUploadStart, BlockUploadAck,
                 BlockUploadEndResponse, BlockSegment, AbortTransfer>;

// What a frame sent by an SDO server decodes to.
using SdoServerMessage =
    std::variant<SdoInvalid, UploadSegmentResponse, DownloadSegmentResponse, InitiateUploadResponse,
                 InitiateDownloadResponse, BlockDownloadInitiateResponse, BlockDownloadAck,
                 BlockDownloadEndResponse, BlockUploadInitiateResponse, BlockUploadEndRequest,
                 BlockSegment, AbortTransfer>;

// How the receiver expects the next frame to be framed.
enum class SdoFraming : std::uint8_t {
  command,        // byte 0 is a command byte (every frame outside a sub-block)
  block_segment,  // inside a sub-block: byte 0 is c | seqno, except 80h = abort transfer
};

// Decodes a frame an SDO client sent (the frame's identifier is not looked at). Total: every
// frame gives a message or SdoInvalid.
SdoClientMessage decode_client_message(const can::Frame& frame,
                                       SdoFraming framing = SdoFraming::command);
// Decodes a frame an SDO server sent.
SdoServerMessage decode_server_message(const can::Frame& frame,
                                       SdoFraming framing = SdoFraming::command);

// The 8 data bytes of a message.
using SdoPayload = std::array<std::uint8_t, kSdoFrameLength>;
SdoPayload encode_payload(const InitiateDownloadRequest& message);
SdoPayload encode_payload(const DownloadSegmentRequest& message);
SdoPayload encode_payload(const InitiateUploadRequest& message);
SdoPayload encode_payload(const UploadSegmentRequest& message);
SdoPayload encode_payload(const BlockDownloadInitiateRequest& message);
SdoPayload encode_payload(const BlockDownloadEndRequest& message);
SdoPayload encode_payload(const BlockUploadInitiateRequest& message);
SdoPayload encode_payload(const BlockUploadStart& message);
SdoPayload encode_payload(const BlockUploadAck& message);
SdoPayload encode_payload(const BlockUploadEndResponse& message);
SdoPayload encode_payload(const UploadSegmentResponse& message);
SdoPayload encode_payload(const DownloadSegmentResponse& message);
SdoPayload encode_payload(const InitiateUploadResponse& message);
SdoPayload encode_payload(const InitiateDownloadResponse& message);
SdoPayload encode_payload(const BlockDownloadInitiateResponse& message);
SdoPayload encode_payload(const BlockDownloadAck& message);
SdoPayload encode_payload(const BlockDownloadEndResponse& message);
SdoPayload encode_payload(const BlockUploadInitiateResponse& message);
SdoPayload encode_payload(const BlockUploadEndRequest& message);
SdoPayload encode_payload(const AbortTransfer& message);
SdoPayload encode_payload(const BlockSegment& message);

// An 8-byte data frame with the given COB-ID. The id is masked to 11 bits (standard) or
// 29 bits (extended).
can::Frame make_sdo_frame(std::uint32_t cob_id, const SdoPayload& payload,
                          can::IdFormat format = can::IdFormat::standard);

// A message as a frame: make_sdo_frame(cob_id, encode_payload(message), format).
template <class Message>
can::Frame encode(const Message& message, std::uint32_t cob_id,
                  can::IdFormat format = can::IdFormat::standard) {
  return make_sdo_frame(cob_id, encode_payload(message), format);
}
// Any decoded message as a frame; nullopt for SdoInvalid.
std::optional<can::Frame> encode(const SdoClientMessage& message, std::uint32_t cob_id,
                                 can::IdFormat format = can::IdFormat::standard);
std::optional<can::Frame> encode(const SdoServerMessage& message, std::uint32_t cob_id,
                                 can::IdFormat format = can::IdFormat::standard);

// One line of text for a message, for transcripts and test failures:
//   "initiate download request 6041h:00 expedited size 2 data 0F 00"
std::string to_string(const SdoClientMessage& message);
std::string to_string(const SdoServerMessage& message);

// CRC-16 of SDO block transfer (CiA 301 §7.2.4.3.16): CCITT polynomial x^16 + x^12 + x^5 + 1
// (1021h), initial value 0, no reflection, no final XOR. Pass the previous result as `crc` to
// continue over data given in pieces. crc16_ccitt("123456789") == 31C3h.
std::uint16_t crc16_ccitt(std::span<const std::uint8_t> data, std::uint16_t crc = 0);

}  // namespace drivecheck::cia301

// "6041h:00"
template <>
struct fmt::formatter<drivecheck::cia301::Multiplexer> : fmt::formatter<std::string_view> {
  template <class FormatContext>
  auto format(const drivecheck::cia301::Multiplexer& mux, FormatContext& ctx) const {
    return fmt::format_to(ctx.out(), "{:04X}h:{:02X}", mux.index, mux.sub_index);
  }
};
