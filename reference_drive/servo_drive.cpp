#include "reference_drive/servo_drive.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <utility>

#include "reference_drive/festo_position_sampling.hpp"
#include "reference_drive/kollmorgen_objects.hpp"
#include "reference_drive/modes/homing.hpp"
#include "reference_drive/profile_objects.hpp"

namespace drivecheck::reference_drive {

// The port between the drive and the bus that adds Kollmorgen's second EMCY and drops Festo's
// NMT frames that come too close together (see the header). Everything else passes unchanged.
class PersonalityPort final : public can::Bus {
 public:
  PersonalityPort(can::Bus& port, std::uint8_t node, bool emcy_follow_up,
                  can::Duration nmt_min_spacing, std::map<std::uint32_t, std::uint32_t> abort_codes,
                  profile::ResponseDelay sdo_delay)
      : port_(port),
        node_(node),
        emcy_follow_up_(emcy_follow_up),
        nmt_min_spacing_(nmt_min_spacing),
        abort_codes_(std::move(abort_codes)),
        sdo_delay_(sdo_delay),
        random_(0x9E3779B9U ^ node) {}
  ~PersonalityPort() override { drop_pending(); }
  PersonalityPort(const PersonalityPort&) = delete;
  PersonalityPort& operator=(const PersonalityPort&) = delete;

  void set_dictionary(const cia301::ObjectDictionary* od) { od_ = od; }

  can::TimePoint now() const override { return port_.now(); }
  can::Duration unix_offset() const override { return port_.unix_offset(); }
  std::error_code send(const can::Frame& original) override {
    can::Frame frame = original;
    if (is_sdo_response(frame)) {
      remap_abort(frame);
      if (sdo_delay_.max > can::Duration{}) return send_later(frame);
    } else if (is_boot_up(frame)) {
      drop_pending();  // a reset loses the responses not yet sent
    }
    const std::error_code error = port_.send(frame);
    if (!error && emcy_follow_up_ && is_emcy(frame) && frame.length() >= 3 &&
        (frame.data[0] | frame.data[1]) != 0) {
      // 80h+N [00 00 | error register | 00 00 00 00 00]: the error state after the EMCY.
      const std::uint8_t bytes[8] = {0x00, 0x00, frame.data[2], 0x00, 0x00, 0x00, 0x00, 0x00};
      return port_.send(can::Frame::standard(frame.id, bytes));
    }
    return error;
  }
  std::optional<can::TimedFrame> receive(can::TimePoint deadline) override {
    while (true) {
      auto frame = port_.receive(deadline);
      if (!frame || !lost(*frame)) return frame;
    }
  }
  void set_frame_handler(FrameHandler handler) override {
    if (!handler || nmt_min_spacing_ == can::Duration{}) {
      port_.set_frame_handler(std::move(handler));
      return;
    }
    port_.set_frame_handler([this, handler = std::move(handler)](const can::TimedFrame& frame) {
      if (!lost(frame)) handler(frame);
    });
  }
  void set_filters(std::span<const can::Filter> filters) override { port_.set_filters(filters); }
  void set_loopback(bool enabled) override { port_.set_loopback(enabled); }
  std::size_t queued(std::uint32_t id, can::IdFormat format) const override {
    return port_.queued(id, format);
  }
  can::TimerId start_timer(can::TimePoint at, TimerCallback callback) override {
    return port_.start_timer(at, std::move(callback));
  }
  void cancel_timer(can::TimerId id) override { port_.cancel_timer(id); }
  void run_until(can::TimePoint deadline) override { port_.run_until(deadline); }
  void stop() override { port_.stop(); }

 private:
  // The default SDO channel's responses (580h + node-ID).
  bool is_sdo_response(const can::Frame& frame) const {
    return !frame.is_remote() && !frame.is_error() && !frame.is_extended() &&
           frame.id == 0x580U + node_;
  }
  bool is_boot_up(const can::Frame& frame) const {
    return !frame.is_remote() && !frame.is_error() && !frame.is_extended() &&
           frame.id == 0x700U + node_ && frame.length() == 1 && frame.data[0] == 0;
  }
  // abort_codes: an abort transfer frame (command 80h) carries the code in bytes 4-7 (LE).
  void remap_abort(can::Frame& frame) const {
    if (abort_codes_.empty() || frame.length() != 8 || frame.data[0] != 0x80) return;
    const std::uint32_t code = static_cast<std::uint32_t>(frame.data[4]) |
                               static_cast<std::uint32_t>(frame.data[5]) << 8U |
                               static_cast<std::uint32_t>(frame.data[6]) << 16U |
                               static_cast<std::uint32_t>(frame.data[7]) << 24U;
    const auto it = abort_codes_.find(code);
    if (it == abort_codes_.end()) return;
    for (unsigned i = 0; i < 4; ++i) {
      frame.data[4 + i] = static_cast<std::uint8_t>(it->second >> (8U * i));
    }
  }
  // sdo_response_delay: min..max later (xorshift32, fixed seed per node), never before a
  // response produced earlier.
  std::error_code send_later(const can::Frame& frame) {
    random_ ^= random_ << 13U;
    random_ ^= random_ >> 17U;
    random_ ^= random_ << 5U;
    const auto span = (sdo_delay_.max - sdo_delay_.min).count();
    const can::Duration delay =
        sdo_delay_.min +
        can::Duration(span > 0 ? static_cast<can::Duration::rep>(random_) % (span + 1) : 0);
    const can::TimePoint due = std::max(port_.now() + delay, last_due_);
    last_due_ = due;
    const std::uint64_t id = next_pending_++;
    pending_[id] = port_.start_timer(due, [this, frame, id] {
      pending_.erase(id);
      (void)port_.send(frame);
    });
    return {};
  }
  void drop_pending() {
    for (const auto& [id, timer] : pending_) {
      (void)id;
      port_.cancel_timer(timer);
    }
    pending_.clear();
  }

  // The EMCY COB-ID: 1014h (bit 31 clear) when the dictionary is known, else 80h + node-ID.
  bool is_emcy(const can::Frame& frame) const {
    if (frame.is_remote() || frame.is_error() || frame.is_extended()) return false;
    std::uint32_t cob_id = 0x80U + node_;
    if (const cia301::Entry* entry = od_ != nullptr ? od_->find(0x1014, 0) : nullptr;
        entry != nullptr && entry->bytes().size() == 4) {
      const std::uint64_t raw = entry->as_unsigned();
      if ((raw & 0x80000000U) != 0) return false;
      cob_id = static_cast<std::uint32_t>(raw & 0x7FFU);
    }
    return frame.id == cob_id;
  }

  // Festo (000 §3.6 L1403-1405): an NMT frame (any node) less than nmt_min_spacing after the
  // previous NMT frame on the bus is not processed. Every NMT frame counts as the previous one.
  bool lost(const can::TimedFrame& timed) {
    const can::Frame& frame = timed.frame;
    if (nmt_min_spacing_ == can::Duration{} || timed.own || frame.id != 0 || frame.is_extended() ||
        frame.is_remote() || frame.is_error()) {
      return false;
    }
    const bool too_close = last_nmt_ && timed.timestamp - *last_nmt_ < nmt_min_spacing_;
    last_nmt_ = timed.timestamp;
    return too_close;
  }

  can::Bus& port_;
  std::uint8_t node_;
  bool emcy_follow_up_;
  can::Duration nmt_min_spacing_;
  std::optional<can::TimePoint> last_nmt_;
  const cia301::ObjectDictionary* od_ = nullptr;
  std::map<std::uint32_t, std::uint32_t> abort_codes_;
  profile::ResponseDelay sdo_delay_;
  std::uint32_t random_;
  can::TimePoint last_due_{};
  std::uint64_t next_pending_ = 1;
  std::map<std::uint64_t, can::TimerId> pending_;  // delayed SDO responses not yet sent
};

// The Cia402Application as the drive's application, with the personality's default overrides
// written into the dictionary at each reset of their group, before the application reloads.
class PersonalityApplication final : public DriveApplication {
 public:
  PersonalityApplication(Cia402Application& inner, std::vector<DefaultOverride> overrides,
                         std::vector<profile::ObjectRule> objects)
      : inner_(inner), overrides_(std::move(overrides)), objects_(std::move(objects)) {}

  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override {
    if (cia402_) {
      if (auto r = inner_.add_objects(od); !r) return r;
    }
    if (auto r = apply_object_rules(od, objects_, inner_); !r) return r;
    if (internal_units_) internal_units_->attach(od);
    if (kollmorgen_) {
      if (auto r = kollmorgen_->add_objects(od); !r) return r;
    }
    if (sampling_) {
      if (auto r = sampling_->add_objects(od); !r) return r;
    }
    if (profile_objects_ != nullptr) {  // last: every object the drive has is in `od`
      for (std::string& line : add_profile_objects(od, *profile_objects_)) {
        not_applied_->push_back(std::move(line));
      }
    }
    if (static_pdo_mapping_) make_pdo_mapping_static(od);
    if (refuse_empty_pdo_) refuse_empty_pdos(od);
    return {};
  }
  void on_reset(ReferenceDrive& drive, cia301::ResetKind kind) override {
    cia301::ObjectDictionary& od = drive.dictionary();
    for (const DefaultOverride& o : overrides_) {
      if (o.reset != kind) continue;
      cia301::Entry* entry = od.find(o.index, o.sub);
      if (entry == nullptr) continue;  // the drive has no such entry: nothing to override
      const std::vector<std::uint8_t> standard = entry->default_bytes(od.node_id());
      if (!std::equal(standard.begin(), standard.end(), entry->bytes().begin(),
                      entry->bytes().end())) {
        continue;  // stored or written by the master: theirs wins
      }
      const bool is_signed =
          cia301::info(entry->type()).type_class == cia301::TypeClass::signed_integer;
      (void)entry->assign(is_signed
                              ? cia301::Value::of_signed(o.value)
                              : cia301::Value::of_unsigned(static_cast<std::uint64_t>(o.value)));
    }
    if (cia402_) inner_.on_reset(drive, kind);
    if (internal_units_) internal_units_->resync(od);
    if (kollmorgen_) kollmorgen_->on_reset();
    if (sampling_) sampling_->on_reset(od, kind);
  }
  void on_nmt_state(ReferenceDrive& drive, cia301::NmtState from, cia301::NmtState to) override {
    if (cia402_) inner_.on_nmt_state(drive, from, to);
  }
  void on_cycle(ReferenceDrive& drive, can::TimePoint now) override {
    if (cia402_) inner_.on_cycle(drive, now);
    if (kollmorgen_) kollmorgen_->refresh(drive.dictionary());  // 1002h for the TPDOs
    if (sampling_) sampling_->refresh(drive.dictionary());      // 204Ah, statusword bit 15
  }
  void on_sync(ReferenceDrive& drive, can::TimePoint at) override {
    if (cia402_) inner_.on_sync(drive, at);
  }
  void on_communication_loss(ReferenceDrive& drive) override {
    if (cia402_) inner_.on_communication_loss(drive);
  }
  void on_connection_event(ReferenceDrive& drive) override {
    if (cia402_) inner_.on_connection_event(drive);
  }
  void on_drive_destroyed(ReferenceDrive& drive) override {
    if (sampling_) sampling_->detach();
    if (cia402_) inner_.on_drive_destroyed(drive);
  }

 private:
  // pdo_mapping: static (CiA 301 §7.5.2.36, §7.5.2.38): every sub-index of the mapping records
  // refuses SDO writes as a read-only entry does (06010002h); the PDO service still reads them.
  static void make_pdo_mapping_static(cia301::ObjectDictionary& od) {
    for (const cia301::Object& object : od.objects()) {
      const std::uint16_t index = object.index();
      if (!((index >= 0x1600 && index <= 0x17FF) || (index >= 0x1A00 && index <= 0x1BFF))) continue;
      for (const cia301::Entry& e : object.entries()) {
        od.find(index, e.sub_index())
            ->set_write_validator(
                [](const cia301::ObjectDictionary&, const cia301::Entry&,
                   std::span<const std::uint8_t>) -> Expected<void, cia301::SdoAbort> {
                  return Unexpected(cia301::SdoAbort::write_read_only);
                });
      }
    }
  }
  // empty_pdo_valid: refuse: a COB-ID written valid (bit 31 = 0) while the PDO maps nothing
  // (its mapping record's sub 00h = 0) aborts 06090030h, after the CiA checks of the entry.
  static void refuse_empty_pdos(cia301::ObjectDictionary& od) {
    for (std::uint16_t base : {std::uint16_t{0x1400}, std::uint16_t{0x1800}}) {
      for (std::uint16_t index = base; index < base + 0x200; ++index) {
        cia301::Entry* cob_id = od.find(index, 1);
        if (cob_id == nullptr) continue;
        const auto mapping = static_cast<std::uint16_t>(index + 0x200);
        cob_id->set_write_validator(
            [previous = cob_id->write_validator(), mapping](
                const cia301::ObjectDictionary& dict, const cia301::Entry& entry,
                std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
              if (previous) {
                if (auto ok = previous(dict, entry, data); !ok) return ok;
              }
              if (data.size() != 4 || (data[3] & 0x80U) != 0) return {};
              const cia301::Entry* count = dict.find(mapping, 0);
              if (count != nullptr && count->as_unsigned() == 0) {
                return Unexpected(cia301::SdoAbort::invalid_value);
              }
              return {};
            });
      }
    }
  }

  Cia402Application& inner_;
  std::vector<DefaultOverride> overrides_;
  std::vector<profile::ObjectRule> objects_;

 public:
  bool cia402_ = true;               // false: inner_ is not this drive's application
  bool static_pdo_mapping_ = false;  // pdo_mapping: static
  bool refuse_empty_pdo_ = false;    // empty_pdo_valid: refuse
  std::unique_ptr<InternalUnitParameters> internal_units_;  // null: user units kept (standard)
  std::unique_ptr<KollmorgenObjects> kollmorgen_;           // manufacturer_objects: kollmorgen
  std::unique_ptr<FestoPositionSampling> sampling_;         // position_sampling: festo
  // The profile's objects file (profile_objects.hpp): the objects the drive lacks are added;
  // what cannot be added goes to not_applied_ (the plan's). Null: the standard drive.
  const std::vector<profile::ObjectSpec>* profile_objects_ = nullptr;
  std::vector<std::string>* not_applied_ = nullptr;
};

// Bus-off as a fault of the drive (personality key bus_off): the PDS's fault reaction stops an
// enabled drive and disables it; recovery removes the cause (a fault reset then clears it).
//   Kollmorgen 002 §2.9 L206-212: error F23 (EMCY code 8182h, §5.1 L1193), reported only when
//   a frame got onto the wire before.
//   ESR 004 §11.4 L789-795: fault 8180h (the NMT reaction is 1029h's, as guarding_loss sets it).
namespace {
constexpr FaultDefinition kBusOffF23{0x8182, 0x10, "CAN bus-off (F23)"};
constexpr FaultDefinition kBusOff8180{0x8180, 0x10, "CAN bus off"};

std::function<void(ReferenceDrive&, bool, bool)> bus_off_fault(Cia402Application& app,
                                                               const FaultDefinition& fault,
                                                               bool after_transmission) {
  return [&app, &fault, after_transmission](ReferenceDrive&, bool bus_off, bool transmitted) {
    if (bus_off && (transmitted || !after_transmission)) {
      app.pds().raise_fault(fault);
    } else if (!bus_off) {
      app.pds().clear_fault_cause(fault.code);
    }
  };
}
}  // namespace

// The profile's objects file in the plan (profile_objects.hpp): the manual's defaults of the
// parameters the drive has (after the personality's own overrides, which win) and the size of
// the PDO mapping records (when the default mappings fit). The objects the drive lacks are
// added by PersonalityApplication::add_objects.
void apply_profile_objects(const profile::DriveProfile& profile, PersonalityPlan& plan) {
  for (const DefaultOverride& o : profile_default_overrides(profile.objects)) {
    plan.overrides.push_back(o);
  }
  cia301::PdoObjectOptions& pdo = plan.drive.dictionary.pdo;
  std::size_t longest = 0;
  for (const auto* list : {&pdo.rpdo_defaults, &pdo.tpdo_defaults}) {
    for (const cia301::PdoDefaults& d : *list)
      longest = std::max(longest, d.mapping.size());
  }
  const std::uint8_t entries = listed_mapping_entries(profile.objects);
  if (entries >= 1 && entries <= 64 && entries >= longest) pdo.mapping_entries = entries;
}

ServoDrive::ServoDrive(PersonalityPlan plan) : plan_(std::move(plan)) {}
ServoDrive::~ServoDrive() = default;

Expected<std::unique_ptr<ServoDrive>, std::string> ServoDrive::create(can::Bus& bus,
                                                                      ServoDriveOptions options) {
  auto plan = plan_personality(options.profile, options.link);
  if (!plan) {
    return Unexpected(fmt::format("personality {}: {}",
                                  options.profile != nullptr ? options.profile->name : "standard",
                                  plan.error()));
  }
  std::unique_ptr<ServoDrive> servo(new ServoDrive(std::move(*plan)));
  PersonalityPlan& p = servo->plan_;

  p.application.deviations = options.deviations;
  p.application.pds.deviations = options.deviations;

  servo->application_ = std::make_unique<Cia402Application>(p.application);
  if (p.host_homing) {
    servo->application_->add_mode(std::make_unique<HomingOperationMode>(p.homing));
  }
  if (options.profile != nullptr) apply_profile_objects(*options.profile, p);
  servo->personality_ =
      std::make_unique<PersonalityApplication>(*servo->application_, p.overrides, p.objects);

  servo->personality_->cia402_ = p.cia402;
  servo->personality_->static_pdo_mapping_ = p.static_pdo_mapping;
  servo->personality_->refuse_empty_pdo_ = p.refuse_empty_pdo;
  if (p.parameters_internal) {
    servo->personality_->internal_units_ = std::make_unique<InternalUnitParameters>();
  }
  if (p.manufacturer_objects == profile::ManufacturerObjects::kollmorgen) {
    servo->personality_->kollmorgen_ = std::make_unique<KollmorgenObjects>(*servo->application_);
  }
  if (p.position_sampling == profile::PositionSampling::festo) {
    servo->personality_->sampling_ = std::make_unique<FestoPositionSampling>(*servo->application_);
  }
  if (options.profile != nullptr) {  // read during create() only (ReferenceDrive::create)
    servo->personality_->profile_objects_ = &options.profile->objects;
    servo->personality_->not_applied_ = &p.not_applied;
  }

  can::Bus* port = &bus;
  if (p.emcy_follow_up || p.nmt_min_spacing != can::Duration{} || !p.abort_codes.empty() ||
      p.sdo_response_delay.max > can::Duration{}) {
    servo->port_ =
        std::make_unique<PersonalityPort>(bus, options.node, p.emcy_follow_up, p.nmt_min_spacing,
                                          p.abort_codes, p.sdo_response_delay);
    port = servo->port_.get();
  }

  DriveConfig config = p.drive;
  config.dictionary.node_id = options.node;
  config.dictionary.identity.serial =
      options.serial_number != 0 ? options.serial_number : options.node;
  config.storage = options.storage;
  config.application = servo->personality_.get();
  config.deviations = options.deviations;
  if (p.bus_off == profile::BusOffReaction::kollmorgen_f23) {
    config.on_bus_off = bus_off_fault(*servo->application_, kBusOffF23, true);
  } else if (p.bus_off == profile::BusOffReaction::esr_8180) {
    config.on_bus_off = bus_off_fault(*servo->application_, kBusOff8180, false);
  }
  if (p.restore_output_stage_off) {
    config.restore_guard = [app = servo->application_.get()]() -> Expected<void, cia301::SdoAbort> {
      const cia402::State state = app->pds().state();
      if (state == cia402::State::switched_on || state == cia402::State::operation_enabled ||
          state == cia402::State::quick_stop_active ||
          state == cia402::State::fault_reaction_active) {
        return Unexpected(cia301::SdoAbort::cannot_transfer_device_state);
      }
      return {};
    };
  }
  if (options.adjust_config) options.adjust_config(config);
  auto drive = ReferenceDrive::create(*port, std::move(config));
  if (!drive) return Unexpected(drive.error());
  servo->drive_ = std::move(*drive);
  servo->personality_->profile_objects_ = nullptr;  // the profile may go now
  if (servo->port_) servo->port_->set_dictionary(&servo->drive_->dictionary());
  if (auto r = servo->application_->simulate("hardware-enable", p.hardware_enable_present ? 1 : 0);
      !r) {
    return Unexpected(r.error());
  }
  return servo;
}

void ServoDrive::power_on() {
  drive_->power_on();
}

Expected<void, std::string> ServoDrive::simulate(std::string_view input, std::int64_t value) {
  if (FestoPositionSampling* sampling = position_sampling();
      sampling != nullptr && input == FestoPositionSampling::kInputName) {
    return sampling->set_input(value);
  }
  return application_->simulate(input, value);
}

FestoPositionSampling* ServoDrive::position_sampling() {
  return personality_ ? personality_->sampling_.get() : nullptr;
}

}  // namespace drivecheck::reference_drive
