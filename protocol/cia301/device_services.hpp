// The CiA 301 device-side communication services of one node, run together on one bus port:
// NMT slave (nmt_slave.hpp), heartbeat producer (heartbeat_producer.hpp), heartbeat consumer
// (heartbeat_consumer.hpp with the 1016h objects of heartbeat_consumer_objects.hpp), node-
// guarding slave (guarding_slave.hpp), EMCY producer (emcy_producer.hpp), SYNC consumer and the
// device's optional SYNC producer (sync_consumer.hpp, sync_producer.hpp).
//
// This is the thin adapter of those pure state machines over a can::Bus: one frame handler,
// one bus timer at the earliest deadline of all of them, and write observers on their objects
// so that an SDO write takes effect at once (CiA 301 §7.5.2: e.g. a new 1017h reschedules the
// heartbeat, a new 1016h entry restarts that node's monitoring). The SDO server and the PDOs
// are the owner's: it passes their frames on (DeviceServicesHandlers::other_frames, or its own
// dispatcher around handle()) and asks allows(NmtService::sdo / pdo) before serving them.
//
// What it does on its own (CiA 301 references in the files named above):
//  - Power on and every reset: Initialisation, the owner's on_reset handler (application for
//    power on and reset node, then communication), the boot-up message after
//    DeviceServicesConfig::initialisation_time, then Pre-operational. The node-ID of the boot-up
//    message and of every service is the object dictionary's node_id() as the owner left it.
//  - Services follow the NMT state (NmtService table): EMCY only in Pre-operational and
//    Operational, SYNC consumption/production likewise, heartbeat and guarding in all three.
//  - Communication errors (a heartbeat consumer timeout, a life guarding event): EMCY 8130h
//    "life guard error or heartbeat error" with error register bit 4 (communication), sent
//    before the NMT state changes, then the reaction of 1029h sub 01h (0: Operational ->
//    Pre-operational, 1: none, 2: -> Stopped; 1029h missing: as 0, its default). 8130h is
//    cleared (error-reset EMCY when nothing else is active) when every monitored node sends
//    heartbeats again and guarding requests come again.
//  - A SYNC with the wrong length: EMCY 8240h (error register bit 4), cleared by the next SYNC
//    of the right length.
//  - A service whose objects do not exist is off (no 1017h: no heartbeat; no 100Ch/100Dh: no
//    guarding answers; no 1014h: no EMCY; no 1016h: no consumer; no 1005h: SYNC on 080h
//    without counter and no producer).
//  - Resets: reset node clears every error and the error history (the application restarts);
//    reset communication drops queued EMCYs and forgets the communication errors (8130h, 8240h,
//    without an EMCY: EMCY is not allowed while initialising) but keeps the application's.
//
// Lifetime: the bus and the object dictionary must outlive this object. While it lives it owns
// the write observers of 1003h sub 00h, 1005h, 1006h, 1007h, 100Ch, 100Dh, 1014h, 1015h,
// 1016h sub 01h.., 1017h and 1019h; the destructor removes them (1003h sub 00h gets back the
// observer add_emcy_producer_objects installs), its frame handler (if attach() set one) and its
// timer.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/deadline_timer.hpp"
#include "protocol/cia301/emcy_producer.hpp"
#include "protocol/cia301/guarding_slave.hpp"
#include "protocol/cia301/heartbeat_consumer.hpp"
#include "protocol/cia301/heartbeat_consumer_objects.hpp"
#include "protocol/cia301/heartbeat_producer.hpp"
#include "protocol/cia301/nmt_slave.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sync_consumer.hpp"
#include "protocol/cia301/sync_producer.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

enum class ResetKind : std::uint8_t {
  application,    // reset the application parameters (2000h-9FFFh) to their stored values
  communication,  // reset the communication parameters (1000h-1FFFh) to their stored values
};
std::string_view to_string(ResetKind kind);

struct DeviceServicesConfig {
  // Time from power on or a reset command to the boot-up message (the device's start-up time).
  can::Duration initialisation_time{0};
  // Fault injection (the reference drive's named deviations; both true in a conformant device):
  // false: heartbeat consumer timeouts (and their resumption) are not events: no EMCY 8130h, no
  // 1029h reaction, handlers.on_heartbeat is not told.
  bool heartbeat_consumer_timeouts = true;
  // false: the EMCY producer ignores the inhibit time 1015h (1015h still reads as written).
  bool emcy_inhibit = true;
  // false: a communication error always takes the reaction of 1029h sub 01h = 0, whatever the
  // object holds (error-behaviour-ignored).
  bool error_behaviour = true;
  // false: a heartbeat consumer timeout takes no NMT reaction at all, whatever 1029h sub 01h
  // holds (EMCY 8130h is still sent; heartbeat-timeout-keeps-nmt-state).
  bool heartbeat_timeout_nmt_reaction = true;
  // The communication error behaviour of a device without 1029h (a value of 1029h sub 01h,
  // CommunicationErrorBehaviour): 0, pre-operational, is CiA 301 §7.5.2.32's default (a device
  // in Operational enters Pre-operational by default; 1029h, where implemented, configures
  // another). A manual may document a fixed other reaction (Kollmorgen S300/S700: none, 1).
  // Not used while the dictionary has 1029h sub 01h.
  std::uint8_t communication_error_without_object = 0;
  // true: 1029h sub 01h = 2 (stopped) acts only in Operational, as 0 does (error-behaviour-
  // stopped-only-in-operational); false in a conformant device.
  bool error_behaviour_stopped_only_in_operational = false;
  // true: SYNC frames are consumed in Stopped too (pdo-in-stopped; false in a conformant device).
  bool sync_in_stopped = false;
  // false: once 1003h is full, new errors are not entered (the oldest stay; emcy-history-full-
  // not-shifted); true in a conformant device (the oldest entry drops out).
  bool error_history_shift_when_full = true;
};

struct DeviceServicesHandlers {
  // Called while initialising: ResetKind::application (power on, reset node), then
  // ResetKind::communication (always). Empty: the object dictionary's defaults of the groups
  // are restored (application: kStoreApplication and kStoreManufacturer; communication:
  // kStoreCommunication), i.e. the values a device without stored parameters starts with.
  std::function<void(ResetKind)> on_reset;
  // Every change of the NMT state (from boot_up when initialisation ends; to boot_up at a
  // reset).
  std::function<void(NmtState from, NmtState to)> on_state_changed;
  // SYNC received (or produced by this device), wrong SYNC length, synchronous window closed.
  std::function<void(const SyncConsumerEvent&)> on_sync;
  // Heartbeat consumer events (boot-up, state change, timeout, resumed, invalid frame).
  std::function<void(const HeartbeatEvent&)> on_heartbeat;
  std::function<void(const LifeGuardingEvent&)> on_life_guarding;
  // attach() only: frames these services do not take (SDO, PDO, TIME, ...).
  std::function<void(const can::TimedFrame&)> other_frames;
};

// What DeviceServices::add_objects adds.
struct DeviceObjectsOptions {
  std::uint16_t producer_heartbeat_ms = 0;      // default of 1017h
  std::uint8_t heartbeat_consumer_entries = 4;  // 1016h sub-entries (0: no 1016h)
  std::uint8_t error_history_size = 8;          // 1003h sub-entries
  bool node_guarding = true;                    // 100Ch, 100Dh
  bool sync_producer_supported = true;          // 1005h bit 30 may be set
};

class DeviceServices {
 public:
  // Adds 1001h, 1003h, 1005h, 1006h, 1007h, 100Ch, 100Dh (node_guarding), 1014h, 1015h, 1016h
  // (entries > 0), 1017h, 1019h and 1029h. Errors: an index is taken.
  static Expected<void, std::string> add_objects(ObjectDictionary& od,
                                                 const DeviceObjectsOptions& options = {});

  // The node starts powered off: call power_on(). Binds the write observers at once.
  DeviceServices(can::Bus& bus, ObjectDictionary& od, DeviceServicesConfig config = {},
                 DeviceServicesHandlers handlers = {});
  ~DeviceServices();
  DeviceServices(const DeviceServices&) = delete;
  DeviceServices& operator=(const DeviceServices&) = delete;

  // Sets the bus port's frame handler: handle(), and other_frames for what it does not take.
  void attach();
  // One frame from the bus (at frame.timestamp). Returns whether it was one of these services'
  // frames (NMT node control, error control on 700h + node, SYNC); the others are the owner's.
  bool handle(const can::TimedFrame& frame);

  // Power on, transition (1): Initialisation, then boot-up and Pre-operational. While powered,
  // a power cycle: as power_off() then power_on().
  void power_on();
  // The node goes silent: nothing is sent or taken (handle() returns false) until power_on().
  // The object dictionary keeps its values; errors and the history are kept until the
  // application reset of the next power_on().
  void power_off();
  bool powered() const { return powered_; }
  // Local NMT control, obeyed as if the master had sent it to this node.
  void command(NmtCommand command);

  NmtState state() const { return nmt_.state(); }
  bool allows(NmtService service) const { return nmt_.allows(service); }
  std::uint8_t node_id() const { return nmt_.node_id(); }

  // The application's errors (EmcyProducer::raise/clear, with the bus time). 1001h and 1003h
  // follow at once.
  bool raise_error(std::uint16_t code, std::uint8_t register_bits,
                   const std::array<std::uint8_t, 5>& manufacturer = {});
  bool clear_error(std::uint16_t code);

  // Reads every service's configuration from the object dictionary again (after the owner
  // changed it without hooks, e.g. ObjectDictionary::load).
  void reload_configuration();

  const NmtSlave& nmt() const { return nmt_; }
  const HeartbeatProducer& heartbeat_producer() const { return heartbeat_producer_; }
  const HeartbeatConsumer& heartbeat_consumer() const { return heartbeat_consumer_; }
  const GuardingSlave& guarding() const { return guarding_; }
  const EmcyProducer& emcy() const { return emcy_; }
  const SyncConsumer& sync_consumer() const { return sync_consumer_; }
  const std::optional<SyncProducer>& sync_producer() const { return sync_producer_; }
  // The communication error behaviour the node acts on (a 1029h sub 01h value): the object's
  // while the dictionary has it (0 with config.error_behaviour false), else
  // config.communication_error_without_object.
  std::uint8_t communication_error_behaviour() const;
  // The error of the last send() that failed (cleared by none; empty when all went out).
  std::error_code last_send_error() const { return last_send_error_; }

 private:
  void service(can::TimePoint now);
  bool run_due(can::TimePoint now);
  void rearm();
  void send(const can::Frame& frame);

  void on_nmt_result(const NmtSlaveResult& result, can::TimePoint now);
  void stop_services();  // everything but the NMT state machine falls silent
  void begin_initialisation(bool application, can::TimePoint now);
  void finish_initialisation(can::TimePoint now);
  void state_changed(NmtState from, NmtState to, can::TimePoint now);

  void on_heartbeat_event(const HeartbeatEvent& event, can::TimePoint now);
  void on_life_guarding_event(const LifeGuardingEvent& event, can::TimePoint now);
  void on_sync_event(const SyncConsumerEvent& event, can::TimePoint now);
  void update_communication_error(can::TimePoint now);
  void flush_emcy(can::TimePoint now);

  void configure_heartbeat(can::TimePoint now);
  void configure_guarding();
  void configure_consumer(bool restart);
  void configure_emcy();
  void configure_sync(can::TimePoint now, bool restart_producer);
  void start_sync_producer(can::TimePoint now);

  void bind_objects();
  void unbind_objects();
  void bind(std::uint16_t index, std::function<void(can::TimePoint)> apply);

  can::Bus& bus_;
  ObjectDictionary& od_;
  DeviceServicesConfig config_;
  DeviceServicesHandlers handlers_;

  NmtSlave nmt_;
  HeartbeatProducer heartbeat_producer_;
  HeartbeatConsumer heartbeat_consumer_;
  std::vector<ConsumerHeartbeatEntry> consumer_entries_;
  GuardingSlave guarding_;
  EmcyProducer emcy_;
  SyncConsumer sync_consumer_;
  std::optional<SyncProducer> sync_producer_;

  bool powered_ = false;
  bool heartbeat_supported_ = false;
  bool guarding_supported_ = false;
  // A heartbeat consumer timed out or life guarding expired, and the 1029h reaction was taken.
  bool communication_error_ = false;
  std::optional<can::TimePoint> boot_up_due_;
  std::vector<std::pair<std::uint16_t, std::uint8_t>> bound_;  // entries observed
  bool attached_ = false;
  bool in_service_ = false;
  bool service_again_ = false;
  can::DeadlineTimer timer_{bus_, [this] { service(bus_.now()); }};
  std::error_code last_send_error_;
};

}  // namespace drivecheck::cia301
