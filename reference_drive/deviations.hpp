// Named deviations: faults injected into the reference drive so that it is non-conformant in
// exactly one documented way each (reference_drive/deviations.inc is the one table: names,
// families, kinds, descriptions). They exist so that the suite can prove it catches each one,
// and so that master developers can test against a misbehaving drive
// (`drivecheck drive --deviation NAME ...`, `drivecheck run --deviation NAME ...`).
//
// Where each deviation lives:
//   - DeviationPort (below): the CiA 301 deviations visible on the wire. It wraps the drive's
//     bus port: every frame the drive sends passes its outgoing mutator (rewritten, dropped,
//     held back), every frame it receives passes its incoming filter (dropped, rewritten, or
//     answered by the port itself); the fatal ones (crash, SDO hang, babble) live here too.
//   - ReferenceDrive (device.cpp, DriveConfig::deviations): the NMT/PDO/SYNC ones that change
//     what a service is told (SDO in Stopped, PDOs in Pre-operational, reset communication,
//     SYNC counter, the SDO timeout, the heartbeat consumer and EMCY inhibit options of
//     DeviceServicesConfig).
//   - PowerDriveSystem (power_drive_system.cpp, PowerDriveConfig::deviations): cia402/fsa,
//     cia402/option-codes, cia402/modes.
//   - the mode logic (axis engineer: pp, pv, tq, ip, csp; homing engineer: homing) checks
//     DeviationSet::has() itself.
#pragma once

#include <array>
#include <bitset>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/pdo.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {
class ObjectDictionary;
}

namespace drivecheck::reference_drive {

class SdoDeviations;

// Generated from deviations.inc.
enum class Deviation : std::uint8_t {
#define DRIVECHECK_DEVIATION(name, text, family, kind, description) name,
#include "reference_drive/deviations.inc"
#undef DRIVECHECK_DEVIATION
};

inline constexpr std::size_t kDeviationCount = 0
#define DRIVECHECK_DEVIATION(name, text, family, kind, description) +1
#include "reference_drive/deviations.inc"
#undef DRIVECHECK_DEVIATION
    ;

enum class DeviationKind : std::uint8_t {
  ordinary,  // one precise misbehaviour; the drive otherwise works
  fatal,     // crash, hang or babble (the description says which and its trigger)
};

struct DeviationInfo {
  Deviation deviation;
  std::string_view name;    // kebab-case, what --deviation takes
  std::string_view family;  // the vector family that must catch it, e.g. "cia301/sdo"
  DeviationKind kind;
  std::string_view description;  // what is wrong and what CiA says instead
};

inline constexpr std::array<DeviationInfo, kDeviationCount> kDeviations{{
#define DRIVECHECK_DEVIATION(name, text, family, kind, description) \
  {Deviation::name, text, family, DeviationKind::kind, description},
#include "reference_drive/deviations.inc"
#undef DRIVECHECK_DEVIATION
}};

// The links a deviation acts on (deviations.inc: DRIVECHECK_DEVIATION_ONLY_ON); a row without
// the mark acts on both.
enum class DeviationLink : std::uint8_t { can, ethercat };
struct DeviationOnlyOn {
  Deviation deviation;
  DeviationLink link;    // the one link it acts on
  std::string_view why;  // why only there
};
inline constexpr DeviationOnlyOn kDeviationsOnlyOn[] = {
#define DRIVECHECK_DEVIATION_ONLY_ON(name, link, why) {Deviation::name, DeviationLink::link, why},
#include "reference_drive/deviations.inc"
#undef DRIVECHECK_DEVIATION_ONLY_ON
};
constexpr bool acts_on(Deviation deviation, DeviationLink link) {
  for (const DeviationOnlyOn& row : kDeviationsOnlyOn) {
    if (row.deviation == deviation) return row.link == link;
  }
  return true;
}
// Why the deviation acts on one link only; empty when it acts on both.
constexpr std::string_view only_on_why(Deviation deviation) {
  for (const DeviationOnlyOn& row : kDeviationsOnlyOn) {
    if (row.deviation == deviation) return row.why;
  }
  return {};
}

constexpr const DeviationInfo& info_of(Deviation deviation) {
  return kDeviations[static_cast<std::size_t>(deviation)];
}
constexpr std::string_view to_string(Deviation deviation) {
  return info_of(deviation).name;
}
constexpr std::string_view to_string(DeviationKind kind) {
  return kind == DeviationKind::fatal ? "fatal" : "ordinary";
}

// The deviation of that exact name (kebab-case), if any.
std::optional<Deviation> find_deviation(std::string_view name);
// Up to `limit` names close to `name` (edit distance, shared words, prefix), best first.
std::vector<std::string_view> close_deviation_names(std::string_view name, std::size_t limit = 3);
// The table for `--help` and reports: one line per deviation, "name  family  kind
// description", grouped as deviations.inc orders them.
std::string deviation_table();

// A set of deviations (value type; empty = the standard drive).
class DeviationSet {
 public:
  DeviationSet() = default;
  DeviationSet(std::initializer_list<Deviation> deviations) {
    for (Deviation deviation : deviations)
      add(deviation);
  }

  // Names as given on the command line; each item may also be a comma-separated list.
  // Errors: "unknown deviation 'x' (did you mean: a, b, c?)".
  static Expected<DeviationSet, std::string> parse(std::span<const std::string> names);
  // Adds one name; errors as parse().
  Expected<void, std::string> add(std::string_view name);

  bool has(Deviation deviation) const { return bits_.test(static_cast<std::size_t>(deviation)); }
  void add(Deviation deviation) { bits_.set(static_cast<std::size_t>(deviation)); }
  void remove(Deviation deviation) { bits_.reset(static_cast<std::size_t>(deviation)); }
  bool empty() const { return bits_.none(); }
  std::size_t size() const { return bits_.count(); }
  bool any_fatal() const;
  // The members in table order.
  std::vector<Deviation> list() const;
  // "a, b, c" (names in table order), "none" when empty.
  std::string names() const;

  friend bool operator==(const DeviationSet&, const DeviationSet&) = default;

 private:
  std::bitset<kDeviationCount> bits_;
};

// ---------------------------------------------------------------------------------------------
// DeviationPort: the drive's bus port with the wire-level deviations applied. It is a can::Bus
// that forwards to the real port; ReferenceDrive puts it between itself and the bus when its
// DeviationSet is not empty. The dictionary (set_dictionary) gives it the node-ID and the
// configured COB-IDs (1014h, 1800h..); without one it passes everything unchanged.
//
// Outgoing (what the drive sends), by frame:
//   SDO response 580h+N  byte 0 scs: 80h abort (bytes 4-7 the code), 60h download response,
//                        4xh expedited upload response (n in bits 2-3), 0xh upload segment
//                        (toggle bit 4); bytes 1-2 index (LE), byte 3 sub-index
//   700h+N 1 byte        boot-up 00h; heartbeat 04h/05h/7Fh; a guarding response (after an
//                        RTR on 700h+N) is bit 7 toggle + bits 0-6 the state
//   EMCY (1014h)         bytes 0-1 error code (LE), byte 2 error register, 3-7 manufacturer
//   TPDOs (1800h..)      the COB-IDs and transmission types of the valid TPDOs
// A dropped synchronous TPDO still comes back as the sender's own echo (loopback), as a frame
// lost on the wire would: the PDO pacing (1007h) does not stall. Heartbeats may be held back
// (heartbeat-period-long: sent 1.1 periods after the previous one, the newest state wins).
// Incoming (what the drive receives): NMT 000h (byte 0 command, byte 1 node-ID), SDO requests
// 600h+N (byte 0 ccs in bits 5-7), RTRs on 700h+N and on TPDO COB-IDs. The port answers some
// requests itself and keeps them from the drive (1003h:00 := 0, 1011h "load": a download
// response, nothing done) and rewrites others (1010h: any value becomes "save").
// Fatal: after its trigger a crashed port drops every frame both ways; an SDO-hung port drops
// 600h+N and 580h+N; a babbling port sends 80h+N [FF x 8] again at each echo of the last one
// (every 100 us without loopback) until the bus refuses it.
class DeviationPort final : public can::Bus {
 public:
  DeviationPort(can::Bus& port, DeviationSet deviations);
  ~DeviationPort() override;
  DeviationPort(const DeviationPort&) = delete;
  DeviationPort& operator=(const DeviationPort&) = delete;

  // The drive's dictionary (must outlive this port, or be reset to nullptr first).
  void set_dictionary(const cia301::ObjectDictionary* od) { od_ = od; }
  const DeviationSet& deviations() const { return deviations_; }

  // Fatal states (sticky until the port is destroyed: "until power off").
  bool crashed() const { return crashed_; }
  bool sdo_hung() const { return sdo_hung_; }
  bool babbling() const { return babbling_; }

  // can::Bus
  can::TimePoint now() const override { return port_.now(); }
  can::Duration unix_offset() const override { return port_.unix_offset(); }
  std::error_code send(const can::Frame& frame) override;
  std::optional<can::TimedFrame> receive(can::TimePoint deadline) override;
  void set_frame_handler(FrameHandler handler) override;
  void set_filters(std::span<const can::Filter> filters) override { port_.set_filters(filters); }
  void set_loopback(bool enabled) override;
  std::size_t queued(std::uint32_t id, can::IdFormat format) const override {
    return port_.queued(id, format);
  }
  can::TimerId start_timer(can::TimePoint at, TimerCallback callback) override {
    return port_.start_timer(at, std::move(callback));
  }
  void cancel_timer(can::TimerId id) override { port_.cancel_timer(id); }
  void run_until(can::TimePoint deadline) override { port_.run_until(deadline); }
  void stop() override { port_.stop(); }

 private:
  // nullopt: drop. Sets the fatal states and arranges answers the port gives itself.
  std::optional<can::Frame> outgoing(const can::Frame& frame);
  std::optional<can::Frame> incoming(const can::Frame& frame);
  // sdo-non-expedited-download-heartbeat-only: a segmented or block download initiate of an
  // object of 4 octets or less but 1017h (and keeps track of the block download running).
  bool refuses_non_expedited_download(const can::Frame& request);
  void on_frame(const can::TimedFrame& frame);
  std::error_code transmit(const can::Frame& frame);
  void fake_echo(const can::Frame& frame);
  void start_owned_timer(can::TimePoint at, std::function<void()> callback);
  void send_held_heartbeat();
  void babble();
  std::uint8_t node() const;
  std::optional<std::uint32_t> emcy_cob_id() const;
  // The number (1..512) of the valid standard-ID PDO of `direction` on CAN-ID `id`.
  std::optional<std::uint16_t> pdo_number_of(cia301::PdoDirection direction,
                                             std::uint32_t id) const;
  bool is_tpdo(std::uint32_t id, bool synchronous_only) const;
  // pdo-dummy-entry-takes-no-room: the RPDO frame on `id` as the drive reads it, its dummy
  // entries' bits taken out (the entries after one read from where it is); nullopt when `id` is
  // no RPDO with a dummy entry.
  std::optional<can::Frame> without_dummy_bits(const can::Frame& frame) const;
  // The last SDO request was an expedited download of a restricted CAN-ID (CiA 301 §7.3.5) to
  // a COB-ID object (1005h, 1012h, 1014h, PDO sub 01h) and `abort` aborts that transfer.
  bool restricted_cob_id_written(const can::Frame& abort) const;

  can::Bus& port_;
  DeviationSet deviations_;
  std::unique_ptr<SdoDeviations> sdo_;  // the SDO service deviations (sdo_deviations.hpp)
  const cia301::ObjectDictionary* od_ = nullptr;
  FrameHandler handler_;
  bool loopback_ = false;

  std::uint8_t last_request_ = 0;                    // byte 0 of the last SDO request
  std::array<std::uint8_t, 8> last_request_data_{};  // all of it (restricted-cob-id-accepted)
  bool in_guarding_request_ = false;  // handling an RTR on 700h+N: 700h+N is its response
  // sdo-block-sequence-ignored: the seqno the next block download segment gets (0: no
  // sub-block open), and whether the transfer goes on after this sub-block.
  std::uint8_t block_download_seqno_ = 0;
  bool block_download_open_ = false;
  // sdo-non-expedited-download-heartbeat-only: a block download the server took is running (its
  // segments are not initiate requests).
  bool block_download_running_ = false;
  // guarding-request-stops-heartbeat: a guarding request came while guarding was configured;
  // the heartbeat stays off until the next boot-up.
  bool guarding_took_over_ = false;
  // guarding-answered-with-guard-time-zero: the NMT state of the last boot-up or heartbeat, and
  // the toggle of the next guarding response this port makes itself.
  std::uint8_t last_nmt_state_ = 0x7F;
  bool guarding_toggle_ = false;
  // heartbeat-period-long
  can::TimePoint last_heartbeat_ = can::TimePoint::min();
  std::optional<can::Frame> held_heartbeat_;
  can::TimerId held_timer_ = can::kNoTimer;
  std::vector<can::TimerId> timers_;  // fake echoes, babble without loopback

  bool crashed_ = false;
  bool sdo_hung_ = false;
  bool babbling_ = false;
};

}  // namespace drivecheck::reference_drive
