// The live-bus fuzzer (`drivecheck fuzz`): cases from the CaseGenerator sent to a node on a
// Bus, the LivenessOracle after each, every anomaly saved as a candump -L log and minimised
// by replaying subsequences (minimiser.hpp) against a fresh device.
//
// Per case:
//   1. the case's frames, each followed by its gap (case_generator.hpp)   -> log, flag T
//   2. 20 ms settle; if the case can have changed the communication state (NMT, 1xxxh
//      writes): NMT reset communication (82h N) and up to boot_timeout for the boot-up
//   3. observation window (liveness_oracle.hpp): SDO abort 08000000h (closes whatever
//      transfer the case left open), SDO ping = read 1000h (two tries of sdo_timeout),
//      a guarding request if the node answered one at start
//   4. CiA 402 drives: 6041h read; Operation Enabled without --allow-motion is stopped at once
//      (quick stop, then disable voltage) and noted
// Housekeeping frames (2-4) are not part of the case and not in its log as T frames; the
// device's answers to everything are (flag R), at most kMaxLogRecords per log.
//
// Reproducers: `anomaly-<n>-<kind>.log` (the case) and, for the first anomaly of each kind,
// `anomaly-<n>-<kind>.min.log` (the minimised case, re-run once more so that it holds the
// device's answers too). Their header names the anomaly:
//   # anomaly: sdo-no-answer: no SDO answer to reading 1000h; ...
// replay_reproducer() sends the T frames again with their original relative timing to a
// fresh device and runs steps 2-3.
//
// Fresh device: Target::power_cycle() (the simulated bus: a new drive); a target that cannot
// power-cycle (a real bus) is recovered by NMT reset node and an SDO ping; if that fails the
// device is lost: minimisation is skipped with a note, and fuzzing ends.
//
// Duration: LiveFuzzerOptions::duration is a hard bound. It counts bus time from the start
// (the device probe included); from the first case on, every wait (case gaps, settle, boot-up,
// observation window, SDO answers, minimisation, recovery) ends at the end of the run at the
// latest, so a device whose waits are long (a case set 1017h to FFFFh and reset communication
// keeps it) cannot stretch the run. A case cut short is not judged (a note says so); a
// minimisation cut short keeps its note. Only the drive's final safe stop (below) may go past
// the end: two SDO writes, each at most sdo_timeout when the drive does not answer.
//
// Safety: the generator's rules (case_generator.hpp), a CiA 402 drive found in Operation
// Enabled is stopped before fuzzing, and at the end, on interruption and on a lost device the
// drive gets quick stop (6040h := 0002h, waited for as conformance/setup.cpp does) and then
// disable voltage (6040h := 0000h).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz/live/case_generator.hpp"
#include "fuzz/live/liveness_oracle.hpp"
#include "protocol/can/bus.hpp"
#include "protocol/can/candump_log.hpp"

namespace drivecheck::fuzz_live {

// Where the device under test is.
class Target {
 public:
  virtual ~Target() = default;
  // The harness's port (valid until the next power_cycle()).
  virtual can::Bus& port() = 0;
  // Replaces the device by a freshly powered-on one. false: this target cannot (a real bus).
  virtual bool power_cycle() = 0;
  // Interface name for the candump logs ("sim", "can0").
  virtual std::string interface_name() const = 0;
};

struct LiveFuzzerOptions {
  std::uint8_t node = 1;
  std::uint64_t seed = 1;
  can::Duration duration = std::chrono::seconds(60);  // bus time, a hard bound (see above)
  std::uint64_t max_cases = 0;                        // 0: until the duration is over
  bool allow_motion = false;
  // Whether the device is a CiA 402 drive (safety stop); nullopt: 1000h bits 0..15 = 402.
  std::optional<bool> cia402;
  std::vector<FuzzObject> objects;  // empty: built-in CiA 301 objects that answer a read
  double babble_limit = 2000.0;     // frames/s from the node
  can::Duration sdo_timeout = std::chrono::milliseconds(100);
  can::Duration boot_timeout = std::chrono::seconds(2);
  bool minimise = true;
  std::size_t max_minimise_tries = 200;
  std::size_t max_logs = 20;                       // anomaly logs written (all are counted)
  std::filesystem::path out_dir;                   // where logs go; empty: none written
  std::function<void(std::string_view)> progress;  // one line per event
  const std::atomic<bool>* interrupted = nullptr;  // set from a signal handler
};

enum class FuzzOutcome : std::uint8_t { clean, anomalies, device_lost_at_start, interrupted };
std::string_view to_string(FuzzOutcome outcome);

struct AnomalyRecord {
  std::uint64_t case_number = 0;
  std::string case_kind;
  Anomaly anomaly;
  std::size_t case_frames = 0;  // harness frames of the case
  std::filesystem::path log;    // empty: not written (max_logs)
  bool minimised = false;
  std::size_t minimised_frames = 0;
  std::size_t minimisation_tries = 0;
  std::filesystem::path minimised_log;
  std::string minimisation_note;       // why not minimised, or a caveat
  std::vector<can::Frame> reproducer;  // the minimised harness frames
};

struct FuzzSummary {
  FuzzOutcome outcome = FuzzOutcome::clean;
  std::uint64_t cases_run = 0;
  can::Duration elapsed{0};
  std::map<std::string, std::uint64_t> cases_by_kind;
  std::map<std::string, std::uint64_t> anomalies_by_kind;
  std::vector<AnomalyRecord> anomalies;  // the first of each kind minimised
  std::uint64_t emcy_frames = 0;
  std::uint32_t device_type = 0;
  bool cia402 = false;
  can::Duration heartbeat_period{0};
  bool guarding = false;
  std::size_t objects = 0;
  bool device_lost = false;  // during the run (after the start)
  std::vector<std::string> notes;
};

FuzzSummary run_live_fuzzer(Target& target, const LiveFuzzerOptions& options);

struct ReplayResult {
  bool device_answered = false;  // the device answered the SDO ping before the replay
  std::size_t frames_sent = 0;
  std::optional<Anomaly> anomaly;
  std::vector<std::string> notes;
};

// Sends the T frames of `records` (a reproducer) with their relative timing to a fresh
// device and runs the oracle.
ReplayResult replay_reproducer(Target& target, const std::vector<can::LogRecord>& records,
                               const LiveFuzzerOptions& options);

// The anomaly a reproducer's header names ("# anomaly: KIND: ..."), if any.
std::optional<AnomalyKind> reproducer_anomaly(std::string_view log_text);

}  // namespace drivecheck::fuzz_live
