// CoE SDO through the EtherCAT master; the engine's clock on the link (ethercat_port.hpp).
#include "conformance/ethercat_port.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <utility>

#include "conformance/vector_run.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "protocol/ethercat/coe_objects.hpp"
#include "protocol/ethercat/esc.hpp"
#include "protocol/profile/vocabulary.hpp"

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
  if (node && power_cycle_) {
    mapping_change_.reset();  // the slave's defaults and a fresh SII
    sync_mode_before_.reset();
  } else if (done) {
    if (auto error = restore_cyclic(); !error.empty())
      return fmt::format("putting the cyclic configuration back: {}", error);
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
  // `transfer: segmented` (a download that is not expedited, CiA 301 §7.2.4.3): a CoE normal
  // transfer, whatever the size; the rest as the size needs.
  const auto transfer = request.transfer == Transfer::segmented
                            ? ethercat::CoeDownloadTransfer::normal
                            : ethercat::CoeDownloadTransfer::expedited_if_it_fits;
  auto done = master_.sdo_download(0, request.mux, data, complete, transfer);
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

// ---- cyclic set-points ----

namespace {

std::uint32_t little_u32(std::span<const std::uint8_t> data) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < data.size() && i < 4; ++i)
    v |= std::uint32_t{data[i]} << (8 * i);
  return v;
}

std::vector<std::uint8_t> le(std::uint32_t value, std::size_t size) {
  std::vector<std::uint8_t> out(size);
  for (std::size_t i = 0; i < size; ++i)
    out[i] = static_cast<std::uint8_t>(value >> (8 * i));
  return out;
}

// A mapping entry (CiA 301 §7.5.2.36: index << 16 | sub-index << 8 | length in bits).
std::uint32_t mapping_entry(std::uint16_t index, std::uint8_t sub, std::uint8_t bits) {
  return std::uint32_t{index} << 16 | std::uint32_t{sub} << 8 | bits;
}

ethercat::SiiPdoEntry sii_entry(std::uint32_t mapping) {
  ethercat::SiiPdoEntry entry;
  entry.index = static_cast<std::uint16_t>(mapping >> 16);
  entry.subindex = static_cast<std::uint8_t>(mapping >> 8);
  entry.bit_length = static_cast<std::uint8_t>(mapping);
  return entry;
}

std::string sdo_error(const ethercat::MasterError& error) {
  if (error.code == ethercat::make_error_code(ethercat::MasterErrc::sdo_abort))
    return fmt::format("abort {:08X}h ({})", error.abort_code,
                       cia301::describe_sdo_abort(error.abort_code));
  return error.message();
}

}  // namespace

EthercatPort::CyclicSetup EthercatPort::prepare_cyclic(std::span<const CyclicSetPoint> points,
                                                       can::Duration period) {
  CyclicSetup result;
  if (master_.slaves().empty()) {
    result.error = "no slave";
    return result;
  }
  if (!cycle_before_) cycle_before_ = cycle_;
  cycle_ = period;
  if (master_.held_state() != ethercat::AlState::init &&
      master_.held_state() != ethercat::AlState::preop) {
    result.error = fmt::format("the RxPDO mapping is configured in PREOP, the slave is in {}",
                               ethercat::al_state_name(master_.held_state()));
    return result;
  }
  if (master_.held_state() == ethercat::AlState::init) {
    if (auto up = master_.request_state(ethercat::AlState::preop); !up) {
      result.error = fmt::format("PREOP: {}", up.error().message());
      return result;
    }
  }
  const auto read = [this](std::uint16_t index, std::uint8_t sub,
                           std::string& why) -> std::optional<std::uint32_t> {
    auto value = master_.sdo_upload(0, {index, sub});
    if (!value) {
      why = fmt::format("{:04X}h sub {}: {}", index, sub, sdo_error(value.error()));
      return std::nullopt;
    }
    return little_u32(*value);
  };
  std::string why;
  // SM-synchronous outputs where the slave supports them (1C32h:04 bit 1, ETG.1020).
  std::string sync;
  const auto mode = read(ethercat::kSmOutputParameter, 1, why);
  const auto supported = mode ? read(ethercat::kSmOutputParameter, 4, why) : std::nullopt;
  if (!mode || !supported) {
    sync = fmt::format("synchronisation as the slave has it (1C32h: {})", why);
  } else if (*mode == 1) {
    sync = "SM-synchronous (1C32h:01 = 1)";
  } else if ((*supported & 0x0002) == 0) {
    sync = fmt::format("1C32h:01 = {} kept: 1C32h:04 = {:04X}h, no SM-synchronous mode", *mode,
                       *supported);
  } else if (auto done = master_.sdo_download(0, {ethercat::kSmOutputParameter, 1}, le(1, 2));
             !done) {
    sync = fmt::format("1C32h:01 = {} kept: 1C32h:01 := 1 refused ({})", *mode,
                       sdo_error(done.error()));
  } else {
    sync_mode_before_ = static_cast<std::uint16_t>(*mode);
    sync = fmt::format("SM-synchronous: 1C32h:01 := 1 (was {})", *mode);
  }
  why.clear();
  // The RxPDOs the slave assigns now and their mappings (as a master reads them over CoE).
  const auto assigned_count = read(0x1C12, 0, why);
  if (!assigned_count) {
    result.not_applicable = fmt::format(
        "the RxPDO assignment 1C12h cannot be read ({}): the set-points must be in the process "
        "data outputs",
        why);
    return result;
  }
  std::vector<ethercat::SiiPdo> pdos;
  const auto read_pdo = [&](std::uint16_t index,
                            std::string& error) -> std::optional<ethercat::SiiPdo> {
    const auto count = read(index, 0, error);
    if (!count) return std::nullopt;
    ethercat::SiiPdo pdo;
    pdo.index = index;
    pdo.sync_manager = 2;  // the outputs' SM (SII SyncM type outputs)
    for (std::uint8_t sub = 1; sub <= *count; ++sub) {
      const auto entry = read(index, sub, error);
      if (!entry) return std::nullopt;
      pdo.entries.push_back(sii_entry(*entry));
    }
    return pdo;
  };
  for (std::uint8_t i = 1; i <= *assigned_count; ++i) {
    const auto index = read(0x1C12, i, why);
    auto pdo = index ? read_pdo(static_cast<std::uint16_t>(*index), why) : std::nullopt;
    if (!pdo) {
      result.error = fmt::format("reading the RxPDO assignment: {}", why);
      return result;
    }
    pdos.push_back(std::move(*pdo));
  }
  const auto mapped = [&pdos](const CyclicSetPoint& point) {
    for (const auto& pdo : pdos)
      for (const auto& entry : pdo.entries)
        if (entry.index == point.index && entry.subindex == point.sub) return true;
    return false;
  };
  std::vector<const CyclicSetPoint*> missing;
  std::vector<std::string> names;
  for (const CyclicSetPoint& point : points) {
    if (mapped(point)) continue;
    missing.push_back(&point);
    names.push_back(
        fmt::format("{:04X}h sub {} ({} bits)", point.index, point.sub, 8 * point.size));
  }
  const auto before = master_.slaves()[0].sii.image.rx_pdos;
  if (missing.empty()) {
    // The master plans by what the slave assigns (the SII lists the default).
    if (pdos != before) {
      if (auto planned = master_.set_pdos(0, true, pdos); !planned) {
        result.error = planned.error().message();
        return result;
      }
    }
    result.done = fmt::format(
        "the set-points already in the outputs; {}; a process data cycle "
        "every {}",
        sync, profile::format_duration(period));
    return result;
  }
  // Another RxPDO for the missing ones (ETG.1000.6: PDO configuration in PREOP): an unassigned
  // one that maps them already (a fixed mapping: only assigned) and nothing the assigned ones
  // map (an object twice in the outputs would get two values each cycle, the later one stale:
  // Festo's RPDO3 maps 6040h beside 607Ah, 000 §3.3.2 L1192-1202), else the first unassigned
  // one, its mapping written.
  std::optional<ethercat::SiiPdo> chosen;
  bool rewrite = false;
  std::optional<ethercat::SiiPdo> first_free;
  for (std::uint16_t index = 0x1600; index <= 0x160F && !chosen; ++index) {
    if (std::any_of(pdos.begin(), pdos.end(),
                    [index](const ethercat::SiiPdo& p) { return p.index == index; }))
      continue;
    std::string ignored;
    auto pdo = read_pdo(index, ignored);
    if (!pdo) continue;
    const bool holds = std::all_of(missing.begin(), missing.end(), [&](const CyclicSetPoint* p) {
      return std::any_of(pdo->entries.begin(), pdo->entries.end(), [p](const auto& e) {
        return e.index == p->index && e.subindex == p->sub;
      });
    });
    const bool doubles = std::any_of(pdo->entries.begin(), pdo->entries.end(), [&](const auto& e) {
      if (e.index < 0x1000) return false;  // a dummy entry (a data type index) maps no object
      return std::any_of(pdos.begin(), pdos.end(), [&e](const ethercat::SiiPdo& assigned) {
        return std::any_of(assigned.entries.begin(), assigned.entries.end(), [&e](const auto& a) {
          return a.index == e.index && a.subindex == e.subindex;
        });
      });
    });
    if (holds && !doubles) {
      chosen = std::move(*pdo);
    } else if (!first_free) {
      first_free = std::move(*pdo);
    }
  }
  if (!chosen && first_free) {
    chosen = first_free;
    rewrite = true;
  }
  if (!chosen) {
    result.not_applicable = fmt::format(
        "no RxPDO among 1600h-160Fh beside the assigned ones to carry {} (the set-points must "
        "be in the process data outputs)",
        fmt::join(names, ", "));
    return result;
  }
  CyclicChange change;
  change.master_before = before;
  change.assigned = static_cast<std::uint8_t>(*assigned_count);
  change.pdo = chosen->index;
  change.pdo_entries = chosen->entries;
  change.rewritten = rewrite;
  mapping_change_ = change;
  const auto write = [this](std::uint16_t index, std::uint8_t sub, std::uint32_t value,
                            std::size_t size) -> std::string {
    auto done = master_.sdo_download(0, {index, sub}, le(value, size));
    return done ? std::string()
                : fmt::format("{:04X}h sub {} := {:X}h: {}", index, sub, value,
                              sdo_error(done.error()));
  };
  std::string refused;
  if (rewrite) {
    // sub 0 := 0, the entries, sub 0 := their count (CiA 301 §7.5.2.36, ETG.1000.6).
    std::vector<ethercat::SiiPdoEntry> entries;
    refused = write(chosen->index, 0, 0, 1);
    for (std::size_t i = 0; refused.empty() && i < missing.size(); ++i) {
      const auto* p = missing[i];
      const auto value = mapping_entry(p->index, p->sub, static_cast<std::uint8_t>(8 * p->size));
      refused = write(chosen->index, static_cast<std::uint8_t>(i + 1), value, 4);
      entries.push_back(sii_entry(value));
    }
    if (refused.empty())
      refused = write(chosen->index, 0, static_cast<std::uint32_t>(missing.size()), 1);
    chosen->entries = entries;
  }
  // 1C12h: sub 0 := 0, the PDO after the assigned ones, sub 0 := their count.
  if (refused.empty()) {
    std::string ignored;
    mapping_change_->assignment_overwritten =
        read(0x1C12, static_cast<std::uint8_t>(change.assigned + 1), ignored);
    refused = write(0x1C12, 0, 0, 1);
  }
  if (refused.empty())
    refused = write(0x1C12, static_cast<std::uint8_t>(change.assigned + 1), chosen->index, 2);
  if (refused.empty())
    refused = write(0x1C12, 0, static_cast<std::uint32_t>(change.assigned + 1), 1);
  if (!refused.empty()) {
    (void)restore_mapping();
    result.not_applicable = fmt::format(
        "the slave refused the RxPDO {:04X}h for {}: {} (the set-points must be in the process "
        "data outputs)",
        chosen->index, fmt::join(names, ", "), refused);
    return result;
  }
  pdos.push_back(*chosen);
  if (auto planned = master_.set_pdos(0, true, pdos); !planned) {
    (void)restore_mapping();
    result.not_applicable =
        fmt::format("{} in the RxPDO {:04X}h, but the master cannot use it: {}",
                    fmt::join(names, ", "), chosen->index, planned.error().message());
    return result;
  }
  result.done = fmt::format(
      "{} {} the RxPDO {:04X}h, assigned in 1C12h after {} RxPDO(s); {}; a process data cycle "
      "every {}",
      fmt::join(names, ", "), rewrite ? "mapped into" : "already in", chosen->index,
      change.assigned, sync, profile::format_duration(period));
  return result;
}

std::string EthercatPort::restore_cyclic() {
  std::vector<std::string> errors;
  if (cycle_before_) {
    cycle_ = *cycle_before_;
    cycle_before_.reset();
  }
  if (auto error = restore_mapping(); !error.empty()) errors.push_back(error);
  if (sync_mode_before_) {
    const auto mode = *sync_mode_before_;
    sync_mode_before_.reset();
    if (auto done = master_.sdo_download(0, {ethercat::kSmOutputParameter, 1}, le(mode, 2)); !done)
      errors.push_back(fmt::format("1C32h sub 1 := {}: {}", mode, sdo_error(done.error())));
  }
  return fmt::format("{}", fmt::join(errors, "; "));
}

std::string EthercatPort::restore_mapping() {
  if (!mapping_change_) return {};
  const CyclicChange change = *mapping_change_;
  mapping_change_.reset();
  std::vector<std::string> errors;
  const auto write = [&](std::uint16_t index, std::uint8_t sub, std::uint32_t value,
                         std::size_t size) {
    auto done = master_.sdo_download(0, {index, sub}, le(value, size));
    if (!done)
      errors.push_back(fmt::format("{:04X}h sub {}: {}", index, sub, sdo_error(done.error())));
  };
  // 1C12h as it was (the entry past the old count only when it could be read), then the
  // mapping of the PDO when it was written.
  write(0x1C12, 0, 0, 1);
  if (change.assignment_overwritten)
    write(0x1C12, static_cast<std::uint8_t>(change.assigned + 1), *change.assignment_overwritten,
          2);
  write(0x1C12, 0, change.assigned, 1);
  if (change.rewritten) {
    write(change.pdo, 0, 0, 1);
    for (std::size_t i = 0; i < change.pdo_entries.size(); ++i) {
      const auto& e = change.pdo_entries[i];
      write(change.pdo, static_cast<std::uint8_t>(i + 1),
            mapping_entry(e.index, e.subindex, e.bit_length), 4);
    }
    write(change.pdo, 0, static_cast<std::uint32_t>(change.pdo_entries.size()), 1);
  }
  if (auto planned = master_.set_pdos(0, true, change.master_before); !planned)
    errors.push_back(planned.error().message());
  return fmt::format("{}", fmt::join(errors, "; "));
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
