// PDO group (as CiA's conformance tool groups it): the reference drive's PDO objects, the
// CiA 301 mapping procedure with every abort, communication parameter rules, TPDO transmission
// types, RPDO reception with its EMCYs, and the NMT state gating. Scripted exchanges on the
// simulated bus; node 5 (TPDO1 185h, RPDO1 205h, SDO 605h/585h, EMCY 085h).
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/cia301/pdo.hpp"
#include "tests/reference_drive/drive_rig.hpp"

namespace drivecheck::reference_drive::testing {
namespace {

using Frames = std::vector<std::string>;

constexpr std::uint32_t kUnsupportedAccess = 0x06010000;
constexpr std::uint32_t kObjectMissing = 0x06020000;
constexpr std::uint32_t kNotMappable = 0x06040041;
constexpr std::uint32_t kTooLong = 0x06040042;
constexpr std::uint32_t kSubMissing = 0x06090011;
constexpr std::uint32_t kInvalidValue = 0x06090030;

constexpr std::uint8_t kStart = 0x01;
constexpr std::uint8_t kStop = 0x02;
constexpr std::uint8_t kPreOperational = 0x80;

// Maps `entries` into PDO `number` of `direction` with the CiA 301 procedure and makes it valid
// with the pre-defined CAN-ID and transmission type `type`. Every step must succeed.
void map_pdo(DriveRig& rig, cia301::PdoDirection direction, std::uint16_t number,
             const std::vector<std::uint32_t>& entries, std::uint8_t type) {
  const auto comm = cia301::pdo_communication_index(direction, number);
  const auto mapping = cia301::pdo_mapping_index(direction, number);
  const std::uint32_t base =
      (direction == cia301::PdoDirection::receive ? 0x200u : 0x180u) + 0x100u * (number - 1u);
  ASSERT_EQ(rig.write(comm, 1, 0x80000000u | (base + rig.node()), 4), 0u) << "1. invalidate";
  ASSERT_EQ(rig.write(mapping, 0, 0, 1), 0u) << "2. disable mapping";
  for (std::size_t i = 0; i < entries.size(); ++i) {
    ASSERT_EQ(rig.write(mapping, static_cast<std::uint8_t>(i + 1), entries[i], 4), 0u)
        << "3. entry " << i + 1;
  }
  ASSERT_EQ(rig.write(mapping, 0, entries.size(), 1), 0u) << "4. enable mapping";
  ASSERT_EQ(rig.write(comm, 2, type, 1), 0u) << "transmission type";
  ASSERT_EQ(rig.write(comm, 1, base + rig.node(), 4), 0u) << "5. make valid";
}

void map_tpdo(DriveRig& rig, std::uint16_t number, const std::vector<std::uint32_t>& entries,
              std::uint8_t type) {
  map_pdo(rig, cia301::PdoDirection::transmit, number, entries, type);
}
void map_rpdo(DriveRig& rig, std::uint16_t number, const std::vector<std::uint32_t>& entries,
              std::uint8_t type) {
  map_pdo(rig, cia301::PdoDirection::receive, number, entries, type);
}

// ---------------------------------------------------------------------------------------------
// PDO objects and their defaults

TEST(PdoObjects, FourRpdosAndFourTpdosWithPredefinedInvalidCobIds) {
  // Given the reference drive at node 5
  // When the PDO communication and mapping records are read
  // Then 4 RPDOs and 4 TPDOs exist with the pre-defined CAN-IDs, bit 31 set, nothing mapped
  DriveRig rig;
  for (std::uint16_t n = 1; n <= 4; ++n) {
    const std::uint32_t offset = 0x100u * (n - 1u);
    EXPECT_EQ(rig.read(0x1400 + n - 1, 1).value, 0x80000205u + offset) << "RPDO" << n;
    EXPECT_EQ(rig.read(0x1800 + n - 1, 1).value, 0x80000185u + offset) << "TPDO" << n;
    EXPECT_EQ(rig.read(0x1400 + n - 1, 0).value, 5u);
    EXPECT_EQ(rig.read(0x1800 + n - 1, 0).value, 6u);
    EXPECT_EQ(rig.read(0x1600 + n - 1, 0).value, 0u);
    EXPECT_EQ(rig.read(0x1A00 + n - 1, 0).value, 0u);
    EXPECT_EQ(rig.read(0x1800 + n - 1, 2).value, 0xFFu);
  }
  EXPECT_EQ(rig.read(0x1404, 1).abort, kObjectMissing);
  EXPECT_EQ(rig.read(0x1804, 0).abort, kObjectMissing);
}

TEST(PdoObjects, ReservedAndInapplicableSubIndicesDoNotExist) {
  // Given the reference drive
  // When 1800h:04 (reserved), 1400h:03 (inhibit time: TPDO only) and 1400h:06 are accessed
  // Then each aborts 06090011h (sub-index does not exist)
  DriveRig rig;
  EXPECT_EQ(rig.read(0x1800, 4).abort, kSubMissing);
  EXPECT_EQ(rig.write(0x1800, 4, 0, 1), kSubMissing);
  EXPECT_EQ(rig.read(0x1400, 3).abort, kSubMissing);
  EXPECT_EQ(rig.read(0x1400, 6).abort, kSubMissing);
  EXPECT_EQ(rig.read(0x1600, 9).abort, kSubMissing);
}

// ---------------------------------------------------------------------------------------------
// Mapping procedure (CiA 301 §7.5.2.36/38) and its aborts

TEST(PdoMapping, ProcedureMapsObjectsAndTheTpdoCarriesThem) {
  // Given TPDO1 mapped with 2000h (16 bit) and 2001h (32 bit), synchronous every SYNC
  // When the drive is started and a SYNC comes
  // Then TPDO1 carries both values, LSB first, 6 bytes
  DriveRig rig;
  ASSERT_EQ(rig.write(0x2000, 0, 0x1234, 2), 0u);
  ASSERT_EQ(rig.write(0x2001, 0, 0xA1B2C3D4, 4), 0u);
  // 1A00h sub 1 = 20000010h: 2000h:00, 16 bit
  ASSERT_EQ(rig.write(0x1A00, 0, 0, 1), 0u);
  EXPECT_EQ(rig.exchange("605#23001A0110000020"),  // ccs=1 e=1 s=1 n=0, 1A00h:01, 20000010h
            Frames{"585#60001A0100000000"});       // scs=3, 1A00h:01
  EXPECT_EQ(rig.exchange("605#23001A0220000120"),  // 1A00h:02 = 20010020h (2001h:00, 32 bit)
            Frames{"585#60001A0200000000"});
  EXPECT_EQ(rig.exchange("605#2F001A0002000000"),  // ccs=1 n=3 e=1 s=1, 1A00h:00 = 2
            Frames{"585#60001A0000000000"});
  ASSERT_EQ(rig.write(0x1800, 2, 1, 1), 0u);
  EXPECT_EQ(rig.exchange("605#2300180185010000"),  // 1800h:01 = 00000185h: valid
            Frames{"585#6000180100000000"});
  rig.nmt(kStart);
  // TPDO1: 2000h = 1234h, 2001h = A1B2C3D4h
  EXPECT_EQ(rig.sync(), (Frames{"185#3412D4C3B2A1"}));
}

TEST(PdoMapping, EntryWritesWhileThePdoIsValidAbort) {
  // Given TPDO1 valid with one mapped object
  // When a mapping entry or the count is written
  // Then the drive aborts 06010000h and the mapping stays as it was
  DriveRig rig;
  map_tpdo(rig, 1, {0x20000010}, 1);
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20010020, 4), kUnsupportedAccess);
  EXPECT_EQ(rig.write(0x1A00, 0, 0, 1), kUnsupportedAccess);
  EXPECT_EQ(rig.read(0x1A00, 1).value, 0x20000010u);
  EXPECT_EQ(rig.read(0x1A00, 0).value, 1u);
}

TEST(PdoMapping, EntryWriteWhileCountIsNotZeroAborts) {
  // Given TPDO1 invalid but its mapping enabled (sub 00h = 1)
  // When sub 01h is written without first setting sub 00h to 0
  // Then the drive aborts 06010000h
  DriveRig rig;
  map_tpdo(rig, 1, {0x20000010}, 1);
  ASSERT_EQ(rig.write(0x1800, 1, 0x80000185, 4), 0u);
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20010020, 4), kUnsupportedAccess);
  ASSERT_EQ(rig.write(0x1A00, 0, 0, 1), 0u);
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20010020, 4), 0u);
}

TEST(PdoMapping, ObjectThatDoesNotExistAborts) {
  // Given TPDO1 with its mapping disabled
  // When 3000h:00 (no such object) or 2000h:05 (no such sub-index) is mapped
  // Then the drive aborts 06020000h / 06090011h
  DriveRig rig;
  EXPECT_EQ(rig.exchange("605#23001A0110000030"),  // 1A00h:01 = 30000010h
            Frames{sdo_abort_frame(5, 0x1A00, 1, kObjectMissing)});
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20000510, 4), kSubMissing);
  EXPECT_EQ(rig.read(0x1A00, 1).value, 0u) << "nothing stored";
}

TEST(PdoMapping, ObjectNotMappableAborts) {
  // Given TPDO1 and RPDO1 with their mapping disabled
  // When a non-mappable object, a string, or an object with the wrong length is mapped
  // Then each aborts 06040041h
  DriveRig rig;
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20050010, 4), kNotMappable) << "2005h not mappable";
  EXPECT_EQ(rig.write(0x1600, 1, 0x20050010, 4), kNotMappable);
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20060008, 4), kNotMappable) << "variable length";
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20000008, 4), kNotMappable) << "16-bit object as 8 bit";
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20000020, 4), kNotMappable) << "16-bit object as 32 bit";
  EXPECT_EQ(rig.write(0x1A00, 1, 0x10180120, 4), kNotMappable) << "1018h:01 not mappable";
}

TEST(PdoMapping, WrongDirectionAborts) {
  // Given RPDO1 and TPDO1 with their mapping disabled
  // When a read-only object goes into the RPDO or a write-only one into the TPDO
  // Then the drive aborts 06040041h; the right direction is accepted
  DriveRig rig;
  // 1600h:01 = 20030010h (2003h:00, 16 bit); 2003h is ro
  EXPECT_EQ(rig.exchange("605#2300160110000320"),
            Frames{sdo_abort_frame(5, 0x1600, 1, kNotMappable)});
  EXPECT_EQ(rig.write(0x1600, 1, 0x10010008, 4), kNotMappable) << "1001h error register is ro";
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20040010, 4), kNotMappable) << "2004h is wo";
  EXPECT_EQ(rig.write(0x1A00, 1, 0x20030010, 4), 0u);
  EXPECT_EQ(rig.write(0x1A00, 2, 0x10010008, 4), 0u);
  EXPECT_EQ(rig.write(0x1600, 1, 0x20040010, 4), 0u);
}

TEST(PdoMapping, MoreThan64BitsAbortsAtTheCount) {
  // Given TPDO1 entries 2009h (64 bit) and 2000h (16 bit) written
  // When the count is set to 2 (80 bits)
  // Then the drive aborts 06040042h; a count of 1 (64 bits) is accepted
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1A00, 1, 0x20090040, 4), 0u);
  ASSERT_EQ(rig.write(0x1A00, 2, 0x20000010, 4), 0u);
  EXPECT_EQ(rig.exchange("605#2F001A0002000000"),  // 1A00h:00 = 2
            Frames{sdo_abort_frame(5, 0x1A00, 0, kTooLong)});
  EXPECT_EQ(rig.read(0x1A00, 0).value, 0u);
  EXPECT_EQ(rig.write(0x1A00, 0, 1, 1), 0u);
}

TEST(PdoMapping, CountAboveTheEntriesAborts) {
  // Given a mapping record with 8 entries
  // When sub 00h is set to 9
  // Then the drive aborts 06040042h
  DriveRig rig;
  EXPECT_EQ(rig.write(0x1A00, 0, 9, 1), kTooLong);
  EXPECT_EQ(rig.write(0x1600, 0, 9, 1), kTooLong);
}

TEST(PdoMapping, EmptyEntryIsAcceptedButCannotBeEnabled) {
  // Given TPDO1 with its mapping disabled
  // When sub 01h is cleared (00000000h) and the count is set to 1
  // Then clearing is accepted and enabling aborts 06020000h (step 4 finds no object)
  DriveRig rig;
  EXPECT_EQ(rig.write(0x1A00, 1, 0, 4), 0u);
  EXPECT_EQ(rig.write(0x1A00, 0, 1, 1), kObjectMissing);
}

TEST(PdoMapping, DummyEntriesOnlyInRpdos) {
  // Given RPDO1 and TPDO1 with their mapping disabled
  // When dummy entries (0005h UNSIGNED8, 0006h UNSIGNED16, 0007h UNSIGNED32) are mapped
  // Then the RPDO accepts them with their size, the TPDO aborts 06040041h
  DriveRig rig;
  EXPECT_EQ(rig.write(0x1600, 1, 0x00050008, 4), 0u);
  EXPECT_EQ(rig.write(0x1600, 2, 0x00060010, 4), 0u);
  EXPECT_EQ(rig.write(0x1600, 3, 0x00070020, 4), 0u);
  EXPECT_EQ(rig.write(0x1600, 4, 0x00060008, 4), kNotMappable) << "16-bit dummy as 8 bit";
  EXPECT_EQ(rig.write(0x1600, 4, 0x00060110, 4), kNotMappable) << "dummy with a sub-index";
  EXPECT_EQ(rig.write(0x1A00, 1, 0x00050008, 4), kNotMappable);
  EXPECT_EQ(rig.write(0x1600, 0, 3, 1), 0u);
}

// ---------------------------------------------------------------------------------------------
// Communication parameters

TEST(PdoCommunication, CobIdChangeWhileValidAborts) {
  // Given TPDO1 valid on 185h
  // When the COB-ID is changed to 186h with bit 31 still 0
  // Then the drive aborts 06090030h; writing the same COB-ID again is accepted
  DriveRig rig;
  map_tpdo(rig, 1, {0x20000010}, 1);
  EXPECT_EQ(rig.exchange("605#2300180186010000"),  // 1800h:01 = 00000186h
            Frames{sdo_abort_frame(5, 0x1800, 1, kInvalidValue)});
  EXPECT_EQ(rig.write(0x1800, 1, 0x00000185, 4), 0u);
  EXPECT_EQ(rig.write(0x1800, 1, 0x80000186, 4), 0u) << "invalidate and change at once";
  EXPECT_EQ(rig.write(0x1800, 1, 0x00000186, 4), 0u) << "make valid on the new CAN-ID";
  EXPECT_EQ(rig.read(0x1800, 1).value, 0x186u);
}

TEST(PdoCommunication, DefaultWithoutRtrReadsBit30AndIgnoresRtr) {
  // Given TPDO1 defaulting to valid, no RTR allowed (a manual's C0000180h+N without bit 31),
  // type 255, mapping 2002h
  DriveConfig config;
  cia301::PdoDefaults tpdo1;
  tpdo1.valid = true;
  tpdo1.rtr_allowed = false;
  tpdo1.mapping = {{0x2002, 0, 8}};
  config.dictionary.pdo.tpdo_defaults = {tpdo1};
  DriveRig rig(5, config);
  // When 1800h sub 1 is read, and an RTR for 185h comes in Operational
  // Then the COB-ID reads 40000185h (bit 30 set), and the RTR gets no TPDO (CiA 301 §7.2.2)
  EXPECT_EQ(rig.read(0x1800, 1).value, 0x40000185u);
  rig.nmt(kStart);
  rig.run(10ms);
  EXPECT_EQ(rig.exchange("185#R1"), Frames{});
}

TEST(PdoCommunication, InvalidCobIdsAbort) {
  // Given TPDO1 invalid
  // When an 11-bit COB-ID with bits 28..11 set, or a valid restricted CAN-ID, is written
  // Then the drive aborts 06090030h
  DriveRig rig;
  EXPECT_EQ(rig.write(0x1800, 1, 0x80000985, 4), kInvalidValue) << "bit 11 set, 11-bit id";
  EXPECT_EQ(rig.write(0x1800, 1, 0x00000605, 4), kInvalidValue) << "605h: default SDO rx";
  EXPECT_EQ(rig.write(0x1800, 1, 0x00000000, 4), kInvalidValue) << "000h: NMT";
  EXPECT_EQ(rig.write(0x1800, 1, 0x80000605, 4), 0u) << "restricted but not valid: accepted";
}

TEST(PdoCommunication, TransmissionTypeRanges) {
  // Given TPDO1 and RPDO1
  // When every transmission type 0..255 is written
  // Then TPDOs accept 0..240 and 252..255, RPDOs 0..240, 254, 255; the rest abort 06090030h
  DriveRig rig;
  for (unsigned type = 0; type <= 255; ++type) {
    const bool reserved = type >= 241 && type <= 251;
    const bool rtr = type == 252 || type == 253;
    EXPECT_EQ(rig.write(0x1800, 2, type, 1), reserved ? kInvalidValue : 0u) << "TPDO " << type;
    EXPECT_EQ(rig.write(0x1400, 2, type, 1), reserved || rtr ? kInvalidValue : 0u)
        << "RPDO " << type;
  }
}

TEST(PdoCommunication, InhibitTimeAndSyncStartFixedWhileValid) {
  // Given TPDO1 valid
  // When its inhibit time or SYNC start value is changed, or the SYNC start set above 240
  // Then the drive aborts 06090030h; the event timer may change
  DriveRig rig;
  EXPECT_EQ(rig.write(0x1800, 6, 241, 1), kInvalidValue);
  map_tpdo(rig, 1, {0x20000010}, 1);
  EXPECT_EQ(rig.write(0x1800, 3, 10, 2), kInvalidValue);
  EXPECT_EQ(rig.write(0x1800, 6, 2, 1), kInvalidValue);
  EXPECT_EQ(rig.write(0x1800, 3, 0, 2), 0u) << "same value: no change";
  EXPECT_EQ(rig.write(0x1800, 5, 100, 2), 0u);
  ASSERT_EQ(rig.write(0x1800, 1, 0x80000185, 4), 0u);
  EXPECT_EQ(rig.write(0x1800, 3, 10, 2), 0u);
  EXPECT_EQ(rig.write(0x1800, 6, 2, 1), 0u);
}

TEST(PdoCommunication, ExtendedCanId) {
  // Given TPDO1 on the 29-bit CAN-ID 18FF0005h (COB-ID bit 29)
  // When the drive is started and a SYNC comes
  // Then TPDO1 goes out as an extended frame
  DriveRig rig;
  ASSERT_EQ(rig.write(0x2000, 0, 0xBEEF, 2), 0u);
  ASSERT_EQ(rig.write(0x1A00, 1, 0x20000010, 4), 0u);
  ASSERT_EQ(rig.write(0x1A00, 0, 1, 1), 0u);
  ASSERT_EQ(rig.write(0x1800, 2, 1, 1), 0u);
  ASSERT_EQ(rig.write(0x1800, 1, 0x38FF0005, 4), 0u);
  rig.nmt(kStart);
  // TPDO1, 29-bit CAN-ID 18FF0005h: 2000h = BEEFh
  EXPECT_EQ(rig.sync(), (Frames{"18FF0005#EFBE"}));
}

// ---------------------------------------------------------------------------------------------
// TPDO transmission types

TEST(PdoTransmission, OnlyInOperational) {
  // Given TPDO1 synchronous (type 1) and valid
  // When SYNCs come in Pre-operational, Operational and Stopped
  // Then TPDO1 is sent only in Operational
  DriveRig rig;
  map_tpdo(rig, 1, {0x20020008}, 1);
  EXPECT_EQ(rig.sync(), Frames{});
  rig.nmt(kStart);
  EXPECT_EQ(rig.sync(), (Frames{"185#00"}));
  rig.nmt(kStop);
  EXPECT_EQ(rig.sync(), Frames{});
  rig.nmt(kPreOperational);
  EXPECT_EQ(rig.sync(), Frames{});
}

TEST(PdoTransmission, CyclicEveryNthSync) {
  // Given TPDO1 type 3 (every 3rd SYNC)
  // When 7 SYNCs come after start
  // Then TPDO1 follows the 3rd and the 6th
  DriveRig rig;
  map_tpdo(rig, 1, {0x20020008}, 3);
  rig.nmt(kStart);
  std::vector<int> sent;
  for (int i = 1; i <= 7; ++i) {
    if (rig.sync().size() == 1) sent.push_back(i);
  }
  EXPECT_EQ(sent, (std::vector<int>{3, 6}));
}

TEST(PdoTransmission, SyncStartValueWithCounter) {
  // Given SYNC counter overflow 1019h = 10 and TPDO1 type 3 with SYNC start value 2
  // When SYNCs with counters 1..10 come
  // Then TPDO1 follows the SYNCs with counter 2, 5 and 8
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1019, 0, 10, 1), 0u);
  ASSERT_EQ(rig.write(0x1800, 6, 2, 1), 0u);
  map_tpdo(rig, 1, {0x20020008}, 3);
  rig.nmt(kStart);
  std::vector<int> sent;
  for (std::uint8_t counter = 1; counter <= 10; ++counter) {
    if (rig.sync(counter).size() == 1) sent.push_back(counter);
  }
  EXPECT_EQ(sent, (std::vector<int>{2, 5, 8}));
}

TEST(PdoTransmission, AcyclicSynchronousOnlyAfterAnEvent) {
  // Given TPDO1 type 0 (acyclic synchronous) mapping 2000h
  // When SYNCs come with and without changes of 2000h, and with an application trigger
  // Then TPDO1 follows the first SYNC, then only a SYNC after a change or a trigger
  DriveRig rig;
  map_tpdo(rig, 1, {0x20000010}, 0);
  rig.nmt(kStart);
  EXPECT_EQ(rig.sync(), (Frames{"185#0000"})) << "first SYNC in Operational";
  EXPECT_EQ(rig.sync(), Frames{});
  ASSERT_EQ(rig.write(0x2000, 0, 0x0102, 2), 0u);
  EXPECT_EQ(rig.run(5ms), Frames{}) << "acyclic synchronous waits for the SYNC";
  EXPECT_EQ(rig.sync(), (Frames{"185#0201"}));
  EXPECT_EQ(rig.sync(), Frames{});
  EXPECT_TRUE(rig.drive().trigger_tpdo(1));
  EXPECT_EQ(rig.sync(), (Frames{"185#0201"}));
}

TEST(PdoTransmission, RtrSynchronousSendsTheSampleOfTheLastSync) {
  // Given TPDO1 type 252 mapping 2000h
  // When 2000h = 1111h, SYNC, 2000h = 2222h, then an RTR on 185h
  // Then nothing follows the SYNC and the RTR is answered with 1111h, the SYNC's sample
  DriveRig rig;
  map_tpdo(rig, 1, {0x20000010}, 252);
  rig.nmt(kStart);
  ASSERT_EQ(rig.write(0x2000, 0, 0x1111, 2), 0u);
  EXPECT_EQ(rig.sync(), Frames{});
  ASSERT_EQ(rig.write(0x2000, 0, 0x2222, 2), 0u);
  // RTR on 185h -> TPDO1 with the sample 1111h
  EXPECT_EQ(rig.exchange("185#R"), Frames{"185#1111"});
}

TEST(PdoTransmission, RtrEventDrivenSendsCurrentValues) {
  // Given TPDO1 type 253 mapping 2000h = ABCDh
  // When an RTR comes, and again after the RTR bit (30) of the COB-ID is set
  // Then the first RTR is answered with ABCDh and the second is ignored
  DriveRig rig;
  map_tpdo(rig, 1, {0x20000010}, 253);
  ASSERT_EQ(rig.write(0x2000, 0, 0xABCD, 2), 0u);
  rig.nmt(kStart);
  EXPECT_EQ(rig.run(5ms), Frames{}) << "RTR-only: nothing on its own";
  // RTR on 185h -> TPDO1 2000h = ABCDh
  EXPECT_EQ(rig.exchange("185#R"), Frames{"185#CDAB"});
  rig.nmt(kPreOperational);
  ASSERT_EQ(rig.write(0x1800, 1, 0xC0000185, 4), 0u);
  ASSERT_EQ(rig.write(0x1800, 1, 0x40000185, 4), 0u);
  rig.nmt(kStart);
  // RTR on 185h while bit 30 forbids RTR: no answer
  EXPECT_EQ(rig.exchange("185#R"), Frames{});
}

TEST(PdoTransmission, EventDrivenOnChangeWithInhibitTime) {
  // Given TPDO1 type 255 mapping 2000h with inhibit time 100 (10 ms), in Operational
  // When the application changes 2000h to 1, and 1.5 ms later to 2
  // Then TPDO1 carries 1 at the next control cycle (1 ms), and 2 one inhibit time after that
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1800, 3, 100, 2), 0u);
  map_tpdo(rig, 1, {0x20000010}, 255);
  rig.nmt(kStart);
  rig.run(20ms);  // the transmission on entering Operational and its inhibit time
  auto& od = rig.drive().dictionary();
  const can::TimePoint changed = rig.bus().now();
  ASSERT_TRUE(od.set(0x2000, 0, cia301::Value::of_unsigned(1)));
  rig.bus().run_for(1500us);
  ASSERT_TRUE(od.set(0x2000, 0, cia301::Value::of_unsigned(2)));
  rig.bus().run_for(30ms);
  const auto frames = rig.take();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(can::to_candump(frames[0].frame), "185#0100");
  EXPECT_EQ(can::to_candump(frames[1].frame), "185#0200");
  EXPECT_LE(frames[0].timestamp - changed, 1100us);
  // Timestamps are ends of frames: the two frames differ by at most a few stuff bits (µs).
  EXPECT_GE(frames[1].timestamp - frames[0].timestamp, 10ms - 5us);
  EXPECT_LE(frames[1].timestamp - frames[0].timestamp, 10ms + 5us);
}

TEST(PdoTransmission, EventDrivenStartAndChanges) {
  // Given TPDO1 type 254 mapping 2002h
  // When the drive enters Operational, then the application changes 2002h, then nothing
  // Then TPDO1 is sent on entering Operational and once for the change, not in between
  DriveRig rig;
  map_tpdo(rig, 1, {0x20020008}, 254);
  EXPECT_EQ(rig.nmt(kStart), Frames{"185#00"});
  ASSERT_TRUE(rig.drive().dictionary().set(0x2002, 0, cia301::Value::of_unsigned(7)));
  EXPECT_EQ(rig.run(10ms), Frames{"185#07"});
  EXPECT_EQ(rig.run(50ms), Frames{});
}

TEST(PdoTransmission, SdoWriteOfAMappedObjectIsAnEvent) {
  // Given TPDO1 type 255 mapping 2002h, in Operational
  // When 2002h is written by SDO
  // Then TPDO1 with the new value follows the SDO answer at once
  DriveRig rig;
  map_tpdo(rig, 1, {0x20020008}, 255);
  rig.nmt(kStart);
  EXPECT_EQ(rig.exchange("605#2F02200009000000"),  // ccs=1 n=3 e=1 s=1, 2002h:00 = 09h
            (Frames{"585#6002200000000000", "185#09"}));
}

TEST(PdoTransmission, EventTimerSendsPeriodically) {
  // Given TPDO1 type 255 with event timer 20 ms and unchanging data
  // When the drive runs 100 ms in Operational
  // Then TPDO1 is sent every 20 ms
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1800, 5, 20, 2), 0u);
  map_tpdo(rig, 1, {0x20020008}, 255);
  rig.nmt(kStart);
  rig.take();
  rig.bus().run_for(100ms);
  const auto frames = rig.take();
  ASSERT_EQ(frames.size(), 5u);
  for (std::size_t i = 1; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].timestamp - frames[i - 1].timestamp, 20ms);
  }
}

TEST(PdoTransmission, EventTimerShorterThanInhibitTimeWaitsForTheInhibitTime) {
  // Given TPDO1 type 255 with event timer 20 ms and inhibit time 1000 (100 ms)
  // When the drive runs 350 ms in Operational
  // Then TPDO1 is sent every 100 ms (the inhibit time wins; CiA 301 §7.2.2.2), and the drive
  // does not wake up at the event timer's past instant over and over (simulated time goes on)
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1800, 3, 1000, 2), 0u);
  ASSERT_EQ(rig.write(0x1800, 5, 20, 2), 0u);
  map_tpdo(rig, 1, {0x20020008}, 255);
  rig.nmt(kStart);
  rig.take();
  rig.bus().run_for(350ms);
  const auto frames = rig.take();
  ASSERT_EQ(frames.size(), 3u);
  for (std::size_t i = 1; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].timestamp - frames[i - 1].timestamp, 100ms);
  }
}

TEST(PdoTransmission, FourTpdosOnOneSync) {
  // Given TPDO1..4 synchronous (type 1) with different objects
  // When a SYNC comes
  // Then all four follow, in CAN-ID order (arbitration)
  DriveRig rig;
  ASSERT_EQ(rig.write(0x2007, 0, 1, 1), 0u);
  map_tpdo(rig, 1, {0x20000010}, 1);
  map_tpdo(rig, 2, {0x20010020}, 1);
  map_tpdo(rig, 3, {0x20070001, 0x20020008}, 1);  // BOOLEAN as 1 bit, then 8 bits
  map_tpdo(rig, 4, {0x200A0110, 0x200A0210, 0x10010008}, 1);
  rig.nmt(kStart);
  // TPDO3: bit 0 = flag 1, bits 1..8 = 2002h (0) -> 2 bytes 01 00
  EXPECT_EQ(rig.sync(), (Frames{"185#0000", "285#00000000", "385#0100", "485#0000000000"}));
}

// ---------------------------------------------------------------------------------------------
// RPDO reception

TEST(PdoReception, EventDrivenRpdoIsAppliedAtOnce) {
  // Given RPDO1 type 255 mapping 2000h (16 bit) and 2001h (32 bit)
  // When 205h#3412 78563412 comes in Operational
  // Then 2000h = 1234h and 2001h = 12345678h
  DriveRig rig;
  map_rpdo(rig, 1, {0x20000010, 0x20010020}, 255);
  rig.nmt(kStart);
  // RPDO1: 2000h = 1234h, 2001h = 12345678h
  EXPECT_EQ(rig.exchange("205#341278563412"), Frames{});
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x1234u);
  EXPECT_EQ(rig.read(0x2001, 0).value, 0x12345678u);
}

TEST(PdoReception, SynchronousRpdoIsAppliedAtTheNextSync) {
  // Given RPDO1 type 1 mapping 2000h
  // When two RPDOs come, then a SYNC
  // Then 2000h keeps its value until the SYNC, then takes the last RPDO's
  DriveRig rig;
  map_rpdo(rig, 1, {0x20000010}, 1);
  rig.nmt(kStart);
  rig.exchange("205#1111");  // RPDO1: 2000h = 1111h
  rig.exchange("205#2222");  // RPDO1: 2000h = 2222h
  EXPECT_EQ(rig.read(0x2000, 0).value, 0u);
  rig.sync();
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x2222u);
}

TEST(PdoReception, IgnoredOutsideOperational) {
  // Given RPDO1 type 255 mapping 2000h
  // When RPDOs come in Pre-operational and Stopped (one also too short)
  // Then nothing is written and no EMCY is sent
  DriveRig rig;
  map_rpdo(rig, 1, {0x20000010}, 255);
  EXPECT_EQ(rig.exchange("205#1111"), Frames{});  // RPDO1: 2000h = 1111h
  EXPECT_EQ(rig.exchange("205#11"), Frames{});    // RPDO1, one byte short
  rig.nmt(kStop);
  EXPECT_EQ(rig.exchange("205#1111"), Frames{});
  rig.nmt(kPreOperational);
  EXPECT_EQ(rig.read(0x2000, 0).value, 0u);
}

TEST(PdoReception, TooShortIsNotProcessedAndRaisesEmcy8210) {
  // Given RPDO1 type 255 mapping 2000h and 2002h (3 bytes)
  // When a 2-byte RPDO comes, then a 3-byte one
  // Then EMCY 8210h (error register 11h) follows the short one, nothing is written; the right
  //      length is applied and the EMCY is reset
  DriveRig rig;
  map_rpdo(rig, 1, {0x20000010, 0x20020008}, 255);
  rig.nmt(kStart);
  // EMCY: code 8210h, error register 11h (generic + communication)
  // RPDO1 with 2 of 3 bytes -> EMCY 8210h
  EXPECT_EQ(rig.exchange("205#3412"), Frames{emcy_frame(5, 0x8210, 0x11)});
  EXPECT_EQ(rig.read(0x2000, 0).value, 0u);
  EXPECT_EQ(rig.read(0x1001, 0).value, 0x11u);
  // RPDO1: 2000h = 1234h, 2002h = 56h -> EMCY error reset
  EXPECT_EQ(rig.exchange("205#341256"), Frames{emcy_frame(5, 0x0000, 0x00)});
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x1234u);
  EXPECT_EQ(rig.read(0x2002, 0).value, 0x56u);
  EXPECT_EQ(rig.read(0x1003, 1).value, 0x8210u) << "in the error history";
}

TEST(PdoReception, TooLongIsProcessedAndRaisesEmcy8220) {
  // Given RPDO1 type 255 mapping 2000h (2 bytes)
  // When a 4-byte RPDO comes, then a 2-byte one
  // Then the first two bytes are applied with EMCY 8220h, and the right length resets it
  DriveRig rig;
  map_rpdo(rig, 1, {0x20000010}, 255);
  rig.nmt(kStart);
  // RPDO1: 2000h = 1234h plus 2 extra bytes -> EMCY 8220h
  EXPECT_EQ(rig.exchange("205#3412AABB"), Frames{emcy_frame(5, 0x8220, 0x11)});
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x1234u);
  // RPDO1: 2000h = 5678h -> EMCY error reset
  EXPECT_EQ(rig.exchange("205#7856"), Frames{emcy_frame(5, 0x0000, 0x00)});
}

TEST(PdoReception, DeadlineMonitoringRaisesEmcy8250) {
  // Given RPDO1 type 255 with event timer 50 ms
  // When one RPDO comes and then none for 100 ms, then another
  // Then EMCY 8250h follows 50 ms after the first, and the next RPDO resets it
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1400, 5, 50, 2), 0u);
  map_rpdo(rig, 1, {0x20020008}, 255);
  rig.nmt(kStart);
  EXPECT_EQ(rig.run(100ms), Frames{}) << "monitoring starts with the first RPDO";
  rig.send("205#01");  // RPDO1: 2002h = 01h
  const can::TimePoint sent = rig.bus().now();
  rig.bus().run_for(100ms);
  const auto frames = rig.take();
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(can::to_candump(frames[0].frame), emcy_frame(5, 0x8250, 0x11));
  EXPECT_GE(frames[0].timestamp - sent, 50ms);
  EXPECT_LT(frames[0].timestamp - sent, 52ms);
  // RPDO1: 2002h = 02h -> EMCY error reset
  EXPECT_EQ(rig.exchange("205#02"), Frames{emcy_frame(5, 0x0000, 0x00)});
}

TEST(PdoReception, DummyEntriesSkipTheirBytes) {
  // Given RPDO1 mapping 2002h, dummy UNSIGNED16, 2000h
  // When 205h#11 2222 3344 comes
  // Then 2002h = 11h, 2000h = 4433h, the dummy bytes go nowhere
  DriveRig rig;
  map_rpdo(rig, 1, {0x20020008, 0x00060010, 0x20000010}, 255);
  rig.nmt(kStart);
  rig.exchange("205#1122223344");  // RPDO1: 2002h = 11h, dummy 2222h, 2000h = 4433h
  EXPECT_EQ(rig.read(0x2002, 0).value, 0x11u);
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x4433u);
}

TEST(PdoReception, EntryRefusedByItsLimitsIsSkipped) {
  // Given RPDO1 mapping 2008h (HighLimit 100) and 2002h
  // When 205h#C8 07 comes (2008h = 200)
  // Then 2008h keeps its value, 2002h = 7
  DriveRig rig;
  map_rpdo(rig, 1, {0x20080008, 0x20020008}, 255);
  rig.nmt(kStart);
  rig.exchange("205#C807");  // RPDO1: 2008h = C8h (200), 2002h = 07h
  EXPECT_EQ(rig.read(0x2008, 0).value, 0u);
  EXPECT_EQ(rig.read(0x2002, 0).value, 7u);
  EXPECT_EQ(rig.drive().pdos().statistics().write_refusals, 1u);
}

TEST(PdoReception, WriteOnlyAndSignedObjects) {
  // Given RPDO2 mapping 2004h (wo) and 200Ah:01/02 (INTEGER16)
  // When 305h#BBAA FFFF 0080 comes
  // Then the pair holds -1 and -32768; 2004h took AABBh (it cannot be read back: 06010001h)
  DriveRig rig;
  map_rpdo(rig, 2, {0x20040010, 0x200A0110, 0x200A0210}, 255);
  rig.nmt(kStart);
  rig.exchange("305#BBAAFFFF0080");  // RPDO2: 2004h = AABBh, 200Ah:01 = FFFFh, :02 = 8000h
  EXPECT_EQ(rig.read(0x200A, 1).value, 0xFFFFu);
  EXPECT_EQ(rig.read(0x200A, 2).value, 0x8000u);
  EXPECT_EQ(rig.read(0x2004, 0).abort, 0x06010001u);
  EXPECT_EQ(rig.drive().dictionary().find(0x2004, 0)->as_unsigned(), 0xAABBu);
}

}  // namespace
}  // namespace drivecheck::reference_drive::testing
