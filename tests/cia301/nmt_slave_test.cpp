// NMT slave (CiA 301 §7.3.2): NMT states, NMT transitions, boot-up, malformed commands, the
// services each state allows and the error behaviour object 1029h. Grouped like the CiA
// conformance tool groups them: NMT states, NMT transitions.
#include "protocol/cia301/nmt_slave.hpp"

#include <gtest/gtest.h>

#include <string>
#include <tuple>
#include <vector>

#include "protocol/cia301/device_services.hpp"
#include "tests/cia301/device_harness.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;
using test_support::at;
using test_support::DeviceHarness;
using test_support::frame_of;

// ---------------------------------------------------------------------------------------------
// NMT states: services per state

TEST(NmtServiceTable, MatchesCia301StatesAndCommunicationObjects) {
  // Given the CiA 301 §7.3.2.2 table (PDO only in Operational; SDO, SYNC, TIME, EMCY in
  //   Pre-operational and Operational; node control and error control in all three; the
  //   boot-up message only at the end of Initialisation)
  struct Row {
    NmtService service;
    bool init, pre, op, stopped;
  };
  const std::vector<Row> expected = {
      {NmtService::pdo, false, false, true, false},
      {NmtService::sdo, false, true, true, false},
      {NmtService::sync, false, true, true, false},
      {NmtService::time, false, true, true, false},
      {NmtService::emcy, false, true, true, false},
      {NmtService::boot_up, true, false, false, false},
      {NmtService::node_control, false, true, true, true},
      {NmtService::error_control, false, true, true, true},
  };
  for (const auto& row : expected) {
    // When the table is asked for each state
    // Then it answers as the standard's table
    SCOPED_TRACE(std::string(to_string(row.service)));
    EXPECT_EQ(nmt_allows(NmtState::boot_up, row.service), row.init);
    EXPECT_EQ(nmt_allows(NmtState::pre_operational, row.service), row.pre);
    EXPECT_EQ(nmt_allows(NmtState::operational, row.service), row.op);
    EXPECT_EQ(nmt_allows(NmtState::stopped, row.service), row.stopped);
  }
}

TEST(NmtSlaveStates, PowerOnIsInitialisationUntilBootUp) {
  // Given a slave just powered on (transition 1)
  NmtSlave slave(5);
  // When nothing happened yet
  // Then it is initialising and allows no service but the boot-up
  EXPECT_TRUE(slave.initialising());
  EXPECT_EQ(slave.state(), NmtState::boot_up);
  EXPECT_FALSE(slave.allows(NmtService::sdo));
  // When initialisation finishes (transition 2)
  const auto boot_up = slave.finish_initialisation(5);
  // Then the boot-up message 705#00 is sent and the slave is pre-operational, once only
  ASSERT_TRUE(boot_up);
  EXPECT_EQ(can::to_candump(*boot_up), "705#00");  // 700h + node 5, byte 0 = 00h
  EXPECT_EQ(slave.state(), NmtState::pre_operational);
  EXPECT_FALSE(slave.finish_initialisation(5));
}

TEST(NmtSlaveStates, CommandsIgnoredWhileInitialising) {
  // Given a slave in Initialisation
  NmtSlave slave(5);
  // When the master sends start to node 5 and to all
  const auto addressed = slave.on_frame(frame_of("000#0105"));  // CS 01h start, node 5
  const auto broadcast = slave.on_frame(frame_of("000#0100"));  // CS 01h start, all nodes
  // Then both are ignored and the slave stays initialising
  EXPECT_EQ(addressed.action, NmtSlaveAction::ignored);
  EXPECT_EQ(addressed.ignored_because, NmtIgnoreReason::initialising);
  EXPECT_EQ(broadcast.action, NmtSlaveAction::ignored);
  EXPECT_EQ(slave.state(), NmtState::boot_up);
}

// ---------------------------------------------------------------------------------------------
// NMT transitions: every state × every command, addressed and broadcast

struct TransitionCase {
  NmtState from;
  std::uint8_t cs;
  NmtSlaveAction action;
  NmtState to;
};

// CiA 301 §7.3.2.1: (3),(6) start; (4),(7) enter pre-operational; (5),(8) stop; (9)-(11) reset
// node; (12)-(14) reset communication; a command for the current state changes nothing.
const std::vector<TransitionCase> kTransitions = {
    {NmtState::pre_operational, 0x01, NmtSlaveAction::state_changed, NmtState::operational},
    {NmtState::pre_operational, 0x02, NmtSlaveAction::state_changed, NmtState::stopped},
    {NmtState::pre_operational, 0x80, NmtSlaveAction::unchanged, NmtState::pre_operational},
    {NmtState::pre_operational, 0x81, NmtSlaveAction::reset_node, NmtState::boot_up},
    {NmtState::pre_operational, 0x82, NmtSlaveAction::reset_communication, NmtState::boot_up},
    {NmtState::operational, 0x01, NmtSlaveAction::unchanged, NmtState::operational},
    {NmtState::operational, 0x02, NmtSlaveAction::state_changed, NmtState::stopped},
    {NmtState::operational, 0x80, NmtSlaveAction::state_changed, NmtState::pre_operational},
    {NmtState::operational, 0x81, NmtSlaveAction::reset_node, NmtState::boot_up},
    {NmtState::operational, 0x82, NmtSlaveAction::reset_communication, NmtState::boot_up},
    {NmtState::stopped, 0x01, NmtSlaveAction::state_changed, NmtState::operational},
    {NmtState::stopped, 0x02, NmtSlaveAction::unchanged, NmtState::stopped},
    {NmtState::stopped, 0x80, NmtSlaveAction::state_changed, NmtState::pre_operational},
    {NmtState::stopped, 0x81, NmtSlaveAction::reset_node, NmtState::boot_up},
    {NmtState::stopped, 0x82, NmtSlaveAction::reset_communication, NmtState::boot_up},
};

// Brings a fresh slave (node 5) to `state` with local commands.
NmtSlave slave_in(NmtState state) {
  NmtSlave slave(5);
  slave.finish_initialisation(5);
  if (state == NmtState::operational) slave.apply(NmtCommand::start);
  if (state == NmtState::stopped) slave.apply(NmtCommand::stop);
  return slave;
}

TEST(NmtSlaveTransitions, EveryStateEveryCommandAddressedAndBroadcast) {
  for (const auto& c : kTransitions) {
    for (const std::uint8_t node : {std::uint8_t{5}, std::uint8_t{0}}) {
      SCOPED_TRACE(std::string(to_string(c.from)) + " CS " + std::to_string(c.cs) + " node " +
                   std::to_string(node));
      // Given a slave of node 5 in the from-state
      NmtSlave slave = slave_in(c.from);
      ASSERT_EQ(slave.state(), c.from);
      // When the master sends the command to node 5, or to all (node 0)
      const auto result = slave.on_frame(can::Frame::standard(0x000, {c.cs, node}));
      // Then the slave obeys it exactly as the state diagram says
      EXPECT_EQ(result.action, c.action);
      EXPECT_EQ(result.before, c.from);
      EXPECT_EQ(result.after, c.to);
      EXPECT_EQ(slave.state(), c.to);
      EXPECT_EQ(result.broadcast, node == 0);
      ASSERT_TRUE(result.command);
      EXPECT_EQ(static_cast<std::uint8_t>(*result.command), c.cs);
    }
  }
}

TEST(NmtSlaveTransitions, OtherNodeIdsIgnoredInEveryState) {
  for (const NmtState state :
       {NmtState::pre_operational, NmtState::operational, NmtState::stopped}) {
    for (const std::uint8_t cs : {0x01, 0x02, 0x80, 0x81, 0x82}) {
      for (const std::uint8_t node : {1, 4, 6, 127}) {
        // Given a slave of node 5
        NmtSlave slave = slave_in(state);
        // When a command addresses another node
        const auto result = slave.on_frame(can::Frame::standard(0x000, {cs, node}));
        // Then it is ignored
        EXPECT_EQ(result.action, NmtSlaveAction::ignored);
        EXPECT_EQ(result.ignored_because, NmtIgnoreReason::other_node);
        EXPECT_EQ(slave.state(), state);
      }
    }
  }
}

TEST(NmtSlaveTransitions, MalformedCommandsIgnored) {
  // Given a pre-operational slave of node 5
  struct Case {
    const char* frame;
    NmtIgnoreReason reason;
    const char* what;
  };
  const std::vector<Case> cases = {
      {"000#01", NmtIgnoreReason::malformed, "DLC 1: CS 01h without node byte"},
      {"000#010500", NmtIgnoreReason::malformed, "DLC 3: start node 5 plus a byte"},
      {"000#0105000000000000", NmtIgnoreReason::malformed, "DLC 8"},
      {"000#", NmtIgnoreReason::malformed, "DLC 0"},
      {"000#0305", NmtIgnoreReason::malformed, "CS 03h unknown"},
      {"000#0005", NmtIgnoreReason::malformed, "CS 00h unknown"},
      {"000#8305", NmtIgnoreReason::malformed, "CS 83h unknown"},
      {"000#FF05", NmtIgnoreReason::malformed, "CS FFh unknown"},
      {"000#0185", NmtIgnoreReason::malformed, "start, node 133 (above 127)"},
      {"000#01FF", NmtIgnoreReason::malformed, "start, node 255"},
      {"000#R2", NmtIgnoreReason::not_nmt, "remote frame on 000h"},
      {"00000000#0105", NmtIgnoreReason::not_nmt, "29-bit identifier 0"},
      {"001#0105", NmtIgnoreReason::not_nmt, "start node 5 on CAN-ID 001h"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    NmtSlave slave = slave_in(NmtState::pre_operational);
    // When the malformed frame arrives
    const auto result = slave.on_frame(frame_of(c.frame));
    // Then it is ignored for the stated reason and the state stays
    EXPECT_EQ(result.action, NmtSlaveAction::ignored);
    EXPECT_EQ(result.ignored_because, c.reason);
    EXPECT_EQ(slave.state(), NmtState::pre_operational);
  }
}

// ---------------------------------------------------------------------------------------------
// The same on the simulated bus, observed from the master's side

// Brings the harness's device (node 5) to `state` with NMT commands from the master.
void bring_to(DeviceHarness& h, NmtState state) {
  if (state == NmtState::operational) h.send("000#0105");  // start node 5
  if (state == NmtState::stopped) h.send("000#0205");      // stop node 5
  ASSERT_EQ(h.device->state(), state);
}

// The state the device reports, from a guarding request (1017h = 0): bits 6..0 of its answer.
std::uint8_t reported_state(DeviceHarness& h) {
  h.send("705#R");  // node-guarding request, RTR on 700h + 5
  const auto answer = h.next(5ms);
  if (!answer) {
    ADD_FAILURE() << "no guarding answer";
    return 0xFF;
  }
  return answer->frame.data[0] & 0x7F;
}

TEST(NmtSlaveOnBus, PowerOnSendsBootUpAndEntersPreOperational) {
  // Given a device of node 5 on the bus
  DeviceHarness h;
  // When it is powered on at t = 0
  const auto boot = h.power_on();
  // Then its boot-up message 705#00 starts at 0 and it is pre-operational (7Fh)
  ASSERT_TRUE(boot);
  EXPECT_EQ(can::to_candump(boot->frame), "705#00");  // 700h + 5, 00h = boot-up
  EXPECT_EQ(h.start_of_frame(*boot), at(0ms));
  EXPECT_EQ(h.device->state(), NmtState::pre_operational);
  EXPECT_EQ(reported_state(h), 0x7F);
}

TEST(NmtSlaveOnBus, EveryStateEveryCommandAddressedAndBroadcast) {
  for (const auto& c : kTransitions) {
    for (const std::uint8_t node : {std::uint8_t{5}, std::uint8_t{0}}) {
      SCOPED_TRACE(std::string(to_string(c.from)) + " CS " + std::to_string(c.cs) + " node " +
                   std::to_string(node));
      // Given a device of node 5 in the from-state
      DeviceHarness h;
      ASSERT_TRUE(h.power_on());
      bring_to(h, c.from);
      // When the master sends the command
      h.send(can::Frame::standard(0x000, {c.cs, node}));
      const can::TimePoint received = h.bus.now();
      const bool reset = c.cs == 0x81 || c.cs == 0x82;
      // Then a reset ends in a boot-up at once, any other command in silence
      if (reset) {
        const auto boot = h.expect("705#00", 1ms);  // boot-up after the reset
        EXPECT_EQ(h.start_of_frame(boot), received + h.intermission());
      } else {
        h.expect_silence(1ms);
      }
      // And the device reports the target state (pre-operational after a reset)
      const NmtState expected = reset ? NmtState::pre_operational : c.to;
      EXPECT_EQ(h.device->state(), expected);
      EXPECT_EQ(reported_state(h), static_cast<std::uint8_t>(expected));
    }
  }
}

TEST(NmtSlaveOnBus, OtherNodeAndMalformedCommandsChangeNothing) {
  // Given a device of node 5 in Operational
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  bring_to(h, NmtState::operational);
  // When commands for node 6, a reset with DLC 1 and an unknown CS arrive
  h.send("000#8106");  // reset node, node 6
  h.send("000#0206");  // stop, node 6
  h.send("000#81");    // reset node without the node byte (DLC 1)
  h.send("000#0405");  // CS 04h (unknown), node 5
  // Then nothing is sent and the device stays operational
  h.expect_silence(10ms);
  EXPECT_EQ(reported_state(h), 0x05);
}

TEST(NmtSlaveOnBus, ResetNodeRestoresApplicationAndCommunication) {
  // Given a device whose 1017h (communication) and 6060h (application) were changed
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1017, 0, 1000, 2));
  ASSERT_TRUE(h.od.set(0x6060, 0, Value::of_signed(3)));
  // When the master resets node 5
  h.send("000#8105");       // CS 81h reset node, node 5
  h.expect("705#00", 1ms);  // boot-up of node 5
  // Then both are back to their stored (here: default) values
  EXPECT_EQ(h.read(0x1017, 0).value_or(99), 0u);
  EXPECT_EQ(h.od.get(0x6060, 0).value().as_signed(), 1);
}

TEST(NmtSlaveOnBus, ResetCommunicationRestoresOnlyCommunication) {
  // Given the same changes
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1017, 0, 1000, 2));
  ASSERT_TRUE(h.od.set(0x6060, 0, Value::of_signed(3)));
  // When the master resets communication of all nodes
  h.send("000#8200");       // CS 82h reset communication, node 0 = all
  h.expect("705#00", 1ms);  // boot-up of node 5
  // Then 1017h is back to its default, 6060h keeps the application's value
  EXPECT_EQ(h.read(0x1017, 0).value_or(99), 0u);
  EXPECT_EQ(h.od.get(0x6060, 0).value().as_signed(), 3);
}

TEST(NmtSlaveOnBus, OwnerIsToldWhatToResetInOrder) {
  // Given a device whose owner records the resets it is asked for
  std::vector<ResetKind> resets;
  DeviceServicesHandlers handlers;
  handlers.on_reset = [&resets](ResetKind kind) { resets.push_back(kind); };
  DeviceHarness h(5, {}, {}, handlers);
  // When it is powered on, reset, and its communication reset
  ASSERT_TRUE(h.power_on());
  const std::vector<ResetKind> full = {ResetKind::application, ResetKind::communication};
  // Then power on and reset node ask for application then communication, reset
  //   communication for communication only, each followed by a boot-up
  EXPECT_EQ(resets, full);
  resets.clear();
  h.send("000#8105");       // reset node 5
  h.expect("705#00", 1ms);  // boot-up of node 5
  EXPECT_EQ(resets, full);
  resets.clear();
  h.send("000#8205");       // reset communication node 5
  h.expect("705#00", 1ms);  // boot-up of node 5
  EXPECT_EQ(resets, std::vector<ResetKind>{ResetKind::communication});
}

TEST(NmtSlaveOnBus, NewNodeIdTakesEffectAtResetCommunication) {
  // Given an owner that applies a new node-ID 7 (e.g. set by LSS) at reset communication
  DeviceHarness* harness = nullptr;
  DeviceServicesHandlers handlers;
  bool renumber = false;
  handlers.on_reset = [&](ResetKind kind) {
    if (kind != ResetKind::communication) return;
    if (renumber) harness->od.set_node_id(7);
    harness->od.restore_defaults(kStoreCommunication);
  };
  DeviceHarness h(5, {}, {}, handlers);
  harness = &h;
  ASSERT_TRUE(h.power_on());
  // When communication is reset
  renumber = true;
  h.send("000#8205");  // reset communication node 5
  // Then the boot-up comes from node 7, node 7 obeys NMT, and EMCY uses 80h + 7
  h.expect("707#00", 1ms);  // boot-up of node 7
  EXPECT_EQ(h.device->node_id(), 7);
  h.send("000#0107");  // start node 7
  EXPECT_EQ(h.device->state(), NmtState::operational);
  ASSERT_TRUE(h.device->raise_error(0x5000, 0x80));
  h.expect("087#0050810000000000", 1ms);  // EMCY 5000h, register 81h
}

TEST(NmtSlaveOnBus, InitialisationTimeDelaysBootUpAndCommandsWait) {
  // Given a device that takes 5 ms to initialise
  DeviceServicesConfig config;
  config.initialisation_time = 5ms;
  DeviceHarness h(5, {}, config);
  // When it is powered on and the master sends start at once
  h.device->power_on();
  h.send("000#0105");  // start node 5, while initialising
  // Then the boot-up starts at 5 ms and the early start was ignored
  const auto boot = h.expect("705#00", 10ms);  // boot-up of node 5
  EXPECT_EQ(h.start_of_frame(boot), at(5ms));
  EXPECT_EQ(h.device->state(), NmtState::pre_operational);
}

TEST(NmtSlaveOnBus, LocalCommandActsLikeTheMasters) {
  // Given a pre-operational device
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  // When the application starts itself, then resets its communication
  h.device->command(NmtCommand::start);
  EXPECT_EQ(h.device->state(), NmtState::operational);
  h.device->command(NmtCommand::reset_communication);
  // Then the reset ends in a boot-up as one from the master would
  h.expect("705#00", 1ms);  // boot-up of node 5
  EXPECT_EQ(h.device->state(), NmtState::pre_operational);
}

TEST(NmtSlaveOnBus, PowerOffSilencesUntilPowerOn) {
  // Given an operational device producing heartbeats every 10 ms
  DeviceObjectsOptions objects;
  objects.producer_heartbeat_ms = 10;
  DeviceHarness h(5, objects);
  ASSERT_TRUE(h.power_on());
  h.send("000#0105");        // start node 5
  h.expect("705#05", 20ms);  // heartbeat, operational
  // When it loses power
  h.device->power_off();
  // Then nothing comes, not even a boot-up after a reset command
  h.send("000#8105");  // reset node 5
  h.expect_silence(100ms);
  // When power returns
  h.device->power_on();
  // Then it boots up again into Pre-operational
  h.expect("705#00", 1ms);   // boot-up of node 5
  h.expect("705#7F", 20ms);  // heartbeat, pre-operational
}

// ---------------------------------------------------------------------------------------------
// 1029h error behaviour

TEST(ErrorBehaviour, CommunicationErrorReactionPerValue) {
  // Given the values of 1029h sub 01h (CiA 301 §7.5.2, 1029h)
  // When a communication error happens in each state
  // Then 0 leaves Operational for Pre-operational only, 1 changes nothing, 2 stops, and
  //   manufacturer-specific values change nothing here
  EXPECT_EQ(communication_error_command(NmtState::operational, 0),
            NmtCommand::enter_pre_operational);
  EXPECT_EQ(communication_error_command(NmtState::pre_operational, 0), std::nullopt);
  EXPECT_EQ(communication_error_command(NmtState::stopped, 0), std::nullopt);
  EXPECT_EQ(communication_error_command(NmtState::operational, 1), std::nullopt);
  EXPECT_EQ(communication_error_command(NmtState::operational, 2), NmtCommand::stop);
  EXPECT_EQ(communication_error_command(NmtState::pre_operational, 2), NmtCommand::stop);
  EXPECT_EQ(communication_error_command(NmtState::stopped, 2), std::nullopt);
  EXPECT_EQ(communication_error_command(NmtState::operational, 0x80), std::nullopt);
}

TEST(ErrorBehaviour, ObjectRefusesReservedValues) {
  // Given 1029h in a dictionary
  ObjectDictionary od(5);
  ASSERT_TRUE(add_error_behaviour_objects(od));
  // When values are written to sub 01h
  const std::uint8_t zero = 0, two = 2, three = 3, reserved = 0x7F, vendor = 0x80;
  // Then 0..2 and 80h..FFh are accepted, 03h..7Fh refused with 06090030h
  EXPECT_TRUE(od.write(0x1029, 1, {&two, 1}));
  EXPECT_TRUE(od.write(0x1029, 1, {&zero, 1}));
  EXPECT_TRUE(od.write(0x1029, 1, {&vendor, 1}));
  EXPECT_EQ(od.write(0x1029, 1, {&three, 1}).error(), SdoAbort::invalid_value);
  EXPECT_EQ(od.write(0x1029, 1, {&reserved, 1}).error(), SdoAbort::invalid_value);
  // And sub 00h is read-only 01h
  EXPECT_EQ(od.get(0x1029, 0).value().as_unsigned(), 1u);
  EXPECT_EQ(od.write(0x1029, 0, {&two, 1}).error(), SdoAbort::write_read_only);
}

}  // namespace
}  // namespace drivecheck::cia301
