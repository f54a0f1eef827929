#include "protocol/ethercat/esc.hpp"

#include <algorithm>
#include <iterator>

#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/sii.hpp"

namespace drivecheck::ethercat {
namespace {

constexpr EscRegisterInfo kRegisters[] = {
#define DRIVECHECK_ESC_REGISTER(name, address, size, ecat, pdi, text) \
  {#name, address, size, EscAccess::ecat, EscAccess::pdi, text},
#include "protocol/ethercat/esc_registers.inc"
#undef DRIVECHECK_ESC_REGISTER
};

constexpr bool registers_sorted_and_disjoint() {
  for (std::size_t i = 1; i < std::size(kRegisters); ++i) {
    if (kRegisters[i - 1].address + kRegisters[i - 1].size > kRegisters[i].address) return false;
  }
  return kRegisters[std::size(kRegisters) - 1].address +
             kRegisters[std::size(kRegisters) - 1].size <=
         0x1000;
}
static_assert(registers_sorted_and_disjoint(),
              "esc_registers.inc: ascending, non-overlapping, below 1000h");

constexpr bool is_register(std::uint16_t address, std::uint16_t size) {
  for (const EscRegisterInfo& row : kRegisters) {
    if (row.address == address && row.size == size) return true;
  }
  return false;
}
// The named constants of esc.hpp are rows of the table.
static_assert(is_register(reg::kStationAddress, 2) && is_register(reg::kStationAlias, 2) &&
              is_register(reg::kDlControl, 4) && is_register(reg::kDlStatus, 2) &&
              is_register(reg::kAlControl, 2) && is_register(reg::kAlStatus, 2) &&
              is_register(reg::kAlStatusCode, 2) && is_register(reg::kAlEventRequest, 4) &&
              is_register(reg::kRxErrorCounter, 8) &&
              is_register(reg::kProcessingErrorCounter, 1) &&
              is_register(reg::kWatchdogDivider, 2) && is_register(reg::kWatchdogTimePdi, 2) &&
              is_register(reg::kWatchdogTimeProcessData, 2) &&
              is_register(reg::kWatchdogStatus, 2) && is_register(reg::kWatchdogCounterPd, 1) &&
              is_register(reg::kSiiConfiguration, 1) && is_register(reg::kSiiPdiAccess, 1) &&
              is_register(reg::kSiiControl, 2) && is_register(reg::kSiiAddress, 4) &&
              is_register(reg::kSiiData, 8) && is_register(reg::kFmmu, 256) &&
              is_register(reg::kSyncManager, 128) && is_register(reg::kDcReceiveTimePort0, 4) &&
              is_register(reg::kDcReceiveTimePort1, 4) && is_register(reg::kDcSystemTime, 8) &&
              is_register(reg::kDcReceiveTimeEpu, 8) && is_register(reg::kDcSystemTimeOffset, 8) &&
              is_register(reg::kDcSystemTimeDifference, 4) && is_register(reg::kPdiControl, 1) &&
              is_register(reg::kPdiConfiguration, 1) &&
              is_register(reg::kExtendedPdiConfiguration, 2) &&
              is_register(reg::kEcatEventRequest, 2) && is_register(reg::kDcPulseLength, 2));

// The ESC configuration area (SII words 0..7) is loaded at power-on when its checksum (word 7,
// low byte; ESC Section I §11.1 Table 37) is right, or when word 7 is 88A4h (the datasheet's
// debugging value that disables the check).
bool configuration_area_valid(const std::vector<std::uint8_t>& sii) {
  if (sii.size() < 16) return false;
  const auto word7 = static_cast<std::uint16_t>(sii[14] | (sii[15] << 8));
  return word7 == 0x88A4 || (word7 & 0xFF) == sii_checksum(std::span(sii).first(14));
}

bool overlaps(std::size_t first, std::size_t last, std::size_t reg_first, std::size_t reg_size) {
  return first < reg_first + reg_size && reg_first <= last;
}

std::int64_t nanoseconds(TimePoint t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

}  // namespace

EscEvents& EscEvents::operator|=(const EscEvents& other) {
  al_control = al_control || other.al_control;
  watchdog_expired = watchdog_expired || other.watchdog_expired;
  sii_command = sii_command || other.sii_command;
  dc_latched = dc_latched || other.dc_latched;
  sm_configured |= other.sm_configured;
  sm_written |= other.sm_written;
  sm_read |= other.sm_read;
  sm_repeat |= other.sm_repeat;
  return *this;
}

std::span<const EscRegisterInfo> esc_register_table() {
  return kRegisters;
}

std::optional<EscRegisterInfo> find_esc_register(std::uint16_t address) {
  for (const EscRegisterInfo& row : kRegisters) {
    if (address >= row.address && address < row.address + row.size) return row;
  }
  return std::nullopt;
}

Esc::Esc(EscConfig config) : config_(std::move(config)) {
  config_.fmmus = std::clamp<std::uint8_t>(config_.fmmus, 1, 16);
  config_.sync_managers = std::clamp<std::uint8_t>(config_.sync_managers, 1, 16);
  memory_.assign(reg::kProcessRam + static_cast<std::size_t>(config_.ram_kbytes) * 1024, 0);
  for (const EscRegisterInfo& row : kRegisters) {
    for (std::size_t a = row.address; a < row.address + row.size; ++a) {
      ecat_rw_[a] = row.ecat == EscAccess::rw ? 1 : 0;
      pdi_rw_[a] = row.pdi == EscAccess::rw ? 1 : 0;
    }
  }
  for (unsigned n = 0; n < 16; ++n) {
    const std::uint16_t base = reg::sync_manager(n);
    for (unsigned k = 0; k < 8; ++k) {
      const bool exists = n < config_.sync_managers;
      ecat_rw_[base + k] = exists && k != 5 && k != 7 ? 1 : 0;  // status, PDI control: PDI's
      pdi_rw_[base + k] = exists && k == 7 ? 1 : 0;
    }
    if (n >= config_.fmmus) {
      for (unsigned k = 0; k < 16; ++k)
        ecat_rw_[reg::fmmu(n) + k] = 0;
    }
  }
  reset();
}

void Esc::set16(std::uint16_t a, std::uint16_t v) {
  memory_[a] = static_cast<std::uint8_t>(v);
  memory_[a + 1] = static_cast<std::uint8_t>(v >> 8);
}
void Esc::set32(std::uint16_t a, std::uint32_t v) {
  set16(a, static_cast<std::uint16_t>(v));
  set16(static_cast<std::uint16_t>(a + 2), static_cast<std::uint16_t>(v >> 16));
}
void Esc::set64(std::uint16_t a, std::uint64_t v) {
  set32(a, static_cast<std::uint32_t>(v));
  set32(static_cast<std::uint16_t>(a + 4), static_cast<std::uint32_t>(v >> 32));
}
std::uint16_t Esc::get16(std::uint16_t a) const {
  return static_cast<std::uint16_t>(memory_[a] | (memory_[a + 1] << 8));
}
std::uint32_t Esc::get32(std::uint16_t a) const {
  return get16(a) | (static_cast<std::uint32_t>(get16(static_cast<std::uint16_t>(a + 2))) << 16);
}
std::uint64_t Esc::get64(std::uint16_t a) const {
  return get32(a) | (static_cast<std::uint64_t>(get32(static_cast<std::uint16_t>(a + 4))) << 32);
}

void Esc::reset() {
  std::fill(memory_.begin(), memory_.end(), 0);
  sms_ = {};
  watchdog_deadline_.reset();
  sii_busy_until_ = {};
  sii_errors_ = 0;
  sii_running_ = 0;
  memory_[reg::kType] = config_.type;
  memory_[0x0001] = config_.revision;
  set16(0x0002, config_.build);
  memory_[0x0004] = config_.fmmus;
  memory_[0x0005] = config_.sync_managers;
  memory_[0x0006] = config_.ram_kbytes;
  memory_[0x0007] = 0x0F;  // ports 0 and 1 MII, 2 and 3 not implemented
  set16(0x0008, config_.features);
  // The ESC configuration area (Section I §11.1 Table 37): word 0 -> PDI control and ESC
  // configuration (0140h/0141h), word 1 -> PDI configuration (0150h/0151h), word 2 -> pulse
  // length of SYNC signals (0982h), word 3 -> extended PDI configuration (0152h), word 4 ->
  // station alias (0012h); only when the checksum holds. Otherwise 0502h shows the checksum
  // error (bit 11) and "device information not available" (bit 12), and DL status bit 0 (PDI
  // operational) stays 0.
  const std::vector<std::uint8_t>& image = config_.sii;
  sii_loaded_ = configuration_area_valid(image);
  auto word = [&](std::size_t w) {
    return static_cast<std::uint16_t>(image[2 * w] | (image[2 * w + 1] << 8));
  };
  if (sii_loaded_) {
    set16(reg::kPdiControl, word(0));
    set16(reg::kPdiConfiguration, word(1));
    set16(reg::kDcPulseLength, word(2));
    set16(reg::kExtendedPdiConfiguration, word(3));
    set16(reg::kStationAlias, word(4));
  }
  // DL control (Section II "DL Control", reset 00070001h): forwarding rule 1 (non-EtherCAT
  // frames destroyed), loop control auto on every port, RX FIFO size 7, alias disabled.
  set32(reg::kDlControl, 0x00070001);
  // DL status (Section II "DL Status"): bit 0 PDI operational (EEPROM loaded), bit 1 PDI
  // watchdog reloaded, bit 4 physical link on port 0, bits 9..8 port 0 loop open and
  // communication established; port 1 open with link and communication when a device follows,
  // else its loop closed (bit 10); ports 2 and 3 are not implemented (0007h): loop closed
  // (bits 12 and 14), no communication.
  std::uint16_t dl_status = 0x0002 | 0x0010 | 0x0200 | 0x1000 | 0x4000;
  if (sii_loaded_) dl_status |= 0x0001;
  dl_status |= config_.downstream ? (0x0020 | 0x0800) : 0x0400;
  set16(reg::kDlStatus, dl_status);
  set16(reg::kAlControl, 0x0001);
  set16(reg::kAlStatus, 0x0001);
  set16(reg::kWatchdogDivider, 0x09C2);
  set16(reg::kWatchdogTimePdi, 0x03E8);
  set16(reg::kWatchdogTimeProcessData, 0x03E8);
  set16(reg::kWatchdogStatus, 0x0001);
  sii_static_ = config_.sii_read_bytes == 4 ? 0 : sii::kReadEightBytes;
  if (image.size() > 2048) sii_static_ |= sii::kTwoAddressBytes;  // above 16 kbit
  if (!sii_loaded_) {
    sii_static_ |= sii::kDeviceInfoError;
    if (image.size() >= 16) sii_static_ |= sii::kChecksumError;
  }
  set16(reg::kSiiControl, sii_static_);
  refresh_dynamic(now_);
}

int Esc::find_sm(std::uint16_t address) const {
  for (unsigned n = 0; n < config_.sync_managers; ++n) {
    if (!sms_[n].enabled) continue;
    const std::uint16_t base = reg::sync_manager(n);
    const std::uint16_t start = get16(base);
    const std::uint16_t length = get16(static_cast<std::uint16_t>(base + 2));
    // A SyncManager covers process RAM only; one configured onto registers has no effect.
    if (start < reg::kProcessRam) continue;
    if (address >= start && address - start < length) return static_cast<int>(n);
  }
  return -1;
}

SyncManagerRegisters Esc::sync_manager(unsigned n) const {
  SyncManagerRegisters r;
  if (n >= 16) return r;
  const std::uint16_t base = reg::sync_manager(n);
  r.start = get16(base);
  r.length = get16(static_cast<std::uint16_t>(base + 2));
  r.control = memory_[base + 4];
  r.status = memory_[base + 5];
  r.activate = memory_[base + 6];
  r.pdi_control = memory_[base + 7];
  return r;
}

FmmuRegisters Esc::fmmu(unsigned n) const {
  FmmuRegisters f;
  if (n >= 16) return f;
  const std::uint16_t base = reg::fmmu(n);
  f.logical_start = get32(base);
  f.length = get16(static_cast<std::uint16_t>(base + 4));
  f.logical_start_bit = memory_[base + 6] & 0x07;
  f.logical_stop_bit = memory_[base + 7] & 0x07;
  f.physical_start = get16(static_cast<std::uint16_t>(base + 8));
  f.physical_start_bit = memory_[base + 10] & 0x07;
  f.type = memory_[base + 11];
  f.active = (memory_[base + 12] & 0x01) != 0;
  return f;
}

std::uint8_t Esc::raw_get(std::uint16_t address) const {
  const int n = find_sm(address);
  if (n >= 0) {
    const SyncManagerRegisters r = sync_manager(static_cast<unsigned>(n));
    const SmState& s = sms_[static_cast<std::size_t>(n)];
    const std::size_t offset = address - r.start;
    if (!r.mailbox()) {
      const auto& buffer = r.ecat_writes() ? s.staging : s.latest;
      return offset < buffer.size() ? buffer[offset] : 0;
    }
  }
  return memory_[address];
}

std::uint8_t Esc::peek(std::uint16_t address) const {
  if (address >= memory_.size()) return 0;
  const int n = find_sm(address);
  if (n >= 0) {
    const SyncManagerRegisters r = sync_manager(static_cast<unsigned>(n));
    const SmState& s = sms_[static_cast<std::size_t>(n)];
    if (!r.mailbox()) {
      const std::size_t offset = address - r.start;
      return offset < s.latest.size() ? s.latest[offset] : 0;
    }
  }
  return memory_[address];
}

bool Esc::ecat_read(std::uint16_t address, std::uint8_t& out, EscEvents& events) {
  if (address >= memory_.size()) return false;
  const int n = find_sm(address);
  if (n < 0) {
    out = memory_[address];
    // Reading AL status clears the AL status event (0210h bit 3).
    if (address == reg::kAlStatus || address == reg::kAlStatus + 1) {
      memory_[reg::kEcatEventRequest] &= static_cast<std::uint8_t>(~0x08);
    }
    return true;
  }
  const auto index = static_cast<unsigned>(n);
  const SyncManagerRegisters r = sync_manager(index);
  SmState& s = sms_[index];
  const std::size_t offset = address - r.start;
  const bool last = offset + 1 == r.length;
  if (r.mailbox()) {
    if (r.ecat_writes() || !s.full) return false;
    out = memory_[address];
    s.interrupt_write = false;
    if (last) {
      s.full = false;
      s.interrupt_read = true;
      events.sm_read |= static_cast<std::uint16_t>(1u << index);
    }
    return true;
  }
  out = offset < s.latest.size() ? s.latest[offset] : 0;
  if (!r.ecat_writes()) {
    s.interrupt_write = false;
    if (last) {
      s.interrupt_read = true;
      events.sm_read |= static_cast<std::uint16_t>(1u << index);
    }
  }
  return true;
}

void Esc::publish_buffer(SmState& s, unsigned n, EscEvents* events) {
  s.latest = s.staging;
  s.last_buffer = s.written_any ? static_cast<std::uint8_t>((s.last_buffer + 1) % 3) : 0;
  s.written_any = true;
  s.interrupt_write = true;
  if (events != nullptr) sm_completed_ecat_write(n, *events);
}

void Esc::sm_completed_ecat_write(unsigned n, EscEvents& events) {
  events.sm_written |= static_cast<std::uint16_t>(1u << n);
  if ((sync_manager(n).control & sm::kWatchdogTrigger) != 0) restart_watchdog();
}

bool Esc::ecat_write(std::uint16_t address, std::uint8_t value, EscEvents& events) {
  if (address >= memory_.size()) return false;
  if (address < reg::kProcessRam) {
    if (ecat_rw_[address] == 0) return true;  // read-only or reserved: ignored, addressed
    if (address >= reg::kSyncManager && address < reg::kSyncManager + 8 * 16) {
      const unsigned n = (address - reg::kSyncManager) / 8;
      const unsigned k = (address - reg::kSyncManager) % 8;
      if (k < 5 && sms_[n].enabled) return true;  // configuration locked while enabled
    }
  }
  const int n = find_sm(address);
  if (n < 0) {
    memory_[address] = value;
    return true;
  }
  const auto index = static_cast<unsigned>(n);
  const SyncManagerRegisters r = sync_manager(index);
  SmState& s = sms_[index];
  const std::size_t offset = address - r.start;
  const bool last = offset + 1 == r.length;
  if (!r.ecat_writes()) return false;
  s.interrupt_read = false;
  if (r.mailbox()) {
    if (s.full) return false;
    memory_[address] = value;
    if (last) {
      s.full = true;
      s.interrupt_write = true;
      sm_completed_ecat_write(index, events);
    }
    return true;
  }
  if (s.staging.size() != r.length) s.staging.resize(r.length, 0);
  s.staging[offset] = value;
  if (last) publish_buffer(s, index, &events);
  return true;
}

Duration Esc::watchdog_period() const {
  const std::int64_t ticks = static_cast<std::int64_t>(get16(reg::kWatchdogTimeProcessData)) *
                             (static_cast<std::int64_t>(get16(reg::kWatchdogDivider)) + 2);
  return std::chrono::nanoseconds(ticks * 40);
}

void Esc::restart_watchdog() {
  const Duration period = watchdog_period();
  if (period.count() == 0) {
    watchdog_deadline_.reset();
  } else {
    watchdog_deadline_ = now_ + period;
  }
  memory_[reg::kWatchdogStatus] |= 0x01;
}

std::optional<TimePoint> Esc::next_deadline() const {
  return watchdog_deadline_;
}

void Esc::refresh_dynamic(TimePoint now) {
  set64(reg::kDcSystemTime,
        static_cast<std::uint64_t>(nanoseconds(now)) + get64(reg::kDcSystemTimeOffset));
  std::uint16_t sii = static_cast<std::uint16_t>((get16(reg::kSiiControl) & sii::kWriteEnable) |
                                                 sii_static_ | sii_errors_);
  if (now < sii_busy_until_) sii |= static_cast<std::uint16_t>(sii::kBusy | sii_running_);
  set16(reg::kSiiControl, sii);
  // SyncManager status (Section II "SyncManager Status"): bit 0 interrupt write (the buffer
  // was written completely; cleared when its first byte is read), bit 1 interrupt read (read
  // completely; cleared when its first byte is written), bit 3 mailbox full, bits 5..4 the
  // buffer written last in buffered mode (11b: none yet).
  for (unsigned n = 0; n < config_.sync_managers; ++n) {
    const SmState& s = sms_[n];
    const SyncManagerRegisters r = sync_manager(n);
    std::uint8_t status = 0;
    if (!s.enabled) {
      memory_[reg::sync_manager(n) + 5] = 0;
      continue;
    }
    if (r.mailbox()) {
      if (s.full) status |= sm::kStatusMailboxFull;
    } else {
      status = s.written_any ? static_cast<std::uint8_t>(s.last_buffer << 4)
                             : sm::kStatusNoBufferWritten;
    }
    if (s.interrupt_write) status |= sm::kStatusInterruptWrite;
    if (s.interrupt_read) status |= sm::kStatusInterruptRead;
    memory_[reg::sync_manager(n) + 5] = status;
  }
}

EscEvents Esc::advance(TimePoint now) {
  EscEvents events;
  if (now > now_) now_ = now;
  if (watchdog_deadline_ && now_ >= *watchdog_deadline_) {
    watchdog_deadline_.reset();
    memory_[reg::kWatchdogStatus] &= static_cast<std::uint8_t>(~0x01);
    if (memory_[reg::kWatchdogCounterPd] < 0xFF) ++memory_[reg::kWatchdogCounterPd];
    events.watchdog_expired = true;
  }
  refresh_dynamic(now_);
  return events;
}

void Esc::run_sii_command(std::uint16_t control, EscEvents& events) {
  // ECAT controls the EEPROM interface only while 0500h bit 0 and 0501h bit 0 are both 0
  // (Section II "EEPROM Configuration"); otherwise the PDI does and the command is ignored.
  if ((memory_[reg::kSiiConfiguration] & 0x01) != 0 || (memory_[reg::kSiiPdiAccess] & 0x01) != 0) {
    return;
  }
  if (now_ < sii_busy_until_) return;  // busy: the command is ignored
  events.sii_command = true;
  const unsigned command = (control >> 8) & 0x07;
  const std::uint32_t word = get32(reg::kSiiAddress);
  const std::vector<std::uint8_t>& image = config_.sii;
  switch (command) {
    case 0:  // no command: clears the error bits
      sii_errors_ = 0;
      break;
    case 1: {  // read 4 words
      sii_errors_ = 0;
      const std::uint64_t byte = static_cast<std::uint64_t>(word) * 2;
      if (byte >= image.size()) {
        sii_errors_ = sii::kCommandError;
        break;
      }
      const unsigned octets = config_.sii_read_bytes == 4 ? 4 : 8;
      for (unsigned i = 0; i < octets; ++i) {
        memory_[reg::kSiiData + i] = byte + i < image.size() ? image[byte + i] : 0xFF;
      }
      sii_busy_until_ = now_ + config_.sii_busy_time;
      break;
    }
    case 2: {  // write 1 word
      sii_errors_ = 0;
      const std::uint64_t byte = static_cast<std::uint64_t>(word) * 2;
      if ((control & sii::kWriteEnable) == 0) {
        sii_errors_ = sii::kWriteEnableError;
      } else if (byte + 2 > image.size()) {
        sii_errors_ = sii::kCommandError;
      } else {
        config_.sii[byte] = memory_[reg::kSiiData];
        config_.sii[byte + 1] = memory_[reg::kSiiData + 1];
        sii_busy_until_ = now_ + config_.sii_busy_time;
      }
      break;
    }
    case 4:  // reload: PDI configuration and SYNC pulse length again; not the alias, which
             // is loaded only at power-on (Section I §11.1)
      sii_errors_ = 0;
      if (configuration_area_valid(image)) {
        set16(reg::kPdiConfiguration, static_cast<std::uint16_t>(image[2] | (image[3] << 8)));
        set16(reg::kDcPulseLength, static_cast<std::uint16_t>(image[4] | (image[5] << 8)));
        set16(reg::kExtendedPdiConfiguration,
              static_cast<std::uint16_t>(image[6] | (image[7] << 8)));
      }
      sii_busy_until_ = now_ + config_.sii_busy_time;
      break;
    default:
      sii_errors_ = sii::kCommandError;
      break;
  }
  // While busy, bits 10..8 show the command running; write enable is self-clearing.
  sii_running_ = static_cast<std::uint16_t>(control & sii::kCommandMask);
  set16(reg::kSiiControl, sii_static_);
  refresh_dynamic(now_);
}

void Esc::after_register_write(std::size_t first, std::size_t last, EscEvents& events) {
  if (overlaps(first, last, reg::kAlControl, 2)) {
    events.al_control = true;
    memory_[reg::kAlEventRequest] |= 0x01;
  }
  if (overlaps(first, last, reg::kRxErrorCounter, 0x0C)) {
    std::fill_n(memory_.begin() + reg::kRxErrorCounter, 0x0C, 0);  // any write clears them
  }
  if (overlaps(first, last, reg::kSyncManager, 8 * 16)) {
    for (unsigned n = 0; n < config_.sync_managers; ++n) {
      if (!overlaps(first, last, reg::sync_manager(n), 8)) continue;
      events.sm_configured |= static_cast<std::uint16_t>(1u << n);
      const SyncManagerRegisters r = sync_manager(n);
      SmState& s = sms_[n];
      if (r.enabled() != s.enabled) {
        const bool repeat = s.repeat;
        s = SmState{};
        s.enabled = r.enabled();
        s.repeat = repeat;
        if (s.enabled && !r.mailbox()) {
          s.latest.assign(r.length, 0);
          s.staging.assign(r.length, 0);
        }
      }
      const bool repeat = (r.activate & sm::kActivateRepeat) != 0;
      if (repeat != s.repeat) {
        s.repeat = repeat;
        events.sm_repeat |= static_cast<std::uint16_t>(1u << n);
      }
    }
  }
  if (overlaps(first, last, reg::kDcReceiveTimePort0, 4)) {
    const auto arrival = static_cast<std::uint64_t>(nanoseconds(frame_arrival_));
    set32(reg::kDcReceiveTimePort0, static_cast<std::uint32_t>(arrival));
    set32(reg::kDcReceiveTimePort1,
          frame_return_ ? static_cast<std::uint32_t>(nanoseconds(*frame_return_)) : 0);
    set64(reg::kDcReceiveTimeEpu, arrival);
    events.dc_latched = true;
  }
  if (overlaps(first, last, reg::kDcSystemTime, 8)) {
    const std::uint64_t received = get64(reg::kDcSystemTime);
    const std::uint64_t local =
        static_cast<std::uint64_t>(nanoseconds(frame_arrival_)) + get64(reg::kDcSystemTimeOffset);
    const std::uint32_t difference =
        local < received
            ? (0x80000000u |
               static_cast<std::uint32_t>(std::min<std::uint64_t>(received - local, 0x7FFFFFFF)))
            : static_cast<std::uint32_t>(std::min<std::uint64_t>(local - received, 0x7FFFFFFF));
    set32(reg::kDcSystemTimeDifference, difference);
  }
  // 0500h bit 1 (force PDI access state) resets 0501h bit 0: ECAT takes the EEPROM back.
  if (overlaps(first, last, reg::kSiiConfiguration, 1) &&
      (memory_[reg::kSiiConfiguration] & 0x02) != 0) {
    memory_[reg::kSiiPdiAccess] &= static_cast<std::uint8_t>(~0x01);
  }
  if (overlaps(first, last, reg::kSiiControl, 2)) run_sii_command(get16(reg::kSiiControl), events);
}

void Esc::logical_access(std::span<std::uint8_t> data, std::uint32_t address, bool read, bool write,
                         bool& any_read, bool& any_write, EscEvents& events) {
  scratch_.assign(data.begin(), data.end());  // data as it arrived: what writes write
  std::size_t reg_first = SIZE_MAX;
  std::size_t reg_last = 0;
  const std::uint64_t dg_start = address;
  const std::uint64_t dg_end = dg_start + data.size();
  for (unsigned n = 0; n < config_.fmmus; ++n) {
    const FmmuRegisters f = fmmu(n);
    if (!f.active || f.length == 0) continue;
    const bool f_read = read && (f.type & 0x01) != 0;
    const bool f_write = write && (f.type & 0x02) != 0;
    if (!f_read && !f_write) continue;
    const std::uint64_t f_start = f.logical_start;
    const std::uint64_t f_end = f_start + f.length;
    const std::uint64_t from = std::max(dg_start, f_start);
    const std::uint64_t to = std::min(dg_end, f_end);
    if (from >= to) continue;
    const bool aligned =
        f.logical_start_bit == 0 && f.logical_stop_bit == 7 && f.physical_start_bit == 0;
    for (std::uint64_t l = from; l < to; ++l) {
      const std::size_t i = static_cast<std::size_t>(l - dg_start);
      const std::size_t offset = static_cast<std::size_t>(l - f_start);
      if (aligned) {
        const std::uint64_t pa64 = f.physical_start + offset;
        if (pa64 > 0xFFFF) break;
        const auto pa = static_cast<std::uint16_t>(pa64);
        if (f_read) {
          std::uint8_t v = 0;
          if (ecat_read(pa, v, events)) {
            data[i] = v;
            any_read = true;
          }
        }
        if (f_write && ecat_write(pa, scratch_[i], events)) {
          any_write = true;
          if (pa < reg::kProcessRam) {
            reg_first = std::min<std::size_t>(reg_first, pa);
            reg_last = std::max<std::size_t>(reg_last, pa);
          }
        }
        continue;
      }
      const unsigned lo = offset == 0 ? f.logical_start_bit : 0;
      const unsigned hi = offset + 1 == f.length ? f.logical_stop_bit : 7;
      for (unsigned bit = lo; bit <= hi; ++bit) {
        const std::uint64_t rel = offset * 8 + bit - f.logical_start_bit;
        const std::uint64_t pbit = f.physical_start_bit + rel;
        const std::uint64_t pa64 = f.physical_start + pbit / 8;
        if (pa64 > 0xFFFF) break;
        const auto pa = static_cast<std::uint16_t>(pa64);
        const unsigned pb = static_cast<unsigned>(pbit % 8);
        if (f_read) {
          std::uint8_t v = 0;
          if (ecat_read(pa, v, events)) {
            data[i] =
                static_cast<std::uint8_t>((data[i] & ~(1u << bit)) | (((v >> pb) & 1u) << bit));
            any_read = true;
          }
        }
        if (f_write) {
          const std::uint8_t current = pa < memory_.size() ? raw_get(pa) : 0;
          const std::uint8_t wanted = static_cast<std::uint8_t>(
              (current & ~(1u << pb)) | (((scratch_[i] >> bit) & 1u) << pb));
          if (ecat_write(pa, wanted, events)) {
            any_write = true;
            if (pa < reg::kProcessRam) {
              reg_first = std::min<std::size_t>(reg_first, pa);
              reg_last = std::max<std::size_t>(reg_last, pa);
            }
          }
        }
      }
    }
  }
  if (reg_first != SIZE_MAX) after_register_write(reg_first, reg_last, events);
}

void Esc::process_datagram(std::span<std::uint8_t> d, std::size_t n, EscEvents& events) {
  const auto info = find_command(d[0]);
  if (!info || info->addressing == Addressing::none) return;  // NOP, unknown: untouched
  const auto data = d.subspan(kDatagramHeaderSize, n);
  std::uint16_t adp = static_cast<std::uint16_t>(d[2] | (d[3] << 8));
  const auto ado = static_cast<std::uint16_t>(d[4] | (d[5] << 8));
  bool read = false;
  bool write = false;
  bool any_read = false;
  bool any_write = false;
  if (info->addressing == Addressing::logical) {
    const std::uint32_t address =
        static_cast<std::uint32_t>(d[2]) | (static_cast<std::uint32_t>(d[3]) << 8) |
        (static_cast<std::uint32_t>(d[4]) << 16) | (static_cast<std::uint32_t>(d[5]) << 24);
    read = info->access == Access::read || info->access == Access::read_write;
    write = info->access == Access::write || info->access == Access::read_write;
    logical_access(data, address, read, write, any_read, any_write, events);
  } else {
    bool match = false;
    switch (info->addressing) {
      case Addressing::position:
        match = adp == 0;
        ++adp;
        break;
      case Addressing::broadcast:
        match = true;
        ++adp;
        break;
      case Addressing::station: {
        const bool alias_enabled = (memory_[reg::kDlControl + 3] & 0x01) != 0;
        match = adp == get16(reg::kStationAddress) ||
                (alias_enabled && adp == get16(reg::kStationAlias));
        break;
      }
      default:
        break;
    }
    d[2] = static_cast<std::uint8_t>(adp);
    d[3] = static_cast<std::uint8_t>(adp >> 8);
    switch (info->access) {
      case Access::read:
        read = match;
        break;
      case Access::write:
        write = match;
        break;
      case Access::read_write:
        read = write = match;
        break;
      case Access::read_multiple_write:
        read = match;
        write = !match;
        break;
      case Access::none:
        break;
    }
    const bool broadcast = info->addressing == Addressing::broadcast;
    std::size_t reg_last = 0;
    for (std::size_t i = 0; i < n && (read || write); ++i) {
      const std::size_t a = static_cast<std::size_t>(ado) + i;
      if (a > 0xFFFF) break;
      const std::uint8_t incoming = data[i];
      if (read) {
        std::uint8_t v = 0;
        if (ecat_read(static_cast<std::uint16_t>(a), v, events)) {
          data[i] = broadcast ? static_cast<std::uint8_t>(incoming | v) : v;
          any_read = true;
        }
      }
      if (write && ecat_write(static_cast<std::uint16_t>(a), incoming, events)) {
        any_write = true;
        if (a < reg::kProcessRam) reg_last = a;
      }
    }
    if (any_write && ado < reg::kProcessRam) after_register_write(ado, reg_last, events);
  }
  unsigned increment = 0;
  switch (info->wkc) {
    case WkcRule::one:
    case WkcRule::multiple_write:
      increment = (any_read || any_write) ? 1 : 0;
      break;
    case WkcRule::read_write:
      increment = (any_read ? 1 : 0) + (any_write ? 2 : 0);
      break;
    case WkcRule::none:
      break;
  }
  if (increment != 0) {
    const std::size_t at = kDatagramHeaderSize + n;
    const auto wkc = static_cast<std::uint16_t>((d[at] | (d[at + 1] << 8)) + increment);
    d[at] = static_cast<std::uint8_t>(wkc);
    d[at + 1] = static_cast<std::uint8_t>(wkc >> 8);
  }
}

EscEvents Esc::process_frame(std::span<std::uint8_t> frame, TimePoint arrival,
                             std::optional<TimePoint> return_arrival) {
  EscEvents events = advance(arrival);
  frame_arrival_ = arrival;
  frame_return_ = return_arrival;
  const auto layout = parse_frame_layout(frame);
  const bool valid =
      layout && !walk_datagrams(frame.subspan(layout->payload_offset, layout->payload_length),
                                layout->payload_offset, spans_);
  if (!valid) {
    // A frame whose EtherType is not EtherCAT is forwarded without counting it as an error.
    if (layout || layout.error().code != FrameError::wrong_ethertype) {
      std::uint8_t& counter = memory_[reg::kProcessingErrorCounter];
      if (counter < 0xFF) ++counter;
    }
    return events;
  }
  const auto payload = frame.subspan(layout->payload_offset, layout->payload_length);
  for (const DatagramSpan& span : spans_) {
    process_datagram(payload.subspan(span.offset, kDatagramOverhead + span.data_length),
                     span.data_length, events);
  }
  frame[6] |= 0x02;
  refresh_dynamic(now_);
  return events;
}

// ---- PDI ----

std::uint8_t Esc::pdi_read8(std::uint16_t address) {
  if (address >= memory_.size()) return 0;
  if (address == reg::kAlControl || address == reg::kAlControl + 1) {
    memory_[reg::kAlEventRequest] &= static_cast<std::uint8_t>(~0x01);
  }
  const int n = find_sm(address);
  if (n < 0) return memory_[address];
  const auto index = static_cast<unsigned>(n);
  const SyncManagerRegisters r = sync_manager(index);
  SmState& s = sms_[index];
  const std::size_t offset = address - r.start;
  if (r.mailbox()) {
    const std::uint8_t value = memory_[address];
    if (r.ecat_writes() && s.full) {
      s.interrupt_write = false;
      if (offset + 1 == r.length) {
        s.full = false;
        s.interrupt_read = true;
      }
    }
    return value;
  }
  if (r.ecat_writes()) {
    s.interrupt_write = false;
    if (offset + 1 == r.length) s.interrupt_read = true;
  }
  const auto& buffer = r.ecat_writes() ? s.latest : s.staging;
  return offset < buffer.size() ? buffer[offset] : 0;
}

std::uint16_t Esc::pdi_read16(std::uint16_t address) {
  const std::uint8_t low = pdi_read8(address);
  return static_cast<std::uint16_t>(low |
                                    (pdi_read8(static_cast<std::uint16_t>(address + 1)) << 8));
}

std::uint32_t Esc::pdi_read32(std::uint16_t address) {
  const std::uint32_t low = pdi_read16(address);
  return low |
         (static_cast<std::uint32_t>(pdi_read16(static_cast<std::uint16_t>(address + 2))) << 16);
}

bool Esc::pdi_write8(std::uint16_t address, std::uint8_t value) {
  if (address >= memory_.size()) return false;
  if (address < reg::kProcessRam) {
    if (pdi_rw_[address] == 0) return false;
    // 0501h: the PDI may take the EEPROM only while ECAT offers it (0500h bit 0 = 1) and does
    // not force it back (bit 1 = 0) (Section II "EEPROM PDI Access State", r/(w)).
    if (address == reg::kSiiPdiAccess && (memory_[reg::kSiiConfiguration] & 0x03) != 0x01) {
      return false;
    }
    memory_[address] = value;
    return true;
  }
  const int n = find_sm(address);
  if (n < 0) {
    memory_[address] = value;
    return true;
  }
  const auto index = static_cast<unsigned>(n);
  const SyncManagerRegisters r = sync_manager(index);
  SmState& s = sms_[index];
  const std::size_t offset = address - r.start;
  const bool last = offset + 1 == r.length;
  if (r.ecat_writes()) return false;
  s.interrupt_read = false;
  if (r.mailbox()) {
    if (s.full) return false;
    memory_[address] = value;
    if (last) {
      s.full = true;
      s.interrupt_write = true;
    }
    return true;
  }
  if (s.staging.size() != r.length) s.staging.resize(r.length, 0);
  s.staging[offset] = value;
  if (last) publish_buffer(s, index, nullptr);
  return true;
}

bool Esc::pdi_write16(std::uint16_t address, std::uint16_t value) {
  const bool low = pdi_write8(address, static_cast<std::uint8_t>(value));
  const bool high =
      pdi_write8(static_cast<std::uint16_t>(address + 1), static_cast<std::uint8_t>(value >> 8));
  return low && high;
}

std::optional<std::vector<std::uint8_t>> Esc::pdi_take_mailbox(unsigned n) {
  if (n >= config_.sync_managers) return std::nullopt;
  const SyncManagerRegisters r = sync_manager(n);
  SmState& s = sms_[n];
  if (!s.enabled || !r.mailbox() || !r.ecat_writes() || !s.full) return std::nullopt;
  if (static_cast<std::size_t>(r.start) + r.length > memory_.size()) return std::nullopt;
  std::vector<std::uint8_t> bytes(memory_.begin() + r.start, memory_.begin() + r.start + r.length);
  s.full = false;
  s.interrupt_write = false;
  s.interrupt_read = true;
  refresh_dynamic(now_);
  return bytes;
}

bool Esc::pdi_put_mailbox(unsigned n, std::span<const std::uint8_t> data) {
  if (n >= config_.sync_managers) return false;
  const SyncManagerRegisters r = sync_manager(n);
  SmState& s = sms_[n];
  if (!s.enabled || !r.mailbox() || r.ecat_writes() || s.full || data.size() > r.length) {
    return false;
  }
  if (static_cast<std::size_t>(r.start) + r.length > memory_.size()) return false;
  std::copy(data.begin(), data.end(), memory_.begin() + r.start);
  std::fill(memory_.begin() + r.start + static_cast<std::ptrdiff_t>(data.size()),
            memory_.begin() + r.start + r.length, 0);
  s.full = true;
  s.interrupt_write = true;
  s.interrupt_read = false;
  refresh_dynamic(now_);
  return true;
}

bool Esc::mailbox_full(unsigned n) const {
  return n < 16 && sms_[n].full;
}

void Esc::pdi_set_al_status(std::uint16_t status, std::uint16_t code) {
  // A change of AL status raises the AL status event (ECAT event request 0210h bit 3) until
  // ECAT reads 0130h (Section II "ECAT Event Request").
  if (get16(reg::kAlStatus) != status) memory_[reg::kEcatEventRequest] |= 0x08;
  set16(reg::kAlStatus, status);
  set16(reg::kAlStatusCode, code);
}

std::uint16_t Esc::al_control() const {
  return get16(reg::kAlControl);
}

std::vector<std::uint8_t> register_block(const SyncManagerRegisters& sm) {
  return {static_cast<std::uint8_t>(sm.start),
          static_cast<std::uint8_t>(sm.start >> 8),
          static_cast<std::uint8_t>(sm.length),
          static_cast<std::uint8_t>(sm.length >> 8),
          sm.control,
          sm.status,
          sm.activate,
          sm.pdi_control};
}

std::vector<std::uint8_t> register_block(const FmmuRegisters& fmmu) {
  return {static_cast<std::uint8_t>(fmmu.logical_start),
          static_cast<std::uint8_t>(fmmu.logical_start >> 8),
          static_cast<std::uint8_t>(fmmu.logical_start >> 16),
          static_cast<std::uint8_t>(fmmu.logical_start >> 24),
          static_cast<std::uint8_t>(fmmu.length),
          static_cast<std::uint8_t>(fmmu.length >> 8),
          fmmu.logical_start_bit,
          fmmu.logical_stop_bit,
          static_cast<std::uint8_t>(fmmu.physical_start),
          static_cast<std::uint8_t>(fmmu.physical_start >> 8),
          fmmu.physical_start_bit,
          fmmu.type,
          static_cast<std::uint8_t>(fmmu.active ? 1 : 0),
          0,
          0,
          0};
}

std::vector<std::uint8_t> sync_manager_block(std::uint16_t start, std::uint16_t length,
                                             std::uint8_t control, bool enable) {
  SyncManagerRegisters sm;
  sm.start = start;
  sm.length = length;
  sm.control = control;
  sm.activate = enable ? sm::kActivateEnable : 0;
  return register_block(sm);
}

std::vector<std::uint8_t> fmmu_block(std::uint32_t logical, std::uint16_t length,
                                     std::uint16_t physical, std::uint8_t type) {
  FmmuRegisters fmmu;
  fmmu.logical_start = logical;
  fmmu.length = length;
  fmmu.physical_start = physical;
  fmmu.type = type;
  fmmu.active = true;
  return register_block(fmmu);
}

}  // namespace drivecheck::ethercat
