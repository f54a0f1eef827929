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
};
inline constexpr std::size_t kVerdictCount = 5;

constexpr std::string_view to_string(Verdict verdict) {
  constexpr std::array<std::string_view, kVerdictCount> kNames{"pass", "fail", "deviation",
                                                               "not-applicable", "error"};
  return kNames[static_cast<std::size_t>(verdict)];
}
constexpr std::string_view to_string(Level level) {
  constexpr std::array<std::string_view, 3> kNames{"must", "should", "may"};
  return kNames[static_cast<std::size_t>(level)];
}

// One frame on the bus during the vector, as the harness saw it.
struct EvidenceFrame {
  can::TimePoint at{};        // bus time (simulated, or the kernel timestamp)
  can::Frame frame;           // prints as candump via fmt / can::to_candump
  bool from_harness = false;  // sent by the harness (else by the DUT or another node)
  std::string decoded;        // the dissector's one-line meaning
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

// One checked expectation: what the step required and what was seen.
struct Check {
  std::size_t step = 0;  // index into the vector's steps
  std::string action;    // the step's action key, e.g. "expect_frame", "sdo_read"
  std::string expected;  // e.g. "580+5#80416000020001 06 (abort 06010002h)", "one of {...}"
  std::string actual;    // what the DUT did, or "nothing within 100 ms"
  bool ok = false;
  Observation observed;  // failed checks: what the DUT did, typed
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

struct RunInfo {
  std::string tool_version;  // drivecheck's version
  std::string started_utc;   // ISO 8601, e.g. 2026-11-21T08:30:00Z
  std::string bus;           // "sim" or "socketcan:can0"
  int node = 0;
  std::string profile_name;  // e.g. "festo-cmmp"
  std::string profile_title;
  std::string profile_file;
  // The profile's commissioning, one line each: first the vectors it applies to, then each
  // write ("6094h sub 1 := 15 (4 bytes): why [source; source]"). Empty: none.
  std::vector<std::string> commissioning;
  std::string eds_file;                 // "" when none
  std::string eds_sha256;               // "" when none
  std::string personality;              // embedded default: the personality the drive took
  std::vector<std::string> deviations;  // embedded default: deviations injected into the drive
  std::uint64_t seed = 0;
  // The order the vectors ran in (conformance/vector_order.hpp): "file", "reverse",
  // "shuffle:SEED".
  std::string order = "file";
  bool strict = false;
  bool allow_motion = false;
  std::string filter;
  DutIdentity dut;
};

struct VerdictCounts {
  std::array<std::size_t, kVerdictCount> by_verdict{};
  std::size_t warnings = 0;
  std::size_t total() const {
    std::size_t sum = 0;
    for (auto n : by_verdict)
      sum += n;
    return sum;
  }
  std::size_t operator[](Verdict verdict) const {
    return by_verdict[static_cast<std::size_t>(verdict)];
  }
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
    for (const auto& vector : vectors) {
      ++counts.by_verdict[static_cast<std::size_t>(vector.verdict)];
      if (vector.warning) ++counts.warnings;
    }
    return counts;
  }
};

// Exit code of `drivecheck run` (DESIGN.md): 0 every required vector passes (or is a
// documented deviation / not applicable / a warning), 1 some fail, 3 the DUT stopped answering,
// 130 interrupted. Harness errors count as failures (exit 1): nothing was shown to pass.
inline int exit_code(const RunResult& result) {
  if (result.interrupted) return 130;
  if (result.dut_lost) return 3;
  for (const auto& vector : result.vectors) {
    if ((vector.verdict == Verdict::fail && !vector.warning) || vector.verdict == Verdict::error)
      return 1;
  }
  return 0;
}

}  // namespace drivecheck::conformance
