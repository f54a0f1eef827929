// The reference drive's CiA 402 power drive system (reference_drive/power_drive_system.hpp),
// driven cycle by cycle with a first-order axis (reference_drive/ramp_axis.hpp).
//
// References: CiA 402 = IEC 61800-7-201 / CiA 402-2 (state machine, option codes 605Ah..605Eh,
// 6007h, modes 6060h/6061h/6502h). Manual lines: 000 = Festo CMMP-AS
// (/work/shared/manuals/000_33c1d912b8b6010a.txt), 003 = IRTSA CU2115
// (003_111f14ab1c37c28a.txt), 002 = Kollmorgen S300/S700 (002_953174ea6ca45cdb.txt).
#include "reference_drive/power_drive_system.hpp"

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia402/controlword.hpp"
#include "protocol/cia402/state_machine.hpp"
#include "reference_drive/ramp_axis.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;
using cia402::State;

constexpr State kNotReady = State::not_ready_to_switch_on;
constexpr State kSod = State::switch_on_disabled;
constexpr State kRtso = State::ready_to_switch_on;
constexpr State kSo = State::switched_on;
constexpr State kOe = State::operation_enabled;
constexpr State kQsa = State::quick_stop_active;
constexpr State kFra = State::fault_reaction_active;
constexpr State kFault = State::fault;
constexpr std::array<State, 8> kAllStates{kNotReady, kSod, kRtso, kSo, kOe, kQsa, kFra, kFault};

// The exact statusword of each state with remote (bit 9) = 1, no warning, no mode bits:
// state bits per CiA 402 (Festo Tab. 6.6, 000 L5426-5444; IRTSA Table 6, 003 L179-192), bit 4
// voltage enabled in SO/OE/QSA/FRA, bit 5 quick stop 1 in RTSO/SO/OE and 0 in QSA.
// Written out, not computed: these are the values a master reads.
constexpr std::uint16_t statusword_in(State state) {
  switch (state) {
    case State::not_ready_to_switch_on:
      return 0x0200;
    case State::switch_on_disabled:
      return 0x0240;
    case State::ready_to_switch_on:
      return 0x0221;
    case State::switched_on:
      return 0x0233;
    case State::operation_enabled:
      return 0x0237;  // Kollmorgen's example reads 0237h too (002 digest L1140)
    case State::quick_stop_active:
      return 0x0217;
    case State::fault_reaction_active:
      return 0x021F;
    case State::fault:
      return 0x0208;
  }
  return 0xFFFF;
}

// The decelerations of the tests (user units/s²) and the times they take from 1000 units/s.
constexpr std::uint32_t kSlowDown = 10000;       // 6084h: 100 ms
constexpr std::uint32_t kQuickStop = 50000;      // 6085h: 20 ms
constexpr std::uint32_t kCurrentLimit = 200000;  // axis: 5 ms
constexpr std::uint32_t kVoltageLimit = 25000;   // axis: 40 ms
constexpr std::int32_t kSpeed = 1000;

PowerDriveConfig test_config() {
  PowerDriveConfig config;
  config.slow_down_deceleration = kSlowDown;
  config.quick_stop_deceleration = kQuickStop;
  return config;
}

RampAxisConfig test_axis() {
  RampAxisConfig config;
  config.acceleration = 0;
  config.coast_deceleration = 1000;
  config.current_limit_deceleration = kCurrentLimit;
  config.voltage_limit_deceleration = kVoltageLimit;
  return config;
}

class RecordingReporter final : public FaultReporter {
 public:
  void fault_raised(std::uint16_t code, std::uint8_t bits) override {
    raised.emplace_back(code, bits);
  }
  void fault_cleared(std::uint16_t code) override { cleared.push_back(code); }
  std::vector<std::pair<std::uint16_t, std::uint8_t>> raised;
  std::vector<std::uint16_t> cleared;
};

class FixedModeStatus final : public ModeStatus {
 public:
  std::uint16_t statusword_bits(State, std::int8_t) const override { return bits; }
  std::uint16_t bits = 0;
};

// One drive: axis + PDS, stepped every `cycle` (the axis moves first, then the PDS looks).
class Rig {
 public:
  explicit Rig(PowerDriveConfig config = test_config(), can::Duration cycle = 1ms)
      : cycle_(cycle), axis(test_axis()), pds(axis, config, &reporter, &modes) {
    pds.set_transition_observer([this](const TransitionRecord& r) { transitions.push_back(r); });
    pds.power_on(now);
  }
  Rig(const Rig&) = delete;
  Rig& operator=(const Rig&) = delete;

  void tick() {
    now += cycle_;
    axis.advance(cycle_);
    pds.step(now);
  }
  void ticks(int n) {
    for (int i = 0; i < n; ++i)
      tick();
  }
  void command(std::uint16_t controlword) {
    pds.set_controlword(controlword);
    tick();
  }
  // Ticks until the state is `target`; the time that took, nullopt after `limit`.
  std::optional<can::Duration> run_until(State target, can::Duration limit = 2s) {
    const can::TimePoint start = now;
    while (now - start < limit) {
      tick();
      if (pds.state() == target) return now - start;
    }
    return std::nullopt;
  }
  void set_option(OptionCode code, std::int16_t value) {
    ASSERT_TRUE(pds.set_option_code(code, value)) << static_cast<int>(code) << "=" << value;
  }

  // The canonical paths (Festo read-back example, 000 L5446-5472; IRTSA 003 L139-149).
  void to_switch_on_disabled() { tick(); }
  void to_ready() {
    to_switch_on_disabled();
    command(0x0006);  // shutdown
  }
  void to_switched_on() {
    to_ready();
    command(0x0007);  // switch on
  }
  void to_operation_enabled(std::int32_t velocity = 0) {
    to_switched_on();
    axis.set_velocity_set_point(velocity);
    command(0x000F);            // enable operation
    if (velocity != 0) tick();  // the axis reaches the set-point in the next cycle
  }
  void to_quick_stop_active(std::int32_t velocity = kSpeed) {
    to_operation_enabled(velocity);
    command(0x000B);  // quick stop: bit 2 = 0, bits 0, 1, 3 = 1
  }
  void to_fault_reaction_active() {
    to_operation_enabled(kSpeed);
    pds.raise_fault(faults::kFollowingError);
    tick();
  }
  void to_fault() {
    to_fault_reaction_active();
    ASSERT_TRUE(run_until(kFault));
  }

  can::Duration cycle_;
  can::TimePoint now{};
  RampAxis axis;
  RecordingReporter reporter;
  FixedModeStatus modes;
  PowerDriveSystem pds;
  std::vector<TransitionRecord> transitions;
};

// A rig in `state` by its canonical path. NOT READY needs a self-test time (1 s); QUICK STOP
// ACTIVE and FAULT REACTION ACTIVE are entered with the axis at 1000 units/s so that they last
// (605Ah = 2 / 605Eh = 2: 20 ms); FAULT has its cause cleared.
std::unique_ptr<Rig> rig_in(State state) {
  PowerDriveConfig config = test_config();
  if (state == kNotReady) config.self_test = 1s;
  auto rig = std::make_unique<Rig>(config);
  switch (state) {
    case State::not_ready_to_switch_on:
      rig->tick();
      break;
    case State::switch_on_disabled:
      rig->to_switch_on_disabled();
      break;
    case State::ready_to_switch_on:
      rig->to_ready();
      break;
    case State::switched_on:
      rig->to_switched_on();
      break;
    case State::operation_enabled:
      rig->to_operation_enabled();
      break;
    case State::quick_stop_active:
      rig->to_quick_stop_active();
      break;
    case State::fault_reaction_active:
      rig->to_fault_reaction_active();
      break;
    case State::fault:
      rig->to_fault();
      rig->pds.clear_fault_cause(faults::kFollowingError.code);
      break;
  }
  EXPECT_EQ(rig->pds.state(), state);
  return rig;
}

// ---------------------------------------------------------------------------------------------
// Transitions 0..16

struct TransitionCase {
  std::uint8_t number;
  State from;
  std::uint16_t controlword;
  State to;
  const char* name;
};

// Each commanded transition by its controlword (IRTSA Table 4, 003 L139-149; Festo Tab. 6.2,
// 000 L5282-5304; CiA 402 Table "transition events"), also with don't-care bits set.
// clang-format off
const TransitionCase kTransitionCases[] = {
    {2,  kSod,  0x0006, kRtso, "Transition2Shutdown"},
    {2,  kSod,  0x000E, kRtso, "Transition2ShutdownBit3Set"},  // Festo L5249: bit 3 irrelevant
    {3,  kRtso, 0x0007, kSo,   "Transition3SwitchOn"},
    {3,  kRtso, 0x000F, kSo,   "Transition3SwitchOnAndEnable"},  // 4 follows next cycle
    {4,  kSo,   0x000F, kOe,   "Transition4EnableOperation"},
    {5,  kOe,   0x0007, kSo,   "Transition5DisableOperation"},
    {6,  kSo,   0x0006, kRtso, "Transition6Shutdown"},
    {7,  kRtso, 0x0000, kSod,  "Transition7DisableVoltage"},
    {7,  kRtso, 0x0002, kSod,  "Transition7QuickStop"},
    {8,  kOe,   0x0006, kRtso, "Transition8Shutdown"},
    {9,  kOe,   0x0000, kSod,  "Transition9DisableVoltage"},
    {9,  kOe,   0x000D, kSod,  "Transition9DisableVoltageBit1Clear"},  // Festo vector 5: 000Dh
    {10, kSo,   0x0000, kSod,  "Transition10DisableVoltage"},
    {10, kSo,   0x0002, kSod,  "Transition10QuickStop"},
    {11, kOe,   0x0002, kQsa,  "Transition11QuickStop"},
    {11, kOe,   0x000B, kQsa,  "Transition11QuickStopBits013Set"},
    {12, kQsa,  0x0000, kSod,  "Transition12DisableVoltage"},
    {15, kFault, 0x0080, kSod, "Transition15FaultReset"},
    {16, kQsa,  0x000F, kOe,   "Transition16EnableOperation"},  // with 605Ah = 6
};
// clang-format on

class PdsTransition : public testing::TestWithParam<TransitionCase> {};

TEST_P(PdsTransition, ControlwordTakesItFromItsStateWithExactStatuswords) {
  const TransitionCase& c = GetParam();
  // Given the drive in the from-state (for 16: quick stop option code 6, CiA 402: 16 only with
  //   605Ah 5..8)
  std::unique_ptr<Rig> rig;
  if (c.number == 16) {
    rig = std::make_unique<Rig>();
    rig->set_option(OptionCode::quick_stop, 6);
    rig->to_quick_stop_active();
  } else {
    rig = rig_in(c.from);
  }
  ASSERT_EQ(rig->pds.state(), c.from);
  EXPECT_EQ(rig->pds.statusword(), statusword_in(c.from));
  // When the controlword is written and one drive cycle runs
  rig->command(c.controlword);
  // Then the drive is in the to-state, by that transition, with the to-state's exact statusword
  EXPECT_EQ(rig->pds.state(), c.to) << cia402::to_string(rig->pds.state());
  EXPECT_EQ(rig->pds.statusword(), statusword_in(c.to));
  ASSERT_TRUE(rig->pds.last_transition());
  EXPECT_EQ(rig->pds.last_transition()->number, c.number);
  EXPECT_EQ(rig->pds.last_transition()->from, c.from);
  EXPECT_EQ(rig->pds.last_transition()->at, rig->now);
}

INSTANTIATE_TEST_SUITE_P(EveryCommandedTransition, PdsTransition,
                         testing::ValuesIn(kTransitionCases),
                         [](const testing::TestParamInfo<TransitionCase>& param_info) {
                           return std::string(param_info.param.name);
                         });

TEST(PdsTransitionTable, EveryCommandRowOfTheTableHasACase) {
  // Given the shared transition table (protocol/cia402/state_machine.hpp)
  // When its command rows are compared with the cases above
  // Then every row's number and from-state has a case with a controlword the row accepts
  for (const cia402::Transition& row : cia402::kTransitions) {
    if (row.trigger != cia402::Trigger::command) continue;
    bool covered = false;
    for (const TransitionCase& c : kTransitionCases) {
      covered |= c.number == row.number && c.from == row.from &&
                 cia402::matches(row, c.controlword, 0x0000);
    }
    EXPECT_TRUE(covered) << "transition " << int{row.number} << " " << row.note;
  }
}

TEST(PdsAutomatic, Transition0And1AfterTheSelfTest) {
  // Given a drive with a 50 ms self-test, powered on at t = 0 (transition 0), and a master
  //   that writes shutdown at once
  PowerDriveConfig config = test_config();
  config.self_test = 50ms;
  Rig rig(config);
  ASSERT_TRUE(rig.pds.last_transition());
  EXPECT_EQ(rig.pds.last_transition()->number, 0);
  EXPECT_EQ(rig.pds.statusword(), 0x0200);
  rig.pds.set_controlword(0x0006);
  // When cycles run
  // Then it stays NOT READY TO SWITCH ON (commands ignored) for 49 ms, transition 1 comes at
  //   exactly 50 ms (Festo L5208, L5260-5263: self-test, then SWITCH ON DISABLED), and the held
  //   shutdown takes transition 2 in the cycle after
  rig.ticks(49);
  EXPECT_EQ(rig.pds.state(), kNotReady);
  EXPECT_EQ(rig.pds.statusword(), 0x0200);
  rig.tick();
  EXPECT_EQ(rig.pds.state(), kSod);
  EXPECT_EQ(rig.pds.last_transition()->number, 1);
  EXPECT_EQ(rig.now.time_since_epoch(), 50ms);
  rig.tick();
  EXPECT_EQ(rig.pds.state(), kRtso);
}

TEST(PdsAutomatic, SwitchOnAndEnableTakesTransitions3Then4) {
  // Given READY TO SWITCH ON
  auto rig = rig_in(kRtso);
  // When 000Fh is written (Festo L5249-5250: transitions 3 and 4 combined)
  rig->command(0x000F);
  // Then transition 3 runs in this cycle and 4 in the next: one transition per cycle
  EXPECT_EQ(rig->pds.state(), kSo);
  rig->tick();
  EXPECT_EQ(rig->pds.state(), kOe);
  EXPECT_EQ(rig->pds.last_transition()->number, 4);
}

TEST(PdsAutomatic, Transition13FromEveryStateButTheFaultStates) {
  // Given the drive in each state
  for (State state : kAllStates) {
    SCOPED_TRACE(cia402::to_string(state));
    auto rig = rig_in(state);
    const std::size_t raised_before = rig->reporter.raised.size();
    // When an over-current occurs
    rig->pds.raise_fault(faults::kOverCurrent);
    rig->tick();
    // Then it is reported (EMCY 2310h, 1001h bit 1), 603Fh = 2310h, and the drive goes to FAULT
    //   REACTION ACTIVE by transition 13; in FAULT REACTION ACTIVE and FAULT it stays
    ASSERT_EQ(rig->reporter.raised.size(), raised_before + 1);
    EXPECT_EQ(rig->reporter.raised.back(),
              std::make_pair(std::uint16_t{0x2310}, std::uint8_t{0x02}));
    EXPECT_EQ(rig->pds.error_code(), 0x2310);
    if (state == kFra || state == kFault) {
      EXPECT_EQ(rig->pds.state(), state);
    } else {
      EXPECT_EQ(rig->pds.state(), kFra);
      EXPECT_EQ(rig->pds.statusword(), 0x021F);
      EXPECT_EQ(rig->pds.last_transition()->number, 13);
    }
  }
}

TEST(PdsAutomatic, Transition14WhenTheFaultReactionIsComplete) {
  // Given OPERATION ENABLED at 1000 units/s, 605Eh = 2 (quick stop ramp, 6085h = 50000)
  Rig rig;
  rig.to_operation_enabled(kSpeed);
  // When a following error occurs
  rig.pds.raise_fault(faults::kFollowingError);
  rig.tick();
  // Then FAULT REACTION ACTIVE lasts until standstill (20 ms), then FAULT (0208h) with the
  //   drive function off
  EXPECT_EQ(rig.pds.state(), kFra);
  EXPECT_EQ(rig.run_until(kFault), 20ms);
  EXPECT_EQ(rig.pds.statusword(), 0x0208);
  EXPECT_EQ(rig.pds.last_transition()->number, 14);
  EXPECT_EQ(rig.axis.motion(), AxisMotion::free);
}

TEST(PdsAutomatic, FaultWhileTheDriveFunctionIsOffCompletesInOneCycle) {
  // Given SWITCHED ON (drive function disabled)
  auto rig = rig_in(kSo);
  // When a fault occurs
  rig->pds.raise_fault(faults::kDcLinkOverVoltage);
  rig->tick();
  // Then FAULT REACTION ACTIVE for one cycle, then FAULT: there is nothing to stop
  EXPECT_EQ(rig->pds.state(), kFra);
  rig->tick();
  EXPECT_EQ(rig->pds.state(), kFault);
}

// ---------------------------------------------------------------------------------------------
// Commands that must not change the state: 8 commands × 8 states

TEST(PdsCommandMatrix, EveryCommandInEveryStateAsTheTableSays) {
  // Expected state after one cycle with each command's canonical controlword (controlword.hpp
  // kCommandCodings order: shutdown 0006h, switch on 0007h, switch on + enable 000Fh, disable
  // voltage 0000h, quick stop 0002h, disable operation 0007h, enable operation 000Fh, fault
  // reset 0→0080h), from IRTSA Table 4 (003 L139-149) and CiA 402; S = stays.
  // QUICK STOP ACTIVE with 605Ah = 2: enable operation is ignored (no transition 16).
  constexpr std::optional<State> S = std::nullopt;
  // clang-format off
  const std::array<std::array<std::optional<State>, 8>, 8> expected{{
      //          shutdown switch on  sw on+en   dis volt  quick st  dis op    enable op  fault reset
      /* NRTSO */ {S,       S,         S,         S,        S,        S,        S,         S},
      /* SOD   */ {kRtso,   S,         S,         S,        S,        S,        S,         S},
      /* RTSO  */ {S,       kSo,       kSo,       kSod,     kSod,     kSo,      kSo,       S},
      /* SO    */ {kRtso,   S,         kOe,       kSod,     kSod,     S,        kOe,       S},
      /* OE    */ {kRtso,   kSo,       S,         kSod,     kQsa,     kSo,      S,         S},
      /* QSA   */ {S,       S,         S,         kSod,     S,        S,        S,         S},
      /* FRA   */ {S,       S,         S,         S,        S,        S,        S,         S},
      /* FAULT */ {S,       S,         S,         S,        S,        S,        S,         kSod},
  }};
  // clang-format on
  for (State state : kAllStates) {
    for (std::size_t c = 0; c < cia402::kCommandCodings.size(); ++c) {
      const cia402::CommandCoding& coding = cia402::kCommandCodings[c];
      SCOPED_TRACE(std::string(cia402::to_string(state)) + " + " + std::string(coding.name));
      const std::optional<State> want = expected[static_cast<std::size_t>(state)][c];
      // The literal expectation agrees with the shared table (the edge given for fault reset).
      const auto row = cia402::commanded_transition(state, coding.value, 0x0000, false);
      ASSERT_EQ(row ? std::optional<State>(row->to) : std::nullopt, want);

      // Given the drive in `state`
      auto rig = rig_in(state);
      const std::uint16_t statusword = rig->pds.statusword();
      const std::uint64_t axis_commands = rig->axis.commands();
      // When the command is written (fault reset: 0080h after a controlword with bit 7 = 0)
      rig->command(coding.value);
      // Then the state is the expected one; where it stays, the statusword is unchanged and
      //   the axis got no command ("nothing moves")
      if (want) {
        EXPECT_EQ(rig->pds.state(), *want);
      } else {
        EXPECT_EQ(rig->pds.state(), state);
        EXPECT_EQ(rig->pds.statusword(), statusword);
        EXPECT_EQ(rig->axis.commands(), axis_commands);
      }
    }
  }
}

TEST(PdsCommandMatrix, QuickStopStayOptionsAllowOnlyEnableOperation) {
  // Given QUICK STOP ACTIVE with 605Ah = 6 (stay in quick stop active), at standstill
  for (std::uint16_t controlword :
       {std::uint16_t{0x0006}, std::uint16_t{0x0007}, std::uint16_t{0x0002}, std::uint16_t{0x000B},
        std::uint16_t{0x0080}, std::uint16_t{0x000F}, std::uint16_t{0x0000}}) {
    SCOPED_TRACE(controlword);
    Rig rig;
    rig.set_option(OptionCode::quick_stop, 6);
    rig.to_quick_stop_active();
    ASSERT_TRUE(rig.run_until(State::switch_on_disabled, 100ms) == std::nullopt);
    ASSERT_EQ(rig.pds.state(), kQsa);
    // When a controlword is written
    rig.command(controlword);
    // Then only enable operation (16) and disable voltage (12) leave the state
    if (controlword == 0x000F) {
      EXPECT_EQ(rig.pds.state(), kOe);
      EXPECT_EQ(rig.pds.last_transition()->number, 16);
      EXPECT_EQ(rig.axis.motion(), AxisMotion::following);
    } else if (controlword == 0x0000) {
      EXPECT_EQ(rig.pds.state(), kSod);
    } else {
      EXPECT_EQ(rig.pds.state(), kQsa);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Fault reset: rising edge of bit 7 only (Festo L5365, L5413-5416; CiA 402 transition 15)

TEST(PdsFaultReset, LevelHeldHighDoesNothingMore) {
  // Given FAULT with the cause still present, and a master writing 0080h
  Rig rig;
  rig.to_fault();
  rig.command(0x0080);
  // Then the reset while the cause is present keeps FAULT (Festo [ctx] L1260-1273), and no
  //   error is acknowledged
  EXPECT_EQ(rig.pds.state(), kFault);
  EXPECT_TRUE(rig.reporter.cleared.empty());
  // When the cause goes away and 0080h stays written for 100 cycles
  rig.pds.clear_fault_cause(faults::kFollowingError.code);
  rig.ticks(100);
  // Then the level does nothing: still FAULT
  EXPECT_EQ(rig.pds.state(), kFault);
  // When bit 7 falls and rises again
  rig.command(0x0000);
  EXPECT_EQ(rig.pds.state(), kFault);
  rig.command(0x0080);
  // Then transition 15: SWITCH ON DISABLED, the fault acknowledged (EMCY 0000h side), 603Fh 0
  EXPECT_EQ(rig.pds.state(), kSod);
  EXPECT_EQ(rig.pds.last_transition()->number, 15);
  EXPECT_EQ(rig.reporter.cleared, std::vector<std::uint16_t>{0x8611});
  EXPECT_EQ(rig.pds.error_code(), 0x0000);
  EXPECT_TRUE(rig.pds.unacknowledged_faults().empty());
}

TEST(PdsFaultReset, ACyclicallyRewrittenLevelIsNoEdge) {
  // Given FAULT with the cause present, and a master whose cyclic RPDO writes 0080h every cycle
  Rig rig;
  rig.to_fault();
  rig.command(0x0080);
  // When the cause goes away and 0080h keeps being written every cycle
  rig.pds.clear_fault_cause(faults::kFollowingError.code);
  for (int i = 0; i < 20; ++i)
    rig.command(0x0080);
  // Then each write is the same level, not a new edge: still FAULT
  EXPECT_EQ(rig.pds.state(), kFault);
}

TEST(PdsFaultReset, APulseShorterThanACycleCounts) {
  // Given FAULT, cause gone, controlword 0000h
  auto rig = rig_in(kFault);
  rig->command(0x0000);
  // When 0080h and 0000h are both written between two cycles
  rig->pds.set_controlword(0x0080);
  rig->pds.set_controlword(0x0000);
  rig->tick();
  // Then the latched edge resets the fault
  EXPECT_EQ(rig->pds.state(), kSod);
}

TEST(PdsFaultReset, AnEdgeBeforeFaultIsNotRemembered) {
  // Given FAULT REACTION ACTIVE (the reaction still running)
  Rig rig;
  rig.to_fault_reaction_active();
  rig.pds.clear_fault_cause(faults::kFollowingError.code);
  // When the fault reset edge comes during the reaction, and bit 7 is held into FAULT
  rig.command(0x0080);
  EXPECT_EQ(rig.pds.state(), kFra);
  ASSERT_TRUE(rig.run_until(kFault));
  rig.ticks(5);
  // Then FAULT stays: the edge came in a state without transition 15
  EXPECT_EQ(rig.pds.state(), kFault);
}

TEST(PdsFaultReset, AcknowledgesEveryFaultAndANewFaultInFaultIsReported) {
  // Given FAULT after a following error, then a limit switch fault while in FAULT
  Rig rig;
  rig.to_fault();
  rig.pds.raise_fault(faults::kLimitSwitch);
  rig.tick();
  // Then the new fault is reported (EMCY 8612h), 603Fh shows the newest, the state stays
  EXPECT_EQ(rig.pds.state(), kFault);
  EXPECT_EQ(rig.pds.error_code(), 0x8612);
  ASSERT_EQ(rig.reporter.raised.size(), 2u);
  // When both causes go and the fault is reset
  rig.pds.clear_fault_cause(0x8611);
  rig.pds.clear_fault_cause(0x8612);
  rig.command(0x0000);
  rig.command(0x0080);
  // Then both are acknowledged
  EXPECT_EQ(rig.pds.state(), kSod);
  EXPECT_EQ(rig.reporter.cleared, (std::vector<std::uint16_t>{0x8611, 0x8612}));
}

TEST(PdsFaultReset, ACauseStillPresentAfterResetKeepsFault) {
  // Given FAULT with two causes, one of them gone
  Rig rig;
  rig.to_operation_enabled(kSpeed);
  rig.pds.raise_fault(faults::kOverCurrent);
  rig.pds.raise_fault(faults::kMotorOverTemperature);
  ASSERT_TRUE(rig.run_until(kFault));
  rig.pds.clear_fault_cause(faults::kOverCurrent.code);
  // When the fault reset edge comes
  rig.command(0x0000);
  rig.command(0x0080);
  // Then FAULT stays and nothing is acknowledged
  EXPECT_EQ(rig.pds.state(), kFault);
  EXPECT_TRUE(rig.reporter.cleared.empty());
  EXPECT_TRUE(rig.pds.fault_cause_present());
}

// ---------------------------------------------------------------------------------------------
// Option codes

struct ReactionCase {
  std::int16_t value;
  std::optional<can::Duration> time;  // to the end state from 1000 units/s; nullopt: 1 cycle
  std::uint32_t deceleration;         // of the stop (0: drive function disabled, coasting)
};

// 605Ah quick stop (CiA 402): the stop, then SWITCH ON DISABLED (0..4) or stay (5..8).
// clang-format off
const ReactionCase kQuickStopCases[] = {
    {0, std::nullopt, 0},               // disable drive function
    {1, 100ms, kSlowDown},              // slow down ramp 6084h
    {2, 20ms,  kQuickStop},             // quick stop ramp 6085h
    {3, 5ms,   kCurrentLimit},          // current limit
    {4, 40ms,  kVoltageLimit},          // voltage limit
    {5, 100ms, kSlowDown},              // as 1..4, stay in QUICK STOP ACTIVE
    {6, 20ms,  kQuickStop},
    {7, 5ms,   kCurrentLimit},
    {8, 40ms,  kVoltageLimit},
};
// clang-format on

class PdsQuickStopOption : public testing::TestWithParam<ReactionCase> {};

TEST_P(PdsQuickStopOption, StopsAsTheOptionSaysAndEndsInItsState) {
  const ReactionCase& c = GetParam();
  // Given OPERATION ENABLED at 1000 units/s with 605Ah = value
  Rig rig;
  rig.set_option(OptionCode::quick_stop, c.value);
  rig.to_operation_enabled(kSpeed);
  // When quick stop is commanded (transition 11)
  rig.command(0x000B);
  ASSERT_EQ(rig.pds.state(), kQsa);
  EXPECT_EQ(rig.pds.statusword(), 0x0217);
  EXPECT_EQ(rig.axis.stop_deceleration(), c.deceleration);
  if (c.value == 0) {
    // Then 0: the drive function is off at once (motor free), transition 12 in the next cycle
    EXPECT_EQ(rig.axis.motion(), AxisMotion::free);
    rig.tick();
    EXPECT_EQ(rig.pds.state(), kSod);
    EXPECT_GT(rig.axis.velocity(), 0.0);  // still running down freely
    return;
  }
  if (c.value <= 4) {
    // Then 1..4: SWITCH ON DISABLED (transition 12) exactly when the axis stands still
    EXPECT_EQ(rig.run_until(kSod), c.time);
    EXPECT_EQ(rig.pds.last_transition()->number, 12);
    EXPECT_EQ(rig.axis.motion(), AxisMotion::free);
    return;
  }
  // Then 5..8: standstill after the same time, but QUICK STOP ACTIVE stays (holding)
  const can::TimePoint start = rig.now;
  while (!rig.axis.is_stopped() && rig.now - start < 1s)
    rig.tick();
  EXPECT_EQ(rig.now - start, *c.time);
  rig.ticks(200);
  EXPECT_EQ(rig.pds.state(), kQsa);
  EXPECT_EQ(rig.axis.motion(), AxisMotion::stopping);
  // And enable operation returns to OPERATION ENABLED (16)
  rig.command(0x000F);
  EXPECT_EQ(rig.pds.state(), kOe);
}

INSTANTIATE_TEST_SUITE_P(EveryValue, PdsQuickStopOption, testing::ValuesIn(kQuickStopCases),
                         [](const testing::TestParamInfo<ReactionCase>& param_info) {
                           return "Value" + std::to_string(param_info.param.value);
                         });

// 605Eh fault reaction (CiA 402): 0 disable drive function, 1..4 stops, then FAULT.
// clang-format off
const ReactionCase kFaultReactionCases[] = {
    {0, std::nullopt, 0},
    {1, 100ms, kSlowDown},
    {2, 20ms,  kQuickStop},
    {3, 5ms,   kCurrentLimit},
    {4, 40ms,  kVoltageLimit},
};
// clang-format on

class PdsFaultReactionOption : public testing::TestWithParam<ReactionCase> {};

TEST_P(PdsFaultReactionOption, ReactsThenFault) {
  const ReactionCase& c = GetParam();
  // Given OPERATION ENABLED at 1000 units/s with 605Eh = value
  Rig rig;
  rig.set_option(OptionCode::fault_reaction, c.value);
  rig.to_operation_enabled(kSpeed);
  // When a fault occurs
  rig.pds.raise_fault(faults::kFollowingError);
  rig.tick();
  // Then FAULT REACTION ACTIVE with the option's stop, FAULT when it is complete
  ASSERT_EQ(rig.pds.state(), kFra);
  EXPECT_EQ(rig.axis.stop_deceleration(), c.deceleration);
  EXPECT_EQ(rig.run_until(kFault), c.time.value_or(1ms));
  EXPECT_EQ(rig.axis.motion(), AxisMotion::free);
  if (c.value == 0) {
    EXPECT_GT(rig.axis.velocity(), 0.0);  // free to rotate
  }
}

INSTANTIATE_TEST_SUITE_P(EveryValue, PdsFaultReactionOption, testing::ValuesIn(kFaultReactionCases),
                         [](const testing::TestParamInfo<ReactionCase>& param_info) {
                           return "Value" + std::to_string(param_info.param.value);
                         });

// 605Dh halt (CiA 402): 1 slow down ramp, 2 quick stop ramp, 3 current limit, 4 voltage limit.
// clang-format off
const ReactionCase kHaltCases[] = {
    {1, 100ms, kSlowDown},
    {2, 20ms,  kQuickStop},
    {3, 5ms,   kCurrentLimit},
    {4, 40ms,  kVoltageLimit},
};
// clang-format on

class PdsHaltOption : public testing::TestWithParam<ReactionCase> {};

TEST_P(PdsHaltOption, StopsAndStaysInOperationEnabled) {
  const ReactionCase& c = GetParam();
  // Given OPERATION ENABLED at 1000 units/s with 605Dh = value
  Rig rig;
  rig.set_option(OptionCode::halt, c.value);
  rig.to_operation_enabled(kSpeed);
  // When halt (bit 8) is set: 010Fh (Kollmorgen "Zwischenstopp", 002 digest L881)
  rig.command(0x010F);
  // Then the axis stops with the option's deceleration in the option's time; the state stays
  //   OPERATION ENABLED (0237h)
  EXPECT_TRUE(rig.pds.halted());
  EXPECT_EQ(rig.axis.stop_deceleration(), c.deceleration);
  const can::TimePoint start = rig.now;
  while (!rig.axis.is_stopped() && rig.now - start < 1s)
    rig.tick();
  EXPECT_EQ(rig.now - start, *c.time);
  rig.ticks(10);
  EXPECT_EQ(rig.pds.state(), kOe);
  EXPECT_EQ(rig.pds.statusword(), 0x0237);
  // When halt is released
  rig.command(0x000F);
  rig.tick();
  // Then the axis follows its set-point again
  EXPECT_FALSE(rig.pds.halted());
  EXPECT_EQ(rig.axis.motion(), AxisMotion::following);
  EXPECT_EQ(rig.axis.velocity(), kSpeed);
}

INSTANTIATE_TEST_SUITE_P(EveryValue, PdsHaltOption, testing::ValuesIn(kHaltCases),
                         [](const testing::TestParamInfo<ReactionCase>& param_info) {
                           return "Value" + std::to_string(param_info.param.value);
                         });

TEST(PdsHaltOption, EnableOperationWithHaltSetDoesNotStartMoving) {
  // Given SWITCHED ON, a set-point of 1000 units/s
  auto rig = rig_in(kSo);
  rig->axis.set_velocity_set_point(kSpeed);
  // When enable operation is written with halt set (010Fh)
  rig->command(0x010F);
  rig->ticks(3);
  // Then OPERATION ENABLED, halted, the axis never moved
  EXPECT_EQ(rig->pds.state(), kOe);
  EXPECT_TRUE(rig->pds.halted());
  EXPECT_EQ(rig->axis.velocity(), 0.0);
}

struct StopTransitionCase {
  OptionCode option;
  std::int16_t value;
  std::uint16_t controlword;
  State to;
  std::uint8_t number;
  can::Duration time;  // 1 cycle for 0 (the state changes in the command's cycle: 0 ms)
  const char* name;
};

// 605Bh shutdown (transition 8) and 605Ch disable operation (transition 5), CiA 402: 0 disable
// the drive function, 1 slow down ramp (6084h) then disable. Festo 605Bh = 0, 605Ch = -1 (000
// L5851-5887), IRTSA 605Ch = 1 "ramp on 6084h" (003 digest L1514).
// clang-format off
const StopTransitionCase kStopTransitionCases[] = {
    {OptionCode::shutdown,          0, 0x0006, kRtso, 8, 0ms,   "Shutdown0DisablesAtOnce"},
    {OptionCode::shutdown,          1, 0x0006, kRtso, 8, 100ms, "Shutdown1RampsFirst"},
    {OptionCode::disable_operation, 0, 0x0007, kSo,   5, 0ms,   "DisableOperation0DisablesAtOnce"},
    {OptionCode::disable_operation, 1, 0x0007, kSo,   5, 100ms, "DisableOperation1RampsFirst"},
};
// clang-format on

class PdsStopTransition : public testing::TestWithParam<StopTransitionCase> {};

TEST_P(PdsStopTransition, StateChangesWhenTheOptionsStopIsDone) {
  const StopTransitionCase& c = GetParam();
  // Given OPERATION ENABLED at 1000 units/s with the option code
  Rig rig;
  rig.set_option(c.option, c.value);
  rig.to_operation_enabled(kSpeed);
  // When the command is written
  rig.command(c.controlword);
  const can::TimePoint start = rig.now;
  if (c.time == 0ms) {
    // Then 0: the state changes at once, the motor runs free
    EXPECT_EQ(rig.pds.state(), c.to);
    EXPECT_EQ(rig.axis.motion(), AxisMotion::free);
    EXPECT_GT(rig.axis.velocity(), 0.0);
  } else {
    // Then 1: OPERATION ENABLED (0237h) while ramping on 6084h, the state change at standstill
    EXPECT_EQ(rig.pds.state(), kOe);
    EXPECT_EQ(rig.pds.statusword(), 0x0237);
    EXPECT_EQ(rig.pds.pending_transition(), c.number);
    EXPECT_EQ(rig.axis.stop_deceleration(), kSlowDown);
    // The held controlword does not restart the stop every cycle: one axis command
    const std::uint64_t axis_commands = rig.axis.commands();
    rig.ticks(50);
    EXPECT_EQ(rig.axis.commands(), axis_commands);
    EXPECT_EQ(rig.run_until(c.to), c.time - 50ms);
    EXPECT_EQ(rig.axis.velocity(), 0.0);
  }
  EXPECT_EQ(rig.pds.last_transition()->number, c.number);
  EXPECT_EQ(rig.pds.statusword(), statusword_in(c.to));
  EXPECT_EQ(rig.now - start, c.time);
}

INSTANTIATE_TEST_SUITE_P(EveryValue, PdsStopTransition, testing::ValuesIn(kStopTransitionCases),
                         [](const testing::TestParamInfo<StopTransitionCase>& param_info) {
                           return std::string(param_info.param.name);
                         });

TEST(PdsStopTransition, AQuickStopReplacesARampedDisableOperation) {
  // Given a ramped disable operation (605Ch = 1) under way for 10 ms
  Rig rig;
  rig.to_operation_enabled(kSpeed);
  rig.command(0x0007);
  rig.ticks(9);
  ASSERT_EQ(rig.pds.pending_transition(), 5);
  ASSERT_EQ(rig.axis.velocity(), 910.0);
  // When quick stop is commanded
  rig.command(0x000B);
  // Then transition 11 replaces it; from 900 units/s (the axis moved on in that cycle) the
  //   quick stop ramp (6085h) takes 900/50000 s = 18 ms
  EXPECT_EQ(rig.pds.state(), kQsa);
  EXPECT_FALSE(rig.pds.pending_transition());
  EXPECT_EQ(rig.run_until(kSod), 18ms);
}

TEST(PdsStopTransition, EnableOperationDoesNotCancelARampedStop) {
  // Given a ramped disable operation under way
  Rig rig;
  rig.to_operation_enabled(kSpeed);
  rig.command(0x0007);
  rig.ticks(10);
  // When enable operation is written again
  rig.command(0x000F);
  // Then the stop goes on (latched) and transition 5 comes at standstill, 100 ms after it began;
  //   the held 000Fh then takes transition 4 in the next cycle
  EXPECT_EQ(rig.pds.pending_transition(), 5);
  EXPECT_EQ(rig.run_until(kSo), 89ms);
  rig.tick();
  EXPECT_EQ(rig.pds.state(), kOe);
}

TEST(PdsStopTransition, AFaultPreemptsARampedShutdown) {
  // Given a ramped shutdown (605Bh = 1) under way
  Rig rig;
  rig.set_option(OptionCode::shutdown, 1);
  rig.to_operation_enabled(kSpeed);
  rig.command(0x0006);
  ASSERT_EQ(rig.pds.pending_transition(), 8);
  // When a fault occurs
  rig.pds.raise_fault(faults::kOverCurrent);
  rig.tick();
  // Then FAULT REACTION ACTIVE with 605Eh's stop (quick stop ramp), not RTSO
  EXPECT_EQ(rig.pds.state(), kFra);
  EXPECT_FALSE(rig.pds.pending_transition());
  EXPECT_EQ(rig.axis.stop_deceleration(), kQuickStop);
}

TEST(PdsOptionCodes, AcceptsExactlyTheStandardValues) {
  // Given the default support (every CiA 402 value)
  Rig rig;
  // clang-format off
  const std::array<std::pair<OptionCode, std::set<int>>, 6> accepted{{
      {OptionCode::abort_connection,  {0, 1, 2, 3}},
      {OptionCode::quick_stop,        {0, 1, 2, 3, 4, 5, 6, 7, 8}},
      {OptionCode::shutdown,          {0, 1}},
      {OptionCode::disable_operation, {0, 1}},
      {OptionCode::halt,              {1, 2, 3, 4}},
      {OptionCode::fault_reaction,    {0, 1, 2, 3, 4}},
  }};
  // clang-format on
  for (const auto& [code, values] : accepted) {
    SCOPED_TRACE(info_of(code).id.index);
    for (int value : {-32768, -2, -1, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 15, 16, 32767}) {
      SCOPED_TRACE(value);
      // When each value is set
      const std::int16_t before = rig.pds.option_code(code);
      const auto result = rig.pds.set_option_code(code, static_cast<std::int16_t>(value));
      // Then the standard values are taken; others (manufacturer negatives, reserved) are
      //   refused with 06090030h and change nothing
      if (values.count(value) != 0) {
        EXPECT_TRUE(result);
        EXPECT_EQ(rig.pds.option_code(code), value);
      } else {
        ASSERT_FALSE(result);
        EXPECT_EQ(result.error(), cia301::SdoAbort::invalid_value);
        EXPECT_EQ(rig.pds.option_code(code), before);
      }
    }
  }
}

TEST(PdsOptionCodes, DefaultsAreCiA402s) {
  // Given a new drive
  Rig rig;
  // Then 6007h 1, 605Ah 2, 605Bh 0, 605Ch 1, 605Dh 1, 605Eh 2
  EXPECT_EQ(rig.pds.option_code(OptionCode::abort_connection), 1);
  EXPECT_EQ(rig.pds.option_code(OptionCode::quick_stop), 2);
  EXPECT_EQ(rig.pds.option_code(OptionCode::shutdown), 0);
  EXPECT_EQ(rig.pds.option_code(OptionCode::disable_operation), 1);
  EXPECT_EQ(rig.pds.option_code(OptionCode::halt), 1);
  EXPECT_EQ(rig.pds.option_code(OptionCode::fault_reaction), 2);
}

TEST(PdsOptionCodes, APersonalityRestrictsTheValues) {
  // Given a drive that supports only 605Ah = 2 and 605Dh = 2 (Festo: 605Ah fixed at 2,
  //   000 L5889-5905)
  PowerDriveConfig config = test_config();
  config.option_code_support.values[static_cast<std::size_t>(OptionCode::quick_stop)] = 1u << 2;
  config.option_code_support.values[static_cast<std::size_t>(OptionCode::halt)] = 1u << 2;
  Rig rig(config);
  // Then 605Dh starts at 2 (CiA 402's 1 is not supported), and 605Ah = 6 is refused
  EXPECT_EQ(rig.pds.option_code(OptionCode::halt), 2);
  const auto result = rig.pds.set_option_code(OptionCode::quick_stop, 6);
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error(), cia301::SdoAbort::invalid_value);
}

TEST(PdsOptionCodes, AReactionKeepsTheValuesItStartedWith) {
  // Given a quick stop with 605Ah = 6 (stay) under way
  Rig rig;
  rig.set_option(OptionCode::quick_stop, 6);
  rig.to_quick_stop_active();
  // When 605Ah is changed to 2 during the stop
  rig.set_option(OptionCode::quick_stop, 2);
  rig.ticks(100);
  // Then the running quick stop still stays in QUICK STOP ACTIVE
  EXPECT_EQ(rig.pds.state(), kQsa);
}

// ---------------------------------------------------------------------------------------------
// 6007h abort connection option code (CiA 402; IRTSA/Dunker 004 §11.2 L772-774 use 1 as
// quick stop, a documented deviation)

TEST(PdsAbortConnection, NoActionKeepsOperating) {
  // Given OPERATION ENABLED with 6007h = 0
  Rig rig;
  rig.set_option(OptionCode::abort_connection, 0);
  rig.to_operation_enabled(kSpeed);
  // When the heartbeat/guarding is lost
  rig.pds.on_communication_loss();
  rig.ticks(10);
  // Then nothing happens
  EXPECT_EQ(rig.pds.state(), kOe);
  EXPECT_TRUE(rig.reporter.raised.empty());
}

TEST(PdsAbortConnection, FaultSignal) {
  // Given OPERATION ENABLED with 6007h = 1 (the default)
  Rig rig;
  rig.to_operation_enabled(kSpeed);
  // When the connection is lost
  rig.pds.on_communication_loss();
  rig.tick();
  // Then fault 8130h (1001h bit 4), 603Fh = 8130h, FAULT REACTION ACTIVE then FAULT
  EXPECT_EQ(rig.pds.state(), kFra);
  ASSERT_EQ(rig.reporter.raised.size(), 1u);
  EXPECT_EQ(rig.reporter.raised[0], std::make_pair(std::uint16_t{0x8130}, std::uint8_t{0x10}));
  EXPECT_EQ(rig.pds.error_code(), 0x8130);
  EXPECT_EQ(rig.run_until(kFault), 20ms);
  // And a master that is back can reset it
  rig.command(0x0000);
  rig.command(0x0080);
  EXPECT_EQ(rig.pds.state(), kSod);
}

TEST(PdsAbortConnection, DisableVoltageCommandHoldsUntilTheControlwordIsWritten) {
  // Given READY TO SWITCH ON (controlword 0006h) with 6007h = 2
  auto rig = rig_in(kRtso);
  rig->set_option(OptionCode::abort_connection, 2);
  // When the connection is lost
  rig->pds.on_communication_loss();
  rig->tick();
  // Then disable voltage: transition 7, and the old 0006h does not take transition 2 back
  EXPECT_EQ(rig->pds.state(), kSod);
  EXPECT_EQ(rig->pds.last_transition()->number, 7);
  rig->ticks(50);
  EXPECT_EQ(rig->pds.state(), kSod);
  EXPECT_EQ(rig->pds.forced_controlword(), 0x0000);
  // When the master writes again
  rig->command(0x0006);
  // Then it is obeyed
  EXPECT_EQ(rig->pds.state(), kRtso);
}

TEST(PdsAbortConnection, DisableVoltageFromOperationEnabledLetsTheMotorRunFree) {
  // Given OPERATION ENABLED at speed, 6007h = 2
  Rig rig;
  rig.set_option(OptionCode::abort_connection, 2);
  rig.to_operation_enabled(kSpeed);
  // When the connection is lost
  rig.pds.on_communication_loss();
  rig.tick();
  // Then transition 9 at once, drive function off
  EXPECT_EQ(rig.pds.state(), kSod);
  EXPECT_EQ(rig.pds.last_transition()->number, 9);
  EXPECT_EQ(rig.axis.motion(), AxisMotion::free);
}

TEST(PdsAbortConnection, QuickStopCommandNeverReEnablesWithoutTheMaster) {
  // Given OPERATION ENABLED (controlword 000Fh) with 6007h = 3 and 605Ah = 6 (stay, 16 allowed)
  Rig rig;
  rig.set_option(OptionCode::abort_connection, 3);
  rig.set_option(OptionCode::quick_stop, 6);
  rig.to_operation_enabled(kSpeed);
  // When the connection is lost
  rig.pds.on_communication_loss();
  rig.tick();
  // Then quick stop (11) and QUICK STOP ACTIVE stays: the dead master's 000Fh is not taken as
  //   enable operation (16)
  EXPECT_EQ(rig.pds.state(), kQsa);
  rig.ticks(500);
  EXPECT_EQ(rig.pds.state(), kQsa);
  EXPECT_TRUE(rig.axis.is_stopped());
  // When the master writes 000Fh again
  rig.command(0x000F);
  // Then transition 16
  EXPECT_EQ(rig.pds.state(), kOe);
}

TEST(PdsAbortConnection, QuickStopCommandWithOption2EndsSwitchOnDisabled) {
  // Given OPERATION ENABLED at speed, 6007h = 3, 605Ah = 2
  Rig rig;
  rig.set_option(OptionCode::abort_connection, 3);
  rig.to_operation_enabled(kSpeed);
  // When the connection is lost
  rig.pds.on_communication_loss();
  rig.tick();
  // Then quick stop ramp, SWITCH ON DISABLED after 20 ms
  EXPECT_EQ(rig.pds.state(), kQsa);
  EXPECT_EQ(rig.run_until(kSod), 20ms);
}

TEST(PdsAbortConnection, QuickStopCommandFromSwitchedOnIsTransition10) {
  // Given SWITCHED ON, 6007h = 3
  auto rig = rig_in(kSo);
  rig->set_option(OptionCode::abort_connection, 3);
  // When the connection is lost
  rig->pds.on_communication_loss();
  rig->tick();
  // Then transition 10
  EXPECT_EQ(rig->pds.state(), kSod);
  EXPECT_EQ(rig->pds.last_transition()->number, 10);
}

// ---------------------------------------------------------------------------------------------
// Hardware enable input (Festo Tab. 6.2 L5218, L5291; B.3 84-0 L9224-9229; L5208)

TEST(PdsHardwareEnable, NeededForShutdown) {
  // Given a drive whose transition 2 needs the enable input, which is off
  PowerDriveConfig config = test_config();
  config.hardware_enable = HardwareEnable::for_shutdown;
  Rig rig(config);
  rig.to_switch_on_disabled();
  // When shutdown is written
  const std::size_t transitions = rig.transitions.size();
  rig.pds.set_controlword(0x0006);
  // Then the drive stays SWITCH ON DISABLED with the warning bit 7 (02C0h), cycle after cycle
  for (int i = 0; i < 5; ++i) {
    rig.tick();
    EXPECT_EQ(rig.pds.state(), kSod);
    EXPECT_EQ(rig.pds.statusword(), 0x02C0);
  }
  EXPECT_EQ(rig.transitions.size(), transitions);
  // When the input comes on
  rig.pds.set_hardware_enable(true);
  rig.tick();
  // Then transition 2, warning gone
  EXPECT_EQ(rig.pds.state(), kRtso);
  EXPECT_EQ(rig.pds.statusword(), 0x0221);
}

TEST(PdsHardwareEnable, RemovalInOperationEnabledDisablesVoltage) {
  // Given OPERATION ENABLED at speed with the enable input on
  PowerDriveConfig config = test_config();
  config.hardware_enable = HardwareEnable::for_shutdown;
  Rig rig(config);
  rig.pds.set_hardware_enable(true);
  rig.to_operation_enabled(kSpeed);
  ASSERT_EQ(rig.pds.state(), kOe);
  // When the input goes off
  rig.pds.set_hardware_enable(false);
  rig.tick();
  // Then transition 9 (Festo L5208: the motor coasts); no warning: 000Fh, still written,
  //   commands nothing from SWITCH ON DISABLED that the enable gates
  EXPECT_EQ(rig.pds.state(), kSod);
  EXPECT_EQ(rig.pds.last_transition()->number, 9);
  EXPECT_EQ(rig.axis.motion(), AxisMotion::free);
  EXPECT_EQ(rig.pds.statusword(), 0x0240);
}

TEST(PdsHardwareEnable, NeededForSwitchOnOnly) {
  // Given a drive whose transition 3 needs the enable input, which is off
  PowerDriveConfig config = test_config();
  config.hardware_enable = HardwareEnable::for_switch_on;
  Rig rig(config);
  rig.to_switch_on_disabled();
  // When shutdown and switch on are written
  rig.command(0x0006);
  EXPECT_EQ(rig.pds.state(), kRtso);
  rig.command(0x0007);
  // Then transition 2 works, transition 3 waits with the warning (02A1h)
  EXPECT_EQ(rig.pds.state(), kRtso);
  EXPECT_EQ(rig.pds.statusword(), 0x02A1);
  rig.pds.set_hardware_enable(true);
  rig.tick();
  EXPECT_EQ(rig.pds.state(), kSo);
  // And removing it in SWITCHED ON disables the voltage (10)
  rig.pds.set_hardware_enable(false);
  rig.tick();
  EXPECT_EQ(rig.pds.state(), kSod);
  EXPECT_EQ(rig.pds.last_transition()->number, 10);
}

TEST(PdsHardwareEnable, IgnoredWhenNotNeeded) {
  // Given a drive without an enable input (default), input off
  Rig rig;
  // When the drive is enabled
  rig.to_operation_enabled();
  // Then it is
  EXPECT_EQ(rig.pds.state(), kOe);
  EXPECT_FALSE(rig.pds.warning());
}

// ---------------------------------------------------------------------------------------------
// Modes of operation 6060h / 6061h / 6502h

TEST(PdsModes, DisplayFollowsTheRequestAtTheNextCycle) {
  // Given a drive with the default modes (pp pv tq hm csp csv cst), 6061h = 0
  Rig rig;
  rig.to_operation_enabled();
  EXPECT_EQ(rig.pds.mode_display(), 0);
  // When 6060h = 1 (pp) is requested
  ASSERT_TRUE(rig.pds.request_mode(1));
  // Then 6061h still shows 0 until the next cycle, then 1; the state is untouched (a mode
  //   change is allowed in OPERATION ENABLED)
  EXPECT_EQ(rig.pds.mode_display(), 0);
  EXPECT_EQ(rig.pds.requested_mode(), 1);
  const std::uint64_t axis_commands = rig.axis.commands();
  rig.tick();
  EXPECT_EQ(rig.pds.mode_display(), 1);
  EXPECT_EQ(rig.pds.state(), kOe);
  EXPECT_EQ(rig.axis.commands(), axis_commands);
  // And 6 (hm), 8 (csp), 0 (no mode) likewise
  for (std::int8_t mode : {std::int8_t{6}, std::int8_t{8}, std::int8_t{0}}) {
    ASSERT_TRUE(rig.pds.request_mode(mode));
    rig.tick();
    EXPECT_EQ(rig.pds.mode_display(), mode);
  }
}

TEST(PdsModes, UnsupportedModesAreRefused) {
  // Given a drive with the default modes and 6060h = 3
  Rig rig;
  ASSERT_TRUE(rig.pds.request_mode(3));
  rig.tick();
  // When unsupported (vl 2, ip 7), reserved (5, 11, 127) or manufacturer (-1) modes are asked
  for (std::int8_t mode : {std::int8_t{2}, std::int8_t{7}, std::int8_t{5}, std::int8_t{11},
                           std::int8_t{127}, std::int8_t{-1}, std::int8_t{-128}}) {
    SCOPED_TRACE(int{mode});
    const auto result = rig.pds.request_mode(mode);
    // Then 06090030h, 6060h and 6061h unchanged
    ASSERT_FALSE(result);
    EXPECT_EQ(result.error(), cia301::SdoAbort::invalid_value);
    rig.tick();
    EXPECT_EQ(rig.pds.requested_mode(), 3);
    EXPECT_EQ(rig.pds.mode_display(), 3);
  }
}

TEST(PdsModes, SupportedModesComeFrom6502h) {
  // Given a drive supporting only ip (6502h bit 6)
  PowerDriveConfig config = test_config();
  config.supported_modes = 0x00000040;
  Rig rig(config);
  // Then 7 is accepted, 1 refused
  EXPECT_TRUE(rig.pds.request_mode(7));
  EXPECT_FALSE(rig.pds.request_mode(1));
}

// ---------------------------------------------------------------------------------------------
// Statusword bits besides the state

TEST(PdsStatusword, ModeBitsPassOnlyBits10To13) {
  // Given a mode logic that sets every bit
  auto rig = rig_in(kOe);
  rig->modes.bits = 0xFFFF;
  // Then only 10..13 are taken: 0237h | 3C00h
  EXPECT_EQ(rig->pds.statusword(), 0x3E37);
}

TEST(PdsStatusword, WarningFromTheApplication) {
  // Given SWITCH ON DISABLED
  auto rig = rig_in(kSod);
  // When the application sets a warning
  rig->pds.set_warning(true);
  // Then bit 7
  EXPECT_EQ(rig->pds.statusword(), 0x02C0);
}

TEST(PdsStatusword, LocalControlClearsRemoteAndIgnoresTheControlword) {
  // Given a drive under local control (remote = 0)
  PowerDriveConfig config = test_config();
  config.remote = false;
  Rig rig(config);
  rig.to_switch_on_disabled();
  // When shutdown is written
  rig.command(0x0006);
  // Then bit 9 is 0 and the controlword is not obeyed
  EXPECT_EQ(rig.pds.statusword(), 0x0040);
  EXPECT_EQ(rig.pds.state(), kSod);
}

TEST(PdsPowerOn, PowerOnAgainStartsOver) {
  // Given FAULT with an unacknowledged fault and 6060h = 1
  Rig rig;
  ASSERT_TRUE(rig.pds.request_mode(1));
  rig.to_fault();
  // When the drive is powered on again (NMT reset node)
  rig.pds.power_on(rig.now);
  // Then NOT READY TO SWITCH ON by transition 0, faults forgotten, 6061h initial, 603Fh 0
  EXPECT_EQ(rig.pds.state(), kNotReady);
  EXPECT_EQ(rig.pds.last_transition()->number, 0);
  EXPECT_TRUE(rig.pds.unacknowledged_faults().empty());
  EXPECT_EQ(rig.pds.error_code(), 0);
  EXPECT_EQ(rig.pds.mode_display(), 0);
  rig.tick();
  EXPECT_EQ(rig.pds.state(), kSod);
}

// ---------------------------------------------------------------------------------------------
// Timing does not depend on the cycle

class PdsCycle : public testing::TestWithParam<can::Duration> {};

TEST_P(PdsCycle, QuickStopTakesTheSameTimeAtEveryCycle) {
  // Given OPERATION ENABLED at 1000 units/s, stepped every GetParam()
  Rig rig(test_config(), GetParam());
  rig.to_operation_enabled(kSpeed);
  // When quick stop is commanded (605Ah = 2, 6085h = 50000)
  rig.command(0x000B);
  // Then SWITCH ON DISABLED after 20 ms
  EXPECT_EQ(rig.run_until(kSod), 20ms);
}

INSTANTIATE_TEST_SUITE_P(Cycles, PdsCycle, testing::Values(250us, 1ms, 4ms),
                         [](const testing::TestParamInfo<can::Duration>& param_info) {
                           return std::to_string(param_info.param.count() / 1000) + "us";
                         });

// ---------------------------------------------------------------------------------------------
// The objects in an object dictionary

struct ObjectCase {
  std::uint16_t index;
  cia301::DataType type;
  cia301::AccessType access;
  bool pdo;
  std::int64_t default_value;
};

TEST(PdsObjects, TypesAccessAndDefaultsPerCiA402) {
  // Given an object dictionary with the PDS objects
  cia301::ObjectDictionary od;
  ASSERT_TRUE(add_power_drive_objects(od, test_config()));
  using cia301::AccessType;
  using cia301::DataType;
  // clang-format off
  const ObjectCase cases[] = {
      {0x6007, DataType::integer16,  AccessType::rw, false, 1},
      {0x603F, DataType::unsigned16, AccessType::ro, true,  0},
      {0x6040, DataType::unsigned16, AccessType::rw, true,  0},
      {0x6041, DataType::unsigned16, AccessType::ro, true,  0},
      {0x605A, DataType::integer16,  AccessType::rw, false, 2},
      {0x605B, DataType::integer16,  AccessType::rw, false, 0},
      {0x605C, DataType::integer16,  AccessType::rw, false, 1},
      {0x605D, DataType::integer16,  AccessType::rw, false, 1},
      {0x605E, DataType::integer16,  AccessType::rw, false, 2},
      {0x6060, DataType::integer8,   AccessType::rw, true,  0},
      {0x6061, DataType::integer8,   AccessType::ro, true,  0},
      {0x6084, DataType::unsigned32, AccessType::rw, true,  kSlowDown},
      {0x6085, DataType::unsigned32, AccessType::rw, true,  kQuickStop},
      {0x6502, DataType::unsigned32, AccessType::ro, false, 0x3AD},
  };
  // clang-format on
  for (const ObjectCase& c : cases) {
    SCOPED_TRACE(c.index);
    const cia301::Entry* entry = od.find(c.index, 0);
    ASSERT_NE(entry, nullptr);
    // Then each is a VAR of CiA 402's type and access with its default
    EXPECT_EQ(entry->type(), c.type);
    EXPECT_EQ(entry->access(), c.access);
    EXPECT_EQ(entry->pdo_mappable(), c.pdo);
    EXPECT_EQ(entry->as_signed(), c.default_value);
  }
  // And the controlword is never stored (1010h), the option codes are (application group)
  EXPECT_EQ(od.find(0x6040, 0)->store_group(), cia301::kStoreNone);
  EXPECT_EQ(od.find(0x605A, 0)->store_group(), cia301::kStoreApplication);
  // And adding them twice fails
  EXPECT_FALSE(add_power_drive_objects(od, test_config()));
}

TEST(PdsObjects, WithoutProfileDecelerationTheConfigValueIsUsed) {
  // Given the objects without 6084h (the mode logic owns it)
  cia301::ObjectDictionary od;
  ASSERT_TRUE(add_power_drive_objects(od, test_config(), {.profile_deceleration = false}));
  // Then 6084h is absent
  EXPECT_EQ(od.find(0x6084, 0), nullptr);
}

class PdsObjectRig {
 public:
  PdsObjectRig() : axis(test_axis()), pds(axis, test_config()) {
    EXPECT_TRUE(add_power_drive_objects(od, test_config()));
    binding = std::make_unique<PowerDriveObjects>(od, pds);
    pds.power_on(now);
    binding->reload();
  }
  void tick() {
    now += 1ms;
    axis.advance(1ms);
    binding->step(now);
  }
  Expected<void, cia301::SdoAbort> write(std::uint16_t index, std::vector<std::uint8_t> bytes) {
    return od.write(index, 0, bytes);
  }
  std::int64_t read(std::uint16_t index) { return od.find(index, 0)->as_signed(); }
  std::uint64_t read_unsigned(std::uint16_t index) { return od.find(index, 0)->as_unsigned(); }

  can::TimePoint now{};
  cia301::ObjectDictionary od;
  RampAxis axis;
  PowerDriveSystem pds;
  std::unique_ptr<PowerDriveObjects> binding;
};

TEST(PdsObjects, UnsupportedOptionCodeWritesAbort) {
  // Given the bound objects
  PdsObjectRig rig;
  // When 605Ah = 9 (reserved), 605Ah = -1 (manufacturer), 605Dh = 0, 6007h = 4 are written
  // Then each is refused with 06090030h and the value stays
  for (auto [index, value] : {std::pair{0x605A, 9}, std::pair{0x605A, -1}, std::pair{0x605D, 0},
                              std::pair{0x6007, 4}, std::pair{0x605B, 2}, std::pair{0x605E, 5}}) {
    SCOPED_TRACE(index);
    const std::int64_t before = rig.read(static_cast<std::uint16_t>(index));
    const auto raw = static_cast<std::uint16_t>(value);
    const auto result =
        rig.write(static_cast<std::uint16_t>(index),
                  {static_cast<std::uint8_t>(raw & 0xFF), static_cast<std::uint8_t>(raw >> 8)});
    ASSERT_FALSE(result);
    EXPECT_EQ(result.error(), cia301::SdoAbort::invalid_value);
    EXPECT_EQ(rig.read(static_cast<std::uint16_t>(index)), before);
  }
}

TEST(PdsObjects, OptionCodeWritesTakeEffectAtTheNextCycle) {
  // Given the bound objects
  PdsObjectRig rig;
  // When 605Ah = 6 and 6085h = 1000 are written (SDO: data 0006h; 000003E8h)
  ASSERT_TRUE(rig.write(0x605A, {0x06, 0x00}));
  ASSERT_TRUE(rig.write(0x6085, {0xE8, 0x03, 0x00, 0x00}));
  rig.tick();
  // Then the PDS uses them
  EXPECT_EQ(rig.pds.option_code(OptionCode::quick_stop), 6);
  EXPECT_EQ(rig.pds.quick_stop_deceleration(), 1000u);
}

TEST(PdsObjects, ControlwordWritesDriveTheStateAndStatuswordFollows) {
  // Given the bound objects, SWITCH ON DISABLED
  PdsObjectRig rig;
  rig.tick();
  EXPECT_EQ(rig.read_unsigned(0x6041), 0x0240);
  // When 6040h = 0006h, 0007h, 000Fh are written a cycle apart (SDO data 0600h ...)
  for (std::uint8_t low : {std::uint8_t{0x06}, std::uint8_t{0x07}, std::uint8_t{0x0F}}) {
    ASSERT_TRUE(rig.write(0x6040, {low, 0x00}));
    rig.tick();
  }
  // Then 6041h reads 0237h (OPERATION ENABLED)
  EXPECT_EQ(rig.read_unsigned(0x6041), 0x0237);
  // When a fault occurs, is cleared, and 6040h gets 0080h then 0000h within one cycle
  rig.pds.raise_fault(faults::kFollowingError);
  for (int i = 0; i < 50; ++i)
    rig.tick();
  EXPECT_EQ(rig.read_unsigned(0x603F), 0x8611);
  EXPECT_EQ(rig.read_unsigned(0x6041), 0x0208);
  rig.pds.clear_fault_cause(0x8611);
  ASSERT_TRUE(rig.write(0x6040, {0x00, 0x00}));
  rig.tick();
  ASSERT_TRUE(rig.write(0x6040, {0x80, 0x00}));
  ASSERT_TRUE(rig.write(0x6040, {0x00, 0x00}));
  rig.tick();
  // Then the observer caught the edge: SWITCH ON DISABLED, 603Fh 0
  EXPECT_EQ(rig.read_unsigned(0x6041), 0x0240);
  EXPECT_EQ(rig.read_unsigned(0x603F), 0x0000);
}

TEST(PdsObjects, ModesOfOperationWrites) {
  // Given the bound objects
  PdsObjectRig rig;
  rig.tick();
  // When 6060h = 2 (vl, unsupported) is written
  const auto refused = rig.write(0x6060, {0x02});
  // Then 06090030h
  ASSERT_FALSE(refused);
  EXPECT_EQ(refused.error(), cia301::SdoAbort::invalid_value);
  // When 6060h = 1 is written
  ASSERT_TRUE(rig.write(0x6060, {0x01}));
  // Then 6061h shows 1 after the next cycle
  EXPECT_EQ(rig.read(0x6061), 0);
  rig.tick();
  EXPECT_EQ(rig.read(0x6061), 1);
}

TEST(PdsObjects, TheBindingRemovesItsHooks) {
  // Given bound objects
  PdsObjectRig rig;
  // When the binding is destroyed
  rig.binding.reset();
  // Then 605Ah = 9 is stored (no validator) and 6040h writes no longer reach the PDS
  EXPECT_TRUE(rig.write(0x605A, {0x09, 0x00}));
  EXPECT_TRUE(rig.write(0x6040, {0x06, 0x00}));
  EXPECT_EQ(rig.pds.controlword(), 0x0000);
}

// ---------------------------------------------------------------------------------------------
// The first-order axis model

TEST(RampAxis, RampIsExactWhateverTheStep) {
  // Given two axes at 1000 units/s ramping at 10000 units/s²
  RampAxis fine(test_axis());
  RampAxis coarse(test_axis());
  for (RampAxis* axis : {&fine, &coarse}) {
    axis->set_velocity(1000);
    axis->ramp_to_stop(10000);
  }
  // When one moves 99 × 1 ms and the other 99 ms at once
  for (int i = 0; i < 99; ++i)
    fine.advance(1ms);
  coarse.advance(99ms);
  // Then both are at 10 units/s, stopped 1 ms later, after 50 units of travel
  EXPECT_EQ(fine.velocity(), 10.0);
  EXPECT_EQ(coarse.velocity(), 10.0);
  fine.advance(1ms);
  coarse.advance(5ms);
  EXPECT_TRUE(fine.is_stopped());
  EXPECT_TRUE(coarse.is_stopped());
  EXPECT_NEAR(fine.position(), 50.0, 1e-9);
  EXPECT_NEAR(coarse.position(), 50.0, 1e-9);
}

TEST(RampAxis, CoastsFollowsAndLimits) {
  // Given an axis with acceleration 5000 units/s², coast 1000 units/s²
  RampAxisConfig config = test_axis();
  config.acceleration = 5000;
  RampAxis axis(config);
  // When it follows a set-point of 1000 units/s for 100 ms
  axis.set_velocity_set_point(1000);
  axis.follow_set_points();
  axis.advance(100ms);
  // Then it is at 500 units/s
  EXPECT_EQ(axis.velocity(), 500.0);
  // When the power goes off for 100 ms
  axis.disable_power();
  axis.advance(100ms);
  // Then it coasts down by 100 units/s
  EXPECT_EQ(axis.velocity(), 400.0);
  // When it stops at the current limit (200000 units/s²)
  axis.stop_at_current_limit();
  EXPECT_EQ(axis.stop_deceleration(), kCurrentLimit);
  axis.advance(2ms);
  // Then it is stopped and holds
  EXPECT_TRUE(axis.is_stopped());
  EXPECT_EQ(axis.motion(), AxisMotion::stopping);
}

}  // namespace
}  // namespace drivecheck::reference_drive
