#include "protocol/ethercat/master_config.hpp"

#include <fmt/format.h>

#include "protocol/ethercat/esc.hpp"

namespace drivecheck::ethercat {
namespace {

constexpr std::uint8_t kDefaultMailboxOut = 0x26;
constexpr std::uint8_t kDefaultMailboxIn = 0x22;
constexpr std::uint8_t kDefaultOutputs = 0x64;
constexpr std::uint8_t kDefaultInputs = 0x20;

std::optional<std::uint8_t> sii_control(const SiiImage& sii, SiiSyncManagerType type) {
  for (const SiiSyncManager& sm : sii.sync_managers) {
    if (sm.type == type && sm.control != 0) return sm.control;
  }
  return std::nullopt;
}

std::size_t pdo_bits(const std::vector<SiiPdo>& pdos, std::size_t sm, bool& any) {
  std::size_t bits = 0;
  for (const SiiPdo& pdo : pdos) {
    if (pdo.sync_manager != sm) continue;
    any = true;
    for (const SiiPdoEntry& entry : pdo.entries)
      bits += entry.bit_length;
  }
  return bits;
}

}  // namespace

std::optional<PdoEntryPlace> locate_pdo_entry(const SiiImage& sii, const SlaveLayout& layout,
                                              std::uint16_t index, std::uint8_t sub_index) {
  for (const bool outputs : {true, false}) {
    std::size_t sm_base = 0;  // bits of the earlier SMs of this direction
    for (const SyncManagerSetup& sm : layout.process_data) {
      if (sm.outputs != outputs) continue;
      std::size_t bit = sm_base;
      for (const SiiPdo& pdo : outputs ? sii.rx_pdos : sii.tx_pdos) {
        if (pdo.sync_manager != sm.index) continue;
        for (const SiiPdoEntry& entry : pdo.entries) {
          if (entry.index == index && entry.subindex == sub_index && entry.bit_length > 0) {
            if (bit + entry.bit_length > sm_base + sm.length * std::size_t{8}) return std::nullopt;
            return PdoEntryPlace{outputs, bit, entry.bit_length};
          }
          bit += entry.bit_length;
        }
      }
      sm_base += sm.length * std::size_t{8};
    }
  }
  return std::nullopt;
}

std::uint64_t get_bits(std::span<const std::uint8_t> bytes, std::size_t bit_offset,
                       unsigned bit_length) {
  std::uint64_t value = 0;
  for (unsigned i = 0; i < bit_length && i < 64; ++i) {
    const std::size_t bit = bit_offset + i;
    if (bit / 8 >= bytes.size()) break;
    if ((bytes[bit / 8] >> (bit % 8)) & 1u) value |= std::uint64_t{1} << i;
  }
  return value;
}

void set_bits(std::span<std::uint8_t> bytes, std::size_t bit_offset, unsigned bit_length,
              std::uint64_t value) {
  for (unsigned i = 0; i < bit_length && i < 64; ++i) {
    const std::size_t bit = bit_offset + i;
    if (bit / 8 >= bytes.size()) break;
    const auto mask = static_cast<std::uint8_t>(1u << (bit % 8));
    if ((value >> i) & 1u) {
      bytes[bit / 8] |= mask;
    } else {
      bytes[bit / 8] &= static_cast<std::uint8_t>(~mask);
    }
  }
}

std::vector<std::uint8_t> sync_manager_bytes(const SyncManagerSetup& sm, bool enable) {
  return sync_manager_block(sm.start, sm.length, sm.control, enable);
}

std::vector<std::uint8_t> fmmu_bytes(const FmmuSetup& fmmu) {
  return fmmu_block(fmmu.logical, fmmu.length, fmmu.physical, fmmu.type);
}

Expected<SlaveLayout, MasterError> plan_slave(const SiiImage& sii, std::uint16_t station) {
  SlaveLayout layout;
  layout.station = station;
  const SiiHeader& h = sii.header;
  SiiMailbox receive = h.standard_receive;
  SiiMailbox send = h.standard_send;
  // Words 18h..1Bh are the standard mailbox configuration; a SII that leaves them 0 but lists
  // the mailboxes as SyncM entries 0 and 1 (types 1 and 2) gets them from there.
  if (receive.size == 0 && send.size == 0 && sii.sync_managers.size() >= 2 &&
      sii.sync_managers[0].type == SiiSyncManagerType::mailbox_out &&
      sii.sync_managers[1].type == SiiSyncManagerType::mailbox_in) {
    receive = {sii.sync_managers[0].start, sii.sync_managers[0].length};
    send = {sii.sync_managers[1].start, sii.sync_managers[1].length};
  }
  if (receive.size != 0 || send.size != 0) {
    if (receive.size < 6 || send.size < 6) {
      return master_error(MasterErrc::sii_unsupported,
                          fmt::format("station {:04X}h: SII mailbox sizes {} (receive) and {} "
                                      "(send) leave no room for a mailbox header",
                                      station, receive.size, send.size),
                          station);
    }
    layout.mailbox_out = SyncManagerSetup{
        0, receive.offset, receive.size,
        sii_control(sii, SiiSyncManagerType::mailbox_out).value_or(kDefaultMailboxOut), false};
    layout.mailbox_in = SyncManagerSetup{
        1, send.offset, send.size,
        sii_control(sii, SiiSyncManagerType::mailbox_in).value_or(kDefaultMailboxIn), false};
  }
  for (std::size_t n = 0; n < sii.sync_managers.size() && n < 16; ++n) {
    const SiiSyncManager& entry = sii.sync_managers[n];
    const bool outputs = entry.type == SiiSyncManagerType::outputs;
    const bool inputs = entry.type == SiiSyncManagerType::inputs;
    if (!outputs && !inputs) continue;
    bool any_pdo = false;
    const std::size_t bits = pdo_bits(outputs ? sii.rx_pdos : sii.tx_pdos, n, any_pdo);
    const std::size_t length = any_pdo ? (bits + 7) / 8 : entry.length;
    if (length == 0) continue;
    if (length > 0xFFFF || entry.start < reg::kProcessRam) {
      return master_error(MasterErrc::sii_unsupported,
                          fmt::format("station {:04X}h: SII SyncM {} (start {:04X}h, {} bytes) "
                                      "cannot hold process data",
                                      station, n, entry.start, length),
                          station);
    }
    SyncManagerSetup sm;
    sm.index = static_cast<unsigned>(n);
    sm.start = entry.start;
    sm.length = static_cast<std::uint16_t>(length);
    sm.control = entry.control != 0 ? entry.control : (outputs ? kDefaultOutputs : kDefaultInputs);
    sm.outputs = outputs;
    layout.process_data.push_back(sm);
    (outputs ? layout.output_bytes : layout.input_bytes) += length;
  }
  return layout;
}

std::size_t assign_logical_addresses(std::vector<SlaveLayout>& slaves, std::uint32_t base) {
  std::size_t offset = 0;
  for (SlaveLayout& slave : slaves) {
    slave.fmmus.clear();
    for (const bool outputs : {true, false}) {
      (outputs ? slave.output_offset : slave.input_offset) = offset;
      for (const SyncManagerSetup& sm : slave.process_data) {
        if (sm.outputs != outputs) continue;
        FmmuSetup fmmu;
        fmmu.index = static_cast<unsigned>(slave.fmmus.size());
        fmmu.logical = base + static_cast<std::uint32_t>(offset);
        fmmu.length = sm.length;
        fmmu.physical = sm.start;
        fmmu.type = outputs ? 2 : 1;
        slave.fmmus.push_back(fmmu);
        offset += sm.length;
      }
    }
  }
  return offset;
}

Expected<void, MasterError> write_mailbox_setup(MasterPort& port, const SlaveLayout& layout) {
  for (const auto* sm : {&layout.mailbox_out, &layout.mailbox_in}) {
    if (!*sm) continue;
    const std::uint16_t address = reg::sync_manager((*sm)->index);
    if (auto off =
            port.write(Command::fpwr, layout.station, static_cast<std::uint16_t>(address + 6), {0});
        !off) {
      return off;
    }
    if (auto on =
            port.write(Command::fpwr, layout.station, address, sync_manager_bytes(**sm, true));
        !on) {
      return on;
    }
  }
  return {};
}

Expected<void, MasterError> write_process_data_setup(MasterPort& port, const SlaveLayout& layout) {
  for (const SyncManagerSetup& sm : layout.process_data) {
    const std::uint16_t address = reg::sync_manager(sm.index);
    if (auto off =
            port.write(Command::fpwr, layout.station, static_cast<std::uint16_t>(address + 6), {0});
        !off) {
      return off;
    }
    if (auto on = port.write(Command::fpwr, layout.station, address, sync_manager_bytes(sm, true));
        !on) {
      return on;
    }
  }
  for (const FmmuSetup& fmmu : layout.fmmus) {
    if (auto written =
            port.write(Command::fpwr, layout.station, reg::fmmu(fmmu.index), fmmu_bytes(fmmu));
        !written) {
      return written;
    }
  }
  return {};
}

}  // namespace drivecheck::ethercat
