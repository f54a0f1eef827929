// What a conformance run produces: one VectorResult per vector with its verdict and evidence,
// and the run's identity. The engine (conformance/engine.hpp) fills it; every report writer
// (reports/: JUnit, HTML, JSON, console) and `drivecheck report diff` read only this. Plain data,
// no behaviour beyond counting: a report must be able to say everything from it alone.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"

namespace drivecheck::conformance {

enum class Level : std::uint8_t { must, should, may };

enum class Verdict : std::uint8_t {
  pass,
  fail,
  deviation,       // failed exactly where the profile documents a deviation (with its source)
  not_applicable,  // skipped: the profile or the EDS says the feature is absent (with reason)
  error,           // harness error: the vector could not be carried out (not the DUT's fault)
  interrupted,     // the user stopped the run (Ctrl-C) while this vector ran: no verdict on it
};
inline constexpr std::size_t kVerdictCount = 6;

constexpr std::string_view to_string(Verdict verdict) {
  constexpr std::array<std::string_view, kVerdictCount> kNames{
      "pass", "fail", "deviation", "not-applicable", "error", "interrupted"};
  return kNames[static_cast<std::size_t>(verdict)];
}
constexpr std::string_view to_string(Level level) {
  constexpr std::array<std::string_view, 3> kNames{"must", "should", "may"};
  return kNames[static_cast<std::size_t>(level)];
}

// A repeated pattern summarised in the evidence (conformance/repeats.hpp), on the first entry
// of its first occurrence: that entry and the `length - 1` after it came again right after
// them, `times` more times until `until` (those repetitions are left out), and then once more:
// that last repetition follows them in full. A pattern is entries alike in their meaning: CAN
// frames equal in identifier, data and sender (an SDO poll and its answer); EtherCAT datagrams
// equal but for process data, the mailbox counter and the SII EEPROM address and data (the SII
// read of a bring-up, a mailbox poll). times 0: no pattern starts here.
struct EvidenceRepeat {
  std::size_t length = 0;
  std::size_t times = 0;
  can::TimePoint until{};
  friend bool operator==(const EvidenceRepeat&, const EvidenceRepeat&) = default;
};

// One frame on the bus during the vector, as the harness saw it.
struct EvidenceFrame {
  can::TimePoint at{};        // bus time (simulated, or the kernel timestamp)
  can::Frame frame;           // prints as candump via fmt / can::to_candump
  bool from_harness = false;  // sent by the harness (else by the DUT or another node)
  std::string decoded;        // the dissector's one-line meaning
  EvidenceRepeat repeat;      // a summarised pattern starting here (times 0: none)
};

// One EtherCAT datagram the master exchanged during the vector, decoded
// (protocol/ethercat/dissector.hpp), as it came back (working counter, data read); a frame that
// never came back is shown as sent, marked "(no answer)". Consecutive identical frames that
// carry no mailbox content (the cyclic process data, polls of an empty mailbox) are one entry
// per datagram with their count: "LRW logical 00010000h len 14 wkc 3" x120.
struct EvidenceDatagram {
  can::TimePoint at{};    // the (first) frame back at the master
  can::TimePoint last{};  // the last frame of a run (== at when count is 1)
  std::size_t count = 1;  // identical frames in a row summarised into this entry
  std::string decoded;    // command, address, registers, length, wkc, mailbox and CoE
  EvidenceRepeat repeat;  // a summarised pattern starting here (times 0: none)
  friend bool operator==(const EvidenceDatagram&, const EvidenceDatagram&) = default;
};

// What the DUT did where a check failed, as data (beside the Actual: text), so that a profile
// deviation's `observed:` (protocol/profile/drive_profile.hpp) can be compared with it exactly.
// The steps fill what they saw: an SDO step its abort code, the value it read, no answer or a
// transfer accepted where an abort was expected; a raw expect_frame on an SDO abort the code;
// a watching step that saw nothing `nothing` (an expect_frame also the code of an SDO abort
// the DUT sent meanwhile); expect_state/expect_statusword the last
// statusword; poll the last value. Empty (all unset) where the step has nothing typed to say.
struct Observation {
  std::optional<std::uint32_t> abort;       // the SDO abort code the DUT answered
  std::optional<std::int64_t> value;        // the value read (as the step interprets it)
  std::optional<std::uint16_t> statusword;  // the last statusword read
  bool nothing = false;                     // no answer / no matching frame within the time allowed
  bool accepted = false;  // the SDO transfer succeeded where the step expected an abort
  bool empty() const { return !abort && !value && !statusword && !nothing && !accepted; }
  friend bool operator==(const Observation&, const Observation&) = default;
};

// The pass of a `repeat:` a step ran in (FORMAT.md "Repeated steps"): `number` of `of`.
struct Iteration {
  std::size_t number = 0;  // 1..of
  std::size_t of = 0;
  friend bool operator==(const Iteration&, const Iteration&) = default;
};

// "iteration 117 of 254"; nested, innermost first: "iteration 2 of 5 in iteration 117 of 254".
inline std::string iteration_text(const std::vector<Iteration>& iterations) {
  std::string text;
  for (auto it = iterations.rbegin(); it != iterations.rend(); ++it) {
    if (!text.empty()) text += " in ";
    text += "iteration " + std::to_string(it->number) + " of " + std::to_string(it->of);
  }
  return text;
}

// How every report and message names a step: "setup" (0), "step 19", "step 19 (iteration 117
// of 254)".
inline std::string step_label(std::size_t step, const std::vector<Iteration>& iterations) {
  if (step == 0) return "setup";
  std::string text = "step " + std::to_string(step);
  if (!iterations.empty()) text += " (" + iteration_text(iterations) + ")";
  return text;
}

// One checked expectation: what the step required and what was seen.
struct Check {
  // The step, numbered from 1 as the vector file lists them (the same number as in the
  // message, "step 3 ..."); 0: not a step (setup, teardown, or the harness's own checks).
  std::size_t step = 0;
  std::string action;    // the step's action key, e.g. "expect_frame", "sdo_read"
  std::string expected;  // e.g. "580+5#80416000020001 06 (abort 06010002h)", "one of {...}"
  std::string actual;    // what the DUT did, or "nothing within 100 ms"
  bool ok = false;
  // Bus time at which the check was decided: the frame judged, or the deadline that passed
  // (the timing diagram and the transcript mark it for a failed check). Absent: not recorded.
  std::optional<can::TimePoint> at = std::nullopt;
  Observation observed;  // failed checks: what the DUT did, typed
  // A step inside `repeat:`: the pass of each repeat it ran in, outermost first (empty: none).
  std::vector<Iteration> iterations = {};
};

// A timing the vector measured (measure, expect_periodic, within-bounds of interest).
struct Timing {
  std::string name;  // e.g. "heartbeat period", "t0→ack"
  can::Duration measured{};
  std::optional<can::Duration> min;
  std::optional<can::Duration> max;
  bool ok = true;
};

// Where a sample was taken: an SDO transfer the harness made (the value read or written, at
// the time the transfer ended), a TPDO the DUT sent, an RPDO the harness sent (both at the
// frame's bus time; conformance/pdo_tracker.hpp decodes them).
enum class SampleOrigin : std::uint8_t { sdo, tpdo, rpdo };
constexpr std::string_view to_string(SampleOrigin origin) {
  constexpr std::array<std::string_view, 3> kNames{"sdo", "tpdo", "rpdo"};
  return kNames[static_cast<std::size_t>(origin)];
}

// A sample of a drive signal for the timing diagram (HTML SVG): controlword, statusword,
// position actual value, velocity actual value, ... as read or as seen in PDOs.
struct Sample {
  can::TimePoint at{};
  std::string signal;  // "controlword", "statusword", "position", "velocity", ...
  std::int64_t value = 0;
  SampleOrigin origin = SampleOrigin::sdo;
};

struct VectorResult {
  // The vector (copied so that a report needs nothing else).
  std::string id;
  std::string family;  // first two id components: "cia301/sdo"
  std::string title;
  std::vector<std::string> sources;
  Level level = Level::must;
  std::string file;  // vector file, repo-relative, and its line
  std::size_t line = 0;

  Verdict verdict = Verdict::pass;
  // fail/error: one-paragraph reason (the first failing check's Expected/Actual);
  // not_applicable: which feature is missing; deviation: the deviation's description.
  std::string message;
  std::string deviation_id;      // deviation: the profile's deviation id
  std::string deviation_source;  // deviation: its citation
  bool warning = false;          // a should/may vector failed and --strict was not given

  std::vector<Check> checks;
  // The frames of the vector; a long one keeps its first and last frames only (the run's
  // candump trace, --trace, has every frame): frames_elided frames were left out after
  // frames[frames_elided_at - 1].
  std::vector<EvidenceFrame> frames;
  std::size_t frames_elided = 0;
  std::size_t frames_elided_at = 0;
  // Frames that arrived between the previous vector's end and this vector's setup (e.g. a late
  // answer to the vector before): shown with this vector, marked, never as its evidence.
  std::vector<EvidenceFrame> between_vectors;
  // EtherCAT (--bus ethercat:...): the datagrams of the vector, from its setup on; a long one
  // keeps its first and last entries (the run's --pcap has every frame): datagrams_elided
  // entries were left out after datagrams[datagrams_elided_at - 1]. Empty on CAN.
  std::vector<EvidenceDatagram> datagrams;
  std::size_t datagrams_elided = 0;
  std::size_t datagrams_elided_at = 0;
  std::vector<Timing> timings;
  // Samples in time order per signal; a long vector's samples are thinned by time
  // (conformance/samples.hpp): samples_elided were left out, never a bit edge.
  std::vector<Sample> samples;
  std::size_t samples_elided = 0;
  can::TimePoint started{};
  can::TimePoint finished{};
  double wall_seconds = 0.0;
};

// The device under test, as read from it at the start of the run (absent: not readable).
struct DutIdentity {
  std::optional<std::uint32_t> device_type;     // 1000h
  std::optional<std::string> device_name;       // 1008h
  std::optional<std::string> hardware_version;  // 1009h
  std::optional<std::string> software_version;  // 100Ah
  std::optional<std::uint32_t> vendor_id;       // 1018h sub 1..4
  std::optional<std::uint32_t> product_code;
  std::optional<std::uint32_t> revision;
  std::optional<std::uint32_t> serial;
};

// The identity the ESI (ETG.2000 EtherCATInfo) gives the device a run was matched to:
// Vendor/Id, Device/Type@ProductCode, @RevisionNo and Device/Name.
struct EsiDeviceIdentity {
  std::uint32_t vendor_id = 0;
  std::uint32_t product_code = 0;
  std::uint32_t revision = 0;
  std::string name;
  int line = 0;  // the <Device> element's line in the ESI (0: not known, e.g. read back)
};

// A document that vectors cite (vectors/manuals.yaml): a drive manual by its file name, or a
// standard ("CiA 301", "CiA 402-2") whose clause numbers the citations use. A citation
// "<key> §<section> ..." refers to the document whose key it starts with.
struct CitedDocument {
  std::string key;      // "000_33c1d912b8b6010a.txt", "CiA 301"
  std::string title;    // "Festo CMMP-AS-...-M3/-M0: Description, Device profile CiA 402 ..."
  std::string edition;  // "8046795 1510b", "v4.2.0 (2011-02-21)"
};

struct RunInfo {
  std::string tool_version;  // drivecheck's version
  // The drivecheck revision it was built from (`git describe --always --dirty` at build time;
  // the version when not built from a git checkout).
  std::string revision;
  // sha256 of the vector set: every vector file and drive profile loaded, order-independent
  // (conformance/vector_digest.hpp says exactly how). Two reports with the same digest ran the
  // same suite.
  std::string vector_digest;
  std::size_t vector_files = 0;  // how many files the digest covers
  std::vector<CitedDocument> documents;
  std::string started_utc;  // ISO 8601, e.g. 2026-11-21T08:30:00Z
  std::string bus;          // "sim" or "socketcan:can0"
  int node = 0;
  std::string profile_name;  // e.g. "festo-cmmp"
  // Why this profile: "--profile festo-cmmp", "embedded default (--bus sim without --profile)",
  // "1000h = 00020192h: device profile 402, a CiA 402 drive (no --profile)".
  std::string profile_choice;
  std::string profile_title;
  std::string profile_file;
  // The profile's commissioning, one line each: first the vectors it applies to, then each
  // write ("6094h sub 1 := 15 (4 bytes): why [source; source]"). Empty: none.
  std::vector<std::string> commissioning;
  std::string eds_file;    // "" when none
  std::string eds_sha256;  // "" when none
  // The EDS's reader and lint findings (an EDS with errors is refused, so warnings), one line
  // each as `drivecheck eds lint` prints them: "file:line: warning: message [id]". Empty: none.
  std::vector<std::string> eds_findings;
  // The ESI (`--esi`, EtherCAT): its file and sha256 ("" when none), as the EDS ones, and the
  // ESI device the slave was matched to (by the SII's product code and revision), once.
  std::string esi_file;
  std::string esi_sha256;
  std::optional<EsiDeviceIdentity> esi_device;
  std::string personality;              // embedded default: the personality the drive took
  std::vector<std::string> deviations;  // embedded default: deviations injected into the drive
  std::uint64_t seed = 0;
  // The order the vectors ran in (conformance/vector_order.hpp): "file", "reverse",
  // "shuffle:SEED".
  std::string order = "file";
  bool strict = false;
  bool allow_motion = false;
  bool allow_factory_restore = false;  // --allow-factory-restore (a real bus needs it)
  std::string filter;
  DutIdentity dut;
  // What the DUT has, probed once at the start of the run (conformance/capabilities.hpp): one
  // line per feature of the profile's `detect:` and per object need of the selected vectors,
  // "heartbeat.producer: present (1017h read 0 ms, written back)". Empty: nothing probed.
  std::vector<std::string> capabilities;
};

// How a vector counts, the one definition every output uses (console, JUnit, HTML, JSON,
// report diff): each vector is in exactly one tally. A should/may failure without --strict is a
// `warning`, not a `fail`; an interrupted vector is neither passed nor failed.
enum class Tally : std::uint8_t {
  pass,
  fail,
  warning,
  deviation,
  not_applicable,
  error,
  interrupted
};
inline constexpr std::size_t kTallyCount = 7;

constexpr std::string_view to_string(Tally tally) {
  constexpr std::array<std::string_view, kTallyCount> kNames{
      "pass", "fail", "warning", "deviation", "not-applicable", "error", "interrupted"};
  return kNames[static_cast<std::size_t>(tally)];
}

constexpr Tally tally_of(Verdict verdict, bool warning) {
  switch (verdict) {
    case Verdict::pass:
      return Tally::pass;
    case Verdict::fail:
      return warning ? Tally::warning : Tally::fail;
    case Verdict::deviation:
      return Tally::deviation;
    case Verdict::not_applicable:
      return Tally::not_applicable;
    case Verdict::error:
      return Tally::error;
    case Verdict::interrupted:
      return Tally::interrupted;
  }
  return Tally::error;
}

struct VerdictCounts {
  std::array<std::size_t, kTallyCount> by_tally{};
  void add(Verdict verdict, bool warning) {
    ++by_tally[static_cast<std::size_t>(tally_of(verdict, warning))];
  }
  // Every vector, interrupted ones included.
  std::size_t total() const {
    std::size_t sum = 0;
    for (auto n : by_tally)
      sum += n;
    return sum;
  }
  std::size_t operator[](Tally tally) const { return by_tally[static_cast<std::size_t>(tally)]; }
};

struct RunResult {
  RunInfo info;
  std::vector<VectorResult> vectors;  // in run order
  bool interrupted = false;           // Ctrl-C: the vectors finished so far
  bool dut_lost = false;              // the DUT stopped answering (exit 3)
  can::Duration simulated{};          // bus time covered
  double wall_seconds = 0.0;
  // What the harness changed on the DUT outside the vectors and whether it put it back (on a
  // real bus: 1016h sub 1 consuming the harness heartbeat), one sentence each.
  std::vector<std::string> harness_notes;

  VerdictCounts counts() const {
    VerdictCounts counts;
    for (const auto& vector : vectors)
      counts.add(vector.verdict, vector.warning);
    return counts;
  }
};

// Exit code of `drivecheck run` (DESIGN.md): 0 every required vector passes (or is a
// documented deviation / not applicable / a warning), 1 some fail, 3 the DUT stopped answering,
// 130 interrupted. Harness errors count as failures (exit 1): nothing was shown to pass.
inline int exit_code(const RunResult& result) {
  if (result.interrupted) return 130;
  if (result.dut_lost) return 3;
  const auto counts = result.counts();
  return counts[Tally::fail] + counts[Tally::error] > 0 ? 1 : 0;
}

}  // namespace drivecheck::conformance
