// The personality keys of the permitted choices (issue 17: reference_drive/personality.hpp,
// cia402, absent_objects, abort_codes, sdo_response_delay, pdo_mapping, empty_pdo_valid,
// tpdo_sync_phase, setpoint_buffer) and the two profiles that use them (cia301-minimal,
// cia402-alternative): each key against the standard drive, on the simulated bus. Every test
// shows the standard drive doing the other thing, so that it fails without the key.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/frame.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/servo_drive.hpp"
#include "tests/profile/servo_rig.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;

using testing::kNoAnswer;
using testing::kNode;
using testing::ServoRig;

constexpr std::uint32_t kNoObject = 0x06020000;
constexpr std::uint32_t kNoSubIndex = 0x06090011;
constexpr std::uint32_t kReadOnly = 0x06010002;
constexpr std::uint32_t kUnsupportedAccess = 0x06010000;
constexpr std::uint32_t kGeneralError = 0x08000000;
constexpr std::uint32_t kInvalidValue = 0x06090030;

// A drive profile with the standard drive's modes and the personality keys `keys` (YAML lines
// indented by two).
profile::DriveProfile profile_with(std::string_view keys) {
  std::string text =
      "name: test-drive\n"
      "title: \"a test drive\"\n"
      "features: [sdo.expedited, cia402]\n"
      "modes: [1, 3, 4, 6, 7, 8, 9, 10]\n"
      "homing_methods: [35, 37]\n"
      "personality:\n"
      "  hardware_enable: transition-3\n";
  text += keys;
  profile::ParseOptions options;
  options.file_name = "test-drive.yaml";
  auto parsed = profile::parse_profile(text, options);
  EXPECT_TRUE(parsed.has_value()) << (parsed ? "" : parsed.error().to_string());
  return parsed ? std::move(*parsed) : profile::DriveProfile{};
}

// The abort code of an expedited upload (0: it answered with data; kNoAnswer: nothing).
std::uint32_t read_abort(ServoRig& rig, std::uint16_t index, std::uint8_t sub = 0) {
  std::uint32_t abort = 0;
  const std::uint32_t value = rig.read(index, sub, &abort);
  return value != kNoAnswer ? 0U : (abort != 0 ? abort : kNoAnswer);
}

// The SDO response to `request` within `window` (nullopt: none).
std::optional<can::Frame> answer(ServoRig& rig, const can::Frame& request, can::Duration window) {
  rig.send(request);
  for (const can::Frame& f : rig.run(window)) {
    if (f.id == 0x580U + kNode) return f;
  }
  return std::nullopt;
}

can::Frame upload_request(std::uint16_t index, std::uint8_t sub) {
  return can::Frame::standard(0x600 + kNode,
                              {0x40, static_cast<std::uint8_t>(index & 0xFF),
                               static_cast<std::uint8_t>(index >> 8), sub, 0, 0, 0, 0});
}

TEST(ServoDriveChoices, Cia402FalseLeavesNoDeviceProfileObject) {
  // Given cia402: false / When 6041h, 6040h and 6502h are read / Then 06020000h (the standard
  // drive answers them)
  ServoRig standard;
  ServoRig plain(profile_with("  cia402: false\n"));
  ASSERT_TRUE(standard.ok() && plain.ok());
  for (std::uint16_t index : {0x6040, 0x6041, 0x6502}) {
    EXPECT_EQ(read_abort(standard, index), 0U) << std::hex << index;
    EXPECT_EQ(read_abort(plain, index), kNoObject) << std::hex << index;
  }
  EXPECT_EQ(read_abort(plain, 0x1000), 0U);  // the communication profile stays
}

TEST(ServoDriveChoices, AbsentObjectsAreGoneAndTheirServiceIsOff) {
  // Given absent_objects 1029h and 100Ch-100Dh / When read, and a guarding RTR sent / Then
  // 06020000h and no guarding answer (the standard drive has them and answers)
  ServoRig standard;
  ServoRig lean(profile_with("  absent_objects: [0x1029, [0x100C, 0x100D]]\n"));
  ASSERT_TRUE(standard.ok() && lean.ok());
  for (std::uint16_t index : {0x1029, 0x100C, 0x100D}) {
    EXPECT_EQ(read_abort(standard, index), 0U) << std::hex << index;
    EXPECT_EQ(read_abort(lean, index), kNoObject) << std::hex << index;
  }
  EXPECT_EQ(read_abort(lean, 0x1017), 0U);  // the others stay
  const auto guarding_answers = [](ServoRig& rig) {
    rig.send(can::Frame::remote(0x700 + kNode, 1));
    for (const can::Frame& f : rig.run(10ms)) {
      if (f.id == 0x700U + kNode && !f.is_remote()) return true;
    }
    return false;
  };
  EXPECT_TRUE(guarding_answers(standard));
  EXPECT_FALSE(guarding_answers(lean));
}

// Operational, 6007h = 0, life guarding 100 ms x 2 started by one RTR, then no RTR for 500 ms:
// the NMT state afterwards.
cia301::NmtState state_after_guarding_loss(ServoRig& rig) {
  EXPECT_EQ(rig.write(0x6007, 0, 0, 2), 0U);
  EXPECT_EQ(rig.write(0x100C, 0, 100, 2), 0U);
  EXPECT_EQ(rig.write(0x100D, 0, 2, 1), 0U);
  rig.send(can::Frame::standard(0x000, {0x01, kNode}));  // NMT start remote node
  rig.run(10ms);
  rig.send(can::Frame::remote(0x700 + kNode, 1));  // guarding request (RTR)
  rig.run(500ms);
  return rig.drive().device().state();
}

TEST(ServoDriveChoices, AbsentErrorBehaviourTakesTheDefaultOrTheGuardingLossKey) {
  // Given a drive without 1029h, and one without 1029h and with guarding_loss: no-nmt-change
  // When life guarding times out in Operational
  // Then the first goes Pre-operational (CiA 301 §7.5.2.32: the default without 1029h), the
  // second stays Operational (the reaction its manual documents, Kollmorgen)
  ServoRig plain(profile_with("  absent_objects: [0x1029]\n"));
  ServoRig kept(profile_with("  absent_objects: [0x1029]\n  guarding_loss: no-nmt-change\n"));
  ASSERT_TRUE(plain.ok() && kept.ok());
  EXPECT_EQ(read_abort(kept, 0x1029, 1), kNoObject);
  EXPECT_EQ(state_after_guarding_loss(plain), cia301::NmtState::pre_operational);
  EXPECT_EQ(state_after_guarding_loss(kept), cia301::NmtState::operational);
}

TEST(ServoDriveChoices, AbsentStoreRestoreResetsToDefaults) {
  // Given 1010h/1011h absent / When 1017h is written and the node reset / Then 1010h aborts
  // 06020000h and 1017h is back at its default (no store/restore: the defaults apply)
  ServoRig lean(profile_with("  absent_objects: [[0x1010, 0x1011]]\n"));
  ASSERT_TRUE(lean.ok());
  EXPECT_FALSE(lean.drive().device().has_store());
  EXPECT_EQ(read_abort(lean, 0x1010, 1), kNoObject);
  EXPECT_EQ(lean.write(0x1017, 0, 500, 2), 0U);
  lean.send(can::Frame::standard(0x000, {0x81, kNode}));  // reset node
  lean.run(50ms);
  EXPECT_EQ(lean.read(0x1017), 0U);
}

TEST(ServoDriveChoices, AbortCodesAreReplaced) {
  // Given abort_codes {06010002h: 06010000h, 06090011h: 08000000h} / When 1000h is written
  // and 1000h sub 1 read / Then the replacements (the standard drive: 06010002h, 06090011h)
  ServoRig standard;
  ServoRig other(profile_with(
      "  abort_codes: {write_read_only: 0x06010000, sub_index_does_not_exist: 0x08000000}\n"));
  ASSERT_TRUE(standard.ok() && other.ok());
  EXPECT_EQ(standard.write(0x1000, 0, 0, 4), kReadOnly);
  EXPECT_EQ(other.write(0x1000, 0, 0, 4), kUnsupportedAccess);
  EXPECT_EQ(read_abort(standard, 0x1000, 1), kNoSubIndex);
  EXPECT_EQ(read_abort(other, 0x1000, 1), kGeneralError);
  EXPECT_EQ(read_abort(other, 0x1FFF), kNoObject);  // codes not listed stay
}

TEST(ServoDriveChoices, SdoResponsesLeaveWithinTheirDelay) {
  // Given sdo_response_delay [20ms, 40ms] / When 1000h is read three times / Then no response
  // before 20 ms and each by 40 ms (the standard drive answers within 1 ms)
  ServoRig standard;
  ServoRig late(profile_with("  sdo_response_delay: [20ms, 40ms]\n"));
  ASSERT_TRUE(standard.ok() && late.ok());
  EXPECT_TRUE(answer(standard, upload_request(0x1000, 0), 1ms).has_value());
  for (int i = 0; i < 3; ++i) {
    EXPECT_FALSE(answer(late, upload_request(0x1000, 0), 19ms).has_value()) << i;
    const auto response = [&]() -> std::optional<can::Frame> {
      for (const can::Frame& f : late.run(22ms)) {
        if (f.id == 0x580U + kNode) return f;
      }
      return std::nullopt;
    }();
    ASSERT_TRUE(response.has_value()) << i;
    EXPECT_EQ(response->data[0], 0x43);  // expedited, 4 bytes
  }
}

TEST(ServoDriveChoices, StaticMappingRefusesEveryMappingWrite) {
  // Given pdo_mapping: static / When TPDO2 is made not valid and its mapping written per CiA
  // 301's procedure / Then 06010002h (the standard drive takes it)
  ServoRig standard;
  ServoRig fixed(profile_with("  pdo_mapping: static\n"));
  ASSERT_TRUE(standard.ok() && fixed.ok());
  for (ServoRig* rig : {&standard, &fixed}) {
    EXPECT_EQ(rig->write(0x1801, 1, 0x80000280U + kNode, 4), 0U);  // comm parameters writable
  }
  EXPECT_EQ(standard.write(0x1A01, 0, 0, 1), 0U);
  EXPECT_EQ(standard.write(0x1A01, 1, 0x10010008, 4), 0U);
  EXPECT_EQ(fixed.write(0x1A01, 0, 0, 1), kReadOnly);
  EXPECT_EQ(fixed.write(0x1A01, 1, 0x10010008, 4), kReadOnly);
  EXPECT_EQ(fixed.write(0x1601, 0, 0, 1), kReadOnly);
  EXPECT_EQ(read_abort(fixed, 0x1A01, 0), 0U);  // still readable
}

TEST(ServoDriveChoices, EmptyPdoMadeValidIsRefused) {
  // Given empty_pdo_valid: refuse / When TPDO2 (nothing mapped) is made valid / Then 06090030h
  // (the standard drive accepts it); with an object mapped it is accepted
  ServoRig standard;
  ServoRig strict(profile_with("  empty_pdo_valid: refuse\n"));
  ASSERT_TRUE(standard.ok() && strict.ok());
  for (ServoRig* rig : {&standard, &strict}) {
    ASSERT_EQ(rig->write(0x1801, 1, 0x80000280U + kNode, 4), 0U);
    ASSERT_EQ(rig->write(0x1A01, 0, 0, 1), 0U);
  }
  EXPECT_EQ(standard.write(0x1801, 1, 0x280U + kNode, 4), 0U);
  EXPECT_EQ(strict.write(0x1801, 1, 0x280U + kNode, 4), kInvalidValue);
  ASSERT_EQ(strict.write(0x1A01, 1, 0x10010008, 4), 0U);
  ASSERT_EQ(strict.write(0x1A01, 0, 1, 1), 0U);
  EXPECT_EQ(strict.write(0x1801, 1, 0x280U + kNode, 4), 0U);
}

// The SYNCs (1-based) after which TPDO1 (type 3, 1001h mapped) was sent, of `syncs` SYNCs.
std::vector<int> type3_transmissions(ServoRig& rig, int syncs) {
  EXPECT_EQ(rig.write(0x1800, 1, 0x80000180U + kNode, 4), 0U);
  EXPECT_EQ(rig.write(0x1A00, 0, 0, 1), 0U);
  EXPECT_EQ(rig.write(0x1A00, 1, 0x10010008, 4), 0U);
  EXPECT_EQ(rig.write(0x1A00, 0, 1, 1), 0U);
  EXPECT_EQ(rig.write(0x1800, 2, 3, 1), 0U);
  EXPECT_EQ(rig.write(0x1800, 1, 0x180U + kNode, 4), 0U);
  rig.send(can::Frame::standard(0x000, {0x01, kNode}));  // start
  rig.run(10ms);
  std::vector<int> sent;
  for (int i = 1; i <= syncs; ++i) {
    rig.send(can::Frame::standard(0x080, std::span<const std::uint8_t>{}));
    for (const can::Frame& f : rig.run(5ms)) {
      if (f.id == 0x180U + kNode) sent.push_back(i);
    }
  }
  return sent;
}

TEST(ServoDriveChoices, TpdoSyncPhaseStartsAtTheFirstSync) {
  // Given tpdo_sync_phase: first-sync / When a type 3 TPDO sees 7 SYNCs / Then it is sent at
  // SYNC 1, 4, 7 (the standard drive: 3, 6)
  ServoRig standard;
  ServoRig early(profile_with("  tpdo_sync_phase: first-sync\n"));
  ASSERT_TRUE(standard.ok() && early.ok());
  EXPECT_EQ(type3_transmissions(standard, 7), (std::vector<int>{3, 6}));
  EXPECT_EQ(type3_transmissions(early, 7), (std::vector<int>{1, 4, 7}));
}

// pp with a set of set-points: the first set-point runs, the second is buffered; whether
// set-point acknowledge (6041h bit 12) clears once bit 4 is 0 again.
bool acknowledge_clears_with_one_buffered(ServoRig& rig) {
  EXPECT_EQ(rig.write(0x6060, 0, 1, 1), 0U);
  EXPECT_EQ(rig.write(0x6081, 0, 1000, 4), 0U);  // slow: the first one keeps running
  EXPECT_EQ(rig.write(0x6083, 0, 10000, 4), 0U);
  EXPECT_EQ(rig.write(0x6084, 0, 10000, 4), 0U);
  rig.enable();
  EXPECT_EQ(rig.state(), cia402::State::operation_enabled);
  EXPECT_EQ(rig.write(0x607A, 0, 100000, 4), 0U);
  rig.controlword(0x001F);  // new set-point, bit 5 = 0: a set of set-points
  rig.controlword(0x000F);
  EXPECT_EQ(rig.statusword() & 0x1000, 0) << "the first set-point runs, the buffer is empty";
  EXPECT_EQ(rig.write(0x607A, 0, 200000, 4), 0U);
  rig.controlword(0x001F);
  EXPECT_NE(rig.statusword() & 0x1000, 0) << "the second is acknowledged";
  rig.controlword(0x000F);
  return (rig.statusword() & 0x1000) == 0;
}

TEST(ServoDriveChoices, SetpointBufferDeeperThanOne) {
  // Given setpoint_buffer: 4 / When one set-point runs and one is buffered / Then set-point
  // acknowledge clears (room for more); the standard drive's one-deep buffer keeps it set
  ServoRig standard;
  ServoRig deep(profile_with("  setpoint_buffer: 4\n"));
  ASSERT_TRUE(standard.ok() && deep.ok());
  EXPECT_FALSE(acknowledge_clears_with_one_buffered(standard));
  EXPECT_TRUE(acknowledge_clears_with_one_buffered(deep));
}

TEST(ServoDriveChoices, ShippedMinimalDevice) {
  // Given the shipped cia301-minimal profile / When its objects are read and written / Then
  // only CiA 301's mandatory objects, EMCY (1014h read-only), 1017h and one static TPDO
  ServoRig minimal("cia301-minimal");
  ASSERT_TRUE(minimal.ok());
  EXPECT_TRUE(minimal.drive().not_applied().empty());
  EXPECT_EQ(minimal.read(0x1000), 0U);  // no device profile
  EXPECT_EQ(minimal.read(0x1018, 0), 1U);
  EXPECT_EQ(read_abort(minimal, 0x1018, 2), kNoSubIndex);
  for (std::uint16_t index : {0x1003, 0x1005, 0x1008, 0x100C, 0x1010, 0x1015, 0x1016, 0x1029,
                              0x1200, 0x1400, 0x1600, 0x1801, 0x6041}) {
    EXPECT_EQ(read_abort(minimal, index), kNoObject) << std::hex << index;
  }
  EXPECT_EQ(minimal.write(0x1014, 0, 0x80000081U, 4), kReadOnly);
  EXPECT_EQ(minimal.write(0x1A00, 0, 0, 1), kReadOnly);
  EXPECT_EQ(minimal.read(0x1A00, 1), 0x10010008U);
  EXPECT_EQ(minimal.write(0x1017, 0, 100, 2), 0U);
}

TEST(ServoDriveChoices, ShippedAlternativeDrive) {
  // Given the shipped cia402-alternative profile / When its choices are exercised / Then the
  // alternative abort codes, late responses and static mapping
  ServoRig alternative("cia402-alternative");
  ASSERT_TRUE(alternative.ok());
  const auto abort_of = [&](const can::Frame& request) -> std::uint32_t {
    const auto f = answer(alternative, request, 45ms);
    if (!f) return kNoAnswer;
    return f->data[0] == 0x80 ? ServoRig::data32(*f) : 0U;
  };
  EXPECT_EQ(abort_of(can::Frame::standard(0x600 + kNode, {0x23, 0x00, 0x10, 0, 0, 0, 0, 0})),
            kUnsupportedAccess);  // write 1000h
  EXPECT_EQ(abort_of(upload_request(0x1000, 1)), kGeneralError);
  EXPECT_EQ(abort_of(upload_request(0x6074, 0)), kNoObject);
  EXPECT_EQ(abort_of(upload_request(0x1029, 0)), kNoObject);
  EXPECT_EQ(abort_of(upload_request(0x6041, 0)), 0U);
  EXPECT_EQ(abort_of(can::Frame::standard(0x600 + kNode, {0x2F, 0x00, 0x1A, 0, 0, 0, 0, 0})),
            kUnsupportedAccess);  // 1A00h sub 0 := 0: static
  EXPECT_FALSE(answer(alternative, upload_request(0x1000, 0), 15ms).has_value());
  alternative.run(40ms);
}

}  // namespace
}  // namespace drivecheck::reference_drive
