// Error control, heartbeat (CiA 301 §7.2.8.3.2.2): the device's heartbeat producer (1017h) and
// its heartbeat consumer (1016h), with the EMCY and the error behaviour (1029h) a consumer
// timeout leads to.
#include "protocol/cia301/heartbeat_producer.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "protocol/cia301/device_services.hpp"
#include "protocol/cia301/heartbeat_consumer_objects.hpp"
#include "tests/cia301/device_harness.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;
using test_support::at;
using test_support::DeviceHarness;

DeviceObjectsOptions heartbeat_every(std::uint16_t ms) {
  DeviceObjectsOptions options;
  options.producer_heartbeat_ms = ms;
  return options;
}

// ---------------------------------------------------------------------------------------------
// Producer, pure

TEST(HeartbeatProducer, DueOnePeriodAfterBootUpThenOnAFixedGrid) {
  // Given a producer of node 5 with 100 ms, started by a boot-up at 0
  HeartbeatProducer producer(5);
  producer.set_period(100ms, at(0ms));
  producer.start(at(0ms));
  // When time passes
  // Then nothing is due before 100 ms, then heartbeats at 100 ms and 200 ms with the state
  EXPECT_EQ(producer.next_deadline(), at(100ms));
  EXPECT_FALSE(producer.on_time(at(99ms), NmtState::pre_operational));
  const auto first = producer.on_time(at(100ms), NmtState::pre_operational);
  ASSERT_TRUE(first);
  EXPECT_EQ(can::to_candump(*first), "705#7F");  // 700h + 5, state 7Fh pre-operational
  EXPECT_EQ(producer.next_deadline(), at(200ms));
  // When a call comes 30 ms late
  const auto late = producer.on_time(at(230ms), NmtState::operational);
  // Then the heartbeat goes out and the next stays on the grid (300 ms, no drift)
  ASSERT_TRUE(late);
  EXPECT_EQ(can::to_candump(*late), "705#05");  // heartbeat of node 5: operational
  EXPECT_EQ(producer.next_deadline(), at(300ms));
}

TEST(HeartbeatProducer, VeryLateCallSkipsMissedHeartbeats) {
  // Given a producer with 10 ms started at 0
  HeartbeatProducer producer(5);
  producer.set_period(10ms, at(0ms));
  producer.start(at(0ms));
  // When it is called only at 55 ms
  // Then one heartbeat goes out (no burst), four are counted as missed, the next is at 60 ms
  EXPECT_TRUE(producer.on_time(at(55ms), NmtState::operational));
  EXPECT_FALSE(producer.on_time(at(55ms), NmtState::operational));
  EXPECT_EQ(producer.missed(), 4u);
  EXPECT_EQ(producer.next_deadline(), at(60ms));
}

TEST(HeartbeatProducer, StoppedOrZeroPeriodProducesNothing) {
  // Given a producer with period 0, and one stopped for a reset
  HeartbeatProducer off(5);
  off.start(at(0ms));
  HeartbeatProducer stopped(5);
  stopped.set_period(10ms, at(0ms));
  stopped.start(at(0ms));
  stopped.stop();
  // When time passes
  // Then neither is ever due
  EXPECT_EQ(off.next_deadline(), can::kForever);
  EXPECT_EQ(stopped.next_deadline(), can::kForever);
  EXPECT_FALSE(stopped.on_time(at(1s), NmtState::operational));
}

// ---------------------------------------------------------------------------------------------
// Producer on the bus

TEST(HeartbeatProducerOnBus, FirstHeartbeatOnePeriodAfterBootUp) {
  // Given a device whose stored 1017h is 100 ms (Festo L1465: the boot-up is the first
  //   heartbeat)
  DeviceHarness h(5, heartbeat_every(100));
  // When it is powered on at 0
  const auto boot = h.power_on();
  ASSERT_TRUE(boot);
  EXPECT_EQ(h.start_of_frame(*boot), at(0ms));
  // Then the first heartbeat starts exactly 100 ms after the boot-up
  const auto first = h.expect("705#7F", 200ms);  // heartbeat, pre-operational
  EXPECT_EQ(h.start_of_frame(first), at(100ms));
}

TEST(HeartbeatProducerOnBus, PeriodIsExactOverManyHeartbeats) {
  // Given a device with 1017h = 100 ms, powered on at 0
  DeviceHarness h(5, heartbeat_every(100));
  ASSERT_TRUE(h.power_on());
  // When 20 heartbeats are received
  // Then heartbeat k starts at exactly k × 100 ms (simulated time: no jitter allowed)
  for (int k = 1; k <= 20; ++k) {
    const auto beat = h.expect("705#7F", 150ms);  // heartbeat of node 5: pre-operational
    EXPECT_EQ(h.start_of_frame(beat), at(k * 100ms)) << "heartbeat " << k;
  }
}

TEST(HeartbeatProducerOnBus, StateByteFollowsNmtState) {
  // Given a device with 1017h = 50 ms
  DeviceHarness h(5, heartbeat_every(50));
  ASSERT_TRUE(h.power_on());
  h.expect("705#7F", 60ms);  // pre-operational
  // When the master starts, stops and pre-operationals node 5
  // Then the heartbeats carry 05h, 04h and 7Fh
  h.send("000#0105");        // start node 5
  h.expect("705#05", 60ms);  // operational
  h.send("000#0205");        // stop node 5
  h.expect("705#04", 60ms);  // stopped: heartbeat still produced
  h.send("000#8005");        // enter pre-operational node 5
  h.expect("705#7F", 60ms);  // heartbeat of node 5: pre-operational
}

TEST(HeartbeatProducerOnBus, PeriodChangeAtRunTimeRestartsTimer) {
  // Given a device with 1017h = 100 ms: heartbeats at 100 and 200 ms
  DeviceHarness h(5, heartbeat_every(100));
  ASSERT_TRUE(h.power_on());
  h.expect("705#7F", 150ms);  // heartbeat of node 5: pre-operational
  h.expect("705#7F", 150ms);  // heartbeat of node 5: pre-operational
  // When 1017h is written with 40 ms at 250 ms
  h.run_to(at(250ms));
  ASSERT_TRUE(h.write(0x1017, 0, 40, 2));
  // Then the next heartbeats start at 290, 330, 370 ms (the 300 ms one is gone)
  for (const auto t : {290ms, 330ms, 370ms}) {
    const auto beat = h.expect("705#7F", 100ms);  // heartbeat of node 5: pre-operational
    EXPECT_EQ(h.start_of_frame(beat), at(t));
  }
}

TEST(HeartbeatProducerOnBus, ZeroStopsAndNonZeroStartsOnePeriodLater) {
  // Given a device with 1017h = 0 (default): no heartbeat
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  h.expect_silence(500ms);
  // When 1017h = 50 ms is written at 600 ms
  h.run_to(at(600ms));
  ASSERT_TRUE(h.write(0x1017, 0, 50, 2));
  // Then heartbeats start at 650 ms
  const auto first = h.expect("705#7F", 100ms);  // heartbeat of node 5: pre-operational
  EXPECT_EQ(h.start_of_frame(first), at(650ms));
  // When 1017h = 0 is written
  ASSERT_TRUE(h.write(0x1017, 0, 0, 2));
  // Then no heartbeat follows
  h.expect_silence(1s);
}

TEST(HeartbeatProducerOnBus, NoHeartbeatWhileInitialisingAfterReset) {
  // Given a device with 1017h = 20 ms that takes 30 ms to initialise
  DeviceServicesConfig config;
  config.initialisation_time = 30ms;
  DeviceHarness h(5, heartbeat_every(20), config);
  h.device->power_on();
  const auto boot = h.expect("705#00", 50ms);  // boot-up of node 5
  EXPECT_EQ(h.start_of_frame(boot), at(30ms));
  // When the node is reset at once
  h.send("000#8105");  // reset node 5
  const can::TimePoint reset = h.bus.now();
  // Then no heartbeat comes during the 30 ms of initialisation; the boot-up comes at +30 ms
  //   and the heartbeat 20 ms after it
  const auto again = h.expect("705#00", 50ms);  // boot-up of node 5
  EXPECT_EQ(h.start_of_frame(again), reset + 30ms);
  const auto beat = h.expect("705#7F", 50ms);  // heartbeat of node 5: pre-operational
  EXPECT_EQ(h.start_of_frame(beat), reset + 50ms);
}

// ---------------------------------------------------------------------------------------------
// Consumer: 1016h

TEST(HeartbeatConsumerObjects, DuplicateNodeIdRefusedWithParameterIncompatibility) {
  // Given 1016h with 4 entries
  ObjectDictionary od(5);
  ASSERT_TRUE(add_heartbeat_consumer_objects(od, 4));
  const auto write = [&od](std::uint8_t sub, std::uint32_t value) {
    std::vector<std::uint8_t> bytes(4);
    store_unsigned(value, bytes);
    return od.write(0x1016, sub, bytes);
  };
  // When sub 1 monitors node 9 with 150 ms
  // Then a second used entry for node 9 is refused with 06040043h (CiA 301 §7.5.2, 1016h)
  ASSERT_TRUE(write(1, 0x00090096));  // node 9, 150 ms
  EXPECT_EQ(write(2, 0x000900C8).error(), SdoAbort::general_parameter_incompatibility);
  // And unused entries naming node 9 (time 0), node 0, and a new time in the same sub-index
  //   are accepted
  EXPECT_TRUE(write(2, 0x00090000));  // node 9, time 0: not used
  EXPECT_TRUE(write(3, 0x000000C8));  // node 0: not used
  EXPECT_TRUE(write(1, 0x0009012C));  // node 9, 300 ms in the same sub-index
  EXPECT_TRUE(write(4, 0x000A0096));  // node 10
  // And reserved bits 31..24 or a node-ID above 127 are invalid values
  EXPECT_EQ(write(2, 0x010B0096).error(), SdoAbort::invalid_value);
  EXPECT_EQ(write(2, 0x00800096).error(), SdoAbort::invalid_value);
  // And sub 00h is read-only: 4 entries
  EXPECT_EQ(od.get(0x1016, 0).value().as_unsigned(), 4u);
  const auto entries = consumer_heartbeat_entries(od);
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_EQ(entries[0], (ConsumerHeartbeatEntry{9, 300}));
  EXPECT_EQ(entries[1], (ConsumerHeartbeatEntry{10, 150}));
}

// Node 9 (the master's port) sends a heartbeat; returns its delivery time.
can::TimePoint heartbeat_from_9(DeviceHarness& h) {
  h.send("709#05");  // heartbeat of node 9, operational
  return h.bus.now();
}

TEST(HeartbeatConsumerOnBus, NoTimeoutBeforeFirstHeartbeat) {
  // Given a device consuming node 9 with 150 ms
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1016, 1, 0x00090096, 4));  // node 9, 150 ms
  // When node 9 never sends a heartbeat
  // Then monitoring never starts: no EMCY (CiA 301 §7.5.2, 1016h: monitoring starts after the
  //   reception of the first heartbeat)
  h.expect_silence(2s);
  EXPECT_EQ(h.read(0x1001, 0).value(), 0u);
}

TEST(HeartbeatConsumerOnBus, TimeoutRaisesEmcy8130AtTheConsumerTime) {
  // Given a pre-operational device consuming node 9 with 150 ms
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1016, 1, 0x00090096, 4));  // node 9, 150 ms
  // When node 9 sends one heartbeat and falls silent
  const can::TimePoint last = heartbeat_from_9(h);
  // Then EMCY 8130h (life guard / heartbeat error), register 11h (generic + communication),
  //   starts exactly 150 ms after that heartbeat
  const auto emcy = h.expect("085#3081110000000000", 200ms);  // 8130h LE, reg 11h, mfr 0
  EXPECT_EQ(h.start_of_frame(emcy), last + 150ms);
  // And 1001h and 1003h record it; pre-operational stays (1029h = 0 acts in Operational only)
  EXPECT_EQ(h.read(0x1001, 0).value(), 0x11u);
  EXPECT_EQ(h.read(0x1003, 0).value(), 1u);
  EXPECT_EQ(h.read(0x1003, 1).value(), 0x8130u);
  EXPECT_EQ(h.device->state(), NmtState::pre_operational);
  // And it is reported once only
  h.expect_silence(1s);
}

TEST(HeartbeatConsumerOnBus, HeartbeatsInTimeKeepTheDeviceQuiet) {
  // Given a device consuming node 9 with 150 ms
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1016, 1, 0x00090096, 4));  // node 9, 150 ms
  // When node 9 sends a heartbeat every 100 ms for 2 s
  for (int i = 0; i < 20; ++i) {
    heartbeat_from_9(h);
    // Then no EMCY comes
    h.expect_silence(100ms);
  }
}

TEST(HeartbeatConsumerOnBus, HeartbeatResumedSendsErrorReset) {
  // Given a device whose consumer of node 9 timed out
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1016, 1, 0x00090096, 4));  // node 9, 150 ms
  heartbeat_from_9(h);
  h.expect("085#3081110000000000", 200ms);  // EMCY 8130h
  // When node 9 sends heartbeats again
  heartbeat_from_9(h);
  // Then the error is cleared: EMCY 0000h "error reset" with register 00h, 1001h = 0
  h.expect("085#0000000000000000", 1ms);  // EMCY error reset 0000h, register 00h
  EXPECT_EQ(h.read(0x1001, 0).value(), 0u);
}

struct BehaviourCase {
  std::uint8_t behaviour;  // 1029h sub 01h
  NmtState after;
};

TEST(HeartbeatConsumerOnBus, TimeoutInOperationalAppliesErrorBehaviour) {
  for (const auto& c :
       {BehaviourCase{0, NmtState::pre_operational}, BehaviourCase{1, NmtState::operational},
        BehaviourCase{2, NmtState::stopped}}) {
    SCOPED_TRACE(static_cast<int>(c.behaviour));
    // Given an operational device consuming node 9 with 150 ms and 1029h sub 01h set
    DeviceHarness h;
    ASSERT_TRUE(h.power_on());
    ASSERT_TRUE(h.write(0x1029, 1, c.behaviour, 1));
    ASSERT_TRUE(h.write(0x1016, 1, 0x00090096, 4));  // node 9, 150 ms
    h.send("000#0105");                              // start node 5
    // When node 9's heartbeat times out
    heartbeat_from_9(h);
    // Then the EMCY goes out first, then the state is the one 1029h asks for
    h.expect("085#3081110000000000", 200ms);  // EMCY 8130h, register 11h
    EXPECT_EQ(h.device->state(), c.after);
  }
}

TEST(HeartbeatConsumerOnBus, ReconfiguredEntryWaitsForNextHeartbeat) {
  // Given a device consuming node 9 with 150 ms that got a heartbeat at t0
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1016, 1, 0x00090096, 4));  // node 9, 150 ms
  const can::TimePoint t0 = heartbeat_from_9(h);
  // When the entry is rewritten to 500 ms at t0 + 100 ms
  h.run_to(t0 + 100ms);
  ASSERT_TRUE(h.write(0x1016, 1, 0x000901F4, 4));  // node 9, 500 ms
  // Then no timeout at t0 + 150 ms: the entry restarted and waits for a heartbeat
  h.expect_silence(1s);
  // When the next heartbeat comes
  const can::TimePoint t1 = heartbeat_from_9(h);
  // Then the timeout is due 500 ms after it
  const auto emcy = h.expect("085#3081110000000000", 600ms);  // EMCY 8130h, register 11h
  EXPECT_EQ(h.start_of_frame(emcy), t1 + 500ms);
}

TEST(HeartbeatConsumerOnBus, RemovingTimedOutNodeClearsTheError) {
  // Given a device whose consumer of node 9 timed out
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1016, 1, 0x00090096, 4));  // node 9, 150 ms
  heartbeat_from_9(h);
  h.expect("085#3081110000000000", 200ms);  // EMCY 8130h, register 11h
  // When the master stops monitoring node 9 (entry 0)
  ASSERT_TRUE(h.write(0x1016, 1, 0, 4));
  // Then the communication error is gone: error reset EMCY
  h.expect("085#0000000000000000", 1ms);  // EMCY error reset 0000h, register 00h
}

}  // namespace
}  // namespace drivecheck::cia301
