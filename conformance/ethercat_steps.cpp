// The EtherCAT-only steps (vectors/FORMAT.md "EtherCAT steps"): AL state requests and the AL
// status, process data cycles with their working counter, a pause of the process data (the SM
// watchdog), a repeated mailbox request. Each runs through the EtherCAT DUT port
// (ethercat_port.hpp), which keeps the raw register and mailbox access; a vector with one is
// not applicable on CAN (verdict.cpp), so another port here is a harness error.
#include <fmt/format.h>

#include <algorithm>

#include "conformance/ethercat_port.hpp"
#include "conformance/vector_run.hpp"
#include "protocol/cia301/data_type.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/ethercat/al_state_machine.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {
namespace {

std::string state_name(std::uint8_t state) {
  return ethercat::al_state_name(state);
}

// "INIT + error, AL status code in {0011h invalid_requested_state_change}", "OP, no error".
std::string describe(const AlExpect& expect, std::uint8_t requested) {
  const std::uint8_t state = expect.state != 0 ? expect.state : requested;
  if (!expect.error) return fmt::format("AL status {}, no error indication", state_name(state));
  std::vector<std::string> codes;
  for (const auto code : expect.codes) {
    const auto info = ethercat::find_al_status_code(code);
    codes.push_back(fmt::format("{:04X}h {}", code, info ? info->name : "?"));
  }
  return fmt::format("AL status {} + error indication, AL status code (0134h) in {{{}}}",
                     state_name(state), fmt::join(codes, ", "));
}

// "OP, no error" / "INIT + error, 0000h no_error: No error" as read.
std::string describe(const ethercat::AlReading& reading) {
  if (!reading.error())
    return fmt::format("AL status {}, no error indication (0130h = {:04X}h)",
                       state_name(reading.state_bits()), reading.status);
  return fmt::format("AL status {} + error indication, AL status code {}",
                     state_name(reading.state_bits()),
                     ethercat::describe_al_status_code(reading.code));
}

bool meets(const AlExpect& expect, std::uint8_t requested, const ethercat::AlReading& reading) {
  const std::uint8_t state = expect.state != 0 ? expect.state : requested;
  if (reading.state_bits() != state || reading.error() != expect.error) return false;
  if (!expect.error) return true;
  return std::find(expect.codes.begin(), expect.codes.end(), reading.code) != expect.codes.end();
}

// What a deviation's `observed:` compares: the AL status code read ({value: 0} for a refusal
// without a code).
Observation observed(const ethercat::AlReading& reading) {
  Observation seen;
  seen.value = reading.code;
  return seen;
}

// Little-endian bytes of `value`, `size` long.
std::vector<std::uint8_t> le_bytes(std::int64_t value, std::size_t size) {
  std::vector<std::uint8_t> bytes(size);
  cia301::store_unsigned(static_cast<std::uint64_t>(value), bytes);
  return bytes;
}

}  // namespace

StepStatus VectorRun::expect_coe_emergency(const ExpectEmcyStep& e, can::TimePoint base) {
  const std::string name = "expect_emcy";
  auto* port = dynamic_cast<EthercatPort*>(&context_.port);
  if (port == nullptr) return harness_error(name, "no EtherCAT port");
  const auto within = resolve(e.within);
  const auto since = e.since.empty() ? base : marks_.at(e.since).at;
  const auto deadline = since + within;
  auto expected =
      e.any_error ? std::string("CoE emergency with an error code (not 0000h)")
                  : fmt::format("CoE emergency with code {{{:04X}h}}", fmt::join(e.codes, "h, "));
  if (e.register_mask)
    expected += fmt::format(", register & {:02X}h == {:02X}h", *e.register_mask, e.register_value);
  expected += fmt::format(" within {}", profile::format_duration(within));
  const auto matches = [&e](const ethercat::CoeEmergency& message) {
    const auto& emcy = message.emcy;
    if (!e.accepts(emcy.error_code)) return false;
    if (e.register_mask && (emcy.error_register & *e.register_mask) != e.register_value)
      return false;
    for (std::size_t i = 0; i < e.manufacturer.size() && i < emcy.manufacturer.size(); ++i)
      if (e.manufacturer[i] && *e.manufacturer[i] != emcy.manufacturer[i]) return false;
    return true;
  };
  const auto describe_emcy = [](const ethercat::CoeEmergency& message) {
    return fmt::format("{:04X}h register {:02X}h data {:02X}", message.emcy.error_code,
                       message.emcy.error_register, fmt::join(message.emcy.manufacturer, " "));
  };
  for (;;) {
    port->collect_emergencies(true);
    std::vector<std::string> seen;
    for (auto& entry : port->emergencies()) {
      if (entry.at < since || entry.matched) continue;
      if (matches(entry.message)) {
        entry.matched = true;
        note_dut_answer();
        if (!e.mark.empty()) set_mark(e.mark, entry.at, received_.size());
        check(name, expected,
              fmt::format("{} after {}", describe_emcy(entry.message),
                          profile::format_duration(entry.at - since)),
              true);
        return StepStatus::ok;
      }
      seen.push_back(describe_emcy(entry.message));
    }
    if (now() >= deadline || vector_timed_out()) {
      Observation nothing;
      nothing.nothing = true;
      return fail_timed(name, expected,
                        seen.empty() ? std::string("no CoE emergency")
                                     : fmt::format("other emergencies: {}", fmt::join(seen, "; ")),
                        nothing);
    }
    wait_until(std::min(deadline, now() + resolve({{}, "poll"})));
  }
}

bool is_ethercat_step(const Action& action) {
  return std::holds_alternative<AlRequestStep>(action) ||
         std::holds_alternative<ExpectAlStep>(action) ||
         std::holds_alternative<ProcessDataStep>(action) ||
         std::holds_alternative<PauseProcessDataStep>(action) ||
         std::holds_alternative<MailboxRepeatStep>(action) ||
         std::holds_alternative<PowerCycleStep>(action);
}

StepStatus VectorRun::run_ethercat_step(const Step& step) {
  const auto& action = step.action;
  const std::string name(action_name(action));
  auto* port = dynamic_cast<EthercatPort*>(&context_.port);
  if (port == nullptr)
    return harness_error(name,
                         "an EtherCAT step on another link (the vector should be not "
                         "applicable here)");
  std::string error;

  if (const auto* request = std::get_if<AlRequestStep>(&action)) {
    const auto target = ethercat::al_state_from(request->state);
    const auto within = resolve(request->within);
    const auto expected =
        fmt::format("request {} (0120h): {} within {}", state_name(request->state),
                    describe(request->expect, request->state), profile::format_duration(within));
    std::optional<ethercat::AlReading> reading;
    if (!request->expect.error) {
      // The way a master goes there: SMs configured on the way up, the cycle running.
      const auto refused = port->request_state(*target);
      reading = port->al_status(error);
      if (!reading) return harness_error(name, fmt::format("reading AL status: {}", error));
      note_dut_answer();
      if (!meets(request->expect, request->state, *reading)) {
        const auto actual = fmt::format("{}{}", describe(*reading),
                                        refused.empty() ? "" : fmt::format(" ({})", refused));
        const auto seen = observed(*reading);
        (void)port->settle();  // back where the master held the slave (the next setup resets)
        return fail(name, expected, actual, seen);
      }
      check(name, expected, describe(*reading), true);
      return StepStatus::ok;
    }
    // A refusal: the request exactly as written, from the state the slave is in.
    reading = port->raw_al_request(*target, now() + within, error);
    if (!reading) return harness_error(name, fmt::format("AL request: {}", error));
    note_dut_answer();
    const bool ok = meets(request->expect, request->state, *reading);
    const auto actual = describe(*reading);
    // The error acknowledged and the slave back where the master holds it.
    const auto settled = port->settle();
    if (!ok) return fail(name, expected, actual, observed(*reading));
    check(name, expected, actual, true);
    if (!settled.empty())
      return harness_error(name,
                           fmt::format("putting the slave back after the refusal: {}", settled));
    return StepStatus::ok;
  }

  if (const auto* e = std::get_if<ExpectAlStep>(&action)) {
    const auto within = resolve(e->within);
    const auto deadline = step_started_ + within;
    const auto expected = fmt::format("{} within {}", describe(e->expect, e->expect.state),
                                      profile::format_duration(within));
    for (;;) {
      auto reading = port->al_status(error);
      if (!reading) return harness_error(name, fmt::format("reading AL status: {}", error));
      note_dut_answer();
      if (meets(e->expect, e->expect.state, *reading)) {
        check(name, expected, describe(*reading), true);
        return StepStatus::ok;
      }
      if (now() >= deadline || vector_timed_out())
        return fail_timed(name, expected, fmt::format("{} at the deadline", describe(*reading)),
                          observed(*reading));
      wait_until(std::min(deadline, now() + resolve({{}, "poll"})));
    }
  }

  if (const auto* pd = std::get_if<ProcessDataStep>(&action)) {
    const auto& master = port->master();
    if (master.held_state() != ethercat::AlState::safeop &&
        master.held_state() != ethercat::AlState::op)
      return harness_error(name, fmt::format("process data needs SAFEOP or OP (the master holds "
                                             "the slave in {}): nmt: operational or al_request",
                                             ethercat::al_state_name(master.held_state())));
    std::uint16_t expected_wkc = 0;
    for (std::size_t i = 0; i < pd->cycles; ++i) {
      const auto outcome = port->checked_cycle();
      if (outcome.result) expected_wkc = outcome.result->expected_wkc;
      const auto expected = fmt::format(
          "{} process data cycle(s) (LRW): working counter {} each (the configuration: outputs "
          "+2, inputs +1), AL status {} without error",
          pd->cycles, expected_wkc, ethercat::al_state_name(master.held_state()));
      if (!outcome.result) {
        Observation seen;
        seen.nothing = true;
        return fail(name, expected, fmt::format("cycle {}: {}", i + 1, outcome.error), seen);
      }
      if (!outcome.error.empty()) {
        Observation seen;
        seen.value = outcome.result->wkc;
        return fail(name, expected,
                    fmt::format("cycle {}: working counter {}, AL status {:04X}h: {}", i + 1,
                                outcome.result->wkc, outcome.result->al_status, outcome.error),
                    seen);
      }
      note_dut_answer();
    }
    check(name,
          fmt::format("{} process data cycle(s): working counter {} each, AL status {}", pd->cycles,
                      expected_wkc, ethercat::al_state_name(master.held_state())),
          fmt::format("{} cycle(s), working counter {} each", pd->cycles, expected_wkc), true);
    return StepStatus::ok;
  }

  if (const auto* pause = std::get_if<PauseProcessDataStep>(&action)) {
    can::Duration duration{};
    std::string what;
    if (pause->duration) {
      duration = resolve(*pause->duration);
      what = profile::format_duration(duration);
    } else {
      const auto watchdog = port->sm_watchdog_time(error);
      if (!watchdog) return harness_error(name, fmt::format("reading the SM watchdog: {}", error));
      if (*watchdog <= can::Duration::zero())
        return fail(name, "an SM watchdog time (0420h) in SAFEOP/OP",
                    "0420h = 0: the process data watchdog is off");
      duration = 2 * *watchdog;
      what = fmt::format("{} (twice the SM watchdog time {} of 0400h/0420h)",
                         profile::format_duration(duration), profile::format_duration(*watchdog));
    }
    port->pause_cycles(now() + duration);
    wait_until(now() + duration);
    check(name, fmt::format("no process data for {}", what), "paused", true);
    return StepStatus::ok;
  }

  if (std::holds_alternative<PowerCycleStep>(action)) {
    if (!port->can_power_cycle())
      return harness_error(name,
                           "this link cannot power-cycle the slave (only the emulated "
                           "slave of ethercat:sim can be)");
    if (auto failed = port->reset(true); !failed.empty())
      return harness_error(name, fmt::format("power cycle and bring-up to PREOP: {}", failed));
    check(name, "the slave switched off and on, then brought up to PREOP",
          fmt::format("PREOP, AL status {}", ethercat::al_state_name(port->master().held_state())),
          true);
    return StepStatus::ok;
  }

  if (const auto* repeat = std::get_if<MailboxRepeatStep>(&action)) {
    const cia301::Multiplexer mux{repeat->index, repeat->sub};
    const auto first = le_bytes(repeat->value, repeat->size);
    const auto second = le_bytes(repeat->repeat, repeat->size);
    const auto what = fmt::format("{:04X}h sub {}", repeat->index, repeat->sub);
    const auto written = sdo_download(mux, first);
    if (!written.ok)
      return fail(name, fmt::format("write {} := {} answered ok", what, repeat->value),
                  written.describe(), written.observed());
    const auto counter = port->last_mailbox_counter();
    const auto replies =
        port->repeat_download(mux, second, now() + resolve({{}, "sdo_response"}), error);
    if (!replies) return harness_error(name, fmt::format("repeated request: {}", error));
    const auto read = sdo_upload(mux);
    const auto expected = fmt::format(
        "write {} := {} (mailbox counter {}), then a write := {} with the same counter (a "
        "repeat: not executed again): {} reads {}",
        what, repeat->value, counter, repeat->repeat, what, repeat->value);
    if (!read.ok)
      return fail(name, expected, fmt::format("read: {}", read.describe()), read.observed());
    note_dut_answer();
    const auto raw = cia301::load_unsigned(
        std::span(read.data.data(), std::min<std::size_t>(read.data.size(), 8)));
    const auto mask =
        repeat->size >= 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8 * repeat->size)) - 1;
    const auto actual =
        fmt::format("{} reply(ies) to the repeat; {} reads {} ({:X}h)", *replies, what, raw, raw);
    if ((raw & mask) != (static_cast<std::uint64_t>(repeat->value) & mask)) {
      Observation seen;
      seen.value = static_cast<std::int64_t>(raw);
      return fail(name, expected, actual, seen);
    }
    check(name, expected, actual, true);
    return StepStatus::ok;
  }
  return StepStatus::ok;
}

}  // namespace drivecheck::conformance
