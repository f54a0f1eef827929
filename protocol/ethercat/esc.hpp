// A model of an EtherCAT Slave Controller (ESC): its register and process RAM address space, and
// how it processes the datagrams of a frame as the frame passes (in place, as the hardware
// does), fed frames and time; no I/O, no threads. The slave application's side of the chip
// (the PDI) is a set of functions the slave front end calls.
//
// Sources: Beckhoff "EtherCAT Slave Controller" Section I (Technology) §2.4 Table 5 (working
// counter), §2.5 Tables 6/7 (commands, address match, data in/out), §6 (FMMU), §8
// (SyncManager: buffered and mailbox mode), §9 (distributed clocks), §11 (SII EEPROM);
// Section II (Register Description) for every address (esc_registers.inc).
//
// Address space: 0000h..0FFFh registers (esc_registers.inc; reserved bytes read 0, writes are
// ignored), 1000h.. process RAM (EscConfig::ram_kbytes). Addresses past the RAM are not
// accessible: a datagram that reaches only those leaves the working counter alone.
//
// Processing a frame (process_frame):
//  - a frame that is not well formed (frame.hpp parse_frame_layout + walk_datagrams) is passed
//    on untouched and counted in the ECAT processing unit error counter (030Ch): the hardware
//    discards such a frame's effects because its FCS or length is wrong;
//  - every datagram in order: position commands (APxx, ARMW) match when ADP is 0 and
//    increment ADP; broadcast commands (Bxx) match always and increment ADP; station commands
//    (FPxx, FRMW) match when ADP equals the configured station address (0010h) or, with DL
//    control bit 24 set, the alias (0012h); logical commands (Lxx) match through the active
//    FMMUs whose logical range overlaps;
//  - reads happen before writes for the same byte (read-write commands return the old value);
//    BRD/BRW OR the read data into the datagram; LRD/LRW replace only the bits an FMMU maps;
//    ARMW/FRMW: the addressed ESC reads, every other ESC writes;
//  - the working counter (ESC Section I Table 5): +1 when at least one byte was read, +2
//    (read-write commands) or +1 (write commands) when at least one byte was written; a byte
//    counts only when it was accessible (an existing address; a SyncManager buffer that
//    allowed the access). ARMW/FRMW count +1 as the read or the write they were;
//  - the source MAC's bit 1 (locally administered) is set on every processed frame (ESC
//    Section I §3: so the master can tell sent from received frames); VLAN-tagged frames are
//    processed with the tag untouched; EtherCAT in UDP/IP is not modelled.
//
// SyncManagers (0800h + 8n: start u16, length u16, control u8, status u8, activate u8, PDI
// control u8). Control bits 1..0: 00 buffered (3-buffer), 10 mailbox; bits 3..2: 00 ECAT
// reads (slave -> master), 01 ECAT writes (master -> slave); bit 6: watchdog trigger.
// Activate bit 0 enables; bit 1 repeat request. Status bit 3 mailbox full; bits 5..4 last
// buffer written (buffered); bit 0 interrupt write, bit 1 interrupt read.
//  - mailbox, ECAT writes: ECAT may write only while the buffer is empty; writing its last
//    byte fills it (status bit 3, the PDI may read it); the PDI reading the last byte empties
//    it. ECAT may not read it.
//  - mailbox, ECAT reads: the PDI writes while empty; its last byte fills it; ECAT may read
//    only while full, and reading the last byte empties it.
//  - buffered: always accessible; the producer writes a buffer that becomes the one the
//    consumer reads when its last byte is written (the model keeps a staging copy that is
//    published at once; the three buffers exist to avoid tearing, which one thread cannot
//    produce). A completed ECAT write with control bit 6 set restarts the process data
//    watchdog.
// Disabling an SM (activate bit 0 = 0) empties its buffers. An SM whose start lies below the
// process RAM (1000h) has no effect: SyncManagers guard process RAM, not registers.
//
// FMMUs (0600h + 16n: logical start u32, length u16, logical start bit u8, logical stop bit
// u8, physical start u16, physical start bit u8, type u8 (bit 0 read, bit 1 write), activate
// u8 (bit 0)). Bit-granular mappings are supported.
//
// Watchdog: process data watchdog time = 0420h × (0400h + 2) × 40 ns (reset values 03E8h and
// 09C2h: 100 ms); 0 disables it. It runs from the first triggering SM write; when it expires
// 0440h bit 0 reads 0, 0442h counts the expiry, and advance() reports watchdog_expired.
//
// SII EEPROM interface (0500h..050Fh, Section I Table 39): a write of the command (0502h bits
// 10..8: 001 read, 010 write, 100 reload, 000 clears errors) runs against the SII image: a read
// puts 8 octets (4 words from the address in 0504h) into 0508h..050Fh, or 4 into 0508h..050Bh
// (EscConfig::sii_read_bytes; 0502h bit 6 says which); a write stores the word in 0508h at
// 0504h and needs the write enable bit 0 in the same access (else error bit 14); an address
// past the image sets error bit 13 (our choice: a real EEPROM wraps). Bit 15 (busy) and bits
// 10..8 (the command running) read set for EscConfig::sii_busy_time after a command; bit 7 says
// two address octets (image above 16 kbit). ECAT controls the interface only while 0500h bit 0
// and 0501h bit 0 are both 0; otherwise commands are ignored. An ECAT write of 0500h bit 1
// (force) clears 0501h bit 0; the PDI may set 0501h bit 0 only while 0500h reads 01b.
// Power-on (reset()): the ESC configuration area (SII words 0..7) is loaded when its checksum
// holds: 0140h/0141h, 0150h/0151h, 0982h, 0152h and the alias 0012h; otherwise 0502h bits 11/12
// are set and DL status bit 0 (PDI operational) stays 0. A reload command loads 0150h, 0982h
// and 0152h again, never the alias (Section I §11.1).
//
// Reset values (Section II): DL control 00070001h; DL status: PDI operational, PDI watchdog
// reloaded, link and communication on port 0 with its loop open; port 1 open with link and
// communication when a device follows, else closed; ports 2 and 3 (not implemented) closed;
// watchdog divider 09C2h, watchdog times 03E8h. AL status changes raise ECAT event request
// 0210h bit 3 until ECAT reads 0130h.
//
// SyncManager status (0805h + 8n): bit 0 "interrupt write" (buffer written completely, cleared
// by the first read), bit 1 "interrupt read" (read completely, cleared by the first write),
// bit 3 mailbox full, bits 5..4 the last buffer written in buffered mode (11b: none yet); 0
// while the SM is disabled.
//
// Distributed clocks (as registers): local time = the time fed in (nanoseconds, 64 bit).
// A write to 0900h latches the receive times of ports 0 and 1 (0900h, 0904h, low 32 bits) and
// 0918h (64 bit). 0910h reads local time + offset (0920h); a write to 0910h stores the
// difference to the local copy in 092Ch (bit 31 set: local copy smaller).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/ethercat/datagram.hpp"

namespace drivecheck::ethercat {

using TimePoint = can::TimePoint;
using Duration = can::Duration;

enum class EscAccess : std::uint8_t { ro, rw };

struct EscRegisterInfo {
  std::string_view name;
  std::uint16_t address;
  std::uint16_t size;
  EscAccess ecat;
  EscAccess pdi;
  std::string_view text;
};
// Every register of esc_registers.inc, in ascending address order.
std::span<const EscRegisterInfo> esc_register_table();
// The register that contains `address`, or nullopt (reserved or process RAM).
std::optional<EscRegisterInfo> find_esc_register(std::uint16_t address);

// Register addresses used by code (each is a row of esc_registers.inc; esc.cpp checks that).
namespace reg {
inline constexpr std::uint16_t kType = 0x0000;
inline constexpr std::uint16_t kStationAddress = 0x0010;
inline constexpr std::uint16_t kStationAlias = 0x0012;
inline constexpr std::uint16_t kDlControl = 0x0100;
inline constexpr std::uint16_t kDlStatus = 0x0110;
inline constexpr std::uint16_t kPdiControl = 0x0140;
inline constexpr std::uint16_t kPdiConfiguration = 0x0150;
inline constexpr std::uint16_t kExtendedPdiConfiguration = 0x0152;
inline constexpr std::uint16_t kEcatEventRequest = 0x0210;
inline constexpr std::uint16_t kAlControl = 0x0120;
inline constexpr std::uint16_t kAlStatus = 0x0130;
inline constexpr std::uint16_t kAlStatusCode = 0x0134;
inline constexpr std::uint16_t kAlEventRequest = 0x0220;
inline constexpr std::uint16_t kRxErrorCounter = 0x0300;
inline constexpr std::uint16_t kProcessingErrorCounter = 0x030C;
inline constexpr std::uint16_t kWatchdogDivider = 0x0400;
inline constexpr std::uint16_t kWatchdogTimePdi = 0x0410;
inline constexpr std::uint16_t kWatchdogTimeProcessData = 0x0420;
inline constexpr std::uint16_t kWatchdogStatus = 0x0440;
inline constexpr std::uint16_t kWatchdogCounterPd = 0x0442;
inline constexpr std::uint16_t kSiiConfiguration = 0x0500;
inline constexpr std::uint16_t kSiiPdiAccess = 0x0501;
inline constexpr std::uint16_t kSiiControl = 0x0502;
inline constexpr std::uint16_t kSiiAddress = 0x0504;
inline constexpr std::uint16_t kSiiData = 0x0508;
inline constexpr std::uint16_t kFmmu = 0x0600;
inline constexpr std::uint16_t kSyncManager = 0x0800;
inline constexpr std::uint16_t kDcReceiveTimePort0 = 0x0900;
inline constexpr std::uint16_t kDcReceiveTimePort1 = 0x0904;
inline constexpr std::uint16_t kDcSystemTime = 0x0910;
inline constexpr std::uint16_t kDcReceiveTimeEpu = 0x0918;
inline constexpr std::uint16_t kDcSystemTimeOffset = 0x0920;
inline constexpr std::uint16_t kDcSystemTimeDifference = 0x092C;
inline constexpr std::uint16_t kDcPulseLength = 0x0982;
inline constexpr std::uint16_t kProcessRam = 0x1000;

constexpr std::uint16_t fmmu(unsigned n) {
  return static_cast<std::uint16_t>(kFmmu + 16 * n);
}
constexpr std::uint16_t sync_manager(unsigned n) {
  return static_cast<std::uint16_t>(kSyncManager + 8 * n);
}
}  // namespace reg

// SyncManager control and status bits (ESC Section II §3.x "SyncManager").
// SII EEPROM control/status bits (register 0502h, ESC Section II): the ESC model sets them,
// the master reads them.
namespace sii {
inline constexpr std::uint16_t kWriteEnable = 0x0001;
inline constexpr std::uint16_t kReadEightBytes = 0x0040;   // 0: a read gives 4 bytes
inline constexpr std::uint16_t kTwoAddressBytes = 0x0080;  // EEPROM above 16 kbit
inline constexpr std::uint16_t kCommandMask = 0x0700;      // written: command; read: running
inline constexpr std::uint16_t kCommandRead = 0x0100;
inline constexpr std::uint16_t kChecksumError = 0x0800;
inline constexpr std::uint16_t kDeviceInfoError = 0x1000;
inline constexpr std::uint16_t kCommandError = 0x2000;
inline constexpr std::uint16_t kWriteEnableError = 0x4000;
inline constexpr std::uint16_t kBusy = 0x8000;
}  // namespace sii

namespace sm {
inline constexpr std::uint8_t kModeMask = 0x03;
inline constexpr std::uint8_t kModeBuffered = 0x00;
inline constexpr std::uint8_t kModeMailbox = 0x02;
inline constexpr std::uint8_t kDirectionMask = 0x0C;
inline constexpr std::uint8_t kDirectionEcatReads = 0x00;
inline constexpr std::uint8_t kDirectionEcatWrites = 0x04;
inline constexpr std::uint8_t kWatchdogTrigger = 0x40;
inline constexpr std::uint8_t kStatusInterruptWrite = 0x01;
inline constexpr std::uint8_t kStatusInterruptRead = 0x02;
inline constexpr std::uint8_t kStatusMailboxFull = 0x08;
inline constexpr std::uint8_t kStatusBufferMask = 0x30;       // buffered: last buffer written
inline constexpr std::uint8_t kStatusNoBufferWritten = 0x30;  // 11b: none written yet
inline constexpr std::uint8_t kActivateEnable = 0x01;
inline constexpr std::uint8_t kActivateRepeat = 0x02;
inline constexpr std::uint8_t kPdiRepeatAck = 0x02;
}  // namespace sm

struct EscConfig {
  std::uint8_t type = 0xD0;  // the emulated ESC's type byte (not a Beckhoff part number)
  std::uint8_t revision = 1;
  std::uint16_t build = 1;
  std::uint8_t fmmus = 8;          // 1..16
  std::uint8_t sync_managers = 8;  // 1..16
  std::uint8_t ram_kbytes = 8;     // process RAM from 1000h
  std::uint16_t features = 0x0000;
  std::vector<std::uint8_t> sii;  // the SII EEPROM image (sii.hpp build_sii)
  Duration sii_busy_time = std::chrono::microseconds(20);
  // Octets one EEPROM read command delivers into 0508h: 8 (0502h bit 6 set) or 4 (bit 6 clear,
  // 0508h..050Bh only), as the ESC advertises (ET1100/IP core: 8, ET1200 and others: 4).
  std::uint8_t sii_read_bytes = 8;
  // Whether a device follows on port 1 (sets DL status link/loop bits; the segment sets it).
  bool downstream = false;
};

// What a processed frame or the passing of time changed, for the slave front end.
struct EscEvents {
  bool al_control = false;          // ECAT wrote AL control (0120h/0121h)
  bool watchdog_expired = false;    // the process data watchdog expired
  bool sii_command = false;         // ECAT issued an SII command
  bool dc_latched = false;          // ECAT wrote 0900h
  std::uint16_t sm_configured = 0;  // bit n: SyncManager n's registers were written by ECAT
  std::uint16_t sm_written = 0;     // bit n: ECAT completed a write to SM n's buffer
  std::uint16_t sm_read = 0;        // bit n: ECAT completed a read of SM n's buffer
  std::uint16_t sm_repeat = 0;      // bit n: ECAT toggled SM n's repeat request
  bool any() const {
    return al_control || watchdog_expired || sii_command || dc_latched || sm_configured != 0 ||
           sm_written != 0 || sm_read != 0 || sm_repeat != 0;
  }
  EscEvents& operator|=(const EscEvents& other);
};

// One SyncManager's registers as values (for tests and the front end's checks).
struct SyncManagerRegisters {
  std::uint16_t start = 0;
  std::uint16_t length = 0;
  std::uint8_t control = 0;
  std::uint8_t status = 0;
  std::uint8_t activate = 0;
  std::uint8_t pdi_control = 0;
  bool enabled() const { return (activate & sm::kActivateEnable) != 0; }
  bool mailbox() const { return (control & sm::kModeMask) == sm::kModeMailbox; }
  bool ecat_writes() const { return (control & sm::kDirectionMask) == sm::kDirectionEcatWrites; }
};

struct FmmuRegisters {
  std::uint32_t logical_start = 0;
  std::uint16_t length = 0;
  std::uint8_t logical_start_bit = 0;
  std::uint8_t logical_stop_bit = 7;
  std::uint16_t physical_start = 0;
  std::uint8_t physical_start_bit = 0;
  std::uint8_t type = 0;  // bit 0 read, bit 1 write
  bool active = false;
};

// The register blocks as a master writes them (SyncManager n at 0800h + 8n: start, length,
// control, status, activate, PDI control; FMMU n at 0600h + 16n: logical start, length, start
// and stop bit, physical start and bit, type, activate, 3 reserved), little-endian.
std::vector<std::uint8_t> register_block(const SyncManagerRegisters& sm);
std::vector<std::uint8_t> register_block(const FmmuRegisters& fmmu);
// Shorthands: an enabled SyncManager; an active whole-byte FMMU (type 1 read, 2 write).
std::vector<std::uint8_t> sync_manager_block(std::uint16_t start, std::uint16_t length,
                                             std::uint8_t control, bool enable = true);
std::vector<std::uint8_t> fmmu_block(std::uint32_t logical, std::uint16_t length,
                                     std::uint16_t physical, std::uint8_t type);

class Esc {
 public:
  explicit Esc(EscConfig config = {});

  // Processes the frame in place as it passes at `arrival` (local time of its first bit at
  // port 0); `return_arrival` is when it comes back through port 1 (for the DC receive time
  // latch; nullopt when nothing follows). Returns what changed.
  EscEvents process_frame(std::span<std::uint8_t> frame, TimePoint arrival,
                          std::optional<TimePoint> return_arrival = std::nullopt);

  // Lets time pass (watchdog expiry, SII busy). process_frame does this itself.
  EscEvents advance(TimePoint now);
  // When advance() has something to do next (watchdog expiry), or nullopt.
  std::optional<TimePoint> next_deadline() const;

  // ---- the PDI (the slave application's side) ----
  std::uint8_t pdi_read8(std::uint16_t address);
  std::uint16_t pdi_read16(std::uint16_t address);
  std::uint32_t pdi_read32(std::uint16_t address);
  // Writes a byte; false when the PDI may not write it (ECAT-only register, SM buffer not
  // writable from the PDI now, no such address).
  bool pdi_write8(std::uint16_t address, std::uint8_t value);
  bool pdi_write16(std::uint16_t address, std::uint16_t value);
  // A whole mailbox SyncManager buffer as the PDI reads it: the bytes when ECAT filled it
  // (reading empties it), nullopt when empty or `n` is no mailbox written by ECAT.
  std::optional<std::vector<std::uint8_t>> pdi_take_mailbox(unsigned n);
  // Fills a mailbox SyncManager that ECAT reads: `data` padded with zeros to the SM length
  // (longer data is refused). False when the buffer is full or `n` is no such mailbox.
  bool pdi_put_mailbox(unsigned n, std::span<const std::uint8_t> data);
  // Whether the mailbox SM `n` is full (status bit 3).
  bool mailbox_full(unsigned n) const;
  // Sets AL status (0130h) and AL status code (0134h), as the application does.
  void pdi_set_al_status(std::uint16_t status, std::uint16_t code);
  // The last value ECAT wrote to AL control.
  std::uint16_t al_control() const;

  SyncManagerRegisters sync_manager(unsigned n) const;
  FmmuRegisters fmmu(unsigned n) const;
  const EscConfig& config() const { return config_; }
  const std::vector<std::uint8_t>& sii() const { return config_.sii; }

  // Raw memory, for tests and traces: what an ECAT read of `address` would return now
  // (SyncManager buffers as the ECAT side sees them, without changing their state).
  std::uint8_t peek(std::uint16_t address) const;

  // The whole address space as stored (registers, RAM; mailbox contents; buffered SyncManager
  // areas hold their last plain-memory contents, the buffers live apart), for oracles.
  std::span<const std::uint8_t> memory() const { return memory_; }

  // Power-on: registers to their reset values, RAM and buffers cleared (the SII stays).
  void reset();

 private:
  struct SmState {
    bool enabled = false;               // shadow of activate bit 0
    bool repeat = false;                // shadow of activate bit 1
    bool full = false;                  // mailbox: full
    std::vector<std::uint8_t> latest;   // buffered: what the consumer reads
    std::vector<std::uint8_t> staging;  // buffered: what the producer is writing
    std::uint8_t last_buffer = 0;
    bool written_any = false;
    bool interrupt_write = false;  // status bit 0: written completely, not yet read
    bool interrupt_read = false;   // status bit 1: read completely, not yet written again
  };

  bool ecat_read(std::uint16_t address, std::uint8_t& out, EscEvents& events);
  bool ecat_write(std::uint16_t address, std::uint8_t value, EscEvents& events);
  int find_sm(std::uint16_t address) const;
  void after_register_write(std::size_t first, std::size_t last, EscEvents& events);
  std::uint8_t raw_get(std::uint16_t address) const;
  void process_datagram(std::span<std::uint8_t> datagram, std::size_t data_length,
                        EscEvents& events);
  void logical_access(std::span<std::uint8_t> data, std::uint32_t address, bool read, bool write,
                      bool& any_read, bool& any_write, EscEvents& events);
  void refresh_dynamic(TimePoint now);
  void run_sii_command(std::uint16_t control, EscEvents& events);
  void restart_watchdog();
  Duration watchdog_period() const;
  void set16(std::uint16_t address, std::uint16_t value);
  void set32(std::uint16_t address, std::uint32_t value);
  void set64(std::uint16_t address, std::uint64_t value);
  std::uint16_t get16(std::uint16_t address) const;
  std::uint32_t get32(std::uint16_t address) const;
  std::uint64_t get64(std::uint16_t address) const;
  void sm_completed_ecat_write(unsigned n, EscEvents& events);
  // A producer completed a buffered SM's buffer: the consumer sees it now.
  void publish_buffer(SmState& s, unsigned n, EscEvents* events);

  EscConfig config_;
  std::vector<std::uint8_t> memory_;            // 0000h .. end of RAM
  std::array<std::uint8_t, 0x1000> ecat_rw_{};  // per register byte: ECAT may write
  std::array<std::uint8_t, 0x1000> pdi_rw_{};   // per register byte: PDI may write
  std::array<SmState, 16> sms_{};
  TimePoint now_{};
  TimePoint frame_arrival_{};
  std::optional<TimePoint> frame_return_{};
  std::optional<TimePoint> watchdog_deadline_;
  TimePoint sii_busy_until_{};
  std::uint16_t sii_errors_ = 0;
  std::uint16_t sii_static_ = 0;   // 0502h bits fixed at reset: read size, algorithm, load errors
  std::uint16_t sii_running_ = 0;  // 0502h bits 10..8 while busy: the command executing
  bool sii_loaded_ = false;        // the ESC configuration area (words 0..7) loaded at reset
  std::vector<DatagramSpan> spans_;
  std::vector<std::uint8_t> scratch_;
};

}  // namespace drivecheck::ethercat
