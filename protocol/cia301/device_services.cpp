#include "protocol/cia301/device_services.hpp"

#include <algorithm>
#include <chrono>
#include <utility>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/emcy.hpp"

namespace drivecheck::cia301 {
namespace {

constexpr auto kCommunicationBit = static_cast<std::uint8_t>(ErrorRegisterBit::communication);
constexpr auto kHeartbeatError = static_cast<std::uint16_t>(EmcyCode::life_guard_or_heartbeat);
constexpr auto kSyncLengthError = static_cast<std::uint16_t>(EmcyCode::unexpected_sync_length);

std::size_t error_history_size(const ObjectDictionary& od) {
  const Object* field = od.find(kPreDefinedErrorFieldIndex);
  if (field == nullptr || field->entries().size() < 2) return 8;
  return field->entries().size() - 1;
}

// Stand-in node-ID for the state machines before the first boot-up when the dictionary's
// node-ID is not a valid one (the boot-up then uses whatever the owner set).
std::uint8_t usable_node_id(std::uint8_t node_id) {
  return is_valid_node_id(node_id) ? node_id : kMinNodeId;
}

}  // namespace

std::string_view to_string(ResetKind kind) {
  switch (kind) {
    case ResetKind::application:
      return "reset application";
    case ResetKind::communication:
      return "reset communication";
  }
  return "?";
}

Expected<void, std::string> DeviceServices::add_objects(ObjectDictionary& od,
                                                        const DeviceObjectsOptions& options) {
  if (auto ok = add_emcy_producer_objects(od, {options.error_history_size}); !ok) return ok;
  if (auto ok = add_sync_objects(od, {options.sync_producer_supported}); !ok) return ok;
  if (options.node_guarding) {
    if (auto ok = add_guarding_slave_objects(od); !ok) return ok;
  }
  if (options.heartbeat_consumer_entries > 0) {
    if (auto ok = add_heartbeat_consumer_objects(od, options.heartbeat_consumer_entries); !ok) {
      return ok;
    }
  }
  if (auto ok = add_heartbeat_producer_objects(od, options.producer_heartbeat_ms); !ok) return ok;
  if (auto ok = add_error_behaviour_objects(od); !ok) return ok;
  return {};
}

DeviceServices::DeviceServices(can::Bus& bus, ObjectDictionary& od, DeviceServicesConfig config,
                               DeviceServicesHandlers handlers)
    : bus_(bus),
      od_(od),
      config_(config),
      handlers_(std::move(handlers)),
      nmt_(usable_node_id(od.node_id())),
      heartbeat_producer_(usable_node_id(od.node_id())),
      guarding_(usable_node_id(od.node_id())),
      emcy_(usable_node_id(od.node_id()), error_history_size(od)) {
  // Powered off: nothing is produced until power_on().
  emcy_.set_enabled(false);
  emcy_.set_history_shift_when_full(config_.error_history_shift_when_full);
  bind_objects();
}

DeviceServices::~DeviceServices() {
  unbind_objects();
  timer_.disarm();
  if (attached_) bus_.set_frame_handler({});
}

void DeviceServices::attach() {
  attached_ = true;
  bus_.set_frame_handler([this](const can::TimedFrame& frame) {
    if (!handle(frame) && handlers_.other_frames) handlers_.other_frames(frame);
  });
}

// ---------------------------------------------------------------------------------------------
// Frames

bool DeviceServices::handle(const can::TimedFrame& timed) {
  const can::Frame& frame = timed.frame;
  const can::TimePoint now = timed.timestamp;
  if (!powered_ || frame.is_error() || timed.own) return false;

  bool taken = false;
  if (!frame.is_extended() && frame.id == kNmtCobId) {
    taken = true;
    on_nmt_result(nmt_.on_frame(frame), now);
  } else if (!frame.is_extended() &&
             classify_cob_id(frame).function == CobFunction::nmt_error_control) {
    taken = true;
    if (!nmt_.initialising()) {
      if (frame.is_remote()) {
        if (guarding_supported_) {
          auto result = guarding_.on_frame(frame, now, nmt_.state());
          if (result.response) send(*result.response);
          if (result.event) on_life_guarding_event(*result.event, now);
        }
      } else if (auto event = heartbeat_consumer_.on_frame(frame, now)) {
        on_heartbeat_event(*event, now);
      }
    }
  } else if (nmt_.allows(NmtService::sync) ||
             (config_.sync_in_stopped && nmt_.state() == NmtState::stopped)) {
    if (auto event = sync_consumer_.on_frame(frame, now)) {
      taken = true;
      on_sync_event(*event, now);
    }
  } else {
    const SyncCobIdEntry& cob = sync_consumer_.config().cob_id;
    taken = !frame.is_remote() && frame.is_extended() == cob.extended && frame.id == cob.can_id;
  }
  if (taken) service(now);
  return taken;
}

void DeviceServices::send(const can::Frame& frame) {
  if (auto error = bus_.send(frame)) last_send_error_ = error;
}

// ---------------------------------------------------------------------------------------------
// NMT

void DeviceServices::power_on() {
  const can::TimePoint now = bus_.now();
  if (powered_) power_off();
  powered_ = true;
  begin_initialisation(true, now);
  service(now);
}

void DeviceServices::power_off() {
  if (!powered_) return;
  const NmtState before = nmt_.state();
  powered_ = false;
  boot_up_due_.reset();
  stop_services();
  nmt_.restart();
  if (before != NmtState::boot_up && handlers_.on_state_changed) {
    handlers_.on_state_changed(before, NmtState::boot_up);
  }
  rearm();
}

void DeviceServices::command(NmtCommand command) {
  if (!powered_) return;
  const can::TimePoint now = bus_.now();
  on_nmt_result(nmt_.apply(command), now);
  service(now);
}

void DeviceServices::on_nmt_result(const NmtSlaveResult& result, can::TimePoint now) {
  switch (result.action) {
    case NmtSlaveAction::ignored:
    case NmtSlaveAction::unchanged:
      return;
    case NmtSlaveAction::state_changed:
      state_changed(result.before, result.after, now);
      return;
    case NmtSlaveAction::reset_node:
      state_changed(result.before, NmtState::boot_up, now);
      begin_initialisation(true, now);
      return;
    case NmtSlaveAction::reset_communication:
      state_changed(result.before, NmtState::boot_up, now);
      begin_initialisation(false, now);
      return;
  }
}

void DeviceServices::stop_services() {
  heartbeat_producer_.stop();
  guarding_.reset();
  sync_consumer_.reset();
  if (sync_producer_) sync_producer_->stop();
  emcy_.set_enabled(false);
  for (const auto& entry : consumer_entries_)
    heartbeat_consumer_.stop_monitoring(entry.node);
  consumer_entries_.clear();
}

void DeviceServices::begin_initialisation(bool application, can::TimePoint now) {
  stop_services();

  if (application) {
    if (handlers_.on_reset) {
      handlers_.on_reset(ResetKind::application);
    } else {
      od_.restore_defaults(kStoreApplication);
      od_.restore_defaults(kStoreManufacturer);
    }
    emcy_.reset();
  }
  if (handlers_.on_reset) {
    handlers_.on_reset(ResetKind::communication);
  } else {
    od_.restore_defaults(kStoreCommunication);
  }
  emcy_.discard_pending();
  // Communication errors belong to the communication that was just reset (no EMCY: not allowed
  // while initialising).
  emcy_.clear(kHeartbeatError, now);
  emcy_.clear(kSyncLengthError, now);
  mirror_error_objects(emcy_, od_);
  communication_error_ = false;

  boot_up_due_ = now + config_.initialisation_time;
}

void DeviceServices::finish_initialisation(can::TimePoint now) {
  boot_up_due_.reset();
  const std::uint8_t node_id = usable_node_id(od_.node_id());
  const auto boot_up = nmt_.finish_initialisation(node_id);
  if (!boot_up) return;
  heartbeat_producer_.set_node_id(node_id);
  guarding_.set_node_id(node_id);
  send(*boot_up);

  configure_heartbeat(now);
  heartbeat_producer_.start(now);
  configure_guarding();
  guarding_.reset();
  configure_consumer(true);
  configure_emcy();
  configure_sync(now, true);
  state_changed(NmtState::boot_up, nmt_.state(), now);
}

void DeviceServices::state_changed(NmtState from, NmtState to, can::TimePoint now) {
  emcy_.set_enabled(nmt_allows(to, NmtService::emcy));
  if (to != NmtState::boot_up) {
    const bool sync_before = nmt_allows(from, NmtService::sync);
    const bool sync_now = nmt_allows(to, NmtService::sync);
    if (sync_producer_) {
      if (!sync_now) {
        sync_producer_->stop();
      } else if (!sync_before || !sync_producer_->running()) {
        start_sync_producer(now);
      } else {
        // Entering Operational or Pre-operational restarts the counter (sync_producer.hpp).
        sync_producer_->reset_counter();
      }
    }
  }
  if (handlers_.on_state_changed) handlers_.on_state_changed(from, to);
}

// ---------------------------------------------------------------------------------------------
// Events of the services

void DeviceServices::flush_emcy(can::TimePoint now) {
  while (auto frame = emcy_.on_time(now))
    send(*frame);
}

std::uint8_t DeviceServices::communication_error_behaviour() const {
  const Entry* behaviour = od_.find(kErrorBehaviourIndex, 1);
  if (behaviour == nullptr) return config_.communication_error_without_object;
  return config_.error_behaviour ? static_cast<std::uint8_t>(behaviour->as_unsigned())
                                 : std::uint8_t{0};
}

void DeviceServices::update_communication_error(can::TimePoint now) {
  const bool guarding_fault = guarding_.expired();
  bool fault = guarding_fault;
  for (const auto& entry : consumer_entries_) {
    fault = fault ||
            (config_.heartbeat_consumer_timeouts && heartbeat_consumer_.is_timed_out(entry.node));
  }
  const bool active = emcy_.is_active(kHeartbeatError);
  // The error behaviour (1029h) follows the communication error itself, not the EMCY: the
  // application may have reported 8130h already from its own handler (CiA 402 6007h = 1 does),
  // and the NMT reaction must still happen.
  if (fault && !communication_error_) {
    communication_error_ = true;
    if (!active) {
      emcy_.raise(kHeartbeatError, kCommunicationBit, {}, now);
      mirror_error_objects(emcy_, od_);
      // The EMCY goes out before the error behaviour may stop the node.
      flush_emcy(now);
    }
    const auto value = communication_error_behaviour();
    auto reaction = communication_error_command(nmt_.state(), value);
    if (config_.error_behaviour_stopped_only_in_operational &&  // fault injection
        nmt_.state() != NmtState::operational) {
      reaction.reset();
    }
    if (reaction && (guarding_fault || config_.heartbeat_timeout_nmt_reaction)) {
      on_nmt_result(nmt_.apply(*reaction), now);
    }
  } else if (!fault && communication_error_) {
    communication_error_ = false;
    if (active) {
      emcy_.clear(kHeartbeatError, now);
      mirror_error_objects(emcy_, od_);
    }
  }
}

void DeviceServices::on_heartbeat_event(const HeartbeatEvent& event, can::TimePoint now) {
  const bool timing =
      event.kind == HeartbeatEventKind::timeout || event.kind == HeartbeatEventKind::resumed;
  if (timing && !config_.heartbeat_consumer_timeouts) return;  // fault injection
  if (handlers_.on_heartbeat) handlers_.on_heartbeat(event);
  if (event.kind == HeartbeatEventKind::timeout || event.kind == HeartbeatEventKind::resumed) {
    update_communication_error(now);
  }
}

void DeviceServices::on_life_guarding_event(const LifeGuardingEvent& event, can::TimePoint now) {
  if (handlers_.on_life_guarding) handlers_.on_life_guarding(event);
  update_communication_error(now);
}

void DeviceServices::on_sync_event(const SyncConsumerEvent& event, can::TimePoint now) {
  if (event.kind == SyncConsumerEventKind::wrong_length) {
    if (emcy_.raise(kSyncLengthError, kCommunicationBit, {}, now)) mirror_error_objects(emcy_, od_);
  } else if (event.kind == SyncConsumerEventKind::sync) {
    if (emcy_.clear(kSyncLengthError, now)) mirror_error_objects(emcy_, od_);
  }
  if (handlers_.on_sync) handlers_.on_sync(event);
}

bool DeviceServices::raise_error(std::uint16_t code, std::uint8_t register_bits,
                                 const std::array<std::uint8_t, 5>& manufacturer) {
  const can::TimePoint now = bus_.now();
  if (!emcy_.raise(code, register_bits, manufacturer, now)) return false;
  mirror_error_objects(emcy_, od_);
  service(now);
  return true;
}

bool DeviceServices::clear_error(std::uint16_t code) {
  const can::TimePoint now = bus_.now();
  if (!emcy_.clear(code, now)) return false;
  mirror_error_objects(emcy_, od_);
  service(now);
  return true;
}

// ---------------------------------------------------------------------------------------------
// Time

bool DeviceServices::run_due(can::TimePoint now) {
  bool progressed = false;
  if (boot_up_due_ && now >= *boot_up_due_) {
    finish_initialisation(now);
    progressed = true;
  }
  if (powered_ && !nmt_.initialising()) {
    if (auto frame = heartbeat_producer_.on_time(now, nmt_.state())) {
      send(*frame);
      progressed = true;
    }
    for (const auto& event : heartbeat_consumer_.on_time(now)) {
      on_heartbeat_event(event, now);
      progressed = true;
    }
    if (auto event = guarding_.on_time(now)) {
      on_life_guarding_event(*event, now);
      progressed = true;
    }
    if (sync_producer_ && nmt_.allows(NmtService::sync)) {
      // A SYNC whose predecessor has not yet reached the bus is skipped (a controller does not
      // queue a second copy of a message object that is still pending): with 1006h shorter than
      // the SYNC frame itself, the producer would otherwise build an unbounded backlog.
      const SyncCobIdEntry& cob = sync_consumer_.config().cob_id;
      const auto format = cob.extended ? can::IdFormat::extended : can::IdFormat::standard;
      if (bus_.queued(cob.can_id, format) > 0 && sync_producer_->skip_due(now)) {
        progressed = true;
      } else if (auto frame = sync_producer_->on_time(now)) {
        // SyncProducer makes CAN-IDs up to 7FFh 11-bit; 1005h bit 29 may ask for 29 bits.
        if (sync_consumer_.config().cob_id.extended) frame->format = can::IdFormat::extended;
        send(*frame);
        // The producing device is a consumer of its own SYNC too.
        if (auto event = sync_consumer_.on_frame(*frame, now)) on_sync_event(*event, now);
        progressed = true;
      }
    }
    if (auto event = sync_consumer_.on_time(now)) {
      if (handlers_.on_sync) handlers_.on_sync(*event);
      progressed = true;
    }
  }
  while (auto frame = emcy_.on_time(now)) {
    send(*frame);
    progressed = true;
  }
  return progressed;
}

void DeviceServices::service(can::TimePoint now) {
  if (in_service_) {
    service_again_ = true;
    return;
  }
  in_service_ = true;
  // Each pass handles what is due; events may make more due at the same instant. The bound
  // only guards against a loop that never settles.
  for (int pass = 0; pass < 64; ++pass) {
    service_again_ = false;
    if (!run_due(now) && !service_again_) break;
  }
  in_service_ = false;
  rearm();
}

void DeviceServices::rearm() {
  can::TimePoint at = can::kForever;
  if (boot_up_due_) at = std::min(at, *boot_up_due_);
  if (powered_ && !nmt_.initialising()) {
    at = std::min(at, heartbeat_producer_.next_deadline());
    at = std::min(at, heartbeat_consumer_.next_deadline());
    at = std::min(at, guarding_.next_deadline());
    at = std::min(at, sync_consumer_.next_deadline());
    if (sync_producer_ && nmt_.allows(NmtService::sync)) {
      at = std::min(at, sync_producer_->next_deadline());
    }
  }
  at = std::min(at, emcy_.next_deadline());
  timer_.arm(at);
}

// ---------------------------------------------------------------------------------------------
// Configuration from the object dictionary

void DeviceServices::configure_heartbeat(can::TimePoint now) {
  const auto period = producer_heartbeat_time(od_);
  heartbeat_supported_ = period.has_value();
  heartbeat_producer_.set_period(period.value_or(std::chrono::milliseconds{0}), now);
  guarding_.set_heartbeat_in_use(period && period->count() != 0);
}

void DeviceServices::configure_guarding() {
  const auto parameters = guarding_parameters(od_);
  guarding_supported_ = parameters.has_value();
  if (parameters) guarding_.configure(parameters->guard_time, parameters->life_time_factor);
}

void DeviceServices::configure_consumer(bool restart) {
  if (restart) {
    for (const auto& entry : consumer_entries_)
      heartbeat_consumer_.stop_monitoring(entry.node);
    consumer_entries_.clear();
  }
  consumer_entries_ = configure_heartbeat_consumer(heartbeat_consumer_, od_, consumer_entries_);
}

void DeviceServices::configure_emcy() {
  const auto cob_id = configured_emcy_cob_id(od_);
  emcy_.set_cob_id(cob_id.value_or(EmcyCobIdEntry{false, false, emcy_cob_id(nmt_.node_id())}));
  emcy_.set_inhibit_time(config_.emcy_inhibit
                             ? configured_emcy_inhibit_time(od_).value_or(can::Duration::zero())
                             : can::Duration::zero());
}

void DeviceServices::start_sync_producer(can::TimePoint now) {
  // The first SYNC follows within one cycle (CiA 301 §7.5.2, 1005h), here exactly one cycle.
  sync_producer_->start(now + sync_producer_->config().period);
}

void DeviceServices::configure_sync(can::TimePoint now, bool restart_producer) {
  sync_consumer_.configure(sync_consumer_config(od_));
  const auto config = sync_producer_config(od_);
  if (!config) {
    sync_producer_.reset();
    return;
  }
  if (!restart_producer && sync_producer_ && sync_producer_->config().period == config->period &&
      sync_producer_->config().counter_overflow == config->counter_overflow &&
      sync_producer_->config().cob_id == config->cob_id) {
    return;
  }
  auto created = SyncProducer::create(*config);
  if (!created) {
    sync_producer_.reset();
    return;
  }
  sync_producer_ = std::move(*created);
  if (!nmt_.initialising() && nmt_.allows(NmtService::sync)) start_sync_producer(now);
}

void DeviceServices::reload_configuration() {
  const can::TimePoint now = bus_.now();
  if (!nmt_.initialising()) {
    configure_heartbeat(now);
    configure_guarding();
    configure_consumer(false);
    configure_sync(now, false);
    update_communication_error(now);
  }
  configure_emcy();
  service(now);
}

// ---------------------------------------------------------------------------------------------
// Write observers

void DeviceServices::bind(std::uint16_t index, std::function<void(can::TimePoint)> apply) {
  Object* object = od_.find(index);
  if (object == nullptr) return;
  for (Entry& entry : object->entries()) {
    if (object->code() != ObjectCode::var && entry.sub_index() == 0 &&
        index != kPreDefinedErrorFieldIndex) {
      continue;
    }
    if (index == kPreDefinedErrorFieldIndex && entry.sub_index() != 0) continue;
    entry.set_write_observer([this, apply](ObjectDictionary&, Entry&) {
      const can::TimePoint now = bus_.now();
      apply(now);
      service(now);
    });
    bound_.push_back({index, entry.sub_index()});
  }
}

void DeviceServices::bind_objects() {
  // Writes take effect at once, but configuration waits while the node is initialising or off
  // (finish_initialisation reads everything then).
  const auto running = [this] { return powered_ && !nmt_.initialising(); };
  bind(kProducerHeartbeatTimeIndex, [this, running](can::TimePoint now) {
    if (!running()) return;
    configure_heartbeat(now);
    update_communication_error(now);  // heartbeat in use ends life guarding
  });
  bind(kConsumerHeartbeatTimeIndex, [this, running](can::TimePoint now) {
    if (!running()) return;
    configure_consumer(false);
    update_communication_error(now);
  });
  bind(kGuardTimeIndex, [this, running](can::TimePoint) {
    if (running()) configure_guarding();
  });
  bind(kLifeTimeFactorIndex, [this, running](can::TimePoint) {
    if (running()) configure_guarding();
  });
  bind(kEmcyCobIdIndex, [this](can::TimePoint) { configure_emcy(); });
  bind(kEmcyInhibitTimeIndex, [this](can::TimePoint) { configure_emcy(); });
  bind(kPreDefinedErrorFieldIndex, [this](can::TimePoint) {
    emcy_.clear_history();
    mirror_error_objects(emcy_, od_);
  });
  for (const std::uint16_t index :
       {kSyncCobIdIndex, kCommunicationCyclePeriodIndex, kSyncCounterOverflowIndex}) {
    bind(index, [this, running](can::TimePoint now) {
      if (running()) configure_sync(now, false);
    });
  }
  bind(kSyncWindowLengthIndex, [this, running](can::TimePoint now) {
    if (running()) configure_sync(now, false);
  });
}

void DeviceServices::unbind_objects() {
  for (const auto& [index, sub_index] : bound_) {
    Entry* entry = od_.find(index, sub_index);
    if (entry == nullptr) continue;
    if (index == kPreDefinedErrorFieldIndex) {
      // Back to the object's own behaviour (add_emcy_producer_objects).
      entry->set_write_observer(
          [](ObjectDictionary& dictionary, Entry&) { clear_pre_defined_error_field(dictionary); });
    } else {
      entry->set_write_observer({});
    }
  }
  bound_.clear();
}

}  // namespace drivecheck::cia301
