#include "reference_drive/ethercat/ethercat_drive.hpp"

#include <fmt/format.h>

#include <utility>
#include <vector>

#include "protocol/ethercat/coe_objects.hpp"
#include "protocol/ethercat/frame.hpp"
#include "reference_drive/ethercat/sii_image.hpp"

namespace drivecheck::reference_drive::ethercat {

namespace ecat = drivecheck::ethercat;
using ecat::AlState;
using ecat::AlStatusCode;

using AbsentRanges = std::vector<std::pair<std::uint16_t, std::uint16_t>>;

// The drive's application with the CoE objects added after its own (before the services bind:
// entry pointers must not move once they have).
class CoeObjectsApplication final : public DriveApplication {
 public:
  // `absent`: the personality's absent objects (DriveConfig::absent_objects), which the device
  // removes after this application has added its objects.
  CoeObjectsApplication(DriveApplication* inner, AbsentRanges absent)
      : inner_(inner), absent_(std::move(absent)) {}

  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override {
    if (inner_ != nullptr) {
      if (auto r = inner_->add_objects(od); !r) return r;
    }
    ecat::CoeObjectsConfig config;
    // The default assignment: the first PDO of each direction where the drive has it (a
    // mapping object that stays in the dictionary and maps something), else nothing (a drive
    // without RxPDOs, e.g. cia301-minimal, has an empty 1C12h: ETG.1000.6 lets 1C12h:00 be 0).
    config.rx_assigned =
        assignable(od, 0x1600) ? std::vector<std::uint16_t>{0x1600} : std::vector<std::uint16_t>{};
    config.tx_assigned =
        assignable(od, 0x1A00) ? std::vector<std::uint16_t>{0x1A00} : std::vector<std::uint16_t>{};
    for (auto& definition : ecat::coe_object_definitions(config)) {
      const auto index = definition.index;
      if (auto r = od.add_object(std::move(definition)); !r) {
        return Unexpected(fmt::format("CoE object {:04X}h: {}", index, r.error()));
      }
    }
    return {};
  }
  void on_reset(ReferenceDrive& drive, cia301::ResetKind kind) override {
    if (inner_ != nullptr) inner_->on_reset(drive, kind);
  }
  void on_nmt_state(ReferenceDrive& drive, cia301::NmtState from, cia301::NmtState to) override {
    if (inner_ != nullptr) inner_->on_nmt_state(drive, from, to);
  }
  void on_cycle(ReferenceDrive& drive, can::TimePoint now) override {
    if (inner_ != nullptr) inner_->on_cycle(drive, now);
  }
  void on_sync(ReferenceDrive& drive, can::TimePoint at) override {
    if (inner_ != nullptr) inner_->on_sync(drive, at);
  }
  void on_communication_loss(ReferenceDrive& drive) override {
    if (inner_ != nullptr) inner_->on_communication_loss(drive);
  }
  void on_drive_destroyed(ReferenceDrive& drive) override {
    if (inner_ != nullptr) inner_->on_drive_destroyed(drive);
  }

 private:
  bool assignable(const cia301::ObjectDictionary& od, std::uint16_t mapping) const {
    for (const auto& [first, last] : absent_) {
      if (mapping >= first && mapping <= last) return false;
    }
    const cia301::Entry* count = od.find(mapping, 0);
    return count != nullptr && count->as_unsigned() != 0;
  }

  DriveApplication* inner_;
  AbsentRanges absent_;
};

namespace {

cia301::PdoDefaults mapping(std::initializer_list<cia301::PdoMappingEntry> entries) {
  cia301::PdoDefaults defaults;
  defaults.mapping = entries;
  return defaults;
}

bool has_mapping(const std::vector<cia301::PdoDefaults>& list) {
  for (const auto& pdo : list) {
    if (!pdo.mapping.empty()) return true;
  }
  return false;
}

// The default PDOs of the file comment (CiA 402 objects), when the personality gives no PDO
// defaults at all. A personality that gives some (its manual's pdo_defaults) has given its PDO
// set whole: a direction it leaves without a mapping stays without one (cia301-minimal: one
// TPDO, no RPDO at all; its mapping records hold 1 entry, where these defaults need 2).
void default_pdos(cia301::PdoObjectOptions& pdo) {
  if (!has_mapping(pdo.rpdo_defaults) && !has_mapping(pdo.tpdo_defaults)) {
    pdo.rpdo_defaults = {
        mapping({{0x6040, 0, 16}, {0x607A, 0, 32}}),
        mapping({{0x60FF, 0, 32}}),
        mapping({{0x6071, 0, 16}}),
    };
    pdo.tpdo_defaults = {
        mapping({{0x6041, 0, 16}, {0x6064, 0, 32}}),
        mapping({{0x606C, 0, 32}}),
        mapping({{0x6077, 0, 16}, {0x6061, 0, 8}}),
    };
  }
  pdo.mapping_while_valid = true;
}

constexpr std::uint16_t kSm0 = 1u << 0;
constexpr std::uint16_t kSm1 = 1u << 1;
constexpr std::uint16_t kSm2 = 1u << 2;

}  // namespace

EthercatDrive::EthercatDrive(ecat::Link& clock, EthercatDriveOptions options)
    : clock_(clock), options_(std::move(options)), port_(clock) {}

EthercatDrive::~EthercatDrive() {
  if (served_ != nullptr) served_->set_frame_handler({});
  if (watchdog_timer_ != ecat::kNoTimer) clock_.cancel_timer(watchdog_timer_);
  port_.set_emcy_handler({});
  port_.set_dictionary(nullptr);
}

Expected<std::unique_ptr<EthercatDrive>, std::string> EthercatDrive::create(
    ecat::Link& clock, EthercatDriveOptions options) {
  std::unique_ptr<EthercatDrive> drive(new EthercatDrive(clock, std::move(options)));
  if (auto r = drive->build(); !r) return Unexpected(r.error());
  return drive;
}

Expected<void, std::string> EthercatDrive::build() {
  for (Deviation d : options_.deviations.list()) {
    if (!acts_on(d, DeviationLink::ethercat)) {
      return Unexpected(fmt::format("deviation '{}' does not act on EtherCAT (CAN only: {})",
                                    to_string(d), only_on_why(d)));
    }
  }
  ServoDriveOptions servo;
  servo.node = 1;  // no meaning on EtherCAT (the EMCY COB-ID the clock port looks for)
  servo.profile = options_.profile;
  servo.deviations = options_.deviations;
  servo.storage = options_.storage;
  servo.serial_number = options_.serial_number;
  servo.link = profile::Link::ethercat;
  servo.adjust_config = [this](DriveConfig& config) {
    application_ =
        std::make_unique<CoeObjectsApplication>(config.application, config.absent_objects);
    config.application = application_.get();
    default_pdos(config.dictionary.pdo);
    config.can_abort_connection_events = false;  // 6007h: leaving OP (on_state_change)
  };
  auto created = ServoDrive::create(port_, std::move(servo));
  if (!created) return Unexpected(created.error());
  servo_ = std::move(*created);
  cia301::ObjectDictionary& od = dictionary();
  port_.set_dictionary(&od);
  port_.set_emcy_handler([this](const cia301::Emcy& emcy) { on_emcy(emcy); });

  profile::CoeRules coe_rules =
      options_.coe ? *options_.coe
                   : (options_.profile != nullptr ? options_.profile->coe : profile::CoeRules{});
  if (has(Deviation::coe_sdo_size_limit_ignored)) coe_rules.max_sdo_size.reset();
  init_loads_saved_values_ =
      coe_rules.init_loads_saved_values && !has(Deviation::init_saved_values_not_loaded);
  ecat::CoeObjectRuleOptions rule_options;
  rule_options.configuration_only_when_configurable =
      coe_rules.pdo_configuration_in == profile::PdoConfigurationIn::preop;
  rule_options.assignment_evaluated = coe_rules.pdo_assignment_evaluated;
  auto rules = ecat::install_coe_object_rules(
      od, [this] { return slave_ != nullptr && slave_->al_status().state == AlState::preop; },
      rule_options);
  if (!rules) return Unexpected(rules.error());
  DriveSiiOptions sii_options;
  // The SII's CoE details say what a master may configure: an assignment that is not
  // evaluated is not offered; the mappings are (Festo 000 L1770-1774: 1600h-1603h/1A00h-1A03h
  // are configured as on CANopen, in PREOP).
  sii_options.pdo_assignment = coe_rules.pdo_assignment_evaluated;
  auto sii = drive_sii_bytes(od, sii_options);
  if (!sii) return Unexpected(sii.error());
  sii_ = std::move(*sii);

  ecat::MailboxSlaveConfig mailbox;
  mailbox.write_size = kMailboxSize;
  mailbox.read_size = kMailboxSize;
  mailbox.honour_counter = !has(Deviation::mailbox_counter_ignored);
  ecat::CoeSdoServerOptions sdo;
  sdo.read_size = kMailboxSize;
  // SDO information lists and describes only what the SDO server serves: not the profile's
  // coe.absent_objects (Festo's 1008h-100Ah, 000 §4.6.2 L1826, §4.6.3 L2029-2036).
  if (!coe_rules.absent_objects.empty()) {
    sdo.sdo_information_hidden = [absent = coe_rules](std::uint16_t index) {
      return absent.is_absent(index);
    };
  }
  coe_ = std::make_unique<ecat::CoeSlave>(od, std::move(mailbox), sdo);
  coe_deviations_ = std::make_unique<CoeDeviationHook>(od, options_.deviations);
  ecat::CoeSdoHook* deviations = coe_deviations_->active() ? coe_deviations_.get() : nullptr;
  coe_rules_ =
      std::make_unique<CoeRulesHook>(coe_rules, deviations, [this] { coe_->sdo().reset(); });
  if (coe_rules_->active()) {
    coe_->sdo().set_hook(coe_rules_.get());
  } else if (deviations != nullptr) {
    coe_->sdo().set_hook(deviations);
  }
  power_on_esc();
  return {};
}

void EthercatDrive::power_on_esc() {
  ecat::EscSlaveConfig config;
  config.esc.sii = sii_;
  config.check_process_data = false;  // check() does it against 1C12h/1C13h
  config.sm_watchdog_drops_op = !has(Deviation::sm_watchdog_ignored);
  config.check = [this](const ecat::AlTransition& t) { return check(t); };
  config.on_state_change = [this](AlState from, AlState to) { on_state_change(from, to); };
  config.on_events = [this](ecat::EscSlave&, const ecat::EscEvents& events) { on_events(events); };
  slave_.reset();  // the old ESC's callbacks go first
  slave_ = std::make_unique<ecat::EscSlave>(std::move(config));
  coe_->reset();
  outputs_ = {};
  inputs_ = {};
  inputs_revision_.reset();
}

void EthercatDrive::power_on() {
  power_on_esc();
  servo_->power_on();
  servo_->device().command(cia301::NmtCommand::stop);  // INIT ~ Stopped (Festo Tab. 4.11)
  arm_watchdog_timer();
}

AlStatusCode EthercatDrive::check(const ecat::AlTransition& t) {
  if (t.requirement != ecat::AlRequirement::process_data) return AlStatusCode::no_error;
  const cia301::ObjectDictionary& od = dictionary();
  auto outputs = read_process_data_layout(od, ProcessDataDirection::outputs);
  if (!outputs || outputs->bytes() > kProcessDataMax) {
    return AlStatusCode::invalid_output_configuration;
  }
  auto inputs = read_process_data_layout(od, ProcessDataDirection::inputs);
  if (!inputs || inputs->bytes() > kProcessDataMax) {
    return AlStatusCode::invalid_input_configuration;
  }
  // SM2/SM3 as the SII places them, buffered, of the direction and the length the assignment
  // gives (001Dh / 001Eh otherwise); an empty direction needs no SyncManager.
  const auto sm_fits = [this](unsigned n, std::uint16_t start, bool outputs_sm,
                              std::size_t length) {
    if (length == 0) return true;
    const ecat::SyncManagerRegisters r = slave_->esc().sync_manager(n);
    return r.enabled() && !r.mailbox() && r.ecat_writes() == outputs_sm && r.start == start &&
           r.length == length;
  };
  if (!sm_fits(2, kOutputsStart, true, outputs->bytes())) {
    return AlStatusCode::invalid_output_configuration;
  }
  if (!sm_fits(3, kInputsStart, false, inputs->bytes())) {
    return AlStatusCode::invalid_input_configuration;
  }
  outputs_ = std::move(*outputs);
  inputs_ = std::move(*inputs);
  inputs_revision_.reset();
  return AlStatusCode::no_error;
}

void EthercatDrive::on_state_change(AlState from, AlState to) {
  ReferenceDrive& device = servo_->device();
  switch (to) {
    case AlState::init:
      coe_->reset();
      device.command(cia301::NmtCommand::stop);
      break;
    case AlState::preop:
    case AlState::safeop:
      if (device.state() != cia301::NmtState::pre_operational) {
        device.command(cia301::NmtCommand::enter_pre_operational);
      }
      break;
    case AlState::op:
      device.command(cia301::NmtCommand::start);
      break;
    case AlState::boot:
      break;
  }
  if (from == AlState::op && to != AlState::op && application_) {
    application_->on_communication_loss(device);  // 6007h (file comment)
  }
  // The saved parameters, after the reaction to leaving OP (which acts with 6007h as it was).
  if (to == AlState::init && from != AlState::init && init_loads_saved_values_) {
    device.load_stored_parameters();
  }
  inputs_revision_.reset();
}

void EthercatDrive::on_events(const ecat::EscEvents& events) {
  ecat::Esc& esc = slave_->esc();
  if ((events.sm_written & kSm0) != 0) {
    if (auto request = esc.pdi_take_mailbox(0)) coe_->on_write_mailbox(*request);
  }
  if ((events.sm_repeat & kSm1) != 0) repeat_read_mailbox();
  if ((events.sm_written & kSm2) != 0 && slave_->al_status().state == AlState::op) {
    const ecat::SyncManagerRegisters sm2 = esc.sync_manager(2);
    scratch_.resize(sm2.length);
    for (std::uint16_t i = 0; i < sm2.length; ++i) {
      scratch_[i] = esc.pdi_read8(static_cast<std::uint16_t>(sm2.start + i));
    }
    cia301::ObjectDictionary& od = dictionary();
    refused_outputs_ += apply_outputs(od, outputs_, scratch_);
    const cia301::Entry* sync_mode = od.find(ecat::kSmOutputParameter, 1);
    if (sync_mode != nullptr && sync_mode->as_unsigned() != 0 && application_) {
      application_->on_sync(servo_->device(), clock_.now());
    }
  }
  feed_read_mailbox();
}

void EthercatDrive::feed_read_mailbox() {
  if (!slave_) return;
  ecat::Esc& esc = slave_->esc();
  if (!esc.sync_manager(1).enabled() || esc.mailbox_full(1)) return;
  if (auto reply = coe_->take_reply()) (void)esc.pdi_put_mailbox(1, *reply);
}

// The master toggled SM1's repeat request (activate 0806h+8 bit 1): its read of the last reply
// was lost. SM1 gets that reply again (unless it is still full: the master never read it), then
// the repeat acknowledge (PDI control 0807h+8 bit 1) takes the request's value (ETG.1000.4
// mailbox repeat; ESC datasheet Section II, SyncManager activate / PDI control).
void EthercatDrive::repeat_read_mailbox() {
  ecat::Esc& esc = slave_->esc();
  const ecat::SyncManagerRegisters sm1 = esc.sync_manager(1);
  if (!sm1.enabled()) return;
  if (!esc.mailbox_full(1)) {
    if (auto last = coe_->repeat_last()) (void)esc.pdi_put_mailbox(1, *last);
  }
  const bool request = (sm1.activate & ecat::sm::kActivateRepeat) != 0;
  const auto pdi_control = static_cast<std::uint16_t>(ecat::reg::sync_manager(1) + 7);
  const std::uint8_t value = esc.pdi_read8(pdi_control);
  (void)esc.pdi_write8(pdi_control,
                       static_cast<std::uint8_t>(request ? (value | ecat::sm::kPdiRepeatAck)
                                                         : (value & ~ecat::sm::kPdiRepeatAck)));
}

void EthercatDrive::on_emcy(const cia301::Emcy& emcy) {
  if (!slave_ || slave_->al_status().state == AlState::init || !coe_->post_emergency(emcy)) {
    ++emergencies_dropped_;
    return;
  }
  feed_read_mailbox();
}

void EthercatDrive::refresh_inputs() {
  const AlState state = slave_->al_status().state;
  if ((state != AlState::safeop && state != AlState::op) || inputs_.bytes() == 0) return;
  ecat::Esc& esc = slave_->esc();
  const ecat::SyncManagerRegisters sm3 = esc.sync_manager(3);
  if (!sm3.enabled()) return;
  const cia301::ObjectDictionary& od = dictionary();
  if (inputs_revision_ == od.revision()) return;
  const std::vector<std::uint8_t> image = collect_inputs(od, inputs_);
  for (std::size_t i = 0; i < image.size() && i < sm3.length; ++i) {
    (void)esc.pdi_write8(static_cast<std::uint16_t>(sm3.start + i), image[i]);
  }
  inputs_revision_ = od.revision();
}

void EthercatDrive::on_frame(std::span<std::uint8_t> frame, ecat::TimePoint arrival,
                             std::optional<ecat::TimePoint> return_arrival) {
  refresh_inputs();
  const bool keep_lrw_counters = has(Deviation::wrong_working_counter);
  if (keep_lrw_counters) {
    lrw_counters_.clear();
    lrw_values_.clear();
    if (auto layout = ecat::parse_frame_layout(frame)) {
      const auto payload = std::span<const std::uint8_t>(frame).subspan(layout->payload_offset,
                                                                        layout->payload_length);
      if (!ecat::walk_datagrams(payload, layout->payload_offset, spans_)) {
        for (const ecat::DatagramSpan& span : spans_) {
          const std::size_t at = layout->payload_offset + span.offset;
          if (frame[at] != static_cast<std::uint8_t>(ecat::Command::lrw)) continue;
          const std::size_t wkc = at + ecat::kDatagramHeaderSize + span.data_length;
          lrw_counters_.push_back(wkc);
          lrw_values_.push_back(static_cast<std::uint16_t>(frame[wkc] | (frame[wkc + 1] << 8)));
        }
      }
    }
  }
  slave_->on_frame(frame, arrival, return_arrival);
  for (std::size_t i = 0; i < lrw_counters_.size() && keep_lrw_counters; ++i) {
    frame[lrw_counters_[i]] = static_cast<std::uint8_t>(lrw_values_[i]);
    frame[lrw_counters_[i] + 1] = static_cast<std::uint8_t>(lrw_values_[i] >> 8);
  }
  after_esc();
}

void EthercatDrive::after_esc() {
  const ecat::AlStatus& status = slave_->al_status();
  if (has(Deviation::al_status_code_missing) && status.error &&
      status.code != AlStatusCode::no_error) {
    slave_->esc().pdi_set_al_status(status.register_value(), 0);
  }
  arm_watchdog_timer();
}

void EthercatDrive::arm_watchdog_timer() {
  const std::optional<ecat::TimePoint> next = slave_->next_deadline();
  if (next == watchdog_at_) return;
  if (watchdog_timer_ != ecat::kNoTimer) clock_.cancel_timer(watchdog_timer_);
  watchdog_timer_ = ecat::kNoTimer;
  watchdog_at_ = next;
  if (!next) return;
  watchdog_timer_ = clock_.start_timer(*next, [this] {
    watchdog_timer_ = ecat::kNoTimer;
    watchdog_at_.reset();
    slave_->advance(clock_.now());
    after_esc();
  });
}

void EthercatDrive::serve(ecat::Link& link) {
  if (served_ != nullptr) served_->set_frame_handler({});
  served_ = &link;
  link.set_frame_handler([this, &link](const ecat::TimedFrame& received) {
    served_frame_ = received.bytes;
    on_frame(served_frame_, received.timestamp, std::nullopt);
    (void)link.send(served_frame_);
  });
}

}  // namespace drivecheck::reference_drive::ethercat
