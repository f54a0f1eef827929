#include "reference_drive/cia402_application.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

#include "protocol/cia402/modes.hpp"
#include "reference_drive/modes/cyclic_sync.hpp"
#include "reference_drive/modes/interpolated_position.hpp"
#include "reference_drive/modes/manual_profile_position.hpp"
#include "reference_drive/modes/manufacturer_mode.hpp"
#include "reference_drive/modes/profile_position.hpp"
#include "reference_drive/modes/profile_torque.hpp"
#include "reference_drive/modes/profile_velocity.hpp"

namespace drivecheck::reference_drive {
namespace {

using cia301::AccessType;
using cia301::DataType;
using cia301::EntryDefinition;
using cia301::ObjectCode;
using cia301::ObjectDefinition;
using cia301::SdoAbort;
using cia301::Value;

constexpr std::uint32_t kFollowingErrorOff = 0xFFFFFFFF;
constexpr std::uint8_t kHomingMode = 6;

// The dictionary's factories under short names (object definitions below read as tables).
constexpr auto* entry = &EntryDefinition::make;
constexpr auto* count = &EntryDefinition::highest_sub_index;

ObjectDefinition pair_object(std::uint16_t index, std::string name, std::string sub1,
                             std::string sub2, DataType type, AccessType access, Value v1, Value v2,
                             bool pdo) {
  return ObjectDefinition{index,
                          std::move(name),
                          ObjectCode::array,
                          {count(2), entry(1, std::move(sub1), type, access, std::move(v1), pdo),
                           entry(2, std::move(sub2), type, access, std::move(v2), pdo)}};
}

using Validator = std::function<Expected<void, SdoAbort>(std::int64_t)>;

void validate(cia301::ObjectDictionary& od, std::uint16_t index, std::uint8_t sub, bool is_signed,
              Validator check) {
  cia301::Entry* e = od.find(index, sub);
  if (e == nullptr) return;
  e->set_write_validator([is_signed, check = std::move(check)](
                             const cia301::ObjectDictionary&, const cia301::Entry&,
                             std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
    const std::int64_t v = is_signed ? cia301::load_signed(data)
                                     : static_cast<std::int64_t>(cia301::load_unsigned(data));
    return check(v);
  });
}

Fraction read_fraction(const cia301::ObjectDictionary& od, std::uint16_t index) {
  const cia301::Entry* n = od.find(index, 1);
  const cia301::Entry* d = od.find(index, 2);
  Fraction f;
  if (n != nullptr && d != nullptr && n->as_unsigned() != 0 && d->as_unsigned() != 0) {
    f.numerator = static_cast<std::uint32_t>(n->as_unsigned());
    f.divisor = static_cast<std::uint32_t>(d->as_unsigned());
  }
  return f;
}

void put(cia301::ObjectDictionary& od, cia402::ObjectId id, std::int64_t value) {
  if (cia301::Entry* e = od.find(id.index, id.sub_index)) {
    e->assign_unsigned(static_cast<std::uint64_t>(value));
  }
}

struct SimulatedFault {
  std::string_view name;
  const FaultDefinition* fault;
};
constexpr SimulatedFault kSimulatedFaults[] = {
    {"following-error", &faults::kFollowingError},
    {"limit-switch", &faults::kLimitSwitch},
    {"overcurrent", &faults::kOverCurrent},
    {"over-voltage", &faults::kDcLinkOverVoltage},
    {"over-temperature", &faults::kMotorOverTemperature},
};

constexpr std::string_view kSimulateNames =
    "hardware-enable, limit-positive, limit-negative, home-switch, limit-positive-at, "
    "limit-negative-at, home-switch-from, home-switch-to, switch-layout-clear, index-period, "
    "index-offset, stop-negative-at, stop-positive-at, axis-position, axis-coast-to-rest, "
    "load-torque, "
    "fault:following-error, fault:limit-switch, "
    "fault:overcurrent, fault:over-voltage, fault:over-temperature";

// The config as the application uses it: manufacturer modes and deviations also in the PDS's
// part (one set of deviations serves the PDS and the modes).
Cia402ApplicationConfig normalised(Cia402ApplicationConfig config) {
  for (Deviation deviation : config.deviations.list())
    config.pds.deviations.add(deviation);
  for (Deviation deviation : config.pds.deviations.list())
    config.deviations.add(deviation);
  for (const ManufacturerModeConfig& m : config.manufacturer_modes) {
    auto& list = config.pds.manufacturer_modes;
    if (m.value < 0 && std::find(list.begin(), list.end(), m.value) == list.end()) {
      list.push_back(m.value);
    }
  }
  return config;
}

// A factor of the dictionary times the drive's internal unit: user units -> axis units. Reduced;
// a product that does not fit 32 bits loses low bits of both parts (the ratio stays).
Fraction in_axis_units(Fraction factor, Fraction unit) {
  if (unit == Fraction{}) return factor;
  std::uint64_t n = std::uint64_t{factor.numerator} * unit.numerator;
  std::uint64_t d = std::uint64_t{factor.divisor} * unit.divisor;
  if (n == 0 || d == 0) return factor;
  const std::uint64_t g = std::gcd(n, d);
  n /= g;
  d /= g;
  while (n > 0xFFFFFFFFU || d > 0xFFFFFFFFU) {
    n = std::max<std::uint64_t>(n >> 1, 1);
    d = std::max<std::uint64_t>(d >> 1, 1);
  }
  return {static_cast<std::uint32_t>(n), static_cast<std::uint32_t>(d)};
}

}  // namespace

FactorGroup read_factor_group(const cia301::ObjectDictionary& od) {
  FactorGroup factors;
  factors.position = read_fraction(od, 0x6093);
  factors.velocity = read_fraction(od, 0x6094);
  factors.acceleration = read_fraction(od, 0x6097);
  if (const cia301::Entry* e = od.find(cia402::kPolarity.index, 0)) {
    factors.polarity = static_cast<std::uint8_t>(e->as_unsigned());
  }
  return factors;
}

// The built-in logic of a standard mode (homing is add_mode()d by its owner; vl has none).
std::unique_ptr<OperationMode> Cia402Application::make_standard_mode(cia402::Mode mode) const {
  switch (mode) {
    case cia402::Mode::profile_position:
      return std::make_unique<ProfilePositionMode>(
          config_.deviations, config_.position_range == PositionRangeSupport::cia402);
    case cia402::Mode::profile_velocity:
      return std::make_unique<ProfileVelocityMode>();
    case cia402::Mode::profile_torque:
      return std::make_unique<ProfileTorqueMode>();
    case cia402::Mode::interpolated_position:
      return std::make_unique<InterpolatedPositionMode>(config_.ip_submode, config_.ip_max_buffer,
                                                        config_.deviations);
    case cia402::Mode::cyclic_sync_position:
      return std::make_unique<CyclicSyncMode>(CyclicKind::position);
    case cia402::Mode::cyclic_sync_velocity:
      return std::make_unique<CyclicSyncMode>(CyclicKind::velocity);
    case cia402::Mode::cyclic_sync_torque:
      return std::make_unique<CyclicSyncMode>(CyclicKind::torque);
    default:
      return nullptr;
  }
}

Cia402Application::Cia402Application(Cia402ApplicationConfig config)
    : config_(normalised(std::move(config))),
      axis_(config_.axis),
      pds_(axis_, config_.pds, this, this) {
  const std::uint32_t supported = config_.pds.supported_modes;
  for (cia402::Mode m : {cia402::Mode::profile_position, cia402::Mode::profile_velocity,
                         cia402::Mode::profile_torque, cia402::Mode::interpolated_position,
                         cia402::Mode::cyclic_sync_position, cia402::Mode::cyclic_sync_velocity,
                         cia402::Mode::cyclic_sync_torque}) {
    if (cia402::supports(supported, m)) modes_.push_back(make_standard_mode(m));
  }
  for (const ManufacturerModeConfig& m : config_.manufacturer_modes) {
    if (m.value >= 0) continue;
    if (m.logic == ManufacturerModeConfig::Logic::irtsa_mpp) {
      modes_.push_back(std::make_unique<ManualProfilePositionMode>(m.value));
      continue;
    }
    const auto standard = cia402::mode_from_value(m.behaves_as);
    if (!standard) continue;
    if (auto logic = make_standard_mode(*standard)) {
      const bool hosted = cia402::supports(supported, *standard);
      modes_.push_back(std::make_unique<ManufacturerMode>(m.value, std::move(logic), !hosted));
    }
  }
}

Cia402Application::~Cia402Application() = default;

void Cia402Application::add_mode(std::unique_ptr<OperationMode> mode) {
  if (!mode) return;
  const auto value = cia402::mode_from_value(mode->mode());
  const auto& manufacturer = config_.manufacturer_modes;
  const bool listed = std::any_of(manufacturer.begin(), manufacturer.end(),
                                  [&](const auto& m) { return m.value == mode->mode(); });
  if (!listed && (!value || !cia402::supports(config_.pds.supported_modes, *value))) return;
  for (auto& hosted : modes_) {
    if (hosted->mode() == mode->mode()) {
      hosted = std::move(mode);  // replaces the built-in one
      return;
    }
  }
  modes_.push_back(std::move(mode));
}

OperationMode* Cia402Application::mode(std::int8_t value) {
  for (auto& m : modes_) {
    if (m->mode() == value) return m.get();
  }
  return nullptr;
}

// ---------------------------------------------------------------------------------------------
// Objects

Expected<void, std::string> Cia402Application::add_objects(cia301::ObjectDictionary& od) {
  PowerDriveObjectOptions options;
  options.profile_deceleration = true;
  if (config_.mode_object_width == ModeObjectWidth::bits16) {
    // ESR: 6060h/6061h as INTEGER16 (004_956552dcd17e975a.txt L1085, L1142, L1158).
    cia301::ObjectDictionary scratch(od.node_id());
    if (auto r = add_power_drive_objects(scratch, config_.pds, options); !r) return r;
    for (const cia301::Object& object : scratch.objects()) {
      ObjectDefinition def = object.definition();
      if (def.index == cia402::kModesOfOperation.index ||
          def.index == cia402::kModesOfOperationDisplay.index) {
        def.entries[0].type = DataType::integer16;
      }
      if (auto r = od.add_object(std::move(def)); !r) return Unexpected(r.error());
      const cia301::Entry* from = object.find(0);
      if (cia301::Entry* to = od.find(object.index(), 0); from != nullptr && to != nullptr) {
        to->set_store_group(from->store_group());
      }
    }
  } else if (auto r = add_power_drive_objects(od, config_.pds, options); !r) {
    return r;
  }
  if (auto r = add_shared_objects(od); !r) return r;
  for (auto& m : modes_) {
    if (auto r = m->add_objects(od); !r) return r;
  }
  bind(od);
  return {};
}

Expected<void, std::string> Cia402Application::add_shared_objects(cia301::ObjectDictionary& od) {
  struct Var {
    cia402::ObjectId id;
    DataType type;
    AccessType access;
    Value value;
    bool pdo;
  };
  const auto u = [](std::uint64_t v) { return Value::of_unsigned(v); };
  const auto s = [](std::int64_t v) { return Value::of_signed(v); };
  const AxisConfig& a = config_.axis;
  const std::vector<Var> vars{
      {cia402::kPositionDemandValue, DataType::integer32, AccessType::ro, s(0), true},
      {cia402::kPositionActualInternalValue, DataType::integer32, AccessType::ro, s(0), true},
      {cia402::kPositionActualValue, DataType::integer32, AccessType::ro, s(0), true},
      {cia402::kFollowingErrorWindow, DataType::unsigned32, AccessType::rw, u(10000), true},
      {cia402::kFollowingErrorTimeOut, DataType::unsigned16, AccessType::rw, u(10), true},
      {cia402::kPositionWindow, DataType::unsigned32, AccessType::rw, u(100), true},
      {cia402::kPositionWindowTime, DataType::unsigned16, AccessType::rw, u(0), true},
      {cia402::kVelocityDemandValue, DataType::integer32, AccessType::ro, s(0), true},
      {cia402::kVelocityActualValue, DataType::integer32, AccessType::ro, s(0), true},
      {cia402::kVelocityWindow, DataType::unsigned16, AccessType::rw, u(20), true},
      {cia402::kVelocityWindowTime, DataType::unsigned16, AccessType::rw, u(0), true},
      {cia402::kVelocityThreshold, DataType::unsigned16, AccessType::rw, u(10), true},
      {cia402::kVelocityThresholdTime, DataType::unsigned16, AccessType::rw, u(0), true},
      {cia402::kTargetTorque, DataType::integer16, AccessType::rw, s(0), true},
      {cia402::kMaxTorque, DataType::unsigned16, AccessType::rw, u(a.torque_limit), true},
      {cia402::kTorqueDemand, DataType::integer16, AccessType::ro, s(0), true},
      {cia402::kTorqueActualValue, DataType::integer16, AccessType::ro, s(0), true},
      {cia402::kTargetPosition, DataType::integer32, AccessType::rw, s(0), true},
      {cia402::kPolarity, DataType::unsigned8, AccessType::rw, u(0), true},
      {cia402::kMaxProfileVelocity, DataType::unsigned32, AccessType::rw,
       u(static_cast<std::uint64_t>(a.max_speed)), true},
      config_.max_motor_speed_rpm
          ? Var{cia402::kMaxMotorSpeed, DataType::unsigned16, AccessType::rw, u(32768), true}
          : Var{cia402::kMaxMotorSpeed, DataType::unsigned32, AccessType::rw,
                u(static_cast<std::uint64_t>(a.max_speed)), true},
      {cia402::kProfileVelocity, DataType::unsigned32, AccessType::rw, u(10000), true},
      {cia402::kEndVelocity, DataType::unsigned32, AccessType::rw, u(0), true},
      {cia402::kProfileAcceleration, DataType::unsigned32, AccessType::rw, u(100000), true},
      {cia402::kMotionProfileType, DataType::integer16, AccessType::rw, s(0), true},
      {cia402::kTorqueSlope, DataType::unsigned32, AccessType::rw, u(10000), true},
      {cia402::kTorqueProfileType, DataType::integer16, AccessType::rw, s(0), true},
      {cia402::kPositionOffset, DataType::integer32, AccessType::rw, s(0), true},
      {cia402::kVelocityOffset, DataType::integer32, AccessType::rw, s(0), true},
      {cia402::kTorqueOffset, DataType::integer16, AccessType::rw, s(0), true},
      {cia402::kFollowingErrorActualValue, DataType::integer32, AccessType::ro, s(0), true},
      {cia402::kPositionDemandInternalValue, DataType::integer32, AccessType::ro, s(0), true},
      {cia402::kDigitalInputs, DataType::unsigned32, AccessType::ro, u(0), true},
      {cia402::kTargetVelocity, DataType::integer32, AccessType::rw, s(0), true},
  };
  for (const Var& v : vars) {
    const auto info = cia402::find_object(v.id.index, v.id.sub_index);
    auto added = od.add_var(v.id.index, info ? std::string(info->name) : std::string(), v.type,
                            v.access, v.value, v.pdo);
    if (!added) return Unexpected(added.error());
  }
  const auto i32 = std::numeric_limits<std::int32_t>::min();
  const auto i32max = std::numeric_limits<std::int32_t>::max();
  std::vector<ObjectDefinition> objects{
      pair_object(0x607D, "software position limit", "min position limit", "max position limit",
                  DataType::integer32, AccessType::rw, s(i32), s(i32max), true),
      pair_object(0x608F, "position encoder resolution", "encoder increments", "motor revolutions",
                  DataType::unsigned32, AccessType::ro, u(a.encoder_increments), u(1), false),
      pair_object(0x6091, "gear ratio", "motor revolutions", "shaft revolutions",
                  DataType::unsigned32, AccessType::rw, u(1), u(1), true),
      pair_object(0x6092, "feed constant", "feed", "shaft revolutions", DataType::unsigned32,
                  AccessType::rw, u(1), u(1), true),
      pair_object(0x6093, "position factor", "numerator", "divisor", DataType::unsigned32,
                  AccessType::rw, u(1), u(1), true),
      pair_object(0x6094, "velocity encoder factor", "numerator", "divisor", DataType::unsigned32,
                  AccessType::rw, u(1), u(1), true),
      pair_object(0x6097, "acceleration factor", "numerator", "divisor", DataType::unsigned32,
                  AccessType::rw, u(1), u(1), true),
      ObjectDefinition{
          0x60C2,
          "interpolation time period",
          ObjectCode::record,
          {count(2),
           entry(1, "interpolation time period value", DataType::unsigned8, AccessType::rw, u(1),
                 true),
           entry(2, "interpolation time index", DataType::integer8, AccessType::rw, s(-3), true)}},
  };
  if (config_.position_range != PositionRangeSupport::none) {
    // 607Bh (CiA 402-2, optional): the whole INTEGER32 range by default (IRTSA 003 §5
    // L732-734), a linear axis until a master sets a narrower range.
    ObjectDefinition range = pair_object(0x607B, "position range limit", "min position range limit",
                                         "max position range limit", DataType::integer32,
                                         AccessType::rw, s(i32), s(i32max), true);
    // Deviation pp-position-range-sub0-wrong: sub 00h reads 1.
    if (config_.deviations.has(Deviation::pp_position_range_sub0_wrong))
      range.entries[0] = count(1);
    objects.push_back(std::move(range));
  }
  for (ObjectDefinition& def : objects) {
    if (auto r = od.add_object(std::move(def)); !r) return Unexpected(r.error());
  }
  return {};
}

void Cia402Application::bind(cia301::ObjectDictionary& od) {
  od_ = &od;
  context_ = std::make_unique<ModeContext>(ModeContext{od, axis_, factors_, pds_});
  context_->deviations = &config_.deviations;
  context_->acknowledge_latency_cycles =
      std::max<std::uint32_t>(1, config_.acknowledge_latency_cycles);
  context_->setpoint_buffer = std::max<std::uint32_t>(1, config_.setpoint_buffer);
  context_->jerk_smoothing_cycles = config_.jerk_smoothing_cycles;
  context_->change_on_set_point = config_.pp_change_on_set_point;
  binding_ = std::make_unique<PowerDriveObjects>(od, pds_);

  const auto refuse = [](bool bad) -> Expected<void, SdoAbort> {
    if (bad) return Unexpected(SdoAbort::invalid_value);
    return {};
  };
  validate(od, cia402::kPolarity.index, 0, false,
           [refuse](std::int64_t v) { return refuse((v & ~std::int64_t{0xC0}) != 0); });
  validate(od, cia402::kMotionProfileType.index, 0, true,
           [refuse](std::int64_t v) { return refuse(v < 0 || v > 3); });
  validate(od, cia402::kTorqueProfileType.index, 0, true,
           [refuse](std::int64_t v) { return refuse(v != 0 && v != 1); });
  for (std::uint16_t index : {std::uint16_t{0x6091}, std::uint16_t{0x6092}, std::uint16_t{0x6093},
                              std::uint16_t{0x6094}, std::uint16_t{0x6097}}) {
    for (std::uint8_t sub : {std::uint8_t{1}, std::uint8_t{2}}) {
      validate(od, index, sub, false, [refuse](std::int64_t v) { return refuse(v == 0); });
    }
  }
  validate(od, 0x60C2, 2, true, [refuse](std::int64_t v) { return refuse(v < -6 || v > 0); });
  // Gear ratio or feed constant written: 6093h := 608Fh × gear ratio / feed constant.
  auto recompute = [this](cia301::ObjectDictionary& dict, cia301::Entry&) {
    const auto get = [&dict](std::uint16_t index, std::uint8_t sub) -> std::uint64_t {
      const cia301::Entry* e = dict.find(index, sub);
      return e != nullptr ? e->as_unsigned() : 1;
    };
    const std::uint64_t num = get(0x608F, 1) * get(0x6091, 1) * get(0x6092, 2);
    const std::uint64_t div = get(0x608F, 2) * get(0x6091, 2) * get(0x6092, 1);
    Fraction f;
    if (reduce_fraction(num, div, f)) {
      put(dict, {0x6093, 1}, f.numerator);
      put(dict, {0x6093, 2}, f.divisor);
    }
    (void)this;
  };
  for (std::uint16_t index : {std::uint16_t{0x6091}, std::uint16_t{0x6092}}) {
    for (std::uint8_t sub : {std::uint8_t{1}, std::uint8_t{2}}) {
      if (cia301::Entry* e = od.find(index, sub)) e->set_write_observer(recompute);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Device events

void Cia402Application::on_reset(ReferenceDrive& drive, cia301::ResetKind kind) {
  drive_ = &drive;
  if (!binding_) return;
  if (kind == cia301::ResetKind::application) {
    // 6040h is never stored (power_drive_system.hpp): after power on / reset node it is 0 again,
    // so that the last controlword before the reset cannot act on the new start.
    put(*od_, cia402::kControlword, 0);
    pds_.power_on(drive.bus().now());
    binding_->reload();
    read_parameters();
    for (auto& m : modes_)
      m->on_reset(*context_);
    active_ = nullptr;
    active_value_ = 0;
    last_cycle_.reset();
    following_error_since_.reset();
    context_->following_error = false;
  } else {
    binding_->reload();
  }
  publish();
}

void Cia402Application::on_drive_destroyed(ReferenceDrive& drive) {
  (void)drive;
  binding_.reset();
  context_.reset();
  od_ = nullptr;
  drive_ = nullptr;
  active_ = nullptr;
}

void Cia402Application::on_communication_loss(ReferenceDrive& drive) {
  drive_ = &drive;
  pds_.on_communication_loss();
}

void Cia402Application::on_connection_event(ReferenceDrive& drive) {
  drive_ = &drive;
  if (pds_.state() == cia402::State::operation_enabled) pds_.on_communication_loss();
}

void Cia402Application::on_sync(ReferenceDrive& drive, can::TimePoint at) {
  drive_ = &drive;
  if (active_ != nullptr && context_) active_->on_sync(*context_, at);
}

void Cia402Application::on_cycle(ReferenceDrive& drive, can::TimePoint now) {
  drive_ = &drive;
  if (!binding_) return;
  ++cycles_;
  const can::Duration dt = last_cycle_ ? now - *last_cycle_ : drive.config().control_cycle;
  last_cycle_ = now;

  read_parameters();
  axis_.advance(dt);
  check_limits(now, dt);
  binding_->step(now);

  ModeCycle cycle;
  cycle.now = now;
  cycle.period = dt;
  cycle.controlword = pds_.forced_controlword().value_or(pds_.controlword());
  cycle.state = pds_.state();
  const bool enabled = cycle.state == cia402::State::operation_enabled;
  cycle.drive_enabled = enabled && axis_.following();
  cycle.halt = enabled && pds_.halted();

  const std::int8_t display = pds_.mode_display();
  OperationMode* next = mode(display);
  // Deviation mode-display-ahead-of-mode: 6061h already shows the new mode, but the old one
  // runs on while the axis moves.
  const bool held = config_.deviations.has(Deviation::mode_display_ahead_of_mode) &&
                    active_ != nullptr && cycle.drive_enabled && !axis_.is_stopped();
  if ((next != active_ || display != active_value_) && !held) {
    if (active_ != nullptr) active_->leave(*context_, cycle);
    active_ = next;
    active_value_ = display;
    if (active_ != nullptr) active_->enter(*context_, cycle);
  }
  context_->position_limited = false;
  context_->torque_demand.reset();
  if (active_ != nullptr) {
    active_->cycle(*context_, cycle);
  } else if (!cycle.drive_enabled) {
    axis_.command_position(axis_.position());
  }
  if (context_->release_controlword_bits != 0) {
    // The drive resets controlword bits itself (pp 60F2h request-response option, bit 4): in
    // 6040h as a read shows it and in the PDS, as if the master had written it.
    const auto controlword =
        static_cast<std::uint16_t>(pds_.controlword() & ~context_->release_controlword_bits);
    if (cia301::Entry* entry =
            od_->find(cia402::kControlword.index, cia402::kControlword.sub_index))
      entry->assign_unsigned(controlword);
    pds_.set_controlword(controlword);
    context_->release_controlword_bits = 0;
  }
  limit_active_ = limit_active_ || context_->position_limited;
  publish();
}

// ---------------------------------------------------------------------------------------------
// One cycle's parts

void Cia402Application::read_parameters() {
  const cia301::ObjectDictionary& od = *od_;
  factors_ = read_factor_group(od);
  // Deviation factor-acceleration-from-velocity-factor: 6094h read where 6097h belongs.
  if (config_.deviations.has(Deviation::factor_acceleration_from_velocity_factor)) {
    factors_.acceleration = factors_.velocity;
  }
  // Deviation factor-velocity-inverted: 6094h applied as divisor / numerator.
  if (config_.deviations.has(Deviation::factor_velocity_inverted))
    std::swap(factors_.velocity.numerator, factors_.velocity.divisor);
  factors_.velocity = in_axis_units(factors_.velocity, config_.internal_velocity_unit);
  factors_.acceleration = in_axis_units(factors_.acceleration, config_.internal_acceleration_unit);
  if (config_.deviations.has(Deviation::factor_polarity_ignored)) factors_.polarity = 0;
  if (config_.deviations.has(Deviation::factor_position_polarity_set_points_only))
    factors_.position_polarity_when_read = false;
  axis_.set_acceleration_factor(factors_.acceleration_to_internal(1.0));
  axis_.set_torque_limit(static_cast<double>(context_->read_unsigned(cia402::kMaxTorque)));
  const double max_motor_speed =
      static_cast<double>(context_->read_unsigned(cia402::kMaxMotorSpeed));
  if (config_.max_motor_speed_rpm) {
    // min^-1 -> increments/s; the simulated motor's own limit stays the ceiling.
    const double speed =
        max_motor_speed * static_cast<double>(config_.axis.encoder_increments) / 60.0;
    axis_.set_max_speed(speed > 0.0 ? std::min(speed, config_.axis.max_speed)
                                    : config_.axis.max_speed);
  } else {
    const double max_speed = factors_.speed_to_internal(max_motor_speed);
    axis_.set_max_speed(max_speed > 0.0 ? max_speed : config_.axis.max_speed);
  }
  const double lo = static_cast<double>(context_->read_signed(cia402::kSoftwarePositionLimitMin));
  const double hi = static_cast<double>(context_->read_signed(cia402::kSoftwarePositionLimitMax));
  if (lo < hi) {
    const double a = factors_.position_to_internal(lo);
    const double b = factors_.position_to_internal(hi);
    context_->min_position = std::min(a, b);
    context_->max_position = std::max(a, b);
  } else {
    context_->min_position = 1.0;
    context_->max_position = 0.0;
  }
  read_position_range();
}

void Cia402Application::read_position_range() {
  context_->position_range = {};
  context_->rotary_direction.reset();
  // Deviation pp-position-range-no-wrap: 607Bh is stored and never used.
  if (config_.position_range == PositionRangeSupport::none ||
      config_.deviations.has(Deviation::pp_position_range_no_wrap))
    return;
  const cia301::Entry* lo = od_->find(cia402::kPositionRangeLimitMin.index, 1);
  const cia301::Entry* hi = od_->find(cia402::kPositionRangeLimitMax.index, 2);
  if (lo == nullptr || hi == nullptr) return;
  const PositionRange range = PositionRange::from_limits(lo->as_signed(), hi->as_signed());
  if (config_.position_range == PositionRangeSupport::festo) {
    // 6510h sub 20h position_range_limit_enable (000 §5.7 L3855-3867).
    const cia301::Entry* enable = od_->find(0x6510, 0x20);
    switch (enable != nullptr ? enable->as_unsigned() : 0) {
      case 1:
      case 2:
        context_->rotary_direction = RotaryDirection::shortest;
        break;
      case 4:
        context_->rotary_direction = RotaryDirection::positive;
        break;
      case 5:
        context_->rotary_direction = RotaryDirection::negative;
        break;
      default:
        return;  // 0 off, 3 reserved
    }
  }
  context_->position_range = range;
}

void Cia402Application::check_limits(can::TimePoint now, can::Duration dt) {
  (void)dt;
  const bool negative = axis_.switch_active(AxisSwitch::negative_limit);
  const bool positive = axis_.switch_active(AxisSwitch::positive_limit);
  const bool home = axis_.switch_active(AxisSwitch::home);
  // Deviation digital-inputs-limit-bits-swapped: positive in bit 0, negative in bit 1.
  const bool swapped = config_.deviations.has(Deviation::digital_inputs_limit_bits_swapped);
  // Deviation digital-inputs-home-switch-in-bit-3: the home switch in bit 3 (interlock).
  const std::uint32_t home_bit =
      config_.deviations.has(Deviation::digital_inputs_home_switch_in_bit_3) ? 0x8u : 0x4u;
  inputs_ = ((swapped ? positive : negative) ? 0x1u : 0u) |
            ((swapped ? negative : positive) ? 0x2u : 0u) | (home ? home_bit : 0u);
  limit_active_ = negative || positive;

  const bool enabled = pds_.state() == cia402::State::operation_enabled;
  const bool homing = pds_.mode_display() == kHomingMode;
  if (enabled && !homing && axis_.following()) {
    const double v = axis_.velocity();
    if ((positive && v > 0.0) || (negative && v < 0.0)) {
      // An event, not a lasting cause: the axis may be moved off the switch after the reset.
      pds_.raise_fault(faults::kLimitSwitch);
      pds_.clear_fault_cause(faults::kLimitSwitch.code);
    }
  }

  // Following error: |60F4h| > 6065h for longer than 6066h.
  const auto window =
      static_cast<std::uint32_t>(context_->read_unsigned(cia402::kFollowingErrorWindow));
  const bool monitored =
      axis_.control() == AxisControl::position && axis_.following() && window != kFollowingErrorOff;
  // Deviation following-error-one-direction: the signed error, so a lag one way never counts.
  const double error = config_.deviations.has(Deviation::following_error_one_direction)
                           ? axis_.following_error()
                           : std::abs(axis_.following_error());
  // Deviation following-error-window-in-increments: 6065h taken as increments.
  const double limit = config_.deviations.has(Deviation::following_error_window_in_increments)
                           ? static_cast<double>(window)
                           : factors_.distance_to_internal(static_cast<double>(window));
  if (monitored && error > limit) {
    if (!following_error_since_) following_error_since_ = now;
    const auto timeout =
        std::chrono::milliseconds(context_->read_unsigned(cia402::kFollowingErrorTimeOut));
    if (now - *following_error_since_ >= timeout && !context_->following_error) {
      context_->following_error = true;
      pds_.raise_fault(faults::kFollowingError);
      pds_.clear_fault_cause(faults::kFollowingError.code);
    }
  } else if (!monitored || error <= limit) {
    // Deviation following-error-timer-not-restarted: back inside the window the timer runs on.
    if (!monitored || !config_.deviations.has(Deviation::following_error_timer_not_restarted)) {
      following_error_since_.reset();
    }
    if (monitored || !axis_.following()) context_->following_error = false;
  }
}

void Cia402Application::publish() {
  if (od_ == nullptr) return;
  cia301::ObjectDictionary& od = *od_;
  const FactorGroup& f = factors_;
  const bool position_control = axis_.control() == AxisControl::position && axis_.following();
  const double demand = position_control ? axis_.demand_position() : axis_.position();
  // On a rotary axis (607Bh in effect) 6062h and 6064h show the value wrapped into the range;
  // 6063h, 60FCh and 60F4h keep counting (the internal frame does not wrap).
  const PositionRange range = context_ ? context_->position_range : PositionRange{};
  const auto shown = [&range](double user) {
    return FactorGroup::to_i32(range.active() ? range.wrap(std::round(user)) : user);
  };
  put(od, cia402::kPositionDemandValue, shown(f.position_to_user(demand)));
  put(od, cia402::kPositionDemandInternalValue, FactorGroup::to_i32(demand));
  // Deviation factor-internal-position-in-user-units: 6063h shows 6064h's user units.
  put(od, cia402::kPositionActualInternalValue,
      config_.deviations.has(Deviation::factor_internal_position_in_user_units)
          ? std::int64_t{FactorGroup::to_i32(f.position_to_user(axis_.position()))}
          : std::int64_t{axis_.actual_position()});
  put(od, cia402::kPositionActualValue, shown(f.position_to_user(axis_.position())));
  put(od, cia402::kVelocityDemandValue,
      FactorGroup::to_i32(f.velocity_to_user(axis_.following() ? axis_.demand_velocity() : 0.0)));
  double velocity_actual = f.velocity_to_user(axis_.velocity());
  // Deviation factor-velocity-actual-unscaled: 606Ch not converted back through 6094h.
  if (config_.deviations.has(Deviation::factor_velocity_actual_unscaled)) {
    const Fraction velocity_factor = read_factor_group(od).velocity;
    velocity_actual *= static_cast<double>(velocity_factor.numerator) /
                       static_cast<double>(velocity_factor.divisor);
  }
  put(od, cia402::kVelocityActualValue, FactorGroup::to_i32(velocity_actual));
  const auto torque =
      static_cast<std::int64_t>(std::lround(std::clamp(axis_.torque(), -32768.0, 32767.0)));
  put(od, cia402::kTorqueDemand,
      context_ && context_->torque_demand ? static_cast<std::int64_t>(std::lround(std::clamp(
                                                *context_->torque_demand, -32768.0, 32767.0)))
                                          : torque);
  put(od, cia402::kTorqueActualValue, torque);
  put(od, cia402::kFollowingErrorActualValue,
      FactorGroup::to_i32(position_control ? f.position_to_user(axis_.demand_position()) -
                                                 f.position_to_user(axis_.position())
                                           : 0.0));
  put(od, cia402::kDigitalInputs, inputs_);
  if (binding_) binding_->publish();
  if (config_.mode_object_width == ModeObjectWidth::bits16) {
    put(od, cia402::kModesOfOperationDisplay, pds_.mode_display());
  }
  if (config_.error_code_format != ErrorCodeFormat::standard) {
    put(od, cia402::kErrorCode, error_code_shown());
  }
}

std::uint16_t Cia402Application::error_code_shown() const {
  const std::uint16_t code = pds_.error_code();
  if (code == 0 || config_.error_code_format == ErrorCodeFormat::standard) return code;
  std::uint8_t number = static_cast<std::uint8_t>(code >> 8);
  for (const auto& [emcy, n] : config_.error_numbers) {
    if (emcy == code) number = n;
  }
  return static_cast<std::uint16_t>((number << 8) | 0x80);
}

// ---------------------------------------------------------------------------------------------
// FaultReporter, ModeStatus

void Cia402Application::fault_raised(std::uint16_t code, std::uint8_t error_register_bits) {
  if (drive_ != nullptr) drive_->raise_error(code, error_register_bits);
}

void Cia402Application::fault_cleared(std::uint16_t code) {
  if (drive_ != nullptr) drive_->clear_error(code);
}

std::uint16_t Cia402Application::statusword_bits(cia402::State state,
                                                 std::int8_t mode_display) const {
  std::uint16_t bits = limit_active_ ? 0x0800 : 0;
  for (const auto& m : modes_) {
    if (m->mode() == mode_display) bits |= m->statusword_bits(state);
  }
  return bits;
}

// ---------------------------------------------------------------------------------------------
// Simulation

Expected<void, std::string> Cia402Application::simulate(std::string_view name, std::int64_t value) {
  const auto bad_value = [&](std::string_view allowed) {
    return Unexpected("simulate " + std::string(name) + ": value " + std::to_string(value) +
                      " out of range (" + std::string(allowed) + ")");
  };
  // The factor group as the dictionary holds it now: a simulate step may come right after an
  // SDO write of 6093h, before the next control cycle reads it (factors_), and the conversion
  // must not depend on that phase.
  const FactorGroup factors = od_ != nullptr ? read_factor_group(*od_) : factors_;
  const auto position = [&factors](std::int64_t user) {
    // User position units of the physical frame (no polarity: the layout is physical).
    return factors.distance_to_internal(static_cast<double>(user));
  };
  const auto force = [&](AxisSwitch which) -> Expected<void, std::string> {
    if (value < -1 || value > 1) return bad_value("-1 layout, 0 off, 1 on");
    axis_.force_switch(which, static_cast<SwitchForce>(value));
    return {};
  };
  if (name == "hardware-enable") {
    if (value < 0 || value > 1) return bad_value("0 or 1");
    pds_.set_hardware_enable(value != 0);
    return {};
  }
  if (name == "limit-positive") return force(AxisSwitch::positive_limit);
  if (name == "limit-negative") return force(AxisSwitch::negative_limit);
  if (name == "home-switch") return force(AxisSwitch::home);
  constexpr std::int64_t kPositionRange = std::int64_t{1} << 31;
  const bool is_position = name.ends_with("-at") || name.starts_with("home-switch-") ||
                           name == "index-offset" || name == "axis-position";
  if (is_position && (value < -kPositionRange || value >= kPositionRange)) {
    return bad_value("a position, INTEGER32");
  }
  SwitchLayout layout = axis_.layout();
  const auto at = static_cast<std::int64_t>(std::llround(position(value)));
  if (name == "limit-positive-at") {
    layout.positive_limit = at;
  } else if (name == "limit-negative-at") {
    layout.negative_limit = at;
  } else if (name == "home-switch-from") {
    layout.home_from = at;
  } else if (name == "home-switch-to") {
    layout.home_to = at;
  } else if (name == "stop-negative-at") {
    layout.stop_negative = at;  // mechanical end stop (axis_model.hpp)
  } else if (name == "stop-positive-at") {
    layout.stop_positive = at;
  } else if (name == "switch-layout-clear") {
    layout = SwitchLayout{};
  } else if (name == "index-period") {
    // 0: once per revolution again (608Fh, AxisConfig::encoder_increments).
    if (value < 0 || value > std::numeric_limits<std::uint32_t>::max()) {
      return bad_value("0 once per revolution, 1..4294967295 increments");
    }
    axis_.set_index(static_cast<std::uint32_t>(value), axis_.config().index_offset);
    return {};
  } else if (name == "index-offset") {
    axis_.set_index(axis_.config().index_period, at);
    return {};
  } else if (name == "axis-position") {
    axis_.place(position(value));
    // A teleport: the mode in 6061h starts again from where the axis now is.
    if (active_ != nullptr && context_) {
      ModeCycle cycle;
      cycle.now = last_cycle_.value_or(can::TimePoint{});
      cycle.controlword = pds_.forced_controlword().value_or(pds_.controlword());
      cycle.state = pds_.state();
      active_->enter(*context_, cycle);
    }
    publish();
    return {};
  } else if (name == "axis-coast-to-rest") {
    if (value != 1) return bad_value("1");
    if (!axis_.powered()) {
      axis_.place(axis_.physical_position());
      publish();
    }
    return {};
  } else if (name == "load-torque") {
    if (value < -100000 || value > 100000) return bad_value("-100000..100000 per mille");
    axis_.set_load_torque(static_cast<double>(value));
    return {};
  } else if (name.starts_with("fault:") || name.starts_with("fault ")) {
    const std::string_view which = name.substr(6);
    for (const SimulatedFault& f : kSimulatedFaults) {
      if (f.name != which) continue;
      if (value < 0 || value > 1) return bad_value("1 occurs, 0 cause gone");
      if (value == 1) {
        pds_.raise_fault(*f.fault);
      } else {
        pds_.clear_fault_cause(f.fault->code);
      }
      return {};
    }
    return Unexpected("simulate: unknown fault '" + std::string(which) +
                      "' (known: following-error, limit-switch, overcurrent, over-voltage, "
                      "over-temperature)");
  } else {
    return Unexpected("simulate: unknown input '" + std::string(name) +
                      "' (known: " + std::string(kSimulateNames) + ")");
  }
  axis_.set_layout(layout);
  return {};
}

}  // namespace drivecheck::reference_drive
