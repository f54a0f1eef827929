#include "reference_drive/modes/homing.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "protocol/cia402/controlword.hpp"
#include "protocol/cia402/object_ids.hpp"
#include "protocol/cia402/statusword.hpp"
#include "reference_drive/deviations.hpp"

namespace drivecheck::reference_drive {

namespace {

constexpr double kStandstill = 1e-9;  // units/s

bool is_stop_method(HomingSignal signal) {
  return signal == HomingSignal::hard_stop_negative || signal == HomingSignal::hard_stop_positive ||
         signal == HomingSignal::hard_stop_dref;
}

// Kollmorgen: the DREF (352Ch) a 6098h write sets (the NREF/DREF column of
// 002_953174ea6ca45cdb.txt §5.10.4.2 L4526-4562); nullopt: the method leaves DREF as it is.
std::optional<std::uint8_t> kollmorgen_dref_of(std::int8_t method) {
  switch (method) {
    case 1:
    case 12:
    case 17:
    case 28:
    case 33:
    case -7:
      return 0;
    case 2:
    case 8:
    case 18:
    case 24:
    case 34:
    case -6:
      return 1;
    case -1:
      return 2;
    default:
      return std::nullopt;
  }
}

}  // namespace

const HomingMethod* find_homing_method(std::int8_t number, HomingVendor vendor) {
  for (const HomingMethod& row : kHomingMethods) {
    if (row.number != number) continue;
    if (row.vendor == HomingVendor::cia402 || row.vendor == vendor) return &row;
  }
  return nullptr;
}

std::vector<std::int8_t> homing_methods_of(HomingVendor vendor) {
  std::vector<std::int8_t> numbers;
  for (const HomingMethod& row : kHomingMethods) {
    if (row.vendor == HomingVendor::cia402 || row.vendor == vendor) numbers.push_back(row.number);
  }
  return numbers;
}

HomingMode::HomingMode(HomingConfig config) : config_(std::move(config)) {
  if (config_.supported_methods.empty())
    config_.supported_methods = homing_methods_of(config_.vendor);
  params_.method = config_.default_method;
  params_.search_speed = config_.search_speed;
  params_.zero_speed = config_.zero_speed;
  params_.acceleration = config_.acceleration;
  params_.stop_window = config_.stop_window;
  dref_ = config_.kollmorgen_dref;
}

namespace {
// CiA 402-2 (6098h): 15, 16, 31, 32 and 36 are reserved; the deviation still refuses 15.
bool reserved_but_15(std::int8_t method) {
  return method == 16 || method == 31 || method == 32 || method == 36;
}
}  // namespace

Expected<void, cia301::SdoAbort> HomingMode::check_method(std::int8_t method) const {
  // Deviation homing-reserved-methods-accepted: confirmed, never applied (set_method).
  if (config_.deviations.reserved_methods_accepted && reserved_but_15(method)) return {};
  const auto& supported = config_.supported_methods;
  if (std::find(supported.begin(), supported.end(), method) == supported.end() ||
      find_homing_method(method, config_.vendor) == nullptr) {
    return Unexpected(cia301::SdoAbort::invalid_value);
  }
  if (running()) return Unexpected(cia301::SdoAbort::cannot_transfer_device_state);
  return {};
}

Expected<void, cia301::SdoAbort> HomingMode::set_method(std::int8_t method) {
  if (auto ok = check_method(method); !ok) return ok;
  if (find_homing_method(method, config_.vendor) == nullptr) return {};  // the deviation's
  params_.method = method;
  if (config_.vendor == HomingVendor::kollmorgen) {
    if (const auto dref = kollmorgen_dref_of(method)) dref_ = *dref;
  }
  return {};
}

void HomingMode::reset() {
  status_ = HomingStatus::not_started;
  homed_ = false;
  previous_bit4_ = false;
  mode_was_active_ = false;
  home_position_.reset();
  finished_.reset();
  method_ = nullptr;
  dref_ = config_.kollmorgen_dref;
  if (config_.vendor == HomingVendor::kollmorgen) {
    if (const auto dref = kollmorgen_dref_of(params_.method)) dref_ = *dref;
  }
  following_error_ = 0.0;
}

std::uint16_t HomingMode::statusword_bits() const {
  using namespace cia402::statusword;
  const std::uint16_t reached = standstill_ ? kTargetReached : 0;
  switch (status_) {
    case HomingStatus::not_started:
      return kTargetReached;
    case HomingStatus::running:
      return 0;
    case HomingStatus::attained:
      return kHomingAttained | reached;
    case HomingStatus::interrupted:
      return halted_ && config_.deviations.halt_not_reported ? 0 : reached;
    case HomingStatus::error:
      if (config_.deviations.no_error_bit) return reached;
      return kHomingError | reached;
  }
  return 0;
}

void HomingMode::step(can::TimePoint now, const HomingInputs& inputs, HomingAxis& axis) {
  now_ = now;
  standstill_ = std::abs(axis.velocity()) < kStandstill;
  const bool bit4 = (inputs.controlword & cia402::controlword::kHomingOperationStart) != 0;
  const bool halt = (inputs.controlword & cia402::controlword::kHalt) != 0;
  const bool rising = bit4 && !previous_bit4_;
  const bool falling = !bit4 && previous_bit4_;
  previous_bit4_ = bit4;
  const bool may_run =
      !inputs.fault && (inputs.operation_enabled || config_.start_outside_operation_enabled);

  if (inputs.mode_active && !mode_was_active_ && inputs.operation_enabled && !running()) {
    // Entering hm: no set-point of another mode survives.
    axis.command_velocity(0.0, params_.acceleration);
  }
  mode_was_active_ = inputs.mode_active;

  if (running()) {
    if (!inputs.mode_active) {
      status_ = HomingStatus::interrupted;  // another mode owns the axis now
      finished_ = now;
    } else if (!may_run) {
      status_ = HomingStatus::error;  // Festo 11-1: enable withdrawn (the PDS stops the axis)
      finished_ = now;
    } else if (halt) {
      interrupt(config_.deviations.halt_sets_error, axis);
    } else if (falling && !config_.deviations.bit4_falling_ignored) {
      interrupt(false, axis);
      halted_ = false;
    } else if (config_.timeout.count() > 0 && now - started_ > config_.timeout) {
      fail(axis);
    } else {
      run_phase(axis);
    }
  } else if (rising && inputs.mode_active && (!halt || config_.deviations.start_ignores_halt) &&
             may_run) {
    start(now, axis);
  } else if (falling && status_ == HomingStatus::attained &&
             config_.deviations.attained_cleared_on_bit4_low) {
    status_ = HomingStatus::not_started;  // the deviation: "completed" forgotten
  }
  standstill_ = std::abs(axis.velocity()) < kStandstill;
  if (status_ == HomingStatus::attained && standstill_ && !finished_) finished_ = now;
}

void HomingMode::start(can::TimePoint now, HomingAxis& axis) {
  active_ = params_;
  method_ = find_homing_method(active_.method, config_.vendor);
  started_ = now;
  finished_.reset();
  home_position_.reset();
  homed_ = false;
  reversed_ = false;
  halted_ = false;
  status_ = HomingStatus::running;
  if (method_ == nullptr) {
    fail(axis);
    return;
  }
  approach_ = method_->approach;
  edge_ = method_->edge;
  stop_direction_ = method_->first;
  if (method_->signal == HomingSignal::hard_stop_dref) {
    stop_direction_ = dref_ == 1 ? +1 : -1;  // 2 (by distance) has no meaning for a stop
    approach_ = -stop_direction_;            // the zero mark crawling back off the stop
  }
  if (config_.deviations.wrong_edge) {
    if (method_->signal == HomingSignal::home_window) {
      edge_ = edge_ == SwitchEdge::lower ? SwitchEdge::upper : SwitchEdge::lower;
    } else {
      approach_ = -approach_;
    }
  }
  last_position_ = axis.position();
  const double period = axis.index_period();
  if (method_->index && period <= 0.0) {
    fail(axis);  // Festo 11-2: no valid zero pulse
    return;
  }
  switch (method_->signal) {
    case HomingSignal::current_position:
      home_found(axis.position(), axis);
      return;
    case HomingSignal::current_position_tolerant: {
      if (period <= 0.0) {
        fail(axis);
        return;
      }
      const double p = axis.position();
      const double target =
          p + std::round((static_cast<double>(active_.home_offset) - p) / period) * period;
      axis.shift_position(target - p);
      home_position_ = target;
      homed_ = true;
      status_ = HomingStatus::attained;
      phase_ = Phase::stopping;
      return;
    }
    case HomingSignal::nearest_index: {
      const double p = axis.position();
      const auto up = axis.index_pulse_between(p, p + period);
      const auto down = axis.index_pulse_between(p, p - period);
      const bool go_up = up && (!down || *up - p <= p - *down);
      move(Phase::index, go_up ? +1 : -1, true, axis);
      return;
    }
    case HomingSignal::index_pulse:
      move(Phase::index, approach_, true, axis);
      return;
    case HomingSignal::hard_stop_negative:
    case HomingSignal::hard_stop_positive:
    case HomingSignal::hard_stop_dref:
      move(Phase::to_limit, stop_direction_, false, axis);
      return;
    case HomingSignal::home_window:
      if (method_->via_limit) {
        move(Phase::to_limit, method_->first, false, axis);
      } else if (axis.home_switch()) {
        inside_window(axis);
      } else {
        move(Phase::seek_window, method_->first, false, axis);
      }
      return;
    case HomingSignal::limit_negative:
    case HomingSignal::limit_positive:
    case HomingSignal::home_positive:
    case HomingSignal::home_negative:
      if (signal_level(axis) == level_after_edge()) {
        move(Phase::leave, -approach_, false, axis);
      } else {
        move(Phase::approach, approach_, true, axis);
      }
      return;
  }
}

void HomingMode::inside_window(HomingAxis& axis) {
  if (level_after_edge()) {
    move(Phase::leave, -approach_, false, axis);  // out over the edge, then back in
  } else {
    move(Phase::approach, approach_, true, axis);  // out over the edge: the edge
  }
}

bool HomingMode::signal_level(const HomingAxis& axis) const {
  switch (method_->signal) {
    case HomingSignal::limit_negative:
      return axis.limit_negative();
    case HomingSignal::limit_positive:
      return axis.limit_positive();
    default:
      return axis.home_switch();
  }
}

bool HomingMode::level_after_edge() const {
  switch (method_->signal) {
    case HomingSignal::limit_negative:
    case HomingSignal::home_negative:
      return approach_ < 0;  // active on the negative side
    case HomingSignal::limit_positive:
    case HomingSignal::home_positive:
      return approach_ > 0;
    case HomingSignal::home_window:
      return edge_ == SwitchEdge::lower ? approach_ > 0 : approach_ < 0;
    default:
      return false;
  }
}

void HomingMode::move(Phase phase, int direction, bool crawl, HomingAxis& axis) {
  phase_ = phase;
  dir_ = direction;
  const double speed = crawl ? active_.zero_speed : active_.search_speed;
  axis.command_velocity(direction * speed, active_.acceleration);
  // A new velocity profile: its demand starts where the axis is.
  target_velocity_ = direction * speed;
  ramp_velocity_ = axis.velocity();
  demand_position_ = axis.position();
  demand_at_ = now_;
  following_error_ = 0.0;
}

void HomingMode::track_demand(const HomingAxis& axis) {
  // The velocity ramp the mode commanded (609Ah; 0: a step), integrated to a demand position.
  const double dt = std::chrono::duration<double>(now_ - demand_at_).count();
  demand_at_ = now_;
  if (dt > 0.0) {
    const double v0 = ramp_velocity_;
    const double a = static_cast<double>(active_.acceleration);
    if (a <= 0.0) {
      ramp_velocity_ = target_velocity_;
    } else if (ramp_velocity_ < target_velocity_) {
      ramp_velocity_ = std::min(target_velocity_, ramp_velocity_ + a * dt);
    } else {
      ramp_velocity_ = std::max(target_velocity_, ramp_velocity_ - a * dt);
    }
    demand_position_ += (v0 + ramp_velocity_) / 2.0 * dt;
  }
  following_error_ = demand_position_ - axis.position();
}

void HomingMode::run_phase(HomingAxis& axis) {
  const double p = axis.position();
  const double from = last_position_;
  last_position_ = p;
  if (phase_ == Phase::stopping) return;

  const HomingSignal signal = method_->signal;
  const bool neg = axis.limit_negative();
  const bool pos = axis.limit_positive();
  const bool limit_ahead = dir_ > 0 ? pos : neg;
  // Blocked: the following error of the commanded profile beyond the window, in the direction
  // of travel (a mechanical stop; Kollmorgen L4527-4528, Festo 11-5 L7845-7848).
  track_demand(axis);
  const bool stop = dir_ != 0 && following_error_ * dir_ > static_cast<double>(active_.stop_window);
  const bool seeks_limit = phase_ == Phase::to_limit || phase_ == Phase::seek_window;
  if (phase_ == Phase::to_zero) {
    // Travel to zero: blocked (a stop before the zero point) or a limit switch ahead is an
    // error; the home found stays (homed()).
    if (stop || limit_ahead) return fail(axis);
  } else if (is_stop_method(signal)) {
    if (stop && phase_ != Phase::to_limit) return fail(axis);  // limit switches ignored
  } else {
    const bool ahead_is_signal = (signal == HomingSignal::limit_positive && dir_ > 0) ||
                                 (signal == HomingSignal::limit_negative && dir_ < 0);
    if (neg && pos) return fail(axis);  // Festo 11-4: both limit switches at once
    if (!seeks_limit && ((limit_ahead && !ahead_is_signal) || stop)) return fail(axis);
  }

  switch (phase_) {
    case Phase::to_limit:
      if (is_stop_method(signal)) {
        if (!stop) return;
        if (method_->index) return move(Phase::index, approach_, true, axis);
        return home_found(p, axis);
      }
      if (!limit_ahead && !stop) return;
      reversed_ = true;
      return move(Phase::seek_window, -dir_, false, axis);
    case Phase::seek_window:
      if (axis.home_switch()) {
        // Met the home edge at search speed: back out and take it at crawl speed ("to exactly
        // determine the position of the switch edge, the system switches to crawl speed",
        // Festo L6036).
        if (dir_ == approach_ && level_after_edge()) return move(Phase::leave, -dir_, true, axis);
        return inside_window(axis);
      }
      if (!limit_ahead && !stop) return;
      if (reversed_) return fail(axis);  // no home switch between the limits
      reversed_ = true;
      return move(Phase::seek_window, -dir_, false, axis);
    case Phase::leave:
      if (signal_level(axis) != level_after_edge()) move(Phase::approach, approach_, true, axis);
      return;
    case Phase::approach:
      if (signal_level(axis) == level_after_edge()) after_edge(p, axis);
      return;
    case Phase::index:
      if (const auto pulse = axis.index_pulse_between(from, p)) home_found(*pulse, axis);
      return;
    case Phase::to_zero:
      if (zero_reached(axis)) {
        status_ = HomingStatus::attained;
        phase_ = Phase::stopping;
        axis.command_velocity(0.0, active_.acceleration);
      }
      return;
    case Phase::stopping:
      return;
  }
}

void HomingMode::after_edge(double edge_position, HomingAxis& axis) {
  if (!method_->index) return home_found(edge_position, axis);
  move(Phase::index, approach_, true, axis);
  // The pulse search starts at the edge (a pulse between the edge and here counts).
  last_position_ = edge_position;
  const double p = axis.position();
  if ((approach_ > 0 && p > edge_position) || (approach_ < 0 && p < edge_position)) {
    if (const auto pulse = axis.index_pulse_between(edge_position, p))
      home_found(*pulse, axis);
    else
      last_position_ = p;
  }
}

void HomingMode::home_found(double position, HomingAxis& axis) {
  const double offset =
      config_.deviations.offset_ignored ? 0.0 : static_cast<double>(active_.home_offset);
  axis.shift_position(offset - position);
  home_position_ = offset;
  last_position_ = axis.position();
  homed_ = true;
  if (active_.travel_to_zero && axis.position() != 0.0) {
    // Festo 6510h:F0h bit 6 (homing.hpp): on to the zero point at search speed; the run ends
    // when the axis brakes there (to_zero in run_phase).
    move(Phase::to_zero, axis.position() < 0.0 ? +1 : -1, false, axis);
    return;
  }
  status_ = HomingStatus::attained;
  phase_ = Phase::stopping;
  axis.command_velocity(0.0, active_.acceleration);
}

bool HomingMode::zero_reached(const HomingAxis& axis) const {
  // Brake now when the braking distance v²/(2a) plus one cycle's travel (1 ms, the drive
  // cycle) covers what is left to 6064h = 0, or when the axis has passed it.
  const double left = -axis.position() * dir_;
  const double v = axis.velocity() * dir_;
  if (left <= 0.0) return true;
  if (v <= 0.0) return false;  // still turning toward the zero point
  const double a = static_cast<double>(active_.acceleration);
  const double braking = a > 0.0 ? v * v / (2.0 * a) : 0.0;
  return left <= braking + v * 0.001;
}

void HomingMode::fail(HomingAxis& axis) {
  status_ = HomingStatus::error;
  finished_ = now_;
  axis.command_velocity(0.0, active_.acceleration);
}

void HomingMode::interrupt(bool as_error, HomingAxis& axis) {
  status_ = as_error ? HomingStatus::error : HomingStatus::interrupted;
  halted_ = true;
  finished_ = now_;
  axis.command_velocity(0.0, active_.acceleration);
}

// ---------------------------------------------------------------------------------------------

namespace {

std::string name_of(const cia402::ObjectId& id) {
  const auto info = cia402::find_object(id.index, id.sub_index);
  return info ? std::string(info->name) : std::string("object");
}

Expected<void, std::string> add_entry(cia301::ObjectDictionary& od, const cia402::ObjectId& id,
                                      cia301::DataType type, cia301::Value value) {
  if (od.find(id.index, id.sub_index) != nullptr) return {};
  auto added = od.add_var(id.index, name_of(id), type, cia301::AccessType::rw, value, true);
  if (!added) return Unexpected(added.error());
  return {};
}

}  // namespace

Expected<void, std::string> add_homing_objects(cia301::ObjectDictionary& od,
                                               const HomingConfig& config) {
  using cia301::DataType;
  using cia301::Value;
  if (auto r = add_entry(od, cia402::kHomeOffset, DataType::integer32, Value::of_signed(0)); !r) {
    return r;
  }
  if (auto r = add_entry(od, cia402::kHomingMethod, DataType::integer8,
                         Value::of_signed(config.default_method));
      !r) {
    return r;
  }
  if (auto r = add_entry(od, cia402::kHomingAcceleration, DataType::unsigned32,
                         Value::of_unsigned(config.acceleration));
      !r) {
    return r;
  }
  if (od.find(cia402::kHomingSpeedSwitch.index) == nullptr) {
    cia301::ObjectDefinition speeds;
    speeds.index = cia402::kHomingSpeedSwitch.index;
    speeds.name = "homing speeds";
    speeds.code = cia301::ObjectCode::array;
    speeds.entries.push_back(cia301::EntryDefinition::unsigned_entry(
        0, "highest sub-index supported", DataType::unsigned8, cia301::AccessType::constant, 2));
    for (const cia402::ObjectId& id : {cia402::kHomingSpeedSwitch, cia402::kHomingSpeedZero}) {
      cia301::EntryDefinition entry = cia301::EntryDefinition::unsigned_entry(
          id.sub_index, name_of(id), DataType::unsigned32, cia301::AccessType::rw,
          id.sub_index == 1 ? config.search_speed : config.zero_speed);
      entry.pdo_mappable = true;
      speeds.entries.push_back(std::move(entry));
    }
    if (auto added = od.add_object(std::move(speeds)); !added) return Unexpected(added.error());
  }
  return {};
}

HomingObjects::HomingObjects(cia301::ObjectDictionary& od, HomingMode& mode)
    : od_(od), mode_(mode) {
  if (cia301::Entry* entry = od_.find(cia402::kHomingMethod.index, 0)) {
    entry->set_write_validator(
        [&mode](const cia301::ObjectDictionary&, const cia301::Entry&,
                std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
          return mode.check_method(static_cast<std::int8_t>(cia301::load_signed(data)));
        });
    // The method takes effect when written, not at the next cycle: on a Kollmorgen drive a
    // 6098h write sets DREF (352Ch), which stays when the next write names a method without
    // a DREF (e.g. -6 then -3 in one go, before the drive cycles).
    entry->set_write_observer([&mode](cia301::ObjectDictionary&, cia301::Entry& written) {
      if (!mode.running()) (void)mode.set_method(static_cast<std::int8_t>(written.as_signed()));
    });
  }
}

void HomingObjects::read_parameters() {
  if (const auto* e = od_.find(cia402::kHomeOffset.index, 0)) {
    mode_.set_home_offset(static_cast<std::int32_t>(e->as_signed()));
  }
  if (const auto* e = od_.find(cia402::kHomingMethod.index, 0)) {
    if (!mode_.running()) (void)mode_.set_method(static_cast<std::int8_t>(e->as_signed()));
  }
  if (const auto* e =
          od_.find(cia402::kHomingSpeedSwitch.index, cia402::kHomingSpeedSwitch.sub_index)) {
    mode_.set_search_speed(static_cast<std::uint32_t>(e->as_unsigned()));
  }
  if (const auto* e =
          od_.find(cia402::kHomingSpeedZero.index, cia402::kHomingSpeedZero.sub_index)) {
    mode_.set_zero_speed(static_cast<std::uint32_t>(e->as_unsigned()));
  }
  // Deviation homing-acceleration-from-profile-acceleration: 6083h read where 609Ah belongs.
  const cia402::ObjectId acceleration = mode_.config().deviations.acceleration_from_profile
                                            ? cia402::kProfileAcceleration
                                            : cia402::kHomingAcceleration;
  if (const auto* e = od_.find(acceleration.index, acceleration.sub_index)) {
    mode_.set_acceleration(static_cast<std::uint32_t>(e->as_unsigned()));
  }
  if (const auto& bit = mode_.config().travel_to_zero_bit) {
    const auto* e = od_.find(bit->index, bit->sub);
    mode_.set_travel_to_zero(e != nullptr && (e->as_unsigned() & bit->mask) != 0);
  }
  // The stop detection uses the following error window while it is on (not FFFFFFFFh).
  if (const auto* e = od_.find(cia402::kFollowingErrorWindow.index, 0)) {
    const auto window = static_cast<std::uint32_t>(e->as_unsigned());
    mode_.set_stop_window(window != 0xFFFF'FFFFU ? window : mode_.config().stop_window);
  }
}

void HomingObjects::step(can::TimePoint now, const HomingInputs& inputs, HomingAxis& axis) {
  read_parameters();
  mode_.step(now, inputs, axis);
}

// ---------------------------------------------------------------------------------------------

double AxisModelHomingAxis::position() const {
  return factors_.position_to_user(axis_.position());
}

double AxisModelHomingAxis::velocity() const {
  return factors_.velocity_to_user(axis_.velocity());
}

void AxisModelHomingAxis::command_velocity(double velocity, double acceleration) {
  axis_.command_velocity(factors_.velocity_to_internal(velocity),
                         factors_.acceleration_to_internal(acceleration));
}

double AxisModelHomingAxis::internal_period() const {
  const AxisConfig& config = axis_.config();
  return config.index_period != 0 ? config.index_period : config.encoder_increments;
}

double AxisModelHomingAxis::index_period() const {
  const double period = internal_period();
  return period <= 0.0 ? 0.0 : std::abs(factors_.distance_to_user(period));
}

std::optional<double> AxisModelHomingAxis::index_pulse_between(double from, double to) const {
  const double period = internal_period();
  if (period <= 0.0 || from == to) return std::nullopt;
  // Physical frame: physical = actual − offset (axis_model.hpp).
  const double offset = axis_.position() - axis_.physical_position();
  const double a = factors_.position_to_internal(from) - offset;
  const double b = factors_.position_to_internal(to) - offset;
  const double base = static_cast<double>(axis_.config().index_offset);
  double pulse = 0.0;
  if (b > a) {
    pulse = base + (std::floor((a - base) / period) + 1.0) * period;  // first pulse > a
    if (pulse > b) return std::nullopt;
  } else {
    pulse = base + (std::ceil((a - base) / period) - 1.0) * period;  // first pulse < a
    if (pulse < b) return std::nullopt;
  }
  return factors_.position_to_user(pulse + offset);
}

void AxisModelHomingAxis::shift_position(double delta) {
  axis_.set_actual_position(factors_.position_to_internal(position() + delta));
}

Expected<void, std::string> HomingOperationMode::add_objects(cia301::ObjectDictionary& od) {
  if (auto r = add_homing_objects(od, mode_.config()); !r) return r;
  objects_.reset();
  objects_.emplace(od, mode_);
  return {};
}

void HomingOperationMode::apply_deviations(const ModeContext& ctx) {
  // The personality's behaviour (the config) plus the deviations injected by name.
  HomingDeviations deviations = base_deviations_;
  if (ctx.deviations != nullptr) {
    const DeviationSet& set = *ctx.deviations;
    deviations.wrong_edge |= set.has(Deviation::homing_wrong_edge);
    deviations.halt_not_reported |= set.has(Deviation::homing_halt_not_reported);
    deviations.no_error_bit |= set.has(Deviation::homing_error_bit_never_set);
    deviations.offset_ignored |= set.has(Deviation::homing_offset_ignored);
    deviations.reserved_methods_accepted |= set.has(Deviation::homing_reserved_methods_accepted);
    deviations.start_ignores_halt |= set.has(Deviation::homing_start_ignores_halt);
    deviations.attained_cleared_on_bit4_low |=
        set.has(Deviation::homing_attained_cleared_on_bit4_low);
    deviations.bit4_falling_ignored |= set.has(Deviation::homing_bit4_falling_ignored);
    deviations.acceleration_from_profile |=
        set.has(Deviation::homing_acceleration_from_profile_acceleration);
  }
  mode_.set_deviations(deviations);
}

void HomingOperationMode::on_reset(ModeContext& ctx) {
  apply_deviations(ctx);
  mode_.reset();
  if (objects_) objects_->read_parameters();
}

void HomingOperationMode::enter(ModeContext& ctx, const ModeCycle& cycle) {
  (void)cycle;
  apply_deviations(ctx);
}

void HomingOperationMode::leave(ModeContext& ctx, const ModeCycle& cycle) {
  AxisModelHomingAxis axis(ctx.axis, ctx.factors);
  HomingInputs inputs;
  inputs.controlword = cycle.controlword;
  inputs.mode_active = false;
  mode_.step(cycle.now, inputs, axis);
}

void HomingOperationMode::cycle(ModeContext& ctx, const ModeCycle& cycle) {
  AxisModelHomingAxis axis(ctx.axis, ctx.factors);
  HomingInputs inputs;
  inputs.controlword = cycle.controlword;
  inputs.operation_enabled = cycle.state == cia402::State::operation_enabled;
  inputs.fault =
      cycle.state == cia402::State::fault || cycle.state == cia402::State::fault_reaction_active;
  inputs.mode_active = true;
  if (objects_) {
    objects_->step(cycle.now, inputs, axis);
  } else {
    mode_.step(cycle.now, inputs, axis);
  }
  // Not running and not braking: hold where the axis is (and track the actual position while
  // the drive function is off, operation_mode.hpp).
  if (!mode_.running() && (!cycle.drive_enabled || std::abs(ctx.axis.velocity()) < kStandstill)) {
    ctx.axis.command_position(ctx.axis.position());
  }
}

std::uint16_t HomingOperationMode::statusword_bits(cia402::State state) const {
  (void)state;
  return mode_.statusword_bits();
}

}  // namespace drivecheck::reference_drive
