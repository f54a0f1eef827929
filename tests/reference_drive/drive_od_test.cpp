// Object dictionary group (as CiA's conformance tool groups it): the reference drive's CiA 301
// objects read over SDO (expedited, segmented, block), their access rules, and the EDS that is
// generated from the same dictionary: checked in, lint-clean, and describing exactly what the
// drive answers.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "protocol/cia306/eds.hpp"
#include "protocol/cia306/eds_lint.hpp"
#include "reference_drive/dictionary.hpp"
#include "reference_drive/servo_drive_eds.hpp"
#include "tests/reference_drive/drive_rig.hpp"

#ifndef DRIVECHECK_SOURCE_DIR
#error "DRIVECHECK_SOURCE_DIR must name the repository (tests/reference_drive/CMakeLists.txt)"
#endif

namespace drivecheck::reference_drive::testing {
namespace {

using Frames = std::vector<std::string>;

constexpr std::uint32_t kWriteReadOnly = 0x06010002;

std::string checked_in_eds() {
  std::ifstream in(DRIVECHECK_SOURCE_DIR "/reference_drive/reference_drive.eds", std::ios::binary);
  EXPECT_TRUE(in.good()) << "reference_drive/reference_drive.eds is missing";
  std::string text;
  char c = 0;
  while (in.get(c))
    text.push_back(c);
  return text;
}

TEST(ObjectDictionary, DeviceTypeAndIdentity) {
  // Given the reference drive with serial number 5
  // When 1000h, 1001h and 1018h are read
  // Then device type 00020192h (CiA 402 servo), error register 0, the identity as configured
  DriveConfig config;
  config.dictionary.identity.serial = 5;
  DriveRig rig(5, config);
  EXPECT_EQ(rig.exchange("605#4000100000000000"),  // ccs=2: upload 1000h:00
            Frames{"585#4300100092010200"});       // scs=2 n=0 e=1 s=1: 00020192h
  EXPECT_EQ(rig.read(0x1001, 0).value, 0u);
  EXPECT_EQ(rig.read(0x1018, 0).value, 4u);
  EXPECT_EQ(rig.read(0x1018, 1).value, 0u);
  EXPECT_EQ(rig.read(0x1018, 2).value, 0x402u);
  EXPECT_EQ(rig.read(0x1018, 3).value, 0x10000u);
  EXPECT_EQ(rig.read(0x1018, 4).value, 5u);
  EXPECT_EQ(rig.read(0x1018, 5).abort, 0x06090011u);
}

TEST(ObjectDictionary, SdoServerParameter) {
  // Given the reference drive at node 5
  // When 1200h is read and written
  // Then it names 605h/585h and refuses writes (06010002h)
  DriveRig rig;
  EXPECT_EQ(rig.read(0x1200, 0).value, 2u);
  EXPECT_EQ(rig.read(0x1200, 1).value, 0x605u);
  EXPECT_EQ(rig.read(0x1200, 2).value, 0x585u);
  EXPECT_EQ(rig.write(0x1200, 1, 0x606, 4), kWriteReadOnly);
}

TEST(ObjectDictionary, ReadOnlyObjectsRefuseWrites) {
  // Given the reference drive
  // When 1000h, 1001h, 1008h, 1018h:01 and 1400h:00 are written
  // Then each aborts 06010002h
  DriveRig rig;
  EXPECT_EQ(rig.exchange("605#2300100000000000"),  // 1000h:00 = 0
            Frames{sdo_abort_frame(5, 0x1000, 0, kWriteReadOnly)});
  EXPECT_EQ(rig.write(0x1001, 0, 1, 1), kWriteReadOnly);
  EXPECT_EQ(rig.write(0x1008, 0, 0x41, 1), kWriteReadOnly);
  EXPECT_EQ(rig.write(0x1018, 1, 1, 4), kWriteReadOnly);
  EXPECT_EQ(rig.write(0x1400, 0, 2, 1), kWriteReadOnly);
}

TEST(ObjectDictionary, DeviceNameIsASegmentedUpload) {
  // Given the reference drive
  // When 1008h is uploaded
  // Then the initiate answer announces the name's length (segmented), and the whole name comes
  DriveRig rig;
  const Identity identity;
  const std::size_t size = identity.device_name.size();
  ASSERT_GT(size, 4u) << "the name must need a segmented transfer";
  EXPECT_EQ(rig.exchange("605#4008100000000000"),                    // upload 1008h:00
            Frames{fmt::format("585#41081000{:02X}000000", size)});  // scs=2 e=0 s=1, size
  EXPECT_EQ(rig.exchange("605#6000000000000000"),                    // upload segment, t=0
            Frames{fmt::format(
                "585#00{:02X}{:02X}{:02X}{:02X}{:02X}{:02X}{:02X}", identity.device_name[0],
                identity.device_name[1], identity.device_name[2], identity.device_name[3],
                identity.device_name[4], identity.device_name[5], identity.device_name[6])});
  rig.send("605#8008100000000000");  // abort the transfer (code 0)
  rig.run(2ms);
  auto client = rig.client();
  for (const auto mode : {cia301::SdoTransferMode::segmented, cia301::SdoTransferMode::block}) {
    for (const auto& [index, text] :
         {std::pair{0x1008, identity.device_name}, std::pair{0x1009, identity.hardware_version},
          std::pair{0x100A, identity.software_version}}) {
      const auto bytes = client.upload({static_cast<std::uint16_t>(index), 0}, mode);
      ASSERT_TRUE(bytes) << bytes.error().message();
      EXPECT_EQ(std::string(bytes->begin(), bytes->end()), text);
      if (mode == cia301::SdoTransferMode::block) {
        EXPECT_EQ(client.last_transfer().kind(), cia301::SdoTransferKind::block);
      }
    }
  }
}

TEST(ObjectDictionary, EveryReadableEntryAnswersAnUpload) {
  // Given the reference drive
  // When every entry of its dictionary is uploaded
  // Then readable entries answer with their value; 1003h sub-indices beyond the (empty)
  //      history abort 08000024h; write-only entries abort 06010001h
  DriveRig rig;
  auto client = rig.client();
  for (const auto& object : rig.drive().dictionary().objects()) {
    for (const auto& entry : object.entries()) {
      const auto bytes = client.upload({object.index(), entry.sub_index()});
      const std::string where = fmt::format("{:04X}h:{}", object.index(), entry.sub_index());
      if (!cia301::is_readable(entry.access())) {
        ASSERT_FALSE(bytes) << where;
        EXPECT_EQ(cia301::server_abort_code(bytes.error()), 0x06010001u) << where;
      } else if (object.index() == 0x1003 && entry.sub_index() > 0) {
        ASSERT_FALSE(bytes) << where;
        EXPECT_EQ(cia301::server_abort_code(bytes.error()), 0x08000024u) << where;
      } else {
        ASSERT_TRUE(bytes) << where << ": " << bytes.error().message();
        EXPECT_EQ(*bytes, std::vector<std::uint8_t>(entry.bytes().begin(), entry.bytes().end()))
            << where;
      }
    }
  }
}

TEST(ObjectDictionary, ManyNodeIdsGiveNodeRelativeDefaults) {
  // Given drives at nodes 1 and 127
  // When their SDO, EMCY and PDO COB-IDs are read
  // Then each carries its own node-ID
  for (const std::uint8_t node : {1, 127}) {
    DriveRig rig(node);
    EXPECT_EQ(rig.read(0x1200, 1).value, 0x600u + node);
    EXPECT_EQ(rig.read(0x1014, 0).value, 0x80u + node);
    EXPECT_EQ(rig.read(0x1800, 1).value, 0x80000180u + node);
    EXPECT_EQ(rig.read(0x1403, 1).value, 0x80000500u + node);
  }
}

// ---------------------------------------------------------------------------------------------
// The EDS

TEST(ReferenceEds, CheckedInFileIsTheGeneratedOne) {
  // Given the standard servo drive's dictionary (CiA 301 part + CiA 402 application)
  // When its EDS is generated
  // Then it equals reference_drive/reference_drive.eds byte for byte
  const auto generated = servo_drive_eds_text();
  ASSERT_TRUE(generated) << generated.error();
  EXPECT_TRUE(*generated == checked_in_eds())
      << "reference_drive/reference_drive.eds is stale: regenerate it with\n"
         "  <build>/reference_drive/reference_drive_eds reference_drive/reference_drive.eds";
}

TEST(ReferenceEds, LintFindsNothing) {
  // Given the checked-in EDS
  // When `drivecheck eds lint` checks it (the linter library)
  // Then there is no error and no warning
  const std::string path = DRIVECHECK_SOURCE_DIR "/reference_drive/reference_drive.eds";
  const auto findings = cia306::lint_eds_file(path);
  ASSERT_TRUE(findings) << findings.error().to_string();
  for (const auto& finding : *findings)
    ADD_FAILURE() << finding.to_string();
}

TEST(ReferenceEds, ListsTheCia402Objects) {
  // Given the checked-in EDS, When its objects are listed, Then the CiA 402 objects the drive
  // has are there (controlword, statusword, modes, homing, position actual value)
  const auto eds = cia306::read_eds(checked_in_eds(), "reference_drive.eds");
  for (const std::uint16_t index : {0x6040, 0x6041, 0x6060, 0x6061, 0x6064, 0x6098, 0x6099}) {
    EXPECT_NE(eds.eds.find(index), nullptr) << fmt::format("{:04X}h missing from the EDS", index);
  }
}

TEST(ReferenceEds, DescribesWhatTheDriveAnswers) {
  // Given the EDS read back as an object dictionary for node 9
  // When it is compared with the standard servo drive's dictionary at node 9
  // Then both have the same objects, entries, types, access, mapping flags and values
  const auto eds = cia306::read_eds(checked_in_eds(), "reference_drive.eds");
  ASSERT_FALSE(eds.has_errors());
  const auto from_eds = cia306::to_object_dictionary(eds.eds, 9);
  ASSERT_TRUE(from_eds);
  const auto built = servo_drive_dictionary(9);
  ASSERT_TRUE(built) << built.error();
  ASSERT_EQ(from_eds->objects().size(), built->objects().size());
  for (const auto& object : built->objects()) {
    const auto* other = from_eds->find(object.index());
    ASSERT_NE(other, nullptr) << fmt::format("{:04X}h missing from the EDS", object.index());
    EXPECT_EQ(other->code(), object.code());
    ASSERT_EQ(other->entries().size(), object.entries().size());
    for (const auto& entry : object.entries()) {
      const auto* e = other->find(entry.sub_index());
      ASSERT_NE(e, nullptr);
      const std::string where = fmt::format("{:04X}h:{}", object.index(), entry.sub_index());
      EXPECT_EQ(e->type(), entry.type()) << where;
      EXPECT_EQ(e->access(), entry.access()) << where;
      EXPECT_EQ(e->pdo_mappable(), entry.pdo_mappable()) << where;
      EXPECT_TRUE(std::equal(e->bytes().begin(), e->bytes().end(), entry.bytes().begin(),
                             entry.bytes().end()))
          << where;
    }
  }
}

}  // namespace
}  // namespace drivecheck::reference_drive::testing
