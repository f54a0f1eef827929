#include "reference_drive/personality.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <span>
#include <utility>

#include "protocol/cia402/modes.hpp"

namespace drivecheck::reference_drive {
namespace {

constexpr std::uint16_t kErrorBehaviourIndex = 0x1029;
constexpr std::uint16_t kGuardTimeIndex = 0x100C;
constexpr std::uint16_t kLifeTimeFactorIndex = 0x100D;

// The reference drive's option-code enum for the profile's (same objects, other order).
OptionCode to_drive(profile::OptionCode code) {
  switch (code) {
    case profile::OptionCode::quick_stop:
      return OptionCode::quick_stop;
    case profile::OptionCode::shutdown:
      return OptionCode::shutdown;
    case profile::OptionCode::disable_operation:
      return OptionCode::disable_operation;
    case profile::OptionCode::halt:
      return OptionCode::halt;
    case profile::OptionCode::fault_reaction:
      return OptionCode::fault_reaction;
    case profile::OptionCode::abort_connection:
      return OptionCode::abort_connection;
  }
  return OptionCode::quick_stop;
}

HomingVendor to_vendor(profile::HomingTable table) {
  switch (table) {
    case profile::HomingTable::none:
      return HomingVendor::cia402;
    case profile::HomingTable::festo:
      return HomingVendor::festo;
    case profile::HomingTable::kollmorgen:
      return HomingVendor::kollmorgen;
    case profile::HomingTable::irtsa:
      return HomingVendor::irtsa;
  }
  return HomingVendor::cia402;
}

void apply_identity(const profile::Identity& from, Identity& to) {
  if (from.device_type) to.device_type = *from.device_type;
  if (from.vendor_id) to.vendor_id = *from.vendor_id;
  if (from.product_code) to.product_code = *from.product_code;
  if (from.revision_number) to.revision = *from.revision_number;
  if (from.serial_number) to.serial = *from.serial_number;
  if (from.device_name) to.device_name = *from.device_name;
  if (from.hardware_version) to.hardware_version = *from.hardware_version;
  if (from.software_version) to.software_version = *from.software_version;
}

Expected<void, std::string> apply_modes(const profile::Personality& p, PersonalityPlan& plan) {
  std::uint32_t supported = 0;
  for (int value : *p.modes) {
    if (value < 0) {
      const bool listed = std::any_of(p.manufacturer_modes.begin(), p.manufacturer_modes.end(),
                                      [value](const auto& m) { return m.value == value; });
      if (!listed) {
        return Unexpected(
            fmt::format("modes: {} is manufacturer specific but not in manufacturer_modes", value));
      }
      continue;
    }
    const auto mode = cia402::mode_from_value(static_cast<std::int8_t>(value));
    if (!mode || *mode == cia402::Mode::no_mode) {
      return Unexpected(fmt::format("modes: {} is no CiA 402 mode of operation", value));
    }
    if (*mode == cia402::Mode::velocity) {
      plan.not_applied.push_back("mode 2 (vl): the reference drive has no velocity mode");
      continue;
    }
    if (auto bit = cia402::supported_modes_bit(*mode)) supported |= 1U << *bit;
  }
  plan.application.pds.supported_modes = supported;
  plan.host_homing = cia402::supports(supported, cia402::Mode::homing);
  for (const auto& m : p.manufacturer_modes) {
    ManufacturerModeConfig mode;
    mode.value = static_cast<std::int8_t>(m.value);
    mode.behaves_as = static_cast<std::int8_t>(m.behaves_as);
    if (m.logic == profile::ManufacturerModeLogic::irtsa_mpp) {
      mode.logic = ManufacturerModeConfig::Logic::irtsa_mpp;
    } else if (m.behaves_as == 2 || m.behaves_as == 6) {
      plan.not_applied.push_back(fmt::format(
          "manufacturer mode {} ({}): behaves_as {} has no logic in the reference drive: the axis "
          "holds its position",
          m.value, m.name, m.behaves_as));
    }
    plan.application.manufacturer_modes.push_back(mode);
  }
  return {};
}

Expected<void, std::string> apply_option_codes(const profile::Personality& p,
                                               PersonalityPlan& plan) {
  OptionCodeSupport& support = plan.application.pds.option_code_support;
  for (const auto& [code, values] : *p.option_codes) {
    std::uint16_t bits = 0;
    std::uint16_t manufacturer = 0;
    for (int value : values) {
      // The one manufacturer value with behaviour: 605Ch = -1 (Festo 000 §6.1.6 L5871-5887,
      // power_drive_system.hpp).
      if (value == -1 && to_drive(code) == OptionCode::disable_operation) {
        manufacturer = static_cast<std::uint16_t>(manufacturer | 1U);
        continue;
      }
      if (value < 0 || value > 15) {
        plan.not_applied.push_back(
            fmt::format("option code {} = {}: the reference drive accepts "
                        "0..15 (and 605Ch -1) only",
                        profile::to_string(code), value));
        continue;
      }
      bits = static_cast<std::uint16_t>(bits | (1U << static_cast<unsigned>(value)));
    }
    if (bits == 0 && manufacturer == 0) {
      plan.not_applied.push_back(
          fmt::format("option code {}: no value it could accept, CiA 402's values kept",
                      profile::to_string(code)));
      continue;
    }
    support.values[static_cast<std::size_t>(to_drive(code))] = bits;
    support.manufacturer[static_cast<std::size_t>(to_drive(code))] = manufacturer;
  }
  for (const auto& [code, value] : p.option_defaults) {
    const OptionCode drive_code = to_drive(code);
    if (!support.accepts(drive_code, static_cast<std::int16_t>(value))) {
      return Unexpected(fmt::format("option_defaults: {} = {} is not accepted by the option codes",
                                    profile::to_string(code), value));
    }
    const OptionCodeInfo& info = info_of(drive_code);
    if (value != info.default_value) {
      plan.overrides.push_back({info.id.index, 0, value, cia301::ResetKind::application});
    }
  }
  // A CiA 402 default the personality's support refuses must move to an accepted value.
  for (const OptionCodeInfo& info : kOptionCodes) {
    const bool overridden = std::any_of(plan.overrides.begin(), plan.overrides.end(),
                                        [&](const auto& o) { return o.index == info.id.index; });
    if (overridden || support.accepts(info.code, info.default_value)) continue;
    for (int v = 0; v < 16; ++v) {
      if (support.accepts(info.code, static_cast<std::int16_t>(v))) {
        plan.overrides.push_back({info.id.index, 0, v, cia301::ResetKind::application});
        break;
      }
    }
    if (support.values[static_cast<std::size_t>(info.code)] == 0 &&
        support.accepts(info.code, -1)) {
      plan.overrides.push_back({info.id.index, 0, -1, cia301::ResetKind::application});
    }
  }
  return {};
}

void apply_homing(const profile::DriveProfile* profile, const profile::Personality& p,
                  PersonalityPlan& plan) {
  HomingConfig& h = plan.homing;
  h.vendor = to_vendor(p.manufacturer_homing);
  const std::vector<std::int8_t> available = homing_methods_of(h.vendor);
  if (profile != nullptr) {
    h.supported_methods.clear();
    for (int method : profile->homing_methods) {
      const auto m = static_cast<std::int8_t>(method);
      if (find_homing_method(m, h.vendor) != nullptr) {
        h.supported_methods.push_back(m);
      } else {
        plan.not_applied.push_back(
            fmt::format("homing method {}: not in the reference drive's homing table", method));
      }
    }
    if (auto timeout = profile->timing.find("homing"); timeout != profile->timing.end()) {
      h.timeout = timeout->second;
    }
  }
  const std::vector<std::int8_t>& methods =
      h.supported_methods.empty() ? available : h.supported_methods;
  auto has = [&methods](int m) {
    return std::find(methods.begin(), methods.end(), static_cast<std::int8_t>(m)) != methods.end();
  };
  if (p.homing_default_method && has(*p.homing_default_method)) {
    h.default_method = static_cast<std::int8_t>(*p.homing_default_method);
  } else if (!has(h.default_method) && !methods.empty()) {
    h.default_method = methods.front();
  }
  if (p.homing == profile::HomingStyle::set_position) {
    h.start_outside_operation_enabled = true;
    h.deviations.no_error_bit = true;
  }
  h.deviations.halt_sets_error = p.homing_halt_sets_error;
  if (p.manufacturer_homing == profile::HomingTable::festo) {
    // Festo 6510h:F0h compatibility_control bit 6 homing_to_zero (000_33c1d912b8b6010a.txt §5.2
    // L2560-2566, §7.2.2 L6149-6151): travel to zero after homing (homing.hpp). The object
    // is in Festo's objects list (objects.yaml), default 0: no travel (L6040).
    h.travel_to_zero_bit = HomingConfig::ObjectBit{0x6510, 0xF0, 0x40};
  }
}

Expected<void, std::string> apply_pdo_defaults(const std::vector<profile::PdoDefault>& pdos,
                                               PersonalityPlan& plan) {
  cia301::PdoObjectOptions& options = plan.drive.dictionary.pdo;
  for (const auto& pdo : pdos) {
    const bool rx = pdo.kind == profile::PdoKind::rpdo;
    const std::string name = fmt::format("{}{}", rx ? "rpdo" : "tpdo", pdo.number);
    // Pre-defined connection set: TPDOn 180h + 100h(n-1), RPDOn 200h + 100h(n-1) (+ node-ID).
    const std::uint32_t base = (rx ? 0x200U : 0x180U) + 0x100U * (pdo.number - 1U);
    if (pdo.number > 4 || !pdo.cob_id.plus_node || (pdo.cob_id.base & 0x7FFU) != base) {
      plan.not_applied.push_back(
          fmt::format("{} COB-ID {}: only the pre-defined COB-IDs of PDOs 1-4 can be defaults",
                      name, profile::to_string(pdo.cob_id)));
      continue;
    }
    cia301::PdoDefaults d;
    d.valid = (pdo.cob_id.base & 0x80000000U) == 0;
    d.rtr_allowed = (pdo.cob_id.base & 0x40000000U) == 0;
    d.transmission_type = pdo.transmission;
    d.inhibit_time = pdo.inhibit_time.value_or(0);
    d.event_timer = pdo.event_timer.value_or(0);
    for (std::uint32_t raw : pdo.mapping) {
      cia301::PdoMappingEntry entry;
      entry.index = static_cast<std::uint16_t>(raw >> 16);
      entry.sub_index = static_cast<std::uint8_t>((raw >> 8) & 0xFFU);
      entry.bits = static_cast<std::uint8_t>(raw & 0xFFU);
      d.mapping.push_back(entry);
    }
    auto& list = rx ? options.rpdo_defaults : options.tpdo_defaults;
    if (list.size() < pdo.number) list.resize(pdo.number);
    list[pdo.number - 1U] = std::move(d);
  }
  return {};
}

// The written value of an integer entry as a signed number (unsigned types never negative).
std::int64_t written_value(const cia301::Entry& entry, std::span<const std::uint8_t> data) {
  const bool is_signed = cia301::info(entry.type()).type_class == cia301::TypeClass::signed_integer;
  return is_signed ? cia301::load_signed(data)
                   : static_cast<std::int64_t>(cia301::load_unsigned(data));
}

// The rule's checks in front of the entry's own validator and read hook.
void restrict_entry(cia301::Entry& entry, const profile::ObjectRule& rule) {
  if (rule.access == cia301::AccessType::wo) {
    entry.set_read_hook(
        [](cia301::ObjectDictionary&, cia301::Entry&) -> Expected<void, cia301::SdoAbort> {
          return Unexpected(cia301::SdoAbort::read_write_only);
        });
  }
  const bool integer = cia301::is_integer(entry.type());
  cia301::WriteValidator inner = entry.write_validator();
  entry.set_write_validator(
      [rule, integer, inner](
          const cia301::ObjectDictionary& od, const cia301::Entry& e,
          std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
        if (rule.access == cia301::AccessType::ro) {
          return Unexpected(cia301::SdoAbort::write_read_only);
        }
        if (integer) {
          const std::int64_t value = written_value(e, data);
          if (rule.min && value < *rule.min) return Unexpected(cia301::SdoAbort::value_too_low);
          if (rule.max && value > *rule.max) return Unexpected(cia301::SdoAbort::value_too_high);
          if (!rule.values.empty() &&
              std::find(rule.values.begin(), rule.values.end(), value) == rule.values.end()) {
            return Unexpected(cia301::SdoAbort::invalid_value);
          }
        }
        if (inner) return inner(od, e, data);
        return {};
      });
}

cia301::Value value_of(cia301::DataType type, std::int64_t value) {
  return cia301::info(type).type_class == cia301::TypeClass::signed_integer
             ? cia301::Value::of_signed(value)
             : cia301::Value::of_unsigned(static_cast<std::uint64_t>(value));
}

}  // namespace

Expected<void, std::string> apply_object_rules(cia301::ObjectDictionary& od,
                                               const std::vector<profile::ObjectRule>& rules,
                                               Cia402Application& application) {
  // 1. The objects to add, one definition per index (all rules with a type).
  std::vector<cia301::ObjectDefinition> added;
  for (const profile::ObjectRule& rule : rules) {
    if (!rule.type) continue;
    if (od.find(rule.index) != nullptr) {
      return Unexpected(fmt::format(
          "objects: {:04X}h sub {}: the drive has this object; give no type to restrict it",
          rule.index, rule.sub));
    }
    auto def = std::find_if(added.begin(), added.end(),
                            [&](const auto& d) { return d.index == rule.index; });
    if (def == added.end()) {
      added.push_back({rule.index,
                       fmt::format("personality object {:04X}h", rule.index),
                       cia301::ObjectCode::var,
                       {}});
      def = std::prev(added.end());
    }
    cia301::EntryDefinition entry =
        cia301::EntryDefinition::make(rule.sub, fmt::format("sub {}", rule.sub), *rule.type,
                                      rule.access.value_or(cia301::AccessType::rw),
                                      value_of(*rule.type, rule.default_value.value_or(0)), false);
    def->entries.push_back(std::move(entry));
  }
  for (cia301::ObjectDefinition& def : added) {
    std::sort(def.entries.begin(), def.entries.end(),
              [](const auto& a, const auto& b) { return a.sub_index < b.sub_index; });
    if (def.entries.front().sub_index != 0) {
      def.code = cia301::ObjectCode::record;
      def.entries.insert(def.entries.begin(),
                         cia301::EntryDefinition::highest_sub_index(def.entries.back().sub_index));
    }
    auto object = od.add_object(std::move(def));
    if (!object) return Unexpected("objects: " + object.error());
  }
  // 2. Checks and actions on every entry a rule names.
  for (const profile::ObjectRule& rule : rules) {
    cia301::Entry* entry = od.find(rule.index, rule.sub);
    if (entry == nullptr) {
      return Unexpected(fmt::format(
          "objects: {:04X}h sub {}: the drive has no such entry and the rule gives no type",
          rule.index, rule.sub));
    }
    // Added entries carry their access in their definition; limits and values need the check.
    if (!rule.type || rule.min || rule.max || !rule.values.empty()) restrict_entry(*entry, rule);
    if (rule.action == profile::ObjectAction::set_actual_position) {
      entry->set_store_group(cia301::kStoreNone);
      Cia402Application* app = &application;
      entry->set_write_observer([app](cia301::ObjectDictionary&, cia301::Entry& e) {
        app->axis().set_actual_position(
            app->factors().position_to_internal(static_cast<double>(e.as_signed())));
      });
    }
  }
  return {};
}

FactorGroup InternalUnitParameters::read_factors(const cia301::ObjectDictionary& od) {
  return read_factor_group(od);
}

double InternalUnitParameters::to_internal(const FactorGroup& f, Kind kind, double user) {
  switch (kind) {
    case Kind::position:
      return f.position_to_internal(user);
    case Kind::distance:
      return f.distance_to_internal(user);
    case Kind::velocity:
      return f.velocity_to_internal(user);
    case Kind::speed:
      return f.speed_to_internal(user);
    case Kind::acceleration:
      return f.acceleration_to_internal(user);
  }
  return user;
}

double InternalUnitParameters::to_user(const FactorGroup& f, Kind kind, double internal) {
  switch (kind) {
    case Kind::position:
      return f.position_to_user(internal);
    case Kind::distance:
      return f.distance_to_user(internal);
    case Kind::velocity:
      return f.velocity_to_user(internal);
    case Kind::speed:
      return f.speed_to_user(internal);
    case Kind::acceleration:
      return f.acceleration_to_user(internal);
  }
  return internal;
}

void InternalUnitParameters::store(const cia301::ObjectDictionary& od, Parameter& p) {
  const cia301::Entry* e = od.find(p.index, p.sub);
  if (e == nullptr) return;
  const bool is_signed = cia301::info(e->type()).type_class == cia301::TypeClass::signed_integer;
  const double user =
      is_signed ? static_cast<double>(e->as_signed()) : static_cast<double>(e->as_unsigned());
  p.internal = std::round(to_internal(read_factors(od), p.kind, user));
}

void InternalUnitParameters::re_express(cia301::ObjectDictionary& od) {
  const FactorGroup f = read_factors(od);
  for (const Parameter& p : parameters_) {
    cia301::Entry* e = od.find(p.index, p.sub);
    if (e == nullptr) continue;
    const double user = to_user(f, p.kind, p.internal);
    const bool is_signed = cia301::info(e->type()).type_class == cia301::TypeClass::signed_integer;
    const std::uint64_t max = cia301::info(e->type()).size >= 4
                                  ? 0xFFFFFFFFU
                                  : (std::uint64_t{1} << (8 * cia301::info(e->type()).size)) - 1;
    if (is_signed) {
      (void)e->assign(cia301::Value::of_signed(FactorGroup::to_i32(user)));
    } else {
      (void)e->assign(
          cia301::Value::of_unsigned(std::min<std::uint64_t>(FactorGroup::to_u32(user), max)));
    }
  }
}

void InternalUnitParameters::attach(cia301::ObjectDictionary& od) {
  struct Row {
    std::uint16_t index;
    std::uint8_t sub;
    Kind kind;
  };
  static constexpr Row kRows[] = {
      {0x607A, 0, Kind::position},     {0x607D, 1, Kind::position},
      {0x607D, 2, Kind::position},     {0x607C, 0, Kind::distance},
      {0x6065, 0, Kind::distance},     {0x6067, 0, Kind::distance},
      {0x60FF, 0, Kind::velocity},     {0x606D, 0, Kind::speed},
      {0x606F, 0, Kind::speed},        {0x607F, 0, Kind::speed},
      {0x6081, 0, Kind::speed},        {0x6099, 1, Kind::speed},
      {0x6099, 2, Kind::speed},        {0x6083, 0, Kind::acceleration},
      {0x6084, 0, Kind::acceleration}, {0x6085, 0, Kind::acceleration},
      {0x609A, 0, Kind::acceleration},
  };
  parameters_.clear();
  for (const Row& row : kRows) {
    cia301::Entry* e = od.find(row.index, row.sub);
    if (e == nullptr || !cia301::is_integer(e->type())) continue;
    parameters_.push_back({row.index, row.sub, row.kind, 0.0});
  }
  resync(od);
  for (std::size_t i = 0; i < parameters_.size(); ++i) {
    cia301::Entry* e = od.find(parameters_[i].index, parameters_[i].sub);
    cia301::WriteObserver inner = e->write_observer();
    e->set_write_observer([this, i, inner](cia301::ObjectDictionary& dict, cia301::Entry& entry) {
      store(dict, parameters_[i]);
      if (inner) inner(dict, entry);
    });
  }
  // Festo: "The position_factor must not be larger than 2^24" (000_33c1d912b8b6010a.txt §5.3
  // L2662); the manual names no reaction, so a write that would make 6093h sub 1 / sub 2 larger
  // is refused with 06090031h (value too high) and the factor keeps its value.
  for (std::uint8_t sub : {std::uint8_t{1}, std::uint8_t{2}}) {
    cia301::Entry* e = od.find(0x6093, sub);
    if (e == nullptr || !cia301::is_integer(e->type())) continue;
    cia301::WriteValidator inner = e->write_validator();
    e->set_write_validator(
        [sub, inner](const cia301::ObjectDictionary& dict, const cia301::Entry& entry,
                     std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
          if (inner) {
            if (auto ok = inner(dict, entry, data); !ok) return ok;
          }
          const cia301::Entry* other = dict.find(0x6093, sub == 1 ? 2 : 1);
          if (other == nullptr) return {};
          const std::uint64_t written = cia301::load_unsigned(data);
          const std::uint64_t numerator = sub == 1 ? written : other->as_unsigned();
          const std::uint64_t divisor = sub == 1 ? other->as_unsigned() : written;
          constexpr std::uint64_t kMaxPositionFactor = std::uint64_t{1} << 24;
          if (divisor != 0 && numerator > kMaxPositionFactor * divisor) {
            return Unexpected(cia301::SdoAbort::value_too_high);
          }
          return {};
        });
  }
  for (std::uint16_t index :
       {std::uint16_t{0x6091}, std::uint16_t{0x6092}, std::uint16_t{0x6093}, std::uint16_t{0x6094},
        std::uint16_t{0x6097}, std::uint16_t{0x607E}}) {
    cia301::Object* object = od.find(index);
    if (object == nullptr) continue;
    for (cia301::Entry& e : object->entries()) {
      cia301::WriteObserver inner = e.write_observer();
      e.set_write_observer([this, inner](cia301::ObjectDictionary& dict, cia301::Entry& entry) {
        if (inner) inner(dict, entry);  // e.g. 6091h/6092h recompute 6093h first
        re_express(dict);
      });
    }
  }
}

void InternalUnitParameters::resync(const cia301::ObjectDictionary& od) {
  for (Parameter& p : parameters_)
    store(od, p);
}

profile::Personality standard_personality() {
  profile::Personality p;
  p.modes = std::vector<int>{1, 3, 4, 6, 7, 8, 9, 10};
  p.option_codes.emplace();
  p.identity.emplace();
  p.hardware_enable = profile::HardwareEnable::transition_3;
  p.sdo_client = true;
  p.time_consumer = true;
  p.position_range_limit = profile::PositionRangeLimit::cia402;
  return p;
}

Expected<PersonalityPlan, std::string> plan_personality(const profile::DriveProfile* profile,
                                                        profile::Link link) {
  profile::Personality p =
      profile != nullptr ? profile->effective_personality() : standard_personality();
  if (profile != nullptr && p.modes) {
    std::erase_if(*p.modes, [&](int mode) {
      return std::any_of(
          profile->modes_only_on.begin(), profile->modes_only_on.end(),
          [&](const profile::ModeOnlyOn& m) { return m.mode == mode && m.link != link; });
    });
  }
  PersonalityPlan plan;
  plan.name = profile != nullptr ? profile->name : "standard";

  apply_identity(*p.identity, plan.drive.dictionary.identity);
  if (auto r = apply_modes(p, plan); !r) return Unexpected(r.error());
  if (auto r = apply_option_codes(p, plan); !r) return Unexpected(r.error());
  apply_homing(profile, p, plan);

  switch (p.hardware_enable) {
    case profile::HardwareEnable::none:
      plan.application.pds.hardware_enable = HardwareEnable::not_needed;
      break;
    case profile::HardwareEnable::transition_2:
      plan.application.pds.hardware_enable = HardwareEnable::for_shutdown;
      break;
    case profile::HardwareEnable::transition_3:
      plan.application.pds.hardware_enable = HardwareEnable::for_switch_on;
      break;
  }
  plan.emcy_follow_up = p.emcy_follow_up;
  plan.manufacturer_objects = p.manufacturer_objects;
  plan.position_sampling = p.position_sampling;
  plan.application.error_code_format = p.error_code_format == profile::ErrorCodeFormat::error_number
                                           ? ErrorCodeFormat::error_number
                                           : ErrorCodeFormat::standard;
  for (const auto& t : p.object_types) {
    const bool mode_object = (t.index == 0x6060 || t.index == 0x6061) && t.sub == 0;
    if (!mode_object || t.type != cia301::DataType::integer16) {
      return Unexpected(fmt::format(
          "object_types: {:04X}h sub {} as {}: the reference drive can only make 6060h/6061h "
          "INTEGER16",
          t.index, t.sub, cia301::info(t.type).name));
    }
    plan.application.mode_object_width = ModeObjectWidth::bits16;
  }
  switch (p.guarding_loss) {
    case profile::GuardingLoss::error_behaviour:
      break;
    case profile::GuardingLoss::pre_operational:
      plan.not_applied.push_back(
          "guarding_loss pre-operational: from Stopped the node stays Stopped (1029h:01 = 0)");
      break;
    case profile::GuardingLoss::no_nmt_change:
      // 1029h:01 defaults to 1 where the personality keeps 1029h; without it (absent_objects)
      // the drive's fixed reaction is the same.
      plan.overrides.push_back({kErrorBehaviourIndex, 1, 1, cia301::ResetKind::communication});
      plan.drive.communication_error_without_1029 = 1;
      break;
  }
  if (p.ack_latency_cycles == 0) {
    return Unexpected(
        "ack_latency_cycles: the reference drive acknowledges one cycle later at "
        "the earliest (1..1000)");
  }
  plan.application.acknowledge_latency_cycles = p.ack_latency_cycles;
  if (p.control_cycle) plan.drive.control_cycle = *p.control_cycle;
  if (p.sdo_dlc == profile::SdoDlc::minimal) {
    plan.not_applied.push_back("sdo_dlc minimal: the SDO server always answers with 8 bytes");
  }
  plan.objects = p.objects;
  for (const profile::ObjectRule& rule : p.objects) {
    if (!rule.type && rule.default_value) {
      plan.overrides.push_back(
          {rule.index, rule.sub, *rule.default_value, cia301::ResetKind::application});
    }
  }
  for (const profile::ObjectRule& rule : p.objects) {
    if (rule.type && rule.action == profile::ObjectAction::none &&
        rule.access == cia301::AccessType::wo) {
      plan.not_applied.push_back(fmt::format(
          "object {:04X}h sub {}: added as the manual lists it; a write is stored and has no "
          "effect (what it acts on is not simulated)",
          rule.index, rule.sub));
    }
  }
  plan.drive.dictionary.pdo.mapping_while_valid = p.pdo_mapping_while_valid;
  plan.drive.dictionary.pdo.cob_id_enable_only = p.pdo_cob_id_enable_only;
  plan.drive.dictionary.pdo.change_mask_index = p.tpdo_transmit_masks;
  plan.parameters_internal = p.parameters_internal;
  plan.application.internal_velocity_unit = {p.internal_units.velocity.numerator,
                                             p.internal_units.velocity.divisor};
  plan.application.internal_acceleration_unit = {p.internal_units.acceleration.numerator,
                                                 p.internal_units.acceleration.divisor};
  if (p.encoder_resolution) plan.application.axis.encoder_increments = *p.encoder_resolution;
  plan.application.pp_change_on_set_point = p.pp_change_on_set_point;
  plan.application.ip_submode = p.ip_submode;
  plan.application.pds.power_stage_in_switched_on = p.power_stage_in_switched_on;
  plan.nmt_min_spacing = p.nmt_min_spacing;
  plan.drive.sdo_short_frames = p.sdo_short_requests == profile::SdoShortRequests::pad
                                    ? cia301::ShortFramePolicy::pad
                                    : cia301::ShortFramePolicy::ignore;
  if (p.heartbeat_time_ms) plan.drive.dictionary.producer_heartbeat_ms = *p.heartbeat_time_ms;
  if (p.guard_time_ms && *p.guard_time_ms != 0) {
    plan.overrides.push_back(
        {kGuardTimeIndex, 0, *p.guard_time_ms, cia301::ResetKind::communication});
  }
  if (p.life_time_factor && *p.life_time_factor != 0) {
    plan.overrides.push_back(
        {kLifeTimeFactorIndex, 0, *p.life_time_factor, cia301::ResetKind::communication});
  }
  // Further SDO servers and the bus-off reaction (device.hpp).
  plan.drive.dictionary.extra_sdo_servers = p.extra_sdo_servers;
  plan.drive.dictionary.sdo_node_id_sub = p.sdo_server_node_id;
  plan.drive.dictionary.sdo_client = p.sdo_client;
  plan.drive.dictionary.time_consumer = p.time_consumer;
  plan.bus_off = p.bus_off;
  // Issue 17's permitted choices (personality.hpp).
  plan.cia402 = p.cia402;
  for (const profile::ObjectRange& range : p.absent_objects) {
    plan.drive.absent_objects.emplace_back(range.first, range.last);
  }
  plan.abort_codes = p.abort_codes;
  plan.sdo_response_delay = p.sdo_response_delay;
  plan.static_pdo_mapping = p.pdo_mapping == profile::PdoMapping::fixed;
  plan.refuse_empty_pdo = p.empty_pdo_valid == profile::EmptyPdoValid::refuse;
  plan.drive.tpdo_first_sync_phase = p.tpdo_sync_phase == profile::TpdoSyncPhase::first_sync;
  plan.application.setpoint_buffer = p.setpoint_buffer;
  plan.application.position_range =
      p.position_range_limit == profile::PositionRangeLimit::cia402  ? PositionRangeSupport::cia402
      : p.position_range_limit == profile::PositionRangeLimit::festo ? PositionRangeSupport::festo
                                                                     : PositionRangeSupport::none;
  plan.application.pds.initial_mode = p.initial_mode;
  plan.application.ip_max_buffer = p.ip_max_buffer;
  plan.application.max_motor_speed_rpm = p.max_motor_speed == profile::MaxMotorSpeed::rpm_u16;
  plan.restore_output_stage_off = p.restore_output_stage_off;
  if (profile != nullptr) {
    if (auto r = apply_pdo_defaults(profile->pdo_defaults, plan); !r) return Unexpected(r.error());
  }
  return plan;
}

}  // namespace drivecheck::reference_drive
