#include "reference_drive/personality.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
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
    plan.application.manufacturer_modes.push_back(static_cast<std::int8_t>(m.value));
    plan.not_applied.push_back(fmt::format(
        "manufacturer mode {} ({}): the PDS refuses negative 6060h values", m.value, m.name));
  }
  return {};
}

Expected<void, std::string> apply_option_codes(const profile::Personality& p,
                                               PersonalityPlan& plan) {
  OptionCodeSupport& support = plan.application.pds.option_code_support;
  for (const auto& [code, values] : *p.option_codes) {
    std::uint16_t bits = 0;
    for (int value : values) {
      if (value < 0 || value > 15) {
        plan.not_applied.push_back(
            fmt::format("option code {} = {}: the reference drive accepts "
                        "0..15 only",
                        profile::to_string(code), value));
        continue;
      }
      bits = static_cast<std::uint16_t>(bits | (1U << static_cast<unsigned>(value)));
    }
    if (bits == 0) {
      plan.not_applied.push_back(
          fmt::format("option code {}: no value it could accept, CiA 402's values kept",
                      profile::to_string(code)));
      continue;
    }
    support.values[static_cast<std::size_t>(to_drive(code))] = bits;
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

}  // namespace

profile::Personality standard_personality() {
  profile::Personality p;
  p.modes = std::vector<int>{1, 3, 4, 6, 7, 8, 9, 10};
  p.option_codes.emplace();
  p.identity.emplace();
  p.hardware_enable = profile::HardwareEnable::transition_3;
  return p;
}

Expected<PersonalityPlan, std::string> plan_personality(const profile::DriveProfile* profile) {
  const profile::Personality p =
      profile != nullptr ? profile->effective_personality() : standard_personality();
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
      plan.overrides.push_back({kErrorBehaviourIndex, 1, 1, cia301::ResetKind::communication});
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
  if (profile != nullptr) {
    if (auto r = apply_pdo_defaults(profile->pdo_defaults, plan); !r) return Unexpected(r.error());
  }
  return plan;
}

}  // namespace drivecheck::reference_drive
