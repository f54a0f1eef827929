// The power drive system (PDS) state machine of CiA 402 / IEC 61800-7-201 as data: the states
// with their statusword patterns, and transitions 0..16 with from/to state, trigger and
// controlword pattern. Drives and the conformance engine both read these tables; nothing else
// encodes the state machine.
//
// Statusword patterns (bits 6 5 3 2 1 0; x = don't care):
//   not ready to switch on   0 x 0 0 0 0   mask 004Fh value 0000h
//   switch on disabled       1 x 0 0 0 0   mask 004Fh value 0040h
//   ready to switch on       0 1 0 0 0 1   mask 006Fh value 0021h
//   switched on              0 1 0 0 1 1   mask 006Fh value 0023h
//   operation enabled        0 1 0 1 1 1   mask 006Fh value 0027h
//   quick stop active        0 0 0 1 1 1   mask 006Fh value 0007h
//   fault reaction active    0 x 1 1 1 1   mask 004Fh value 000Fh
//   fault                    0 x 1 0 0 0   mask 004Fh value 0008h
//   Sources: IRTSA Table 6 (003_111f14ab1c37c28a.txt L179-192), Festo Tab. 6.6
//   (000_33c1d912b8b6010a.txt L5426-5444). Festo deviation: by default (6510h:F0h bit 7 = 0) its
//   FAULT reads 000Fh like FAULT REACTION ACTIVE; a conformance check accepts that only where
//   the drive profile declares it.
//
// Transitions (IEC 61800-7-201 Figure "PDS state machine" and Table "transition events";
// IRTSA Table 4 L139-149 and L96-137; Festo Tab. 6.2 and L5282-5304):
//   0  start → not ready to switch on          automatic: power on / reset
//   1  not ready → switch on disabled          automatic: self-test and initialisation done
//   2  switch on disabled → ready to switch on shutdown
//   3  ready to switch on → switched on        switch on (bit 3 don't care: 000Fh = 3 then 4)
//   4  switched on → operation enabled         enable operation
//   5  operation enabled → switched on         disable operation
//   6  switched on → ready to switch on        shutdown
//   7  ready to switch on → switch on disabled quick stop or disable voltage
//   8  operation enabled → ready to switch on  shutdown
//   9  operation enabled → switch on disabled  disable voltage
//   10 switched on → switch on disabled        disable voltage or quick stop
//   11 operation enabled → quick stop active   quick stop
//   12 quick stop active → switch on disabled  disable voltage, or automatic when the quick stop
//                                              is complete (quick stop option code 1..4)
//   13 any state → fault reaction active       fault
//   14 fault reaction active → fault           automatic: fault reaction complete
//   15 fault → switch on disabled              fault reset (bit 7 rising edge)
//   16 quick stop active → operation enabled   enable operation (quick stop option code 5..8
//                                              only; IRTSA and Festo do not support it)
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

#include "protocol/cia402/controlword.hpp"

namespace drivecheck::cia402 {

enum class State : std::uint8_t {
  not_ready_to_switch_on,
  switch_on_disabled,
  ready_to_switch_on,
  switched_on,
  operation_enabled,
  quick_stop_active,
  fault_reaction_active,
  fault,
};
inline constexpr std::size_t kStateCount = 8;

struct StatePattern {
  State state;
  std::uint16_t mask;
  std::uint16_t value;
  std::string_view name;
};

// clang-format off
inline constexpr std::array<StatePattern, kStateCount> kStatePatterns{{
    {State::not_ready_to_switch_on, 0x004F, 0x0000, "not ready to switch on"},  // xxxx xxxx x0xx 0000
    {State::switch_on_disabled,     0x004F, 0x0040, "switch on disabled"},      // xxxx xxxx x1xx 0000
    {State::ready_to_switch_on,     0x006F, 0x0021, "ready to switch on"},      // xxxx xxxx x01x 0001
    {State::switched_on,            0x006F, 0x0023, "switched on"},             // xxxx xxxx x01x 0011
    {State::operation_enabled,      0x006F, 0x0027, "operation enabled"},       // xxxx xxxx x01x 0111
    {State::quick_stop_active,      0x006F, 0x0007, "quick stop active"},       // xxxx xxxx x00x 0111
    {State::fault_reaction_active,  0x004F, 0x000F, "fault reaction active"},   // xxxx xxxx x0xx 1111
    {State::fault,                  0x004F, 0x0008, "fault"},                   // xxxx xxxx x0xx 1000
}};
// clang-format on

constexpr const StatePattern& pattern_of(State state) {
  return kStatePatterns[static_cast<std::size_t>(state)];
}
// The canonical statusword of a state (don't-care bits 0): 0000h, 0040h, 0021h, 0023h, 0027h,
// 0007h, 000Fh, 0008h.
constexpr std::uint16_t statusword_of(State state) {
  return pattern_of(state).value;
}

// The state a statusword shows; nullopt = "no valid state" (e.g. 0001h: ready to switch on
// without quick stop bit 5).
constexpr std::optional<State> decode_statusword(std::uint16_t statusword) {
  for (const StatePattern& pattern : kStatePatterns) {
    if ((statusword & pattern.mask) == pattern.value) return pattern.state;
  }
  return std::nullopt;
}

std::string_view to_string(State state);
// "operation enabled", or "no valid state (statusword 0001h)".
std::string describe_statusword(std::uint16_t statusword);

enum class Trigger : std::uint8_t {
  command,    // the controlword pattern
  automatic,  // the drive does it by itself (power on, init done, reaction or quick stop done)
  fault,      // an error occurs
};

struct Transition {
  std::uint8_t number;
  std::optional<State> from;  // nullopt: 0 = from start (power on), 13 = from any state
  State to;
  Trigger trigger;
  std::optional<Command> command;  // for Trigger::command
  std::uint16_t cw_mask;           // controlword bits that must match (command only)
  std::uint16_t cw_value;
  bool rising_edge;  // bit 7 must rise (transition 15)
  std::string_view note;
};

// clang-format off
inline constexpr std::array<Transition, 20> kTransitions{{
    // 0: power on or reset → not ready to switch on (self-test, initialisation)
    {0,  std::nullopt,                  State::not_ready_to_switch_on, Trigger::automatic, std::nullopt,               0x0000, 0x0000, false, "power on or reset"},
    // 1: initialisation complete → switch on disabled (communication enabled)
    {1,  State::not_ready_to_switch_on, State::switch_on_disabled,     Trigger::automatic, std::nullopt,               0x0000, 0x0000, false, "self-test and initialisation complete"},
    // 2: shutdown 0 x 1 1 0
    {2,  State::switch_on_disabled,     State::ready_to_switch_on,     Trigger::command,   Command::shutdown,          0x0087, 0x0006, false, ""},
    // 3: switch on 0 x 1 1 1 (bit 3 don't care: 000Fh switches on, then transition 4 follows)
    {3,  State::ready_to_switch_on,     State::switched_on,            Trigger::command,   Command::switch_on,         0x0087, 0x0007, false, "000Fh continues with transition 4"},
    // 4: enable operation 0 1 1 1 1
    {4,  State::switched_on,            State::operation_enabled,      Trigger::command,   Command::enable_operation,  0x008F, 0x000F, false, ""},
    // 5: disable operation 0 0 1 1 1
    {5,  State::operation_enabled,      State::switched_on,            Trigger::command,   Command::disable_operation, 0x008F, 0x0007, false, "action per 605Ch"},
    // 6: shutdown 0 x 1 1 0
    {6,  State::switched_on,            State::ready_to_switch_on,     Trigger::command,   Command::shutdown,          0x0087, 0x0006, false, ""},
    // 7: disable voltage 0 x x 0 x
    {7,  State::ready_to_switch_on,     State::switch_on_disabled,     Trigger::command,   Command::disable_voltage,   0x0082, 0x0000, false, ""},
    // 7: quick stop 0 x 0 1 x
    {7,  State::ready_to_switch_on,     State::switch_on_disabled,     Trigger::command,   Command::quick_stop,        0x0086, 0x0002, false, ""},
    // 8: shutdown 0 x 1 1 0
    {8,  State::operation_enabled,      State::ready_to_switch_on,     Trigger::command,   Command::shutdown,          0x0087, 0x0006, false, "action per 605Bh"},
    // 9: disable voltage 0 x x 0 x
    {9,  State::operation_enabled,      State::switch_on_disabled,     Trigger::command,   Command::disable_voltage,   0x0082, 0x0000, false, "drive function disabled, motor free"},
    // 10: disable voltage 0 x x 0 x
    {10, State::switched_on,            State::switch_on_disabled,     Trigger::command,   Command::disable_voltage,   0x0082, 0x0000, false, ""},
    // 10: quick stop 0 x 0 1 x
    {10, State::switched_on,            State::switch_on_disabled,     Trigger::command,   Command::quick_stop,        0x0086, 0x0002, false, ""},
    // 11: quick stop 0 x 0 1 x
    {11, State::operation_enabled,      State::quick_stop_active,      Trigger::command,   Command::quick_stop,        0x0086, 0x0002, false, "action per 605Ah"},
    // 12: disable voltage 0 x x 0 x
    {12, State::quick_stop_active,      State::switch_on_disabled,     Trigger::command,   Command::disable_voltage,   0x0082, 0x0000, false, ""},
    // 12: quick stop complete (605Ah = 1..4)
    {12, State::quick_stop_active,      State::switch_on_disabled,     Trigger::automatic, std::nullopt,               0x0000, 0x0000, false, "quick stop complete, 605Ah 1..4"},
    // 13: fault in any state → fault reaction active
    {13, std::nullopt,                  State::fault_reaction_active,  Trigger::fault,     std::nullopt,               0x0000, 0x0000, false, "fault occurs (any state)"},
    // 14: fault reaction complete → fault
    {14, State::fault_reaction_active,  State::fault,                  Trigger::automatic, std::nullopt,               0x0000, 0x0000, false, "fault reaction complete"},
    // 15: fault reset, bit 7 0 → 1
    {15, State::fault,                  State::switch_on_disabled,     Trigger::command,   Command::fault_reset,       0x0080, 0x0080, true,  "only when the fault is gone"},
    // 16: enable operation 0 1 1 1 1 (605Ah = 5..8 only)
    {16, State::quick_stop_active,      State::operation_enabled,      Trigger::command,   Command::enable_operation,  0x008F, 0x000F, false, "only with 605Ah 5..8"},
}};
// clang-format on

// Whether a controlword (with the previous one, for the fault-reset edge) matches a row.
constexpr bool matches(const Transition& row, std::uint16_t controlword,
                       std::uint16_t previous_controlword) {
  if (row.trigger != Trigger::command) return false;
  if ((controlword & row.cw_mask) != row.cw_value) return false;
  if (row.rising_edge && (previous_controlword & controlword::kFaultReset) != 0) return false;
  return true;
}

// The command-triggered transition a controlword asks for in a state; nullopt when it asks for
// none (the drive stays). `allow_transition_16`: quick stop option code 5..8.
constexpr std::optional<Transition> commanded_transition(State from, std::uint16_t controlword,
                                                         std::uint16_t previous_controlword = 0,
                                                         bool allow_transition_16 = false) {
  for (const Transition& row : kTransitions) {
    if (row.from != from || !matches(row, controlword, previous_controlword)) continue;
    if (row.number == 16 && !allow_transition_16) continue;
    return row;
  }
  return std::nullopt;
}

// Rows of a transition number (1 or 2 rows).
std::span<const Transition> transitions_numbered(std::uint8_t number);

// Quick stop option code 605Ah: 5..8 stay in quick stop active (transition 16 possible),
// 1..4 go to switch on disabled when the stop is complete, 0 disables the drive function.
constexpr bool quick_stop_stays_active(std::int16_t option_code) {
  return option_code >= 5 && option_code <= 8;
}

}  // namespace drivecheck::cia402
