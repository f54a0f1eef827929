#include "reference_drive/servo_drive.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "reference_drive/modes/homing.hpp"

namespace drivecheck::reference_drive {

// The port between the drive and the bus that adds Kollmorgen's second EMCY (see the header).
// Everything else passes unchanged.
class EmcyFollowUpPort final : public can::Bus {
 public:
  EmcyFollowUpPort(can::Bus& port, std::uint8_t node) : port_(port), node_(node) {}

  void set_dictionary(const cia301::ObjectDictionary* od) { od_ = od; }

  can::TimePoint now() const override { return port_.now(); }
  can::Duration unix_offset() const override { return port_.unix_offset(); }
  std::error_code send(const can::Frame& frame) override {
    const std::error_code error = port_.send(frame);
    if (!error && is_emcy(frame) && frame.length() >= 3 && (frame.data[0] | frame.data[1]) != 0) {
      // 80h+N [00 00 | error register | 00 00 00 00 00]: the error state after the EMCY.
      const std::uint8_t bytes[8] = {0x00, 0x00, frame.data[2], 0x00, 0x00, 0x00, 0x00, 0x00};
      return port_.send(can::Frame::standard(frame.id, bytes));
    }
    return error;
  }
  std::optional<can::TimedFrame> receive(can::TimePoint deadline) override {
    return port_.receive(deadline);
  }
  void set_frame_handler(FrameHandler handler) override {
    port_.set_frame_handler(std::move(handler));
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

  can::Bus& port_;
  std::uint8_t node_;
  const cia301::ObjectDictionary* od_ = nullptr;
};

// The Cia402Application as the drive's application, with the personality's default overrides
// written into the dictionary at each reset of their group, before the application reloads.
class PersonalityApplication final : public DriveApplication {
 public:
  PersonalityApplication(Cia402Application& inner, std::vector<DefaultOverride> overrides,
                         std::vector<profile::ObjectRule> objects)
      : inner_(inner), overrides_(std::move(overrides)), objects_(std::move(objects)) {}

  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override {
    if (auto r = inner_.add_objects(od); !r) return r;
    if (auto r = apply_object_rules(od, objects_, inner_); !r) return r;
    if (internal_units_) internal_units_->attach(od);
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
    inner_.on_reset(drive, kind);
    if (internal_units_) internal_units_->resync(od);
  }
  void on_nmt_state(ReferenceDrive& drive, cia301::NmtState from, cia301::NmtState to) override {
    inner_.on_nmt_state(drive, from, to);
  }
  void on_cycle(ReferenceDrive& drive, can::TimePoint now) override { inner_.on_cycle(drive, now); }
  void on_sync(ReferenceDrive& drive, can::TimePoint at) override { inner_.on_sync(drive, at); }
  void on_communication_loss(ReferenceDrive& drive) override {
    inner_.on_communication_loss(drive);
  }
  void on_drive_destroyed(ReferenceDrive& drive) override { inner_.on_drive_destroyed(drive); }

 private:
  Cia402Application& inner_;
  std::vector<DefaultOverride> overrides_;
  std::vector<profile::ObjectRule> objects_;

 public:
  std::unique_ptr<InternalUnitParameters> internal_units_;  // null: user units kept (standard)
};

ServoDrive::ServoDrive(PersonalityPlan plan) : plan_(std::move(plan)) {}
ServoDrive::~ServoDrive() = default;

Expected<std::unique_ptr<ServoDrive>, std::string> ServoDrive::create(can::Bus& bus,
                                                                      ServoDriveOptions options) {
  auto plan = plan_personality(options.profile);
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
  servo->personality_ =
      std::make_unique<PersonalityApplication>(*servo->application_, p.overrides, p.objects);

  if (p.parameters_internal) {
    servo->personality_->internal_units_ = std::make_unique<InternalUnitParameters>();
  }

  can::Bus* port = &bus;
  if (p.emcy_follow_up) {
    servo->port_ = std::make_unique<EmcyFollowUpPort>(bus, options.node);
    port = servo->port_.get();
  }

  DriveConfig config = p.drive;
  config.dictionary.node_id = options.node;
  config.dictionary.identity.serial =
      options.serial_number != 0 ? options.serial_number : options.node;
  config.storage = options.storage;
  config.application = servo->personality_.get();
  config.deviations = options.deviations;
  auto drive = ReferenceDrive::create(*port, std::move(config));
  if (!drive) return Unexpected(drive.error());
  servo->drive_ = std::move(*drive);
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
  return application_->simulate(input, value);
}

}  // namespace drivecheck::reference_drive
