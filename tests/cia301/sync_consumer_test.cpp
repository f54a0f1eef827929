// SYNC (CiA 301 §7.2.5) on the device: consumption with and without counter, the wrong-length
// EMCY 8240h, the synchronous window 1007h, the rules of 1005h and 1019h, and the device's own
// SYNC production (1005h bit 30, 1006h).
#include "protocol/cia301/sync_consumer.hpp"

#include <gtest/gtest.h>

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
// Pure state machine

TEST(SyncConsumer, SyncWithAndWithoutCounter) {
  // Given a consumer on 080h without counter, and one with 1019h = 10
  SyncConsumer plain;
  SyncConsumer counted;
  counted.configure({SyncCobIdEntry{}, 10, can::Duration{0}});
  // When SYNCs of the configured length arrive
  const auto a = plain.on_frame(frame_of("080#"), at(1ms));      // SYNC, DLC 0
  const auto b = counted.on_frame(frame_of("080#07"), at(2ms));  // SYNC, counter 7
  // Then each is a SYNC, the counted one with its counter
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->kind, SyncConsumerEventKind::sync);
  EXPECT_EQ(a->counter, std::nullopt);
  EXPECT_EQ(b->kind, SyncConsumerEventKind::sync);
  EXPECT_EQ(b->counter, 7);
  // And other identifiers and remote frames are not SYNC
  EXPECT_FALSE(plain.on_frame(frame_of("081#"), at(3ms)));       // DLC 0 on 081h (node 1's EMCY id)
  EXPECT_FALSE(plain.on_frame(frame_of("080#R"), at(3ms)));      // guarding request: RTR on 080h
  EXPECT_FALSE(plain.on_frame(frame_of("00000080#"), at(3ms)));  // 29-bit identifier 80h
}

TEST(SyncConsumer, WrongLengthIsNotASync) {
  // Given a consumer without counter and one with 1019h = 10
  SyncConsumer plain;
  SyncConsumer counted;
  counted.configure({SyncCobIdEntry{}, 10, can::Duration{0}});
  // When frames of the wrong length arrive on 080h
  // Then each is wrong_length and no SYNC is recorded
  // DLC 1, 2 and 8 on 080h while 1019h = 0
  for (const char* text : {"080#01", "080#0102", "080#0000000000000000"}) {
    const auto event = plain.on_frame(frame_of(text), at(1ms));
    ASSERT_TRUE(event) << text;
    EXPECT_EQ(event->kind, SyncConsumerEventKind::wrong_length) << text;
  }
  // DLC 0 and 2 on 080h while 1019h = 10 (DLC 1 expected)
  for (const char* text : {"080#", "080#0102"}) {
    const auto event = counted.on_frame(frame_of(text), at(1ms));
    ASSERT_TRUE(event) << text;
    EXPECT_EQ(event->kind, SyncConsumerEventKind::wrong_length) << text;
  }
  EXPECT_FALSE(plain.last_sync());
  EXPECT_EQ(plain.wrong_lengths(), 3u);
}

TEST(SyncConsumer, SynchronousWindowEndsExactly) {
  // Given a synchronous window of 2 ms (1007h = 2000 µs)
  SyncConsumer consumer;
  consumer.configure({SyncCobIdEntry{}, 0, 2ms});
  // When no SYNC came yet
  // Then synchronous PDOs may not be sent
  EXPECT_FALSE(consumer.in_window(at(0ms)));
  // When a SYNC arrives at 10 ms
  consumer.on_frame(frame_of("080#"), at(10ms));  // SYNC without counter
  // Then the window is open until just before 12 ms and window_closed is due at 12 ms
  EXPECT_TRUE(consumer.in_window(at(10ms)));
  EXPECT_TRUE(consumer.in_window(at(11999us)));
  EXPECT_FALSE(consumer.in_window(at(12ms)));
  EXPECT_EQ(consumer.next_deadline(), at(12ms));
  EXPECT_FALSE(consumer.on_time(at(11999us)));
  const auto closed = consumer.on_time(at(12ms));
  ASSERT_TRUE(closed);
  EXPECT_EQ(closed->kind, SyncConsumerEventKind::window_closed);
  EXPECT_EQ(consumer.next_deadline(), can::kForever);
}

TEST(SyncConsumer, NoWindowMeansAlwaysInWindowAfterASync) {
  // Given 1007h = 0
  SyncConsumer consumer;
  consumer.on_frame(frame_of("080#"), at(0ms));  // SYNC without counter
  // When much later
  // Then still in the window, nothing due
  EXPECT_TRUE(consumer.in_window(at(10s)));
  EXPECT_EQ(consumer.next_deadline(), can::kForever);
}

// ---------------------------------------------------------------------------------------------
// Objects

TEST(SyncObjects, CobIdRules) {
  // Given the SYNC objects of a device that can produce SYNC, and of one that cannot
  ObjectDictionary od(5);
  ASSERT_TRUE(add_sync_objects(od, {true}));
  ObjectDictionary consumer_only(5);
  ASSERT_TRUE(add_sync_objects(consumer_only, {false}));
  const auto write = [](ObjectDictionary& d, std::uint32_t value) {
    std::vector<std::uint8_t> bytes(4);
    store_unsigned(value, bytes);
    return d.write(0x1005, 0, bytes);
  };
  // When 1005h is written
  // Then: default 80h; bit 30 refused where SYNC cannot be produced (06090030h); bits 28..11
  //   for an 11-bit CAN-ID and restricted CAN-IDs refused
  EXPECT_EQ(od.get(0x1005, 0).value().as_unsigned(), 0x80u);
  EXPECT_EQ(write(consumer_only, 0x40000080).error(), SdoAbort::invalid_value);
  EXPECT_EQ(write(od, 0x00000880).error(), SdoAbort::invalid_value);
  EXPECT_EQ(write(od, 0x00000000).error(), SdoAbort::invalid_value);  // NMT's 000h
  EXPECT_EQ(write(od, 0x00000601).error(), SdoAbort::invalid_value);  // default SDO rx
  EXPECT_TRUE(write(od, 0x00000081));  // another CAN-ID while not producing: fine
  EXPECT_TRUE(write(od, 0x80000081));  // bit 31 is don't care
  // When the device produces SYNC (bit 30)
  ASSERT_TRUE(write(od, 0x40000081));
  // Then bits 0..29 may not change (CiA 301 §7.5.2, 1005h), bit 30 may be cleared
  EXPECT_EQ(write(od, 0x40000082).error(), SdoAbort::invalid_value);
  EXPECT_EQ(write(od, 0x60000081).error(), SdoAbort::invalid_value);
  EXPECT_TRUE(write(od, 0x00000081));
}

TEST(SyncObjects, CounterOverflowRules) {
  // Given the SYNC objects
  ObjectDictionary od(5);
  ASSERT_TRUE(add_sync_objects(od));
  const auto write8 = [&od](std::uint16_t index, std::uint8_t value) {
    return od.write(index, 0, {&value, 1});
  };
  // When 1019h is written
  // Then 0 and 2..240 are accepted, 1 and 241..255 refused with 06090030h
  EXPECT_TRUE(write8(0x1019, 0));
  EXPECT_TRUE(write8(0x1019, 2));
  EXPECT_TRUE(write8(0x1019, 240));
  EXPECT_EQ(write8(0x1019, 1).error(), SdoAbort::invalid_value);
  EXPECT_EQ(write8(0x1019, 241).error(), SdoAbort::invalid_value);
  EXPECT_EQ(write8(0x1019, 255).error(), SdoAbort::invalid_value);
  // When the communication cycle period is not 0
  std::vector<std::uint8_t> period(4);
  store_unsigned(1000, period);
  ASSERT_TRUE(od.write(0x1006, 0, period));
  // Then 1019h may not change (08000022h present device state); the same value is fine
  EXPECT_EQ(write8(0x1019, 10).error(), SdoAbort::cannot_transfer_device_state);
  EXPECT_TRUE(write8(0x1019, 240));
}

// ---------------------------------------------------------------------------------------------
// On the bus

struct SyncRecorder {
  std::vector<SyncConsumerEvent> events;
  DeviceServicesHandlers handlers() {
    DeviceServicesHandlers h;
    h.on_sync = [this](const SyncConsumerEvent& e) { events.push_back(e); };
    return h;
  }
};

TEST(SyncConsumerOnBus, SyncReachesTheOwnerOnlyInPreOperationalAndOperational) {
  // Given a device whose owner records SYNC events
  SyncRecorder recorder;
  DeviceHarness h(5, {}, {}, recorder.handlers());
  ASSERT_TRUE(h.power_on());
  // When SYNCs come in Pre-operational, Operational and Stopped
  h.send("080#");      // SYNC
  h.send("000#0105");  // start node 5
  h.send("080#");      // SYNC without counter
  h.send("000#0205");  // stop node 5
  h.send("080#");      // SYNC without counter
  // Then the two first are reported, the one in Stopped is not (CiA 301 §7.3.2.2)
  ASSERT_EQ(recorder.events.size(), 2u);
  EXPECT_EQ(recorder.events[0].kind, SyncConsumerEventKind::sync);
  EXPECT_EQ(recorder.events[1].kind, SyncConsumerEventKind::sync);
  EXPECT_EQ(h.device->sync_consumer().received(), 2u);
}

TEST(SyncConsumerOnBus, WrongLengthRaisesEmcy8240ClearedByNextGoodSync) {
  // Given a pre-operational device with 1019h = 0
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  // When a SYNC with one data byte arrives
  h.send("080#01");  // SYNC with a counter the device does not expect
  // Then EMCY 8240h "unexpected SYNC data length", register 11h, is sent once
  h.expect("085#4082110000000000", 1ms);  // 8240h LE, reg 11h (generic + communication)
  h.send("080#02");                       // SYNC, counter 2
  h.expect_silence(10ms);
  // When a SYNC of the right length follows
  h.send("080#");  // SYNC without counter
  // Then the error is reset
  h.expect("085#0000000000000000", 1ms);  // EMCY error reset 0000h, register 00h
}

TEST(SyncConsumerOnBus, CounterExpectedWhenConfigured) {
  // Given a device with 1019h = 4
  SyncRecorder recorder;
  DeviceHarness h(5, {}, {}, recorder.handlers());
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1019, 0, 4, 1));
  // When a SYNC with counter 3 and one without counter arrive
  h.send("080#03");  // SYNC counter 3
  h.send("080#");    // SYNC without counter
  // Then the first is a SYNC with counter 3, the second raises 8240h
  ASSERT_EQ(recorder.events.size(), 2u);
  EXPECT_EQ(recorder.events[0].counter, 3);
  EXPECT_EQ(recorder.events[1].kind, SyncConsumerEventKind::wrong_length);
  h.expect("085#4082110000000000", 1ms);  // EMCY 8240h, register 11h
}

TEST(SyncConsumerOnBus, WindowClosedReportedAtSyncPlusWindow) {
  // Given a device with 1007h = 3000 µs
  SyncRecorder recorder;
  DeviceHarness h(5, {}, {}, recorder.handlers());
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1007, 0, 3000, 4));
  // When a SYNC arrives
  h.send("080#");  // SYNC without counter
  const can::TimePoint sync = h.bus.now();
  h.run_to(sync + 10ms);
  // Then window_closed is reported exactly 3 ms after it
  ASSERT_EQ(recorder.events.size(), 2u);
  EXPECT_EQ(recorder.events[1].kind, SyncConsumerEventKind::window_closed);
  EXPECT_EQ(recorder.events[1].time, sync + 3ms);
  EXPECT_FALSE(h.device->sync_consumer().in_window(h.bus.now()));
}

TEST(SyncProducerOnDevice, ProducesSyncEveryCycleWithCounter) {
  // Given a device told to produce SYNC: 1006h = 1000 µs, 1019h = 3, then 1005h bit 30
  SyncRecorder recorder;
  DeviceHarness h(5, {}, {}, recorder.handlers());
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1019, 0, 3, 1));
  ASSERT_TRUE(h.write(0x1006, 0, 1000, 4));
  const can::TimePoint t0 = h.bus.now();
  ASSERT_TRUE(h.write(0x1005, 0, 0x40000080, 4));  // gen = 1, CAN-ID 080h
  // When 5 SYNCs are received
  // Then they start exactly 1, 2, ... 5 ms after bit 30 was set (the first within one cycle),
  //   counting 1, 2, 3, 1, 2
  // SYNC on 080h with counter byte 1, 2, 3, then back to 1 after the overflow value 3
  const char* expected[] = {"080#01", "080#02", "080#03", "080#01", "080#02"};
  for (int k = 0; k < 5; ++k) {
    const auto sync = h.expect(expected[k], 2ms);
    EXPECT_EQ(h.start_of_frame(sync), t0 + (k + 1) * 1ms) << "SYNC " << k + 1;
  }
  // And the device consumed its own SYNCs
  EXPECT_GE(recorder.events.size(), 5u);
  EXPECT_EQ(recorder.events[0].counter, 1);
}

TEST(SyncProducerOnDevice, NoSyncInStoppedAndCounterRestartsAfter) {
  // Given a device producing SYNC every 1 ms without counter
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1006, 0, 1000, 4));
  ASSERT_TRUE(h.write(0x1005, 0, 0x40000080, 4));
  h.expect("080#", 2ms);  // SYNC without counter
  // When the node is stopped
  h.send("000#0205");  // stop node 5
  h.drain(1ms);        // a SYNC queued before the stop may still be on the wire
  // Then no SYNC is produced (CiA 301 §7.3.2.2: SYNC not in Stopped)
  h.expect_silence(20ms);
  // When it is started again
  h.send("000#0105");  // start node 5
  // Then SYNC resumes one cycle later
  const can::TimePoint started = h.bus.now();
  const auto sync = h.expect("080#", 2ms);  // SYNC without counter
  EXPECT_EQ(h.start_of_frame(sync), started + 1ms);
}

TEST(SyncProducerOnDevice, PeriodZeroStopsProduction) {
  // Given a device producing SYNC every 1 ms
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1006, 0, 1000, 4));
  ASSERT_TRUE(h.write(0x1005, 0, 0x40000080, 4));
  h.expect("080#", 2ms);  // SYNC without counter
  // When 1006h is set to 0
  ASSERT_TRUE(h.write(0x1006, 0, 0, 4));
  h.drain(1ms);
  // Then no more SYNC
  h.expect_silence(20ms);
}

TEST(SyncProducerOnDevice, TwentyNineBitCobId) {
  // Given a device producing SYNC every 1 ms on the 29-bit CAN-ID 80h (1005h bits 30 and 29)
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1006, 0, 1000, 4));
  ASSERT_TRUE(h.write(0x1005, 0, 0x60000080, 4));  // gen = 1, frame = 1, CAN-ID 80h
  // When the next SYNC comes
  // Then it carries the 29-bit identifier
  h.expect("00000080#", 2ms);  // SYNC, 29-bit CAN-ID 00000080h, no counter
}

}  // namespace
}  // namespace drivecheck::cia301
