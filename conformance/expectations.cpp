// Expectation steps: frame matching against what the DUT sends, the polled CiA 402 checks,
// marks and timing measurements. A watching step sees the frames that arrived after the
// previous step ended (or after `since:` its mark), never earlier ones.
#include <fmt/format.h>

#include <algorithm>

#include "conformance/vector_run.hpp"
#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {
namespace {

std::string ms(can::Duration duration) {
  return fmt::format("{:.3f} ms", std::chrono::duration<double, std::milli>(duration).count());
}

Observation nothing() {
  Observation observation;
  observation.nothing = true;
  return observation;
}

std::string cob_text(const CobIdSpec& cob, std::uint8_t node) {
  return cob.plus_node ? fmt::format("{:X}+N ({:03X})", cob.base, cob.resolve(node))
                       : fmt::format("{:03X}", cob.base);
}

}  // namespace

std::optional<std::uint32_t> refused_abort(const ExpectFrameStep& e, const can::Frame& frame,
                                           std::uint8_t node) {
  if (!e.abort || !e.pattern.matches(frame, node)) return std::nullopt;
  // The pattern is an SDO abort with the code as don't-care (loader): the set decides.
  const auto payload = frame.payload();
  const auto code = static_cast<std::uint32_t>(payload[4] | payload[5] << 8 | payload[6] << 16 |
                                               static_cast<std::uint32_t>(payload[7]) << 24);
  if (e.abort->accepts(code)) return std::nullopt;
  return code;
}

void VectorRun::set_mark(const std::string& name, can::TimePoint at, std::size_t index) {
  marks_[name] = Mark{at, index};
}

std::size_t VectorRun::watch_start(const std::string& since) const {
  if (since.empty()) return step_from_;
  const auto it = marks_.find(since);
  return it == marks_.end() ? received_.size() : it->second.index;
}

std::optional<std::size_t> VectorRun::watch(std::size_t from, can::TimePoint deadline,
                                            const std::function<bool(const can::Frame&)>& match) {
  // Judged by the frame's timestamp (its wire time), never by when the harness read it.
  const auto on_time = [&](std::size_t i) {
    return received_[i].timestamp <= deadline && match(received_[i].frame);
  };
  for (std::size_t i = from; i < received_.size(); ++i) {
    if (on_time(i)) return i;
  }
  while (now() < deadline && !vector_timed_out()) {
    auto frame = pump(deadline);
    if (!frame) {
      if (context_.interrupted.load()) return std::nullopt;
      continue;
    }
    if (on_time(received_.size() - 1)) return received_.size() - 1;
  }
  // The deadline has passed for the harness. Frames already waiting in the port may still
  // have arrived in time (a busy host reads them late): take them by their timestamps. Those
  // read here that do not match belong to the next step.
  const std::size_t late_from = received_.size();
  while (pump(now())) {
    const std::size_t i = received_.size() - 1;
    if (on_time(i)) {
      resume_from_ = i + 1;
      return i;
    }
  }
  if (late_from < received_.size()) resume_from_ = late_from;
  return std::nullopt;
}

StepStatus VectorRun::poll_statusword(std::string action, std::uint16_t mask, std::uint16_t value,
                                      std::string expected, can::TimePoint deadline) {
  const auto every = resolve({{}, "poll"});
  std::string last = "no statusword read";
  Observation observed = nothing();
  while (true) {
    const auto started = now();
    const auto outcome = sdo_upload({0x6041, 0});
    if (outcome.ok && outcome.data.size() == 2) {
      const auto sw = static_cast<std::uint16_t>(outcome.data[0] | outcome.data[1] << 8);
      if ((sw & mask) == value) {
        check(std::move(action), std::move(expected),
              fmt::format("statusword {:04X}h ({})", sw, cia402::describe_statusword(sw)), true);
        return StepStatus::ok;
      }
      last = fmt::format("statusword {:04X}h ({})", sw, cia402::describe_statusword(sw));
      observed = Observation{};
      observed.statusword = sw;
    } else {
      last = fmt::format("reading 6041h: {}", outcome.describe());
      observed = outcome.observed();
    }
    if (now() >= deadline || vector_timed_out() || context_.interrupted.load()) break;
    wait_until(std::min(deadline, std::max(now(), started + every)));
    // A read after the vector's limit would end unanswered and hide the last real answer.
    if (vector_timed_out()) break;
  }
  return fail_timed(std::move(action), std::move(expected), fmt::format("{} at the deadline", last),
                    observed);
}

StepStatus VectorRun::expect_frame(const ExpectFrameStep& e, const std::string& name) {
  const auto within = resolve(e.within);
  const auto from = watch_start(e.since);
  const auto base = e.since.empty() ? request_time() : marks_.at(e.since).at;
  std::vector<std::string> patterns{e.pattern.text};
  for (const auto& alternative : e.alternatives)
    patterns.push_back(alternative.text);
  auto expected = fmt::format("a frame matching {} within {}", fmt::join(patterns, " or "),
                              profile::format_duration(within));
  if (e.abort) expected += fmt::format(", {}", e.abort->describe());
  const auto hit = watch(from, base + within, [&](const can::Frame& f) {
    return e.pattern.matches(f, node()) || std::any_of(e.alternatives.begin(), e.alternatives.end(),
                                                       [&](const FrameSpec& alternative) {
                                                         return alternative.matches(f, node());
                                                       });
  });
  if (!hit) {
    // Nothing matched; an SDO abort the DUT's server sent meanwhile is the typed observation.
    Observation observed = nothing();
    for (std::size_t i = from; i < received_.size(); ++i) {
      const auto& f = received_[i].frame;
      if (!f.is_extended() && !f.is_remote() && f.id == 0x580U + node() && f.length() == 8 &&
          f.data[0] == 0x80)
        observed.abort = static_cast<std::uint32_t>(f.data[4] | f.data[5] << 8 | f.data[6] << 16 |
                                                    static_cast<std::uint32_t>(f.data[7]) << 24);
    }
    return fail_timed(name, expected,
                      fmt::format("nothing matching within {}; {}",
                                  profile::format_duration(within), recent_frames(from)),
                      observed);
  }
  const auto& frame = received_[*hit];
  if (const auto code = refused_abort(e, frame.frame, node())) {
    Observation observed;
    observed.abort = *code;
    return fail(
        name, expected,
        fmt::format("{} after {}: abort {}", frame.frame, ms(frame.timestamp - base),
                    cia301::make_error_code(static_cast<cia301::SdoAbort>(*code)).message()),
        observed);
  }
  if (!e.mark.empty()) set_mark(e.mark, frame.timestamp, *hit + 1);
  check(name, expected, fmt::format("{} after {}", frame.frame, ms(frame.timestamp - base)), true);
  return StepStatus::ok;
}

StepStatus VectorRun::run_expectation(const Step& step) {
  const auto& action = step.action;
  const std::string name(action_name(action));
  // Bus time when the previous step ended: a late harness does not shift the windows.
  const auto start = step_started_;
  if (const auto* e = std::get_if<ExpectFrameStep>(&action)) return expect_frame(*e, name);
  if (const auto* e = std::get_if<ExpectSdoResponseStep>(&action)) {
    // On CAN the response is the frame 580h+N: the expect_frame it stands for.
    if (context_.port.link() == LinkKind::can) return expect_frame(e->expect, name);
    return expect_coe_sdo_response(e->expect, name);
  }
  if (const auto* e = std::get_if<ExpectSilenceStep>(&action)) {
    const auto duration = resolve(e->duration);
    const auto from = watch_start(e->since);
    const auto base = e->since.empty() ? start : marks_.at(e->since).at;
    std::vector<std::string> cobs;
    for (const auto& cob : e->cob_ids)
      cobs.push_back(cob_text(cob, node()));
    for (const auto& pattern : e->patterns)
      cobs.push_back(pattern.text);
    const auto expected =
        e->any ? fmt::format("no frame at all for {}", profile::format_duration(duration))
               : fmt::format("no frame on {} for {}", fmt::join(cobs, ", "),
                             profile::format_duration(duration));
    const auto hit = watch(from, base + duration, [&](const can::Frame& f) {
      if (e->any) return true;
      if (std::any_of(e->patterns.begin(), e->patterns.end(),
                      [&](const FrameSpec& pattern) { return pattern.matches(f, node()); }))
        return true;
      return std::any_of(e->cob_ids.begin(), e->cob_ids.end(), [&](const CobIdSpec& cob) {
        return !f.is_error() && f.id == cob.resolve(node()) && f.is_extended() == cob.extended;
      });
    });
    if (hit)
      return fail_timed(
          name, expected,
          fmt::format("{} after {}", received_[*hit].frame, ms(received_[*hit].timestamp - base)));
    check(name, expected, "silence", true);
    return StepStatus::ok;
  }
  if (const auto* e = std::get_if<ExpectBootupStep>(&action)) {
    const auto within = resolve(e->within);
    const auto from = watch_start(e->since);
    const auto base = e->since.empty() ? request_time() : marks_.at(e->since).at;
    const auto expected = fmt::format("boot-up {:03X}#00 within {}", 0x700 + node(),
                                      profile::format_duration(within));
    const auto hit = watch(from, base + within, [&](const can::Frame& f) {
      return !f.is_extended() && !f.is_remote() && f.id == 0x700U + node() && f.length() == 1 &&
             f.data[0] == 0;
    });
    if (!hit)
      return fail_timed(name, expected, fmt::format("no boot-up; {}", recent_frames(from)),
                        nothing());
    if (!e->mark.empty()) set_mark(e->mark, received_[*hit].timestamp, *hit + 1);
    check(name, expected, fmt::format("after {}", ms(received_[*hit].timestamp - base)), true);
    return StepStatus::ok;
  }
  if (const auto* e = std::get_if<ExpectHeartbeatStep>(&action)) {
    can::Duration within{};
    if (e->within) {
      within = resolve(*e->within);
    } else {
      if (!heartbeat_time_) (void)sdo_upload({0x1017, 0});
      within = heartbeat_time_ && heartbeat_time_->count() > 0 ? *heartbeat_time_ * 3 / 2
                                                               : resolve({{}, "response"});
    }
    const auto from = e->since.empty() ? watch_start({}) : watch_start(e->since);
    const auto base = e->since.empty() ? request_time() : marks_.at(e->since).at;
    const auto state = static_cast<std::uint8_t>(e->state);
    const auto expected =
        fmt::format("heartbeat {:03X}#{:02X} ({}) within {}", 0x700 + node(), state,
                    cia301::to_string(e->state), profile::format_duration(within));
    const auto hit =
        watch(std::min(from, received_.size()), base + within, [&](const can::Frame& f) {
          return !f.is_extended() && !f.is_remote() && f.id == 0x700U + node() && f.length() == 1 &&
                 (f.data[0] & 0x7F) == state;
        });
    if (!hit)
      return fail_timed(name, expected, fmt::format("none; {}", recent_frames(from)), nothing());
    if (!e->mark.empty()) set_mark(e->mark, received_[*hit].timestamp, *hit + 1);
    check(name, expected, fmt::format("after {}", ms(received_[*hit].timestamp - base)), true);
    return StepStatus::ok;
  }
  if (const auto* e = std::get_if<ExpectEmcyStep>(&action)) {
    if (context_.port.link() == LinkKind::ethercat) return expect_coe_emergency(*e, start);
    const auto within = resolve(e->within);
    const auto from = watch_start(e->since);
    const auto base = e->since.empty() ? request_time() : marks_.at(e->since).at;
    auto expected = e->any_error
                        ? fmt::format("EMCY {:03X} with an error code (not 0000h)", 0x80 + node())
                        : fmt::format("EMCY {:03X} with code {{{:04X}h}}", 0x80 + node(),
                                      fmt::join(e->codes, "h, "));
    if (e->register_mask)
      expected +=
          fmt::format(", register & {:02X}h == {:02X}h", *e->register_mask, e->register_value);
    expected += fmt::format(" within {}", profile::format_duration(within));
    const auto hit = watch(from, base + within, [&](const can::Frame& f) {
      if (f.is_extended() || f.is_remote() || f.id != 0x80U + node() || f.length() != 8)
        return false;
      const auto code = static_cast<std::uint16_t>(f.data[0] | f.data[1] << 8);
      if (!e->accepts(code)) return false;
      if (e->register_mask && (f.data[2] & *e->register_mask) != e->register_value) return false;
      for (std::size_t i = 0; i < e->manufacturer.size(); ++i) {
        if (e->manufacturer[i] && *e->manufacturer[i] != f.data[3 + i]) return false;
      }
      return true;
    });
    if (!hit)
      return fail_timed(name, expected, fmt::format("no such EMCY; {}", recent_frames(from)),
                        nothing());
    if (!e->mark.empty()) set_mark(e->mark, received_[*hit].timestamp, *hit + 1);
    check(name, expected,
          fmt::format("{} after {}", received_[*hit].frame, ms(received_[*hit].timestamp - base)),
          true);
    return StepStatus::ok;
  }
  if (const auto* e = std::get_if<ExpectStateStep>(&action)) {
    const auto within = resolve(e->within);
    const auto& pattern = cia402::pattern_of(e->state);
    return poll_statusword(
        name, pattern.mask, pattern.value,
        fmt::format("state {} (statusword & {:04X}h == {:04X}h) within {}", pattern.name,
                    pattern.mask, pattern.value, profile::format_duration(within)),
        start + within);
  }
  if (const auto* e = std::get_if<ExpectStatuswordStep>(&action)) {
    const auto within = resolve(e->within);
    return poll_statusword(name, e->mask, e->value,
                           fmt::format("statusword & {:04X}h == {:04X}h within {}", e->mask,
                                       e->value, profile::format_duration(within)),
                           start + within);
  }
  if (const auto* e = std::get_if<PollStep>(&action)) {
    const auto deadline = start + resolve(e->within);
    const auto every = resolve(e->every);
    // `range:` bounds, resolved once (saved values do not change while polling).
    std::int64_t low = 0;
    std::int64_t high = 0;
    if (e->range) {
      std::string error;
      const auto lo = value_of(e->range->first, error);
      const auto hi = lo ? value_of(e->range->second, error) : std::nullopt;
      if (!lo || !hi) return harness_error(name, error);
      low = *lo;
      high = *hi;
    }
    const auto bound = [](const ValueSpec& spec, std::int64_t v) {
      if (spec.saved.empty()) return fmt::format("{}", v);
      return fmt::format("{} = {}", to_text(spec), v);
    };
    const auto expected =
        e->range
            ? fmt::format("{:04X}h sub {} in [{}, {}]{} within {}", e->index, e->sub,
                          bound(e->range->first, low), bound(e->range->second, high),
                          e->is_signed ? " (signed)" : "",
                          profile::format_duration(resolve(e->within)))
            : fmt::format("{:04X}h sub {} & {:X}h == {:X}h within {}", e->index, e->sub, e->mask,
                          e->value & e->mask, profile::format_duration(resolve(e->within)));
    std::string last = "nothing read";
    Observation observed = nothing();
    while (true) {
      const auto started = now();
      const auto outcome = sdo_upload({e->index, e->sub});
      if (outcome.ok) {
        const auto bytes =
            std::span(outcome.data.data(), std::min<std::size_t>(outcome.data.size(), 8));
        const auto raw = cia301::load_unsigned(bytes);
        const std::int64_t value = e->is_signed && !bytes.empty() ? cia301::load_signed(bytes)
                                                                  : static_cast<std::int64_t>(raw);
        // As sdo_read's range: unsigned, a value above INT64_MAX is above any bound.
        const bool met =
            e->range ? (e->is_signed ? value >= low && value <= high
                                     : high >= 0 && raw <= static_cast<std::uint64_t>(high) &&
                                           (low <= 0 || raw >= static_cast<std::uint64_t>(low)))
                     : (raw & e->mask) == (e->value & e->mask);
        const auto seen =
            e->range ? fmt::format("{} ({:X}h)", value, raw) : fmt::format("{:X}h", raw);
        if (met) {
          check(name, expected, fmt::format("{} after {}", seen, ms(now() - start)), true);
          return StepStatus::ok;
        }
        last = seen;
        observed = Observation{};
        observed.value = e->range ? value : static_cast<std::int64_t>(raw);
      } else {
        last = outcome.describe();
        observed = outcome.observed();
      }
      if (now() >= deadline || vector_timed_out() || context_.interrupted.load()) break;
      wait_until(std::min(deadline, std::max(now(), started + every)));
    }
    return fail_timed(name, expected, fmt::format("last read: {}", last), observed);
  }
  if (const auto* e = std::get_if<MeasureStep>(&action)) {
    const auto from = marks_.find(e->from);
    const auto to = marks_.find(e->to);
    if (from == marks_.end() || to == marks_.end())
      return harness_error(
          name, fmt::format("unknown mark '{}'", from == marks_.end() ? e->from : e->to));
    if (!e->frames.empty()) {
      // Frames on the bus between the two marks, by their timestamps: the harness's own too
      // (their echo is their wire time), so what counts is what was on the bus, not when the
      // harness meant to send it.
      const auto first = from->second.at;
      const auto last = to->second.at;
      std::size_t count = 0;
      for (const EvidenceFrame& seen : result_.frames) {
        if (seen.at <= first || seen.at > last) continue;
        if (std::ranges::any_of(e->frames, [&](const FrameSpec& pattern) {
              return pattern.matches(seen.frame, node());
            }))
          ++count;
      }
      std::string patterns;
      for (const FrameSpec& pattern : e->frames)
        patterns += (patterns.empty() ? "" : " or ") + pattern.text;
      const auto bound = [](const std::optional<std::size_t>& n) {
        return n ? fmt::format("{}", *n) : std::string("-");
      };
      const auto expected = fmt::format("frames matching {} between {} and {}: [{}, {}]", patterns,
                                        e->from, e->to, bound(e->min_count), bound(e->max_count));
      const bool ok =
          (!e->min_count || count >= *e->min_count) && (!e->max_count || count <= *e->max_count);
      const auto actual = fmt::format("{} ({} after {})", count, ms(last - first), e->from);
      if (!ok) return fail(name, expected, actual);
      check(name, expected, actual, true);
      return StepStatus::ok;
    }
    const auto interval = to->second.at - from->second.at;
    Timing timing{fmt::format("{}→{}", e->from, e->to), interval, std::nullopt, std::nullopt, true};
    if (e->min) timing.min = resolve(*e->min);
    if (e->max) timing.max = resolve(*e->max);
    timing.ok =
        (!timing.min || interval >= *timing.min) && (!timing.max || interval <= *timing.max);
    result_.timings.push_back(timing);
    const auto expected = fmt::format("{} → {} in [{}, {}]", e->from, e->to,
                                      timing.min ? profile::format_duration(*timing.min) : "-",
                                      timing.max ? profile::format_duration(*timing.max) : "-");
    if (!timing.ok) return fail_timed(name, expected, ms(interval));
    check(name, expected, ms(interval), true);
    return StepStatus::ok;
  }
  if (const auto* e = std::get_if<ExpectPeriodicStep>(&action)) {
    const auto period = resolve(e->period);
    const auto tolerance = resolve(e->tolerance);
    const auto expected =
        fmt::format("{} frames on {} every {} ± {}", e->count, cob_text(e->cob, node()),
                    profile::format_duration(period), profile::format_duration(tolerance));
    const auto matches = [&](const can::Frame& f) {
      return !f.is_error() && f.id == e->cob.resolve(node()) && f.is_extended() == e->cob.extended;
    };
    std::size_t from = step_from_;
    std::optional<can::TimePoint> previous;
    for (std::size_t n = 0; n < e->count; ++n) {
      const auto deadline = (previous ? *previous : start) + period + tolerance;
      const auto hit = watch(from, deadline, matches);
      if (!hit)
        return fail_timed(name, expected,
                          fmt::format("frame {} of {} missing within {}{}", n + 1, e->count,
                                      profile::format_duration(period + tolerance),
                                      previous ? " of the previous one" : " of the step start"),
                          nothing());
      const auto at = received_[*hit].timestamp;
      if (previous) {
        const auto interval = at - *previous;
        Timing timing{fmt::format("period {}", n), interval, period - tolerance, period + tolerance,
                      true};
        timing.ok = interval >= *timing.min && interval <= *timing.max;
        result_.timings.push_back(timing);
        if (!timing.ok)
          return fail_timed(
              name, expected,
              fmt::format("interval {} between frames {} and {}", ms(interval), n, n + 1));
      } else if (!e->mark.empty()) {
        set_mark(e->mark, at, *hit + 1);
      }
      if (n + 1 == e->count && !e->last.empty()) set_mark(e->last, at, *hit + 1);
      previous = at;
      from = *hit + 1;
    }
    check(name, expected, fmt::format("{} frames, periods within tolerance", e->count), true);
    return StepStatus::ok;
  }
  return StepStatus::ok;  // a stimulus: sdo_steps.cpp
}

}  // namespace drivecheck::conformance
