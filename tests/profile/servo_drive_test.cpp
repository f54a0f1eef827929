// ServoDrive with each manual's personality against the standard drive, on the simulated bus:
// each personality differs from the standard drive exactly where its manual says.
#include "reference_drive/servo_drive.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "tests/profile/servo_rig.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;

using testing::kDrives;
using testing::kNoAnswer;
using testing::kNode;
using testing::ServoRig;

constexpr std::uint32_t kInvalidValue = 0x06090030;

std::vector<can::Frame> emcys(const std::vector<can::Frame>& frames) {
  std::vector<can::Frame> out;
  for (const auto& f : frames)
    if (f.id == 0x80U + kNode) out.push_back(f);
  return out;
}

TEST(ServoDriveStandard, HostsEveryModeAndEveryOptionCode) {
  // Given the standard drive / When 6502h and 605Ah are used / Then all modes, 605Ah 5 accepted
  ServoRig rig;
  ASSERT_TRUE(rig.ok());
  // pp pv tq hm ip csp csv cst = bits 0 2 3 5 6 7 8 9
  EXPECT_EQ(rig.read(0x6502), 0x000003EDU);
  EXPECT_EQ(rig.write(0x605A, 0, 5, 2), 0U);
  EXPECT_EQ(rig.read(0x1000), 0x00020192U);
  EXPECT_TRUE(rig.drive().not_applied().empty());
}

TEST(ServoDrivePersonality, FestoHasCspOverEthercatOnly) {
  // Given the Festo profile (csp in modes_only_on for EtherCAT) / When planned for CAN and for
  // EtherCAT / Then 6502h bit 7 (csp) is set over EtherCAT only, the other modes on both
  auto festo = profile::find_profile("festo-cmmp", kDrives);
  ASSERT_TRUE(festo.has_value()) << festo.error().to_string();
  auto can = plan_personality(&*festo, profile::Link::can);
  auto ecat = plan_personality(&*festo, profile::Link::ethercat);
  ASSERT_TRUE(can.has_value()) << can.error();
  ASSERT_TRUE(ecat.has_value()) << ecat.error();
  constexpr std::uint32_t kCsp = 1U << 7;
  EXPECT_EQ(can->application.pds.supported_modes & kCsp, 0U);
  EXPECT_EQ(ecat->application.pds.supported_modes & kCsp, kCsp);
  EXPECT_EQ(ecat->application.pds.supported_modes & ~kCsp, can->application.pds.supported_modes);
}

TEST(ServoDriveStandard, PlanEqualsTheReferenceProfile) {
  // Given the standard drive and cia402-reference.yaml / When planned / Then the same drive
  auto reference = profile::find_profile("cia402-reference", kDrives);
  ASSERT_TRUE(reference.has_value()) << reference.error().to_string();
  auto from_profile = plan_personality(&*reference);
  auto standard = plan_personality(nullptr);
  ASSERT_TRUE(from_profile.has_value()) << from_profile.error();
  ASSERT_TRUE(standard.has_value()) << standard.error();
  EXPECT_EQ(from_profile->application.pds.supported_modes,
            standard->application.pds.supported_modes);
  EXPECT_EQ(from_profile->application.pds.option_code_support.values,
            standard->application.pds.option_code_support.values);
  EXPECT_EQ(from_profile->application.pds.hardware_enable,
            standard->application.pds.hardware_enable);
  EXPECT_EQ(from_profile->overrides, standard->overrides);
  EXPECT_EQ(from_profile->homing.supported_methods.size(), 32U);
  EXPECT_TRUE(from_profile->not_applied.empty());
}

TEST(ServoDriveStandard, HardwareEnableGatesSwitchOn) {
  // Given the standard drive without its hardware enable input / When switched on / Then it
  // stays READY TO SWITCH ON until the input comes
  ServoRig rig;
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(rig.drive().simulate("hardware-enable", 0));
  rig.controlword(0x0006);
  rig.controlword(0x0007);
  EXPECT_EQ(rig.statusword() & 0x6F, 0x21);  // ready to switch on
  ASSERT_TRUE(rig.drive().simulate("hardware-enable", 1));
  rig.controlword(0x0007);
  EXPECT_EQ(rig.statusword() & 0x6F, 0x23);  // switched on
}

TEST(ServoDriveFesto, QuickStopOptionCodeRefusesFive) {
  // Given the Festo drive (605Ah fixed 2, L5889-5905) / When 605Ah = 5 / Then abort 06090030h
  ServoRig rig("festo-cmmp");
  ASSERT_TRUE(rig.ok());
  EXPECT_EQ(rig.write(0x605A, 0, 5, 2), kInvalidValue);
  EXPECT_EQ(rig.write(0x605A, 0, 2, 2), 0U);
  EXPECT_EQ(rig.read(0x605A), 2U);
  EXPECT_EQ(rig.write(0x605B, 0, 1, 2), kInvalidValue);  // shutdown fixed 0
  EXPECT_EQ(rig.read(0x1018, 1), 0x1DU);                 // Festo vendor-ID
}

TEST(ServoDriveFesto, ObjectsAndRestoreAsTheManualDocuments) {
  // Given the Festo drive after power on / When 605Ch, 6061h, 60C4h, 6080h are read and "load"
  // is written to 1011h:01 with the output stage on and off / Then the manual's values: 605Ch
  // -1 (L5871-5887), 6061h 3 (L5996-6005), 60C4h:01/02 0 (L6606-6638), 6080h 2 bytes = 32768
  // (L6939-6948), restore refused with 08000022h while the output stage is on (L2501)
  ServoRig rig("festo-cmmp");
  ASSERT_TRUE(rig.ok());
  EXPECT_EQ(static_cast<std::int16_t>(rig.read(0x605C)), -1);
  EXPECT_EQ(rig.write(0x605C, 0, 1, 2), kInvalidValue);  // fixed: cannot be changed
  EXPECT_EQ(rig.read(0x6061), 3U);
  EXPECT_EQ(rig.read(0x6060), 3U);
  EXPECT_EQ(rig.read(0x60C4, 1), 0U);
  EXPECT_EQ(rig.read(0x60C4, 2), 0U);
  EXPECT_EQ(rig.write(0x60C4, 2, 1, 4), kInvalidValue);  // value range 0 .. max_buffer_size
  const auto speed = rig.upload(0x6080, 0);
  ASSERT_TRUE(speed.has_value());
  EXPECT_EQ(speed->data[0], 0x4B);  // expedited upload, 2 bytes
  EXPECT_EQ(rig.read(0x6080), 32768U);
  rig.enable();
  ASSERT_EQ(rig.state(), cia402::State::operation_enabled);
  constexpr std::uint32_t kLoad = 0x64616F6C;
  EXPECT_EQ(rig.write(0x1011, 1, kLoad, 4), 0x0800'0022U);
  rig.controlword(0x0007);  // disable operation: SWITCHED ON, the output stage still on
  EXPECT_EQ(rig.write(0x1011, 1, kLoad, 4), 0x0800'0022U);
  rig.controlword(0x0000);  // disable voltage: the output stage off
  rig.run(500ms);           // 605Ch -1 brakes with 6085h first
  EXPECT_EQ(rig.write(0x1011, 1, kLoad, 4), 0U);
}

TEST(ServoDriveFesto, ShortSdoRequestIsPadded) {
  // Given the Festo drive (its examples print requests with 4 bytes, L744-756) and the standard
  // drive / When "40 61 60 00" (upload 6061h, DLC 4) comes / Then Festo answers, standard not
  ServoRig festo("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(festo.ok());
  ASSERT_TRUE(standard.ok());
  // ccs=2 initiate upload, 6061h sub 0, no data bytes
  const std::uint8_t request[4] = {0x40, 0x61, 0x60, 0x00};
  auto answers = [](ServoRig& rig, std::span<const std::uint8_t> bytes) {
    rig.send(can::Frame::standard(0x600 + kNode, bytes));
    std::size_t n = 0;
    for (const auto& f : rig.run(5ms))
      n += f.id == 0x580U + kNode ? 1 : 0;
    return n;
  };
  EXPECT_EQ(answers(festo, request), 1U);
  EXPECT_EQ(answers(standard, request), 0U);
}

TEST(ServoDriveFesto, HardwareEnableGatesShutdown) {
  // Given the Festo drive without DIN4/DIN5 (Tab. 6.2 L5218) / When shutdown / Then it stays
  // SWITCH ON DISABLED
  ServoRig rig("festo-cmmp");
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(rig.drive().simulate("hardware-enable", 0));
  rig.controlword(0x0006);
  EXPECT_EQ(rig.statusword() & 0x4F, 0x40);  // switch on disabled
  ASSERT_TRUE(rig.drive().simulate("hardware-enable", 1));
  rig.controlword(0x0006);
  EXPECT_EQ(rig.statusword() & 0x6F, 0x21);  // ready to switch on
}

TEST(ServoDriveFesto, DefaultPdoMappingOfTheManual) {
  // Given the Festo drive / When the PDO defaults are read / Then the manual's tables (L1088-1214)
  ServoRig rig("festo-cmmp");
  ASSERT_TRUE(rig.ok());
  EXPECT_EQ(rig.read(0x1A01, 0), 2U);
  EXPECT_EQ(rig.read(0x1A01, 1), 0x60410010U);
  EXPECT_EQ(rig.read(0x1A01, 2), 0x60610008U);
  EXPECT_EQ(rig.read(0x1603, 2), 0x60FF0020U);
  EXPECT_NE(rig.read(0x1800, 1) & 0x80000000U, 0U);  // invalid as shipped
  ServoRig standard;
  EXPECT_NE(standard.read(0x1A01, 2), 0x60610008U);
}

TEST(ServoDriveFesto, HomingMethodsOfTheManual) {
  // Given the Festo drive / When 6098h is written / Then -17 is accepted, 3 is refused
  ServoRig rig("festo-cmmp");
  ASSERT_TRUE(rig.ok());
  EXPECT_EQ(rig.read(0x6098), 17U);
  EXPECT_EQ(rig.write(0x6098, 0, static_cast<std::uint8_t>(-17), 1), 0U);
  EXPECT_NE(rig.write(0x6098, 0, 3, 1), 0U);
  ServoRig standard;
  EXPECT_EQ(standard.write(0x6098, 0, 3, 1), 0U);
}

TEST(ServoDriveIrtsa, ErrorCodeIsErrorNumberTimes256Plus80h) {
  // Given the IRTSA drive (603Fh = n * 256 + 80h, L212-228) / When a fault occurs / Then 603Fh
  // has 80h in its low byte, where the standard drive shows the CiA 402 code
  ServoRig irtsa("irtsa-drive-fb");
  ServoRig standard;
  ASSERT_TRUE(irtsa.ok());
  ASSERT_TRUE(standard.ok());
  ASSERT_TRUE(irtsa.drive().simulate("fault:over-voltage", 1));
  ASSERT_TRUE(standard.drive().simulate("fault:over-voltage", 1));
  irtsa.run(20ms);
  standard.run(20ms);
  const std::uint32_t standard_code = standard.read(0x603F);
  const std::uint32_t irtsa_code = irtsa.read(0x603F);
  EXPECT_EQ(standard_code, 0x3210U);  // DC link over-voltage
  EXPECT_EQ(irtsa_code & 0xFFU, 0x80U);
  EXPECT_NE(irtsa_code, standard_code);
}

TEST(ServoDriveIrtsa, HomingOnlyByManufacturerMethods) {
  // Given the IRTSA drive (no CiA 402 homing method, L418) / When 6098h is written / Then 35 is
  // refused, -126 accepted; 6098h starts at 81h
  ServoRig rig("irtsa-drive-fb");
  ASSERT_TRUE(rig.ok());
  EXPECT_EQ(rig.read(0x6098), 0x81U);
  EXPECT_NE(rig.write(0x6098, 0, 35, 1), 0U);
  EXPECT_EQ(rig.write(0x6098, 0, 0x82, 1), 0U);
  EXPECT_EQ(rig.read(0x1000), 0x00420192U);
}

TEST(ServoDriveFesto, PositionRangeOnlyOnARoundAxis) {
  // Given the Festo drive at 6064h = 0 with 607Bh = 250 .. 750 (0 lies outside: it shows as
  // 500 once the range is in effect); 60F2h is not in the manual (L3821-3867: the round axis is
  // selected and directed by 6510h sub 20h)
  ServoRig rig("festo-cmmp");
  ASSERT_TRUE(rig.ok());
  std::uint32_t abort = 0;
  rig.read(0x60F2, 0, &abort);
  EXPECT_EQ(abort, 0x06020000U);
  ASSERT_EQ(rig.read(0x6064), 0U);
  ASSERT_EQ(rig.write(0x607B, 1, 250, 4), 0U);
  ASSERT_EQ(rig.write(0x607B, 2, 750, 4), 0U);
  // When 6510h sub 20h is 0 (off), then 4 (fixed direction positive)
  rig.run(10ms);
  const std::uint32_t off = rig.read(0x6064);
  ASSERT_EQ(rig.write(0x6510, 0x20, 4, 2), 0U);
  rig.run(10ms);
  // Then the range takes effect only with the round axis selected
  EXPECT_EQ(off, 0U);
  EXPECT_EQ(rig.read(0x6064), 500U);
}

TEST(ServoDriveIrtsa, HomingSetsThePositionWithoutMotion) {
  // Given the IRTSA drive in SWITCH ON DISABLED, homing mode, 607Ch = 1234, method 81h
  // (L416-421: the home offset becomes the actual position; any state but the fault states)
  ServoRig rig("irtsa-drive-fb");
  ASSERT_TRUE(rig.ok());
  ASSERT_EQ(rig.write(0x6060, 0, 6, 1), 0U);
  ASSERT_EQ(rig.write(0x607C, 0, 1234, 4), 0U);
  rig.run(10ms);
  // When homing starts (controlword bit 4 rising, bits 0-3 = 0: still SWITCH ON DISABLED)
  rig.controlword(0x0000);
  rig.controlword(0x0010);
  // Then 6064h reads 1234, homing attained (bit 12), no error (bit 13), still SWITCH ON DISABLED
  EXPECT_EQ(rig.read(0x6064), 1234U);
  const std::uint16_t sw = rig.statusword();
  EXPECT_NE(sw & 0x1000, 0) << std::hex << sw;
  EXPECT_EQ(sw & 0x2000, 0) << std::hex << sw;
  EXPECT_EQ(sw & 0x4F, 0x40) << std::hex << sw;
}

TEST(ServoDriveEsr, ModesOfOperationAre16Bit) {
  // Given the ESR drive (6060h/6061h INTEGER16, L1029-1036) / When 6060h is uploaded / Then the
  // response carries 2 bytes (4Bh), where the standard drive's carries 1 (4Fh)
  ServoRig esr("esr-triodrive");
  ServoRig standard;
  ASSERT_TRUE(esr.ok());
  ASSERT_TRUE(standard.ok());
  const auto esr_answer = esr.upload(0x6060, 0);
  const auto standard_answer = standard.upload(0x6060, 0);
  ASSERT_TRUE(esr_answer.has_value());
  ASSERT_TRUE(standard_answer.has_value());
  EXPECT_EQ(esr_answer->data[0], 0x4B);
  EXPECT_EQ(standard_answer->data[0], 0x4F);
  EXPECT_EQ(esr.write(0x6060, 0, 1, 2), 0U);  // 16-bit write accepted
  EXPECT_EQ(esr.read(0x1A01, 2), 0x60610010U);
}

TEST(ServoDriveKollmorgen, EveryEmcyIsFollowedByAnErrorStateEmcy) {
  // Given the Kollmorgen drive (L768-777) / When a fault occurs / Then two EMCYs: the code, then
  // 0000h with the error register; the standard drive sends one
  ServoRig rig("kollmorgen-s300-s700");
  ServoRig standard;
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(standard.ok());
  ASSERT_TRUE(rig.drive().simulate("fault:over-temperature", 1));
  ASSERT_TRUE(standard.drive().simulate("fault:over-temperature", 1));
  const auto frames = emcys(rig.run(20ms));
  const auto standard_frames = emcys(standard.run(20ms));
  ASSERT_EQ(frames.size(), 2U);
  EXPECT_NE(frames[0].data[0] | frames[0].data[1], 0);
  EXPECT_EQ(frames[1].data[0] | frames[1].data[1], 0);  // error reset code 0000h
  EXPECT_EQ(frames[1].data[2], frames[0].data[2]);      // the error register
  EXPECT_NE(frames[1].data[2], 0);                      // an error is pending
  EXPECT_EQ(standard_frames.size(), 1U);
}

TEST(ServoDriveKollmorgen, IdentityQuickStopAndNoErrorBehaviourObject) {
  // Given the Kollmorgen drive / When identity, 605Ah and 1029h are read / Then the manual's
  // 00002192h and 6Ah, quick stop stays in QUICK STOP ACTIVE (6), and no 1029h (its object
  // table, 002 §6.1.3 L6009-6040, does not list it): 06020000h
  ServoRig rig("kollmorgen-s300-s700");
  ASSERT_TRUE(rig.ok());
  EXPECT_EQ(rig.read(0x1000), 0x00002192U);
  EXPECT_EQ(rig.read(0x1018, 1), 0x6AU);
  EXPECT_EQ(rig.read(0x605A), 6U);
  EXPECT_EQ(rig.write(0x605A, 0, 2, 2), kInvalidValue);
  std::uint32_t abort = 0;
  EXPECT_EQ(rig.read(0x1029, 1, &abort), kNoAnswer);
  EXPECT_EQ(abort, 0x06020000U);                    // object does not exist
  EXPECT_FALSE(rig.drive().not_applied().empty());  // manufacturer modes, methods -3/-8
}

// Operational, 6007h = 0 (no CiA 402 reaction), life guarding 100 ms x 2 started by one RTR,
// then no more RTRs for 500 ms: the NMT state afterwards.
cia301::NmtState state_after_guarding_loss(ServoRig& rig) {
  EXPECT_EQ(rig.write(0x6007, 0, 0, 2), 0U);
  EXPECT_EQ(rig.write(0x100C, 0, 100, 2), 0U);
  EXPECT_EQ(rig.write(0x100D, 0, 2, 1), 0U);
  const std::uint8_t start[2] = {0x01, kNode};  // NMT start remote node 5
  rig.send(can::Frame::standard(0x000, start));
  rig.run(10ms);
  rig.send(can::Frame::remote(0x700 + kNode, 1));  // guarding request (RTR, DLC 1)
  const auto frames = emcys(rig.run(500ms));
  EXPECT_FALSE(frames.empty());  // EMCY 8130h: the life guarding event happened
  return rig.drive().device().state();
}

TEST(ServoDriveKollmorgen, GuardingLossKeepsTheNmtState) {
  // Given the Kollmorgen drive (warning N04 and quick stop, no NMT change, L1029-1069) and the
  // standard drive (1029h:01 = 0) / When life guarding times out in Operational / Then Kollmorgen
  // stays Operational, the standard drive goes Pre-operational
  ServoRig rig("kollmorgen-s300-s700");
  ServoRig standard;
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(standard.ok());
  EXPECT_EQ(state_after_guarding_loss(rig), cia301::NmtState::operational);
  EXPECT_EQ(state_after_guarding_loss(standard), cia301::NmtState::pre_operational);
}

TEST(ServoDriveKollmorgen, BusOffKeepsTheNmtStateWithout1029) {
  // Given the Kollmorgen drive (no 1029h; bus-off is F23 with an emergency-ramp stop, no NMT
  // change documented, 002 §2.9 L192-212) and the standard drive (1029h:01 = 0), both
  // Operational / When their controllers go bus-off / Then Kollmorgen stays Operational, the
  // standard drive goes Pre-operational
  ServoRig rig("kollmorgen-s300-s700");
  ServoRig standard;
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(standard.ok());
  for (ServoRig* r : {&rig, &standard}) {
    const std::uint8_t start[2] = {0x01, kNode};  // NMT start remote node 5
    r->send(can::Frame::standard(0x000, start));
    r->run(10ms);
    r->bus_off(true);
    r->run(10ms);
  }
  EXPECT_EQ(rig.drive().device().state(), cia301::NmtState::operational);
  EXPECT_EQ(standard.drive().device().state(), cia301::NmtState::pre_operational);
}

constexpr std::uint32_t kWriteReadOnly = 0x06010002;
constexpr std::uint32_t kNoObject = 0x06020000;
constexpr std::uint32_t kValueTooHigh = 0x06090031;
constexpr std::uint32_t kValueTooLow = 0x06090032;
constexpr std::uint32_t kUnsupportedAccess = 0x06010000;

TEST(ServoDriveFesto, ManualObjectsAnswerAsDocumented) {
  // Given the Festo drive (2030h wo L3879-3892, 604Dh 2..254 L3199-3214, 1005h fixed L1234-1245)
  // When they are read and written / Then the manual's aborts, and 2030h moves 6064h only
  ServoRig rig("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(standard.ok());
  const auto upload = rig.upload(0x2030, 0);
  ASSERT_TRUE(upload.has_value());
  EXPECT_EQ(upload->data[0], 0x80);  // abort
  EXPECT_EQ(rig.write(0x2030, 0, 0, 4), 0U);
  EXPECT_EQ(rig.read(0x2030), kNoAnswer);  // a read never answers with data
  EXPECT_EQ(rig.write(0x2030, 0, 12345, 4), 0U);
  rig.run(10ms);
  EXPECT_EQ(rig.read(0x6064), 12345U);  // the actual position, shifted without motion
  EXPECT_EQ(rig.read(0x604D), 4U);
  EXPECT_EQ(rig.write(0x604D, 0, 1, 1), kValueTooLow);
  EXPECT_EQ(rig.write(0x604D, 0, 255, 1), kValueTooHigh);
  EXPECT_EQ(rig.write(0x604D, 0, 8, 1), 0U);
  EXPECT_EQ(rig.read(0x604D), 8U);
  EXPECT_EQ(rig.write(0x1005, 0, 0x81, 4), kInvalidValue);
  EXPECT_EQ(rig.write(0x1005, 0, 0x80000080, 4), 0U);
  EXPECT_EQ(rig.read(0x1005), 0x80000080U);
  // the standard drive has neither object and takes another SYNC COB-ID
  EXPECT_EQ(standard.write(0x2030, 0, 1, 4), kNoObject);
  EXPECT_EQ(standard.write(0x604D, 0, 1, 1), kNoObject);
  EXPECT_EQ(standard.write(0x1005, 0, 0x81, 4), 0U);
}

TEST(ServoDriveFesto, ReadOfWriteOnlyObjectAborts06010001h) {
  // Given the Festo drive / When 2030h (wo) is read / Then abort 06010001h (L779)
  ServoRig rig("festo-cmmp");
  ASSERT_TRUE(rig.ok());
  const auto f = rig.upload(0x2030, 0);
  ASSERT_TRUE(f.has_value());
  // abort, 2030h sub 0, 06010001h
  const can::Frame expected = can::Frame::standard(
      0x580 + kNode, std::array<std::uint8_t, 8>{0x80, 0x30, 0x20, 0x00, 0x01, 0x00, 0x01, 0x06});
  EXPECT_EQ(can::to_candump(*f), can::to_candump(expected));
}

// TPDO1 of the rig's drive on 607Ah (rw, mappable), sent on change (255), then Operational.
void map_target_position_on_change(ServoRig& rig) {
  ASSERT_EQ(rig.write(0x1800, 1, 0xC0000180U + kNode, 4), 0U);  // invalid while mapping
  ASSERT_EQ(rig.write(0x1A00, 0, 0, 1), 0U);
  ASSERT_EQ(rig.write(0x1A00, 1, 0x607A0020, 4), 0U);  // target position, 32 bits
  ASSERT_EQ(rig.write(0x1A00, 0, 1, 1), 0U);
  ASSERT_EQ(rig.write(0x1800, 2, 255, 1), 0U);
  ASSERT_EQ(rig.write(0x1800, 1, 0x40000180U + kNode, 4), 0U);
  const std::uint8_t start[2] = {0x01, kNode};  // NMT start remote node 5
  rig.send(can::Frame::standard(0x000, start));
  rig.run(20ms);  // the first TPDO (entering Operational)
}

// 607Ah := value by SDO, then 20 ms: the TPDO1 frames sent meanwhile.
std::vector<can::Frame> tpdos_after_target(ServoRig& rig, std::uint32_t value) {
  // ccs=1 e=1 s=1 n=0 (23h), 607Ah sub 0, data LE
  const std::uint8_t request[8] = {0x23,
                                   0x7A,
                                   0x60,
                                   0x00,
                                   static_cast<std::uint8_t>(value),
                                   static_cast<std::uint8_t>(value >> 8),
                                   static_cast<std::uint8_t>(value >> 16),
                                   static_cast<std::uint8_t>(value >> 24)};
  rig.send(can::Frame::standard(0x600 + kNode, request));
  std::vector<can::Frame> out;
  for (const auto& f : rig.run(20ms))
    if (f.id == 0x180U + kNode) out.push_back(f);
  return out;
}

TEST(ServoDriveFesto, TransmitMaskLimitsChangeDetection) {
  // Given the Festo drive, TPDO1 = 607Ah on change and 2014h masking only byte 1 (L903-909)
  // When byte 0 changes / Then no TPDO; when byte 1 changes / Then the TPDO with both bytes
  ServoRig rig("festo-cmmp");
  ASSERT_TRUE(rig.ok());
  EXPECT_EQ(rig.read(0x2014, 0), 2U);
  EXPECT_EQ(rig.read(0x2014, 1), 0xFFFFFFFFU);
  EXPECT_EQ(rig.read(0x2017, 2), 0xFFFFFFFFU);
  ASSERT_EQ(rig.write(0x2014, 1, 0x0000FF00, 4), 0U);  // low: payload bits 8-15
  ASSERT_EQ(rig.write(0x2014, 2, 0, 4), 0U);           // high: none
  map_target_position_on_change(rig);
  EXPECT_EQ(tpdos_after_target(rig, 0x01).size(), 0U);
  const auto frames = tpdos_after_target(rig, 0x0201);
  ASSERT_EQ(frames.size(), 1U);
  EXPECT_EQ(can::to_candump(frames[0]), "185#01020000");  // 607Ah = 00000201h
  // all bits masked again: any change is sent
  ASSERT_EQ(rig.write(0x2014, 1, 0xFFFFFFFF, 4), 0U);
  EXPECT_EQ(tpdos_after_target(rig, 0x0202).size(), 1U);
}

TEST(ServoDriveStandard, EveryChangeIsSentWithoutMasks) {
  // Given the standard drive (no 2014h) and TPDO1 = 607Ah on change / When byte 0 changes
  // Then the TPDO is sent
  ServoRig rig;
  ASSERT_TRUE(rig.ok());
  EXPECT_EQ(rig.read(0x2014, 1), kNoAnswer);
  map_target_position_on_change(rig);
  EXPECT_EQ(tpdos_after_target(rig, 0x01).size(), 1U);
}

TEST(ServoDriveKollmorgen, FactorObjectsReadOnlyAndDeleteMotionTasks) {
  // Given the Kollmorgen drive (6094h/6097h ro L3675-3679, L3846-3850; 2083h wo with the
  // signature "prom" L2337-2353) / When written and read / Then the manual's answers
  ServoRig rig("kollmorgen-s300-s700");
  ServoRig standard;
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(standard.ok());
  EXPECT_EQ(rig.write(0x6094, 1, 1, 4), kWriteReadOnly);
  EXPECT_EQ(rig.write(0x6094, 2, 1, 4), kWriteReadOnly);
  EXPECT_EQ(rig.write(0x6097, 1, 1, 4), kWriteReadOnly);
  EXPECT_EQ(rig.read(0x6094, 1), 1U);
  EXPECT_EQ(standard.write(0x6094, 1, 2, 4), 0U);
  EXPECT_EQ(rig.read(0x2083), kNoAnswer);
  EXPECT_EQ(rig.write(0x2083, 0, 1, 4), kInvalidValue);
  EXPECT_EQ(rig.write(0x2083, 0, 0x6D6F7270, 4), 0U);  // "prom"
  bool named = false;
  for (const auto& line : rig.drive().not_applied())
    named = named || line.find("2083h") != std::string::npos;
  EXPECT_TRUE(named);
}

TEST(ServoDriveKollmorgen, MappingWritableWhilePdoValid) {
  // Given the Kollmorgen drive (jog example L7199-7244) and the standard drive, RPDO1 valid
  // When 1600h sub 0 := 0 / Then Kollmorgen confirms, the standard drive aborts 06010000h
  ServoRig rig("kollmorgen-s300-s700");
  ServoRig standard;
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(standard.ok());
  ASSERT_EQ(rig.read(0x1400, 1) & 0x80000000U, 0U);  // valid by default
  EXPECT_EQ(rig.write(0x1600, 0, 0, 1), 0U);
  EXPECT_EQ(rig.write(0x1600, 1, 0x60FF0020, 4), 0U);
  EXPECT_EQ(rig.write(0x1600, 0, 1, 1), 0U);
  EXPECT_EQ(rig.read(0x1600, 1), 0x60FF0020U);
  EXPECT_EQ(rig.write(0x1600, 1, 0x60710010, 4), kUnsupportedAccess);  // sub 0 is not 0
  ASSERT_EQ(standard.write(0x1400, 1, 0x200U + kNode, 4), 0U);         // RPDO1 valid
  EXPECT_EQ(standard.write(0x1600, 0, 0, 1), kUnsupportedAccess);
}

TEST(ServoDriveFesto, ParametersKeptInInternalUnits) {
  // Given the Festo drive (parameters stored internal, converted on read, L2594) and the
  // standard drive / When 607Ah = 65536 under 1/1 and the position factor becomes 4096/225
  // (1/10 degree) / Then Festo reads 3600, standard 65536
  ServoRig rig("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(rig.ok());
  ASSERT_TRUE(standard.ok());
  for (ServoRig* r : {&rig, &standard}) {
    ASSERT_EQ(r->write(0x607A, 0, 65536, 4), 0U);
    ASSERT_EQ(r->write(0x6093, 1, 4096, 4), 0U);
    ASSERT_EQ(r->write(0x6093, 2, 225, 4), 0U);
  }
  EXPECT_EQ(rig.read(0x607A), 3600U);
  EXPECT_EQ(standard.read(0x607A), 65536U);
  // a write converts the other way: 900 (90.0 degree) reads 16384 increments under 1/1
  ASSERT_EQ(rig.write(0x607A, 0, 900, 4), 0U);
  ASSERT_EQ(rig.write(0x6093, 1, 1, 4), 0U);
  ASSERT_EQ(rig.write(0x6093, 2, 1, 4), 0U);
  EXPECT_EQ(rig.read(0x607A), 16384U);
  // rounding shows: 1 increment under 1/10 degree (225/4096 = 0.055) reads 0
  ASSERT_EQ(rig.write(0x607A, 0, 1, 4), 0U);
  ASSERT_EQ(rig.write(0x6093, 1, 4096, 4), 0U);
  ASSERT_EQ(rig.write(0x6093, 2, 225, 4), 0U);
  EXPECT_EQ(rig.read(0x607A), 0U);
  // polarity: 6081h (speed) keeps its sign, 60FFh (velocity) is inverted
  ASSERT_EQ(rig.write(0x60FF, 0, 100, 4), 0U);
  ASSERT_EQ(rig.write(0x6081, 0, 100, 4), 0U);
  ASSERT_EQ(rig.write(0x607E, 0, 0x40, 1), 0U);
  EXPECT_EQ(rig.read(0x60FF), static_cast<std::uint32_t>(-100));
  EXPECT_EQ(rig.read(0x6081), 100U);
}

TEST(ServoDrivePlan, RefusesWhatTheDriveCannotTake) {
  // Given personalities the reference drive cannot take / When planned / Then errors
  auto bad = profile::parse_profile(R"(name: x
title: x
features: [cia402]
modes: [1]
personality:
  object_types: [{index: 0x6041, type: INTEGER32}]
)",
                                    {});
  ASSERT_TRUE(bad.has_value()) << bad.error().to_string();
  EXPECT_FALSE(plan_personality(&*bad).has_value());
  auto restrict_missing = profile::parse_profile(
      "name: x\ntitle: x\nfeatures: [cia402]\npersonality: {objects: [{index: 0x2999, access: "
      "ro}]}\n",
      {});
  ASSERT_TRUE(restrict_missing.has_value()) << restrict_missing.error().to_string();
  can::SimBus bus;
  auto port = bus.attach("drive");
  ServoDriveOptions options;
  options.profile = &*restrict_missing;
  EXPECT_FALSE(ServoDrive::create(*port, options).has_value());  // no 2999h, no type
  auto zero = profile::parse_profile(
      "name: x\ntitle: x\nfeatures: [cia402]\npersonality: {ack_latency_cycles: 0}\n", {});
  ASSERT_TRUE(zero.has_value()) << zero.error().to_string();
  EXPECT_FALSE(plan_personality(&*zero).has_value());
}

// --- Festo and Kollmorgen deviations the personalities impersonate (issues #5, #6, #7) -----

// Festo's commissioning to increments/s and increments/s² (festo-cmmp.yaml `commissioning:`).
void commission_increments(ServoRig& rig) {
  ASSERT_EQ(rig.write(0x6094, 1, 15, 4), 0U);  // velocity_encoder_factor 15/4
  ASSERT_EQ(rig.write(0x6094, 2, 4, 4), 0U);
  ASSERT_EQ(rig.write(0x6097, 1, 15, 4), 0U);  // acceleration_factor 15/64
  ASSERT_EQ(rig.write(0x6097, 2, 64, 4), 0U);
  rig.run(5ms);
}

TEST(ServoDriveFesto, PositionFactorAboveTwoToTheTwentyFourIsRefused) {
  // Given the Festo drive ("The position_factor must not be larger than 2^24", L2662) and the
  // standard drive, both with 6093h sub 2 = 1
  ServoRig festo("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(festo.ok());
  ASSERT_TRUE(standard.ok());
  // When 6093h sub 1 := 2^25 / Then Festo aborts 06090031h and keeps 1, the standard drive takes it
  EXPECT_EQ(festo.write(0x6093, 1, 0x0200'0000, 4), 0x0609'0031U);
  EXPECT_EQ(festo.read(0x6093, 1), 1U);
  EXPECT_EQ(standard.write(0x6093, 1, 0x0200'0000, 4), 0U);
  // When the divisor is 2 first / Then 2^25 / 2 = 2^24 is accepted, and the divisor cannot go
  // back to 1 under it
  ASSERT_EQ(festo.write(0x6093, 2, 2, 4), 0U);
  EXPECT_EQ(festo.write(0x6093, 1, 0x0200'0000, 4), 0U);
  EXPECT_EQ(festo.write(0x6093, 2, 1, 4), 0x0609'0031U);
}

TEST(ServoDriveFesto, FactorDefaultsAreInFestoUnits) {
  // Given the Festo drive (6094h = 4096/1 min^-1, 6097h = 256/1 min^-1/s, internal units
  // 1/4096 min^-1 and 1/256 min^-1/s, L2709-2811) and the standard drive / When read after power
  // on / Then Festo shows the manual's defaults and one user unit is 1 min^-1 on the axis
  ServoRig festo("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(festo.ok());
  ASSERT_TRUE(standard.ok());
  EXPECT_EQ(festo.read(0x6094, 1), 4096U);
  EXPECT_EQ(festo.read(0x6094, 2), 1U);
  EXPECT_EQ(festo.read(0x6097, 1), 256U);
  EXPECT_EQ(festo.read(0x6097, 2), 1U);
  EXPECT_EQ(standard.read(0x6094, 1), 1U);
  EXPECT_EQ(standard.read(0x6097, 1), 1U);
  // 1 min^-1 = 65536 / 60 increments/s = 4096 x 4/15; 1 min^-1/s = 256 x 64/15 increments/s².
  const FactorGroup& f = festo.drive().application().factors();
  EXPECT_NEAR(f.speed_to_internal(1.0), 65536.0 / 60.0, 1e-9);
  EXPECT_NEAR(f.acceleration_to_internal(1.0), 65536.0 / 60.0, 1e-9);
  EXPECT_EQ(standard.drive().application().factors().speed_to_internal(1.0), 1.0);
}

TEST(ServoDriveFesto, EncoderCountsSixtyFiveThousandFiveHundredThirtySixPerRevolution) {
  // Given the Festo drive ('65536 increments per revolution', Tab. 5.3 L2598-2605, L2617) and
  // the standard drive (4096) / When 608Fh is read / Then 65536/1 and 4096/1
  ServoRig festo("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(festo.ok());
  ASSERT_TRUE(standard.ok());
  EXPECT_EQ(festo.read(0x608F, 1), 65536U);
  EXPECT_EQ(festo.read(0x608F, 2), 1U);
  EXPECT_EQ(standard.read(0x608F, 1), 4096U);
  // Then Festo's windows are the manual's defaults in increments at that resolution: 6065h
  // 9101 (50 degree, L3716), 6067h 1820 (10 degree, L3778)
  EXPECT_EQ(festo.read(0x6065), 9101U);
  EXPECT_EQ(festo.read(0x6067), 1820U);
  // When gear 1/1 and feed 3600 (1/10 degree) are written / Then 6093h = 65536 / 3600 = 4096/225,
  // the manual's Tab. 5.5 row (L2664-2703); the standard drive gets 4096 / 3600 = 256/225
  for (ServoRig* r : {&festo, &standard}) {
    ASSERT_EQ(r->write(0x6092, 1, 3600, 4), 0U);
    ASSERT_EQ(r->write(0x6092, 2, 1, 4), 0U);
  }
  EXPECT_EQ(festo.read(0x6093, 1), 4096U);
  EXPECT_EQ(festo.read(0x6093, 2), 225U);
  EXPECT_EQ(standard.read(0x6093, 1), 256U);
  EXPECT_EQ(standard.read(0x6093, 2), 225U);
  // When gear 2/3 and feed 100 (1/100 rev) / Then 32768/75 (Tab. 5.5)
  ASSERT_EQ(festo.write(0x6091, 1, 2, 4), 0U);
  ASSERT_EQ(festo.write(0x6091, 2, 3, 4), 0U);
  ASSERT_EQ(festo.write(0x6092, 1, 100, 4), 0U);
  EXPECT_EQ(festo.read(0x6093, 1), 32768U);
  EXPECT_EQ(festo.read(0x6093, 2), 75U);
  // When gear 4/5 and feed 6315 per 10 shaft revolutions (63.15 mm in 1/10 mm) / Then 524288/6315
  ASSERT_EQ(festo.write(0x6091, 1, 4, 4), 0U);
  ASSERT_EQ(festo.write(0x6091, 2, 5, 4), 0U);
  ASSERT_EQ(festo.write(0x6092, 1, 6315, 4), 0U);
  ASSERT_EQ(festo.write(0x6092, 2, 10, 4), 0U);
  EXPECT_EQ(festo.read(0x6093, 1), 524288U);
  EXPECT_EQ(festo.read(0x6093, 2), 6315U);
  // Then the index pulse comes once per revolution: 65536 increments, 3600 under 4096/225
  ASSERT_EQ(festo.write(0x6093, 1, 1, 4), 0U);
  ASSERT_EQ(festo.write(0x6093, 2, 1, 4), 0U);
  festo.run(5ms);
  Cia402Application& app = festo.drive().application();
  EXPECT_EQ(app.axis().config().encoder_increments, 65536U);
  EXPECT_DOUBLE_EQ(AxisModelHomingAxis(app.axis(), app.factors()).index_period(), 65536.0);
  ASSERT_EQ(festo.write(0x6093, 1, 4096, 4), 0U);
  ASSERT_EQ(festo.write(0x6093, 2, 225, 4), 0U);
  festo.run(5ms);
  EXPECT_NEAR(AxisModelHomingAxis(app.axis(), app.factors()).index_period(), 3600.0, 1e-9);
  // When `simulate index-period` sets 1000 and then 0 / Then 0 is once per revolution again
  ASSERT_TRUE(festo.drive().simulate("index-period", 1000));
  EXPECT_EQ(app.axis().config().index_period, 1000U);
  ASSERT_TRUE(festo.drive().simulate("index-period", 0));
  EXPECT_NEAR(AxisModelHomingAxis(app.axis(), app.factors()).index_period(), 3600.0, 1e-9);
  EXPECT_FALSE(festo.drive().simulate("index-period", -1));
}

TEST(ServoDriveIrtsa, EncoderCountsSixtyFiveThousandFiveHundredThirtySixPerRevolution) {
  // Given the IRTSA drive (608Fh 00010000h increments per 1 motor revolution, L750-752) / When
  // 608Fh and the axis are read / Then 65536/1, and the axis counts the same (the index pulse)
  ServoRig irtsa("irtsa-drive-fb");
  ASSERT_TRUE(irtsa.ok());
  EXPECT_EQ(irtsa.read(0x608F, 1), 65536U);
  EXPECT_EQ(irtsa.read(0x608F, 2), 1U);
  EXPECT_EQ(irtsa.drive().application().axis().config().encoder_increments, 65536U);
}

TEST(ServoDriveFesto, CommissioningMakesUserUnitsIncrementsPerSecond) {
  // Given the Festo drive / When commissioned with 6094h = 15/4, 6097h = 15/64 / Then one
  // user unit is one increment/s (/s²) on the axis, as on the standard drive uncommissioned
  ServoRig festo("festo-cmmp");
  ASSERT_TRUE(festo.ok());
  commission_increments(festo);
  const FactorGroup& f = festo.drive().application().factors();
  EXPECT_NEAR(f.speed_to_internal(1000.0), 1000.0, 1e-9);
  EXPECT_NEAR(f.acceleration_to_internal(1000.0), 1000.0, 1e-9);
}

TEST(ServoDriveFesto, MotionProfileTypeSin2IsRefused) {
  // Given Festo (6086h value range 0, 2: L6393-6410) and the standard drive / When 6086h := 1
  // (sin²), 2 and 0 / Then Festo aborts 1 with 06090030h, both take 0 and 2
  ServoRig festo("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(festo.ok());
  ASSERT_TRUE(standard.ok());
  EXPECT_EQ(festo.write(0x6086, 0, 1, 2), kInvalidValue);
  EXPECT_EQ(standard.write(0x6086, 0, 1, 2), 0U);
  for (ServoRig* r : {&festo, &standard}) {
    EXPECT_EQ(r->write(0x6086, 0, 2, 2), 0U);
    EXPECT_EQ(r->write(0x6086, 0, 0, 2), 0U);
  }
}

TEST(ServoDriveFesto, InterpolationSubModeIsMinusTwoOnly) {
  // Given Festo (60C0h value range -2, default -2: L6478-6494) and the standard drive (0) /
  // When read, 0 and -2 written / Then each takes only its own value
  ServoRig festo("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(festo.ok());
  ASSERT_TRUE(standard.ok());
  EXPECT_EQ(festo.read(0x60C0), 0xFFFEU);  // INTEGER16 -2
  EXPECT_EQ(standard.read(0x60C0), 0U);
  EXPECT_EQ(festo.write(0x60C0, 0, 0, 2), kInvalidValue);
  EXPECT_EQ(festo.write(0x60C0, 0, 0xFFFE, 2), 0U);
  EXPECT_EQ(standard.write(0x60C0, 0, 0, 2), 0U);
  EXPECT_EQ(standard.write(0x60C0, 0, 0xFFFE, 2), kInvalidValue);
}

// pp at 1000 increments/s and 1000 increments/s²: A = 1000, then B = 3000 with controlword bit 9
// (change on set-point); the actual position 2.4 s after B was given.
std::int32_t position_after_set_of_set_points(ServoRig& rig) {
  EXPECT_EQ(rig.write(0x6060, 0, 1, 1), 0U);  // profile position
  for (const std::uint16_t index :
       {std::uint16_t{0x6081}, std::uint16_t{0x6083}, std::uint16_t{0x6084}})
    EXPECT_EQ(rig.write(index, 0, 1000, 4), 0U);
  rig.controlword(0x0006);  // shutdown
  rig.controlword(0x000F);  // switch on + enable operation
  EXPECT_EQ(rig.statusword() & 0x006F, 0x0027);
  EXPECT_EQ(rig.write(0x607A, 0, 1000, 4), 0U);  // A
  rig.controlword(0x001F);                       // new set-point
  rig.controlword(0x000F);
  EXPECT_EQ(rig.write(0x607A, 0, 3000, 4), 0U);  // B
  rig.controlword(0x021F);                       // new set-point + change on set-point
  rig.controlword(0x020F);
  rig.run(2400ms);
  return static_cast<std::int32_t>(rig.read(0x6064));
}

TEST(ServoDriveFesto, ChangeOnSetPointBitIsReserved) {
  // Given Festo (controlword bits 9..15 reserved: L5326-5424), commissioned to increments/s,
  // and the standard drive / When A then B with bit 9 / Then the standard drive passes A at
  // speed (near 1930 after 2.4 s), Festo stops at A first (near 1100)
  ServoRig festo("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(festo.ok());
  ASSERT_TRUE(standard.ok());
  commission_increments(festo);
  const std::int32_t at_festo = position_after_set_of_set_points(festo);
  const std::int32_t at_standard = position_after_set_of_set_points(standard);
  EXPECT_GE(at_standard, 1600);
  EXPECT_LE(at_standard, 2300);
  EXPECT_LT(at_festo, 1600);
  EXPECT_GT(at_festo, 900);
}

TEST(ServoDriveFesto, NmtBurstLosesTheSecondCommand) {
  // Given Festo (two NMT messages need 2 x 500 us between them, L1403-1405) and the standard
  // drive / When start and stop are sent back to back / Then Festo stays operational (stop
  // lost), the standard drive is stopped; with 2 ms between them both obey both
  ServoRig festo("festo-cmmp");
  ServoRig standard;
  ASSERT_TRUE(festo.ok());
  ASSERT_TRUE(standard.ok());
  for (ServoRig* r : {&festo, &standard}) {
    r->send(can::Frame::standard(0x000, std::array<std::uint8_t, 2>{0x01, 0x00}));  // start, all
    r->send(can::Frame::standard(0x000, std::array<std::uint8_t, 2>{0x02, 0x00}));  // stop, all
    r->run(10ms);
  }
  EXPECT_EQ(festo.drive().device().state(), cia301::NmtState::operational);
  EXPECT_EQ(standard.drive().device().state(), cia301::NmtState::stopped);
  for (ServoRig* r : {&festo, &standard}) {
    r->send(can::Frame::standard(0x000, std::array<std::uint8_t, 2>{0x80, 0x00}));  // pre-op
    r->run(2ms);
    r->send(can::Frame::standard(0x000, std::array<std::uint8_t, 2>{0x01, 0x00}));  // start
    r->run(10ms);
    EXPECT_EQ(r->drive().device().state(), cia301::NmtState::operational);
  }
}

TEST(ServoDriveKollmorgen, SwitchedOnHoldsTheMotorAgainstALoad) {
  // Given Kollmorgen (SWITCHED ON: power stage enabled, L3057-3061, L3099-3101) and the
  // standard drive, a load torque of 20 per mille / When in READY TO SWITCH ON and then SWITCHED
  // ON / Then both give no torque in READY TO SWITCH ON; in SWITCHED ON Kollmorgen holds the
  // load (torque, no motion), the standard drive gives no torque and the load moves the axis
  ServoRig kollmorgen("kollmorgen-s300-s700");
  ServoRig standard;
  ASSERT_TRUE(kollmorgen.ok());
  ASSERT_TRUE(standard.ok());
  for (ServoRig* r : {&kollmorgen, &standard}) {
    ASSERT_TRUE(r->drive().simulate("load-torque", 20));
    r->controlword(0x0006);  // shutdown
    EXPECT_EQ(r->statusword() & 0x006F, 0x0021);
    EXPECT_EQ(r->read(0x6077), 0U);  // torque actual value
    ASSERT_TRUE(r->drive().simulate("axis-position", 0));
    r->controlword(0x0007);  // switch on
    EXPECT_EQ(r->statusword() & 0x006F, 0x0023);
    r->run(50ms);
  }
  EXPECT_NE(kollmorgen.read(0x6077), 0U);
  EXPECT_LT(std::abs(kollmorgen.drive().application().axis().velocity()), 50.0);
  EXPECT_EQ(standard.read(0x6077), 0U);
  EXPECT_GT(std::abs(standard.drive().application().axis().velocity()), 100.0);
  for (ServoRig* r : {&kollmorgen, &standard})
    ASSERT_TRUE(r->drive().simulate("load-torque", 0));
}

TEST(ServoDriveKollmorgen, DisableOperationKeepsHoldingThePosition) {
  // Given Kollmorgen (transition 5: "Aktuelle Position wird gehalten", L3102-3107) and the
  // standard drive in OPERATION ENABLED, profile position, a load torque of 20 per mille /
  // When disable operation (SWITCHED ON) / Then Kollmorgen holds the load, the standard drive
  // gives no torque
  ServoRig kollmorgen("kollmorgen-s300-s700");
  ServoRig standard;
  ASSERT_TRUE(kollmorgen.ok());
  ASSERT_TRUE(standard.ok());
  for (ServoRig* r : {&kollmorgen, &standard}) {
    ASSERT_EQ(r->write(0x6060, 0, 1, 1), 0U);  // profile position: holds the position enabled
    r->controlword(0x0006);                    // shutdown
    r->controlword(0x000F);                    // switch on + enable operation
    EXPECT_EQ(r->statusword() & 0x006F, 0x0027);
    ASSERT_TRUE(r->drive().simulate("load-torque", 20));
    r->run(50ms);
    EXPECT_NE(r->read(0x6077), 0U);  // both hold the load while enabled
    r->controlword(0x0007);          // disable operation
    r->run(200ms);
    EXPECT_EQ(r->statusword() & 0x006F, 0x0023);
  }
  EXPECT_NE(kollmorgen.read(0x6077), 0U);
  EXPECT_EQ(standard.read(0x6077), 0U);
  for (ServoRig* r : {&kollmorgen, &standard})
    ASSERT_TRUE(r->drive().simulate("load-torque", 0));
}

}  // namespace
}  // namespace drivecheck::reference_drive
