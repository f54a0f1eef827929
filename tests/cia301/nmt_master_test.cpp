#include "protocol/cia301/nmt_master.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/error_control.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;

can::TimePoint at(can::Duration d) {
  return can::TimePoint{} + d;
}

TEST(NmtMaster, CommandFramesAndCommandedState) {
  // Given a fresh NMT master
  NmtMaster master;
  // When it commands start for node 5 and stop for all nodes
  const can::Frame start = master.command(NmtCommand::start, 5);
  // Then the frames are the NMT frames and the commanded states follow
  EXPECT_EQ(can::to_candump(start), "000#0105");
  EXPECT_EQ(master.node(5).commanded, NmtState::operational);
  EXPECT_FALSE(master.node(6).commanded.has_value());
  EXPECT_EQ(can::to_candump(master.command(NmtCommand::stop, 0)), "000#0200");
  EXPECT_EQ(master.node(6).commanded, NmtState::stopped);
  EXPECT_EQ(master.node(127).commanded, NmtState::stopped);
}

TEST(NmtMaster, TracksStatesFromBootUpAndHeartbeats) {
  // Given a master that reset node 1 (Festo vector 11/12: boot-up 701#00, then 7F, then 05)
  NmtMaster master;
  master.command(NmtCommand::reset_node, 1);
  // When the boot-up, a pre-operational heartbeat, a repeat and an operational one arrive
  const auto boot = master.on_frame(encode(BootUp{1}), at(1ms));
  const auto pre = master.on_frame(encode(Heartbeat{1, NmtState::pre_operational}), at(101ms));
  const auto repeat = master.on_frame(encode(Heartbeat{1, NmtState::pre_operational}), at(201ms));
  // Then boot-up and each change are events, a repeat is not; the state is tracked
  ASSERT_TRUE(boot);
  EXPECT_EQ(boot->kind, NmtEventKind::boot_up);
  EXPECT_EQ(master.node(1).boot_ups, 1u);
  ASSERT_TRUE(pre);
  EXPECT_EQ(pre->kind, NmtEventKind::state_changed);
  EXPECT_EQ(pre->previous, NmtState::boot_up);
  EXPECT_EQ(pre->state, NmtState::pre_operational);
  EXPECT_FALSE(repeat);
  EXPECT_TRUE(master.in_commanded_state(1));  // reset ends in pre-operational
  master.command(NmtCommand::start, 1);
  EXPECT_FALSE(master.in_commanded_state(1));
  const auto op = master.on_frame(encode(GuardResponse{1, true, NmtState::operational}), at(301ms));
  ASSERT_TRUE(op);
  EXPECT_EQ(master.state(1), NmtState::operational);
  EXPECT_TRUE(master.in_commanded_state(1));
  EXPECT_EQ(master.node(1).last_seen, at(301ms));
}

TEST(NmtMaster, IgnoresOtherFramesAndReportsInvalidOnes) {
  // Given a master
  NmtMaster master;
  // When it sees an SDO, a guarding request and a malformed error-control frame
  // Then only the malformed one is an event
  EXPECT_FALSE(master.on_frame(*can::parse_candump("581#4B41600034120000"), at(0ms)));
  EXPECT_FALSE(master.on_frame(*can::parse_candump("701#R"), at(0ms)));
  const auto bad = master.on_frame(*can::parse_candump("701#7F00"), at(0ms));
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->kind, NmtEventKind::invalid_frame);
  EXPECT_NE(bad->reason.find("DLC 2"), std::string::npos);
  EXPECT_FALSE(master.state(1).has_value());
}

TEST(NmtMasterPort, StartAndWaitOnSimulatedBus) {
  // Given a simulated bus with a master and a node-1 stand-in that obeys NMT and answers with a
  //   heartbeat 1 ms later
  can::SimBus bus;
  auto master_port = bus.attach("master");
  auto node = bus.attach("node1");
  node->set_frame_handler([&](const can::TimedFrame& frame) {
    const auto nmt = decode_nmt_node_control(frame.frame);
    if (!nmt || (nmt->node != 1 && nmt->node != 0)) return;
    const NmtState state = state_after(nmt->command);
    node->start_timer_after(1ms, [&node, state] { node->send(encode(Heartbeat{1, state})); });
  });
  std::vector<NmtEvent> events;
  NmtMasterPort nmt(*master_port, [&](const NmtEvent& event) { events.push_back(event); });
  // When the master sends start and waits for operational
  ASSERT_FALSE(nmt.send(NmtCommand::start, 1));
  const bool reached = nmt.wait_for_state(1, NmtState::operational, master_port->now() + 100ms);
  // Then the node reached it, and the event was reported once
  EXPECT_TRUE(reached);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].state, NmtState::operational);
  EXPECT_LT(master_port->now(), can::TimePoint{} + 5ms);
  // And waiting for a state the node never reports times out at the deadline
  const auto deadline = master_port->now() + 50ms;
  EXPECT_FALSE(nmt.wait_for_state(1, NmtState::stopped, deadline));
  EXPECT_EQ(master_port->now(), deadline);
  EXPECT_EQ(nmt.send(NmtCommand::start, 200), can::make_error_code(can::BusError::invalid_frame));
}

}  // namespace
}  // namespace drivecheck::cia301
