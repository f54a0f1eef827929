#include "protocol/cia402/modes.hpp"

#include <fmt/format.h>

namespace drivecheck::cia402 {
namespace {

constexpr Mode kModes[] = {Mode::profile_position,
                           Mode::velocity,
                           Mode::profile_velocity,
                           Mode::profile_torque,
                           Mode::homing,
                           Mode::interpolated_position,
                           Mode::cyclic_sync_position,
                           Mode::cyclic_sync_velocity,
                           Mode::cyclic_sync_torque};

}  // namespace

std::optional<Mode> mode_from_value(std::int8_t value) {
  if (value == 0) return Mode::no_mode;
  for (Mode mode : kModes) {
    if (static_cast<std::int8_t>(mode) == value) return mode;
  }
  return std::nullopt;
}

std::string_view abbreviation(Mode mode) {
  switch (mode) {
    case Mode::no_mode:
      return "-";
    case Mode::profile_position:
      return "pp";
    case Mode::velocity:
      return "vl";
    case Mode::profile_velocity:
      return "pv";
    case Mode::profile_torque:
      return "tq";
    case Mode::homing:
      return "hm";
    case Mode::interpolated_position:
      return "ip";
    case Mode::cyclic_sync_position:
      return "csp";
    case Mode::cyclic_sync_velocity:
      return "csv";
    case Mode::cyclic_sync_torque:
      return "cst";
  }
  return "?";
}

std::string_view to_string(Mode mode) {
  switch (mode) {
    case Mode::no_mode:
      return "no mode";
    case Mode::profile_position:
      return "profile position";
    case Mode::velocity:
      return "velocity";
    case Mode::profile_velocity:
      return "profile velocity";
    case Mode::profile_torque:
      return "profile torque";
    case Mode::homing:
      return "homing";
    case Mode::interpolated_position:
      return "interpolated position";
    case Mode::cyclic_sync_position:
      return "cyclic synchronous position";
    case Mode::cyclic_sync_velocity:
      return "cyclic synchronous velocity";
    case Mode::cyclic_sync_torque:
      return "cyclic synchronous torque";
  }
  return "?";
}

std::string describe_mode(std::int8_t value) {
  if (const auto mode = mode_from_value(value)) {
    if (*mode == Mode::no_mode) return "no mode";
    return fmt::format("{} ({})", to_string(*mode), abbreviation(*mode));
  }
  if (is_manufacturer_specific_mode(value))
    return fmt::format("manufacturer-specific mode {}", value);
  return fmt::format("reserved mode {}", value);
}

std::optional<unsigned> supported_modes_bit(Mode mode) {
  switch (mode) {
    case Mode::no_mode:
      return std::nullopt;
    case Mode::profile_position:
      return 0;
    case Mode::velocity:
      return 1;
    case Mode::profile_velocity:
      return 2;
    case Mode::profile_torque:
      return 3;
    case Mode::homing:
      return 5;
    case Mode::interpolated_position:
      return 6;
    case Mode::cyclic_sync_position:
      return 7;
    case Mode::cyclic_sync_velocity:
      return 8;
    case Mode::cyclic_sync_torque:
      return 9;
  }
  return std::nullopt;
}

bool supports(std::uint32_t supported_drive_modes, Mode mode) {
  const auto bit = supported_modes_bit(mode);
  return bit && (supported_drive_modes & (1u << *bit)) != 0;
}

std::string describe_supported_modes(std::uint32_t supported_drive_modes) {
  std::string text;
  for (Mode mode : kModes) {
    if (!supports(supported_drive_modes, mode)) continue;
    if (!text.empty()) text += '+';
    text += abbreviation(mode);
  }
  if (text.empty()) text = "none";
  if (const std::uint32_t reserved = supported_drive_modes & 0x0000FC10u) {
    text += fmt::format(" (+ reserved bits {:08X}h)", reserved);
  }
  if (const std::uint32_t manufacturer = supported_drive_modes & 0xFFFF0000u) {
    text += fmt::format(" (+ manufacturer bits {:08X}h)", manufacturer);
  }
  return text;
}

}  // namespace drivecheck::cia402
