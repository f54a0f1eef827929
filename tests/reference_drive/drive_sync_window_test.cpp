// PDO group, synchronous window 1007h (CiA 301 §7.5.2, object 1007h: when the window expires,
// synchronous TPDOs not sent are discarded and synchronous RPDOs are discarded until the next
// SYNC). Scripted exchanges on a simulated bus at 125 kbit/s, where an 8-byte TPDO takes about
// 1 ms on the wire; node 5 (TPDO1..4 185h..485h, RPDO1 205h, SYNC 080h).
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/can/frame_timing.hpp"
#include "protocol/cia301/pdo.hpp"
#include "protocol/cia301/sync_consumer.hpp"
#include "tests/reference_drive/drive_rig.hpp"

namespace drivecheck::reference_drive::testing {
namespace {

using Frames = std::vector<std::string>;

constexpr std::uint32_t kBitrate = 125'000;
constexpr std::uint8_t kStart = 0x01;

// The CiA 301 mapping procedure for PDO `number`, made valid on its pre-defined CAN-ID with
// transmission type `type`.
void map_pdo(DriveRig& rig, cia301::PdoDirection direction, std::uint16_t number,
             std::uint32_t entry, std::uint8_t type) {
  const auto comm = cia301::pdo_communication_index(direction, number);
  const auto mapping = cia301::pdo_mapping_index(direction, number);
  const std::uint32_t base =
      (direction == cia301::PdoDirection::receive ? 0x200u : 0x180u) + 0x100u * (number - 1u);
  ASSERT_EQ(rig.write(comm, 1, 0x80000000u | (base + rig.node()), 4), 0u);
  ASSERT_EQ(rig.write(mapping, 0, 0, 1), 0u);
  ASSERT_EQ(rig.write(mapping, 1, entry, 4), 0u);
  ASSERT_EQ(rig.write(mapping, 0, 1, 1), 0u);
  ASSERT_EQ(rig.write(comm, 2, type, 1), 0u);
  ASSERT_EQ(rig.write(comm, 1, base + rig.node(), 4), 0u);
}

// TPDO1..4 synchronous (type 1), each carrying 2009h (UNSIGNED64 = 0123456789ABCDEFh), the drive
// Operational.
void four_long_tpdos(DriveRig& rig, std::uint32_t window_us) {
  rig.drive().dictionary().find(0x2009, 0)->assign_unsigned(0x0123456789ABCDEFu);
  for (std::uint16_t n = 1; n <= 4; ++n) {
    map_pdo(rig, cia301::PdoDirection::transmit, n, 0x20090040, 1);
  }
  ASSERT_EQ(rig.write(cia301::kSyncWindowLengthIndex, 0, window_us, 4), 0u);
  rig.nmt(kStart);
}

// When the frame seen at `timed.timestamp` (its end of frame) started on the wire.
can::TimePoint start_of(const can::TimedFrame& timed) {
  return timed.timestamp - (can::frame_duration(timed.frame, kBitrate, can::BitStuffing::exact) -
                            can::bit_duration(3, kBitrate));
}

TEST(PdoSyncWindow, WindowZeroSendsEverySynchronousTpdo) {
  // Given four 8-byte synchronous TPDOs at 125 kbit/s and 1007h = 0 (no window)
  // When a SYNC comes
  // Then all four are sent, in CAN-ID order, and none is discarded
  DriveRig rig(5, {}, kBitrate);
  four_long_tpdos(rig, 0);
  // TPDO1..4: 2009h = 0123456789ABCDEFh, little endian
  EXPECT_EQ(rig.exchange("080#", 10ms), (Frames{"185#EFCDAB8967452301", "285#EFCDAB8967452301",
                                                "385#EFCDAB8967452301", "485#EFCDAB8967452301"}));
  EXPECT_EQ(rig.drive().pdos().statistics().sync_tpdos_discarded, 0u);
}

TEST(PdoSyncWindow, WindowLongerThanTheQueueSendsEveryTpdo) {
  // Given the four TPDOs and a window of 10 ms (they need about 4 ms)
  // When a SYNC comes
  // Then all four are sent
  DriveRig rig(5, {}, kBitrate);
  four_long_tpdos(rig, 10'000);
  EXPECT_EQ(rig.exchange("080#", 10ms).size(), 4u);
  EXPECT_EQ(rig.drive().pdos().statistics().sync_tpdos_discarded, 0u);
}

TEST(PdoSyncWindow, TpdosThatCannotStartInsideTheWindowAreDiscarded) {
  // Given the four 8-byte TPDOs (about 1 ms each on the wire) and 1007h = 1500 µs
  // When a SYNC comes
  // Then TPDO1 and TPDO2 are sent, each starting inside the window; TPDO3 and TPDO4 are
  //   discarded, not sent late (neither in the 10 ms after the SYNC); the next SYNC starts a
  //   new window with the same outcome
  DriveRig rig(5, {}, kBitrate);
  four_long_tpdos(rig, 1500);
  rig.send("080#");  // SYNC without counter
  rig.bus().run_for(10ms);
  const auto frames = rig.take();
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_EQ(can::to_candump(frames[0].frame), "185#EFCDAB8967452301");
  EXPECT_EQ(can::to_candump(frames[1].frame), "285#EFCDAB8967452301");
  const auto sync = rig.drive().services().sync_consumer().last_sync();
  ASSERT_TRUE(sync.has_value());
  for (const auto& timed : frames) {
    EXPECT_LT(start_of(timed), *sync + 1500us) << can::to_candump(timed.frame);
  }
  EXPECT_GT(frames[1].timestamp, *sync + 1500us) << "TPDO2 ends after the window: the window "
                                                    "was shorter than the queue";
  EXPECT_EQ(rig.drive().pdos().statistics().sync_tpdos_discarded, 2u);

  EXPECT_EQ(rig.exchange("080#", 10ms), (Frames{"185#EFCDAB8967452301", "285#EFCDAB8967452301"}));
  EXPECT_EQ(rig.drive().pdos().statistics().sync_tpdos_discarded, 4u);
}

TEST(PdoSyncWindow, WindowRemovedWhileTpdosWaitSendsThemAll) {
  // Given the four TPDOs and 1007h = 1500 µs
  // When 1007h is written 0 while TPDO1 is on the wire
  // Then no window applies any more: TPDO2..4 follow TPDO1, none is discarded
  DriveRig rig(5, {}, kBitrate);
  four_long_tpdos(rig, 1500);
  rig.send("080#");  // SYNC without counter
  rig.bus().run_for(600us);
  const std::uint8_t zero[4] = {};
  ASSERT_TRUE(rig.drive().dictionary().write(cia301::kSyncWindowLengthIndex, 0, zero));
  EXPECT_EQ(rig.run(10ms).size(), 4u);
  EXPECT_EQ(rig.drive().pdos().statistics().sync_tpdos_discarded, 0u);
}

TEST(PdoSyncWindow, SynchronousRpdoAfterTheWindowDoesNotTakeEffect) {
  // Given RPDO1 type 1 mapping 2000h and 1007h = 1200 µs, Operational
  // When a SYNC comes, then an RPDO 2 ms later (window closed), then a SYNC
  // Then 2000h keeps its value at that SYNC (the RPDO was discarded, without an EMCY)
  DriveRig rig(5, {}, kBitrate);
  map_pdo(rig, cia301::PdoDirection::receive, 1, 0x20000010, 1);
  ASSERT_EQ(rig.write(cia301::kSyncWindowLengthIndex, 0, 1200, 4), 0u);
  rig.nmt(kStart);
  rig.sync();  // the window closes 1.2 ms after it; rig.sync() runs 2 ms
  EXPECT_EQ(rig.exchange("205#2222", 2ms), Frames{});  // RPDO1: 2000h = 2222h, late
  rig.sync();
  EXPECT_EQ(rig.read(0x2000, 0).value, 0u);
  EXPECT_EQ(rig.drive().pdos().statistics().sync_rpdos_discarded, 1u);
}

TEST(PdoSyncWindow, SynchronousRpdoInsideTheWindowTakesEffectAtTheNextSync) {
  // Given RPDO1 type 1 mapping 2000h and 1007h = 1200 µs, Operational
  // When an RPDO follows a SYNC at once (it ends about 0.5 ms after it), then a SYNC
  // Then 2000h takes the RPDO's value at that SYNC
  DriveRig rig(5, {}, kBitrate);
  map_pdo(rig, cia301::PdoDirection::receive, 1, 0x20000010, 1);
  ASSERT_EQ(rig.write(cia301::kSyncWindowLengthIndex, 0, 1200, 4), 0u);
  rig.nmt(kStart);
  rig.send("080#");               // SYNC
  rig.exchange("205#3333", 2ms);  // RPDO1: 2000h = 3333h, queued right behind the SYNC
  EXPECT_EQ(rig.read(0x2000, 0).value, 0u) << "not before the next SYNC";
  rig.sync();
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x3333u);
  EXPECT_EQ(rig.drive().pdos().statistics().sync_rpdos_discarded, 0u);
}

TEST(PdoSyncWindow, WithoutWindowALateSynchronousRpdoStillTakesEffect) {
  // Given RPDO1 type 1 mapping 2000h and 1007h = 0, Operational
  // When a SYNC comes, then an RPDO 2 ms later, then a SYNC
  // Then 2000h takes the RPDO's value at that SYNC
  DriveRig rig(5, {}, kBitrate);
  map_pdo(rig, cia301::PdoDirection::receive, 1, 0x20000010, 1);
  rig.nmt(kStart);
  rig.sync();
  rig.exchange("205#2222", 2ms);  // RPDO1: 2000h = 2222h
  rig.sync();
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x2222u);
}

}  // namespace
}  // namespace drivecheck::reference_drive::testing
