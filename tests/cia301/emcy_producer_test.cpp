// EMCY producer (CiA 301 §7.2.7): EMCY frames for errors and error resets, the inhibit time
// 1015h, the error register 1001h, the pre-defined error field 1003h and the COB-ID 1014h.
#include "protocol/cia301/emcy_producer.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "protocol/cia301/device_services.hpp"
#include "tests/cia301/device_harness.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;
using test_support::at;
using test_support::DeviceHarness;

// ---------------------------------------------------------------------------------------------
// Pure state machine

TEST(EmcyProducer, RaiseAndClearFollowTheErrorStateMachine) {
  // Given a producer of node 5
  EmcyProducer producer(5);
  // When 3220h (DC link undervoltage, register bit 2) is raised with manufacturer bytes
  EXPECT_TRUE(producer.raise(0x3220, 0x04, {1, 2, 3, 4, 5}, at(0ms)));
  // Then an EMCY with the code, register 05h (generic + voltage) and the bytes is sent at once
  auto frame = producer.on_time(at(0ms));
  ASSERT_TRUE(frame);
  EXPECT_EQ(can::to_candump(*frame), "085#2032050102030405");  // 3220h LE, reg 05h, mfr
  EXPECT_EQ(producer.error_register(), 0x05);
  // When the same code is raised again
  // Then nothing changes
  EXPECT_FALSE(producer.raise(0x3220, 0x04, {}, at(1ms)));
  EXPECT_FALSE(producer.on_time(at(1ms)));
  // When 4210h (temperature, bit 3) is raised, then 3220h cleared
  EXPECT_TRUE(producer.raise(0x4210, 0x08, {}, at(2ms)));
  EXPECT_EQ(can::to_candump(*producer.on_time(at(2ms))), "085#10420D0000000000");  // reg 0Dh
  EXPECT_TRUE(producer.clear(0x3220, at(3ms)));
  // Then no EMCY comes while 4210h is still active, and the register keeps bits 0 and 3
  EXPECT_FALSE(producer.on_time(at(3ms)));
  EXPECT_EQ(producer.error_register(), 0x09);
  // When the last error clears
  EXPECT_TRUE(producer.clear(0x4210, at(4ms)));
  // Then the error reset EMCY 0000h with register 00h is sent
  EXPECT_EQ(can::to_candump(*producer.on_time(at(4ms))),
            "085#0000000000000000");  // EMCY error reset 0000h, register 00h
  EXPECT_EQ(producer.error_register(), 0x00);
  // And clearing an inactive code or raising 0000h does nothing
  EXPECT_FALSE(producer.clear(0x4210, at(5ms)));
  EXPECT_FALSE(producer.raise(0x0000, 0, {}, at(5ms)));
}

TEST(EmcyProducer, InhibitTimeQueuesInsteadOfLosing) {
  // Given a producer with an inhibit time of 10 ms (1015h = 100 × 100 µs)
  EmcyProducer producer(5);
  producer.set_inhibit_time(10ms);
  // When three errors are raised at 0 ms
  producer.raise(0x1000, 0, {}, at(0ms));
  producer.raise(0x2310, 0x02, {}, at(0ms));
  producer.raise(0x4210, 0x08, {}, at(0ms));
  // Then the first goes at 0, the others at 10 and 20 ms, in order
  EXPECT_EQ(can::to_candump(*producer.on_time(at(0ms))),
            "085#0010010000000000");  // EMCY 1000h, register 01h
  EXPECT_FALSE(producer.on_time(at(9999us)));
  EXPECT_EQ(producer.next_deadline(), at(10ms));
  EXPECT_EQ(can::to_candump(*producer.on_time(at(10ms))),
            "085#1023030000000000");  // EMCY 2310h, register 03h
  EXPECT_EQ(producer.next_deadline(), at(20ms));
  EXPECT_EQ(can::to_candump(*producer.on_time(at(20ms))),
            "085#10420B0000000000");  // EMCY 4210h, register 0Bh
  EXPECT_EQ(producer.next_deadline(), can::kForever);
  EXPECT_EQ(producer.dropped(), 0u);
}

TEST(EmcyProducer, HistoryIsNewestFirstAndBounded) {
  // Given a history of 3 entries
  EmcyProducer producer(5, 3);
  // When 4 errors are raised
  for (const std::uint16_t code : {0x1000, 0x2000, 0x3000, 0x4000}) {
    producer.raise(code, 0, {}, at(0ms));
  }
  // Then the 3 newest are kept, newest first
  const std::vector<std::uint32_t> expected = {0x4000, 0x3000, 0x2000};
  EXPECT_EQ(std::vector<std::uint32_t>(producer.history().begin(), producer.history().end()),
            expected);
}

TEST(EmcyProducer, FullHistoryWithoutShiftKeepsTheOldest) {
  // Given a history of 3 entries that does not shift when full (the fault injection of
  // emcy-history-full-not-shifted)
  EmcyProducer producer(5, 3);
  producer.set_history_shift_when_full(false);
  // When 4 errors are raised
  for (const std::uint16_t code : {0x1000, 0x2000, 0x3000, 0x4000}) {
    producer.raise(code, 0, {}, at(0ms));
  }
  // Then the first 3 stay and the 4th is not entered
  const std::vector<std::uint32_t> expected = {0x3000, 0x2000, 0x1000};
  EXPECT_EQ(std::vector<std::uint32_t>(producer.history().begin(), producer.history().end()),
            expected);
}

TEST(EmcyProducer, NothingSentWhenDisabledOrInvalid) {
  // Given producers disabled by the NMT state, and with 1014h bit 31 set
  EmcyProducer stopped(5);
  stopped.set_enabled(false);
  EmcyProducer invalid(5);
  invalid.set_cob_id({false, false, 0x85});
  // When errors are raised
  stopped.raise(0x5000, 0, {}, at(0ms));
  invalid.raise(0x5000, 0, {}, at(0ms));
  // Then no EMCY is sent, the register still shows the error
  EXPECT_FALSE(stopped.on_time(at(1s)));
  EXPECT_FALSE(invalid.on_time(at(1s)));
  EXPECT_EQ(stopped.error_register(), 0x01);
  EXPECT_EQ(stopped.suppressed(), 1u);
}

// ---------------------------------------------------------------------------------------------
// On the bus, with the objects

TEST(EmcyProducerOnBus, ErrorAndErrorResetWithObjects) {
  // Given a pre-operational device of node 5
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  // When the application raises 2310h (continuous overcurrent, register bit 1)
  ASSERT_TRUE(h.device->raise_error(0x2310, 0x02));
  // Then EMCY 80h + 5 = 085h carries it, 1001h = 03h, 1003h:00 = 1, 1003h:01 = 2310h
  h.expect("085#1023030000000000", 1ms);  // 2310h LE, register 03h, mfr 0
  EXPECT_EQ(h.read(0x1001, 0).value(), 0x03u);
  EXPECT_EQ(h.read(0x1003, 0).value(), 1u);
  EXPECT_EQ(h.read(0x1003, 1).value(), 0x2310u);
  // When it clears
  ASSERT_TRUE(h.device->clear_error(0x2310));
  // Then the error reset EMCY follows, 1001h = 0, the history keeps the entry
  h.expect("085#0000000000000000", 1ms);  // EMCY error reset 0000h, register 00h
  EXPECT_EQ(h.read(0x1001, 0).value(), 0u);
  EXPECT_EQ(h.read(0x1003, 0).value(), 1u);
}

TEST(EmcyProducerOnBus, InhibitTimeSpacesEmcysOnTheWire) {
  // Given 1015h = 50 (5 ms)
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1015, 0, 50, 2));
  h.run_to(at(10ms));  // the wire is idle
  const can::TimePoint t0 = h.bus.now();
  // When three errors are raised at once
  h.device->raise_error(0x1000, 0);
  h.device->raise_error(0x3210, 0x04);
  h.device->raise_error(0x4310, 0x08);
  // Then they start at t0, t0 + 5 ms and t0 + 10 ms, in the order raised
  const auto e1 = h.expect("085#0010010000000000", 1ms);   // 1000h, reg 01h
  const auto e2 = h.expect("085#1032050000000000", 10ms);  // 3210h, reg 05h
  const auto e3 = h.expect("085#10430D0000000000", 10ms);  // 4310h, reg 0Dh
  EXPECT_EQ(h.start_of_frame(e1), t0);
  EXPECT_EQ(h.start_of_frame(e2), t0 + 5ms);
  EXPECT_EQ(h.start_of_frame(e3), t0 + 10ms);
}

TEST(EmcyProducerOnBus, PreDefinedErrorFieldRules) {
  // Given a device with a 1003h of 8 entries and two errors recorded
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  h.device->raise_error(0x5000, 0x80);
  h.device->raise_error(0x6000, 0x80);
  h.drain(10ms);
  ASSERT_EQ(h.read(0x1003, 0).value(), 2u);
  EXPECT_EQ(h.read(0x1003, 1).value(), 0x6000u);  // newest first
  EXPECT_EQ(h.read(0x1003, 2).value(), 0x5000u);
  // When sub-index 3 (beyond the number of errors) is read
  // Then the read is refused with 08000024h no data available
  EXPECT_EQ(h.read(0x1003, 3).error(), SdoAbort::no_data_available);
  // When 1003h:00 is written with 1
  // Then it is refused with 06090030h invalid value (only 0 may be written)
  EXPECT_EQ(h.write(0x1003, 0, 1, 1).error(), SdoAbort::invalid_value);
  // And the entries are read-only
  EXPECT_EQ(h.write(0x1003, 1, 0, 4).error(), SdoAbort::write_read_only);
  // When 1003h:00 is written with 0
  ASSERT_TRUE(h.write(0x1003, 0, 0, 1));
  // Then the history is empty, and stays empty for the errors already active
  EXPECT_EQ(h.read(0x1003, 0).value(), 0u);
  EXPECT_EQ(h.read(0x1003, 1).error(), SdoAbort::no_data_available);
  EXPECT_EQ(h.read(0x1001, 0).value(), 0x81u);  // the errors are still active
  // When a new error comes
  h.device->raise_error(0x7000, 0x80);
  // Then the history holds only it
  EXPECT_EQ(h.read(0x1003, 0).value(), 1u);
  EXPECT_EQ(h.read(0x1003, 1).value(), 0x7000u);
}

TEST(EmcyProducerOnBus, ErrorRegisterIsReadOnlyAndMappable) {
  // Given the device's 1001h
  DeviceHarness h;
  const Entry* reg = h.od.find(0x1001, 0);
  ASSERT_NE(reg, nullptr);
  // When the master writes it
  // Then 06010002h write to read-only; it is PDO-mappable (CiA 301 §7.5.2, 1001h)
  EXPECT_EQ(h.write(0x1001, 0, 0, 1).error(), SdoAbort::write_read_only);
  EXPECT_TRUE(reg->pdo_mappable());
  EXPECT_EQ(reg->type(), DataType::unsigned8);
}

TEST(EmcyProducerOnBus, CobIdChangesOnlyWhileNotValid) {
  // Given a device whose 1014h is the default 80h + 5 = 85h, valid
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  EXPECT_EQ(h.read(0x1014, 0).value(), 0x85u);
  // When the CAN-ID is changed while valid
  // Then 06090030h (CiA 301 §7.5.2, 1014h)
  EXPECT_EQ(h.write(0x1014, 0, 0x00000090, 4).error(), SdoAbort::invalid_value);
  // When the EMCY is made invalid (bit 31), the CAN-ID changed, then made valid
  ASSERT_TRUE(h.write(0x1014, 0, 0x80000085, 4));
  // Then nothing is sent while invalid
  h.device->raise_error(0x5000, 0x80);
  h.expect_silence(10ms);
  ASSERT_TRUE(h.write(0x1014, 0, 0x80000090, 4));
  ASSERT_TRUE(h.write(0x1014, 0, 0x00000090, 4));
  // And the next EMCY goes out on 090h
  h.device->clear_error(0x5000);
  h.expect("090#0000000000000000", 1ms);  // error reset on the new COB-ID
}

TEST(EmcyProducerOnBus, CobIdValuesRefused) {
  // Given a device with EMCY made invalid (so that CAN-ID changes are allowed)
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  ASSERT_TRUE(h.write(0x1014, 0, 0x80000085, 4));
  // When values that no EMCY COB-ID may have are written
  // Then each is refused with 06090030h: bit 30 set, bits 28..11 set for an 11-bit CAN-ID, a
  //   restricted CAN-ID (CiA 301 §7.3.5: 000h NMT, 601h..67Fh default SDO, 701h.. NMT EC)
  EXPECT_EQ(h.write(0x1014, 0, 0x40000085, 4).error(), SdoAbort::invalid_value);
  EXPECT_EQ(h.write(0x1014, 0, 0x00000885, 4).error(), SdoAbort::invalid_value);
  EXPECT_EQ(h.write(0x1014, 0, 0x00000000, 4).error(), SdoAbort::invalid_value);
  EXPECT_EQ(h.write(0x1014, 0, 0x00000605, 4).error(), SdoAbort::invalid_value);
  EXPECT_EQ(h.write(0x1014, 0, 0x00000705, 4).error(), SdoAbort::invalid_value);
  // And a 29-bit CAN-ID is accepted and used
  ASSERT_TRUE(h.write(0x1014, 0, 0x20012345, 4));  // bit 29: 29-bit CAN-ID 12345h
  h.device->raise_error(0x5000, 0x80);
  h.expect("00012345#0050810000000000", 1ms);  // EMCY 5000h, register 81h
}

TEST(EmcyProducerOnBus, NoEmcyInStoppedButErrorRecorded) {
  // Given a stopped device
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  h.send("000#0205");  // stop node 5
  // When an error is raised
  h.device->raise_error(0x5000, 0x80);
  // Then no EMCY is sent (CiA 301 §7.3.2.2: EMCY not in Stopped), 1001h/1003h record it
  h.expect_silence(100ms);
  EXPECT_EQ(h.read(0x1001, 0).value(), 0x81u);
  EXPECT_EQ(h.read(0x1003, 1).value(), 0x5000u);
  // When the node is started again and the error clears
  h.send("000#0105");  // start node 5
  h.device->clear_error(0x5000);
  // Then the error reset is sent
  h.expect("085#0000000000000000", 1ms);  // EMCY error reset 0000h, register 00h
}

TEST(EmcyProducerOnBus, ResetNodeClearsErrorsResetCommunicationKeepsThem) {
  // Given a device with an active application error
  DeviceHarness h;
  ASSERT_TRUE(h.power_on());
  h.device->raise_error(0x5000, 0x80);
  h.drain(1ms);
  // When communication is reset
  h.send("000#8205");       // reset communication node 5
  h.expect("705#00", 1ms);  // boot-up of node 5
  // Then the error stays active and recorded
  EXPECT_EQ(h.read(0x1001, 0).value(), 0x81u);
  EXPECT_TRUE(h.device->emcy().is_active(0x5000));
  // When the node is reset
  h.send("000#8105");       // reset node 5
  h.expect("705#00", 1ms);  // boot-up of node 5
  // Then the application restarted without errors or history
  EXPECT_EQ(h.read(0x1001, 0).value(), 0u);
  EXPECT_EQ(h.read(0x1003, 0).value(), 0u);
}

}  // namespace
}  // namespace drivecheck::cia301
