// Internal to the engine: the state of one vector while it runs, and the step implementations,
// split by concern:
//   evidence.cpp      receiving, sending, recording frames/samples/checks, durations
//   sdo_steps.cpp     SDO transfers and the stimuli (send, nmt, sdo_*, wait, controlword,
//                     simulate, mark)
//   expectations.cpp  frame matching and the expect_* / poll / measure / periodic steps
//   setup.cpp         setup (reset, NMT state, CiA 402 state walk) and teardown
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <system_error>
#include <vector>

#include "conformance/dut_port.hpp"
#include "conformance/engine.hpp"
#include "conformance/isolation.hpp"
#include "conformance/pdo_tracker.hpp"
#include "conformance/result.hpp"
#include "conformance/vector.hpp"
#include "protocol/can/bus.hpp"
#include "protocol/cia301/dissector.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::conformance {

// A change a vector made that the engine could not undo (isolation.hpp): it stands until a
// later read shows the value before again (e.g. after a reset) or a later write puts it back.
struct Leak {
  ObjectRef ref;
  Bytes expected;                     // the value before the vector
  std::optional<Bytes> actual;        // what the object held when the restore failed
  std::optional<std::uint8_t> store;  // the vector stored it (1010h sub n): stored too
  std::string vector_id;
  std::string describe() const;  // "1017h sub 0 still holds C8 00 (was 00 00) from vector X"
};

// What every vector of a run shares.
struct EngineContext {
  can::Bus& bus;
  DutPort& port;  // the services (SDO) of the DUT: CAN, or CoE through an EtherCAT master
  const profile::DriveProfile& profile;
  EngineOptions& options;
  cia301::Dissector& dissector;
  const std::atomic<bool>& interrupted;
  const std::atomic<bool>& stalled;      // the simulation stopped making progress
  std::atomic<std::uint64_t>& progress;  // counts every return from the bus
  PdoTracker& pdo;                       // the DUT's PDOs: decoded into samples in pump()
  // When the engine last sent an NMT frame, and whether a `send:` step sent it, for
  // $timing.nmt_spacing (VectorRun::send_nmt).
  std::optional<can::TimePoint> last_nmt;
  bool last_nmt_raw = false;
  // `$dut.<name>` values found on the DUT in this run (device_values.hpp).
  std::map<std::string, std::int64_t> device_values;
  // Isolation (isolation.hpp): the leaks that stand, and the harness notes of the run so far
  // (Engine::run moves them into RunResult::harness_notes).
  std::map<ObjectRef, Leak> leaks;
  std::vector<std::string> notes;
  // Real bus with motion: the 1016h sub 1 entry that makes the DUT consume the harness
  // heartbeat (Engine::prepare_motion). A reset puts 1016h back to its stored value, so every
  // motion vector's setup writes it again before the drive may move (VectorRun::setup).
  std::optional<std::vector<std::uint8_t>> harness_consumer;
};

// not_applicable: a value the vector takes from the device does not exist on it
// (device_values.hpp); the message says why.
enum class StepStatus : std::uint8_t { ok, failed, harness_error, not_applicable };

// Whether the action is one of the EtherCAT-only steps (ethercat_steps.cpp).
bool is_ethercat_step(const Action& action);

// With `abort:`, a frame that matched the main pattern but carries an abort code outside the
// set: that code (the step fails with it); nullopt when the frame meets the expectation. Both
// expect_frame and expect_sdo_response (on either link) judge a matched frame by it.
std::optional<std::uint32_t> refused_abort(const ExpectFrameStep& e, const can::Frame& frame,
                                           std::uint8_t node);

class VectorRun {
 public:
  VectorRun(EngineContext& context, const Vector& vector, VectorResult& result);
  ~VectorRun();
  VectorRun(const VectorRun&) = delete;
  VectorRun& operator=(const VectorRun&) = delete;

  // ---- evidence.cpp ----
  // Receives one frame from another node (recording it), or nullopt at `deadline` (clipped to
  // the vector's deadline). Own echoes are recorded and skipped.
  std::optional<can::TimedFrame> pump(can::TimePoint deadline);
  // Takes every frame already due off the port (recording it).
  void drain();
  void wait_until(can::TimePoint deadline);
  std::error_code send(const can::Frame& frame);
  // An NMT frame (COB-ID 000h): sent no sooner than $timing.nmt_spacing after the previous NMT
  // frame, except a `send:` step's (`raw`) right after another `send:` step's: a vector may
  // send a burst on purpose.
  std::error_code send_nmt(const can::Frame& frame, bool raw = false);
  void sample(std::uint16_t index, std::uint8_t sub, std::span<const std::uint8_t> data);
  void check(std::string action, std::string expected, std::string actual, bool ok);
  can::Duration resolve(const DurationSpec& spec) const;
  can::TimePoint now() const { return context_.bus.now(); }
  can::TimePoint deadline() const { return deadline_; }
  bool vector_timed_out() const { return now() >= deadline_ || context_.stalled.load(); }
  std::uint8_t node() const { return context_.options.node; }
  // The last frames from other nodes, for Actual: texts ("585#..., 701#05").
  std::string recent_frames(std::size_t from_index, std::size_t max = 4) const;
  // The YAML line of the current step (in `steps:` or `finally:`), else the vector's.
  std::size_t step_line() const;
  // Fails with `expected`/`actual` (sets the failure message).
  // `observed`: what the DUT did, typed (result.hpp), for a deviation's `observed:`.
  StepStatus fail(std::string action, std::string expected, std::string actual,
                  Observation observed = {});
  StepStatus harness_error(std::string action, std::string message);
  // A timing check failed: when the harness was late in this vector (harness_late() says
  // why), the check is not charged to the device: `error: harness late` (a harness error);
  // otherwise fail(). FORMAT.md "Timing".
  StepStatus fail_timed(std::string action, std::string expected, std::string actual,
                        Observation observed = {});
  // Why the harness was late in this vector so far ("" = it never was): a `send:` frame or a
  // poll that went out later than the step asked by more than $timing.harness_slack, or a
  // wait that ended that much late.
  const std::string& harness_late() const { return harness_late_; }
  void note_harness_late(std::string why);
  // The longest stall of the harness's machine since this vector started (EngineOptions::
  // stalls), described; nullopt when it did not stall (or nothing watches).
  std::optional<std::string> stall_in_vector() const;
  // The loopback echo of one of the harness's frames (its wire time) came in.
  void on_echo(can::TimePoint at);

  // ---- sdo_steps.cpp ----
  // block_size: the blksize a block upload offers (0 = the client's default).
  SdoOutcome sdo_upload(cia301::Multiplexer mux, Transfer transfer = Transfer::automatic,
                        std::uint8_t block_size = 0);
  // `timeout`: the response time allowed (default $timing.sdo_response).
  SdoOutcome sdo_download(cia301::Multiplexer mux, std::span<const std::uint8_t> data,
                          Transfer transfer = Transfer::automatic,
                          std::optional<can::Duration> timeout = std::nullopt);
  StepStatus run_stimulus(const Step& step);
  // ---- cyclic_steps.cpp ----
  // `cyclic`: the cyclic modes' set-points and synchronisation on either link.
  StepStatus run_cyclic(const Step& step, const CyclicStep& cyclic);

  // ---- expectations.cpp ----
  StepStatus run_expectation(const Step& step);
  // An expect_frame (also the CAN form of expect_sdo_response), reported under `name`.
  StepStatus expect_frame(const ExpectFrameStep& e, const std::string& name);
  // A 402 state or statusword pattern polled through 6041h until `deadline`.
  StepStatus poll_statusword(std::string action, std::uint16_t mask, std::uint16_t value,
                             std::string expected, can::TimePoint deadline);

  // ---- raw_sdo_steps.cpp: sdo_request / expect_sdo_response on EtherCAT (CoE) ----
  // The 8 octets as a CoE SDO request in the write mailbox (isolation learns a download from
  // them as on CAN from the frame).
  StepStatus send_coe_sdo_request(const SendStep& request, const std::string& name);
  // A CoE SDO response whose first 8 octets after the CoE header match `e`'s pattern (or an
  // `or:` one), by the CAN frame 580h+N they would be: the same matcher and abort judgement.
  StepStatus expect_coe_sdo_response(const ExpectFrameStep& e, const std::string& name);

  // ---- ethercat_steps.cpp ----
  // The EtherCAT-only steps (is_ethercat_step), through the EtherCAT DUT port.
  StepStatus run_ethercat_step(const Step& step);
  // expect_emcy on EtherCAT: a CoE emergency the port took from the master at or after `base`
  // (the step's start, or the request before it) or the `since:` mark, within `within:`.
  StepStatus expect_coe_emergency(const ExpectEmcyStep& step, can::TimePoint base);

  // ---- device_values.cpp ----
  // Finds the `$dut.<name>` values the vector's steps use (once per run) and saves them.
  StepStatus resolve_device_values();

  // ---- setup.cpp ----
  StepStatus setup();
  // setup() on a link without NMT frames (DutPort::reset, DutPort::enter_state).
  // The profile's commissioning writes, when they apply to this vector (part of setup()).
  StepStatus commission();
  StepStatus consume_harness_heartbeat();  // 1016h sub 1 := context_.harness_consumer
  void teardown();

  // ---- isolation (setup.cpp) ----
  // Before the steps: re-checks the standing leaks (cleared when the value before is back, or
  // when writing it back now succeeds), then reads the objects the vector may change.
  void check_leaks();
  void take_snapshot();
  // `finally:` steps, with their own time budget; a failure is a harness note.
  void run_finally();
  // After teardown: puts back what the vector changed (and stored); a failure is a leak.
  void restore();
  // The leaks that stood while this vector ran ("" when none): a failure becomes an error.
  const std::string& standing_leaks() const { return standing_leaks_; }

  // Runs the whole vector: setup, steps, teardown; returns the outcome and message.
  StepStatus run_steps();

  const std::string& message() const { return message_; }
  // Setup got through: the steps began (`finally:` runs only then).
  bool steps_started() const { return steps_started_; }
  bool dut_spoke() const { return dut_frames_ > 0; }
  // A DUT port that carries no CAN frames (EtherCAT) counts the DUT's answers here.
  void note_dut_answer() { ++dut_frames_; }
  // Isolation (isolation.hpp) on every link: an SDO download the harness asked for (`size`:
  // its length when the DUT gets the value whole, expedited on CAN, any CoE download), and one
  // the DUT confirmed. On CAN pump() calls these from the frames (a `send:` step's raw SDO
  // included); a DUT port without CAN frames (EtherCAT) calls them for each download it makes.
  // Noted only while the vector's writes are tracked (snapshot to restore).
  void note_download_request(cia301::Multiplexer mux, std::optional<std::size_t> size);
  void note_confirmed_download(cia301::Multiplexer mux);
  std::size_t current_step() const { return step_index_; }
  // The current step's number (0: not in `steps:`), its repeats' passes, and both as messages
  // name them: "step 19 (iteration 117 of 254)", "setup".
  std::size_t current_number() const;
  std::vector<Iteration> current_iterations() const;
  std::string current_place() const;

 private:
  struct Mark {
    can::TimePoint at{};
    std::size_t index = 0;  // first frame index after the mark
  };
  StepStatus write_controlword(std::uint16_t value, std::string action);
  StepStatus reach_drive_state(cia402::State target);
  // Sends `command` and confirms the NMT state it asks for (FORMAT.md "Setup"): by the
  // heartbeat's state byte when the DUT produces one, else by behaviour.
  StepStatus reach_nmt_state(cia301::NmtState target);
  void note(std::string text);
  // An SDO download of a value read back, shortened when the DUT refuses its zero padding.
  SdoOutcome write_back(cia301::Multiplexer mux, Bytes& data);
  StepStatus await_bootup(std::string action);
  std::size_t watch_start(const std::string& since) const;
  // The time a watching expectation measures `within:` from when it has no `since:`: the
  // later of the step's start and the wire time (loopback echo) of the harness's latest
  // frame, waiting for that echo first (up to $timing.response) when it is not in yet.
  can::TimePoint request_time();
  std::optional<std::size_t> watch(std::size_t from, can::TimePoint deadline,
                                   const std::function<bool(const can::Frame&)>& match);
  void set_mark(const std::string& name, can::TimePoint at, std::size_t index);
  std::optional<std::int64_t> value_of(const ValueSpec& spec, std::string& error) const;
  std::size_t object_size(std::uint16_t index, std::uint8_t sub) const;

  EngineContext& context_;
  const Vector& vector_;
  VectorResult& result_;
  VectorResult* previous_evidence_sink_ = nullptr;  // the DUT port's sink before this run
  can::TimePoint deadline_ = can::kForever;
  std::vector<can::TimedFrame> received_;  // frames from other nodes, in order
  std::size_t dut_frames_ = 0;
  std::map<std::string, Mark> marks_;
  std::map<std::string, std::int64_t> saved_;
  std::optional<std::uint16_t> last_statusword_;
  std::optional<can::Duration> heartbeat_time_;  // 1017h as written or read in this vector
  std::size_t step_index_ = 0;
  // Fair timing (FORMAT.md "Timing"): frames are judged by their timestamps, not by when the
  // harness got to read them.
  std::size_t step_from_ = 0;      // received_.size() when the current step began
  can::TimePoint step_started_{};  // bus time when the current step began
  struct PendingEcho {
    std::optional<can::TimePoint> asked;  // a `send:` step's frame: when the step asked for it
    std::string what;
  };
  std::deque<PendingEcho> echoes_;            // own frames sent whose loopback echo is not in yet
  std::optional<can::TimePoint> last_echo_;   // wire time of the harness's latest frame
  std::optional<can::TimePoint> send_asked_;  // set by a `send:` step around its send()
  can::TimePoint last_send_call_{};           // when send() was last called
  bool until_echo_ = false;                   // pump() returns after an echo (request_time)
  std::string harness_late_;
  // Frames an expectation read after its deadline (a late harness) that it did not take: the
  // next step watches them too.
  std::optional<std::size_t> resume_from_;
  std::string action_;  // current step's action
  std::string message_;
  // Isolation: the snapshot, and what the DUT confirmed while the vector's steps ran.
  bool tracking_writes_ = false;
  std::map<ObjectRef, Bytes> snapshot_;
  std::set<ObjectRef> written_;
  // The length of the last expedited download the harness sent to each object: the write back
  // uses it where an upload answered longer (a DUT that pads 1- and 2-byte values to 4).
  std::map<ObjectRef, std::size_t> request_sizes_;
  std::set<std::uint8_t> stored_;   // 1010h sub-indices a confirmed "save" went to
  bool restored_defaults_ = false;  // a confirmed 1011h download
  std::string standing_leaks_;
  bool steps_started_ = false;
};

}  // namespace drivecheck::conformance
