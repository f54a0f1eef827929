#include "protocol/ethercat/esc.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <vector>

#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/sii.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

TimePoint at(Duration d) {
  return TimePoint(d);
}

Bytes u16(std::uint16_t v) {
  return {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8)};
}

// Sends `datagrams` in one frame through `escs` in order (as a segment does) at time `t`, and
// returns the frame as it came back, decoded.
std::vector<Datagram> pass(std::vector<Esc*> escs, std::vector<Datagram> datagrams,
                           TimePoint t = {}) {
  Frame frame;
  frame.datagrams = std::move(datagrams);
  Bytes bytes = *encode_frame(frame);
  for (Esc* esc : escs)
    esc->process_frame(bytes, t);
  auto decoded = decode_frame(bytes);
  EXPECT_TRUE(decoded) << decoded.error().message();
  return decoded ? decoded->datagrams : std::vector<Datagram>{};
}

Datagram one(Esc& esc, Datagram datagram, TimePoint t = {}) {
  return pass({&esc}, {std::move(datagram)}, t).at(0);
}

// The SyncManager register block: start, length, control, status, activate, PDI control.
Bytes sm_block(std::uint16_t start, std::uint16_t length, std::uint8_t control, bool enable) {
  Bytes b = u16(start);
  const Bytes l = u16(length);
  b.insert(b.end(), l.begin(), l.end());
  b.insert(b.end(), {control, 0, static_cast<std::uint8_t>(enable ? 1 : 0), 0});
  return b;
}

// The FMMU register block.
Bytes fmmu_block(std::uint32_t logical, std::uint16_t length, std::uint16_t physical,
                 std::uint8_t type, std::uint8_t start_bit = 0, std::uint8_t stop_bit = 7,
                 std::uint8_t physical_bit = 0) {
  return {static_cast<std::uint8_t>(logical),
          static_cast<std::uint8_t>(logical >> 8),
          static_cast<std::uint8_t>(logical >> 16),
          static_cast<std::uint8_t>(logical >> 24),
          static_cast<std::uint8_t>(length),
          static_cast<std::uint8_t>(length >> 8),
          start_bit,
          stop_bit,
          static_cast<std::uint8_t>(physical),
          static_cast<std::uint8_t>(physical >> 8),
          physical_bit,
          type,
          1,
          0,
          0,
          0};
}

// A configured slave at station 1001h: SM0 write mailbox 1000h/128, SM1 read mailbox
// 1080h/128, SM2 outputs 1100h/2 (watchdog trigger), SM3 inputs 1180h/2, FMMU0 outputs at
// logical 10000h, FMMU1 inputs at 10002h.
void configure(Esc& esc, std::uint16_t station = 0x1001, std::uint32_t logical = 0x10000) {
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kStationAddress, u16(station)));
  Bytes sms = sm_block(0x1000, 128, 0x26, true);
  for (const Bytes& b : {sm_block(0x1080, 128, 0x22, true), sm_block(0x1100, 2, 0x64, true),
                         sm_block(0x1180, 2, 0x20, true)}) {
    sms.insert(sms.end(), b.begin(), b.end());
  }
  EXPECT_EQ(one(esc, Datagram::physical(Command::fpwr, 1, station, reg::kSyncManager, sms))
                .working_counter,
            1);
  Bytes fmmus = fmmu_block(logical, 2, 0x1100, 0x02);
  const Bytes in = fmmu_block(logical + 2, 2, 0x1180, 0x01);
  fmmus.insert(fmmus.end(), in.begin(), in.end());
  EXPECT_EQ(
      one(esc, Datagram::physical(Command::fpwr, 2, station, reg::kFmmu, fmmus)).working_counter,
      1);
}

TEST(EscRegisters, TableHoldsTheDatasheetAddresses) {
  // Given register addresses from ESC Section II (an independent copy, on purpose)
  // When they are looked up
  // Then each is the register of that name
  const std::pair<std::uint16_t, const char*> expected[] = {{0x0000, "type"},
                                                            {0x0010, "station_address"},
                                                            {0x0012, "station_alias"},
                                                            {0x0120, "al_control"},
                                                            {0x0130, "al_status"},
                                                            {0x0134, "al_status_code"},
                                                            {0x0400, "watchdog_divider"},
                                                            {0x0420, "watchdog_time_process_data"},
                                                            {0x0440, "watchdog_status"},
                                                            {0x0502, "sii_control"},
                                                            {0x050F, "sii_data"},
                                                            {0x0600, "fmmu"},
                                                            {0x0810, "sync_manager"},
                                                            {0x0910, "dc_system_time"}};
  for (const auto& [address, name] : expected) {
    const auto row = find_esc_register(address);
    ASSERT_TRUE(row) << address;
    EXPECT_EQ(row->name, name);
  }
  EXPECT_FALSE(find_esc_register(0x0F00));
}

TEST(EscProcessing, AutoIncrementAddressesThePositionZeroSlave) {
  // Given two ESCs in a row
  // When an APRD of the type register with ADP 0 and one with ADP FFFFh (-1) pass both
  // Then ADP 0 reads the first ESC, ADP -1 the second; each WKC is 1; ADP came back +2
  EscConfig first;
  first.type = 0x11;
  EscConfig second;
  second.type = 0x22;
  Esc a(first);
  Esc b(second);
  const auto out = pass({&a, &b}, {Datagram::physical(Command::aprd, 0, 0, reg::kType, {0}),
                                   Datagram::physical(Command::aprd, 1, 0xFFFF, reg::kType, {0})});
  EXPECT_EQ(out[0].data[0], 0x11);
  EXPECT_EQ(out[0].working_counter, 1);
  EXPECT_EQ(out[0].adp(), 2);
  EXPECT_EQ(out[1].data[0], 0x22);
  EXPECT_EQ(out[1].working_counter, 1);
}

TEST(EscProcessing, ConfiguredStationAddressAndAlias) {
  // Given an ESC with station address 1001h and alias 0007h from the SII
  // When FPRDs go to 1001h, 1002h, and 0007h before and after DL control bit 24 is set
  // Then 1001h answers, 1002h does not (WKC 0), the alias answers only once enabled
  SiiImage image;
  image.header.station_alias = 0x0007;
  EscConfig config;
  config.sii = *build_sii(image);
  Esc esc(config);
  configure(esc);
  auto read = [&](std::uint16_t adp) {
    return one(esc, Datagram::physical(Command::fprd, 0, adp, reg::kAlStatus, {0, 0}))
        .working_counter;
  };
  EXPECT_EQ(read(0x1001), 1);
  EXPECT_EQ(read(0x1002), 0);
  EXPECT_EQ(read(0x0007), 0);
  one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, reg::kDlControl, {0, 0, 0, 1}));
  EXPECT_EQ(read(0x0007), 1);
}

TEST(EscProcessing, BroadcastReadOrsEverySlave) {
  // Given two ESCs whose AL status codes are 0011h and 0100h
  // When a BRD of 0134h passes both
  // Then the data is their OR (0111h) and the WKC 2
  Esc a;
  Esc b;
  a.pdi_set_al_status(0x0001, 0x0011);
  b.pdi_set_al_status(0x0001, 0x0100);
  const auto out =
      pass({&a, &b}, {Datagram::physical(Command::brd, 0, 0, reg::kAlStatusCode, {0, 0})});
  EXPECT_EQ(out[0].data, u16(0x0111));
  EXPECT_EQ(out[0].working_counter, 2);
}

TEST(EscProcessing, ReadWriteReturnsOldValueAndCountsThree) {
  // Given a configured ESC with station address 1001h
  // When an FPRW writes 2000h to the station address register
  // Then the datagram carries the old value 1001h, the WKC is 3, and 2000h answers after
  Esc esc;
  configure(esc);
  const auto rw =
      one(esc, Datagram::physical(Command::fprw, 0, 0x1001, reg::kStationAddress, u16(0x2000)));
  EXPECT_EQ(rw.data, u16(0x1001));
  EXPECT_EQ(rw.working_counter, 3);
  EXPECT_EQ(one(esc, Datagram::physical(Command::fprd, 0, 0x2000, reg::kType, {0})).working_counter,
            1);
}

TEST(EscProcessing, ReadOnlyRegisterIgnoresWriteButIsAddressed) {
  // Given an ESC in INIT
  // When ECAT writes 0008h to AL status (read-only from ECAT)
  // Then AL status stays 0001h and the WKC is 1 (the ESC was addressed)
  Esc esc;
  EXPECT_EQ(
      one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kAlStatus, u16(8))).working_counter, 1);
  EXPECT_EQ(one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kAlStatus, {0, 0})).data,
            u16(0x0001));
}

TEST(EscProcessing, AddressPastTheRamIsNotAccessible) {
  // Given an ESC with 8 KB process RAM (1000h..2FFFh)
  // When an APRD reads 4 bytes at 3000h and an APWR writes there
  // Then neither counts and the data comes back unchanged
  Esc esc;
  const auto rd = one(esc, Datagram::physical(Command::aprd, 0, 0, 0x3000, {1, 2, 3, 4}));
  EXPECT_EQ(rd.working_counter, 0);
  EXPECT_EQ(rd.data, (Bytes{1, 2, 3, 4}));
  EXPECT_EQ(one(esc, Datagram::physical(Command::apwr, 0, 0, 0x3000, {1})).working_counter, 0);
  // A datagram straddling the end counts for the bytes that exist.
  EXPECT_EQ(one(esc, Datagram::physical(Command::aprd, 0, 0, 0x2FFF, {0, 0})).working_counter, 1);
}

TEST(EscProcessing, WriteMailboxFillsOnceAndRefusesWhileFull) {
  // Given SM0 as a write mailbox (1000h, 128 bytes)
  // When ECAT writes all 128 bytes, then writes again before the PDI read it
  // Then the first write counts and fills the mailbox; the second is refused (WKC 0);
  // the PDI takes the bytes, which empties the mailbox and lets ECAT write again
  Esc esc;
  configure(esc);
  Bytes message(128, 0);
  message[0] = 0x0A;
  EXPECT_EQ(one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, 0x1000, message)).working_counter,
            1);
  EXPECT_TRUE(esc.mailbox_full(0));
  EXPECT_EQ(esc.sync_manager(0).status & sm::kStatusMailboxFull, sm::kStatusMailboxFull);
  EXPECT_EQ(one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, 0x1000, message)).working_counter,
            0);
  const auto taken = esc.pdi_take_mailbox(0);
  ASSERT_TRUE(taken);
  EXPECT_EQ(*taken, message);
  EXPECT_FALSE(esc.mailbox_full(0));
  EXPECT_EQ(one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, 0x1000, message)).working_counter,
            1);
  // ECAT may not read a mailbox it writes.
  EXPECT_EQ(
      one(esc, Datagram::physical(Command::fprd, 0, 0x1001, 0x1000, Bytes(128))).working_counter,
      0);
}

TEST(EscProcessing, ReadMailboxCountsOnlyWhenFull) {
  // Given SM1 as a read mailbox (1080h, 128 bytes)
  // When ECAT reads it empty, then after the PDI put a reply, then again
  // Then the first read gives WKC 0, the second WKC 1 with the reply (emptying it), the third 0
  Esc esc;
  configure(esc);
  auto read = [&] {
    return one(esc, Datagram::physical(Command::fprd, 0, 0x1001, 0x1080, Bytes(128)));
  };
  EXPECT_EQ(read().working_counter, 0);
  EXPECT_TRUE(esc.pdi_put_mailbox(1, Bytes{1, 2, 3}));
  EXPECT_FALSE(esc.pdi_put_mailbox(1, Bytes{4}));  // full
  const auto reply = read();
  EXPECT_EQ(reply.working_counter, 1);
  EXPECT_EQ(reply.data[2], 3);
  EXPECT_EQ(reply.data[3], 0);  // padded
  EXPECT_EQ(read().working_counter, 0);
  EXPECT_FALSE(esc.pdi_put_mailbox(1, Bytes(129)));  // longer than the SM
}

TEST(EscProcessing, SyncManagerConfigurationIsLockedWhileEnabled) {
  // Given SM2 enabled at 1100h
  // When ECAT writes another start address, then disables SM2 and writes it again
  // Then the first write changes nothing; the second takes effect
  Esc esc;
  configure(esc);
  one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, reg::sync_manager(2), u16(0x1200)));
  EXPECT_EQ(esc.sync_manager(2).start, 0x1100);
  one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, reg::sync_manager(2) + 6, {0}));
  one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, reg::sync_manager(2), u16(0x1200)));
  EXPECT_EQ(esc.sync_manager(2).start, 0x1200);
}

TEST(EscProcessing, SyncManagerOverRegistersHasNoEffect) {
  // Given SM4 configured as an ECAT-written buffer over AL status (0130h; found by the fuzz
  // target: the buffer hid the register)
  // When ECAT writes and reads AL status
  // Then AL status still reads 0001h: a SyncManager guards process RAM only
  Esc esc;
  configure(esc);
  one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, reg::sync_manager(4),
                              sm_block(reg::kAlStatus, 2, 0x04, true)));
  one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, reg::kAlStatus, u16(8)));
  EXPECT_EQ(one(esc, Datagram::physical(Command::fprd, 0, 0x1001, reg::kAlStatus, {0, 0})).data,
            u16(1));
}

TEST(EscProcessing, LrwExchangesProcessDataThroughFmmus) {
  // Given a configured slave (outputs at logical 10000h, inputs at 10002h) whose application
  // put inputs 0BB0h
  // When an LRW of 4 bytes carries outputs 000Fh
  // Then the application reads 000Fh, the datagram returns the inputs, the WKC is 3
  Esc esc;
  configure(esc);
  esc.pdi_write16(0x1180, 0x0BB0);
  const auto out = one(esc, Datagram::logical(Command::lrw, 0, 0x10000, {0x0F, 0x00, 0, 0}));
  EXPECT_EQ(out.working_counter, 3);
  EXPECT_EQ(out.data, (Bytes{0x0F, 0x00, 0xB0, 0x0B}));
  EXPECT_EQ(esc.pdi_read16(0x1100), 0x000F);
  // LRD counts 1 (inputs only), LWR 1 (outputs only); a logical address no FMMU maps, 0.
  EXPECT_EQ(one(esc, Datagram::logical(Command::lrd, 0, 0x10000, Bytes(4))).working_counter, 1);
  EXPECT_EQ(one(esc, Datagram::logical(Command::lwr, 0, 0x10000, Bytes(4))).working_counter, 1);
  EXPECT_EQ(one(esc, Datagram::logical(Command::lrw, 0, 0x20000, Bytes(4))).working_counter, 0);
}

TEST(EscProcessing, LrwOverTwoSlavesCountsSix) {
  // Given two configured slaves with consecutive logical images
  // When one LRW covers both
  // Then the WKC is 3 + 3 and each slave's inputs land in its part
  Esc a;
  Esc b;
  configure(a, 0x1001, 0x10000);
  configure(b, 0x1002, 0x10004);
  a.pdi_write16(0x1180, 0x1111);
  b.pdi_write16(0x1180, 0x2222);
  const auto out = pass({&a, &b}, {Datagram::logical(Command::lrw, 0, 0x10000, Bytes(8, 0))}).at(0);
  EXPECT_EQ(out.working_counter, 6);
  EXPECT_EQ(out.data, (Bytes{0, 0, 0x11, 0x11, 0, 0, 0x22, 0x22}));
}

TEST(EscProcessing, BitGranularFmmuMapsOnlyItsBits) {
  // Given an FMMU mapping logical 20000h bits 2..5 onto RAM 1200h bits 0..3 (read and write)
  // When an LWR writes FFh, then an LRD reads with incoming AAh
  // Then RAM 1200h holds 0Fh; the LRD returns AAh with bits 2..5 replaced by RAM bits 0..3
  Esc esc;
  configure(esc);
  one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, reg::fmmu(2),
                              fmmu_block(0x20000, 1, 0x1200, 0x03, 2, 5, 0)));
  EXPECT_EQ(one(esc, Datagram::logical(Command::lwr, 0, 0x20000, {0xFF})).working_counter, 1);
  EXPECT_EQ(esc.peek(0x1200), 0x0F);
  esc.pdi_write8(0x1200, 0x05);  // bits 0 and 2
  const auto rd = one(esc, Datagram::logical(Command::lrd, 0, 0x20000, {0xAA}));
  // AAh = 1010'1010b; bits 2..5 become 0101 (RAM bits 0..3 = 0101b): 1001'0110b = 96h
  EXPECT_EQ(rd.data[0], 0x96);
}

TEST(EscProcessing, ArmwReadsAtPositionZeroAndWritesElsewhere) {
  // Given three ESCs whose system time offsets make them read 1000, 2000, 3000 ns at t=0
  // When an ARMW of 0910h with ADP 0 passes all three (the DC drift compensation pattern)
  // Then the first is read (its time), the others get it written; WKC 3
  Esc escs[3];
  for (int i = 0; i < 3; ++i) {
    Bytes offset(8, 0);
    offset[0] = static_cast<std::uint8_t>((i + 1) * 1000 & 0xFF);
    offset[1] = static_cast<std::uint8_t>((i + 1) * 1000 >> 8);
    one(escs[i], Datagram::physical(Command::apwr, 0, 0, reg::kDcSystemTimeOffset, offset));
  }
  const auto out = pass({&escs[0], &escs[1], &escs[2]},
                        {Datagram::physical(Command::armw, 0, 0, reg::kDcSystemTime, Bytes(8, 0))})
                       .at(0);
  EXPECT_EQ(out.working_counter, 3);
  EXPECT_EQ(out.data[0] | (out.data[1] << 8), 1000);
  // The third ESC's local copy (3000) is above the received 1000: difference 2000, bit 31 0.
  const auto diff =
      one(escs[2], Datagram::physical(Command::aprd, 0, 0, reg::kDcSystemTimeDifference, Bytes(4)));
  EXPECT_EQ(diff.data, (Bytes{0xD0, 0x07, 0, 0}));
}

TEST(EscProcessing, FrmwReadsAtTheStationAndWritesElsewhere) {
  // Given two configured ESCs (1001h, 1002h)
  // When an FRMW to 1002h of RAM 1400h carries 5Ah
  // Then 1002h is read (WKC +1), 1001h is written (+1): WKC 2, RAM of 1001h holds 5Ah
  Esc a;
  Esc b;
  configure(a, 0x1001);
  configure(b, 0x1002, 0x10004);
  b.pdi_write8(0x1400, 0x33);
  const auto out =
      pass({&a, &b}, {Datagram::physical(Command::frmw, 0, 0x1002, 0x1400, {0x5A})}).at(0);
  EXPECT_EQ(out.working_counter, 2);
  EXPECT_EQ(out.data[0], 0x33);
  EXPECT_EQ(a.peek(0x1400), 0x5A);
}

TEST(EscProcessing, DcLatchRecordsPortReceiveTimes) {
  // Given an ESC that sees a frame at 5 us and its return at 7 us
  // When a BWR to 0900h passes
  // Then 0900h holds 5000 and 0904h 7000 (ns), 0918h 5000; 0910h reads the local time
  Esc esc;
  Frame frame;
  frame.datagrams = {Datagram::physical(Command::bwr, 0, 0, reg::kDcReceiveTimePort0, Bytes(4))};
  Bytes bytes = *encode_frame(frame);
  const EscEvents events = esc.process_frame(bytes, at(5us), at(7us));
  EXPECT_TRUE(events.dc_latched);
  EXPECT_EQ(esc.peek(0x0900) | (esc.peek(0x0901) << 8), 5000);
  EXPECT_EQ(esc.peek(0x0904) | (esc.peek(0x0905) << 8), 7000);
  EXPECT_EQ(esc.peek(0x0918) | (esc.peek(0x0919) << 8), 5000);
  const auto t =
      one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kDcSystemTime, Bytes(8)), at(9us));
  EXPECT_EQ(t.data[0] | (t.data[1] << 8), 9000);
}

TEST(EscWatchdog, ExpiresAfterTheConfiguredTimeWithoutOutputs) {
  // Given a configured slave (SM2 triggers the watchdog; reset values: 100 ms)
  // When outputs come by LRW at t=0 and 50 ms, then nothing until 151 ms
  // Then it has not expired at 149 ms, has at 151 ms (0440h bit 0 = 0, 0442h = 1)
  Esc esc;
  configure(esc);
  one(esc, Datagram::logical(Command::lwr, 0, 0x10000, Bytes(2)), at(0ms));
  one(esc, Datagram::logical(Command::lwr, 0, 0x10000, Bytes(2)), at(50ms));
  EXPECT_EQ(esc.next_deadline(), at(150ms));
  EXPECT_FALSE(esc.advance(at(149ms)).watchdog_expired);
  EXPECT_TRUE(esc.advance(at(151ms)).watchdog_expired);
  EXPECT_EQ(esc.peek(reg::kWatchdogStatus) & 1, 0);
  EXPECT_EQ(esc.peek(reg::kWatchdogCounterPd), 1);
  EXPECT_FALSE(esc.advance(at(300ms)).watchdog_expired);  // once per expiry
}

TEST(EscWatchdog, ZeroTimeDisablesIt) {
  // Given a configured slave with 0420h = 0
  // When outputs come once and a second passes
  // Then the watchdog never expires
  Esc esc;
  configure(esc);
  one(esc, Datagram::physical(Command::fpwr, 0, 0x1001, reg::kWatchdogTimeProcessData, u16(0)));
  one(esc, Datagram::logical(Command::lwr, 0, 0x10000, Bytes(2)), at(0ms));
  EXPECT_FALSE(esc.next_deadline());
  EXPECT_FALSE(esc.advance(at(1s)).watchdog_expired);
}

TEST(EscSii, ReadCommandCopiesEightBytesFromTheImage) {
  // Given an ESC whose SII has vendor 0000001Dh and product 00012345h
  // When ECAT writes address 0008h and the read command (0100h) to 0502h
  // Then 0508h..050Fh hold words 8..11 (vendor, product), busy reads 1 until 20 us passed
  SiiImage image;
  image.header.vendor_id = 0x1D;
  image.header.product_code = 0x12345;
  EscConfig config;
  config.sii = *build_sii(image);
  Esc esc(config);
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiAddress, {8, 0, 0, 0}));
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiControl, u16(0x0100)), at(1us));
  const auto busy =
      one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kSiiControl, Bytes(2)), at(2us));
  EXPECT_EQ(busy.data[1] & 0x80, 0x80);
  const auto data =
      one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kSiiControl, Bytes(14)), at(30us));
  EXPECT_EQ(data.data[1] & 0x80, 0);
  EXPECT_EQ(data.data[0] & 0x40, 0x40);  // 8-byte reads
  EXPECT_EQ(Bytes(data.data.begin() + 6, data.data.end()),
            (Bytes{0x1D, 0, 0, 0, 0x45, 0x23, 0x01, 0}));
}

TEST(EscSii, ErrorsForAddressPastTheImageAndWriteWithoutEnable) {
  // Given an ESC with a header-only SII (65 words)
  // When ECAT reads word 1000h, then writes word 4 without the write enable bit
  // Then the first sets error bit 13 (no acknowledge), the second bit 14
  EscConfig config;
  config.sii = *build_sii(SiiImage{});
  Esc esc(config);
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiAddress, {0, 0x10, 0, 0}));
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiControl, u16(0x0100)));
  auto status = [&] {
    const auto d =
        one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kSiiControl, Bytes(2)), at(1ms));
    return static_cast<std::uint16_t>(d.data[0] | (d.data[1] << 8));
  };
  EXPECT_EQ(status() & 0x2000, 0x2000);
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiAddress, {4, 0, 0, 0}), at(1ms));
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiControl, u16(0x0200)), at(1ms));
  EXPECT_EQ(status() & 0x6000, 0x4000);
  // With the enable bit the word is written into the image.
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiData, u16(0xBEEF)), at(1ms));
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiControl, u16(0x0201)), at(1ms));
  EXPECT_EQ(status() & 0x6000, 0);
  EXPECT_EQ(esc.sii()[8], 0xEF);
}

TEST(EscSii, FourOctetReadsFillOnly0508hTo050Bh) {
  // Given an ESC that reads 4 octets per command (EscConfig::sii_read_bytes = 4)
  SiiImage image;
  image.header.vendor_id = 0x1D;
  image.header.product_code = 0x12345;
  EscConfig config;
  config.sii = *build_sii(image);
  config.sii_read_bytes = 4;
  Esc esc(config);
  // When ECAT reads word 8
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiControl, {0x00, 0x01, 8, 0, 0, 0}));
  const auto data =
      one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kSiiControl, Bytes(14)), at(30us));
  // Then 0502h bit 6 is clear and only the vendor id arrived
  EXPECT_EQ(data.data[0] & 0x40, 0);
  EXPECT_EQ(Bytes(data.data.begin() + 6, data.data.end()), (Bytes{0x1D, 0, 0, 0, 0, 0, 0, 0}));
}

TEST(EscSii, OwnershipFollowsTheConfigurationAndPdiAccessBits) {
  // Given an ESC whose EEPROM ECAT offers to the PDI (0500h = 01h) and the PDI takes (0501h)
  SiiImage image;
  image.header.vendor_id = 0x1D;
  EscConfig config;
  config.sii = *build_sii(image);
  Esc esc(config);
  EXPECT_FALSE(esc.pdi_write8(reg::kSiiPdiAccess, 1));  // not offered yet
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiConfiguration, {0x01}));
  ASSERT_TRUE(esc.pdi_write8(reg::kSiiPdiAccess, 1));
  // When ECAT takes it back without forcing (0500h = 0) and reads word 8
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiConfiguration, {0x00}));
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiControl, {0x00, 0x01, 8, 0, 0, 0}));
  const auto ignored =
      one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kSiiData, Bytes(2)), at(30us));
  // Then the command is ignored (the PDI still holds it); forcing (0500h bit 1) frees it
  EXPECT_EQ(ignored.data, (Bytes{0, 0}));
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiConfiguration, {0x02}), at(30us));
  EXPECT_EQ(esc.peek(reg::kSiiPdiAccess) & 0x01, 0);
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiConfiguration, {0x00}), at(30us));
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiControl, {0x00, 0x01, 8, 0, 0, 0}),
      at(30us));
  const auto read =
      one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kSiiData, Bytes(2)), at(60us));
  EXPECT_EQ(read.data, (Bytes{0x1D, 0}));
}

TEST(EscSii, ConfigurationAreaIsLoadedOnlyWithAValidChecksum) {
  // Given two ESCs with alias 1234h and PDI control 0005h in the SII, one with a bad checksum
  SiiImage image;
  image.header.station_alias = 0x1234;
  image.header.pdi_control = 0x0005;
  EscConfig good;
  good.sii = *build_sii(image);
  EscConfig bad = good;
  ASSERT_GE(bad.sii.size(), 16u);
  bad.sii.at(14) = static_cast<std::uint8_t>(bad.sii.at(14) ^ 0xFF);
  Esc loaded(good);
  Esc failed(bad);
  // Then the good one shows alias and PDI control, DL status bit 0 (PDI operational), no error
  EXPECT_EQ(loaded.peek(reg::kStationAlias), 0x34);
  EXPECT_EQ(loaded.peek(reg::kPdiControl), 0x05);
  EXPECT_EQ(loaded.peek(reg::kDlStatus) & 0x01, 0x01);
  EXPECT_EQ(loaded.peek(reg::kSiiControl + 1) & 0x18, 0);
  // And the other none of it, with 0502h bits 11 (checksum) and 12 (not loaded)
  EXPECT_EQ(failed.peek(reg::kStationAlias), 0);
  EXPECT_EQ(failed.peek(reg::kPdiControl), 0);
  EXPECT_EQ(failed.peek(reg::kDlStatus) & 0x01, 0);
  EXPECT_EQ(failed.peek(reg::kSiiControl + 1) & 0x18, 0x18);
}

TEST(EscSii, ReloadKeepsTheAlias) {
  // Given an ESC whose alias register the PDI changed to 0042h after power-on
  SiiImage image;
  image.header.station_alias = 0x1234;
  EscConfig config;
  config.sii = *build_sii(image);
  Esc esc(config);
  ASSERT_TRUE(esc.pdi_write16(reg::kStationAlias, 0x0042));
  // When ECAT issues the reload command (100b)
  one(esc, Datagram::physical(Command::apwr, 0, 0, reg::kSiiControl, u16(0x0400)));
  // Then the alias stays (Section I 11.1: loaded at power-on only)
  EXPECT_EQ(esc.peek(reg::kStationAlias), 0x42);
}

TEST(EscRegisters, DlStatusShowsPortZeroOpenAndTheOthersClosed) {
  // Given an ESC alone (nothing behind port 1) with a valid SII
  EscConfig config;
  config.sii = *build_sii(SiiImage{});
  Esc esc(config);
  // When ECAT reads DL status and DL control
  const auto status = one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kDlStatus, Bytes(2)));
  const auto control = one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kDlControl, Bytes(4)));
  // Then DL status is 5613h and DL control 00070001h (Section II reset values)
  EXPECT_EQ(status.data, (Bytes{0x13, 0x56}));
  EXPECT_EQ(control.data, (Bytes{0x01, 0x00, 0x07, 0x00}));
}

TEST(EscRegisters, AlStatusChangeRaisesTheEventUntilEcatReadsIt) {
  // Given an ESC whose application changes AL status to PREOP
  Esc esc;
  esc.pdi_set_al_status(0x0002, 0);
  // When ECAT reads 0210h, then 0130h, then 0210h
  const auto before =
      one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kEcatEventRequest, Bytes(2)));
  one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kAlStatus, Bytes(2)));
  const auto after =
      one(esc, Datagram::physical(Command::aprd, 0, 0, reg::kEcatEventRequest, Bytes(2)));
  // Then bit 3 was set and is cleared by the AL status read
  EXPECT_EQ(before.data[0] & 0x08, 0x08);
  EXPECT_EQ(after.data[0] & 0x08, 0);
}

TEST(EscRegisters, EveryAddressIsAnsweredWithItsWorkingCounter) {
  // Given an ESC with 8 KiB of process RAM (1000h..2FFFh)
  Esc esc;
  // When ECAT reads every address of the 64 KiB space, one octet each, and writes every
  // register address with its current value
  // Then registers (known or reserved) and RAM count 1 (Section I 2.4: addressed and
  // accessible), addresses past the RAM 0 (our choice, README); register writes count 1
  // (SII control, AL control and DC left out: their writes are commands)
  for (std::uint32_t a = 0; a <= 0xFFFF; ++a) {
    const auto address = static_cast<std::uint16_t>(a);
    const auto read = one(esc, Datagram::physical(Command::aprd, 0, 0, address, Bytes(1)));
    ASSERT_EQ(read.working_counter, a < 0x3000 ? 1 : 0) << std::hex << a;
    if (a < 0x1000 && (a < reg::kSiiControl || a > reg::kSiiData + 7) && a != reg::kAlControl &&
        a != reg::kAlControl + 1 && (a < reg::kDcReceiveTimePort0 || a >= 0x0940)) {
      const auto written = one(esc, Datagram::physical(Command::apwr, 0, 0, address, read.data));
      ASSERT_EQ(written.working_counter, 1) << std::hex << a;
    }
  }
}

TEST(EscProcessing, AlControlWriteIsAnEvent) {
  // Given an ESC
  // When ECAT writes 0002h to AL control
  // Then process_frame reports it, al_control() is 0002h, AL event request bit 0 is set
  Esc esc;
  Frame frame;
  frame.datagrams = {Datagram::physical(Command::apwr, 0, 0, reg::kAlControl, u16(2))};
  Bytes bytes = *encode_frame(frame);
  EXPECT_TRUE(esc.process_frame(bytes, {}).al_control);
  EXPECT_EQ(esc.al_control(), 2);
  EXPECT_EQ(esc.peek(reg::kAlEventRequest) & 1, 1);
  esc.pdi_read16(reg::kAlControl);
  EXPECT_EQ(esc.peek(reg::kAlEventRequest) & 1, 0);
}

TEST(EscProcessing, MalformedFrameIsForwardedUntouchedAndCounted) {
  // Given an APWR frame whose EtherCAT length runs past the frame
  // When it passes an ESC
  // Then no byte changes, the station address stays 0, 030Ch counts 1
  Esc esc;
  Frame frame;
  frame.datagrams = {Datagram::physical(Command::apwr, 0, 0, reg::kStationAddress, u16(0x1001))};
  Bytes bytes = *encode_frame(frame);
  bytes[14] = 0xFF;
  const Bytes before = bytes;
  esc.process_frame(bytes, {});
  EXPECT_EQ(bytes, before);
  EXPECT_EQ(esc.peek(reg::kStationAddress), 0);
  EXPECT_EQ(esc.peek(reg::kProcessingErrorCounter), 1);
  // Unknown commands pass through untouched inside a good frame.
  frame.datagrams[0].command = static_cast<Command>(0x20);
  Bytes unknown = *encode_frame(frame);
  const Bytes unknown_before = unknown;
  esc.process_frame(unknown, {});
  EXPECT_EQ(Bytes(unknown.begin() + 12, unknown.end()),
            Bytes(unknown_before.begin() + 12, unknown_before.end()));
}

TEST(EscProcessing, ProcessedFramesHaveTheLocallyAdministeredBit) {
  // Given a frame from source MAC 00:..:01
  // When an ESC processes it
  // Then the source MAC's first byte has bit 1 set
  Esc esc;
  Frame frame;
  frame.source = {0, 0, 0, 0, 0, 1};
  frame.datagrams = {Datagram::physical(Command::brd, 0, 0, 0, {0})};
  Bytes bytes = *encode_frame(frame);
  esc.process_frame(bytes, {});
  EXPECT_EQ(bytes[6], 0x02);
}

}  // namespace
}  // namespace drivecheck::ethercat
