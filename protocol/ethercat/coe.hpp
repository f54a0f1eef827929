// CoE, CANopen over EtherCAT (ETG.1000.6 CoE, ETG.1000.5 CoE services; CiA 301 SDO
// semantics): the CoE header, the SDO messages as they travel in a mailbox, and the emergency.
// Pure functions over the mailbox data (the octets after the 6-octet mailbox header): no state,
// total over their input, a decode error names what was wrong.
//
// CoE header, 2 octets, little-endian (public layout: Wireshark packet-ecatmb.h):
//   bits 0..8   Number   (PDO number for the PDO services; 0 for SDO and emergency)
//   bits 9..11  reserved (0)
//   bits 12..15 Service  (coe_services.inc)
//
// SDO request / response (Service 2 / 3): the CoE header, then the 8 octets of a CiA 301 SDO
// frame, then for the "normal" (not expedited) transfer and longer segments more data, as far
// as the mailbox Length says. Festo CMMP-AS 000 §4.8 L2116-2140 (Fig. 4.4): "6 bytes Mailbox
// Header, 2 bytes CoE Header, 1 byte SDO Control Byte, 2 bytes Index, 1 byte Sub-index,
// 4 bytes Data, 1..n bytes Data (optional)". Command byte bits (CiA 301 §7.2.4.3, plus CoE's
// complete access bit 4 in initiate requests and the initiate upload response):
//
//   initiate download request   001C nnes   C: complete access; n: unused of 4 (e=1, s=1)
//                                           e: expedited; s: size indicated
//     index, sub-index; e=1: 4 data octets; e=0: complete size (UNSIGNED32) then data
//   download segment request    000t nnnc   t: toggle; n: unused of 7 (segment of 7 octets);
//                                           c: last segment
//     segment data: 7 octets (n unused) or, when the mailbox is longer, all octets after the
//     command byte (n = 0)
//   initiate upload request     010C 0000   index, sub-index, 4 reserved
//   upload segment request      011t 0000   7 reserved
//   abort transfer              1000 0000   index, sub-index, abort code (UNSIGNED32)
//   initiate upload response    010C nnes   as the download request (normal: complete size
//                                           then as much data as fits the mailbox)
//   upload segment response     000t nnnc   as the download segment request
//   initiate download response  0110 0000   index, sub-index, 4 reserved
//   download segment response   001t 0000   7 reserved
//
// Complete access (C=1, ETG.1000.6): the whole object in one transfer, sub-index 0 or 1 only
// (0: sub-index 0 included, 1: from sub-index 1). The data layout is in coe_sdo_server.hpp.
//
// Emergency (Service 1): the CoE header, then the 8 octets of a CiA 301 EMCY (error code,
// error register, 5 manufacturer octets), then optional data (Festo 000 §4.11 L2220-2236,
// Fig. 4.7; the Festo drive sends no optional data).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::ethercat {

using cia301::Multiplexer;

inline constexpr std::size_t kCoeHeaderSize = 2;
inline constexpr std::size_t kCoeSdoSize = 8;  // command, index, sub-index, 4 octets
// Mailbox data of the smallest SDO message: CoE header + 8.
inline constexpr std::size_t kCoeSdoMessageSize = kCoeHeaderSize + kCoeSdoSize;
inline constexpr std::size_t kCoeEmergencySize = 8;

enum class CoeService : std::uint8_t {
#define DRIVECHECK_COE_SERVICE(name, value, text) name = value,
#include "protocol/ethercat/coe_services.inc"
#undef DRIVECHECK_COE_SERVICE
};
std::optional<std::string_view> coe_service_name(std::uint8_t value);

struct CoeHeader {
  std::uint16_t number = 0;  // 0..511
  std::uint8_t reserved = 0;
  std::uint8_t service = 0;  // raw 4 bits (CoeService for the known values)
  friend bool operator==(const CoeHeader&, const CoeHeader&) = default;
};
void encode_coe_header(const CoeHeader& header, std::span<std::uint8_t, 2> out);
CoeHeader decode_coe_header(std::span<const std::uint8_t, 2> bytes);

// Why a CoE message could not be decoded. `abort` is the code an SDO server answers it with
// (nullopt: not an SDO matter, e.g. a wrong service, which the caller turns into a mailbox
// error service_not_supported).
struct CoeDecodeError {
  std::string_view reason;
  std::optional<cia301::SdoAbort> abort;
};

// ---- SDO messages -----------------------------------------------------------------------------

struct CoeDownloadInitiate {
  Multiplexer mux;
  bool complete_access = false;
  bool expedited = false;
  bool size_indicated = false;
  std::uint32_t complete_size = 0;  // e=0, s=1: the announced size; e=1, s=1: 4 - n
  std::vector<std::uint8_t> data;   // e=1: the 4 - n (s=1) or 4 (s=0) octets; e=0: what follows
  friend bool operator==(const CoeDownloadInitiate&, const CoeDownloadInitiate&) = default;
};
struct CoeDownloadSegment {
  bool toggle = false;
  bool last = false;
  std::vector<std::uint8_t> data;
  friend bool operator==(const CoeDownloadSegment&, const CoeDownloadSegment&) = default;
};
struct CoeUploadInitiate {
  Multiplexer mux;
  bool complete_access = false;
  friend bool operator==(const CoeUploadInitiate&, const CoeUploadInitiate&) = default;
};
struct CoeUploadSegmentRequest {
  bool toggle = false;
  friend bool operator==(const CoeUploadSegmentRequest&, const CoeUploadSegmentRequest&) = default;
};
struct CoeAbort {
  Multiplexer mux;
  std::uint32_t code = 0;
  friend bool operator==(const CoeAbort&, const CoeAbort&) = default;
};
struct CoeUploadInitiateResponse {
  Multiplexer mux;
  bool complete_access = false;
  bool expedited = false;
  bool size_indicated = false;
  std::uint32_t complete_size = 0;
  std::vector<std::uint8_t> data;
  friend bool operator==(const CoeUploadInitiateResponse&,
                         const CoeUploadInitiateResponse&) = default;
};
struct CoeUploadSegment {
  bool toggle = false;
  bool last = false;
  std::vector<std::uint8_t> data;
  friend bool operator==(const CoeUploadSegment&, const CoeUploadSegment&) = default;
};
struct CoeDownloadInitiateResponse {
  Multiplexer mux;
  friend bool operator==(const CoeDownloadInitiateResponse&,
                         const CoeDownloadInitiateResponse&) = default;
};
struct CoeDownloadSegmentResponse {
  bool toggle = false;
  friend bool operator==(const CoeDownloadSegmentResponse&,
                         const CoeDownloadSegmentResponse&) = default;
};

using CoeSdoRequest = std::variant<CoeDownloadInitiate, CoeDownloadSegment, CoeUploadInitiate,
                                   CoeUploadSegmentRequest, CoeAbort>;
using CoeSdoResponse =
    std::variant<CoeUploadInitiateResponse, CoeUploadSegment, CoeDownloadInitiateResponse,
                 CoeDownloadSegmentResponse, CoeAbort>;

// Decoders of the mailbox data (CoE header included). Errors: shorter than 10 octets; a CoE
// service other than SDO request (resp. response); a reserved command specifier; an expedited
// size of 0 octets; a long segment with n != 0; a normal initiate without its complete size.
Expected<CoeSdoRequest, CoeDecodeError> decode_sdo_request(std::span<const std::uint8_t> data);
Expected<CoeSdoResponse, CoeDecodeError> decode_sdo_response(std::span<const std::uint8_t> data);

// Encoders: the mailbox data (CoE header first). Segments shorter than 7 octets are padded to
// 7 with n set; longer ones are carried whole with n = 0. Preconditions: expedited data of 1..4
// octets.
std::vector<std::uint8_t> encode(const CoeSdoRequest& message);
std::vector<std::uint8_t> encode(const CoeSdoResponse& message);

// "SDO upload initiate 1018h:01", "SDO abort 6040h:00 06010002h", ... for traces and failures.
std::string to_string(const CoeSdoRequest& message);
std::string to_string(const CoeSdoResponse& message);

// ---- Emergency ------------------------------------------------------------------------------

struct CoeEmergency {
  cia301::Emcy emcy;
  std::vector<std::uint8_t> extra;  // optional data after the 8 octets
  friend bool operator==(const CoeEmergency&, const CoeEmergency&) = default;
};
std::vector<std::uint8_t> encode(const CoeEmergency& message);
// Errors: shorter than 10 octets, a service other than emergency.
Expected<CoeEmergency, CoeDecodeError> decode_emergency(std::span<const std::uint8_t> data);

// The CoE service of mailbox data, or nullopt when it is shorter than a CoE header.
std::optional<std::uint8_t> peek_coe_service(std::span<const std::uint8_t> data);

// One line for a trace or a report, of a whole mailbox (an SM0 or SM1 content), total over any
// input: "CoE cnt 1: SDO upload initiate 1018h:01", "ERR cnt 2: 0004h service_not_supported:
// ...", "CoE cnt 3: emergency 8611h Following error, register 20h", "CoE cnt 4: SDO information
// opcode 2, 1 fragment(s) left", "FoE cnt 1: 12 octets", or why it is no mailbox.
std::string describe_mailbox_message(std::span<const std::uint8_t> buffer);

}  // namespace drivecheck::ethercat
