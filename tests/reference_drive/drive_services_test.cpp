// NMT, error control, EMCY and SYNC groups on the assembled reference drive: the services are
// tested on their own in tests/cia301; here they are checked as the drive composes them on one
// port (which service gets which frame, what each NMT state allows, resets). Node 5.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "protocol/cia301/sdo_client.hpp"
#include "tests/reference_drive/drive_rig.hpp"

namespace drivecheck::reference_drive::testing {
namespace {

using Frames = std::vector<std::string>;

TEST(DriveNmt, BootUpThenPreOperationalWithSdo) {
  // Given a drive just powered on (the rig saw 705#00)
  // When an SDO upload of 1000h is sent
  // Then it is answered: SDO runs in Pre-operational
  DriveRig rig;
  EXPECT_EQ(rig.drive().state(), cia301::NmtState::pre_operational);
  // upload 1000h:00 -> scs=2 n=0 e=1 s=1, 00020192h
  EXPECT_EQ(rig.exchange("605#4000100000000000"), Frames{"585#4300100092010200"});
}

TEST(DriveNmt, StoppedServesNoSdoButObeysNmt) {
  // Given a stopped drive
  // When an SDO request comes, then "enter pre-operational"
  // Then the SDO request gets no answer while stopped, and is served again after
  DriveRig rig;
  rig.nmt(0x02);
  EXPECT_EQ(rig.drive().state(), cia301::NmtState::stopped);
  EXPECT_EQ(rig.exchange("605#4000100000000000", 50ms), Frames{});  // upload 1000h:00
  rig.nmt(0x80);
  // upload 1000h:00 -> scs=2 n=0 e=1 s=1, 00020192h
  EXPECT_EQ(rig.exchange("605#4000100000000000"), Frames{"585#4300100092010200"});
}

TEST(DriveNmt, StopDropsAnOpenSdoTransferSilently) {
  // Given a segmented upload of 1008h in progress
  // When the drive is stopped and put back into pre-operational
  // Then no abort is sent, and the next segment request is answered 05040001h (no transfer)
  DriveRig rig;
  ASSERT_EQ(rig.exchange("605#4008100000000000").size(), 1u);  // initiate upload 1008h
  EXPECT_EQ(rig.nmt(0x02), Frames{});
  rig.nmt(0x80);
  EXPECT_EQ(rig.exchange("605#6000000000000000"),  // upload segment t=0
            Frames{sdo_abort_frame(5, 0x0000, 0, 0x05040001)});
}

TEST(DriveNmt, ResetsSendBootUpAndRunTheApplicationResets) {
  // Given a started drive
  // When it gets reset communication, then reset node
  // Then each sends a boot-up; the application saw application resets only for power on and
  //      reset node, communication resets every time
  DriveRig rig;
  rig.nmt(0x01);
  EXPECT_EQ(rig.nmt(0x82), Frames{"705#00"});
  EXPECT_EQ(rig.drive().state(), cia301::NmtState::pre_operational);
  EXPECT_EQ(rig.nmt(0x81), Frames{"705#00"});
  using K = cia301::ResetKind;
  EXPECT_EQ(rig.application().resets,
            (std::vector<K>{K::application, K::communication, K::communication, K::application,
                            K::communication}));
}

TEST(DriveNmt, BroadcastAndOtherNodes) {
  // Given the drive at node 5
  // When NMT start goes to node 6, then to all nodes (0)
  // Then only the broadcast starts it
  DriveRig rig;
  rig.exchange("000#0106");  // NMT start, node 6
  EXPECT_EQ(rig.drive().state(), cia301::NmtState::pre_operational);
  rig.exchange("000#0100");  // NMT start, all nodes
  EXPECT_EQ(rig.drive().state(), cia301::NmtState::operational);
}

TEST(DriveErrorControl, NodeGuardingAnswersWithToggle) {
  // Given the drive with 1017h = 0 (guarding is the error control protocol)
  // When three guarding requests (RTR on 705h) come, the second after a start
  // Then the answers carry the state with the toggle bit alternating: 7Fh, 85h, 05h
  DriveRig rig;
  // guarding request (RTR 705h) -> t=0, state 7Fh
  EXPECT_EQ(rig.exchange("705#R"), Frames{"705#7F"});
  rig.nmt(0x01);
  EXPECT_EQ(rig.exchange("705#R"), Frames{"705#85"});  // t=1, operational
  EXPECT_EQ(rig.exchange("705#R"), Frames{"705#05"});  // t=0, operational
}

TEST(DriveErrorControl, LifeGuardingEventRaisesEmcyAndLeavesOperational) {
  // Given guard time 100 ms and life time factor 2, one guarding request, Operational
  // When no request comes for 300 ms
  // Then EMCY 8130h (register 11h) is sent and the drive falls back to Pre-operational (1029h)
  DriveRig rig;
  ASSERT_EQ(rig.write(0x100C, 0, 100, 2), 0u);
  ASSERT_EQ(rig.write(0x100D, 0, 2, 1), 0u);
  rig.nmt(0x01);
  rig.exchange("705#R");  // guarding request: life guarding starts
  EXPECT_EQ(rig.run(300ms), Frames{emcy_frame(5, 0x8130, 0x11)});
  EXPECT_EQ(rig.drive().state(), cia301::NmtState::pre_operational);
}

TEST(DriveEmcy, ApplicationErrorsAndTheCobId) {
  // Given the drive in Pre-operational
  // When the application raises 5000h, clears it, then 1014h is made invalid and 5000h raised
  // Then EMCY 5000h and the error reset are sent; with 1014h bit 31 set nothing is sent, but
  //      1001h and 1003h still record it
  DriveRig rig;
  EXPECT_TRUE(rig.drive().raise_error(0x5000, 0x80));
  EXPECT_EQ(rig.run(2ms), Frames{emcy_frame(5, 0x5000, 0x81)});
  EXPECT_TRUE(rig.drive().clear_error(0x5000));
  EXPECT_EQ(rig.run(2ms), Frames{emcy_frame(5, 0x0000, 0x00)});
  ASSERT_EQ(rig.write(0x1014, 0, 0x80000085, 4), 0u);
  EXPECT_TRUE(rig.drive().raise_error(0x5000, 0x80));
  EXPECT_EQ(rig.run(2ms), Frames{});
  EXPECT_EQ(rig.read(0x1001, 0).value, 0x81u);
  EXPECT_EQ(rig.read(0x1003, 0).value, 2u);
  EXPECT_EQ(rig.read(0x1003, 1).value, 0x5000u);
}

TEST(DriveSync, WrongSyncLengthRaisesEmcy8240) {
  // Given the drive with 1019h = 0 (SYNC without counter)
  // When a SYNC with one data byte comes, then a correct one
  // Then EMCY 8240h follows the wrong one and the correct one resets it
  DriveRig rig;
  // SYNC with a counter byte while 1019h = 0 -> EMCY 8240h
  EXPECT_EQ(rig.exchange("080#01"), Frames{emcy_frame(5, 0x8240, 0x11)});
  EXPECT_EQ(rig.exchange("080#"), Frames{emcy_frame(5, 0x0000, 0x00)});  // SYNC, DLC 0
}

TEST(DriveSync, TheDriveCanProduceSyncForItsOwnPdos) {
  // Given the drive as SYNC producer (1006h = 10 ms, 1005h = 40000080h) and TPDO1 type 1 on
  //      1001h, Operational
  // When 35 ms pass
  // Then the drive sends SYNCs every 10 ms, each followed by its TPDO1
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1A00, 1, 0x10010008, 4), 0u);
  ASSERT_EQ(rig.write(0x1A00, 0, 1, 1), 0u);
  ASSERT_EQ(rig.write(0x1800, 2, 1, 1), 0u);
  ASSERT_EQ(rig.write(0x1800, 1, 0x185, 4), 0u);
  rig.nmt(0x01);
  ASSERT_EQ(rig.write(0x1006, 0, 10000, 4), 0u);
  ASSERT_EQ(rig.write(0x1005, 0, 0x40000080, 4), 0u);
  // SYNC (DLC 0), TPDO1 1001h = 00h; three times
  EXPECT_EQ(rig.run(35ms), (Frames{"080#", "185#00", "080#", "185#00", "080#", "185#00"}));
}

TEST(DriveSdo, BlockDownloadAndUploadThroughTheDrive) {
  // Given the drive and an SdoClient on a master port
  // When 1017h is written as a block download and 1008h read as a block upload
  // Then both succeed as block transfers
  DriveRig rig;
  auto client = rig.client();
  const std::uint8_t period[] = {0x64, 0x00};
  ASSERT_TRUE(client.download({0x1017, 0}, period, cia301::SdoTransferMode::block));
  EXPECT_EQ(client.last_transfer().kind(), cia301::SdoTransferKind::block);
  EXPECT_EQ(rig.read(0x1017, 0).value, 100u);
  const auto name = client.upload({0x1008, 0}, cia301::SdoTransferMode::block);
  ASSERT_TRUE(name) << name.error().message();
  EXPECT_EQ(std::string(name->begin(), name->end()), Identity{}.device_name);
}

TEST(DriveApplicationHook, ControlCycleRunsEveryMillisecond) {
  // Given the drive with the default 1 ms control cycle
  // When 100 ms pass
  // Then the application's hook ran 100 times
  DriveRig rig;
  const auto before = rig.application().cycles;
  rig.run(100ms);
  EXPECT_EQ(rig.application().cycles - before, 100u);
}

TEST(DriveRobustness, RandomFramesAndParameterWritesNeverBreakTheDrive) {
  // Given a started drive with RPDO1/TPDO1 mapped
  // When 20000 random frames (any identifier, length, payload; RTRs) and random SDO writes to
  //      the PDO parameters arrive (fixed seed)
  // Then nothing crashes and, put back into pre-operational, the drive still answers SDO
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1600, 1, 0x20000010, 4), 0u);
  ASSERT_EQ(rig.write(0x1600, 0, 1, 1), 0u);
  ASSERT_EQ(rig.write(0x1400, 1, 0x205, 4), 0u);
  ASSERT_EQ(rig.write(0x1A00, 1, 0x20010020, 4), 0u);
  ASSERT_EQ(rig.write(0x1A00, 0, 1, 1), 0u);
  ASSERT_EQ(rig.write(0x1800, 1, 0x185, 4), 0u);
  rig.nmt(0x01);
  std::mt19937 random(20250101);
  const auto byte = [&] { return static_cast<std::uint8_t>(random()); };
  for (int i = 0; i < 20000; ++i) {
    can::Frame frame;
    if (random() % 4 == 0) {
      // An expedited SDO write to a PDO parameter: 14xxh/16xxh/18xxh/1Axxh, sub 0..9.
      const std::uint16_t index =
          static_cast<std::uint16_t>(0x1400 + 0x200 * (random() % 4) + random() % 5);
      frame = can::Frame::standard(
          0x605, {static_cast<std::uint8_t>(0x23 | (random() % 4) << 2),
                  static_cast<std::uint8_t>(index), static_cast<std::uint8_t>(index >> 8),
                  static_cast<std::uint8_t>(random() % 10), byte(), byte(), byte(), byte()});
    } else {
      const std::uint32_t id = random() % 0x800;
      if (id == 0x000 && random() % 2 == 0) continue;  // keep most NMT commands away
      const auto length = static_cast<std::uint8_t>(random() % 9);
      if (random() % 8 == 0) {
        frame = can::Frame::remote(id, length);
      } else {
        const std::uint8_t data[8] = {byte(), byte(), byte(), byte(),
                                      byte(), byte(), byte(), byte()};
        frame = can::Frame::standard(id, std::span<const std::uint8_t>(data, length));
      }
    }
    rig.send(can::to_candump(frame));
    rig.bus().run_for(std::chrono::microseconds(random() % 3000));
  }
  rig.run(100ms);
  EXPECT_GT(rig.drive().sdo_server().statistics().requests, 4000u) << "the frames arrived";
  rig.nmt(0x80);
  rig.run(10ms);
  if (rig.drive().state() != cia301::NmtState::pre_operational) {
    rig.nmt(0x82);  // a random reset may still be initialising: reset communication and wait
    rig.run(10ms);
    rig.nmt(0x80);
  }
  EXPECT_EQ(rig.read(0x1000, 0).value, 0x00020192u);
}

}  // namespace
}  // namespace drivecheck::reference_drive::testing
