#include "protocol/cia402/state_machine.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <map>
#include <vector>

#include "protocol/cia402/statusword.hpp"

namespace drivecheck::cia402 {
namespace {

// Every value of the bits outside `mask` (16-bit words).
std::vector<std::uint16_t> variants(std::uint16_t mask, std::uint16_t value) {
  std::vector<std::uint16_t> out;
  const auto free = static_cast<std::uint16_t>(~mask);
  // Enumerate subsets of `free`.
  std::uint16_t subset = 0;
  do {
    out.push_back(static_cast<std::uint16_t>(value | subset));
    subset = static_cast<std::uint16_t>((subset - free) & free);
  } while (subset != 0);
  return out;
}

TEST(Cia402Statusword, EveryStateDecodesWithDontCareBitsFlipped) {
  // Given each state's statusword pattern (IRTSA Table 6, 003 L179-192; Festo Tab. 6.6,
  //   000 L5426-5444)
  // When every combination of its don't-care bits is decoded
  // Then each decodes to that state
  for (const StatePattern& pattern : kStatePatterns) {
    const auto words = variants(pattern.mask, pattern.value);
    EXPECT_EQ(words.size(), std::size_t{1} << (16 - std::popcount(pattern.mask)));
    for (std::uint16_t word : words) {
      ASSERT_EQ(decode_statusword(word), pattern.state)
          << pattern.name << " statusword " << std::hex << word;
    }
  }
}

TEST(Cia402Statusword, PatternsDoNotOverlapAndInvalidWordsExist) {
  // Given every 16-bit statusword
  // When matched against all 8 patterns
  // Then no word matches two patterns, and the words matching none are "no valid state"
  int invalid = 0;
  for (unsigned word = 0; word <= 0xFFFF; ++word) {
    int hits = 0;
    for (const StatePattern& pattern : kStatePatterns) {
      hits += (word & pattern.mask) == pattern.value;
    }
    ASSERT_LE(hits, 1) << std::hex << word;
    if (hits == 0) {
      ++invalid;
      EXPECT_FALSE(decode_statusword(static_cast<std::uint16_t>(word)).has_value());
    }
  }
  EXPECT_GT(invalid, 0);
  EXPECT_EQ(describe_statusword(0x0001), "no valid state (statusword 0001h)");
}

TEST(Cia402Statusword, FestoReadBackExample) {
  // Given the Festo read-back example (000 L5446-5472): 0021h after 0006h, 0027h after 000Fh,
  //   with other bits set as a real drive shows them (voltage enabled, remote, target reached)
  // Then the states are ready to switch on and operation enabled
  EXPECT_EQ(decode_statusword(0x0231), State::ready_to_switch_on);
  EXPECT_EQ(decode_statusword(0x0637), State::operation_enabled);
  EXPECT_EQ(decode_statusword(0x0250), State::switch_on_disabled);
  EXPECT_EQ(decode_statusword(0x0218), State::fault);
  EXPECT_EQ(decode_statusword(0x021F), State::fault_reaction_active);  // Festo's default FAULT
  EXPECT_EQ(decode_statusword(0x0617), State::quick_stop_active);
  EXPECT_EQ(statusword_of(State::switched_on), 0x0023);
  EXPECT_EQ(to_string(State::quick_stop_active), "quick stop active");
}

TEST(Cia402Transitions, EveryCommandRowTriggersExactlyItself) {
  // Given each command-triggered transition row
  // When its controlword, with every don't-care bit combination, is applied in its from-state
  // Then commanded_transition returns exactly that transition number and target
  for (const Transition& row : kTransitions) {
    if (row.trigger != Trigger::command) continue;
    ASSERT_TRUE(row.from.has_value());
    for (std::uint16_t cw : variants(row.cw_mask, row.cw_value)) {
      const std::uint16_t previous = row.rising_edge ? 0x0000 : cw;
      const auto found = commanded_transition(*row.from, cw, previous, true);
      ASSERT_TRUE(found) << "transition " << int{row.number} << " cw " << std::hex << cw;
      ASSERT_EQ(found->number, row.number) << std::hex << cw;
      ASSERT_EQ(found->to, row.to);
    }
  }
}

TEST(Cia402Transitions, CanonicalCommandsPerState) {
  // Given the canonical controlwords of IRTSA Table 4 (003 L139-149)
  // When applied in each state
  // Then the transition numbers are those of CiA 402
  struct Case {
    State from;
    std::uint16_t cw;
    std::optional<int> number;
  };
  const Case cases[] = {
      {State::switch_on_disabled, 0x0006, 2},
      {State::ready_to_switch_on, 0x0007, 3},
      {State::ready_to_switch_on, 0x000F, 3},
      {State::switched_on, 0x000F, 4},
      {State::operation_enabled, 0x0007, 5},
      {State::switched_on, 0x0006, 6},
      {State::ready_to_switch_on, 0x0000, 7},
      {State::ready_to_switch_on, 0x0002, 7},
      {State::operation_enabled, 0x0006, 8},
      {State::operation_enabled, 0x0000, 9},
      {State::switched_on, 0x0000, 10},
      {State::switched_on, 0x0002, 10},
      {State::operation_enabled, 0x0002, 11},
      {State::quick_stop_active, 0x0000, 12},
      // Commands that change nothing in a state
      {State::switch_on_disabled, 0x000F, std::nullopt},
      {State::switch_on_disabled, 0x0000, std::nullopt},
      {State::operation_enabled, 0x000F, std::nullopt},
      {State::switched_on, 0x0007, std::nullopt},
      {State::quick_stop_active, 0x0002, std::nullopt},
      {State::quick_stop_active, 0x000F, std::nullopt},  // 16 needs 605Ah 5..8
      {State::fault, 0x000F, std::nullopt},
      {State::fault_reaction_active, 0x0080, std::nullopt},
      {State::not_ready_to_switch_on, 0x0006, std::nullopt},
  };
  for (const Case& c : cases) {
    const auto found = commanded_transition(c.from, c.cw, 0);
    if (c.number) {
      ASSERT_TRUE(found) << to_string(c.from) << " cw " << std::hex << c.cw;
      EXPECT_EQ(found->number, *c.number) << to_string(c.from) << " cw " << std::hex << c.cw;
    } else {
      EXPECT_FALSE(found) << to_string(c.from) << " cw " << std::hex << c.cw;
    }
  }
  const auto sixteen = commanded_transition(State::quick_stop_active, 0x000F, 0, true);
  ASSERT_TRUE(sixteen);
  EXPECT_EQ(sixteen->number, 16);
}

TEST(Cia402Transitions, FaultResetNeedsRisingEdge) {
  // Given a drive in FAULT (transition 15: bit 7 0 → 1; Festo L5365, L5413-5416)
  // When bit 7 rises, stays high, or is low
  // Then only the rising edge is transition 15
  EXPECT_EQ(commanded_transition(State::fault, 0x0080, 0x0000)->number, 15);
  EXPECT_EQ(commanded_transition(State::fault, 0x0086, 0x0006)->number, 15);
  EXPECT_FALSE(commanded_transition(State::fault, 0x0080, 0x0080));
  EXPECT_FALSE(commanded_transition(State::fault, 0x0000, 0x0080));
}

TEST(Cia402Transitions, CommandsWithBit7SetAreNoCommandsOutsideFault) {
  // Given CiA 402's coding (every command but fault reset has bit 7 = 0)
  // When 0086h (shutdown + bit 7) is applied in switch on disabled
  // Then it triggers nothing (Festo marks bit 7 don't care: a documented deviation, if any)
  EXPECT_FALSE(commanded_transition(State::switch_on_disabled, 0x0086, 0x0006));
}

TEST(Cia402Transitions, TableShape) {
  // Given the transition table
  // Then numbers 0..16 all exist, 7/10/12 have two rows, automatic rows carry no controlword,
  //      and every row's to-state is reachable
  std::map<int, int> rows;
  for (const Transition& row : kTransitions) {
    ++rows[row.number];
    if (row.trigger != Trigger::command) {
      EXPECT_EQ(row.cw_mask, 0) << int{row.number};
      EXPECT_FALSE(row.command.has_value());
    } else {
      ASSERT_TRUE(row.command.has_value());
      // The row's controlword pattern is its command's coding (3 takes bit 3 as don't care)
      const CommandCoding& coding = coding_of(*row.command);
      EXPECT_EQ(row.cw_value & coding.mask, coding.value) << int{row.number};
    }
  }
  for (int number = 0; number <= 16; ++number) {
    EXPECT_GE(rows[number], 1) << number;
    EXPECT_EQ(transitions_numbered(static_cast<std::uint8_t>(number)).size(),
              static_cast<std::size_t>(rows[number]));
  }
  EXPECT_EQ(rows[7], 2);
  EXPECT_EQ(rows[10], 2);
  EXPECT_EQ(rows[12], 2);
  EXPECT_FALSE(kTransitions[0].from.has_value());
  EXPECT_EQ(transitions_numbered(13)[0].trigger, Trigger::fault);
  EXPECT_TRUE(quick_stop_stays_active(6));
  EXPECT_FALSE(quick_stop_stays_active(2));
}

TEST(Cia402Transitions, WalkToOperationEnabledAndBack) {
  // Given a drive in switch on disabled, statusword as the state table gives it
  // When the master sends 0006h, 0007h, 000Fh, then 0002h and 0000h
  // Then the states follow 2, 3, 4, 11, 12 and the statusword of each state decodes to it
  State state = State::switch_on_disabled;
  const std::pair<std::uint16_t, State> steps[] = {
      {0x0006, State::ready_to_switch_on}, {0x0007, State::switched_on},
      {0x000F, State::operation_enabled},  {0x0002, State::quick_stop_active},
      {0x0000, State::switch_on_disabled},
  };
  std::uint16_t previous = 0;
  for (const auto& [cw, expected] : steps) {
    const auto t = commanded_transition(state, cw, previous);
    ASSERT_TRUE(t) << std::hex << cw;
    state = t->to;
    EXPECT_EQ(state, expected);
    EXPECT_EQ(decode_statusword(statusword_of(state) | statusword::kVoltageEnabled), state);
    previous = cw;
  }
}

TEST(Cia402Controlword, DecodeIsTotal) {
  // Given every controlword
  // When decoded without a state
  // Then each maps to one of six commands consistent with the coding table
  for (unsigned cw = 0; cw <= 0xFFFF; ++cw) {
    const Command command = decode_controlword(static_cast<std::uint16_t>(cw));
    const CommandCoding& coding = coding_of(command);
    EXPECT_EQ(cw & coding.mask, coding.value) << std::hex << cw;
  }
  EXPECT_EQ(decode_controlword(0x0006), Command::shutdown);
  EXPECT_EQ(decode_controlword(0x0007), Command::switch_on);
  EXPECT_EQ(decode_controlword(0x000F), Command::enable_operation);
  EXPECT_EQ(decode_controlword(0x000D), Command::disable_voltage);
  EXPECT_EQ(decode_controlword(0x000B), Command::quick_stop);
  EXPECT_EQ(decode_controlword(0x0080), Command::fault_reset);
  EXPECT_EQ(controlword_of(Command::enable_operation), 0x000F);
  EXPECT_EQ(describe_controlword(0x001F), "enable operation, bit 4 (new set-point/start)");
  EXPECT_EQ(describe_controlword(0x0107), "switch on / disable operation, halt");
  // Festo example write 03E8h (000 L749-752): bits 3, 5, 6, 7, 8, 9 set → fault reset first
  EXPECT_EQ(decode_controlword(0x03E8), Command::fault_reset);
}

}  // namespace
}  // namespace drivecheck::cia402
