// Controlword 6040h (CiA 402 / IEC 61800-7-201 §"Controlword"): bits and the device-control
// commands.
//
// Controlword, UNSIGNED16:
//   bit 0   switch on                    M
//   bit 1   enable voltage               M
//   bit 2   quick stop (0 = quick stop)  O (M in CiA 402 v2; Festo, IRTSA use it)
//   bit 3   enable operation             M
//   bit 4   operation-mode specific: pp new set-point, hm homing operation start,
//           ip enable ip mode
//   bit 5   operation-mode specific: pp change set immediately
//   bit 6   operation-mode specific: pp absolute (0) / relative (1)
//   bit 7   fault reset (rising edge)    M
//   bit 8   halt                         O
//   bit 9   operation-mode specific: pp change on set-point
//   bit 10  reserved
//   bits 11..15 manufacturer specific
//   (IRTSA CU2115 Table 3, 003_111f14ab1c37c28a.txt L118-135; Festo Tab. 6.3,
//   000_33c1d912b8b6010a.txt L5345-5363)
//
// Command coding, bits 7 3 2 1 0 (x = don't care; IRTSA Table 4 L139-149 = CiA 402):
//   shutdown                       0 x 1 1 0   transitions 2, 6, 8
//   switch on                      0 0 1 1 1   transition 3
//   switch on + enable operation   0 1 1 1 1   transitions 3 + 4
//   disable voltage                0 x x 0 x   transitions 7, 9, 10, 12
//   quick stop                     0 x 0 1 x   transitions 7, 10, 11
//   disable operation              0 0 1 1 1   transition 5
//   enable operation               0 1 1 1 1   transitions 4, 16
//   fault reset                    0→1 x x x x transition 15
// Festo's Tab. 6.4 (L5365-5377) marks bit 7 "x" in every command but fault reset, and bit 3
// "x" in switch on; the state machine table (state_machine.hpp) takes switch on with bit 3 as
// don't care, so 000Fh in READY TO SWITCH ON is switch on (3), followed by 4 at once.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>

namespace drivecheck::cia402 {

namespace controlword {
inline constexpr std::uint16_t kSwitchOn = 0x0001;
inline constexpr std::uint16_t kEnableVoltage = 0x0002;
inline constexpr std::uint16_t kQuickStop = 0x0004;  // 0 = quick stop requested
inline constexpr std::uint16_t kEnableOperation = 0x0008;
inline constexpr std::uint16_t kNewSetPoint = 0x0010;           // pp
inline constexpr std::uint16_t kHomingOperationStart = 0x0010;  // hm
inline constexpr std::uint16_t kEnableIpMode = 0x0010;          // ip
inline constexpr std::uint16_t kChangeSetImmediately = 0x0020;  // pp
inline constexpr std::uint16_t kRelative = 0x0040;              // pp: 1 = relative
inline constexpr std::uint16_t kFaultReset = 0x0080;
inline constexpr std::uint16_t kHalt = 0x0100;
inline constexpr std::uint16_t kChangeOnSetPoint = 0x0200;  // pp
inline constexpr std::uint16_t kManufacturerMask = 0xF800;
// The bits that select a device-control command.
inline constexpr std::uint16_t kCommandMask = 0x008F;
}  // namespace controlword

enum class Command : std::uint8_t {
  shutdown,
  switch_on,
  switch_on_and_enable_operation,
  disable_voltage,
  quick_stop,
  disable_operation,
  enable_operation,
  fault_reset,
};

struct CommandCoding {
  Command command;
  std::uint16_t mask;   // bits that must match
  std::uint16_t value;  // their values
  bool rising_edge;     // fault reset: bit 7 must go 0 → 1
  std::string_view name;
};

// clang-format off
inline constexpr std::array<CommandCoding, 8> kCommandCodings{{
    // command                                  mask    value   edge   name
    {Command::shutdown,                         0x0087, 0x0006, false, "shutdown"},
    {Command::switch_on,                        0x008F, 0x0007, false, "switch on"},
    {Command::switch_on_and_enable_operation,   0x008F, 0x000F, false, "switch on + enable operation"},
    {Command::disable_voltage,                  0x0082, 0x0000, false, "disable voltage"},
    {Command::quick_stop,                       0x0086, 0x0002, false, "quick stop"},
    {Command::disable_operation,                0x008F, 0x0007, false, "disable operation"},
    {Command::enable_operation,                 0x008F, 0x000F, false, "enable operation"},
    {Command::fault_reset,                      0x0080, 0x0080, true,  "fault reset"},
}};
// clang-format on

constexpr const CommandCoding& coding_of(Command command) {
  for (const CommandCoding& coding : kCommandCodings) {
    if (coding.command == command) return coding;
  }
  return kCommandCodings[0];
}

// The canonical controlword of a command (don't-care bits 0): shutdown 0006h, switch on 0007h,
// enable operation 000Fh, disable voltage 0000h, quick stop 0002h, fault reset 0080h.
constexpr std::uint16_t controlword_of(Command command) {
  return coding_of(command).value;
}

std::string_view to_string(Command command);

// The command a controlword gives, without knowing the state. Total: every value is one of
// shutdown, switch on (= disable operation: same bits), enable operation (= switch on + enable
// operation), disable voltage, quick stop, or fault reset (bit 7 set; whether it is a rising
// edge is for the caller, who knows the previous controlword).
Command decode_controlword(std::uint16_t controlword);
// "enable operation", "switch on / disable operation", "fault reset" + the set mode bits:
// "enable operation, new set-point, halt".
std::string describe_controlword(std::uint16_t controlword);

}  // namespace drivecheck::cia402
