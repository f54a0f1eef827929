// CoE SDO through the EtherCAT master; the engine's clock on the link (ethercat_port.hpp).
#include "conformance/ethercat_port.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "conformance/vector_run.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia301/sdo_client.hpp"

namespace drivecheck::conformance {
namespace {

// The engine's outcome of a master call: an abort as the server's code, no mailbox reply as
// "no answer" (as an SDO timeout on CAN), anything else as the master's error.
SdoOutcome outcome_of(const ethercat::MasterError& error) {
  SdoOutcome outcome;
  if (error.code == ethercat::make_error_code(ethercat::MasterErrc::sdo_abort)) {
    outcome.abort = error.abort_code;
    outcome.error = cia301::make_error_code(static_cast<cia301::SdoAbort>(error.abort_code));
  } else if (error.code == ethercat::make_error_code(ethercat::MasterErrc::mailbox_timeout)) {
    outcome.error = cia301::make_error_code(cia301::SdoClientError::timeout);
  } else {
    outcome.error = error.code;
  }
  return outcome;
}

bool answered(const SdoOutcome& outcome) {
  return outcome.ok || outcome.abort.has_value();
}

}  // namespace

std::error_code EthercatClock::send(const can::Frame& frame) {
  (void)frame;  // no CAN on this link: frame-level steps are not applicable here
  return std::make_error_code(std::errc::operation_not_supported);
}

std::optional<can::TimedFrame> EthercatClock::receive(can::TimePoint deadline) {
  stopped_ = false;
  port_.pass_time(deadline);
  return std::nullopt;
}

std::optional<ethercat::AlState> EthercatPort::al_state_of(cia301::NmtState state) {
  switch (state) {
    case cia301::NmtState::stopped:
      return ethercat::AlState::init;
    case cia301::NmtState::pre_operational:
      return ethercat::AlState::preop;
    case cia301::NmtState::operational:
      return ethercat::AlState::op;
    case cia301::NmtState::boot_up:
      break;
  }
  return std::nullopt;
}

bool EthercatPort::cyclic() const {
  const auto held = master_.held_state();
  return held == ethercat::AlState::safeop || held == ethercat::AlState::op;
}

void EthercatPort::run_cycle() {
  if (auto result = master_.cycle(); !result && cycle_error_.empty())
    cycle_error_ = result.error().message();
}

void EthercatPort::pass_time(can::TimePoint deadline) {
  auto& link = master_.port().link();
  if (!cyclic()) {
    link.run_until(deadline);
    return;
  }
  while (link.now() < deadline) {
    if (link.now() >= next_cycle_) {
      next_cycle_ = link.now() + cycle_;
      run_cycle();
    }
    const auto until = std::min(deadline, next_cycle_);
    const auto before = link.now();
    link.run_until(until);
    if (link.now() == before && link.now() < until) return;  // stop()
  }
}

std::string EthercatPort::take_cycle_error() {
  return std::exchange(cycle_error_, {});
}

std::string EthercatPort::request_state(ethercat::AlState state) {
  if (state == ethercat::AlState::op || state == ethercat::AlState::safeop) {
    // The outputs carry what the dictionary holds now: OP takes them (a zero controlword
    // would be a command).
    if (master_.held_state() != ethercat::AlState::op && !master_.slaves().empty()) {
      for (const auto& pdo : master_.slaves()[0].sii.image.rx_pdos) {
        for (const auto& entry : pdo.entries) {
          if (entry.index == 0) continue;
          auto value = master_.sdo_upload(0, {entry.index, entry.subindex});
          if (!value) continue;
          std::uint64_t v = 0;
          for (std::size_t i = 0; i < value->size() && i < 8; ++i)
            v |= std::uint64_t{(*value)[i]} << (8 * i);
          (void)master_.set_output(0, {entry.index, entry.subindex}, v);
        }
      }
    }
  }
  auto done = master_.request_state(state);
  next_cycle_ = master_.port().link().now();
  if (!done) return done.error().message();
  return {};
}

std::string EthercatPort::enter_state(cia301::NmtState state) {
  const auto al = al_state_of(state);
  if (!al) return "no AL state for NMT boot-up";
  return request_state(*al);
}

std::string EthercatPort::reset(bool node) {
  // A power cycle loses the station address and the ESC's configuration: a new bring-up (scan,
  // SII, INIT, PREOP). Otherwise AL INIT then PREOP; the master restarts its mailbox counters
  // with the slave's at INIT (Master::request_state).
  Expected<void, ethercat::MasterError> done;
  if (node && power_cycle_) {
    power_cycle_();
    done = master_.bring_up(ethercat::AlState::preop);
  } else {
    done = master_.request_state(ethercat::AlState::init);
    if (done) done = master_.request_state(ethercat::AlState::preop);
  }
  next_cycle_ = master_.port().link().now();
  if (!done) return done.error().message();
  return {};
}

bool EthercatPort::before_transfer(VectorRun& run, SdoOutcome& outcome) {
  if (run.vector_timed_out()) {
    outcome.error = cia301::make_error_code(cia301::SdoClientError::aborted_locally);
    outcome.vector_timed_out = true;
    return false;
  }
  // A process data cycle that is due runs first, so the SM watchdog stays fed.
  if (cyclic() && master_.port().link().now() >= next_cycle_) pass_time(next_cycle_);
  return true;
}

SdoOutcome EthercatPort::upload(VectorRun& run, const SdoRequest& request) {
  SdoOutcome outcome;
  if (!before_transfer(run, outcome)) return outcome;
  auto value = master_.sdo_upload(0, request.mux);
  if (value) {
    outcome.ok = true;
    outcome.data = std::move(*value);
  } else {
    outcome = outcome_of(value.error());
  }
  if (answered(outcome)) run.note_dut_answer();
  return outcome;
}

SdoOutcome EthercatPort::download(VectorRun& run, const SdoRequest& request,
                                  std::span<const std::uint8_t> data) {
  SdoOutcome outcome;
  if (!before_transfer(run, outcome)) return outcome;
  auto done = master_.sdo_download(0, request.mux, data);
  if (done) {
    outcome.ok = true;
    // The outputs carry the object too: the next cycle writes the same value.
    if (master_.locate(0, request.mux) && data.size() <= 8) {
      std::uint64_t v = 0;
      for (std::size_t i = 0; i < data.size(); ++i)
        v |= std::uint64_t{data[i]} << (8 * i);
      (void)master_.set_output(0, request.mux, v);
    }
  } else {
    outcome = outcome_of(done.error());
  }
  if (answered(outcome)) run.note_dut_answer();
  return outcome;
}

}  // namespace drivecheck::conformance
