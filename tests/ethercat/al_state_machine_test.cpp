#include "protocol/ethercat/al_state_machine.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>
#include <utility>
#include <vector>

namespace drivecheck::ethercat {
namespace {

AlConfig with_boot() {
  AlConfig config;
  config.bootstrap = true;
  return config;
}

AlConfig with_check(std::function<AlStatusCode(const AlTransition&)> check) {
  AlConfig config;
  config.check = std::move(check);
  return config;
}

// Drives a machine to `state` along allowed transitions (INIT, PREOP, SAFEOP, OP).
void walk_to(AlStateMachine& machine, AlState state) {
  for (AlState step : {AlState::preop, AlState::safeop, AlState::op}) {
    if (static_cast<int>(machine.status().state) >= static_cast<int>(state)) break;
    machine.request(static_cast<std::uint16_t>(step));
  }
  ASSERT_EQ(machine.status().state, state);
}

TEST(AlStatusCodes, IndependentCopyMatchesTheTable) {
  // Given codes the brief and ETG.1000.6 Table 11 name (an independent copy, on purpose)
  // When they are looked up
  // Then each is in the table with its meaning, and an unknown code says so
  EXPECT_EQ(describe_al_status_code(0x0011),
            "0011h invalid_requested_state_change: Invalid requested state change");
  EXPECT_EQ(find_al_status_code(0x0012)->code, AlStatusCode::unknown_requested_state);
  EXPECT_EQ(find_al_status_code(0x001B)->code, AlStatusCode::sync_manager_watchdog);
  EXPECT_EQ(find_al_status_code(0x001D)->code, AlStatusCode::invalid_output_configuration);
  EXPECT_EQ(find_al_status_code(0x0016)->code, AlStatusCode::invalid_mailbox_configuration);
  EXPECT_EQ(describe_al_status_code(0x7777), "7777h (unknown AL status code)");
  EXPECT_EQ(make_error_code(AlStatusCode::sync_manager_watchdog).category().name(),
            std::string("al-status"));
}

TEST(AlStateMachine, StartsInInitWithoutError) {
  // Given a new state machine
  // When nothing is requested
  // Then AL status reads 0001h, code 0
  AlStateMachine machine;
  EXPECT_EQ(machine.status().register_value(), 0x0001);
  EXPECT_EQ(machine.status().code, AlStatusCode::no_error);
}

TEST(AlStateMachine, EveryTableTransitionIsTaken) {
  // Given each row of the transition table (BOOT supported)
  // When the machine in the row's source state is asked for its target
  // Then it enters the target without error, and on_state_change names both states
  for (const AlTransition& row : kAlTransitions) {
    std::vector<std::pair<AlState, AlState>> changes;
    AlConfig config = with_boot();
    config.on_state_change = [&](AlState from, AlState to) { changes.emplace_back(from, to); };
    AlStateMachine machine(config);
    if (row.from == AlState::boot) {
      machine.request(static_cast<std::uint16_t>(AlState::boot));
    } else {
      walk_to(machine, row.from);
    }
    ASSERT_EQ(machine.status().state, row.from) << row.name;
    changes.clear();
    const AlStatus& status = machine.request(static_cast<std::uint16_t>(row.to));
    EXPECT_EQ(status.state, row.to) << row.name;
    EXPECT_FALSE(status.error) << row.name;
    ASSERT_EQ(changes.size(), 1u) << row.name;
    EXPECT_EQ(changes[0], std::make_pair(row.from, row.to)) << row.name;
  }
}

TEST(AlStateMachine, PairsOutsideTheTableAreRefusedWith0011h) {
  // Given every pair of distinct states not in the table
  // When the machine in the first is asked for the second
  // Then it stays, sets the error indication and code 0011h
  const AlState states[] = {AlState::init, AlState::preop, AlState::boot, AlState::safeop,
                            AlState::op};
  int refused = 0;
  for (AlState from : states) {
    for (AlState to : states) {
      if (from == to || find_al_transition(from, to) != nullptr) continue;
      AlStateMachine machine(with_boot());
      if (from == AlState::boot) {
        machine.request(3);
      } else {
        walk_to(machine, from);
      }
      const AlStatus& status = machine.request(static_cast<std::uint16_t>(to));
      EXPECT_EQ(status.state, from);
      EXPECT_TRUE(status.error);
      EXPECT_EQ(status.code, AlStatusCode::invalid_requested_state_change)
          << al_state_name(from) << " -> " << al_state_name(to);
      EXPECT_EQ(status.register_value(), static_cast<unsigned>(from) | 0x10);
      ++refused;
    }
  }
  EXPECT_EQ(refused, 20 - 11);
}

TEST(AlStateMachine, UnknownStateValueIsRefusedWith0012h) {
  // Given a machine in PREOP
  // When AL control requests 5, 6, 7, 9..15 or 0
  // Then it stays in PREOP with error and code 0012h
  for (std::uint16_t value : {0, 5, 6, 7, 9, 10, 15}) {
    AlStateMachine machine;
    machine.request(2);
    const AlStatus& status = machine.request(value);
    EXPECT_EQ(status.state, AlState::preop) << value;
    EXPECT_EQ(status.code, AlStatusCode::unknown_requested_state) << value;
    EXPECT_TRUE(status.error);
  }
}

TEST(AlStateMachine, BootWithoutSupportIsRefusedWith0013h) {
  // Given a machine without bootstrap support (the CMMP-AS, 000 §4.7)
  // When INIT -> BOOT is requested
  // Then it stays in INIT with error, code 0013h
  AlStateMachine machine;
  const AlStatus& status = machine.request(3);
  EXPECT_EQ(status.state, AlState::init);
  EXPECT_EQ(status.code, AlStatusCode::bootstrap_not_supported);
}

TEST(AlStateMachine, InjectedCheckRefusesWithItsCode) {
  // Given a check that refuses SO with 001Dh (invalid output configuration)
  // When SAFEOP -> OP is requested
  // Then the machine stays in SAFEOP + error with 001Dh, and the check saw the SO row
  std::vector<std::string> seen;
  AlStateMachine machine(with_check([&](const AlTransition& t) {
    seen.emplace_back(t.name);
    return t.requirement == AlRequirement::outputs ? AlStatusCode::invalid_output_configuration
                                                   : AlStatusCode::no_error;
  }));
  walk_to(machine, AlState::safeop);
  const AlStatus& status = machine.request(8);
  EXPECT_EQ(status.register_value(), 0x0014);
  EXPECT_EQ(status.code, AlStatusCode::invalid_output_configuration);
  EXPECT_EQ(seen, (std::vector<std::string>{"IP", "PS", "SO"}));
}

TEST(AlStateMachine, ErrorHoldsUpwardRequestsUntilAcknowledged) {
  // Given a machine in SAFEOP + error after a refused SO
  // When OP is requested again without the acknowledge bit, then with it (check now passes)
  // Then the first is ignored (error stays), the second clears the error and enters OP
  bool refuse = true;
  AlStateMachine machine(with_check([&](const AlTransition& t) {
    return refuse && t.name == "SO" ? AlStatusCode::no_valid_outputs : AlStatusCode::no_error;
  }));
  walk_to(machine, AlState::safeop);
  machine.request(8);
  refuse = false;
  EXPECT_EQ(machine.request(8).register_value(), 0x0014);
  EXPECT_EQ(machine.status().code, AlStatusCode::no_valid_outputs);
  const AlStatus& status = machine.request(0x0018);
  EXPECT_EQ(status.register_value(), 0x0008);
  EXPECT_EQ(status.code, AlStatusCode::no_error);
}

TEST(AlStateMachine, ErrorDoesNotHoldDownwardRequests) {
  // Given a machine in SAFEOP + error
  // When INIT is requested without acknowledge
  // Then it goes to INIT and the error indication stays until acknowledged
  AlStateMachine machine;
  walk_to(machine, AlState::safeop);
  machine.request(0x0009);  // unknown state 9: error set
  ASSERT_TRUE(machine.status().error);
  EXPECT_EQ(machine.request(1).register_value(), 0x0011);
  EXPECT_EQ(machine.request(0x0011).register_value(), 0x0001);
}

TEST(AlStateMachine, SmWatchdogDropsOpToSafeopWithError) {
  // Given a machine in OP
  // When the SM watchdog expires
  // Then AL status is SAFEOP + error (0014h), code 001Bh; in SAFEOP it changes nothing
  AlStateMachine machine;
  walk_to(machine, AlState::op);
  const AlStatus& status = machine.sm_watchdog_expired();
  EXPECT_EQ(status.register_value(), 0x0014);
  EXPECT_EQ(status.code, AlStatusCode::sync_manager_watchdog);
  AlStateMachine in_safeop;
  walk_to(in_safeop, AlState::safeop);
  EXPECT_EQ(in_safeop.sm_watchdog_expired().register_value(), 0x0004);
}

}  // namespace
}  // namespace drivecheck::ethercat
