// EthercatDrive: the reference drive (ServoDrive: the same CiA 301 device and CiA 402 drive as on
// CAN, same dictionary, same personalities and named deviations) behind an emulated EtherCAT
// slave controller. A SegmentDevice for the simulated segment; serve() puts it on a RawLink
// (a NIC or a veth end: `drivecheck drive --bus ethercat:IF`).
//
//   ESC + ESM      protocol/ethercat EscSlave, SII from the dictionary (sii_image.hpp)
//   mailbox + CoE  protocol/ethercat CoeSlave over the drive's dictionary: SDO (the
//                  dictionary's access rules, aborts from the one table), SDO information,
//                  emergencies; SM0 written -> request, SM1 free -> next reply
//   CoE objects    1C00h, 1C12h, 1C13h, 1C32h, 1C33h added with the application's objects;
//                  their rules (PDO assignment and mapping only in PREOP, the assignment's
//                  content) as the profile's `coe:` says (coe.pdo_configuration_in,
//                  coe.pdo_assignment_evaluated; Festo 000 L1931: not evaluated)
//   CoE rules      the profile's coe.absent_objects and coe.max_sdo_size on the SDO server
//                  (coe_rules.hpp), in front of the SDO service deviations
//   process data   process_data.hpp: SM2 (RxPDOs) written by the master -> mapped objects, in OP
//                  only (SAFEOP: "ignores new setpoint values", Festo 000 §4.7 L2058);
//                  mapped objects -> SM3 (TxPDOs) in SAFEOP and OP, before each frame passes
//   clock          the drive runs on the link's clock (clock_port.hpp): simulated time on a
//                  SimSegment; its EMCYs become CoE emergencies
//
// Default PDOs (when the personality gives no PDO defaults at all; a personality that gives
// some keeps exactly its own): 1C12h = {1600h}, 1600h = 6040h:00 (16),
// 607Ah:00 (32); 1C13h = {1A00h}, 1A00h = 6041h:00 (16), 6064h:00 (32); 1601h = 60FFh:00,
// 1602h = 6071h:00, 1A01h = 606Ch:00, 1A02h = 6077h:00, 6061h:00 for the other cyclic modes (our
// choice: the objects CiA 402-2's cyclic synchronous modes exchange). The default assignment
// 1C12h/1C13h names 1600h/1A00h only where that mapping object exists (not among the
// personality's absent objects) and maps something; else it is empty (cia301-minimal: no
// RxPDO, 1C12h:00 = 0). Mappings may be written
// while "valid": COB-IDs mean nothing on EtherCAT (ETG.1000.6: PDO configuration in PREOP).
//
// AL state -> drive (Festo 000 §4.7.1 Tab. 4.11: Init ~ Stopped, Operational ~ Operational,
// Safe-Operational has no NMT counterpart; we take Pre-operational for PREOP and SAFEOP):
//   INIT           NMT Stopped, mailbox and CoE reset (transfers forgotten, counters cleared);
//                  with the profile's coe.init_loads_saved_values (Festo 000 §4.7 L2056) the
//                  saved parameters are applied on entering INIT from another state
//                  (ReferenceDrive::load_stored_parameters; named deviation
//                  init-saved-values-not-loaded leaves them)
//   PREOP, SAFEOP  NMT Pre-operational
//   OP             NMT Operational
// Leaving OP (OS, OP, OI, and the SM watchdog dropping OP to SAFEOP, AL status code 001Bh)
// is a loss of the master's connection: the drive's abort connection reaction 6007h runs
// (CiA 402-2 6007h: "the function that is performed if there is a connection loss"; as a
// heartbeat loss does on CAN, device.hpp), so an enabled motor stops (6007h = 1: fault).
//
// Synchronisation: 1C32h:01 = 0 free run (the modes latch their command every drive cycle);
// 1 SM-synchronous (ETG.1020 as public) or 2/3 DC: each SM2 write is the cyclic modes' SYNC
// (DriveApplication::on_sync, as a CAN SYNC is).
//
// The SDO service deviations (sdo-read-only-wrong-abort, device-type-wrong, store-signature-
// ignored, ...: reference_drive/sdo_deviations.hpp) act on the CoE SDO server through
// coe_deviations.hpp, as DeviationPort makes them act on CAN SDO frames.
// Named EtherCAT deviations (deviations.inc, family ethercat/...): wrong-working-counter (the
// working counter of every LRW is put back as it came in), al-status-code-missing (0134h
// written 0 while the error indication is set), mailbox-counter-ignored
// (MailboxSlaveConfig::honour_counter off), sm-watchdog-ignored (the watchdog leaves OP alone).
//
// Mailbox repeat (ETG.1000.4): when the master toggles SM1's repeat request, the last reply goes
// into SM1 again (unless SM1 still holds it) and the repeat acknowledge (0807h+8 bit 1, written
// by the PDI) takes the request's value.
//
// SDO information lists and describes only the objects the SDO server serves: the profile's
// coe.absent_objects are left out of every list and their descriptions answer 06020000h.
// Named deviation coe-sdo-size-limit-ignored: the profile's coe.max_sdo_size is not applied.
//
// Not here yet: DC sync pulses; Festo's process data from the CANopen PDO configuration
// instead of 1C12h/1C13h (000 L1933).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/cia301/store_restore.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/ethercat/coe_sdo_server.hpp"
#include "protocol/ethercat/esc_slave.hpp"
#include "protocol/ethercat/link.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/deviations.hpp"
#include "reference_drive/ethercat/clock_port.hpp"
#include "reference_drive/ethercat/coe_deviations.hpp"
#include "reference_drive/ethercat/coe_rules.hpp"
#include "reference_drive/ethercat/process_data.hpp"
#include "reference_drive/servo_drive.hpp"

namespace drivecheck::reference_drive::ethercat {

struct EthercatDriveOptions {
  // The drive to impersonate; nullptr: the standard drive. Only read during create().
  const profile::DriveProfile* profile = nullptr;
  DeviationSet deviations;
  cia301::ParameterStorage* storage = nullptr;  // must outlive the drive; nullptr: memory
  std::uint32_t serial_number = 1;              // 1018h:04
  // The drive's CoE rules; nullopt: the profile's `coe:` (the standard drive: the defaults).
  std::optional<profile::CoeRules> coe;
};

class CoeObjectsApplication;

class EthercatDrive final : public drivecheck::ethercat::SegmentDevice {
 public:
  // `clock` gives the drive its time and timers (the segment it is attached to, or the link it
  // is served on); it must outlive the drive. The drive is powered off: power_on().
  static Expected<std::unique_ptr<EthercatDrive>, std::string> create(
      drivecheck::ethercat::Link& clock, EthercatDriveOptions options = {});
  ~EthercatDrive() override;
  EthercatDrive(const EthercatDrive&) = delete;
  EthercatDrive& operator=(const EthercatDrive&) = delete;

  // Power on: the ESC's registers at reset, AL INIT, the drive initialised (NMT Stopped).
  void power_on();

  // SegmentDevice: the frame passes the ESC.
  void on_frame(std::span<std::uint8_t> frame, drivecheck::ethercat::TimePoint arrival,
                std::optional<drivecheck::ethercat::TimePoint> return_arrival) override;

  // Serves frames arriving on `link` (a RawLink on the slave's end): each is processed and sent
  // back. The handler stays until the drive is destroyed or serve() is called with another link.
  void serve(drivecheck::ethercat::Link& link);

  ServoDrive& servo() { return *servo_; }
  cia301::ObjectDictionary& dictionary() { return servo_->device().dictionary(); }
  drivecheck::ethercat::EscSlave& slave() { return *slave_; }
  drivecheck::ethercat::CoeSlave& coe() { return *coe_; }
  const std::vector<std::uint8_t>& sii() const { return sii_; }
  // The process data as configured at the last PS transition.
  const ProcessDataLayout& outputs() const { return outputs_; }
  const ProcessDataLayout& inputs() const { return inputs_; }
  // Output writes the dictionary refused (an RxPDO entry out of range, ...).
  std::uint64_t refused_outputs() const { return refused_outputs_; }
  std::uint64_t emergencies_dropped() const { return emergencies_dropped_; }

 private:
  explicit EthercatDrive(drivecheck::ethercat::Link& clock, EthercatDriveOptions options);
  Expected<void, std::string> build();
  void power_on_esc();  // a new ESC + ESM (power-on state), CoE reset
  drivecheck::ethercat::AlStatusCode check(const drivecheck::ethercat::AlTransition& t);
  void on_state_change(drivecheck::ethercat::AlState from, drivecheck::ethercat::AlState to);
  void on_events(const drivecheck::ethercat::EscEvents& events);
  void on_emcy(const cia301::Emcy& emcy);
  void feed_read_mailbox();
  void repeat_read_mailbox();  // SM1 repeat request: the last reply again, then the acknowledge
  void refresh_inputs();
  void after_esc();  // deviations on the AL status code; the watchdog timer
  void arm_watchdog_timer();
  bool has(Deviation d) const { return options_.deviations.has(d); }

  drivecheck::ethercat::Link& clock_;
  EthercatDriveOptions options_;
  LinkClockPort port_;
  std::unique_ptr<CoeObjectsApplication> application_;  // outlives servo_
  std::unique_ptr<ServoDrive> servo_;
  std::vector<std::uint8_t> sii_;
  std::unique_ptr<drivecheck::ethercat::EscSlave> slave_;
  std::unique_ptr<CoeDeviationHook> coe_deviations_;  // outlives coe_ and coe_rules_
  std::unique_ptr<CoeRulesHook> coe_rules_;           // outlives coe_
  std::unique_ptr<drivecheck::ethercat::CoeSlave> coe_;
  bool init_loads_saved_values_ = false;  // the profile's coe.init_loads_saved_values
  ProcessDataLayout outputs_;
  ProcessDataLayout inputs_;
  std::optional<std::uint64_t> inputs_revision_;  // dictionary revision SM3 was filled from
  std::uint64_t refused_outputs_ = 0;
  std::uint64_t emergencies_dropped_ = 0;
  drivecheck::ethercat::TimerId watchdog_timer_ = drivecheck::ethercat::kNoTimer;
  std::optional<drivecheck::ethercat::TimePoint> watchdog_at_;
  drivecheck::ethercat::Link* served_ = nullptr;
  std::vector<std::uint8_t> scratch_;
  std::vector<std::uint8_t> served_frame_;
  std::vector<drivecheck::ethercat::DatagramSpan> spans_;
  std::vector<std::size_t> lrw_counters_;  // wrong-working-counter: WKC offsets of LRWs
  std::vector<std::uint16_t> lrw_values_;
};

}  // namespace drivecheck::reference_drive::ethercat
