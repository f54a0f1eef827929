// The engine's I/O and bookkeeping for one vector: every frame that passes the port is recorded
// with its wire time and the dissector's decoding; checks, samples and the failure message.
#include <fmt/format.h>

#include <algorithm>
#include <iterator>

#include "conformance/samples.hpp"
#include "conformance/vector_run.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {
namespace {

std::string format_ms(can::Duration duration) {
  return fmt::format("{:.3f} ms", std::chrono::duration<double, std::milli>(duration).count());
}

}  // namespace

VectorRun::VectorRun(EngineContext& context, const Vector& vector, VectorResult& result)
    : context_(context), vector_(vector), result_(result) {
  deadline_ = context_.bus.now() + resolve(vector.timeout);
  // On EtherCAT the port records the datagrams: into this vector's result from here on
  // (the evidence begins at the setup, which follows).
  previous_evidence_sink_ = context_.port.set_evidence_sink(&result_);
}

VectorRun::~VectorRun() {
  context_.port.set_evidence_sink(previous_evidence_sink_);
}

can::Duration VectorRun::resolve(const DurationSpec& spec) const {
  if (!spec.is_timing()) return spec.value;
  return context_.profile.timing_value(spec.timing).value_or(std::chrono::milliseconds(100));
}

std::optional<can::TimedFrame> VectorRun::pump(can::TimePoint deadline) {
  deadline = std::min(deadline, deadline_);
  while (true) {
    if (context_.stalled.load()) return std::nullopt;
    // Past the deadline the harness still takes a frame already waiting in the port (a busy
    // host reads late), but only one whose timestamp is within the deadline counts as
    // received by then; a later one is recorded and ends the wait (so a flood ends it too).
    const bool late = context_.bus.now() > deadline;
    auto frame = context_.bus.receive(deadline);
    context_.progress.fetch_add(1, std::memory_order_relaxed);
    if (!frame) return std::nullopt;
    const bool in_time = !late || frame->timestamp <= deadline;
    EvidenceFrame evidence;
    evidence.at = frame->timestamp;
    evidence.frame = frame->frame;
    evidence.from_harness = frame->own;
    evidence.decoded = context_.dissector.dissect(frame->frame).summary();
    result_.frames.push_back(std::move(evidence));
    const std::size_t samples_before = result_.samples.size();
    context_.pdo.on_frame(frame->frame, frame->own, frame->timestamp, result_.samples);
    for (std::size_t i = samples_before; i < result_.samples.size(); ++i) {
      const Sample& pdo_sample = result_.samples[i];
      if (pdo_sample.origin == SampleOrigin::tpdo && pdo_sample.signal == "statusword")
        last_statusword_ = static_cast<std::uint16_t>(pdo_sample.value);
    }
    if (frame->own) {
      if (const auto request = sdo_download_request(frame->frame, node()); request) {
        note_download_request(request->mux, request->expedited_data
                                                ? std::optional(request->expedited_data->size())
                                                : std::nullopt);
      }
      on_echo(frame->timestamp);
      if (!in_time || until_echo_) return std::nullopt;
      continue;
    }
    // Isolation: what the DUT confirmed writing while the vector's steps ran.
    if (const auto ref = confirmed_download(frame->frame, node()))
      note_confirmed_download({ref->index, ref->sub});
    ++dut_frames_;
    received_.push_back(*frame);
    if (!in_time) return std::nullopt;
    return frame;
  }
}

void VectorRun::note_download_request(cia301::Multiplexer mux, std::optional<std::size_t> size) {
  if (tracking_writes_ && size) request_sizes_[ObjectRef{mux.index, mux.sub_index}] = *size;
}

void VectorRun::note_confirmed_download(cia301::Multiplexer mux) {
  if (!tracking_writes_) return;
  if (mux.index == 0x1010) {
    stored_.insert(mux.sub_index);
  } else if (mux.index == 0x1011) {
    restored_defaults_ = true;
  } else {
    written_.insert(ObjectRef{mux.index, mux.sub_index});
  }
}

void VectorRun::on_echo(can::TimePoint at) {
  last_echo_ = at;
  if (echoes_.empty()) return;
  const PendingEcho echo = std::move(echoes_.front());
  echoes_.pop_front();
  const auto slack = resolve({{}, "harness_slack"});
  if (echo.asked && at > *echo.asked + slack) {
    note_harness_late(
        fmt::format("{} went out {} after the step asked for it ($timing.harness_slack {})",
                    echo.what, format_ms(at - *echo.asked), profile::format_duration(slack)));
  }
}

void VectorRun::note_harness_late(std::string why) {
  if (harness_late_.empty()) harness_late_ = fmt::format("{}: {}", current_place(), why);
}

void VectorRun::drain() {
  const auto at = context_.bus.now();
  while (pump(at)) {
  }
}

void VectorRun::wait_until(can::TimePoint deadline) {
  deadline = std::min(deadline, deadline_);
  while (context_.bus.now() < deadline) {
    if (!pump(deadline)) {
      // receive() returned early (stop()): do not spin.
      if (context_.interrupted.load() || context_.stalled.load() || context_.bus.now() < deadline)
        return;
    }
  }
  // The harness woke up late (a busy host): what it sends next goes out late.
  const auto slack = resolve({{}, "harness_slack"});
  if (!vector_timed_out() && now() > deadline + slack)
    note_harness_late(fmt::format("a wait ended {} late ($timing.harness_slack {})",
                                  format_ms(now() - deadline), profile::format_duration(slack)));
}

std::error_code VectorRun::send(const can::Frame& frame) {
  last_send_call_ = now();
  const std::error_code error = context_.bus.send(frame);
  if (!error) {
    PendingEcho echo;
    if (send_asked_) {
      // A frame of a `send:` step may not go out before the harness's previous frame did.
      echo.asked =
          last_echo_ && echoes_.empty() ? std::max(*send_asked_, *last_echo_) : *send_asked_;
      echo.what = fmt::format("frame {}", frame);
    }
    echoes_.push_back(std::move(echo));
  }
  return error;
}

can::TimePoint VectorRun::request_time() {
  // Wait for the echo of what the harness sent last (its actual send time); a port without
  // loopback echoes nothing, and then the step's start is the best the harness knows.
  const auto limit = now() + resolve({{}, "response"});
  until_echo_ = true;
  while (!echoes_.empty() && now() < limit && !vector_timed_out()) {
    if (!pump(limit) && (context_.interrupted.load() || context_.stalled.load())) break;
  }
  until_echo_ = false;
  if (!echoes_.empty()) echoes_.clear();
  return last_echo_ ? std::max(step_started_, *last_echo_) : step_started_;
}

StepStatus VectorRun::fail_timed(std::string action, std::string expected, std::string actual,
                                 Observation observed) {
  if (harness_late_.empty()) {
    if (auto why = stall_in_vector()) note_harness_late(std::move(*why));
  }
  if (harness_late_.empty())
    return fail(std::move(action), std::move(expected), std::move(actual), std::move(observed));
  message_ = fmt::format(
      "error: harness late in {} {} (line {}): {}; the check is not charged to the device:\n"
      "  Expected: {}\n  Actual:   {}",
      current_place(), action,
      step_index_ < vector_.steps.size() ? vector_.steps[step_index_].line : vector_.line,
      harness_late_, expected, actual);
  check(std::move(action), std::move(expected),
        fmt::format("error: harness late ({}); saw: {}", harness_late_, actual), false);
  return StepStatus::harness_error;
}

std::error_code VectorRun::send_nmt(const can::Frame& frame, bool raw) {
  const can::Duration spacing = resolve({{}, "nmt_spacing"});
  const bool burst = raw && context_.last_nmt_raw;
  if (!burst && context_.last_nmt && spacing > can::Duration{} &&
      now() < *context_.last_nmt + spacing) {
    wait_until(*context_.last_nmt + spacing);
  }
  const std::error_code error = send(frame);
  if (!error) {
    context_.last_nmt = now();
    context_.last_nmt_raw = raw;
  }
  return error;
}

void VectorRun::sample(std::uint16_t index, std::uint8_t sub, std::span<const std::uint8_t> data) {
  const SignalInfo* signal = signal_of(index, sub);
  if (signal == nullptr || data.empty()) return;
  std::uint64_t raw = 0;
  const std::size_t n = std::min<std::size_t>(data.size(), 8);
  for (std::size_t i = 0; i < n; ++i)
    raw |= static_cast<std::uint64_t>(data[i]) << (8 * i);
  const std::int64_t value = signal_value(raw, static_cast<unsigned>(8 * n), signal->is_signed);
  result_.samples.push_back(
      Sample{context_.bus.now(), std::string(signal->name), value, SampleOrigin::sdo});
  if (index == 0x6041) last_statusword_ = static_cast<std::uint16_t>(raw);
}

// Steps are numbered from 1 as the vector file lists them (Step::number: a `repeat:` and each
// step in it counted once), a step in a repeat with its iteration; 0 is the setup (step_index_
// is past the steps while setup and teardown run). The message, the checks and every report
// use this.
std::size_t VectorRun::current_number() const {
  return step_index_ < vector_.steps.size() ? step_number(vector_.steps, step_index_) : 0;
}

std::vector<Iteration> VectorRun::current_iterations() const {
  return step_index_ < vector_.steps.size() ? iterations_of(vector_.steps[step_index_])
                                            : std::vector<Iteration>{};
}

std::string VectorRun::current_place() const {
  return step_label(current_number(), current_iterations());
}

void VectorRun::check(std::string action, std::string expected, std::string actual, bool ok) {
  result_.checks.push_back(Check{current_number(),
                                 std::move(action),
                                 std::move(expected),
                                 std::move(actual),
                                 ok,
                                 now(),
                                 {},
                                 current_iterations()});
}

std::string VectorRun::recent_frames(std::size_t from_index, std::size_t max) const {
  if (from_index >= received_.size()) return "no frame from the bus";
  const std::size_t count = received_.size() - from_index;
  const std::size_t first = count > max ? received_.size() - max : from_index;
  std::vector<std::string> texts;
  for (std::size_t i = first; i < received_.size(); ++i)
    texts.push_back(can::to_candump(received_[i].frame));
  return fmt::format("{}{}{}", count > max ? fmt::format("{} frames, last: ", count) : "saw ",
                     fmt::join(texts, ", "), "");
}

std::optional<std::string> VectorRun::stall_in_vector() const {
  if (context_.options.stalls == nullptr) return std::nullopt;
  const auto stall = context_.options.stalls->longest_between(result_.started, now());
  if (!stall) return std::nullopt;
  return fmt::format(
      "no thread of the harness ran for {} ({} after the vector started): its machine stalled, "
      "so its requests and the frames' timestamps may be late",
      format_ms(stall->length()),
      format_ms(std::max(stall->from, result_.started) - result_.started));
}

StepStatus VectorRun::fail(std::string action, std::string expected, std::string actual,
                           Observation observed) {
  // The harness stalled in this vector: nothing that depends on when it asked or when a frame
  // came can be judged (stall_log.hpp); the engine runs the vector again.
  if (harness_late_.empty()) {
    if (auto why = stall_in_vector()) {
      note_harness_late(std::move(*why));
      return fail_timed(std::move(action), std::move(expected), std::move(actual),
                        std::move(observed));
    }
  }
  if (vector_timed_out() && actual.find("vector timeout") == std::string::npos)
    actual += fmt::format(" (vector timeout {} reached)",
                          profile::format_duration(resolve(vector_.timeout)));
  // The first line says it all on one line (CI systems show only that, as JUnit's failure
  // message): where in the vector file, which step, Expected and Actual. The block follows.
  const std::size_t line = step_line();
  const std::string where =
      current_number() != 0 ? fmt::format("{} {}", current_place(), action) : action;
  message_ = fmt::format("{}:{}: {}: Expected {}; Actual {}\n  Expected: {}\n  Actual:   {}",
                         vector_.file, line, where, expected, actual, expected, actual);
  check(std::move(action), std::move(expected), std::move(actual), false);
  result_.checks.back().observed = std::move(observed);
  return StepStatus::failed;
}

std::size_t VectorRun::step_line() const {
  if (step_index_ < vector_.steps.size()) return vector_.steps[step_index_].line;
  const std::size_t in_finally = step_index_ - vector_.steps.size();
  if (in_finally < vector_.finally_steps.size()) return vector_.finally_steps[in_finally].line;
  return vector_.line;
}

StepStatus VectorRun::harness_error(std::string action, std::string message) {
  const bool in_step = current_number() != 0;
  message_ = fmt::format("{}:{}: harness error in {}: {}", vector_.file,
                         in_step ? vector_.steps[step_index_].line : vector_.line,
                         in_step ? fmt::format("{} {}", current_place(), action) : action, message);
  check(std::move(action), "a step the harness can carry out", std::move(message), false);
  return StepStatus::harness_error;
}

std::string_view to_string(LinkKind link) {
  return link == LinkKind::ethercat ? "ethercat" : "can";
}

std::string SdoOutcome::describe() const {
  if (ok)
    return data.empty() ? "ok"
                        : fmt::format("ok, {} byte(s) {:02X}", data.size(), fmt::join(data, " "));
  if (vector_timed_out)
    return "no answer before the vector's time limit (not the SDO timeout: the server was not "
           "judged)";
  if (abort) {
    return fmt::format("abort {}",
                       cia301::make_error_code(static_cast<cia301::SdoAbort>(*abort)).message());
  }
  return error.message();
}

Observation SdoOutcome::observed() const {
  Observation observation;
  if (ok) {
    observation.accepted = true;
  } else if (abort) {
    observation.abort = *abort;
  } else if (error == cia301::make_error_code(cia301::SdoClientError::timeout)) {
    observation.nothing = true;
  }
  return observation;
}

StepStatus VectorRun::run_steps() {
  result_.started = now();
  // The evidence begins at this vector's setup: what the DUT sent before the setup's first
  // frame (a late answer to the vector before, a frame queued while nothing listened) is kept
  // apart as "between vectors", never as this vector's own evidence.
  step_index_ = vector_.steps.size();  // setup: no step
  const std::size_t first = result_.frames.size();
  drain();
  const std::size_t drained = result_.frames.size();
  const StepStatus setup_status = setup();
  std::size_t own = first;
  while (own < result_.frames.size() && !result_.frames[own].from_harness)
    ++own;
  if (own == result_.frames.size()) own = drained;  // the setup sent nothing: the drain only
  const auto from = result_.frames.begin() + static_cast<std::ptrdiff_t>(first);
  const auto to = result_.frames.begin() + static_cast<std::ptrdiff_t>(own);
  result_.between_vectors.insert(result_.between_vectors.end(), std::make_move_iterator(from),
                                 std::make_move_iterator(to));
  result_.frames.erase(from, to);
  if (setup_status != StepStatus::ok) return setup_status;
  steps_started_ = true;
  if (const auto status = resolve_device_values(); status != StepStatus::ok) return status;
  can::TimePoint previous_end = now();
  // An SDO stimulus (sdo_write, sdo_read, controlword) is a request: the DUT may react to it
  // before its SDO answer (an EMCY before the confirmation), so a frame expectation right
  // after it watches from the request, not from the answer.
  bool previous_request = false;
  std::size_t request_from = 0;
  can::TimePoint request_start{};
  for (step_index_ = 0; step_index_ < vector_.steps.size(); ++step_index_) {
    const Step& step = vector_.steps[step_index_];
    action_ = std::string(action_name(step.action));
    // The step watches the frames that arrived after the previous step ended, judged by their
    // timestamps, not by when the harness got to read them: those read late by the previous
    // step (resume_from_) and those already queued now with a later timestamp.
    const std::size_t queued = received_.size();
    step_started_ = previous_end;
    drain();
    if (resume_from_) {
      step_from_ = std::min(*resume_from_, queued);
    } else {
      step_from_ = queued;
      while (step_from_ < received_.size() && received_[step_from_].timestamp <= previous_end)
        ++step_from_;
    }
    resume_from_.reset();
    const bool reacts = frame_expected(step) != nullptr ||
                        std::holds_alternative<ExpectEmcyStep>(step.action) ||
                        std::holds_alternative<ExpectHeartbeatStep>(step.action);
    if (previous_request && reacts) {
      step_from_ = std::min(step_from_, request_from);
      step_started_ = request_start;
    }
    previous_request = std::holds_alternative<SdoWriteStep>(step.action) ||
                       std::holds_alternative<SdoReadStep>(step.action) ||
                       std::holds_alternative<ControlwordStep>(step.action);
    request_from = step_from_;
    request_start = step_started_;
    StepStatus status = run_stimulus(step);
    if (status == StepStatus::ok) status = run_expectation(step);
    if (status != StepStatus::ok) return status;
    if (context_.interrupted.load()) return harness_error(action_, "interrupted by the user");
    // A step that ends with a send ends when it handed the frame over (the harness may be
    // descheduled right after); any other step ends now.
    const bool sends = frame_sent(step) != nullptr || std::holds_alternative<NmtStep>(step.action);
    previous_end = sends && last_send_call_ >= step_started_ ? last_send_call_ : now();
    if (vector_timed_out())
      return fail(action_,
                  fmt::format("the vector to end within {}",
                              profile::format_duration(resolve(vector_.timeout))),
                  "vector timeout reached");
  }
  drain();
  return StepStatus::ok;
}

}  // namespace drivecheck::conformance
