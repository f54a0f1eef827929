// The engine's I/O and bookkeeping for one vector: every frame that passes the port is recorded
// with its wire time and the dissector's decoding; checks, samples and the failure message.
#include <fmt/format.h>

#include <algorithm>

#include "conformance/samples.hpp"
#include "conformance/vector_run.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {

VectorRun::VectorRun(EngineContext& context, const Vector& vector, VectorResult& result)
    : context_(context), vector_(vector), result_(result) {
  deadline_ = context_.bus.now() + resolve(vector.timeout);
}

can::Duration VectorRun::resolve(const DurationSpec& spec) const {
  if (!spec.is_timing()) return spec.value;
  return context_.profile.timing_value(spec.timing).value_or(std::chrono::milliseconds(100));
}

std::optional<can::TimedFrame> VectorRun::pump(can::TimePoint deadline) {
  deadline = std::min(deadline, deadline_);
  while (true) {
    if (context_.bus.now() > deadline || context_.stalled.load()) return std::nullopt;
    auto frame = context_.bus.receive(deadline);
    context_.progress.fetch_add(1, std::memory_order_relaxed);
    if (!frame) return std::nullopt;
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
      if (tracking_writes_) {
        if (const auto request = sdo_download_request(frame->frame, node());
            request && request->expedited_data) {
          request_sizes_[ObjectRef{request->mux.index, request->mux.sub_index}] =
              request->expedited_data->size();
        }
      }
      continue;
    }
    // Isolation: what the DUT confirmed writing while the vector's steps ran.
    if (tracking_writes_) {
      if (const auto ref = confirmed_download(frame->frame, node())) {
        if (ref->index == 0x1010) {
          stored_.insert(ref->sub);
        } else if (ref->index == 0x1011) {
          restored_defaults_ = true;
        } else {
          written_.insert(*ref);
        }
      }
    }
    ++dut_frames_;
    received_.push_back(*frame);
    return frame;
  }
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
}

std::error_code VectorRun::send(const can::Frame& frame) {
  return context_.bus.send(frame);
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

void VectorRun::check(std::string action, std::string expected, std::string actual, bool ok) {
  result_.checks.push_back(
      Check{step_index_, std::move(action), std::move(expected), std::move(actual), ok});
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

StepStatus VectorRun::fail(std::string action, std::string expected, std::string actual) {
  if (vector_timed_out() && actual.find("vector timeout") == std::string::npos)
    actual += fmt::format(" (vector timeout {} reached)",
                          profile::format_duration(resolve(vector_.timeout)));
  message_ = fmt::format("step {} {} (line {}):\n  Expected: {}\n  Actual:   {}", step_index_ + 1,
                         action, step_line(), expected, actual);
  check(std::move(action), std::move(expected), std::move(actual), false);
  return StepStatus::failed;
}

std::size_t VectorRun::step_line() const {
  if (step_index_ < vector_.steps.size()) return vector_.steps[step_index_].line;
  const std::size_t in_finally = step_index_ - vector_.steps.size();
  if (in_finally < vector_.finally_steps.size()) return vector_.finally_steps[in_finally].line;
  return vector_.line;
}

StepStatus VectorRun::harness_error(std::string action, std::string message) {
  message_ = fmt::format("harness error in step {} {}: {}", step_index_ + 1, action, message);
  check(std::move(action), "a step the harness can carry out", std::move(message), false);
  return StepStatus::harness_error;
}

std::string SdoOutcome::describe() const {
  if (ok)
    return data.empty() ? "ok"
                        : fmt::format("ok, {} byte(s) {:02X}", data.size(), fmt::join(data, " "));
  if (abort) {
    return fmt::format("abort {}",
                       cia301::make_error_code(static_cast<cia301::SdoAbort>(*abort)).message());
  }
  return error.message();
}

StepStatus VectorRun::run_steps() {
  result_.started = now();
  if (const auto status = setup(); status != StepStatus::ok) return status;
  steps_started_ = true;
  for (step_index_ = 0; step_index_ < vector_.steps.size(); ++step_index_) {
    const Step& step = vector_.steps[step_index_];
    action_ = std::string(action_name(step.action));
    drain();
    StepStatus status = run_stimulus(step);
    if (status == StepStatus::ok) status = run_expectation(step);
    if (status != StepStatus::ok) return status;
    if (context_.interrupted.load()) return harness_error(action_, "interrupted by the user");
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
