// The live fuzzer over EtherCAT: mailbox and CoE cases (ethercat_cases.hpp) sent to slave 0 of
// a segment through the master's raw mailbox access (ethercat::MasterMailbox::send_raw), each
// judged by a liveness oracle.
//
// Per case: the slave is taken to the case's AL state (Master::request_state; the process data
// cycle runs every cycle_period in SAFEOP/OP, so the SM watchdog stays fed), the steps are
// written into SM0 one by one, and after each step the read mailbox (SM1) is polled for the
// replies (reply_wait after the last one; for a step that a repeat follows, until its reply or
// the mailbox timeout). Then the oracle, in this order:
//   1. SM1 drained; for `observation` the cycle runs (SAFEOP/OP) or time passes (PREOP);
//      every cycle's LRW working counter must be the expected one (Master::cycle);
//   2. AL status (0130h) and AL status code (0134h): the state the slave was in, no error
//      indication; an error indication must carry a code (ETG.1000.6 AL status code);
//   3. a CoE SDO abort (closing any transfer the case left open; the server answers none),
//      then an SDO upload of 1000h, which must return 4 octets (retried once after draining
//      SM1, so that a late reply of the case is not taken for the answer).
// Also during the steps: a request sent again with the same counter (CounterMode::repeat)
// after its first copy was answered must not be executed again: no new SDO reply may come for
// it (ETG.1000.4 mailbox counter; a repeated reply, the same counter, is dropped as a
// duplicate by the master and is fine).
//
// Anomalies (EthercatAnomalyKind, most specific first):
//   device-silent             frames do not come back (MasterErrc::no_response, link errors)
//   working-counter           the cyclic LRW's working counter is wrong in SAFEOP/OP
//   al-state-lost             the slave left the case's AL state (with or without error)
//   al-error-without-code     error indication set (0130h bit 4) with AL status code 0000h
//   al-error                  error indication set with a code (the case's state kept)
//   mailbox-repeat-executed   a repeated request (same counter) produced a new SDO reply
//   coe-no-answer             the SDO upload of 1000h got no reply (mailbox timeout, SM0 full)
//   coe-ping-refused          it got an abort, a mailbox error or not 4 octets
// After an anomaly the harness acknowledges the error and takes the slave back to PREOP (the
// next case goes on from there); when that fails the device is reset (Target::power_cycle) or,
// if it cannot be, the run ends with device_lost.
//
// Reproducers: each anomaly (up to max_logs) is written to out_dir as
// `anomaly-<n>-<kind>.pcap` (every frame of the case: the state request, the steps, the
// polls and the oracle, LINKTYPE_ETHERNET, protocol/ethercat/pcap.hpp) and
// `anomaly-<n>-<kind>.txt` (the steps, one line each, describe_step). The first of each kind
// is minimised by delta debugging over the steps (minimiser.hpp), each try against a fresh
// device (Target::power_cycle; skipped with a note when the target cannot), into
// `.min.pcap`/`.min.txt`.
//
// Time: everything runs on the link's clock (simulated on ethercat:sim: the same seed gives
// the same run; real on a RawLink). `duration` is a hard bound on the case loop: no case starts
// after it, and a case that is running then is not judged; the last wait ends within one
// master timeout (MasterConfig: mailbox 1 s by default) past it.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fuzz/live/ethercat_cases.hpp"
#include "fuzz/live/tap_link.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/ethercat/master.hpp"

namespace drivecheck::fuzz_live {

enum class EthercatAnomalyKind : std::uint8_t {
  device_silent,
  working_counter,
  al_state_lost,
  al_error_without_code,
  al_error,
  mailbox_repeat_executed,
  coe_no_answer,
  coe_ping_refused,
};
std::string_view to_string(EthercatAnomalyKind kind);

struct EthercatAnomaly {
  EthercatAnomalyKind kind = EthercatAnomalyKind::device_silent;
  std::string detail;
};

// The device side: a master on a TapLink over the link to the slave(s).
class EthercatTarget {
 public:
  virtual ~EthercatTarget() = default;
  // The master, brought up to PREOP (slave 0 is the device under test).
  virtual ethercat::Master& master() = 0;
  // The link the master runs on (TapLink: the fuzzer sets its tap).
  virtual TapLink& link() = 0;
  // A fresh device and master, brought up to PREOP (simulation); false when impossible.
  virtual bool power_cycle() = 0;
  virtual std::string interface_name() const = 0;
};

struct EthercatFuzzerOptions {
  std::uint64_t seed = 1;
  ethercat::Duration duration = std::chrono::seconds(60);
  std::uint64_t max_cases = 0;  // 0: until duration
  bool allow_motion = false;
  std::vector<FuzzObject> objects;
  ethercat::Duration cycle_period = std::chrono::milliseconds(1);
  ethercat::Duration reply_wait = std::chrono::milliseconds(5);
  ethercat::Duration observation = std::chrono::milliseconds(20);
  bool minimise = true;
  std::size_t max_minimise_tries = 100;
  std::size_t max_logs = 20;
  std::filesystem::path out_dir;                   // empty: nothing written
  std::function<void(std::string_view)> progress;  // one line per event
  const std::atomic<bool>* interrupted = nullptr;
};

struct EthercatAnomalyRecord {
  std::uint64_t case_number = 0;
  std::string case_kind;
  std::string state;  // the case's AL state
  EthercatAnomaly anomaly;
  std::vector<std::string> steps;  // describe_step of each step
  std::filesystem::path pcap;      // empty: not written
  std::filesystem::path text;
  bool minimised = false;
  std::vector<std::string> minimised_steps;
  std::size_t minimisation_tries = 0;
  std::filesystem::path minimised_pcap;
  std::filesystem::path minimised_text;
  std::string minimisation_note;
};

enum class EthercatFuzzOutcome : std::uint8_t {
  clean,
  anomalies,
  device_lost_at_start,
  interrupted
};
std::string_view to_string(EthercatFuzzOutcome outcome);

struct EthercatFuzzSummary {
  EthercatFuzzOutcome outcome = EthercatFuzzOutcome::clean;
  std::uint64_t cases_run = 0;
  ethercat::Duration elapsed{0};
  std::map<std::string, std::uint64_t> cases_by_kind;
  std::map<std::string, std::uint64_t> cases_by_state;
  std::map<std::string, std::uint64_t> anomalies_by_kind;
  std::vector<EthercatAnomalyRecord> anomalies;
  std::uint64_t emergencies = 0;     // CoE emergencies read
  std::uint64_t mailbox_errors = 0;  // ERR replies read
  std::uint32_t device_type = 0;     // 1000h at the start
  std::vector<std::string> states;   // the AL states cases ran in
  bool device_lost = false;
  std::vector<std::string> notes;
};

EthercatFuzzSummary run_ethercat_fuzzer(EthercatTarget& target,
                                        const EthercatFuzzerOptions& options);

std::optional<EthercatAnomalyKind> ethercat_anomaly_kind_from_string(std::string_view text);

// A text reproducer (anomaly-<n>-<kind>[.min].txt) read back: the case (its AL state from the
// "# case" line, one step per line) and the anomaly its header names. Errors name file:line.
struct EthercatReproducer {
  EthercatCase c;
  std::optional<EthercatAnomalyKind> anomaly;
};
Expected<EthercatReproducer, std::string> parse_ethercat_reproducer(std::string_view text,
                                                                    const std::string& name);

struct EthercatReplayResult {
  bool device_answered = false;  // the SDO upload of 1000h answered before the replay
  std::optional<EthercatAnomaly> anomaly;
  std::vector<std::string> notes;
};
// Runs the case once against the target (state, steps, oracle) as the fuzzer does.
EthercatReplayResult replay_ethercat_case(EthercatTarget& target, const EthercatCase& c,
                                          const EthercatFuzzerOptions& options);

}  // namespace drivecheck::fuzz_live
