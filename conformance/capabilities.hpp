// What the device under test has, learnt once per run (DESIGN.md "Judging a device": needs, not
// guesses).
//
// Objects (a vector's `object.IIII` / `object.IIII.SS` needs, vocabulary.hpp):
//   - with an EDS (--eds): present when the EDS has the object (the sub-index, for a sub need),
//     else absent "(not in the EDS)";
//   - without: an SDO upload of the object (sub 0, or the sub-index needed), once per run.
//     An abort 06020000h (object does not exist) or 06090011h (sub-index does not exist) is
//     absent; any other answer, an abort included (06010001h write only ...), is present; no
//     answer is unknown: the vector runs, and a harness note says that it was not known.
// Features a profile leaves to probing (`detect:`, vocabulary.hpp detectable_features()), by the
// objects CiA 301/402 make mandatory with them (emcy: 1014h, store: 1010h ...) and by behaviour:
//   heartbeat.producer  1017h present and the value read written back accepted
//   nmt.guarding        100Ch present, else a remote frame on 700h+N answered
//   pdo.rtr             TPDO1 COB-ID (1800h sub 1) bit 30 clear: RTR allowed (CiA 301 §7.5.2.37)
//   pdo.dynamic-mapping with TPDO1 made invalid (1800h sub 1 bit 31), 1A00h sub 0 written with
//                       the value it holds: accepted = dynamic, refused = static; 1800h sub 1 is
//                       put back to what it was
//   sdo.block           a block upload of 1000h: completed = present, aborted = absent
//   sdo.segmented       an upload of 1008h/1009h/100Ah longer than 4 bytes (a segmented
//                       transfer) = present; none longer: unknown
//   cia402              1000h bits 0..15 = 402
//   mode.*              6502h bits (CiA 402-2 §6502h: 0 pp, 1 vl, 2 pv, 3 tq, 5 hm, 6 ip,
//                       7 csp, 8 csv, 9 cst)
// Also recorded (not a feature): the objects known to be PDO-mappable (the EDS's PDOMapping, else
// the objects TPDO1/RPDO1 map by default, as read from 1A00h/1600h).
//
// The probes speak services (SDO upload/download, a guarding request) through DeviceProbe, so the
// engine's transport decides how (CAN today; an EtherCAT port later answers guarding with
// nullopt).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::cia301 {
class ObjectDictionary;
}  // namespace drivecheck::cia301

namespace drivecheck::conformance {

enum class Presence : std::uint8_t { present, absent, unknown };
std::string_view to_string(Presence presence);

struct Finding {
  Presence presence = Presence::unknown;
  std::string how;  // "upload answered 06020000h", "not in the EDS", "no answer to the upload"
};

// The services the probes need from the device under test.
class DeviceProbe {
 public:
  struct Answer {
    bool ok = false;
    std::vector<std::uint8_t> data;      // upload
    std::optional<std::uint32_t> abort;  // the server's abort code; !ok && !abort: no answer
  };
  virtual ~DeviceProbe() = default;
  virtual Answer upload(std::uint16_t index, std::uint8_t sub) = 0;
  virtual Answer block_upload(std::uint16_t index, std::uint8_t sub) = 0;
  virtual Answer download(std::uint16_t index, std::uint8_t sub,
                          std::span<const std::uint8_t> data) = 0;
  // A node guarding request answered; nullopt where the transport has no node guarding.
  virtual std::optional<bool> guarding_answered() = 0;
};

// The generic profile for a DUT given no --profile on a real bus, from its 1000h (CiA 301
// §7.5.2.1: bits 0..15 the device profile number): 402 -> cia402-device, anything else (or no
// answer) -> cia301-device; `why` says so for the reports.
struct ProfileChoice {
  std::string name;
  std::string why;
};
ProfileChoice choose_generic_profile(std::optional<std::uint32_t> device_type);

class Capabilities {
 public:
  // `eds` (not owned, may be null): the DUT's object dictionary as its EDS describes it.
  explicit Capabilities(const cia301::ObjectDictionary* eds = nullptr);

  // Learns every object need and every feature of `detect` (once: later calls only add what is
  // not known yet). `device_type`: 1000h as read at the start of the run.
  void probe(DeviceProbe& device, const std::set<profile::ObjectNeed>& needs,
             const std::set<std::string>& detect, std::optional<std::uint32_t> device_type);

  // What is known (unknown "not probed" when it never was).
  Finding object(const profile::ObjectNeed& need) const;
  Finding feature(std::string_view name) const;
  bool probed() const { return probed_; }

  // For the reports (RunInfo::capabilities): one line per finding, e.g.
  // "heartbeat.producer: present (1017h read 0, written back)",
  // "object 1029h: absent (upload answered 06020000h)", "mappable (EDS): 6040h, 6041h ...".
  std::vector<std::string> describe() const;
  // Harness notes: the needs and features that stayed unknown (their vectors run regardless).
  std::vector<std::string> notes() const;

 private:
  Finding find_object(DeviceProbe& device, const profile::ObjectNeed& need);
  Finding probe_feature(DeviceProbe& device, std::string_view name,
                        std::optional<std::uint32_t> device_type);
  Finding present_if(DeviceProbe& device, std::uint16_t index, std::optional<std::uint8_t> sub);
  void learn_mappable(DeviceProbe& device);

  const cia301::ObjectDictionary* eds_;
  bool probed_ = false;
  std::map<profile::ObjectNeed, Finding> objects_;
  std::map<std::string, Finding, std::less<>> features_;
  std::optional<std::uint16_t> supported_modes_;  // 6502h bits 0..15, once read
  std::optional<Finding> modes_finding_;
  std::string mappable_;  // "" when nothing learnt
};

}  // namespace drivecheck::conformance
