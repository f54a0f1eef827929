// Modes of operation (CiA 402 / IEC 61800-7-201): 6060h modes of operation, 6061h modes of
// operation display (INTEGER8), and 6502h supported drive modes (UNSIGNED32).
//
// 6060h / 6061h values (IRTSA Table 9, 003_111f14ab1c37c28a.txt L236-249; Festo L5973-5980):
//    0  no mode assigned          6  homing (hm)
//    1  profile position (pp)     7  interpolated position (ip)
//    2  velocity (vl)             8  cyclic synchronous position (csp)
//    3  profile velocity (pv)     9  cyclic synchronous velocity (csv)
//    4  profile torque (tq)      10  cyclic synchronous torque (cst)
//    5  reserved                 11..127 reserved
//   -128..-1 manufacturer specific (Festo 6061h: -1 invalid mode or change in progress, -11 user
//   position, -13 user velocity, -14 user torque; IRTSA: -127 manual profile position mpp)
//
// 6502h supported drive modes, bit = mode (IRTSA Table 10 L270-274):
//   bit 0 pp, 1 vl, 2 pv, 3 tq, 4 reserved, 5 hm, 6 ip, 7 csp, 8 csv, 9 cst, 10..15 reserved,
//   16..31 manufacturer specific
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace drivecheck::cia402 {

enum class Mode : std::int8_t {
  no_mode = 0,
  profile_position = 1,
  velocity = 2,
  profile_velocity = 3,
  profile_torque = 4,
  homing = 6,
  interpolated_position = 7,
  cyclic_sync_position = 8,
  cyclic_sync_velocity = 9,
  cyclic_sync_torque = 10,
};

// The mode of a 6060h/6061h value; nullopt for reserved and manufacturer-specific values.
std::optional<Mode> mode_from_value(std::int8_t value);
constexpr bool is_manufacturer_specific_mode(std::int8_t value) {
  return value < 0;
}
constexpr bool is_reserved_mode(std::int8_t value) {
  return value == 5 || value > 10;
}

// "pp", "vl", "pv", "tq", "hm", "ip", "csp", "csv", "cst", "-" for no_mode.
std::string_view abbreviation(Mode mode);
// "profile position", ...
std::string_view to_string(Mode mode);
// Any 6060h/6061h value in words: "profile position (pp)", "manufacturer-specific mode -11",
// "reserved mode 5".
std::string describe_mode(std::int8_t value);

// 6502h bit of a mode; nullopt for no_mode.
std::optional<unsigned> supported_modes_bit(Mode mode);
// Whether 6502h declares the mode.
bool supports(std::uint32_t supported_drive_modes, Mode mode);
// "pp+hm+csp (+ manufacturer bits 00010000h)".
std::string describe_supported_modes(std::uint32_t supported_drive_modes);

}  // namespace drivecheck::cia402
