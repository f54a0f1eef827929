#include "reference_drive/device.hpp"

#include <algorithm>
#include <utility>

#include "protocol/cia301/emcy.hpp"

namespace drivecheck::reference_drive {
namespace {

constexpr auto kCommunicationBit =
    static_cast<std::uint8_t>(cia301::ErrorRegisterBit::communication);

}  // namespace

Expected<std::unique_ptr<ReferenceDrive>, std::string> ReferenceDrive::create(can::Bus& bus,
                                                                              DriveConfig config) {
  std::unique_ptr<ReferenceDrive> drive(new ReferenceDrive(bus, std::move(config)));
  if (auto ok = drive->start(); !ok) return Unexpected(ok.error());
  return drive;
}

ReferenceDrive::ReferenceDrive(can::Bus& bus, DriveConfig config)
    : deviation_port_(config.deviations.empty()
                          ? nullptr
                          : std::make_unique<DeviationPort>(bus, config.deviations)),
      bus_(deviation_port_ ? *deviation_port_ : bus),
      config_(std::move(config)) {}

Expected<void, std::string> ReferenceDrive::start() {
  auto od = build_dictionary(config_.dictionary);
  if (!od) return Unexpected(od.error());
  od_ = std::make_unique<cia301::ObjectDictionary>(std::move(*od));
  if (deviation_port_) deviation_port_->set_dictionary(od_.get());
  if (config_.application != nullptr) {
    if (auto ok = config_.application->add_objects(*od_); !ok) {
      return Unexpected("application objects: " + ok.error());
    }
  }

  cia301::ParameterStorage* storage = config_.storage;
  if (storage == nullptr) {
    own_storage_ = std::make_unique<cia301::MemoryParameterStorage>();
    storage = own_storage_.get();
  }
  auto store = cia301::StoreRestore::create(*od_, *storage);
  if (!store) return Unexpected(store.error());
  store_ = std::move(*store);

  pdos_ = std::make_unique<cia301::PdoService>(*od_, bus_, config_.dictionary.pdo.dummy_mapping,
                                               config_.dictionary.pdo.change_mask_index);

  cia301::SdoServerConfig sdo = cia301::SdoServerConfig::for_node(od_->node_id());
  sdo.timeout = config_.sdo_timeout;
  sdo.short_frames = config_.sdo_short_frames;
  if (has(Deviation::sdo_no_timeout)) sdo.timeout = can::Duration::max();  // deviation
  sdo_ = std::make_unique<cia301::SdoServer>(*od_, sdo);
  sdo_runner_ = std::make_unique<cia301::SdoServerRunner>(bus_, *sdo_);

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
    if (event.kind == cia301::LifeGuardingEventKind::expired && config_.application != nullptr) {
      config_.application->on_communication_loss(*this);
    }
  };
  handlers.other_frames = [this](const can::TimedFrame& frame) { on_frame(frame); };
  cia301::DeviceServicesConfig services{config_.initialisation_time};
  services.heartbeat_consumer_timeouts = !has(Deviation::heartbeat_consumer_timeout_ignored);
  services.emcy_inhibit = !has(Deviation::emcy_inhibit_ignored);
  services_ = std::make_unique<cia301::DeviceServices>(bus_, *od_, services, std::move(handlers));
  services_->attach();
  // Own frames come back at their end on the wire: PdoService::on_sent (synchronous window).
  bus_.set_loopback(true);
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
    // The end of our own frame on the wire: the PDOs pace synchronous TPDOs by it (1007h).
    handle(pdos_->on_sent(timed.frame, timed.timestamp));
    rearm();
    return;
  }
  if (sdo_->is_request(timed.frame)) {
    if (services_->allows(cia301::NmtService::sdo) ||
        (has(Deviation::sdo_in_stopped) && state() == cia301::NmtState::stopped)) {
      sdo_runner_->handle(timed);
      // An SDO write may have changed a PDO (new timers, errors to clear): let the PDOs look.
      handle(pdos_->on_time(timed.timestamp));
      rearm();
    }
    return;
  }
  handle(pdos_->on_frame(timed.frame, timed.timestamp));
  rearm();
}

void ReferenceDrive::on_reset(cia301::ResetKind kind) {
  if (kind == cia301::ResetKind::application) {
    store_->apply(cia301::kStoreApplication);
    store_->apply(cia301::kStoreManufacturer);
    application_reset_ = true;
  } else {
    sdo_->reset();
    // Deviation: a reset communication on its own keeps the communication objects as written.
    if (application_reset_ || !has(Deviation::nmt_reset_communication_keeps_values)) {
      store_->apply(cia301::kStoreCommunication);
    }
    application_reset_ = false;
    pdos_->reload(bus_.now());
    // PDO errors belong to the communication that was just reset.
    handle(pdos_->clear_errors());
  }
  if (config_.application != nullptr) config_.application->on_reset(*this, kind);
}

void ReferenceDrive::on_state_changed(cia301::NmtState from, cia301::NmtState to) {
  const can::TimePoint now = bus_.now();
  const bool sdo_in_stopped =
      has(Deviation::sdo_in_stopped) && to == cia301::NmtState::stopped;  // deviation
  if (!cia301::nmt_allows(to, cia301::NmtService::sdo) && !sdo_in_stopped) {
    sdo_->reset();
    sdo_runner_->transmit({});  // re-arms (cancels) the runner's timeout timer
  }
  // Deviation pdo-in-pre-operational: the PDOs run as if Operational.
  const bool pdo_in_pre_operational =
      has(Deviation::pdo_in_pre_operational) && to == cia301::NmtState::pre_operational;
  pdos_->set_nmt_state(pdo_in_pre_operational ? cia301::NmtState::operational : to, now);
  if (config_.application != nullptr) config_.application->on_nmt_state(*this, from, to);
  rearm();
}

void ReferenceDrive::on_sync(const cia301::SyncConsumerEvent& event) {
  if (event.kind != cia301::SyncConsumerEventKind::sync) return;
  // Deviation sync-counter-ignored: the PDOs never see the counter.
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
    while (next_cycle_ <= now)
      next_cycle_ += config_.control_cycle;
    ++stats_.cycles;
    if (config_.application != nullptr) config_.application->on_cycle(*this, now);
  }
  handle(pdos_->on_time(now));
  in_tick_ = false;
  rearm();
}

void ReferenceDrive::rearm() {
  if (in_tick_ || !powered_) return;
  timer_.arm(std::min(next_cycle_, pdos_->next_deadline()));
}

}  // namespace drivecheck::reference_drive
