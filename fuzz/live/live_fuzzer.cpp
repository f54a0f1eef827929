#include "fuzz/live/live_fuzzer.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <utility>

#include "fuzz/live/minimiser.hpp"
#include "protocol/cia402/state_machine.hpp"
#include "reports/report_writers.hpp"

namespace drivecheck::fuzz_live {
namespace {

using namespace std::chrono_literals;

constexpr std::uint32_t kNmtId = 0x000;
constexpr std::uint32_t kSdoRequestBase = 0x600;
constexpr std::uint32_t kSdoResponseBase = 0x580;
constexpr std::uint32_t kErrorControlBase = 0x700;
constexpr can::Duration kSettle = 20ms;
constexpr std::size_t kMaxLogRecords = 5000;

// A harness frame of a case with its offset from the case's start.
struct TimedStep {
  can::Frame frame;
  can::Duration offset{};
};

// One harness on one port: sends, receives, keeps the case log, feeds the oracle.
class Harness {
 public:
  Harness(Target& target, const LiveFuzzerOptions& options)
      : target_(target),
        options_(options),
        oracle_(OracleConfig{.node = options.node}),
        segment_start_(target.port().now()) {}

  can::Bus& port() { return target_.port(); }
  can::TimePoint now() { return port().now(); }
  // Interrupted by the user; never while the drive is being put in a safe state, which must
  // wait for its answers whatever happens.
  bool interrupted() const {
    return !safe_stopping_ && options_.interrupted != nullptr && options_.interrupted->load();
  }
  LivenessOracle& oracle() { return oracle_; }
  void configure_oracle(const OracleConfig& config) {
    oracle_ = LivenessOracle(config);
    guarding_at_start_ = config.guarding;
  }

  // Bus time used so far, across power cycles.
  can::Duration elapsed() { return elapsed_ + (now() - segment_start_); }

  // The run's hard end (LiveFuzzerOptions::duration). Once bound() is called, every wait ends
  // at the end of the run at the latest, whatever it waits for (a window of 2.5 periods of a
  // heartbeat a case set to FFFFh, a boot-up that does not come, minimisation). A wait cut
  // short is noted (cut_short()): the case it belongs to is not judged. The drive's safe stop
  // is never cut short.
  void bound() { bounded_ = true; }
  bool out_of_time() { return bounded_ && elapsed() >= options_.duration; }
  bool cut_short() const { return cut_short_; }
  void clear_cut_short() { cut_short_ = false; }
  // A wait's deadline, bounded by the end of the run; `truncated`: the wait would have gone on
  // past the end (it was cut short if it then reaches the deadline without what it waited for).
  struct Limit {
    can::TimePoint deadline;
    bool truncated = false;
  };
  Limit limit(can::TimePoint wanted) {
    if (!bounded_ || safe_stopping_) return {wanted};
    const can::Duration used = elapsed();
    const can::TimePoint end = now() + std::max(can::Duration{0}, options_.duration - used);
    if (wanted <= end) return {wanted};
    return {end, true};
  }
  bool power_cycle() {
    const can::Duration used = now() - segment_start_;
    if (!target_.power_cycle()) return false;
    elapsed_ += used;
    segment_start_ = now();
    return true;
  }

  void start_log() {
    log_.clear();
    log_truncated_ = false;
    recording_ = true;
  }
  void stop_log() { recording_ = false; }
  const std::vector<can::LogRecord>& log() const { return log_; }
  bool log_truncated() const { return log_truncated_; }

  void send(const can::Frame& frame, bool case_frame) {
    const auto error = port().send(frame);
    if (case_frame && recording_ && !error) record(frame, now(), can::TraceDirection::transmit);
  }

  void observe(const can::TimedFrame& frame) {
    if (frame.own) return;
    oracle_.on_frame(frame);
    if (recording_) record(frame.frame, frame.timestamp, can::TraceDirection::receive);
  }

  void pump_until(can::TimePoint wanted) {
    const auto [deadline, truncated] = limit(wanted);
    while (!interrupted()) {
      auto frame = port().receive(deadline);
      if (!frame) {
        cut_short_ = cut_short_ || truncated;
        return;
      }
      observe(*frame);
    }
  }

  // The first frame matching `match` until `deadline`.
  template <typename Match>
  std::optional<can::Frame> wait_for(can::TimePoint wanted, Match match) {
    const auto [deadline, truncated] = limit(wanted);
    while (!interrupted()) {
      auto frame = port().receive(deadline);
      if (!frame) {
        cut_short_ = cut_short_ || truncated;
        return std::nullopt;
      }
      observe(*frame);
      if (!frame->own && match(frame->frame)) return frame->frame;
    }
    return std::nullopt;
  }

  std::optional<can::Frame> sdo(const std::array<std::uint8_t, 8>& request) {
    send(can::Frame::standard(kSdoRequestBase + options_.node, request), false);
    const std::uint32_t response = kSdoResponseBase + options_.node;
    return wait_for(now() + options_.sdo_timeout, [response](const can::Frame& frame) {
      return frame.id == response && !frame.is_remote() && !frame.is_extended() &&
             frame.length() == 8;
    });
  }

  static std::array<std::uint8_t, 8> request(std::uint8_t command, std::uint16_t index,
                                             std::uint8_t sub, std::uint32_t value = 0) {
    return {command,
            static_cast<std::uint8_t>(index),
            static_cast<std::uint8_t>(index >> 8),
            sub,
            static_cast<std::uint8_t>(value),
            static_cast<std::uint8_t>(value >> 8),
            static_cast<std::uint8_t>(value >> 16),
            static_cast<std::uint8_t>(value >> 24)};
  }

  // Expedited upload: the value (up to 4 bytes), nullopt on abort, silence or segmented.
  std::optional<std::uint32_t> read(std::uint16_t index, std::uint8_t sub) {
    auto answer = sdo(request(0x40, index, sub));
    if (!answer || (answer->data[0] & 0xE3) != 0x43) return std::nullopt;
    return static_cast<std::uint32_t>(answer->data[4] | (answer->data[5] << 8) |
                                      (answer->data[6] << 16) |
                                      (static_cast<std::uint32_t>(answer->data[7]) << 24));
  }
  bool write_u16(std::uint16_t index, std::uint8_t sub, std::uint16_t value) {
    auto answer = sdo(request(0x2B, index, sub, value));  // ccs=1 e=1 s=1 n=2
    return answer && answer->data[0] == 0x60;
  }

  // Any SDO answer to reading 1000h: the server is alive.
  bool ping() {
    for (int attempt = 0; attempt < 2 && !interrupted() && !out_of_time(); ++attempt) {
      if (sdo(request(0x40, 0x1000, 0))) return true;
    }
    return false;
  }

  bool guarding_request() {
    const std::uint32_t id = kErrorControlBase + options_.node;
    send(can::Frame::remote(id, 1), false);
    return wait_for(now() + options_.sdo_timeout,
                    [id](const can::Frame& frame) {
                      return frame.id == id && !frame.is_remote() && frame.length() == 1;
                    })
        .has_value();
  }

  void nmt(std::uint8_t command) {
    send(can::Frame::standard(kNmtId, {command, options_.node}), false);
  }

  // NMT reset node and wait for the boot-up and an SDO answer: a device that recovered.
  bool recover() {
    nmt(0x81);
    const std::uint32_t id = kErrorControlBase + options_.node;
    (void)wait_for(now() + options_.boot_timeout, [id](const can::Frame& frame) {
      return frame.id == id && !frame.is_remote() && frame.length() == 1 && frame.data[0] == 0;
    });
    pump_until(now() + 50ms);
    return ping();
  }

  std::optional<std::uint16_t> statusword() {
    auto value = read(0x6041, 0);
    if (!value) return std::nullopt;
    return static_cast<std::uint16_t>(*value);
  }

  // Quick stop, waited for, then disable voltage (conformance/setup.cpp's teardown).
  void safe_stop() {
    safe_stopping_ = true;
    // A stop() from the signal handler ends one wait: let it end this one, not an SDO answer's.
    if (auto frame = port().receive(now())) observe(*frame);
    if (write_u16(0x6040, 0, 0x0002)) {
      const can::TimePoint limit = now() + 10s;
      while (now() < limit) {
        const auto word = statusword();
        if (!word) break;
        const auto state = cia402::decode_statusword(*word);
        if (!state) break;
        if (*state != cia402::State::operation_enabled &&
            *state != cia402::State::quick_stop_active &&
            *state != cia402::State::fault_reaction_active)
          break;
        if (*state == cia402::State::quick_stop_active) {
          const auto velocity = read(0x606C, 0);
          if (!velocity || *velocity == 0) break;
        }
        pump_until(now() + 50ms);
      }
    }
    (void)write_u16(0x6040, 0, 0x0000);
    safe_stopping_ = false;
  }

  bool operation_enabled() {
    const auto word = statusword();
    if (!word) return false;
    const auto state = cia402::decode_statusword(*word);
    return state && *state == cia402::State::operation_enabled;
  }

  // Sends the steps at their offsets, then the settle time.
  void run_steps(const std::vector<TimedStep>& steps, can::Duration tail) {
    const can::TimePoint start = now();
    for (const auto& step : steps) {
      pump_until(start + step.offset);
      send(step.frame, true);
    }
    const can::TimePoint last = steps.empty() ? start : start + steps.back().offset;
    pump_until(std::max(now(), last + tail));
  }

  // Steps 2-4 of the case (see the header) after the case's frames went out.
  std::optional<Anomaly> check(const std::vector<can::Frame>& frames, bool cia402_drive,
                               std::vector<std::string>* notes) {
    pump_until(now() + kSettle);
    if (resets_node(frames, options_.node)) oracle_.expect_boot_up();
    if (needs_communication_reset(frames)) {
      // Back to the communication parameters of power-on and Pre-operational; the oracle
      // judges the boot-up (none: no-boot-up).
      oracle_.expect_boot_up();
      nmt(0x82);
      const std::uint32_t id = kErrorControlBase + options_.node;
      (void)wait_for(now() + options_.boot_timeout, [id](const can::Frame& frame) {
        return frame.id == id && !frame.is_remote() && frame.length() == 1 && frame.data[0] == 0;
      });
      // The reset brought back 1017h's power-on (or stored) value, which may differ from the
      // value at the start of the run.
      if (const auto period = read(0x1017, 0)) {
        const can::Duration heartbeat = std::chrono::milliseconds(*period & 0xFFFF);
        oracle_.set_heartbeat_period(heartbeat, guarding_at_start_ && heartbeat.count() == 0);
      }
    }
    const can::TimePoint start = now();
    oracle_.begin_observation(start);
    // SDO abort, general error (08000000h): closes any transfer the case left open.
    send(can::Frame::standard(kSdoRequestBase + options_.node, request(0x80, 0, 0, 0x08000000)),
         false);
    pump_until(now() + 10ms);
    const bool answered = ping();
    const bool guarded = oracle_.config().guarding ? guarding_request() : true;
    pump_until(std::max(now(), start + oracle_.window()));
    oracle_.end_observation(now(), answered, guarded);
    if (cia402_drive && answered && !options_.allow_motion && operation_enabled()) {
      if (notes != nullptr)
        notes->push_back("the drive was in Operation Enabled after a case: stopped");
      safe_stop();
    }
    return oracle_.verdict();
  }

 private:
  void record(const can::Frame& frame, can::TimePoint at, can::TraceDirection direction) {
    if (log_.size() >= kMaxLogRecords) {
      log_truncated_ = true;
      return;
    }
    log_.push_back(can::LogRecord{can::to_unix_time(at, port().unix_offset()),
                                  target_.interface_name(), frame, direction});
  }

  Target& target_;
  const LiveFuzzerOptions& options_;
  LivenessOracle oracle_;
  can::Duration elapsed_{0};
  can::TimePoint segment_start_{};
  std::vector<can::LogRecord> log_;
  bool log_truncated_ = false;
  bool recording_ = false;
  bool safe_stopping_ = false;
  bool guarding_at_start_ = false;
  bool bounded_ = false;
  bool cut_short_ = false;
};

std::vector<TimedStep> timed_steps(const std::vector<CaseStep>& steps) {
  std::vector<TimedStep> timed;
  can::Duration offset{0};
  for (const auto& step : steps) {
    timed.push_back({step.frame, offset});
    offset += step.delay_after;
  }
  return timed;
}

std::vector<can::Frame> frames_of(const std::vector<TimedStep>& steps) {
  std::vector<can::Frame> frames;
  for (const auto& step : steps)
    frames.push_back(step.frame);
  return frames;
}

// The harness frames (T) of a log, with offsets from the first of them.
std::vector<TimedStep> steps_of(const std::vector<can::LogRecord>& records) {
  std::vector<TimedStep> steps;
  std::optional<std::chrono::nanoseconds> first;
  for (const auto& record : records) {
    if (record.direction != can::TraceDirection::transmit || record.frame.is_error()) continue;
    if (!first) first = record.timestamp;
    steps.push_back({record.frame, std::max(can::Duration{0}, record.timestamp - *first)});
  }
  return steps;
}

std::string log_text(const std::vector<std::string>& header, const Harness& harness) {
  std::string text;
  for (const auto& line : header)
    text += fmt::format("# {}\n", line);
  text +=
      "# T: frames the harness sent (`drivecheck fuzz --replay FILE` sends them again), R: frames "
      "it received\n";
  if (harness.log_truncated())
    text += fmt::format("# (truncated after {} records)\n", kMaxLogRecords);
  for (const auto& record : harness.log())
    text += can::to_candump_log(record) + "\n";
  return text;
}

class Fuzzer {
 public:
  Fuzzer(Target& target, const LiveFuzzerOptions& options)
      : options_(options), harness_(target, options) {}

  void say(const std::string& line) {
    if (options_.progress) options_.progress(line);
  }

  // Reads what the oracle needs; false if the device does not answer.
  bool probe() {
    harness_.pump_until(harness_.now() + 10ms);
    const auto type = harness_.read(0x1000, 0);
    if (!type) return false;
    summary_.device_type = *type;
    summary_.cia402 = options_.cia402.value_or((*type & 0xFFFF) == 402);
    const auto heartbeat = harness_.read(0x1017, 0);
    summary_.heartbeat_period = std::chrono::milliseconds(heartbeat.value_or(0) & 0xFFFF);
    summary_.guarding = summary_.heartbeat_period.count() == 0 && harness_.guarding_request();
    harness_.configure_oracle(OracleConfig{.node = options_.node,
                                           .heartbeat_period = summary_.heartbeat_period,
                                           .guarding = summary_.guarding,
                                           .babble_limit = options_.babble_limit});
    return true;
  }

  // A device in a known state for the next case; false: lost.
  bool fresh_device() {
    if (harness_.power_cycle()) {
      harness_.pump_until(harness_.now() + 10ms);
      return harness_.ping();
    }
    return harness_.recover();
  }

  // The case's verdict; a case the end of the run cut short (Harness::cut_short()) has none.
  std::optional<Anomaly> run_steps(const std::vector<TimedStep>& steps, can::Duration tail) {
    harness_.clear_cut_short();
    harness_.oracle().begin_case(harness_.now());
    harness_.start_log();
    harness_.run_steps(steps, tail);
    auto anomaly = harness_.check(frames_of(steps), summary_.cia402, &summary_.notes);
    harness_.stop_log();
    if (harness_.cut_short()) return std::nullopt;
    return anomaly;
  }

  std::filesystem::path write_log(const std::string& name, const std::vector<std::string>& header) {
    if (options_.out_dir.empty()) return {};
    const auto path = options_.out_dir / name;
    auto done = reports::write_file_atomically(path, log_text(header, harness_));
    if (!done) {
      summary_.notes.push_back(done.error());
      return {};
    }
    return path;
  }

  std::vector<std::string> header(const AnomalyRecord& record, std::string_view what) const {
    return {fmt::format("drivecheck fuzz: case {} ({}), node {}, seed {}{}", record.case_number,
                        record.case_kind, options_.node, options_.seed, what),
            fmt::format("anomaly: {}: {}", to_string(record.anomaly.kind), record.anomaly.detail)};
  }

  void minimise(AnomalyRecord& record, const std::vector<TimedStep>& steps, can::Duration tail) {
    const AnomalyKind kind = record.anomaly.kind;
    bool lost = false;
    std::size_t runs = 0;  // tries that ran (at the end of the run the rest return at once)
    const auto subset = [&](std::span<const std::size_t> indices) {
      std::vector<TimedStep> chosen;
      for (std::size_t i : indices)
        chosen.push_back(steps[i]);
      return chosen;
    };
    const auto result = fuzz_live::minimise(
        steps.size(),
        [&](std::span<const std::size_t> indices) {
          if (lost || harness_.interrupted() || harness_.out_of_time()) return false;
          if (!fresh_device()) {
            lost = true;
            return false;
          }
          ++runs;
          const auto anomaly = run_steps(subset(indices), tail);
          if (harness_.cut_short()) return false;
          return anomaly && anomaly->kind == kind;
        },
        options_.max_minimise_tries);
    record.minimisation_tries = result.tries;
    if (lost) {
      record.minimisation_note =
          "skipped: the device did not recover by NMT reset node (power-cycle it and use "
          "--replay)";
      return;
    }
    if (harness_.interrupted()) {
      record.minimisation_note = "interrupted";
      return;
    }
    if (harness_.out_of_time()) {
      record.minimisation_note =
          fmt::format("stopped at the end of --duration after {} tries", runs);
      return;
    }
    // Once more, so that the minimised log holds the device's answers.
    const auto minimal = subset(result.kept);
    if (!fresh_device()) {
      record.minimisation_note = "skipped: the device did not recover for the final run";
      return;
    }
    const auto again = run_steps(minimal, tail);
    if (harness_.cut_short()) {
      record.minimisation_note = "the final run was cut short by the end of --duration";
      return;
    }
    if (!again || again->kind != kind) {
      record.minimisation_note =
          "the minimised sequence did not reproduce on its final run (flaky)";
      return;
    }
    record.minimised = true;
    record.minimised_frames = minimal.size();
    record.reproducer = frames_of(minimal);
    if (result.budget_exhausted)
      record.minimisation_note = "try budget exhausted: may not be minimal";
    record.minimised_log = write_log(
        fmt::format("anomaly-{}-{}.min.log", summary_.anomalies.size() + 1, to_string(kind)),
        header(record, fmt::format(", minimised from {} to {} frames in {} tries",
                                   record.case_frames, minimal.size(), result.tries)));
  }

  FuzzSummary run() {
    if (!probe()) {
      summary_.outcome = FuzzOutcome::device_lost_at_start;
      summary_.notes.push_back(
          fmt::format("node {} does not answer an SDO read of 1000h", options_.node));
      return std::move(summary_);
    }
    if (summary_.cia402 && !options_.allow_motion && harness_.operation_enabled()) {
      summary_.notes.push_back("the drive was in Operation Enabled at the start: stopped first");
      harness_.safe_stop();
    }
    // From here on the duration is a hard bound (Harness::bound()).
    harness_.bound();
    std::vector<FuzzObject> objects = options_.objects;
    if (objects.empty()) {
      for (const auto& object : builtin_objects()) {
        if (harness_.sdo(Harness::request(0x40, object.index, object.sub)).has_value())
          objects.push_back(object);
      }
    }
    summary_.objects = objects.size();
    // The profile is what 1000h says (CiA 301 §7.5.2.1: bits 0-15 the device profile number);
    // whether the cases treat the node as a CiA 402 drive may have been set otherwise.
    const auto device_profile = summary_.device_type & 0xFFFF;
    std::string profile_text = device_profile == 0 ? std::string("no standard device profile")
                                                   : fmt::format("CiA {}", device_profile);
    if (summary_.cia402 != (device_profile == 402))
      profile_text += summary_.cia402 ? "; fuzzed as a CiA 402 drive" : "; not fuzzed as a drive";
    say(fmt::format(
        "node {}: device type {:08X}h ({}), heartbeat {} ms, guarding {}, {} objects",
        options_.node, summary_.device_type, profile_text,
        std::chrono::duration_cast<std::chrono::milliseconds>(summary_.heartbeat_period).count(),
        summary_.guarding ? "answered" : "not used", objects.size()));
    const CaseGenerator generator(
        GeneratorOptions{
            .node = options_.node, .seed = options_.seed, .allow_motion = options_.allow_motion},
        std::move(objects));

    std::map<AnomalyKind, bool> minimised_kinds;
    constexpr std::size_t kEmcyCasesShown = 10;
    std::size_t emcy_cases = 0;
    for (std::uint64_t number = 1;; ++number) {
      if (harness_.interrupted()) {
        summary_.outcome = FuzzOutcome::interrupted;
        break;
      }
      if (harness_.elapsed() >= options_.duration) break;
      if (options_.max_cases != 0 && summary_.cases_run >= options_.max_cases) break;
      const FuzzCase fuzz_case = generator.generate(number);
      const auto steps = timed_steps(fuzz_case.steps);
      const can::Duration tail =
          fuzz_case.steps.empty() ? can::Duration{0} : fuzz_case.steps.back().delay_after;
      const auto anomaly = run_steps(steps, tail);
      if (harness_.cut_short()) {
        summary_.notes.push_back(
            fmt::format("case {} ({}) was cut short by the end of --duration: not judged", number,
                        fuzz_case.kind));
        break;
      }
      ++summary_.cases_run;
      ++summary_.cases_by_kind[fuzz_case.kind];
      summary_.emcy_frames += harness_.oracle().emcy_frames();
      if (harness_.oracle().emcy_frames() > 0 && !harness_.oracle().emcys().empty() &&
          ++emcy_cases <= kEmcyCasesShown) {
        say(fmt::format("case {} ({}): {} EMCY, first {}{}", number, fuzz_case.kind,
                        harness_.oracle().emcy_frames(),
                        can::to_candump(harness_.oracle().emcys().front()),
                        emcy_cases == kEmcyCasesShown ? " (further EMCYs are only counted)" : ""));
      }
      if (!anomaly || harness_.interrupted()) continue;

      AnomalyRecord record;
      record.case_number = number;
      record.case_kind = fuzz_case.kind;
      record.anomaly = *anomaly;
      record.case_frames = steps.size();
      ++summary_.anomalies_by_kind[std::string(to_string(anomaly->kind))];
      const std::size_t index = summary_.anomalies.size() + 1;
      if (summary_.anomalies.size() < options_.max_logs) {
        record.log = write_log(fmt::format("anomaly-{}-{}.log", index, to_string(anomaly->kind)),
                               header(record, ""));
      }
      say(fmt::format("case {} ({}, {} frames): {}: {}", number, fuzz_case.kind, steps.size(),
                      to_string(anomaly->kind), anomaly->detail));
      if (!options_.minimise) {
        record.minimisation_note = "not asked for (--no-minimise)";
      } else if (minimised_kinds[anomaly->kind]) {
        record.minimisation_note = "not minimised: an earlier anomaly of this kind was";
      } else {
        minimised_kinds[anomaly->kind] = true;
        minimise(record, steps, tail);
        if (record.minimised) {
          say(fmt::format("  minimised to {} frame(s) in {} tries: {}", record.minimised_frames,
                          record.minimisation_tries, record.minimised_log.string()));
        } else {
          say(fmt::format("  not minimised: {}", record.minimisation_note));
        }
      }
      if (summary_.anomalies.size() < options_.max_logs || record.minimised)
        summary_.anomalies.push_back(std::move(record));
      if (harness_.interrupted()) continue;
      if (harness_.out_of_time()) break;
      if (!fresh_device()) {
        if (harness_.out_of_time()) break;  // the recovery was cut short, not refused
        summary_.device_lost = true;
        summary_.notes.push_back(fmt::format(
            "after case {} the device did not recover (NMT reset node, SDO ping): fuzzing ended",
            number));
        break;
      }
    }
    if (summary_.outcome != FuzzOutcome::interrupted) {
      summary_.outcome =
          summary_.anomalies_by_kind.empty() ? FuzzOutcome::clean : FuzzOutcome::anomalies;
    }
    if (summary_.cia402) harness_.safe_stop();
    summary_.elapsed = harness_.elapsed();
    return std::move(summary_);
  }

  ReplayResult replay(const std::vector<can::LogRecord>& records) {
    ReplayResult result;
    if (!fresh_device() || !probe()) {
      result.notes.push_back(
          fmt::format("node {} does not answer an SDO read of 1000h", options_.node));
      return result;
    }
    result.device_answered = true;
    if (summary_.cia402 && !options_.allow_motion && harness_.operation_enabled())
      harness_.safe_stop();
    const auto all = steps_of(records);
    std::vector<TimedStep> steps;
    for (const auto& step : all) {
      if (is_allowed_frame(step.frame, options_.node, options_.allow_motion)) {
        steps.push_back(step);
      } else {
        result.notes.push_back(
            fmt::format("not sent (safety rules): {}", can::to_candump(step.frame)));
      }
    }
    result.frames_sent = steps.size();
    result.anomaly = run_steps(steps, 5ms);
    result.notes.insert(result.notes.end(), summary_.notes.begin(), summary_.notes.end());
    if (summary_.cia402) harness_.safe_stop();
    return result;
  }

 private:
  const LiveFuzzerOptions& options_;
  Harness harness_;
  FuzzSummary summary_;
};

}  // namespace

std::string_view to_string(FuzzOutcome outcome) {
  switch (outcome) {
    case FuzzOutcome::clean:
      return "clean";
    case FuzzOutcome::anomalies:
      return "anomalies";
    case FuzzOutcome::device_lost_at_start:
      return "device-lost-at-start";
    case FuzzOutcome::interrupted:
      return "interrupted";
  }
  return "unknown";
}

FuzzSummary run_live_fuzzer(Target& target, const LiveFuzzerOptions& options) {
  Fuzzer fuzzer(target, options);
  return fuzzer.run();
}

ReplayResult replay_reproducer(Target& target, const std::vector<can::LogRecord>& records,
                               const LiveFuzzerOptions& options) {
  Fuzzer fuzzer(target, options);
  return fuzzer.replay(records);
}

std::optional<AnomalyKind> reproducer_anomaly(std::string_view text) {
  constexpr std::string_view kPrefix = "# anomaly: ";
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t end = std::min(text.find('\n', at), text.size());
    const std::string_view line = text.substr(at, end - at);
    if (line.starts_with(kPrefix)) {
      const std::string_view rest = line.substr(kPrefix.size());
      return anomaly_kind_from_string(rest.substr(0, rest.find(':')));
    }
    at = end + 1;
  }
  return std::nullopt;
}

}  // namespace drivecheck::fuzz_live
