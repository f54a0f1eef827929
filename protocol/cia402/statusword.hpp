// Statusword 6041h (CiA 402 / IEC 61800-7-201 §"Statusword"): bits.
//
// Statusword, UNSIGNED16:
//   bit 0   ready to switch on            M
//   bit 1   switched on                   M
//   bit 2   operation enabled             M
//   bit 3   fault                         M
//   bit 4   voltage enabled               O
//   bit 5   quick stop (0 = quick stop active)  O
//   bit 6   switch on disabled            M
//   bit 7   warning                       O
//   bit 8   manufacturer specific (Festo: drive is moving; IRTSA: home position set)
//   bit 9   remote                        O
//   bit 10  target reached                O (csp: status toggle)
//   bit 11  internal limit active         O
//   bit 12  operation-mode specific: pp set-point acknowledge, pv speed (0), hm homing attained,
//           ip ip mode active, csp/csv/cst drive follows the command value
//   bit 13  operation-mode specific: pp/csp following error, hm homing error, pv max slippage
//   bits 14..15 manufacturer specific (Festo bit 15: drive referenced)
//   (IRTSA Table 5, 003_111f14ab1c37c28a.txt L155-177; Festo Tab. 6.7,
//   000_33c1d912b8b6010a.txt L5491-5507)
//
// The state bits (0-3, 5, 6) are decoded by state_machine.hpp.
#pragma once

#include <cstdint>
#include <string>

namespace drivecheck::cia402::statusword {

inline constexpr std::uint16_t kReadyToSwitchOn = 0x0001;
inline constexpr std::uint16_t kSwitchedOn = 0x0002;
inline constexpr std::uint16_t kOperationEnabled = 0x0004;
inline constexpr std::uint16_t kFault = 0x0008;
inline constexpr std::uint16_t kVoltageEnabled = 0x0010;
inline constexpr std::uint16_t kQuickStop = 0x0020;  // 0 = quick stop active
inline constexpr std::uint16_t kSwitchOnDisabled = 0x0040;
inline constexpr std::uint16_t kWarning = 0x0080;
inline constexpr std::uint16_t kManufacturer8 = 0x0100;
inline constexpr std::uint16_t kRemote = 0x0200;
inline constexpr std::uint16_t kTargetReached = 0x0400;
inline constexpr std::uint16_t kInternalLimitActive = 0x0800;
inline constexpr std::uint16_t kSetPointAcknowledge = 0x1000;  // pp
inline constexpr std::uint16_t kSpeed = 0x1000;                // pv: speed = 0
inline constexpr std::uint16_t kHomingAttained = 0x1000;       // hm
inline constexpr std::uint16_t kIpModeActive = 0x1000;         // ip
inline constexpr std::uint16_t kFollowsCommand = 0x1000;       // csp, csv, cst
inline constexpr std::uint16_t kFollowingError = 0x2000;       // pp, csp
inline constexpr std::uint16_t kHomingError = 0x2000;          // hm
inline constexpr std::uint16_t kManufacturerMask = 0xC000;
// The bits that encode the power drive state (see state_machine.hpp).
inline constexpr std::uint16_t kStateMask = 0x006F;

}  // namespace drivecheck::cia402::statusword
