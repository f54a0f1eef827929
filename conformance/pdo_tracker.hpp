// What the harness knows of the DUT's PDO configuration, followed from the frames of the run,
// and the decoding of PDO frames into timing-diagram samples (result.hpp Sample).
//
// Sources of knowledge, in order:
//   1. the profile's pdo_defaults (COB-ID with the node-ID, mapping); a PDO the profile does
//      not list is unknown (its COB-ID, if never written or read, is taken as the pre-defined
//      one of CiA 301 §7.3.5 for PDOs 1-4: TPDO n 180h/280h/380h/480h + N, RPDO n
//      200h/300h/400h/500h + N);
//   2. every expedited SDO download the harness makes to the DUT's default SDO server (600h+N)
//      that the DUT confirms (580h+N, scs 3) to 1400h-15FFh / 1800h-19FFh sub 01h (COB-ID) or
//      1600h-17FFh / 1A00h-1BFFh sub 00h..40h (mapping): the value written now holds;
//   3. every expedited SDO upload of those objects (scs 2, e=1): the value read now holds;
//   4. 1010h sub 01h/02h := "save" (73 61 76 65) confirmed: the current configuration is what a
//      reset brings back; 1011h sub 01h/02h := "load" (6C 6F 61 64) confirmed: the profile's
//      defaults are (CiA 301 §7.5.2.13-14);
//   5. NMT reset node / reset communication (000#81 NN, 000#82 NN with NN the DUT or 0) sent by
//      the harness, and a boot-up of the DUT (700h+N #00): the configuration a reset brings back.
// Segmented and block transfers of PDO objects are not followed (the PDO's state becomes
// unknown when such a transfer to it is confirmed).
//
// Mapping procedure (CiA 301 §7.5.2.36): sub 00h := 0 disables the mapping, subs 01h..n take
// the entries, sub 00h := n enables it. The tracker holds what the DUT accepted; a mapping is
// usable for decoding when sub 00h and each of its n entries are known, every entry decodes
// (pdo.hpp decode_pdo_mapping_entry) and they total at most 64 bits.
//
// Decoding: a data frame (11-bit, not RTR) the DUT sends on the COB-ID of a valid TPDO (bit 31
// = 0) with a usable mapping, or one the harness sends on the COB-ID of a valid RPDO, is
// unpacked (pdo.hpp unpack_pdo); each mapped object that samples.hpp names becomes a sample at
// the frame's time, origin tpdo / rpdo. A frame shorter than its mapping gives no sample (and
// counts in short_frames()).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "conformance/result.hpp"
#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/pdo.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::conformance {

// One PDO's parameters as far as known (nullopt: unknown).
struct TrackedPdo {
  std::optional<std::uint32_t> cob_id;  // sub 01h of the communication record, raw
  std::optional<std::uint8_t> count;    // sub 00h of the mapping record
  std::array<std::optional<std::uint32_t>, cia301::kMaxMappedObjects> entries{};  // subs 01h..
  friend bool operator==(const TrackedPdo&, const TrackedPdo&) = default;
};

// Appends the samples of one PDO payload along `mapping` to `out`. Returns false (nothing
// appended) when the payload is shorter than the mapping or the mapping is invalid.
bool decode_pdo_samples(const cia301::PdoMapping& mapping, std::span<const std::uint8_t> payload,
                        can::TimePoint at, SampleOrigin origin, std::vector<Sample>& out);

class PdoTracker {
 public:
  PdoTracker(const profile::DriveProfile& profile, std::uint8_t node);

  // Every frame on the bus, in order: `from_harness` for the harness's own frames (their echo).
  // Appends the samples of a decoded PDO to `samples`.
  void on_frame(const can::Frame& frame, bool from_harness, can::TimePoint at,
                std::vector<Sample>& samples);

  // The COB-ID a PDO currently uses if it is valid (bit 31 = 0, 11-bit), else nullopt.
  std::optional<std::uint32_t> can_id(cia301::PdoDirection direction, std::uint16_t number) const;
  // The usable mapping of a PDO (see above), nullopt if unknown or invalid.
  std::optional<cia301::PdoMapping> mapping(cia301::PdoDirection direction,
                                            std::uint16_t number) const;
  // The tracked state (a default-constructed one for a PDO never heard of).
  TrackedPdo state(cia301::PdoDirection direction, std::uint16_t number) const;

  std::size_t short_frames() const { return short_frames_; }

 private:
  using Key = std::pair<cia301::PdoDirection, std::uint16_t>;
  struct Pending {
    cia301::Multiplexer mux;
    std::optional<std::vector<std::uint8_t>> data;  // download: expedited data; upload: none
    bool expedited = true;
  };
  void apply(cia301::Multiplexer mux, std::span<const std::uint8_t> data);
  void forget(cia301::Multiplexer mux);
  void reset();
  void on_sdo_request(const can::Frame& frame);
  void on_sdo_response(const can::Frame& frame);
  void decode(const can::Frame& frame, cia301::PdoDirection direction, can::TimePoint at,
              std::vector<Sample>& samples);

  std::uint8_t node_;
  std::map<Key, TrackedPdo> defaults_;  // the profile's
  std::map<Key, TrackedPdo> stored_;    // what a reset brings back
  std::map<Key, TrackedPdo> current_;
  std::optional<Pending> download_;
  std::optional<cia301::Multiplexer> upload_;
  std::size_t short_frames_ = 0;
};

}  // namespace drivecheck::conformance
