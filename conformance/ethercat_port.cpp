// CoE SDO through the EtherCAT master; the engine's clock on the link (ethercat_port.hpp).
#include "conformance/ethercat_port.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "conformance/vector_run.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "protocol/ethercat/esc.hpp"

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
  if (master_.port().now() < paused_until_) return false;
  const auto held = master_.held_state();
  return held == ethercat::AlState::safeop || held == ethercat::AlState::op;
}

void EthercatPort::run_cycle() {
  if (auto result = master_.cycle(); !result && cycle_error_.empty())
    cycle_error_ = result.error().message();
}

void EthercatPort::pass_time(can::TimePoint deadline) {
  auto& link = master_.port().link();
  if (link.now() < paused_until_ && paused_until_ < deadline) {
    link.run_until(paused_until_);           // no cycle while paused, then as usual
    if (link.now() < paused_until_) return;  // stop()
  }
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
  emergencies_.clear();
  raw_open_ = false;  // INIT stops the slave's mailbox: no reply of before can come
  raw_replies_.clear();
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
  settle_raw(run.resolve({{}, "sdo_response"}));
  return true;
}

SdoOutcome EthercatPort::upload(VectorRun& run, const SdoRequest& request) {
  SdoOutcome outcome;
  if (!before_transfer(run, outcome)) return outcome;
  auto value = master_.sdo_upload(0, request.mux, request.transfer == Transfer::complete_access);
  if (value) {
    outcome.ok = true;
    outcome.data = std::move(*value);
  } else {
    outcome = outcome_of(value.error());
  }
  if (answered(outcome)) run.note_dut_answer();
  collect_emergencies(false);
  return outcome;
}

SdoOutcome EthercatPort::download(VectorRun& run, const SdoRequest& request,
                                  std::span<const std::uint8_t> data) {
  SdoOutcome outcome;
  if (!before_transfer(run, outcome)) return outcome;
  // Isolation (isolation.hpp) learns what the vector wrote from here: there are no SDO frames
  // on this link for it to read.
  run.note_download_request(request.mux, data.size());
  const bool complete = request.transfer == Transfer::complete_access;
  auto done = master_.sdo_download(0, request.mux, data, complete);
  if (done) {
    outcome.ok = true;
    run.note_confirmed_download(request.mux);
    // The outputs carry the object too: the next cycle writes the same value.
    if (!complete && master_.locate(0, request.mux) && data.size() <= 8) {
      std::uint64_t v = 0;
      for (std::size_t i = 0; i < data.size(); ++i)
        v |= std::uint64_t{data[i]} << (8 * i);
      (void)master_.set_output(0, request.mux, v);
    }
  } else {
    outcome = outcome_of(done.error());
  }
  if (answered(outcome)) run.note_dut_answer();
  collect_emergencies(false);
  return outcome;
}

void EthercatPort::collect_emergencies(bool poll) {
  if (master_.slaves().empty()) return;
  if (poll && raw_open_) {
    // A raw request's reply may be in the read mailbox: keep it (poll_mailbox drops it).
    std::string error;
    while (poll_raw(error)) {
    }
  } else if (poll) {
    (void)master_.poll_mailbox(0);  // a broken mailbox shows in the next SDO
  }
  const auto at = master_.port().now();
  for (auto& message : master_.take_emergencies(0))
    emergencies_.push_back({at, std::move(message), false});
}

// ---- raw SDO ----

std::string EthercatPort::send_raw_sdo(std::span<const std::uint8_t> sdo) {
  auto* mailbox = master_.mailbox(0);
  if (mailbox == nullptr) return "slave 0 has no mailbox";
  // A reply to an earlier raw request still on its way is kept, not taken for this one's.
  std::string error;
  while (poll_raw(error)) {
  }
  std::vector<std::uint8_t> data(ethercat::kCoeHeaderSize);
  ethercat::CoeHeader header;
  header.service = static_cast<std::uint8_t>(ethercat::CoeService::sdo_request);
  ethercat::encode_coe_header(header, std::span<std::uint8_t, 2>(data.data(), 2));
  data.insert(data.end(), sdo.begin(), sdo.end());
  if (auto sent = mailbox->send(ethercat::MailboxType::coe, data); !sent)
    return sent.error().message();
  raw_open_ = true;
  return {};
}

bool EthercatPort::poll_raw(std::string& error) {
  auto* mailbox = master_.mailbox(0);
  if (mailbox == nullptr) {
    error = "slave 0 has no mailbox";
    return false;
  }
  auto message = mailbox->poll();
  if (!message) {
    error = message.error().message();
    return false;
  }
  if (!*message) return false;
  auto& in = **message;
  if (!in.error && in.header.type == static_cast<std::uint8_t>(ethercat::MailboxType::coe) &&
      ethercat::peek_coe_service(in.data) ==
          static_cast<std::uint8_t>(ethercat::CoeService::emergency)) {
    if (auto emergency = ethercat::decode_emergency(in.data))
      mailbox->emergencies().push_back(std::move(*emergency));
    collect_emergencies(false);  // stamped now
    return true;
  }
  raw_replies_.push_back({master_.port().now(), in.header.type, std::move(in.data), in.error});
  raw_open_ = false;
  mailbox->protocol().reply_matched();
  return true;
}

std::optional<EthercatPort::RawReply> EthercatPort::receive_raw(can::TimePoint deadline,
                                                                std::string& error) {
  auto& link = master_.port().link();
  can::Duration interval = std::chrono::microseconds(20);
  for (;;) {
    if (!raw_replies_.empty()) {
      RawReply reply = std::move(raw_replies_.front());
      raw_replies_.pop_front();
      return reply;
    }
    if (!poll_raw(error) && !error.empty()) return std::nullopt;
    if (!raw_replies_.empty()) continue;
    if (link.now() >= deadline) return std::nullopt;
    const auto before = link.now();
    pass_time(std::min(deadline, link.now() + interval));
    if (link.now() == before) return std::nullopt;  // stop()
    interval = std::min<can::Duration>(interval * 2, std::chrono::milliseconds(1));
  }
}

void EthercatPort::settle_raw(can::Duration timeout) {
  if (!raw_open_) return;
  auto& link = master_.port().link();
  const auto deadline = link.now() + timeout;
  std::string error;
  while (raw_open_ && link.now() < deadline) {
    if (poll_raw(error)) continue;
    if (!error.empty()) break;
    const auto before = link.now();
    pass_time(std::min(deadline, link.now() + std::chrono::microseconds(100)));
    if (link.now() == before) break;  // stop()
  }
  // No reply (or a broken mailbox, which the next transfer reports): the master goes on.
  if (raw_open_) {
    raw_open_ = false;
    if (auto* mailbox = master_.mailbox(0)) mailbox->protocol().reply_matched();
  }
}

// ---- raw access for the EtherCAT-only steps ----

std::optional<ethercat::AlReading> EthercatPort::al_status(std::string& error) {
  if (master_.slaves().empty()) {
    error = "no slave (the bring-up failed)";
    return std::nullopt;
  }
  auto reading = ethercat::read_al_status(master_.port(), master_.slaves()[0].info.station);
  if (!reading) {
    error = reading.error().message();
    return std::nullopt;
  }
  return *reading;
}

std::optional<ethercat::AlReading> EthercatPort::raw_al_request(ethercat::AlState state,
                                                                can::TimePoint deadline,
                                                                std::string& error) {
  auto before = al_status(error);
  if (!before) return std::nullopt;
  auto control = static_cast<std::uint16_t>(state);
  if (before->error()) control |= ethercat::kAlControlAcknowledge;
  if (auto written = master_.port().write(ethercat::Command::fpwr, before->station,
                                          ethercat::reg::kAlControl, ethercat::le16(control));
      !written) {
    error = written.error().message();
    return std::nullopt;
  }
  auto& link = master_.port().link();
  for (;;) {
    pass_time(std::min(deadline, link.now() + std::chrono::milliseconds(1)));
    auto now = al_status(error);
    if (!now) return std::nullopt;
    if (now->error() || now->in(state) || link.now() >= deadline) return now;
  }
}

std::string EthercatPort::settle() {
  auto done = master_.request_state(master_.held_state());
  next_cycle_ = master_.port().link().now();
  if (!done) return done.error().message();
  return {};
}

EthercatPort::CycleOutcome EthercatPort::checked_cycle() {
  auto& link = master_.port().link();
  if (link.now() < next_cycle_) pass_time(next_cycle_);
  next_cycle_ = link.now() + cycle_;
  CycleOutcome outcome;
  const auto before = master_.port().frames_sent();
  auto result = master_.cycle();
  if (result) {
    outcome.result = *result;
  } else {
    outcome.error = result.error().message();
    // The LRW came back but the master found it wrong: its counts are in last_cycle().
    if (master_.port().frames_sent() > before &&
        result.error().code != ethercat::make_error_code(ethercat::MasterErrc::no_response))
      outcome.result = master_.last_cycle();
  }
  return outcome;
}

std::optional<can::Duration> EthercatPort::sm_watchdog_time(std::string& error) {
  if (master_.slaves().empty()) {
    error = "no slave (the bring-up failed)";
    return std::nullopt;
  }
  const auto station = master_.slaves()[0].info.station;
  auto divider =
      master_.port().read(ethercat::Command::fprd, station, ethercat::reg::kWatchdogDivider, 2);
  auto time = master_.port().read(ethercat::Command::fprd, station,
                                  ethercat::reg::kWatchdogTimeProcessData, 2);
  if (!divider || !time) {
    error = (!divider ? divider.error() : time.error()).message();
    return std::nullopt;
  }
  // ESC datasheet Section II 0400h/0420h: one watchdog increment is (divider + 2) x 40 ns.
  const std::int64_t ticks =
      std::int64_t{ethercat::get_le16(*time)} * (std::int64_t{ethercat::get_le16(*divider)} + 2);
  return std::chrono::nanoseconds(ticks * 40);
}

std::uint8_t EthercatPort::last_mailbox_counter() {
  auto* mailbox = master_.mailbox(0);
  return mailbox == nullptr ? 0 : mailbox->protocol().last_request_counter();
}

std::optional<std::size_t> EthercatPort::repeat_download(cia301::Multiplexer mux,
                                                         std::span<const std::uint8_t> data,
                                                         can::TimePoint until, std::string& error) {
  auto* mailbox = master_.mailbox(0);
  if (mailbox == nullptr || master_.slaves().empty() || !master_.slaves()[0].layout.mailbox_out) {
    error = "slave 0 has no mailbox";
    return std::nullopt;
  }
  const auto& out = *master_.slaves()[0].layout.mailbox_out;
  ethercat::CoeSdoClient client;
  const auto request = client.start_download(mux, data);
  ethercat::MailboxHeader header;
  header.type = static_cast<std::uint8_t>(ethercat::MailboxType::coe);
  header.counter = mailbox->protocol().last_request_counter();
  auto& link = master_.port().link();
  // SM0 takes a write only while empty (working counter 0 otherwise): tried until `until`.
  for (;;) {
    auto written =
        master_.port().write(ethercat::Command::fpwr, master_.slaves()[0].info.station, out.start,
                             ethercat::build_mailbox(header, request, out.length));
    if (written) break;
    if (link.now() >= until) {
      error = fmt::format("the write mailbox did not take the repeated request: {}",
                          written.error().message());
      return std::nullopt;
    }
    pass_time(std::min(until, link.now() + std::chrono::milliseconds(1)));
  }
  std::size_t replies = 0;
  while (link.now() < until) {
    pass_time(std::min(until, link.now() + std::chrono::milliseconds(1)));
    auto message = mailbox->poll();
    if (!message) {
      error = message.error().message();
      return std::nullopt;
    }
    if (!*message) continue;
    const auto& in = **message;
    if (in.header.type == static_cast<std::uint8_t>(ethercat::MailboxType::coe) &&
        ethercat::peek_coe_service(in.data) ==
            static_cast<std::uint8_t>(ethercat::CoeService::emergency)) {
      if (auto emergency = ethercat::decode_emergency(in.data))
        mailbox->emergencies().push_back(std::move(*emergency));
      continue;  // an emergency is no reply
    }
    ++replies;
  }
  return replies;
}

}  // namespace drivecheck::conformance
