// Further SDO server channels (1201h.., protocol/cia301/sdo_server_parameter.hpp) and bus-off
// on the assembled reference drive (device.hpp). Node 5: the default channel 605h/585h; the
// second channel is put on 67Fh/5FFh (node-ID 7Fh).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "protocol/cia301/sdo_server_parameter.hpp"
#include "tests/reference_drive/drive_rig.hpp"

namespace drivecheck::reference_drive::testing {
namespace {

using Frames = std::vector<std::string>;

DriveConfig with_servers(std::uint8_t extra, cia301::SdoNodeIdSub sub) {
  DriveConfig config;
  config.dictionary.extra_sdo_servers = extra;
  config.dictionary.sdo_node_id_sub = sub;
  return config;
}

// 1201h:02 then 1201h:01 made valid on 5FFh / 67Fh (client mode: the COB-IDs are written).
void open_second_channel(DriveRig& rig) {
  ASSERT_EQ(rig.write(0x1201, 2, 0x5FF, 4), 0u);
  ASSERT_EQ(rig.write(0x1201, 1, 0x67F, 4), 0u);
}

TEST(DriveSdoServers, FurtherChannelIsOffUntilItsCobIdsAreValid) {
  // Given a drive with one further SDO server (1201h) at its defaults
  // When 1201h is read and a request is sent on 67Fh
  // Then both COB-IDs read 80000000h (not valid), sub 0 reads 3, and 67Fh gets no answer
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::client));
  EXPECT_EQ(rig.read(0x1201, 0).value, 3u);
  EXPECT_EQ(rig.read(0x1201, 1).value, 0x80000000u);
  EXPECT_EQ(rig.read(0x1201, 2).value, 0x80000000u);
  EXPECT_EQ(rig.exchange("67F#4000100000000000", 50ms), Frames{});  // upload 1000h:00
}

TEST(DriveSdoServers, ValidChannelAnswersOnItsOwnCobId) {
  // Given the second channel made valid on 67Fh/5FFh
  // When 1000h is uploaded through it
  // Then the answer comes on 5FFh with the device type, and 605h still answers on 585h
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::client));
  open_second_channel(rig);
  // upload 1000h:00 -> scs=2 n=0 e=1 s=1, 00020192h
  EXPECT_EQ(rig.exchange("67F#4000100000000000"), Frames{"5FF#4300100092010200"});
  EXPECT_EQ(rig.exchange("605#4000100000000000"), Frames{"585#4300100092010200"});
}

TEST(DriveSdoServers, TransfersOnTwoChannelsAreIndependent) {
  // Given a segmented upload of 1008h open on the second channel
  // When the default channel serves an expedited download and an upload meanwhile
  // Then the second channel's upload goes on with its next segment (toggle 0) undisturbed
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::client));
  open_second_channel(rig);
  const auto initiate = rig.exchange("67F#4008100000000000");  // initiate upload 1008h:00
  ASSERT_EQ(initiate.size(), 1u);
  EXPECT_EQ(initiate[0].substr(0, 12), "5FF#41081000");  // scs=2 e=0 s=1: segmented
  EXPECT_EQ(rig.write(0x1017, 0, 100, 2), 0u);           // through 605h/585h
  EXPECT_EQ(rig.read(0x1017, 0).value, 100u);
  const auto segment = rig.exchange("67F#6000000000000000");  // upload segment t=0
  ASSERT_EQ(segment.size(), 1u);
  // t=0 n=0 c=0, "drivech" (the reference drive's device name starts "drivecheck")
  EXPECT_EQ(segment[0], "5FF#0064726976656368");
  EXPECT_TRUE(rig.drive().extra_sdo_server(0).busy());
  EXPECT_FALSE(rig.drive().sdo_server().busy());
}

TEST(DriveSdoServers, InvalidCobIdsAreRefused) {
  // Given the second channel valid on 67Fh
  // When a 29-bit COB-ID, reserved bits, or a new CAN-ID while valid is written to 1201h:01
  // Then each write aborts 06090030h and the channel stays on 67Fh
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::client));
  open_second_channel(rig);
  EXPECT_EQ(rig.write(0x1201, 1, 0x2000067F, 4), 0x06090030u);  // bit 29: 29-bit frame
  EXPECT_EQ(rig.write(0x1201, 1, 0x0000167F, 4), 0x06090030u);  // bit 12 reserved
  EXPECT_EQ(rig.write(0x1201, 1, 0x0000067E, 4), 0x06090030u);  // new CAN-ID while valid
  EXPECT_EQ(rig.read(0x1201, 1).value, 0x67Fu);
  EXPECT_EQ(rig.exchange("67F#4000100000000000"), Frames{"5FF#4300100092010200"});
  // 1200h stays read-only
  EXPECT_EQ(rig.write(0x1200, 1, 0x67F, 4), 0x06010002u);
}

TEST(DriveSdoServers, NotValidBitSwitchesTheChannelOff) {
  // Given the second channel valid on 67Fh
  // When 1201h:01 gets bit 31 set, then a new CAN-ID 67Eh valid
  // Then 67Fh gets no answer while off, and afterwards the channel answers on 67Eh only
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::client));
  open_second_channel(rig);
  ASSERT_EQ(rig.write(0x1201, 1, 0x8000067F, 4), 0u);
  EXPECT_EQ(rig.exchange("67F#4000100000000000", 50ms), Frames{});
  ASSERT_EQ(rig.write(0x1201, 1, 0x67E, 4), 0u);
  EXPECT_EQ(rig.exchange("67F#4000100000000000", 50ms), Frames{});
  EXPECT_EQ(rig.exchange("67E#4000100000000000"), Frames{"5FF#4300100092010200"});
}

TEST(DriveSdoServers, ResetCommunicationPutsTheChannelBackOff) {
  // Given the second channel valid on 67Fh
  // When the drive gets reset communication
  // Then 1201h is back at 80000000h and 67Fh gets no answer
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::client));
  open_second_channel(rig);
  rig.nmt(0x82);
  rig.run(10ms);
  EXPECT_EQ(rig.read(0x1201, 1).value, 0x80000000u);
  EXPECT_EQ(rig.exchange("67F#4000100000000000", 50ms), Frames{});
}

TEST(DriveSdoServers, KeptOverResetDeviationLeavesTheCobIdsAsWritten) {
  // Given the deviation sdo-server-cob-ids-kept-over-reset and the second channel valid on 67Fh
  // When the drive gets reset communication
  // Then 1201h sub 01h still reads the written COB-ID (valid, 67Fh)
  DriveConfig config = with_servers(1, cia301::SdoNodeIdSub::client);
  config.deviations.add(Deviation::sdo_server_cob_ids_kept_over_reset);
  DriveRig rig(5, config);
  open_second_channel(rig);
  rig.nmt(0x82);
  rig.run(10ms);
  EXPECT_EQ(rig.read(0x1201, 1).value & 0x800007FFu, 0x67Fu);
}

TEST(DriveSdoServers, StoppedServesNoChannel) {
  // Given the second channel valid and the drive stopped
  // When a request comes on 67Fh
  // Then no answer (SDO is not allowed in Stopped, on any channel)
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::client));
  open_second_channel(rig);
  rig.nmt(0x02);
  EXPECT_EQ(rig.exchange("67F#4000100000000000", 50ms), Frames{});
}

TEST(DriveSdoServersEsr, ServerNodeIdSetsBothCobIdsAtOnce) {
  // Given ESR's second server (sub 03h = the server's node-ID, 004 §14.1 L930-942)
  // When 1201h:03 is written 7Fh
  // Then 1201h:01/02 read 67Fh/5FFh (valid) and the server answers on 5FFh at once
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::server));
  EXPECT_EQ(rig.read(0x1201, 3).value, 0u);
  ASSERT_EQ(rig.write(0x1201, 3, 0x7F, 1), 0u);
  EXPECT_EQ(rig.read(0x1201, 1).value, 0x67Fu);
  EXPECT_EQ(rig.read(0x1201, 2).value, 0x5FFu);
  EXPECT_EQ(rig.exchange("67F#4000100000000000"), Frames{"5FF#4300100092010200"});
}

TEST(DriveSdoServersEsr, ZeroDisablesTheSecondServer) {
  // Given ESR's second server on node-ID 7Fh
  // When 1201h:03 is written 0
  // Then its COB-IDs read 80000000h and 67Fh gets no answer (L940-942)
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::server));
  ASSERT_EQ(rig.write(0x1201, 3, 0x7F, 1), 0u);
  ASSERT_EQ(rig.write(0x1201, 3, 0, 1), 0u);
  EXPECT_EQ(rig.read(0x1201, 1).value, 0x80000000u);
  EXPECT_EQ(rig.exchange("67F#4000100000000000", 50ms), Frames{});
}

TEST(DriveSdoServersEsr, NodeIdAbove127IsRefused) {
  // Given ESR's second server
  // When 1201h:03 is written 80h
  // Then the write aborts 06090031h (value too high) and the server stays off
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::server));
  EXPECT_EQ(rig.write(0x1201, 3, 0x80, 1), 0x06090031u);
  EXPECT_EQ(rig.read(0x1201, 1).value, 0x80000000u);
}

TEST(DriveSdoServersEsr, MovingTheServerThroughItselfAnswersOnTheOldCobId) {
  // Given ESR's second server on node-ID 7Fh
  // When 1201h:03 := 7Eh is written through that server (67Fh)
  // Then the download response leaves on 5FFh, and the server then answers on 67Eh/5FEh only
  DriveRig rig(5, with_servers(1, cia301::SdoNodeIdSub::server));
  ASSERT_EQ(rig.write(0x1201, 3, 0x7F, 1), 0u);
  // ccs=1 e=1 s=1 n=3, 1201h sub 3, data 7Eh -> scs=3, 1201h sub 3
  EXPECT_EQ(rig.exchange("67F#2F0112037E000000"), Frames{"5FF#6001120300000000"});
  EXPECT_EQ(rig.exchange("67F#4000100000000000", 50ms), Frames{});
  EXPECT_EQ(rig.exchange("67E#4000100000000000"), Frames{"5FE#4300100092010200"});
}

TEST(DriveBusOff, RecoverySendsEmcy8140WithCommunicationBit) {
  // Given a drive in pre-operational
  // When its controller goes bus-off and recovers
  // Then it sends EMCY 8140h with error register 11h (generic + communication), and a reset
  //      communication clears the error (1001h = 0)
  DriveRig rig;
  rig.drive_port().set_bus_off(true);
  rig.drive().set_bus_off(true);
  rig.run(20ms);
  rig.drive_port().set_bus_off(false);
  rig.drive().set_bus_off(false);
  EXPECT_EQ(rig.run(10ms), Frames{emcy_frame(5, 0x8140, 0x11)});
  EXPECT_EQ(rig.read(0x1001, 0).value, 0x11u);
  rig.nmt(0x82);
  rig.run(10ms);
  EXPECT_EQ(rig.read(0x1001, 0).value, 0u);
}

TEST(DriveBusOff, OperationalGoesPreOperationalByErrorBehaviour) {
  // Given an operational drive (1029h:01 = 0, the default)
  // When its controller goes bus-off
  // Then the drive is pre-operational (CiA 301 1029h: communication error)
  DriveRig rig;
  rig.nmt(0x01);
  ASSERT_EQ(rig.drive().state(), cia301::NmtState::operational);
  rig.drive_port().set_bus_off(true);
  rig.drive().set_bus_off(true);
  EXPECT_EQ(rig.drive().state(), cia301::NmtState::pre_operational);
}

TEST(DriveBusOff, ErrorBehaviourOneKeepsTheState) {
  // Given an operational drive with 1029h:01 = 1 (no state change)
  // When its controller goes bus-off
  // Then the drive stays operational
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1029, 1, 1, 1), 0u);
  rig.nmt(0x01);
  rig.drive_port().set_bus_off(true);
  rig.drive().set_bus_off(true);
  EXPECT_EQ(rig.drive().state(), cia301::NmtState::operational);
}

TEST(DriveBusOff, ApplicationHookReplacesTheRecoveryEmcy) {
  // Given a drive whose DriveConfig::on_bus_off records its calls
  // When the controller goes bus-off and recovers
  // Then the hook sees (true, transmitted = true) and (false, true), and no EMCY 8140h is sent
  std::vector<std::pair<bool, bool>> calls;
  DriveConfig config;
  config.on_bus_off = [&calls](ReferenceDrive&, bool off, bool transmitted) {
    calls.emplace_back(off, transmitted);
  };
  DriveRig rig(5, config);
  rig.drive_port().set_bus_off(true);
  rig.drive().set_bus_off(true);
  rig.drive_port().set_bus_off(false);
  rig.drive().set_bus_off(false);
  EXPECT_EQ(rig.run(10ms), Frames{});
  EXPECT_EQ(calls, (std::vector<std::pair<bool, bool>>{{true, true}, {false, true}}));
}

}  // namespace
}  // namespace drivecheck::reference_drive::testing
