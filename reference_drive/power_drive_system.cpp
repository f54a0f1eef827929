#include "reference_drive/power_drive_system.hpp"

#include <algorithm>
#include <string>

#include "protocol/cia301/data_type.hpp"
#include "protocol/cia402/controlword.hpp"
#include "protocol/cia402/modes.hpp"
#include "protocol/cia402/object_ids.hpp"
#include "protocol/cia402/statusword.hpp"

namespace drivecheck::reference_drive {
namespace {

using cia402::State;
using cia402::Transition;
using cia402::Trigger;

// Controlwords the drive acts on for the 6007h commands (controlword.hpp canonical codings).
constexpr std::uint16_t kDisableVoltageCommand =
    cia402::controlword_of(cia402::Command::disable_voltage);
constexpr std::uint16_t kQuickStopCommand = cia402::controlword_of(cia402::Command::quick_stop);

// The row of a transition that is not commanded (1, 12 automatic, 13, 14), from the table.
const Transition& row_of(std::uint8_t number, Trigger trigger) {
  const auto rows = cia402::transitions_numbered(number);
  for (const Transition& row : rows) {
    if (row.trigger == trigger) return row;
  }
  return rows.front();
}

bool contains(const std::vector<std::uint16_t>& codes, std::uint16_t code) {
  return std::find(codes.begin(), codes.end(), code) != codes.end();
}

// The value a drive starts with: CiA 402's default, or the lowest value the drive accepts.
std::optional<std::int16_t> initial_option_code(const OptionCodeSupport& support, OptionCode code) {
  const std::int16_t standard = info_of(code).default_value;
  if (support.accepts(code, standard)) return standard;
  for (std::int16_t value = 0; value < 16; ++value) {
    if (support.accepts(code, value)) return value;
  }
  for (std::int16_t value = -1; value >= -16; --value) {
    if (support.accepts(code, value)) return value;
  }
  return std::nullopt;
}

// supported-modes-wrong: 6502h also claims vl (bit 1) and ip (bit 6).
constexpr std::uint32_t kSupportedModesWrongBits = 0x00000042;

// States with high voltage applied to the power stage (statusword bit 4).
bool voltage_applied(State state) {
  return state == State::switched_on || state == State::operation_enabled ||
         state == State::quick_stop_active || state == State::fault_reaction_active;
}

}  // namespace

PowerDriveSystem::PowerDriveSystem(Axis& axis, PowerDriveConfig config, FaultReporter* reporter,
                                   const ModeStatus* mode_status)
    : axis_(axis),
      config_(config),
      reporter_(reporter),
      mode_status_(mode_status),
      slow_down_(config.slow_down_deceleration),
      quick_stop_(config.quick_stop_deceleration),
      mode_request_(config.initial_mode),
      mode_display_(config.initial_mode) {
  for (const OptionCodeInfo& info : kOptionCodes) {
    // A support that accepts no value at all keeps CiA 402's default (nothing can be written).
    option_codes_[static_cast<std::size_t>(info.code)] =
        initial_option_code(config_.option_code_support, info.code).value_or(info.default_value);
  }
}

void PowerDriveSystem::power_on(can::TimePoint now) {
  powered_ = true;
  self_test_done_ = now + config_.self_test;
  controlword_ = 0;
  reset_edge_ = false;
  forced_.reset();
  enable_blocked_ = false;
  if (torque_on_) axis_.disable_power();
  torque_on_ = false;
  active_quick_stop_ = 0;
  reaction_complete_ = false;
  pending_.reset();
  halted_ = false;
  causes_.clear();
  reported_.clear();
  fault_event_ = false;
  error_code_ = 0;
  mode_request_ = config_.initial_mode;
  mode_display_ = config_.initial_mode;
  const State from = state_;
  state_ = State::not_ready_to_switch_on;
  last_ = TransitionRecord{0, from, state_, now};
  if (observer_) observer_(*last_);
}

void PowerDriveSystem::step(can::TimePoint now) {
  if (!powered_) return;
  bool moved = false;
  // 13: a fault in any state but the two fault states (CiA 402: "fault occurs").
  if ((fault_event_ || !causes_.empty()) && state_ != State::fault_reaction_active &&
      state_ != State::fault) {
    start_fault_reaction();
    enter(13, row_of(13, Trigger::fault).to, now);
    moved = true;
  }
  fault_event_ = false;
  skip_reaction_ = false;
  if (!moved) moved = try_automatic(now);
  if (!moved) moved = try_enable_loss(now);
  // Deviation fault-reset-on-level: bit 7 high counts as a new edge at every step.
  if (has(Deviation::fault_reset_on_level) &&
      (controlword_ & cia402::controlword::kFaultReset) != 0) {
    reset_edge_ = true;
  }
  if (!moved) try_command(now);
  update_halt();
  if (!has(Deviation::mode_display_not_following)) mode_display_ = mode_request_;
  reset_edge_ = false;

  // Statusword bit 7: a command the controlword gives now waits for the hardware enable.
  enable_blocked_ = false;
  if (config_.hardware_enable != HardwareEnable::not_needed && !enable_ &&
      (config_.remote || forced_)) {
    const auto row = cia402::commanded_transition(
        state_, forced_.value_or(controlword_), cia402::controlword::kFaultReset,
        cia402::quick_stop_stays_active(active_quick_stop_));
    enable_blocked_ = row && enable_gates(row->number);
  }
}

bool PowerDriveSystem::try_automatic(can::TimePoint now) {
  switch (state_) {
    case State::not_ready_to_switch_on:
      // 1: self-test and initialisation complete.
      if (now < self_test_done_) return false;
      enter(1, row_of(1, Trigger::automatic).to, now);
      return true;
    case State::fault_reaction_active:
      // 14: the fault reaction is complete; FAULT has the drive function disabled.
      if (!reaction_complete_ && !axis_.is_stopped()) return false;
      if (torque_on_) axis_.disable_power();
      torque_on_ = false;
      enter(14, row_of(14, Trigger::automatic).to, now);
      return true;
    case State::operation_enabled:
      if (!pending_ || !axis_.is_stopped()) return false;
      complete_pending(now);
      return true;
    case State::quick_stop_active:
      // 12 (automatic): quick stop complete with 605Ah 0..4.
      if (cia402::quick_stop_stays_active(active_quick_stop_)) return false;
      if (!reaction_complete_ && !axis_.is_stopped()) return false;
      if (torque_on_) axis_.disable_power();
      torque_on_ = false;
      enter(12, row_of(12, Trigger::automatic).to, now);
      return true;
    default:
      return false;
  }
}

bool PowerDriveSystem::enable_needed_in(State state) const {
  switch (config_.hardware_enable) {
    case HardwareEnable::not_needed:
      return false;
    case HardwareEnable::for_shutdown:
      return state == State::ready_to_switch_on || state == State::switched_on ||
             state == State::operation_enabled || state == State::quick_stop_active;
    case HardwareEnable::for_switch_on:
      return state == State::switched_on || state == State::operation_enabled ||
             state == State::quick_stop_active;
  }
  return false;
}

bool PowerDriveSystem::enable_gates(std::uint8_t transition_number) const {
  switch (config_.hardware_enable) {
    case HardwareEnable::not_needed:
      return false;
    case HardwareEnable::for_shutdown:
      return transition_number == 2;
    case HardwareEnable::for_switch_on:
      return transition_number == 3;
  }
  return false;
}

bool PowerDriveSystem::try_enable_loss(can::TimePoint now) {
  if (enable_ || !enable_needed_in(state_)) return false;
  // The enable went away: as the disable voltage command (7, 9, 10 or 12).
  const auto row = cia402::commanded_transition(state_, kDisableVoltageCommand);
  if (!row) return false;
  execute(*row, now);
  return true;
}

bool PowerDriveSystem::try_command(can::TimePoint now) {
  if (!forced_ && !config_.remote) return false;
  std::uint16_t controlword = forced_.value_or(controlword_);
  // Without a latched 0→1 edge, bit 7 counts as high before: the fault reset row cannot match.
  std::uint16_t previous = cia402::controlword::kFaultReset;
  // Deviation fault-reset-needs-command-bits-clear: the edge counts only with bits 0..3 clear.
  const bool command_bits_block_reset =
      has(Deviation::fault_reset_needs_command_bits_clear) && (controlword_ & 0x000F) != 0;
  if (!forced_ && reset_edge_ && state_ == State::fault && !command_bits_block_reset) {
    // A rising edge since the last step counts even if bit 7 fell again before this step.
    controlword = static_cast<std::uint16_t>(controlword | cia402::controlword::kFaultReset);
    previous = 0;
  }
  // Deviation fault-reset-in-stop-states: a fault reset edge ends a quick stop or a fault
  // reaction in SWITCH ON DISABLED (recorded as 15, the transition it impersonates).
  if (!forced_ && reset_edge_ && has(Deviation::fault_reset_in_stop_states) &&
      (state_ == State::quick_stop_active || state_ == State::fault_reaction_active)) {
    execute(row_of(15, Trigger::command), now);
    return true;
  }
  // Deviation transition-16-only-with-quick-stop-6: 5, 7 and 8 keep QUICK STOP ACTIVE.
  const bool transition_16_allowed = has(Deviation::transition_16_only_with_quick_stop_6)
                                         ? active_quick_stop_ == 6
                                         : cia402::quick_stop_stays_active(active_quick_stop_);
  auto row = cia402::commanded_transition(
      state_, controlword, previous,
      transition_16_allowed || has(Deviation::transition_16_when_forbidden));
  // Deviation enable-operation-from-switch-on-disabled: 000Fh there runs 2 (then 3, 4).
  if (!row && state_ == State::switch_on_disabled &&
      has(Deviation::enable_operation_from_switch_on_disabled) &&
      (controlword & 0x008F) == 0x000F) {
    row = cia402::commanded_transition(state_, cia402::controlword_of(cia402::Command::shutdown));
  }
  if (!row) return false;  // not a command in this state: ignored, nothing moves
  if (row->number == 11 && has(Deviation::quick_stop_ignored)) return false;
  if (enable_gates(row->number) && !enable_) return false;
  // Edge consumed, FAULT stays (deviation fault-reset-with-cause-present: 15 is taken).
  if (row->number == 15 && !causes_.empty() && !has(Deviation::fault_reset_with_cause_present))
    return false;
  if (pending_ && *pending_ == row->number) return false;  // already on its way
  execute(*row, now);
  return true;
}

void PowerDriveSystem::execute(const Transition& row, can::TimePoint now) {
  pending_.reset();
  halted_ = false;
  const bool halt = (forced_.value_or(controlword_) & cia402::controlword::kHalt) != 0;
  switch (row.number) {
    case 4:
    case 16:
      torque_on_ = true;
      // With halt set the axis stops at once (update_halt), it does not start following first.
      if (!halt || !config_.remote || forced_) axis_.follow_set_points();
      enter(row.number, row.to, now);
      return;
    case 5:
    case 8: {
      const std::int16_t option = row.number == 5 ? option_code(OptionCode::disable_operation)
                                                  : option_code(OptionCode::shutdown);
      // -1 on 605Ch (Festo L5871-5887): braking with the quick stop deceleration 6085h.
      const bool quick_stop_ramp = row.number == 5 && option == -1;
      if ((option == 1 || quick_stop_ramp) && torque_on_) {
        // Slow down ramp, then disable the drive function: the state changes at standstill.
        axis_.ramp_to_stop(quick_stop_ramp ? quick_stop_ : slow_down_);
        pending_ = row.number;
        if (axis_.is_stopped()) complete_pending(now);
        return;
      }
      if (row.number == 5 && config_.power_stage_in_switched_on && torque_on_) {
        // The power stage stays on in SWITCHED ON: stop (quick stop ramp) and hold.
        axis_.ramp_to_stop(quick_stop_);
        enter(row.number, row.to, now);
        return;
      }
      break;  // 0: disable the drive function now
    }
    case 3:
      if (config_.power_stage_in_switched_on) {
        // The power stage on, the drive function off: the axis holds where it is.
        axis_.ramp_to_stop(quick_stop_);
        torque_on_ = true;
        enter(row.number, row.to, now);
        return;
      }
      break;
    case 11:
      start_quick_stop();
      enter(row.number, row.to, now);
      return;
    case 15:
      for (std::uint16_t code : reported_) {
        if (reporter_) reporter_->fault_cleared(code);
      }
      reported_.clear();
      error_code_ = 0;
      break;
    default:
      break;
  }
  if (torque_on_) axis_.disable_power();
  torque_on_ = false;
  enter(row.number, row.to, now);
}

void PowerDriveSystem::complete_pending(can::TimePoint now) {
  const std::uint8_t number = *pending_;
  pending_.reset();
  if (number == 5 && config_.power_stage_in_switched_on && torque_on_) {
    // Stopped on the ramp: the axis holds the position (the stop ends in position control).
  } else {
    if (torque_on_) axis_.disable_power();
    torque_on_ = false;
  }
  for (const Transition& row : cia402::transitions_numbered(number)) {
    if (row.trigger == Trigger::command) {
      enter(number, row.to, now);
      return;
    }
  }
}

void PowerDriveSystem::stop_with(std::int16_t ramp_code) {
  torque_on_ = true;
  switch (ramp_code) {
    case 1:
      axis_.ramp_to_stop(slow_down_);
      break;
    case 2:
      axis_.ramp_to_stop(quick_stop_);
      break;
    case 3:
      axis_.stop_at_current_limit();
      break;
    case 4:
      axis_.stop_at_voltage_limit();
      break;
    default:
      axis_.disable_power();
      torque_on_ = false;
      break;
  }
}

void PowerDriveSystem::start_quick_stop() {
  active_quick_stop_ = option_code(OptionCode::quick_stop);
  reaction_complete_ = false;
  if (active_quick_stop_ <= 0 || !torque_on_) {
    // 0: disable the drive function; transition 12 follows at the next step.
    if (torque_on_) axis_.disable_power();
    torque_on_ = false;
    reaction_complete_ = true;
    return;
  }
  stop_with(cia402::quick_stop_stays_active(active_quick_stop_)
                ? static_cast<std::int16_t>(active_quick_stop_ - 4)
                : active_quick_stop_);
}

void PowerDriveSystem::start_fault_reaction() {
  pending_.reset();
  halted_ = false;
  reaction_complete_ = false;
  const std::int16_t option = option_code(OptionCode::fault_reaction);
  if (!torque_on_ || option <= 0 || skip_reaction_) {
    // The drive function is off already, or 0: disable it (the motor runs free).
    if (torque_on_) axis_.disable_power();
    torque_on_ = false;
    reaction_complete_ = true;
    return;
  }
  stop_with(option);
}

void PowerDriveSystem::update_halt() {
  const bool obeyed = config_.remote && !forced_ && !has(Deviation::halt_ignored);
  const bool requested = obeyed && state_ == State::operation_enabled && !pending_ &&
                         (controlword_ & cia402::controlword::kHalt) != 0;
  if (requested && !halted_) {
    halted_ = true;
    stop_with(option_code(OptionCode::halt));
  } else if (!requested && halted_) {
    halted_ = false;
    if (state_ == State::operation_enabled && !pending_) axis_.follow_set_points();
  }
}

void PowerDriveSystem::enter(std::uint8_t number, State to, can::TimePoint now) {
  last_ = TransitionRecord{number, state_, to, now};
  state_ = to;
  if (observer_) observer_(*last_);
}

void PowerDriveSystem::set_controlword(std::uint16_t controlword) {
  if ((controlword & cia402::controlword::kFaultReset) != 0 &&
      (controlword_ & cia402::controlword::kFaultReset) == 0) {
    reset_edge_ = true;
  }
  controlword_ = controlword;
  forced_.reset();
}

void PowerDriveSystem::set_hardware_enable(bool present) {
  enable_ = present;
}

void PowerDriveSystem::raise_fault(const FaultDefinition& fault) {
  if (!contains(causes_, fault.code)) causes_.push_back(fault.code);
  fault_event_ = true;
  error_code_ = fault.code;
  if (!contains(reported_, fault.code)) {
    reported_.push_back(fault.code);
    if (reporter_) reporter_->fault_raised(fault.code, fault.error_register_bits);
  }
}

void PowerDriveSystem::clear_fault_cause(std::uint16_t code) {
  std::erase(causes_, code);
}

void PowerDriveSystem::on_communication_loss() {
  if (has(Deviation::abort_connection_ignored)) return;
  switch (option_code(OptionCode::abort_connection)) {
    case 1:
      // A fault event: the cause does not persist (a master that can send the fault reset
      // has its connection back).
      raise_fault(faults::kCommunication);
      clear_fault_cause(faults::kCommunication.code);
      skip_reaction_ = has(Deviation::connection_fault_skips_reaction);
      break;
    case 2:
      forced_ = kDisableVoltageCommand;
      break;
    case 3:
      forced_ = kQuickStopCommand;
      break;
    default:  // 0: no action
      break;
  }
}

Expected<void, cia301::SdoAbort> PowerDriveSystem::check_option_code(OptionCode code,
                                                                     std::int16_t value) const {
  if (!config_.option_code_support.accepts(code, value)) {
    return Unexpected(cia301::SdoAbort::invalid_value);
  }
  return {};
}

Expected<void, cia301::SdoAbort> PowerDriveSystem::set_option_code(OptionCode code,
                                                                   std::int16_t value) {
  auto checked = check_option_code(code, value);
  if (checked) option_codes_[static_cast<std::size_t>(code)] = value;
  return checked;
}

Expected<void, cia301::SdoAbort> PowerDriveSystem::check_mode(std::int8_t mode) const {
  if (mode == 0) return {};
  if (mode < 0 && std::find(config_.manufacturer_modes.begin(), config_.manufacturer_modes.end(),
                            mode) != config_.manufacturer_modes.end()) {
    return {};
  }
  const auto known = cia402::mode_from_value(mode);
  if (!known || !cia402::supports(config_.supported_modes, *known)) {
    return Unexpected(cia301::SdoAbort::invalid_value);
  }
  return {};
}

Expected<void, cia301::SdoAbort> PowerDriveSystem::request_mode(std::int8_t mode) {
  auto checked = check_mode(mode);
  if (checked) mode_request_ = mode;
  return checked;
}

bool PowerDriveSystem::warning() const {
  return external_warning_ || enable_blocked_;
}

std::uint16_t PowerDriveSystem::statusword() const {
  namespace sw = cia402::statusword;
  auto word = cia402::statusword_of(state_);
  if (voltage_applied(state_)) word |= sw::kVoltageEnabled;
  if (state_ == State::switched_on && has(Deviation::statusword_bit5_wrong_switched_on)) {
    word = static_cast<decltype(word)>(word & ~sw::kQuickStop);
  }
  // Bit 10 (target reached) in QUICK STOP ACTIVE with 605Ah 5..8 once the stop is finished and
  // the axis stands (CiA 402-2 statusword bit 10; IEC 61800-7-201 "Statusword"): whatever the
  // mode, whose own bits are 0 outside OPERATION ENABLED.
  if (state_ == State::quick_stop_active && cia402::quick_stop_stays_active(active_quick_stop_) &&
      axis_.is_stopped() && !has(Deviation::quick_stop_target_reached_missing)) {
    word |= sw::kTargetReached;
  }
  if (warning()) word |= sw::kWarning;
  if (config_.remote) word |= sw::kRemote;
  word |= manufacturer_bits_;
  if (mode_status_ != nullptr) {
    constexpr std::uint16_t kModeBits = sw::kTargetReached | sw::kInternalLimitActive |
                                        sw::kSetPointAcknowledge | sw::kFollowingError;
    word |= static_cast<std::uint16_t>(mode_status_->statusword_bits(state_, mode_display_) &
                                       kModeBits);
  }
  return static_cast<std::uint16_t>(word);
}

// ---------------------------------------------------------------------------------------------

namespace {

std::string object_name(cia402::ObjectId id) {
  const auto info = cia402::find_object(id.index, id.sub_index);
  return info ? std::string(info->name) : std::string();
}

Expected<void, std::string> add(cia301::ObjectDictionary& od, cia402::ObjectId id,
                                cia301::DataType type, cia301::AccessType access,
                                cia301::Value default_value, bool pdo_mappable) {
  auto added =
      od.add_var(id.index, object_name(id), type, access, std::move(default_value), pdo_mappable);
  if (!added) return Unexpected(std::move(added).error());
  return {};
}

}  // namespace

Expected<void, std::string> add_power_drive_objects(cia301::ObjectDictionary& od,
                                                    const PowerDriveConfig& config,
                                                    const PowerDriveObjectOptions& options) {
  using cia301::AccessType;
  using cia301::DataType;
  using cia301::Value;
  for (const OptionCodeInfo& info : kOptionCodes) {
    const auto initial = initial_option_code(config.option_code_support, info.code);
    if (!initial) {
      return Unexpected(object_name(info.id) + ": the drive accepts no value");
    }
    if (auto r = add(od, info.id, DataType::integer16, AccessType::rw, Value::of_signed(*initial),
                     false);
        !r) {
      return r;
    }
  }
  const auto mode = Value::of_signed(config.initial_mode);
  struct Row {
    cia402::ObjectId id;
    DataType type;
    AccessType access;
    Value value;
    bool pdo;
  };
  std::vector<Row> rows{
      {cia402::kErrorCode, DataType::unsigned16, AccessType::ro, Value::of_unsigned(0), true},
      {cia402::kControlword, DataType::unsigned16, AccessType::rw, Value::of_unsigned(0), true},
      {cia402::kStatusword, DataType::unsigned16, AccessType::ro, Value::of_unsigned(0), true},
      {cia402::kModesOfOperation, DataType::integer8, AccessType::rw, mode, true},
      {cia402::kModesOfOperationDisplay, DataType::integer8, AccessType::ro, mode, true},
      {cia402::kQuickStopDeceleration, DataType::unsigned32, AccessType::rw,
       Value::of_unsigned(config.quick_stop_deceleration), true},
      {cia402::kSupportedDriveModes, DataType::unsigned32, AccessType::ro,
       Value::of_unsigned(config.deviations.has(Deviation::supported_modes_wrong)
                              ? config.supported_modes | kSupportedModesWrongBits
                              : config.supported_modes),
       false},
  };
  if (options.profile_deceleration) {
    rows.push_back({cia402::kProfileDeceleration, DataType::unsigned32, AccessType::rw,
                    Value::of_unsigned(config.slow_down_deceleration), true});
  }
  for (const Row& row : rows) {
    if (auto r = add(od, row.id, row.type, row.access, row.value, row.pdo); !r) return r;
  }
  // A stored controlword would enable the drive at the next power on: never stored.
  od.find(cia402::kControlword.index, 0)->set_store_group(cia301::kStoreNone);
  return {};
}

PowerDriveObjects::PowerDriveObjects(cia301::ObjectDictionary& od, PowerDriveSystem& pds)
    : od_(od), pds_(pds) {
  for (const OptionCodeInfo& info : kOptionCodes) {
    cia301::Entry* entry = od_.find(info.id.index, info.id.sub_index);
    if (entry == nullptr) continue;
    const OptionCode code = info.code;
    entry->set_write_validator(
        [&pds, code](const cia301::ObjectDictionary&, const cia301::Entry&,
                     std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
          // Deviation: stored, never applied (read_inputs keeps the old value in force).
          if (pds.config().deviations.has(Deviation::option_code_invalid_accepted)) return {};
          return pds.check_option_code(code, static_cast<std::int16_t>(cia301::load_signed(data)));
        });
    bound_.push_back(info.id.index);
  }
  if (cia301::Entry* entry = od_.find(cia402::kModesOfOperation.index, 0)) {
    entry->set_write_validator(
        [&pds](const cia301::ObjectDictionary&, const cia301::Entry&,
               std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
          // Deviation: stored, never applied (6061h keeps the mode in force).
          if (pds.config().deviations.has(Deviation::unsupported_mode_accepted)) return {};
          return pds.check_mode(static_cast<std::int8_t>(cia301::load_signed(data)));
        });
    bound_.push_back(cia402::kModesOfOperation.index);
  }
  if (cia301::Entry* entry = od_.find(cia402::kControlword.index, 0)) {
    entry->set_write_observer([&pds](cia301::ObjectDictionary&, cia301::Entry& written) {
      pds.set_controlword(static_cast<std::uint16_t>(written.as_unsigned()));
    });
    bound_.push_back(cia402::kControlword.index);
  }
}

PowerDriveObjects::~PowerDriveObjects() {
  for (std::uint16_t index : bound_) {
    if (cia301::Entry* entry = od_.find(index, 0)) {
      entry->set_write_validator({});
      entry->set_write_observer({});
    }
  }
}

void PowerDriveObjects::read_inputs() {
  for (const OptionCodeInfo& info : kOptionCodes) {
    if (const cia301::Entry* entry = od_.find(info.id.index, info.id.sub_index)) {
      // A value the drive does not accept (only possible without hooks) keeps the old one.
      (void)pds_.set_option_code(info.code, static_cast<std::int16_t>(entry->as_signed()));
    }
  }
  if (const cia301::Entry* entry = od_.find(cia402::kModesOfOperation.index, 0)) {
    (void)pds_.request_mode(static_cast<std::int8_t>(entry->as_signed()));
  }
  if (const cia301::Entry* entry = od_.find(cia402::kProfileDeceleration.index, 0)) {
    pds_.set_slow_down_deceleration(static_cast<std::uint32_t>(entry->as_unsigned()));
  }
  if (const cia301::Entry* entry = od_.find(cia402::kQuickStopDeceleration.index, 0)) {
    pds_.set_quick_stop_deceleration(static_cast<std::uint32_t>(entry->as_unsigned()));
  }
}

void PowerDriveObjects::reload() {
  read_inputs();
  if (const cia301::Entry* entry = od_.find(cia402::kControlword.index, 0)) {
    pds_.set_controlword(static_cast<std::uint16_t>(entry->as_unsigned()));
  }
  publish();
}

void PowerDriveObjects::step(can::TimePoint now) {
  read_inputs();
  pds_.step(now);
  publish();
}

void PowerDriveObjects::publish() {
  if (cia301::Entry* entry = od_.find(cia402::kStatusword.index, 0)) {
    entry->assign_unsigned(pds_.statusword());
  }
  if (cia301::Entry* entry = od_.find(cia402::kModesOfOperationDisplay.index, 0)) {
    entry->assign_unsigned(static_cast<std::uint8_t>(pds_.mode_display()));
  }
  if (cia301::Entry* entry = od_.find(cia402::kErrorCode.index, 0)) {
    entry->assign_unsigned(pds_.error_code());
  }
}

}  // namespace drivecheck::reference_drive
