// The reference drive: one CANopen device (CiA 301 part) on one can::Bus port and one node-ID,
// composed of the protocol services (protocol/cia301):
//
//   DeviceServices  NMT slave, heartbeat producer/consumer, node guarding, EMCY, SYNC
//   SdoServer       the default SDO server channel (600h/580h + node-ID, 1200h), and the
//                   further channels of DictionaryOptions::extra_sdo_servers (1201h.., on the
//                   COB-IDs its record holds, off while they are not valid)
//   PdoService      4 RPDOs and 4 TPDOs, dynamic mapping (pdo_service.hpp)
//   StoreRestore    1010h/1011h over an injected ParameterStorage (memory or a file)
// over one object dictionary (dictionary.hpp). Any number of drives share a SimBus, one port
// each; on SocketCAN the port is the interface (`drivecheck drive`).
//
// Frames on the port go first to DeviceServices (NMT, error control, SYNC), then to the TIME
// consumer (1012h, time_consumer.hpp), the SDO client (answers on 1280h sub 02h while a
// transfer of it runs, sdo_client_channel.hpp), the SDO server (its request COB-ID, while the
// NMT state allows SDO), then to the PDO service (RPDOs and TPDO RTRs, in Operational). The
// SDO client starts a transfer the request object 2F00h asks for once the SDO write that asked
// is answered; NMT Stopped and every reset end its transfer without a frame. The drive reacts to
// the NMT state as CiA 301 §7.3.2.2 says: an open SDO transfer is dropped without a frame in
// Stopped and at every reset; PDOs run only in Operational. Resets (and power on) apply the stored
// parameters (StoreRestore::apply): reset node the application and manufacturer groups, then (every
// reset) the communication group; then the PDOs are reconfigured and their EMCYs cleared. A write
// of a further SDO channel's record takes effect once the frame that wrote it is answered (the
// answer leaves on the old COB-ID); a channel on the default channel's request COB-ID gets nothing
// (the default channel takes the frame).
//
// Bus-off: the owner of the port tells the drive what its CAN controller reports
// (set_bus_off, as a controller's status interrupt would). CiA 301: at bus-off the
// communication error behaviour of 1029h:01 applies; at recovery the drive sends EMCY 8140h
// (recovered from bus off, error register bit 4), active until the next reset communication.
// DriveConfig::on_bus_off lets the application react instead (Kollmorgen F23, ESR 8180h).
//
// PDO errors become EMCYs with error register bit 4 (communication): 8210h, 8220h, 8250h.
//
// The drive turns loopback on for its port: the echo of its own frames (end of frame on the
// wire) goes to PdoService::on_sent, which hands out the next synchronous TPDO while the
// synchronous window 1007h is open (pdo_service.hpp).
//
// The application (the CiA 402 part comes in the next issue) plugs in through DriveApplication:
// it adds its objects before the services bind, is told about resets and NMT states, and gets a
// hook every control cycle (DriveConfig::control_cycle, default 1 ms, on the bus's clock) with
// the object dictionary at hand; after each cycle event-driven TPDOs see the changed values.
// Nothing else in the drive knows the application.
//
// Deviations (DriveConfig::deviations, reference_drive/deviations.hpp): a DeviationPort wraps
// the bus port (wire-level faults); the drive itself serves SDO in Stopped, runs PDOs in
// Pre-operational, hides the SYNC counter from the PDOs, keeps the communication objects over
// a reset communication, never times out SDO, and tells DeviceServices to ignore heartbeat
// consumer timeouts and the EMCY inhibit time, when the set says so.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/deadline_timer.hpp"
#include "protocol/cia301/device_services.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/pdo_service.hpp"
#include "protocol/cia301/sdo_server.hpp"
#include "protocol/cia301/store_restore.hpp"
#include "protocol/common/expected.hpp"
#include "reference_drive/deviations.hpp"
#include "reference_drive/dictionary.hpp"
#include "reference_drive/sdo_client_channel.hpp"
#include "reference_drive/time_consumer.hpp"

namespace drivecheck::reference_drive {

class ReferenceDrive;
class ReboundBus;  // device.cpp: the port the drive talks through, re-pointed by restart()

// The device's application: everything above CiA 301 communication.
class DriveApplication {
 public:
  virtual ~DriveApplication() = default;
  // Adds the application's objects, once, before the services start (2000h-9FFFh).
  virtual Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) {
    (void)od;
    return {};
  }
  // A reset while initialising, after the stored parameters of its groups were applied:
  // ResetKind::application (power on, reset node), then ResetKind::communication.
  virtual void on_reset(ReferenceDrive& drive, cia301::ResetKind kind) {
    (void)drive;
    (void)kind;
  }
  // Every change of the NMT state.
  virtual void on_nmt_state(ReferenceDrive& drive, cia301::NmtState from, cia301::NmtState to) {
    (void)drive;
    (void)from;
    (void)to;
  }
  // Every control cycle, in every NMT state once powered on.
  virtual void on_cycle(ReferenceDrive& drive, can::TimePoint now) {
    (void)drive;
    (void)now;
  }
  // A SYNC was received (or produced by this device) at `at`, after the PDOs took it (the
  // synchronous RPDOs' data is in the dictionary): the synchronous modes of operation start
  // their cycle here.
  virtual void on_sync(ReferenceDrive& drive, can::TimePoint at) {
    (void)drive;
    (void)at;
  }
  // Heartbeat consumer timeout or life guarding event (the services have sent EMCY 8130h and
  // applied 1029h): CiA 402's abort connection reaction (6007h) starts here.
  virtual void on_communication_loss(ReferenceDrive& drive) { (void)drive; }
  // Bus-off, NMT Stopped entered or a reset communication of its own (CiA 402-2 lists them as
  // abort connection events too; DriveConfig::can_abort_connection_events): the 6007h reaction
  // where the application applies it (the CiA 402 application: in OPERATION ENABLED only).
  virtual void on_connection_event(ReferenceDrive& drive) { (void)drive; }
  // The drive is being destroyed (its dictionary goes with it): drop every reference to it.
  virtual void on_drive_destroyed(ReferenceDrive& drive) { (void)drive; }
};

struct DriveConfig {
  DictionaryOptions dictionary;  // node-ID, identity, PDO counts, 1017h default, ...
  // CiA 402-2 6007h on CAN: bus-off, entering NMT Stopped and a reset communication of its own
  // are abort connection events (on_communication_loss), besides heartbeat and life guarding.
  // False behind EtherCAT (reference_drive/ethercat), whose AL states drive the NMT state and
  // whose event is leaving OP.
  bool can_abort_connection_events = true;
  // The application's control cycle; 0: none (then event-driven TPDOs see changes only at
  // their timers and at SYNC/SDO activity).
  can::Duration control_cycle = std::chrono::milliseconds(1);
  // Power on or reset command to boot-up message.
  can::Duration initialisation_time{0};
  can::Duration sdo_timeout = std::chrono::milliseconds(1000);
  // SDO requests shorter than 8 bytes: ignored (CiA 301) or padded with 00h (sdo_server.hpp).
  cia301::ShortFramePolicy sdo_short_frames = cia301::ShortFramePolicy::ignore;
  // Where 1010h saves to; nullptr: a MemoryParameterStorage the drive owns. Must outlive the
  // drive.
  cia301::ParameterStorage* storage = nullptr;
  // nullptr: no application. Must outlive the drive.
  DriveApplication* application = nullptr;
  // Bus-off reaction in place of CiA 301's (see the file comment); called with true at bus-off
  // (after the NMT reaction of 1029h:01) and false at recovery (no EMCY 8140h is sent then).
  // `transmitted` says whether a frame of the drive got onto the wire since power on. Empty:
  // the CiA 301 reaction only.
  std::function<void(ReferenceDrive&, bool bus_off, bool transmitted)> on_bus_off;
  // Objects the device does not have (personality key absent_objects): index ranges [first,
  // last] removed from the dictionary after the application added its objects, before the
  // services bind. The services whose objects are gone are off (device_services.hpp); without
  // 1010h/1011h there is no store/restore (each reset applies the defaults).
  std::vector<std::pair<std::uint16_t, std::uint16_t>> absent_objects;
  // The NMT reaction to a communication error (heartbeat or life guarding event, bus-off) of a
  // drive without 1029h, as a 1029h sub 01h value (DeviceServicesConfig::
  // communication_error_without_object): 0, CiA 301 §7.5.2.32's default (Operational ->
  // Pre-operational); personality key guarding_loss: no-nmt-change makes it 1 (Kollmorgen).
  std::uint8_t communication_error_without_1029 = 0;
  // TPDOs of type n without a SYNC start value start their count at the first SYNC (personality
  // key tpdo_sync_phase: first-sync; PdoService::set_first_sync_phase).
  bool tpdo_first_sync_phase = false;
  // Asked before a 1011h "load" is carried out (StoreRestore::set_restore_guard): an abort it
  // returns answers the write (Festo: 08000022h with the output stage on, 000 §5.1 L2501).
  // Empty: every restore is carried out.
  std::function<Expected<void, cia301::SdoAbort>()> restore_guard;
  // Named deviations (deviations.hpp; empty: the conformant drive). The drive applies the
  // CiA 301 ones (a DeviationPort between it and `bus`, and its own hooks); the application
  // applies the CiA 402 ones from its own copy.
  DeviationSet deviations;
};

struct DriveStatistics {
  std::uint64_t frames_sent = 0;
  std::uint64_t send_errors = 0;  // bus send() failures (bus-off, queue full)
  std::uint64_t cycles = 0;       // control cycles run
};

class ReferenceDrive {
 public:
  // Builds the dictionary (and the application's objects), reads the storage and binds the
  // services to `bus`, which must outlive the drive. The drive is powered off: power_on().
  // Errors: a bad option (node-ID), the application's objects, an unreadable storage.
  static Expected<std::unique_ptr<ReferenceDrive>, std::string> create(can::Bus& bus,
                                                                       DriveConfig config);
  ~ReferenceDrive();
  // The drive as create() left it, now on `bus` (which must outlive the drive; the previous
  // bus must still exist during this call unless release_bus() left it): services unbound
  // from the old bus and bound anew, every entry's value and hooks as they were before the
  // services bound (only entries whose revision() moved and whose bytes differ are copied
  // back: an entry a reset stored its unchanged default into keeps its revision), the drive's own
  // parameter storage emptied (an injected DriveConfig::storage keeps what it holds, as it
  // would over a power cycle), statistics cleared, powered off. Much cheaper than create(): no
  // dictionary is built. The application is not told: its owner resets its state. Error: a
  // drive with deviations (their port keeps fatal states "until power off"), or a service that
  // does not bind.
  Expected<void, std::string> restart(can::Bus& bus);
  // Leaves the bus, e.g. before it is destroyed: the services go (timers cancelled, frame
  // handler removed, their memory freed). Afterwards only restart() and destruction are allowed.
  // (A drive with deviations cannot restart; its deviation port stays on the bus.)
  void release_bus();
  ReferenceDrive(const ReferenceDrive&) = delete;
  ReferenceDrive& operator=(const ReferenceDrive&) = delete;

  // Power on: initialisation (stored parameters applied), boot-up after initialisation_time,
  // Pre-operational.
  void power_on();
  // Local NMT control, as if the master had sent it.
  void command(cia301::NmtCommand command);
  // The stored parameters of every group (communication, application, manufacturer) applied
  // now, as at power on, without a reset: no NMT transition, no boot-up, the CiA 402 state
  // kept (an EtherCAT slave that loads its saved values in INIT, Festo 000 §4.7 L2056).
  void load_stored_parameters();
  // What the CAN controller reports: bus-off (true) or recovered (false). Repeats are ignored.
  void set_bus_off(bool bus_off);
  bool bus_off() const { return bus_off_; }

  cia301::ObjectDictionary& dictionary() { return *od_; }
  const cia301::ObjectDictionary& dictionary() const { return *od_; }
  cia301::NmtState state() const { return services_->state(); }
  std::uint8_t node_id() const { return od_->node_id(); }
  can::Bus& bus() { return bus_; }

  // The application's errors (EMCY, 1001h, 1003h).
  bool raise_error(std::uint16_t code, std::uint8_t register_bits,
                   const std::array<std::uint8_t, 5>& manufacturer = {});
  bool clear_error(std::uint16_t code);
  // An application event for a TPDO (transmission types 0, 254, 255).
  bool trigger_tpdo(std::uint16_t number);

  const cia301::DeviceServices& services() const { return *services_; }
  const cia301::SdoServer& sdo_server() const { return *sdo_; }
  // The further SDO server channels, 1201h + i (i < extra_sdo_server_count()).
  std::size_t extra_sdo_server_count() const { return extra_sdo_.size(); }
  const cia301::SdoServer& extra_sdo_server(std::size_t i) const { return *extra_sdo_.at(i); }
  const cia301::PdoService& pdos() const { return *pdos_; }
  // Precondition: has_store() (1010h and 1011h exist).
  const cia301::StoreRestore& store() const { return *store_; }
  bool has_store() const { return store_ != nullptr; }
  const DriveStatistics& statistics() const { return stats_; }
  const DriveConfig& config() const { return config_; }
  // The wire-level deviations (nullptr when config().deviations is empty).
  const DeviationPort* deviation_port() const { return deviation_port_.get(); }

 private:
  ReferenceDrive(can::Bus& bus, DriveConfig config);
  Expected<void, std::string> start();
  // start() after the dictionary: storage, services, frame handler (also restart()).
  Expected<void, std::string> bind_services();
  // The entries' values and hooks before the services bound, and restoring them (restart()).
  void take_snapshot();
  Expected<void, std::string> restore_snapshot();

  bool has(Deviation deviation) const { return config_.deviations.has(deviation); }
  void on_frame(const can::TimedFrame& frame);
  bool sdo_allowed() const;
  void sync_sdo_channels();
  void reset_sdo_servers();
  void on_reset(cia301::ResetKind kind);
  // The stored parameters of `group`, or its defaults without store/restore.
  void apply_stored(std::uint8_t group);
  void on_state_changed(cia301::NmtState from, cia301::NmtState to);
  // An event of the abort connection option code 6007h other than heartbeat and life guarding
  // (CiA 402-2: bus-off, NMT Stopped entered, reset communication): the application's
  // on_communication_loss.
  void abort_connection_event();
  void on_sync(const cia301::SyncConsumerEvent& event);
  void handle(const cia301::PdoOutput& output);
  void send(const can::Frame& frame);
  void tick();
  void rearm();

  // Deviations: the wire-level ones sit between the drive and the bus passed to create()
  // (declared before bus_, which refers to it when there is one).
  std::unique_ptr<ReboundBus> rebound_bus_;  // between bus_ (or the deviation port) and the bus
  std::unique_ptr<DeviationPort> deviation_port_;
  bool application_reset_ = false;  // nmt-reset-communication-keeps-values
  // restore-communication-at-reset-node-only: the stored parameters before the last restore
  // command since the last reset node.
  std::optional<cia301::ObjectDictionary::StoredParameters> stored_before_restore_;
  can::Bus& bus_;
  DriveConfig config_;
  std::unique_ptr<cia301::ObjectDictionary> od_;
  std::unique_ptr<cia301::MemoryParameterStorage> own_storage_;
  std::unique_ptr<cia301::StoreRestore> store_;
  std::unique_ptr<cia301::PdoService> pdos_;
  std::unique_ptr<cia301::SdoServer> sdo_;
  std::unique_ptr<cia301::SdoServerRunner> sdo_runner_;
  std::vector<std::unique_ptr<cia301::SdoServer>> extra_sdo_;
  std::vector<std::unique_ptr<cia301::SdoServerRunner>> extra_sdo_runners_;  // after extra_sdo_
  bool sdo_channels_changed_ = false;
  std::unique_ptr<SdoClientChannel> sdo_client_;  // 1280h, 2F00h (nullptr: none)
  std::unique_ptr<TimeConsumer> time_consumer_;   // 1012h, 2F01h (nullptr: none)
  void send_all(const std::vector<can::Frame>& frames);
  bool bus_off_ = false;
  bool transmitted_ = false;  // a frame of ours reached the wire since power on
  std::unique_ptr<cia301::DeviceServices> services_;
  bool powered_ = false;
  can::TimePoint next_cycle_ = can::kForever;
  can::DeadlineTimer timer_{bus_, [this] { tick(); }};
  bool in_tick_ = false;
  DriveStatistics stats_;
  // restart(): each entry's value (with the revision() it last had with these bytes) and
  // hooks before the services bound. Entry pointers stay valid: no object is added after start().
  struct PristineEntry {
    cia301::Entry* entry = nullptr;
    std::vector<std::uint8_t> bytes;
    std::uint64_t revision = 0;
    cia301::ReadHook read_hook;
    cia301::WriteValidator validator;
    cia301::WriteObserver observer;
  };
  std::vector<PristineEntry> pristine_;
  std::uint8_t pristine_node_id_ = 0;
};

}  // namespace drivecheck::reference_drive
