// The named deviations of the SDO service (deviations.inc rows that are about the object
// dictionary or the SDO semantics: abort codes, read-only and length checks, values read,
// store/restore signatures, PDO mapping rules, the answer missing), written once over a
// transport-neutral view of one SDO exchange. Two adapters feed it:
//   CAN   DeviationPort (deviations.hpp): the SDO frames 600h+N / 580h+N
//   CoE   reference_drive/ethercat/coe_deviations.hpp: the CoE SDO server's decoded messages
// so one deviation acts the same on both links. Rows that only exist on CAN (block SDO, the SDO
// timeout, COB-IDs, NMT, heartbeat, guarding, SYNC, CAN PDO frames) stay in DeviationPort; the
// table marks them (DRIVECHECK_DEVIATION_TRANSPORTS in deviations.inc).
//
// The view (what both links have):
//   request   download initiate (expedited: its 1..4 data octets), upload initiate, a segment
//             request of either direction, an abort from the client, or a request the server
//             cannot decode (CAN: ccs 7; CoE: a reserved command specifier)
//   answer    abort (multiplexer, code), download confirmed (initiate download response),
//             expedited upload (multiplexer, 1..4 octets), upload segment (toggle), or another
//             answer the deviations leave alone
// before() runs on a request before the server sees it; it may answer it itself (the server
// never sees it) or replace the data of an expedited download. after() runs on every answer
// (the server's, or before()'s) and may change it or drop it (no answer at all).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "reference_drive/deviations.hpp"

namespace drivecheck::cia301 {
class ObjectDictionary;
}

namespace drivecheck::reference_drive {

struct SdoRequestView {
  enum class Kind : std::uint8_t {
    download,          // initiate download
    upload,            // initiate upload
    download_segment,  // a download segment
    upload_segment,    // an upload segment request
    abort,             // the client aborts
    invalid,           // not decodable (a reserved command specifier, ...)
    other,             // anything else (block transfers, CoE complete access)
  };
  Kind kind = Kind::other;
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  bool expedited = false;          // download: e = 1
  std::vector<std::uint8_t> data;  // expedited download: its data octets (1..4)
  friend bool operator==(const SdoRequestView&, const SdoRequestView&) = default;
};

struct SdoAnswerView {
  enum class Kind : std::uint8_t {
    abort,               // abort transfer: index, sub, code
    download_confirmed,  // initiate download response: index, sub
    expedited_upload,    // initiate upload response, e = 1, size indicated: index, sub, data
    upload_segment,      // upload segment response: toggle
    other,               // anything else
  };
  Kind kind = Kind::other;
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::uint32_t code = 0;
  std::vector<std::uint8_t> data;  // expedited upload: 1..4 octets (the size it indicates)
  bool toggle = false;

  static SdoAnswerView abort_of(std::uint16_t index, std::uint8_t sub, std::uint32_t code);
  static SdoAnswerView confirmed(std::uint16_t index, std::uint8_t sub);
  static SdoAnswerView upload(std::uint16_t index, std::uint8_t sub,
                              std::vector<std::uint8_t> data);
  friend bool operator==(const SdoAnswerView&, const SdoAnswerView&) = default;
};

// What before() decided.
struct SdoBefore {
  std::optional<SdoAnswerView> answer;                // answered here: the server never sees it
  std::optional<std::vector<std::uint8_t>> replaced;  // expedited download: data written instead
};

class SdoDeviations {
 public:
  explicit SdoDeviations(DeviationSet deviations) : deviations_(deviations) {}

  // Whether any deviation of this layer is in the set (else both calls change nothing).
  bool active() const;
  SdoBefore before(const SdoRequestView& request, const cia301::ObjectDictionary& od) const;
  // nullopt: no answer is sent.
  std::optional<SdoAnswerView> after(const SdoRequestView& request, SdoAnswerView answer,
                                     const cia301::ObjectDictionary& od) const;

 private:
  bool has(Deviation d) const { return deviations_.has(d); }
  DeviationSet deviations_;
};

}  // namespace drivecheck::reference_drive
