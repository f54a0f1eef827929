// Error control, node guarding (CiA 301 §7.2.8.3.2.1): the device answers guarding requests
// with a toggling state byte, watches its life time (100Ch × 100Dh) and stays silent while it
// produces heartbeats.
#include "protocol/cia301/guarding_slave.hpp"

#include <gtest/gtest.h>

#include "protocol/cia301/device_services.hpp"
#include "tests/cia301/device_harness.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;
using test_support::at;
using test_support::DeviceHarness;
using test_support::frame_of;

// ---------------------------------------------------------------------------------------------
// Pure state machine

TEST(GuardingSlave, ToggleStartsAtZeroAndAlternates) {
  // Given a guarding slave of node 5
  GuardingSlave slave(5);
  // When three requests arrive in Pre-operational
  const auto request = frame_of("705#R");  // RTR on 700h + 5, DLC 0
  const auto r1 = slave.on_frame(request, at(0ms), NmtState::pre_operational);
  const auto r2 = slave.on_frame(request, at(10ms), NmtState::pre_operational);
  const auto r3 = slave.on_frame(request, at(20ms), NmtState::pre_operational);
  // Then the answers are 7Fh, FFh, 7Fh (toggle 0, 1, 0)
  ASSERT_TRUE(r1.response && r2.response && r3.response);
  EXPECT_EQ(can::to_candump(*r1.response), "705#7F");  // t = 0, state 7Fh
  EXPECT_EQ(can::to_candump(*r2.response), "705#FF");  // t = 1, state 7Fh
  EXPECT_EQ(can::to_candump(*r3.response), "705#7F");  // t = 0
  // When the slave is reset (boot-up)
  slave.reset();
  // Then the toggle is 0 again
  const auto after = slave.on_frame(request, at(30ms), NmtState::operational);
  ASSERT_TRUE(after.response);
  EXPECT_EQ(can::to_candump(*after.response), "705#05");  // guarding answer: toggle 0, operational
}

TEST(GuardingSlave, OnlyRequestsForThisNodeAreAnswered) {
  // Given a guarding slave of node 5
  GuardingSlave slave(5);
  // When other frames arrive
  // Then none is answered: another node's request, a data frame, a 29-bit RTR, an RTR with
  //   DLC 8
  const auto answered = [&slave](const char* text) {
    return slave.on_frame(frame_of(text), at(0ms), NmtState::operational).response.has_value();
  };
  EXPECT_FALSE(answered("706#R"));       // RTR on 700h + 6: node 6's request
  EXPECT_FALSE(answered("705#05"));      // data frame on 705h: a heartbeat, no request
  EXPECT_FALSE(answered("00000705#R"));  // RTR with the 29-bit identifier 705h
  EXPECT_FALSE(answered("705#R8"));      // RTR on 705h with DLC 8
  // And an RTR with DLC 1 (as some masters send it) is answered
  EXPECT_TRUE(answered("705#R1"));  // RTR on 705h, DLC 1
}

TEST(GuardingSlave, LifeGuardingStartsWithFirstRequest) {
  // Given guard time 100 ms × life time factor 3
  GuardingSlave slave(5);
  slave.configure(100ms, 3);
  // When no request ever came
  // Then nothing is due (Festo L1497: monitoring begins with the first request)
  EXPECT_EQ(slave.next_deadline(), can::kForever);
  // When a request comes at 1 s and then nothing
  const auto request = frame_of("705#R");  // guarding request: RTR on 700h + 5
  slave.on_frame(request, at(1s), NmtState::operational);
  // Then the life guarding event is due at 1.3 s exactly, once
  EXPECT_EQ(slave.next_deadline(), at(1300ms));
  EXPECT_FALSE(slave.on_time(at(1299ms)));
  const auto event = slave.on_time(at(1300ms));
  ASSERT_TRUE(event);
  EXPECT_EQ(event->kind, LifeGuardingEventKind::expired);
  EXPECT_EQ(event->time, at(1300ms));
  EXPECT_FALSE(slave.on_time(at(5s)));
  // When the next request comes
  const auto back = slave.on_frame(request, at(6s), NmtState::operational);
  // Then it is answered and the event resolved
  EXPECT_TRUE(back.response);
  ASSERT_TRUE(back.event);
  EXPECT_EQ(back.event->kind, LifeGuardingEventKind::resolved);
}

TEST(GuardingSlave, ZeroGuardTimeOrFactorMeansNoLifeGuarding) {
  for (const auto& [guard, factor] :
       {std::pair{0ms, std::uint8_t{3}}, std::pair{100ms, std::uint8_t{0}}}) {
    // Given guard time × factor = 0
    GuardingSlave slave(5);
    slave.configure(guard, factor);
    // When requests come
    slave.on_frame(frame_of("705#R"), at(0ms), NmtState::operational);  // RTR on 700h + 5
    // Then they are answered but never watched
    EXPECT_EQ(slave.next_deadline(), can::kForever);
  }
}

// ---------------------------------------------------------------------------------------------
// On the bus

TEST(GuardingSlaveOnBus, AnswersInEveryStateWithToggle) {
  // Given a device of node 5 with 1017h = 0, just booted
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  // When the master polls twice in each state
  // Then the answers carry the state and a toggle that started at 0 after boot-up
  //   (Festo §3.9.2 L1499; Kollmorgen §4.4.8)
  h.send("705#R");          // guarding request: RTR on 705h
  h.expect("705#7F", 1ms);  // t 0, pre-operational
  h.send("705#R");          // guarding request: RTR on 705h
  h.expect("705#FF", 1ms);  // t 1, pre-operational
  h.send("000#0105");       // start node 5
  h.send("705#R");          // guarding request: RTR on 705h
  h.expect("705#05", 1ms);  // t 0, operational
  h.send("705#R");          // guarding request: RTR on 705h
  h.expect("705#85", 1ms);  // t 1, operational
  h.send("000#0205");       // stop node 5: error control still runs
  h.send("705#R");          // guarding request: RTR on 705h
  h.expect("705#04", 1ms);  // t 0, stopped
  h.send("705#R");          // guarding request: RTR on 705h
  h.expect("705#84", 1ms);  // t 1, stopped
}

TEST(GuardingSlaveOnBus, ResetCommunicationRestartsToggle) {
  // Given a device that answered once (next toggle 1)
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  h.send("705#R");          // guarding request: RTR on 705h
  h.expect("705#7F", 1ms);  // guarding answer: toggle 0, pre-operational
  // When the master resets its communication
  h.send("000#8205");       // reset communication node 5
  h.expect("705#00", 1ms);  // boot-up of node 5
  // Then the next answer carries toggle 0 again
  h.send("705#R");          // guarding request: RTR on 705h
  h.expect("705#7F", 1ms);  // guarding answer: toggle 0, pre-operational
}

TEST(GuardingSlaveOnBus, NoAnswerWhileHeartbeatProduced) {
  // Given a device whose producer heartbeat time is 1000 ms
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1017, 0, 1000, 2));
  // When the master polls
  h.send("705#R");  // guarding request: RTR on 705h
  // Then the device does not answer (CiA 301 §7.2.8.3.2: heartbeat when 1017h ≠ 0, never both)
  h.expect_silence(100ms);
  // When 1017h goes back to 0
  ASSERT_TRUE(h.write(0x1017, 0, 0, 2));
  h.send("705#R");  // guarding request: RTR on 705h
  // Then it answers again
  h.expect("705#7F", 1ms);  // guarding answer: toggle 0, pre-operational
}

TEST(GuardingSlaveOnBus, LifeGuardingEventRaisesEmcyAndErrorBehaviour) {
  // Given an operational device with guard time 100 ms × factor 3 and 1029h = 0
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x100C, 0, 100, 2));  // guard time 100 ms
  ASSERT_TRUE(h.write(0x100D, 0, 3, 1));    // life time factor 3
  h.send("000#0105");                       // start node 5
  // When the master polls once and then stops polling
  h.send("705#R");  // guarding request: RTR on 705h
  const can::TimePoint polled = h.bus.now();
  h.expect("705#05", 1ms);  // guarding answer: toggle 0, operational
  // Then EMCY 8130h starts exactly one life time (300 ms) after the request, and the device
  //   falls back to Pre-operational
  const auto emcy = h.expect("085#3081110000000000", 400ms);  // 8130h, reg 11h
  EXPECT_EQ(h.start_of_frame(emcy), polled + 300ms);
  EXPECT_EQ(h.device->state(), NmtState::pre_operational);
  // When the master polls again
  h.send("705#R");  // guarding request: RTR on 705h
  // Then the device answers (toggle 1, pre-operational) and resets the error
  h.expect("705#FF", 1ms);                // guarding answer: toggle 1, pre-operational
  h.expect("085#0000000000000000", 1ms);  // EMCY error reset 0000h, register 00h
}

TEST(GuardingSlaveOnBus, RegularPollingKeepsTheDeviceQuiet) {
  // Given guard time 100 ms × factor 2 (life time 200 ms)
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x100C, 0, 100, 2));
  ASSERT_TRUE(h.write(0x100D, 0, 2, 1));
  // When the master polls every 150 ms for 3 s
  for (int i = 0; i < 20; ++i) {
    h.send("705#R");  // guarding request: RTR on 705h
    // Then each poll gets its answer and nothing else comes
    ASSERT_TRUE(h.next(1ms));
    h.expect_silence(150ms);
  }
}

TEST(GuardingSlaveOnBus, NewLifeTimeTakesEffectAtOnce) {
  // Given life time 300 ms and a request at t0
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x100C, 0, 100, 2));
  ASSERT_TRUE(h.write(0x100D, 0, 3, 1));
  h.send("705#R");  // guarding request: RTR on 705h
  const can::TimePoint polled = h.bus.now();
  h.expect("705#7F", 1ms);  // guarding answer: toggle 0, pre-operational
  // When the guard time is raised to 500 ms at t0 + 100 ms (life time 1.5 s)
  h.run_to(polled + 100ms);
  ASSERT_TRUE(h.write(0x100C, 0, 500, 2));
  // Then the event comes at t0 + 1.5 s, not at t0 + 300 ms
  const auto emcy = h.expect("085#3081110000000000", 2s);  // EMCY 8130h, register 11h
  EXPECT_EQ(h.start_of_frame(emcy), polled + 1500ms);
}

}  // namespace
}  // namespace drivecheck::cia301
