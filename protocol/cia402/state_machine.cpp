#include "protocol/cia402/state_machine.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivecheck::cia402 {
namespace {

// Every state pattern is decodable: its own canonical value decodes to it.
constexpr bool patterns_decode_to_themselves() {
  for (const StatePattern& pattern : kStatePatterns) {
    if (decode_statusword(pattern.value) != pattern.state) return false;
    if (&pattern_of(pattern.state) != &pattern) return false;
  }
  return true;
}
static_assert(patterns_decode_to_themselves(), "kStatePatterns: one row per State, in enum order");

// No two command rows leaving the same state accept the same controlword (checked over the
// command bits 0-3 and 7 and both values of the previous bit 7; other bits are don't care in
// every row).
constexpr bool transitions_unambiguous() {
  for (std::size_t a = 0; a < kTransitions.size(); ++a) {
    for (std::size_t b = a + 1; b < kTransitions.size(); ++b) {
      const Transition& x = kTransitions[a];
      const Transition& y = kTransitions[b];
      if (x.trigger != Trigger::command || y.trigger != Trigger::command || x.from != y.from)
        continue;
      for (std::uint16_t cw = 0; cw <= 0x00FF; ++cw) {
        for (std::uint16_t previous : {std::uint16_t{0x0000}, std::uint16_t{0x0080}}) {
          if (matches(x, cw, previous) && matches(y, cw, previous)) return false;
        }
      }
    }
  }
  return true;
}
static_assert(transitions_unambiguous(), "kTransitions: two rows from one state overlap");

// Rows with the same number are adjacent, numbers ascend 0..16.
constexpr bool transitions_ordered() {
  for (std::size_t i = 1; i < kTransitions.size(); ++i) {
    if (kTransitions[i].number < kTransitions[i - 1].number) return false;
    if (kTransitions[i].number > kTransitions[i - 1].number + 1) return false;
  }
  return kTransitions.front().number == 0 && kTransitions.back().number == 16;
}
static_assert(transitions_ordered(), "kTransitions: numbers 0..16 in order");

}  // namespace

std::string_view to_string(State state) {
  return pattern_of(state).name;
}

std::string describe_statusword(std::uint16_t statusword) {
  if (const auto state = decode_statusword(statusword)) return std::string(to_string(*state));
  return fmt::format("no valid state (statusword {:04X}h)", statusword);
}

std::span<const Transition> transitions_numbered(std::uint8_t number) {
  const auto first = std::find_if(kTransitions.begin(), kTransitions.end(),
                                  [number](const Transition& row) { return row.number == number; });
  const auto last = std::find_if(first, kTransitions.end(),
                                 [number](const Transition& row) { return row.number != number; });
  return {first, last};
}

std::string_view to_string(Command command) {
  return coding_of(command).name;
}

Command decode_controlword(std::uint16_t controlword) {
  if ((controlword & controlword::kFaultReset) != 0) return Command::fault_reset;
  if ((controlword & controlword::kEnableVoltage) == 0) return Command::disable_voltage;
  if ((controlword & controlword::kQuickStop) == 0) return Command::quick_stop;
  if ((controlword & controlword::kSwitchOn) == 0) return Command::shutdown;
  if ((controlword & controlword::kEnableOperation) == 0) return Command::switch_on;
  return Command::enable_operation;
}

std::string describe_controlword(std::uint16_t controlword) {
  std::string text;
  switch (decode_controlword(controlword)) {
    case Command::switch_on:
    case Command::disable_operation:
      text = "switch on / disable operation";
      break;
    case Command::enable_operation:
    case Command::switch_on_and_enable_operation:
      text = "enable operation";
      break;
    case Command::shutdown:
      text = "shutdown";
      break;
    case Command::disable_voltage:
      text = "disable voltage";
      break;
    case Command::quick_stop:
      text = "quick stop";
      break;
    case Command::fault_reset:
      text = "fault reset";
      break;
  }
  if ((controlword & controlword::kNewSetPoint) != 0) text += ", bit 4 (new set-point/start)";
  if ((controlword & controlword::kChangeSetImmediately) != 0)
    text += ", bit 5 (change set immediately)";
  if ((controlword & controlword::kRelative) != 0) text += ", bit 6 (relative)";
  if ((controlword & controlword::kHalt) != 0) text += ", halt";
  if ((controlword & controlword::kChangeOnSetPoint) != 0) text += ", bit 9 (change on set-point)";
  return text;
}

}  // namespace drivecheck::cia402
