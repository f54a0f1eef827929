#include "reference_drive/device.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/heartbeat_consumer_objects.hpp"
#include "protocol/cia301/nmt_slave.hpp"
#include "protocol/cia301/sdo_server_parameter.hpp"

namespace drivecheck::reference_drive {
namespace {

constexpr auto kCommunicationBit =
    static_cast<std::uint8_t>(cia301::ErrorRegisterBit::communication);
constexpr auto kRecoveredFromBusOff =
    static_cast<std::uint16_t>(cia301::EmcyCode::recovered_from_bus_off);
// Control cycles a late tick runs to catch up (at 1 ms: a stall of 100 ms).
constexpr std::int64_t kMaxCatchUpCycles = 100;

}  // namespace

// The drive's side of its port: every call goes to the bus it currently stands on, which
// restart() changes (the services keep one Bus& for their lifetime; this is it).
class ReboundBus final : public can::Bus {
 public:
  explicit ReboundBus(can::Bus& bus) : bus_(&bus) {}
  void retarget(can::Bus& bus) { bus_ = &bus; }

  can::TimePoint now() const override { return bus_->now(); }
  can::Duration unix_offset() const override { return bus_->unix_offset(); }
  std::error_code send(const can::Frame& frame) override { return bus_->send(frame); }
  std::optional<can::TimedFrame> receive(can::TimePoint deadline) override {
    return bus_->receive(deadline);
  }
  void set_frame_handler(FrameHandler handler) override {
    bus_->set_frame_handler(std::move(handler));
  }
  void set_filters(std::span<const can::Filter> filters) override { bus_->set_filters(filters); }
  std::size_t queued(std::uint32_t id, can::IdFormat format) const override {
    return bus_->queued(id, format);
  }
  void set_loopback(bool enabled) override { bus_->set_loopback(enabled); }
  can::TimerId start_timer(can::TimePoint at, TimerCallback callback) override {
    return bus_->start_timer(at, std::move(callback));
  }
  void cancel_timer(can::TimerId id) override { bus_->cancel_timer(id); }
  void run_until(can::TimePoint deadline) override { bus_->run_until(deadline); }
  void stop() override { bus_->stop(); }

 private:
  can::Bus* bus_;
};

Expected<std::unique_ptr<ReferenceDrive>, std::string> ReferenceDrive::create(can::Bus& bus,
                                                                              DriveConfig config) {
  std::unique_ptr<ReferenceDrive> drive(new ReferenceDrive(bus, std::move(config)));
  if (auto ok = drive->start(); !ok) return Unexpected(ok.error());
  return drive;
}

ReferenceDrive::ReferenceDrive(can::Bus& bus, DriveConfig config)
    : rebound_bus_(std::make_unique<ReboundBus>(bus)),
      deviation_port_(config.deviations.empty()
                          ? nullptr
                          : std::make_unique<DeviationPort>(*rebound_bus_, config.deviations)),
      bus_(deviation_port_ ? static_cast<can::Bus&>(*deviation_port_) : *rebound_bus_),
      config_(std::move(config)) {}

Expected<void, std::string> ReferenceDrive::start() {
  // Deviation pdo-dummy-entry-refused: the drive declares dummy mapping (its EDS, the standard
  // profile) but its RPDO mappings refuse the dummy entries 0002h-0007h (06040041h).
  if (has(Deviation::pdo_dummy_entry_refused)) config_.dictionary.pdo.dummy_mapping = false;
  auto od = build_dictionary(config_.dictionary);
  if (!od) return Unexpected(od.error());
  od_ = std::make_unique<cia301::ObjectDictionary>(std::move(*od));
  if (deviation_port_) deviation_port_->set_dictionary(od_.get());
  if (config_.application != nullptr) {
    if (auto ok = config_.application->add_objects(*od_); !ok) {
      return Unexpected("application objects: " + ok.error());
    }
  }
  for (const auto& [first, last] : config_.absent_objects) {
    od_->remove_objects(first, last);
  }
  take_snapshot();
  return bind_services();
}

Expected<void, std::string> ReferenceDrive::bind_services() {
  cia301::ParameterStorage* storage = config_.storage;
  if (storage == nullptr) {
    own_storage_ = std::make_unique<cia301::MemoryParameterStorage>();
    storage = own_storage_.get();
  }
  // Store/restore only where its objects are (absent_objects may remove them).
  if (od_->find(cia301::kStoreParametersIndex) != nullptr &&
      od_->find(cia301::kRestoreDefaultParametersIndex) != nullptr) {
    auto store = cia301::StoreRestore::create(*od_, *storage);
    if (!store) return Unexpected(store.error());
    store_ = std::move(*store);
    store_->set_restore_guard([this]() -> Expected<void, cia301::SdoAbort> {
      if (config_.restore_guard) {
        if (auto ok = config_.restore_guard(); !ok) return ok;
      }
      // Deviation restore-communication-at-reset-node-only: what was stored before the restore
      // is what a reset communication still loads, until the next reset node.
      if (has(Deviation::restore_communication_at_reset_node_only) && !stored_before_restore_) {
        stored_before_restore_ = store_->stored();
      }
      return {};
    });
  }

  if (has(Deviation::store_misses_sync_objects)) {  // deviation: not part of any store group
    for (const std::uint16_t index : {0x1005, 0x1006, 0x1007, 0x1019}) {
      if (cia301::Entry* entry = od_->find(index, 0)) entry->set_store_group(cia301::kStoreNone);
    }
  }
  // Deviation store-heartbeat-time-in-application-group: the firmware's parameter table puts
  // 1017h with the application parameters.
  if (has(Deviation::store_heartbeat_time_in_application_group)) {
    if (cia301::Entry* entry = od_->find(0x1017, 0))
      entry->set_store_group(cia301::kStoreApplication);
  }
  // Deviation: 1020h belongs to no group, so neither a store nor a reset nor a restore touches it.
  if (has(Deviation::store_verify_configuration_not_saved)) {
    if (cia301::Object* verify = od_->find(kVerifyConfigurationIndex)) {
      for (cia301::Entry& entry : verify->entries()) {
        if (entry.sub_index() != 0) entry.set_store_group(cia301::kStoreNone);
      }
    }
  }
  // Deviation: the further SDO server records (1201h..) belong to no group: no reset sets them.
  if (has(Deviation::sdo_server_cob_ids_kept_over_reset)) {
    for (unsigned i = 1; i <= config_.dictionary.extra_sdo_servers; ++i) {
      if (cia301::Object* record =
              od_->find(static_cast<std::uint16_t>(kSdoServerParameterIndex + i))) {
        for (cia301::Entry& entry : record->entries()) {
          if (entry.sub_index() != 0) entry.set_store_group(cia301::kStoreNone);
        }
      }
    }
  }
  // Deviation: the consumer heartbeat times belong to no group, so no reset (nor store) touches
  // them.
  if (has(Deviation::nmt_reset_keeps_heartbeat_consumers)) {
    if (cia301::Object* consumers = od_->find(cia301::kConsumerHeartbeatTimeIndex)) {
      for (cia301::Entry& entry : consumers->entries()) {
        if (entry.sub_index() != 0) entry.set_store_group(cia301::kStoreNone);
      }
    }
  }

  pdos_ = std::make_unique<cia301::PdoService>(*od_, bus_, config_.dictionary.pdo.dummy_mapping,
                                               config_.dictionary.pdo.change_mask_index);
  pdos_->set_first_sync_phase(config_.tpdo_first_sync_phase);
  pdos_->set_rtr_in_any_state(has(Deviation::pdo_rtr_outside_operational));          // deviation
  pdos_->set_sync_acyclic_in_stopped(has(Deviation::sync_tpdo_acyclic_in_stopped));  // deviation
  pdos_->set_sync_acyclic_in_pre_operational(
      has(Deviation::sync_tpdo_acyclic_in_pre_operational));                           // deviation
  pdos_->set_sync_window_tpdos_sent_late(has(Deviation::sync_window_tpdo_sent_late));  // deviation
  pdos_->set_sync_tpdo_only_first(has(Deviation::sync_tpdo_only_first));               // deviation
  pdos_->set_sync_window_rpdo_not_resumed(
      has(Deviation::sync_window_rpdo_not_resumed));                                    // deviation
  pdos_->set_rpdo_deadline_not_restarted(has(Deviation::rpdo_deadline_not_restarted));  // deviation

  cia301::SdoServerConfig sdo = cia301::SdoServerConfig::for_node(od_->node_id());
  sdo.timeout = config_.sdo_timeout;
  sdo.short_frames = config_.sdo_short_frames;
  if (has(Deviation::sdo_no_timeout)) sdo.timeout = can::Duration::max();  // deviation
  if (has(Deviation::sdo_block_upload_blksize_ignored))                    // deviation
    sdo.upload_block_size = cia301::kSdoMaxBlockSize;
  sdo_ = std::make_unique<cia301::SdoServer>(*od_, sdo);
  sdo_runner_ = std::make_unique<cia301::SdoServerRunner>(bus_, *sdo_);
  // Further channels (1201h..): on the COB-IDs their records hold, re-read after each write.
  for (unsigned i = 1; i <= config_.dictionary.extra_sdo_servers; ++i) {
    const auto index = static_cast<std::uint16_t>(kSdoServerParameterIndex + i);
    extra_sdo_.push_back(std::make_unique<cia301::SdoServer>(*od_, sdo));
    extra_sdo_runners_.push_back(
        std::make_unique<cia301::SdoServerRunner>(bus_, *extra_sdo_.back()));
    for (std::uint8_t sub = cia301::sdo_server_sub::kRequestCobId;
         sub <= cia301::sdo_server_sub::kNodeId; ++sub) {
      cia301::Entry* entry = od_->find(index, sub);
      if (entry == nullptr) continue;
      entry->set_write_observer([this, chained = entry->write_observer()](
                                    cia301::ObjectDictionary& od, cia301::Entry& self) {
        if (chained) chained(od, self);
        sdo_channels_changed_ = true;  // applied once the writing frame is answered
      });
    }
  }
  sync_sdo_channels();

  // The SDO client (1280h, 2F00h) and the TIME consumer (1012h, 2F01h), where the dictionary
  // has their objects.
  if (od_->find(kSdoClientParameterIndex) != nullptr) {
    SdoClientChannelOptions client;
    client.refuse_restricted = !has(Deviation::sdo_client_restricted_cob_id_accepted);
    client.wrong_cob_id = has(Deviation::sdo_client_wrong_cob_id);
    client.no_timeout = has(Deviation::sdo_client_no_timeout);
    sdo_client_ = std::make_unique<SdoClientChannel>(*od_, client);
    if (!sdo_client_->present()) sdo_client_.reset();
  }
  if (has(Deviation::sdo_client_parameter_not_stored)) {  // deviation: in no store group
    if (cia301::Object* record = od_->find(kSdoClientParameterIndex)) {
      for (cia301::Entry& entry : record->entries()) {
        if (entry.sub_index() != 0) entry.set_store_group(cia301::kStoreNone);
      }
    }
  }
  if (od_->find(kTimeCobIdIndex) != nullptr) {
    TimeConsumerOptions time;
    time.refuse_restricted = !has(Deviation::time_restricted_cob_id_accepted);
    time.refuse_producer_frame = !has(Deviation::time_cob_id_bits_not_checked);
    time.consumer_bit_ignored = has(Deviation::time_consumer_bit_ignored);
    time_consumer_ = std::make_unique<TimeConsumer>(*od_, time);
    if (!time_consumer_->present()) time_consumer_.reset();
  }

  cia301::DeviceServicesHandlers handlers;
  handlers.on_reset = [this](cia301::ResetKind kind) { on_reset(kind); };
  handlers.on_state_changed = [this](cia301::NmtState from, cia301::NmtState to) {
    on_state_changed(from, to);
  };
  handlers.on_sync = [this](const cia301::SyncConsumerEvent& event) { on_sync(event); };
  handlers.on_heartbeat = [this](const cia301::HeartbeatEvent& event) {
    if (event.kind == cia301::HeartbeatEventKind::timeout && config_.application != nullptr) {
      config_.application->on_communication_loss(*this);
    }
  };
  handlers.on_life_guarding = [this](const cia301::LifeGuardingEvent& event) {
    // Deviation abort-connection-guarding-ignored: only the heartbeat loss reaches 6007h.
    if (event.kind == cia301::LifeGuardingEventKind::expired && config_.application != nullptr &&
        !has(Deviation::abort_connection_guarding_ignored)) {
      config_.application->on_communication_loss(*this);
    }
  };
  handlers.other_frames = [this](const can::TimedFrame& frame) { on_frame(frame); };
  cia301::DeviceServicesConfig services{config_.initialisation_time};
  services.heartbeat_consumer_timeouts = !has(Deviation::heartbeat_consumer_timeout_ignored);
  services.emcy_inhibit = !has(Deviation::emcy_inhibit_ignored);
  services.error_history_shift_when_full = !has(Deviation::emcy_history_full_not_shifted);
  services.error_behaviour = !has(Deviation::error_behaviour_ignored);
  services.heartbeat_timeout_nmt_reaction = !has(Deviation::heartbeat_timeout_keeps_nmt_state);
  services.communication_error_without_object = config_.communication_error_without_1029;
  services.error_behaviour_stopped_only_in_operational =
      has(Deviation::error_behaviour_stopped_only_in_operational);
  services.sync_in_stopped =
      has(Deviation::pdo_in_stopped) || has(Deviation::sync_tpdo_acyclic_in_stopped);
  services_ = std::make_unique<cia301::DeviceServices>(bus_, *od_, services, std::move(handlers));
  services_->attach();
  // Own frames come back at their end on the wire: PdoService::on_sent (synchronous window).
  bus_.set_loopback(true);
  return {};
}

Expected<void, std::string> ReferenceDrive::restart(can::Bus& bus) {
  if (deviation_port_) {
    return Unexpected(std::string("restart: a drive with deviations cannot restart, create one"));
  }
  release_bus();
  rebound_bus_->retarget(bus);
  // Every member that changes while the drive runs goes back to its initial value here.
  application_reset_ = false;
  sdo_channels_changed_ = false;
  bus_off_ = false;
  transmitted_ = false;
  powered_ = false;
  next_cycle_ = can::kForever;
  in_tick_ = false;
  stats_ = {};
  if (auto ok = restore_snapshot(); !ok) return ok;
  return bind_services();
}

void ReferenceDrive::release_bus() {
  // The old bus is left first (timers, frame handler, filters), while it exists.
  timer_.disarm();
  services_.reset();
  sdo_client_.reset();
  time_consumer_.reset();
  extra_sdo_runners_.clear();
  extra_sdo_.clear();
  sdo_runner_.reset();
  sdo_.reset();
  pdos_.reset();
  store_.reset();
  own_storage_.reset();  // bind_services() makes an empty one
}

void ReferenceDrive::take_snapshot() {
  pristine_.clear();
  pristine_node_id_ = od_->node_id();
  for (const cia301::Object& object : od_->objects()) {
    for (const cia301::Entry& entry : object.entries()) {
      const auto bytes = entry.bytes();
      pristine_.push_back({od_->find(object.index(), entry.sub_index()),
                           {bytes.begin(), bytes.end()},
                           entry.revision(),
                           entry.read_hook(),
                           entry.write_validator(),
                           entry.write_observer()});
    }
  }
}

Expected<void, std::string> ReferenceDrive::restore_snapshot() {
  od_->set_node_id(pristine_node_id_);
  for (PristineEntry& pristine : pristine_) {
    cia301::Entry& entry = *pristine.entry;
    if (entry.revision() != pristine.revision) {
      // Stored into since: put the bytes back unless they are the pristine ones (most often
      // a reset stored the default, which they are); not storing keeps the entry's revision,
      // so that the next reset need not store its default again (restore_defaults).
      const auto bytes = entry.bytes();
      if (!std::equal(bytes.begin(), bytes.end(), pristine.bytes.begin(), pristine.bytes.end()) &&
          !entry.assign_bytes(pristine.bytes)) {
        return Unexpected(fmt::format("restart: {:04X}h sub {} could not be restored",
                                      entry.index(), entry.sub_index()));
      }
      pristine.revision = entry.revision();
    }
    // Hooks: copying an empty one over an empty one changes nothing.
    if (pristine.read_hook || entry.read_hook()) entry.set_read_hook(pristine.read_hook);
    if (pristine.validator || entry.write_validator()) {
      entry.set_write_validator(pristine.validator);
    }
    if (pristine.observer || entry.write_observer()) entry.set_write_observer(pristine.observer);
  }
  return {};
}

ReferenceDrive::~ReferenceDrive() {
  if (config_.application != nullptr) config_.application->on_drive_destroyed(*this);
  timer_.disarm();
  if (deviation_port_) deviation_port_->set_dictionary(nullptr);
}

void ReferenceDrive::power_on() {
  if (powered_) return;
  powered_ = true;
  if (config_.control_cycle > can::Duration::zero()) {
    next_cycle_ = bus_.now() + config_.control_cycle;
  }
  services_->power_on();
  rearm();
}

void ReferenceDrive::command(cia301::NmtCommand command) {
  services_->command(command);
  rearm();
}

void ReferenceDrive::load_stored_parameters() {
  apply_stored(cia301::kStoreCommunication);
  apply_stored(cia301::kStoreApplication);
  apply_stored(cia301::kStoreManufacturer);
  rearm();
}

void ReferenceDrive::set_bus_off(bool bus_off) {
  if (bus_off == bus_off_) return;
  bus_off_ = bus_off;
  if (bus_off) {
    // CiA 301 1029h:01: bus-off is a communication error (0: Operational -> Pre-operational;
    // without 1029h the drive's fixed behaviour, DriveConfig::communication_error_without_1029).
    if (powered_) {
      if (auto reaction = cia301::communication_error_command(
              state(), services_->communication_error_behaviour())) {
        command(*reaction);
      }
    }
  }
  // CiA 402-2 6007h: bus-off is one of the events of the abort connection option code (a
  // personality with its manual's own bus-off reaction, on_bus_off, takes that instead).
  if (bus_off && powered_ && !config_.on_bus_off) abort_connection_event();
  if (config_.on_bus_off) {
    config_.on_bus_off(*this, bus_off, transmitted_);
  } else if (!bus_off && powered_) {
    services_->raise_error(kRecoveredFromBusOff, kCommunicationBit);  // CiA 301 Table 21
  }
  rearm();
}

bool ReferenceDrive::raise_error(std::uint16_t code, std::uint8_t register_bits,
                                 const std::array<std::uint8_t, 5>& manufacturer) {
  return services_->raise_error(code, register_bits, manufacturer);
}

bool ReferenceDrive::clear_error(std::uint16_t code) {
  return services_->clear_error(code);
}

bool ReferenceDrive::trigger_tpdo(std::uint16_t number) {
  if (!pdos_->trigger(number)) return false;
  rearm();
  return true;
}

// ---------------------------------------------------------------------------------------------
// Events

void ReferenceDrive::on_frame(const can::TimedFrame& timed) {
  if (timed.frame.is_error()) return;
  if (timed.own) {
    transmitted_ = true;
    // The end of our own frame on the wire: the PDOs pace synchronous TPDOs by it (1007h).
    handle(pdos_->on_sent(timed.frame, timed.timestamp));
    rearm();
    return;
  }
  if (time_consumer_ && time_consumer_->on_frame(timed.frame, state())) return;
  if (sdo_client_ && sdo_client_->takes(timed.frame)) {
    if (sdo_allowed()) send_all(sdo_client_->on_frame(timed.frame, timed.timestamp));
    rearm();
    return;
  }
  cia301::SdoServerRunner* sdo = nullptr;
  if (sdo_->is_request(timed.frame)) {
    sdo = sdo_runner_.get();
  } else {
    for (std::size_t i = 0; i < extra_sdo_.size() && sdo == nullptr; ++i) {
      if (extra_sdo_[i]->is_request(timed.frame)) sdo = extra_sdo_runners_[i].get();
    }
  }
  if (sdo != nullptr) {
    if (sdo_allowed()) {
      sdo->handle(timed);
      if (sdo_channels_changed_) sync_sdo_channels();
      // A command of 2F00h: the client starts once the write that asked is answered.
      if (sdo_client_ && sdo_client_->pending()) send_all(sdo_client_->start(timed.timestamp));
      // An SDO write may have changed a PDO (new timers, errors to clear): let the PDOs look.
      handle(pdos_->on_time(timed.timestamp));
      rearm();
    }
    return;
  }
  handle(pdos_->on_frame(timed.frame, timed.timestamp));
  rearm();
}

bool ReferenceDrive::sdo_allowed() const {
  return services_->allows(cia301::NmtService::sdo) ||
         (has(Deviation::sdo_in_stopped) && state() == cia301::NmtState::stopped);
}

void ReferenceDrive::sync_sdo_channels() {
  sdo_channels_changed_ = false;
  for (std::size_t i = 0; i < extra_sdo_.size(); ++i) {
    const auto index = static_cast<std::uint16_t>(kSdoServerParameterIndex + i + 1);
    const auto channel = cia301::read_sdo_server_channel(*od_, index);
    if (!channel) continue;
    // Deviation sdo-further-server-answers-on-default-cob-id: the answers go on 580h + N.
    const std::uint32_t response = has(Deviation::sdo_further_server_answers_on_default_cob_id)
                                       ? 0x580U + od_->node_id()
                                       : channel->response_cob_id;
    extra_sdo_[i]->set_channel(channel->request_cob_id, response, channel->valid);
    extra_sdo_runners_[i]->transmit({});  // re-arms (cancels) a dropped transfer's timer
  }
}

void ReferenceDrive::send_all(const std::vector<can::Frame>& frames) {
  for (const can::Frame& frame : frames)
    send(frame);
}

void ReferenceDrive::reset_sdo_servers() {
  sdo_->reset();
  sdo_runner_->transmit({});  // re-arms (cancels) the runner's timeout timer
  for (std::size_t i = 0; i < extra_sdo_.size(); ++i) {
    extra_sdo_[i]->reset();
    extra_sdo_runners_[i]->transmit({});
  }
}

void ReferenceDrive::apply_stored(std::uint8_t group) {
  if (store_) {
    store_->apply(group);
  } else {
    od_->restore_defaults(group);  // nothing can be stored: the defaults
  }
}

void ReferenceDrive::on_reset(cia301::ResetKind kind) {
  // CiA 402-2 6007h: a reset communication of its own (not the one of a reset node or power on)
  // is one of the events of the abort connection option code; it acts after the application
  // has taken the reset (which re-reads 6040h).
  const bool abort_connection = kind == cia301::ResetKind::communication && !application_reset_;
  if (kind == cia301::ResetKind::application) {
    stored_before_restore_.reset();
    apply_stored(cia301::kStoreApplication);
    apply_stored(cia301::kStoreManufacturer);
    // Deviation: 60F8h (max slippage) boots with its default + 1, not the EDS's value.
    if (has(Deviation::od_default_after_reset_differs)) {
      if (cia301::Entry* entry = od_->find(0x60F8, 0)) {
        auto bytes = entry->default_bytes(node_id());
        if (!bytes.empty()) ++bytes[0];
        (void)entry->assign_bytes(bytes);
      }
    }
    application_reset_ = true;
  } else {
    reset_sdo_servers();
    if (sdo_client_) sdo_client_->reset();
    if (time_consumer_) time_consumer_->reset();
    // Deviation: a reset communication on its own keeps the communication objects as written.
    if (!application_reset_ && stored_before_restore_) {
      // Deviation restore-communication-at-reset-node-only: the values stored before the
      // restore come back, not the defaults.
      od_->restore_defaults(cia301::kStoreCommunication);
      cia301::ObjectDictionary::StoredParameters communication;
      for (const auto& stored : *stored_before_restore_) {
        const cia301::Entry* entry = od_->find(stored.index, stored.sub_index);
        if (entry != nullptr && entry->store_group() == cia301::kStoreCommunication) {
          communication.push_back(stored);
        }
      }
      (void)od_->load(communication);
    } else if (application_reset_ || !has(Deviation::nmt_reset_communication_keeps_values)) {
      apply_stored(cia301::kStoreCommunication);
    }
    application_reset_ = false;
    // Deviation: RPDO1-4's default COB-IDs without the node-ID (where they hold the default).
    if (has(Deviation::pdo_rpdo_default_cob_id_without_node_id)) {
      for (std::uint16_t index = 0x1400; index <= 0x1403; ++index) {
        cia301::Entry* entry = od_->find(index, 1);
        if (entry == nullptr) continue;
        auto bytes = entry->default_bytes(node_id());
        if (bytes.empty() || !std::ranges::equal(bytes, entry->bytes())) continue;
        bytes[0] = static_cast<std::uint8_t>(bytes[0] - node_id());  // 200h + N - N, no borrow
        (void)entry->assign_bytes(bytes);
      }
    }
    sync_sdo_channels();
    // The bus-off recovery EMCY belongs to the communication that was just reset.
    if (!config_.on_bus_off) services_->clear_error(kRecoveredFromBusOff);
    pdos_->reload(bus_.now());
    // PDO errors belong to the communication that was just reset.
    handle(pdos_->clear_errors());
  }
  if (config_.application != nullptr) config_.application->on_reset(*this, kind);
  if (abort_connection) abort_connection_event();
}

void ReferenceDrive::on_state_changed(cia301::NmtState from, cia301::NmtState to) {
  const can::TimePoint now = bus_.now();
  const bool sdo_in_stopped =
      has(Deviation::sdo_in_stopped) && to == cia301::NmtState::stopped;  // deviation
  if (!cia301::nmt_allows(to, cia301::NmtService::sdo) && !sdo_in_stopped) {
    reset_sdo_servers();
    if (sdo_client_ && to == cia301::NmtState::stopped) sdo_client_->stop();
  }
  // Deviations pdo-in-pre-operational, pdo-in-stopped: the PDOs run as if Operational.
  const bool pdo_in_pre_operational =
      has(Deviation::pdo_in_pre_operational) && to == cia301::NmtState::pre_operational;
  const bool pdo_in_stopped = has(Deviation::pdo_in_stopped) && to == cia301::NmtState::stopped;
  pdos_->set_nmt_state(
      pdo_in_pre_operational || pdo_in_stopped ? cia301::NmtState::operational : to, now);
  if (config_.application != nullptr) config_.application->on_nmt_state(*this, from, to);
  // CiA 402-2 6007h: entering NMT Stopped is one of the events of the abort connection option
  // code.
  if (to == cia301::NmtState::stopped && from != cia301::NmtState::stopped) {
    abort_connection_event();
  }
  rearm();
}

void ReferenceDrive::abort_connection_event() {
  // Deviation abort-connection-other-events-ignored: only heartbeat and life guarding count.
  if (config_.application == nullptr || !config_.can_abort_connection_events ||
      has(Deviation::abort_connection_other_events_ignored)) {
    return;
  }
  config_.application->on_connection_event(*this);
}

void ReferenceDrive::on_sync(const cia301::SyncConsumerEvent& event) {
  if (event.kind != cia301::SyncConsumerEventKind::sync) return;
  // Deviation sync-counter-ignored: the PDOs never see the counter.
  handle(pdos_->on_sync(has(Deviation::sync_counter_ignored) ? std::nullopt : event.counter,
                        event.time));
  // Deviation sync-counted-twice: the PDOs see every SYNC twice.
  if (has(Deviation::sync_counted_twice))
    handle(pdos_->on_sync(has(Deviation::sync_counter_ignored) ? std::nullopt : event.counter,
                          event.time));
  if (config_.application != nullptr) config_.application->on_sync(*this, event.time);
  rearm();
}

void ReferenceDrive::handle(const cia301::PdoOutput& output) {
  for (const can::Frame& frame : output.frames)
    send(frame);
  // Copy first: raising an EMCY runs the services, which may call back into the PDOs.
  std::array<cia301::PdoErrorChange, 16> changes{};
  const std::size_t count = std::min(output.errors.size(), changes.size());
  std::copy_n(output.errors.begin(), count, changes.begin());
  for (std::size_t i = 0; i < count; ++i) {
    if (changes[i].active) {
      services_->raise_error(changes[i].code, kCommunicationBit);
    } else {
      services_->clear_error(changes[i].code);
    }
  }
}

void ReferenceDrive::send(const can::Frame& frame) {
  if (bus_.send(frame)) {
    ++stats_.send_errors;
  } else {
    ++stats_.frames_sent;
  }
}

// ---------------------------------------------------------------------------------------------
// Time

void ReferenceDrive::tick() {
  in_tick_ = true;
  const can::TimePoint now = bus_.now();
  if (now >= next_cycle_) {
    // Every control cycle runs at its own time, also the ones a process woken late missed (a
    // busy host: `drivecheck drive`): the modes and the axis step by the control cycle as a
    // drive's control loop does, never one long step, in which the position controller would
    // chase a stale demand and overshoot (606Ch above 6081h). After a stall longer than
    // kMaxCatchUpCycles the older cycles are skipped (one longer step), so that the drive
    // cannot fall further behind. On the simulated bus the timer is never late: one cycle.
    const auto cycle = config_.control_cycle;
    const auto missed = (now - next_cycle_) / cycle + 1;
    if (missed > kMaxCatchUpCycles) next_cycle_ += (missed - kMaxCatchUpCycles) * cycle;
    while (next_cycle_ <= now) {
      const can::TimePoint at = next_cycle_;
      next_cycle_ += cycle;
      ++stats_.cycles;
      if (config_.application != nullptr) config_.application->on_cycle(*this, at);
    }
  }
  handle(pdos_->on_time(now));
  if (sdo_client_) send_all(sdo_client_->on_time(now));
  in_tick_ = false;
  rearm();
}

void ReferenceDrive::rearm() {
  if (in_tick_ || !powered_) return;
  can::TimePoint next = std::min(next_cycle_, pdos_->next_deadline());
  if (sdo_client_) next = std::min(next, sdo_client_->next_deadline());
  timer_.arm(next);
}

}  // namespace drivecheck::reference_drive
