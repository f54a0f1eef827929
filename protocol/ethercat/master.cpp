#include "protocol/ethercat/master.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivecheck::ethercat {
namespace {

// BOOT is no step on the way up: for the ladder it counts as INIT.
int rank(AlState state) {
  return state == AlState::boot ? 0 : al_state_rank(state);
}

constexpr AlState kLadder[] = {AlState::init, AlState::preop, AlState::safeop, AlState::op};

int rank_of_bits(std::uint8_t bits) {
  const auto state = al_state_from(bits);
  return state ? rank(*state) : 0;
}

}  // namespace

Master::Master(Link& link, MasterConfig config)
    : config_(std::move(config)), port_(link, config_.port) {}

Expected<void, MasterError> Master::check_slave(std::size_t slave) const {
  if (slave < slaves_.size()) return {};
  return master_error(
      MasterErrc::not_configured,
      fmt::format("no slave at position {} ({} found by the scan)", slave, slaves_.size()));
}

MasterMailbox* Master::mailbox(std::size_t slave) {
  return slave < slaves_.size() ? slaves_[slave].mailbox.get() : nullptr;
}

Expected<void, MasterError> Master::scan() {
  slaves_.clear();
  cycling_ = false;
  held_ = AlState::init;
  auto found = scan_segment(port_, config_.scan);
  if (!found) return Unexpected(found.error());
  std::vector<SlaveLayout> layouts;
  for (const SlaveInfo& info : *found) {
    auto sii = read_sii(port_, info.station, config_.sii);
    if (!sii) return Unexpected(sii.error());
    auto layout = plan_slave(sii->image, info.station);
    if (!layout) return Unexpected(layout.error());
    MasterSlave slave;
    slave.info = info;
    slave.sii = std::move(*sii);
    slave.layout = std::move(*layout);
    slaves_.push_back(std::move(slave));
    layouts.push_back(slaves_.back().layout);
  }
  const std::size_t size = assign_logical_addresses(layouts, config_.logical_base);
  // One LRW and the BRD of AL status (2 bytes) must fit one frame.
  if (size + 2 * kDatagramOverhead + 2 > kMaxDatagramBytes) {
    return master_error(MasterErrc::frame_too_long,
                        fmt::format("the process image of {} bytes does not fit one frame", size));
  }
  for (std::size_t i = 0; i < slaves_.size(); ++i) {
    slaves_[i].layout = layouts[i];
    if (layouts[i].mailbox_out) {
      slaves_[i].mailbox =
          std::make_unique<MasterMailbox>(port_, slaves_[i].layout, config_.mailbox);
    }
  }
  image_ = ProcessImage(layouts, config_.logical_base, size);
  return {};
}

Expected<void, MasterError> Master::set_pdos(std::size_t slave, bool outputs,
                                             std::vector<SiiPdo> pdos) {
  if (auto ok = check_slave(slave); !ok) return ok;
  if (cycling_ || rank(held_) > rank(AlState::preop)) {
    return master_error(MasterErrc::not_configured,
                        "a PDO configuration only in INIT or PREOP (the SMs are set on the way "
                        "to SAFEOP)");
  }
  std::vector<SlaveLayout> layouts;
  for (std::size_t i = 0; i < slaves_.size(); ++i) {
    SiiImage image = slaves_[i].sii.image;
    if (i == slave) (outputs ? image.rx_pdos : image.tx_pdos) = pdos;
    auto layout = plan_slave(image, slaves_[i].info.station);
    if (!layout) return Unexpected(layout.error());
    layouts.push_back(std::move(*layout));
  }
  const std::size_t size = assign_logical_addresses(layouts, config_.logical_base);
  if (size + 2 * kDatagramOverhead + 2 > kMaxDatagramBytes) {
    return master_error(MasterErrc::frame_too_long,
                        fmt::format("the process image of {} bytes does not fit one frame", size));
  }
  auto& image = slaves_[slave].sii.image;
  (outputs ? image.rx_pdos : image.tx_pdos) = std::move(pdos);
  for (std::size_t i = 0; i < slaves_.size(); ++i)
    slaves_[i].layout = layouts[i];
  image_ = ProcessImage(layouts, config_.logical_base, size);
  return {};
}

Expected<void, MasterError> Master::pdos_from_coe(std::size_t slave) {
  const SiiImage& sii = slaves_[slave].sii.image;
  if (!slaves_[slave].mailbox || (sii.header.mailbox_protocols & kSiiMailboxCoe) == 0) return {};
  std::vector<SiiPdo> rx = sii.rx_pdos;
  std::vector<SiiPdo> tx = sii.tx_pdos;
  bool changed = false;
  auto upload = [&](Multiplexer mux) -> Expected<std::uint32_t, MasterError> {
    auto bytes = sdo_upload(slave, mux);
    if (!bytes) return Unexpected(bytes.error());
    std::uint32_t value = 0;
    for (std::size_t i = 0; i < bytes->size() && i < 4; ++i)
      value |= static_cast<std::uint32_t>((*bytes)[i]) << (8 * i);
    return value;
  };
  // The PDOs of SM n from CoE; an sdo_abort when the slave has no such object (the SII's plan
  // stands for that SM then).
  auto read_sm = [&](std::size_t n) -> Expected<std::vector<SiiPdo>, MasterError> {
    std::vector<SiiPdo> pdos;
    const auto assign = static_cast<std::uint16_t>(0x1C10 + n);
    auto count = upload({assign, 0});
    if (!count) return Unexpected(count.error());
    for (std::uint32_t k = 1; k <= (*count & 0xFF); ++k) {
      auto index = upload({assign, static_cast<std::uint8_t>(k)});
      if (!index) return Unexpected(index.error());
      SiiPdo pdo;
      pdo.index = static_cast<std::uint16_t>(*index);
      pdo.sync_manager = static_cast<std::uint8_t>(n);
      auto entries = upload({pdo.index, 0});
      if (!entries) return Unexpected(entries.error());
      for (std::uint32_t j = 1; j <= (*entries & 0xFF); ++j) {
        auto entry = upload({pdo.index, static_cast<std::uint8_t>(j)});
        if (!entry) return Unexpected(entry.error());
        SiiPdoEntry e;
        e.index = static_cast<std::uint16_t>(*entry >> 16);
        e.subindex = static_cast<std::uint8_t>(*entry >> 8);
        e.bit_length = static_cast<std::uint8_t>(*entry);
        pdo.entries.push_back(e);
      }
      pdos.push_back(std::move(pdo));
    }
    return pdos;
  };
  for (std::size_t n = 0; n < sii.sync_managers.size() && n < 16; ++n) {
    const SiiSyncManagerType type = sii.sync_managers[n].type;
    const bool outputs = type == SiiSyncManagerType::outputs;
    if (!outputs && type != SiiSyncManagerType::inputs) continue;
    std::vector<SiiPdo>& list = outputs ? rx : tx;
    if (std::any_of(list.begin(), list.end(),
                    [&](const SiiPdo& pdo) { return pdo.sync_manager == n; })) {
      continue;
    }
    auto pdos = read_sm(n);
    if (!pdos) {
      if (pdos.error().code == MasterErrc::sdo_abort) continue;
      return Unexpected(pdos.error());
    }
    changed = changed || !pdos->empty();
    for (SiiPdo& pdo : *pdos)
      list.push_back(std::move(pdo));
  }
  if (!changed) return {};
  if (auto ok = set_pdos(slave, true, std::move(rx)); !ok) return ok;
  return set_pdos(slave, false, std::move(tx));
}

void Master::restart_mailbox(std::size_t slave) {
  if (slaves_[slave].mailbox) slaves_[slave].mailbox->protocol().reset();
}

Expected<void, MasterError> Master::bring_up(AlState target) {
  if (auto scanned = scan(); !scanned) return scanned;
  for (std::size_t i = 0; i < slaves_.size(); ++i) {
    auto init = request_al_state(port_, slaves_[i].info.station, AlState::init, config_.al);
    if (!init) return Unexpected(init.error());
    slaves_[i].al = *init;
    restart_mailbox(i);
  }
  return request_state(target);
}

Expected<void, MasterError> Master::step(std::size_t slave, AlState from, AlState to) {
  MasterSlave& s = slaves_[slave];
  AlOptions options = config_.al;
  if (from == AlState::init && to == AlState::preop) {
    // Also when the slave fell to INIT on its own: its mailbox handler starts afresh.
    restart_mailbox(slave);
    if (auto written = write_mailbox_setup(port_, s.layout); !written) return written;
  } else if (from == AlState::preop && to == AlState::safeop) {
    if (auto coe = pdos_from_coe(slave); !coe) return coe;
    if (auto written = write_process_data_setup(port_, s.layout); !written) return written;
  } else if (from == AlState::safeop && to == AlState::op) {
    // Valid outputs before OP, and the SM watchdog fed while the slave gets there.
    (void)image_.cycle(port_);
    options.between_polls = [this] { (void)image_.cycle(port_); };
  }
  auto reached = request_al_state(port_, s.info.station, to, options);
  if (!reached) return Unexpected(reached.error());
  s.al = *reached;
  return {};
}

Expected<void, MasterError> Master::request_state(std::size_t slave, AlState target) {
  if (auto ok = check_slave(slave); !ok) return ok;
  auto now = read_al_status(port_, slaves_[slave].info.station);
  if (!now) return Unexpected(now.error());
  slaves_[slave].al = *now;
  const int from = rank_of_bits(now->state_bits());
  if (target == AlState::boot || rank(target) <= from) {
    auto reached = request_al_state(port_, slaves_[slave].info.station, target, config_.al);
    if (!reached) return Unexpected(reached.error());
    slaves_[slave].al = *reached;
    if (target == AlState::init) restart_mailbox(slave);
    return {};
  }
  for (int level = from + 1; level <= rank(target); ++level) {
    if (auto ok = step(slave, kLadder[level - 1], kLadder[level]); !ok) return ok;
  }
  return {};
}

Expected<void, MasterError> Master::request_state(AlState target) {
  if (slaves_.empty()) {
    return master_error(MasterErrc::not_configured, "no slaves: scan() or bring_up() first");
  }
  auto states = read_states();
  if (!states) return Unexpected(states.error());
  if (target != AlState::boot) {
    // Upwards level by level for all slaves (every slave in SAFEOP before the first goes to OP).
    for (int level = 1; level <= rank(target); ++level) {
      for (std::size_t i = 0; i < slaves_.size(); ++i) {
        if (rank_of_bits(slaves_[i].al.state_bits()) >= level) continue;
        if (auto ok = step(i, kLadder[level - 1], kLadder[level]); !ok) return ok;
      }
      if (kLadder[level] == AlState::safeop) cycling_ = true;
    }
  }
  for (std::size_t i = 0; i < slaves_.size(); ++i) {
    if (target != AlState::boot && rank_of_bits(slaves_[i].al.state_bits()) <= rank(target) &&
        !slaves_[i].al.error()) {
      continue;
    }
    auto reached = request_al_state(port_, slaves_[i].info.station, target, config_.al);
    if (!reached) return Unexpected(reached.error());
    slaves_[i].al = *reached;
    if (target == AlState::init) restart_mailbox(i);
  }
  held_ = target;
  if (rank(target) < 2) cycling_ = false;
  return {};
}

std::optional<PdoEntryPlace> Master::locate(std::size_t slave, Multiplexer mux) const {
  if (slave >= slaves_.size()) return std::nullopt;
  return locate_pdo_entry(slaves_[slave].sii.image, slaves_[slave].layout, mux.index,
                          mux.sub_index);
}

std::optional<std::uint64_t> Master::input(std::size_t slave, Multiplexer mux) const {
  const auto place = locate(slave, mux);
  if (!place) return std::nullopt;
  return get_bits(place->outputs ? image_.outputs_view(slave) : image_.inputs(slave),
                  place->bit_offset, place->bit_length);
}

bool Master::set_output(std::size_t slave, Multiplexer mux, std::uint64_t value) {
  const auto place = locate(slave, mux);
  if (!place || !place->outputs) return false;
  set_bits(image_.outputs(slave), place->bit_offset, place->bit_length, value);
  return true;
}

Expected<std::vector<AlReading>, MasterError> Master::read_states() {
  std::vector<AlReading> out;
  for (MasterSlave& slave : slaves_) {
    auto reading = read_al_status(port_, slave.info.station);
    if (!reading) return Unexpected(reading.error());
    slave.al = *reading;
    out.push_back(*reading);
  }
  return out;
}

MasterError Master::explain_cycle(const CycleResult& result) {
  std::string states;
  std::uint16_t code = 0;
  std::uint16_t station = 0;
  bool lost = false;
  if (auto readings = read_states()) {
    for (std::size_t i = 0; i < readings->size(); ++i) {
      const AlReading& r = (*readings)[i];
      if (r.in(held_) && !r.error()) continue;
      states += fmt::format("; slave {} (station {:04X}h) is {}", i, r.station, r.describe());
      if (station == 0) station = r.station;
      if (r.error() && code == 0) {
        code = r.code;
        station = r.station;
      }
      lost = true;
    }
  } else {
    states = "; AL status unreadable: " + readings.error().detail;
  }
  MasterError e;
  e.station = station;
  e.al_status_code = code;
  if (!result.wkc_ok()) {
    e.code = MasterErrc::process_data_wkc;
    e.detail = fmt::format("LRW working counter {}, expected {} ({} slaves){}", result.wkc,
                           result.expected_wkc, slaves_.size(), states);
  } else if (result.al_wkc != slaves_.size()) {
    e.code = MasterErrc::slave_count;
    e.detail = fmt::format("BRD 0130h counted {} slave(s), expected {}{}", result.al_wkc,
                           slaves_.size(), states);
  } else {
    e.code = MasterErrc::al_state_lost;
    e.detail = fmt::format("a slave left {} (AL status OR {:04X}h){}", al_state_name(held_),
                           result.al_status, lost ? states : std::string());
  }
  return e;
}

Expected<CycleResult, MasterError> Master::cycle() {
  if (!cycling_) {
    return master_error(MasterErrc::not_configured,
                        "process data is configured on the way to SAFEOP: request_state first");
  }
  auto result = image_.cycle(port_);
  if (!result) return result;
  last_cycle_ = *result;
  const auto expected_status = static_cast<std::uint16_t>(held_);
  if (!result->wkc_ok() || result->al_wkc != slaves_.size() ||
      (result->al_status & 0x1F) != expected_status) {
    return Unexpected(explain_cycle(*result));
  }
  return result;
}

Expected<std::vector<std::uint8_t>, MasterError> Master::sdo_upload(std::size_t slave,
                                                                    Multiplexer mux,
                                                                    bool complete_access) {
  if (auto ok = check_slave(slave); !ok) return Unexpected(ok.error());
  if (!slaves_[slave].mailbox) {
    return master_error(MasterErrc::not_configured, fmt::format("slave {} has no mailbox", slave));
  }
  return slaves_[slave].mailbox->sdo_upload(mux, complete_access);
}

Expected<void, MasterError> Master::sdo_download(std::size_t slave, Multiplexer mux,
                                                 std::span<const std::uint8_t> data,
                                                 bool complete_access,
                                                 CoeDownloadTransfer transfer) {
  if (auto ok = check_slave(slave); !ok) return ok;
  if (!slaves_[slave].mailbox) {
    return master_error(MasterErrc::not_configured, fmt::format("slave {} has no mailbox", slave));
  }
  return slaves_[slave].mailbox->sdo_download(mux, data, complete_access, transfer);
}

std::vector<CoeEmergency> Master::take_emergencies(std::size_t slave) {
  std::vector<CoeEmergency> out;
  if (slave >= slaves_.size() || !slaves_[slave].mailbox) return out;
  auto& queue = slaves_[slave].mailbox->emergencies();
  out.assign(queue.begin(), queue.end());
  queue.clear();
  return out;
}

Expected<void, MasterError> Master::poll_mailbox(std::size_t slave) {
  if (auto ok = check_slave(slave); !ok) return ok;
  MasterMailbox* mailbox = slaves_[slave].mailbox.get();
  if (!mailbox) return {};
  for (;;) {
    auto message = mailbox->poll();
    if (!message) return Unexpected(message.error());
    if (!*message) return {};
    const MailboxIn& in = **message;
    if (in.header.type == static_cast<std::uint8_t>(MailboxType::coe) &&
        peek_coe_service(in.data) == static_cast<std::uint8_t>(CoeService::emergency)) {
      if (auto emergency = decode_emergency(in.data)) {
        mailbox->emergencies().push_back(std::move(*emergency));
      }
    }
  }
}

}  // namespace drivecheck::ethercat
