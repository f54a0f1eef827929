// Store/restore group (CiA 301 §7.5.2.13-14, 1010h/1011h): capabilities, signatures, what each
// group saves, when restored values and defaults take effect (resets), a failing storage, and
// the parameter file of `drivecheck drive --store`. Scripted exchanges on the simulated bus,
// node 5.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "reference_drive/parameter_file.hpp"
#include "tests/reference_drive/drive_rig.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::reference_drive::testing {
namespace {

using Frames = std::vector<std::string>;

constexpr std::uint32_t kSave = 0x65766173;  // "save"
constexpr std::uint32_t kLoad = 0x64616F6C;  // "load"
constexpr std::uint32_t kCannotStore = 0x08000020;
constexpr std::uint32_t kHardwareError = 0x06060000;

constexpr std::uint8_t kStart = 0x01;
constexpr std::uint8_t kResetNode = 0x81;
constexpr std::uint8_t kResetCommunication = 0x82;

TEST(StoreRestore, SubIndicesReadTheCapabilities) {
  // Given the reference drive
  // When 1010h and 1011h are read
  // Then sub 00h = 4 and every group reads 00000001h (save on command / restore possible)
  DriveRig rig;
  EXPECT_EQ(rig.read(0x1010, 0).value, 4u);
  EXPECT_EQ(rig.read(0x1011, 0).value, 4u);
  for (std::uint8_t sub = 1; sub <= 4; ++sub) {
    EXPECT_EQ(rig.read(0x1010, sub).value, 1u) << "1010h sub " << int{sub};
    EXPECT_EQ(rig.read(0x1011, sub).value, 1u) << "1011h sub " << int{sub};
  }
  EXPECT_EQ(rig.read(0x1010, 5).abort, 0x06090011u);
}

TEST(StoreRestore, WrongSignatureAborts) {
  // Given the reference drive
  // When 1010h:01 gets "load", 1011h:01 gets "save", or either gets 0
  // Then each aborts 08000020h and nothing is stored
  DriveRig rig;
  EXPECT_EQ(rig.exchange("605#231010016C6F6164"),  // 1010h:01 = "load"
            Frames{sdo_abort_frame(5, 0x1010, 1, kCannotStore)});
  EXPECT_EQ(rig.write(0x1011, 1, kSave, 4), kCannotStore);
  EXPECT_EQ(rig.write(0x1010, 2, 0, 4), kCannotStore);
  EXPECT_EQ(rig.write(0x1011, 4, 0, 4), kCannotStore);
  EXPECT_EQ(rig.write(0x1010, 1, 0x7361, 2), 0x06070013u) << "2 bytes: too short";
  EXPECT_EQ(rig.storage().writes(), 0u);
}

TEST(StoreRestore, SaveCommandAnswersAndReadsCapabilitiesAgain) {
  // Given the reference drive
  // When "save" is written to 1010h:01 (all parameters)
  // Then the drive confirms, the storage holds the parameters, 1010h:01 reads 1 again
  DriveRig rig;
  EXPECT_EQ(rig.exchange("605#2310100173617665"),  // ccs=1 e=1 s=1 n=0, 1010h:01 = "save"
            Frames{"585#6010100100000000"});
  EXPECT_EQ(rig.storage().writes(), 1u);
  EXPECT_FALSE(rig.storage().stored().empty());
  EXPECT_EQ(rig.read(0x1010, 1).value, 1u);
}

TEST(StoreRestore, SavedCommunicationParametersSurviveResetNode) {
  // Given 1017h = 100 ms saved with 1010h:02 (communication), then 1017h set to 300
  // When the node is reset
  // Then 1017h is 100 again and heartbeats come every 100 ms
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1017, 0, 100, 2), 0u);
  ASSERT_EQ(rig.write(0x1010, 2, kSave, 4), 0u);
  ASSERT_EQ(rig.write(0x1017, 0, 300, 2), 0u);
  rig.take();
  EXPECT_EQ(rig.nmt(kResetNode).front(), "705#00") << "boot-up";
  EXPECT_EQ(rig.read(0x1017, 0).value, 100u);
  rig.take();
  const auto heartbeats = rig.run(1000ms);
  EXPECT_EQ(heartbeats.size(), 10u);
  EXPECT_EQ(heartbeats.front(), "705#7F") << "pre-operational";
}

TEST(StoreRestore, ResetCommunicationRestoresOnlyCommunicationParameters) {
  // Given 1017h = 50 and 2000h = 1234h saved (1010h:01), then both changed
  // When communication is reset, then the node
  // Then reset communication brings back 1017h only; reset node 2000h too
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1017, 0, 50, 2), 0u);
  ASSERT_EQ(rig.write(0x2000, 0, 0x1234, 2), 0u);
  ASSERT_EQ(rig.write(0x1010, 1, kSave, 4), 0u);
  ASSERT_EQ(rig.write(0x1017, 0, 0, 2), 0u);
  ASSERT_EQ(rig.write(0x2000, 0, 0x5678, 2), 0u);
  rig.nmt(kResetCommunication);
  EXPECT_EQ(rig.read(0x1017, 0).value, 50u);
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x5678u);
  rig.nmt(kResetNode);
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x1234u);
}

TEST(StoreRestore, EachGroupSavesOnlyItsParameters) {
  // Given 1017h and 2000h changed
  // When 1010h:03 (application) and 1010h:04 (manufacturer) are saved, then the node reset
  // Then 2000h (manufacturer, 2000h-5FFFh) survives, 1017h (communication) does not
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1017, 0, 70, 2), 0u);
  ASSERT_EQ(rig.write(0x2000, 0, 0x0042, 2), 0u);
  ASSERT_EQ(rig.write(0x1010, 3, kSave, 4), 0u);
  for (const auto& stored : rig.storage().stored()) {
    ADD_FAILURE() << fmt::format("application group stored {:04X}h:{}", stored.index,
                                 stored.sub_index);
  }
  ASSERT_EQ(rig.write(0x1010, 4, kSave, 4), 0u);
  for (const auto& stored : rig.storage().stored()) {
    EXPECT_TRUE(stored.index >= 0x2000 && stored.index <= 0x5FFF)
        << fmt::format("{:04X}h", stored.index);
  }
  rig.nmt(kResetNode);
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x42u);
  EXPECT_EQ(rig.read(0x1017, 0).value, 0u);
}

TEST(StoreRestore, SavedPdoConfigurationWorksAfterReset) {
  // Given TPDO1 mapped to 2002h, type 1, valid, saved (communication) with 2002h = 5 (all)
  // When the node is reset and started, and a SYNC comes
  // Then TPDO1 is sent with 05h
  DriveRig rig;
  ASSERT_EQ(rig.write(0x2002, 0, 5, 1), 0u);
  ASSERT_EQ(rig.write(0x1A00, 1, 0x20020008, 4), 0u);
  ASSERT_EQ(rig.write(0x1A00, 0, 1, 1), 0u);
  ASSERT_EQ(rig.write(0x1800, 2, 1, 1), 0u);
  ASSERT_EQ(rig.write(0x1800, 1, 0x185, 4), 0u);
  ASSERT_EQ(rig.write(0x1010, 1, kSave, 4), 0u);
  ASSERT_EQ(rig.write(0x1800, 1, 0x80000185, 4), 0u);
  rig.nmt(kResetNode);
  rig.nmt(kStart);
  EXPECT_EQ(rig.sync(), Frames{"185#05"});
}

TEST(StoreRestore, RestoreDefaultsTakesEffectAfterTheNextReset) {
  // Given 1017h = 100 saved
  // When "load" is written to 1011h:01, 1017h read, then the communication reset
  // Then 1017h stays 100 until the reset and is the default 0 after it
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1017, 0, 100, 2), 0u);
  ASSERT_EQ(rig.write(0x1010, 1, kSave, 4), 0u);
  EXPECT_EQ(rig.exchange("605#231110016C6F6164"),  // 1011h:01 = "load"
            Frames{"585#6011100100000000"});
  EXPECT_EQ(rig.read(0x1017, 0).value, 100u) << "not at once";
  EXPECT_EQ(rig.read(0x1011, 1).value, 1u);
  rig.nmt(kResetCommunication);
  EXPECT_EQ(rig.read(0x1017, 0).value, 0u);
  EXPECT_TRUE(rig.storage().stored().empty());
}

TEST(StoreRestore, VerifyConfigurationIsStoredAndRestored) {
  // Given 1020h = 15000 days / noon saved with 1010h:01, then changed
  // When the node is reset, then "load" is written to 1011h:01 and the node reset again
  // Then 1020h reads the saved date and time, and after the restore its defaults 0 / 0
  DriveRig rig;
  EXPECT_EQ(rig.read(0x1020, 0).value, 2u);
  ASSERT_EQ(rig.write(0x1020, 1, 15000, 4), 0u);
  ASSERT_EQ(rig.write(0x1020, 2, 43200000, 4), 0u);
  ASSERT_EQ(rig.write(0x1010, 1, kSave, 4), 0u);
  ASSERT_EQ(rig.write(0x1020, 1, 15001, 4), 0u);
  rig.nmt(kResetNode);
  EXPECT_EQ(rig.read(0x1020, 1).value, 15000u);
  EXPECT_EQ(rig.read(0x1020, 2).value, 43200000u);
  ASSERT_EQ(rig.write(0x1011, 1, kLoad, 4), 0u);
  rig.nmt(kResetNode);
  EXPECT_EQ(rig.read(0x1020, 1).value, 0u);
  EXPECT_EQ(rig.read(0x1020, 2).value, 0u);
}

TEST(StoreRestore, VerifyConfigurationNotSavedDeviationKeepsTheLastWrite) {
  // Given the deviation store-verify-configuration-not-saved, 1020h:01 = 15000 saved, then 15001
  // When the node is reset
  // Then 1020h:01 reads 15001: neither the store nor the reset touched it
  DriveConfig config;
  config.deviations.add(Deviation::store_verify_configuration_not_saved);
  DriveRig rig(5, config);
  ASSERT_EQ(rig.write(0x1020, 1, 15000, 4), 0u);
  ASSERT_EQ(rig.write(0x1010, 1, kSave, 4), 0u);
  ASSERT_EQ(rig.write(0x1020, 1, 15001, 4), 0u);
  rig.nmt(kResetNode);
  EXPECT_EQ(rig.read(0x1020, 1).value, 15001u);
}

TEST(StoreRestore, RestoreOfOneGroupKeepsTheOthers) {
  // Given 1017h and 2000h saved (all)
  // When 1011h:02 (communication defaults) is restored and the node reset
  // Then 1017h is back to 0, 2000h keeps its stored value
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1017, 0, 100, 2), 0u);
  ASSERT_EQ(rig.write(0x2000, 0, 0x77, 2), 0u);
  ASSERT_EQ(rig.write(0x1010, 1, kSave, 4), 0u);
  ASSERT_EQ(rig.write(0x1011, 2, kLoad, 4), 0u);
  rig.nmt(kResetNode);
  EXPECT_EQ(rig.read(0x1017, 0).value, 0u);
  EXPECT_EQ(rig.read(0x2000, 0).value, 0x77u);
}

TEST(StoreRestore, FailingStorageAbortsWithHardwareError) {
  // Given a storage that refuses writes
  // When "save" or "load" is written
  // Then the drive aborts 06060000h and keeps what was stored before
  DriveRig rig;
  ASSERT_EQ(rig.write(0x1017, 0, 100, 2), 0u);
  ASSERT_EQ(rig.write(0x1010, 2, kSave, 4), 0u);
  rig.storage().set_failing(true);
  ASSERT_EQ(rig.write(0x1017, 0, 200, 2), 0u);
  EXPECT_EQ(rig.write(0x1010, 2, kSave, 4), kHardwareError);
  EXPECT_EQ(rig.write(0x1011, 1, kLoad, 4), kHardwareError);
  EXPECT_FALSE(rig.drive().store().last_error().empty());
  rig.nmt(kResetNode);
  EXPECT_EQ(rig.read(0x1017, 0).value, 100u);
}

TEST(StoreRestore, StoredParametersApplyAtPowerOn) {
  // Given a storage that holds 1017h = 20 (from an earlier run)
  // When a drive is created on it and powered on
  // Then 1017h reads 20 and the first heartbeat follows the boot-up after 20 ms
  cia301::MemoryParameterStorage storage;
  ASSERT_TRUE(storage.write({{0x1017, 0, {20, 0}}}));
  DriveConfig config;
  config.storage = &storage;
  DriveRig rig(5, config);
  EXPECT_EQ(rig.read(0x1017, 0).value, 20u);
  EXPECT_EQ(rig.run(25ms).size(), 1u);
}

// ---------------------------------------------------------------------------------------------
// The parameter file

TEST(ParameterFile, RoundTrip) {
  // Given stored parameters with a 2-byte, a 4-byte and an empty value
  // When they are formatted and parsed back
  // Then the result equals the input and the text is the documented format
  const cia301::ObjectDictionary::StoredParameters parameters = {
      {0x1017, 0, {0xE8, 0x03}}, {0x1400, 1, {0x01, 0x02, 0x00, 0x80}}, {0x2006, 0, {}}};
  const std::string text = format_parameter_file(parameters);
  EXPECT_EQ(text,
            "# drivecheck stored parameters v1\n"
            "1017:00 E803\n"
            "1400:01 01020080\n"
            "2006:00 -\n");
  const auto parsed = parse_parameter_file(text, "p.txt");
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  EXPECT_EQ(*parsed, parameters);
}

TEST(ParameterFile, BadInputIsAFileLineError) {
  // Given parameter files with a defect each
  // When they are parsed
  // Then each fails with "file:line: message", never crashes
  const std::pair<const char*, const char*> cases[] = {
      {"", "p.txt: empty file"},
      {"[FileInfo]\n", "p.txt:1: not a drivecheck parameter file"},
      {"# drivecheck stored parameters v1\n1017:00 E8033\n", "p.txt:2: 1017:00: the value"},
      {"# drivecheck stored parameters v1\n# c\n\n1017-00 E803\n", "p.txt:4: '1017-00 E803'"},
      {"# drivecheck stored parameters v1\n1G17:00 E803\n", "p.txt:2: '1G17:00'"},
      {"# drivecheck stored parameters v1\n1017:00 ZZ\n", "p.txt:2: 1017:00: 'ZZ'"},
      {"# drivecheck stored parameters v1\n1017:00 01\n1017:00 02\n",
       "p.txt:3: 1017:00 is stored twice"},
      {"# drivecheck stored parameters v1\n1017:00\n", "p.txt:2: '1017:00'"},
  };
  for (const auto& [text, message] : cases) {
    const auto parsed = parse_parameter_file(text, "p.txt");
    ASSERT_FALSE(parsed) << text;
    EXPECT_EQ(parsed.error().to_string().rfind(message, 0), 0u)
        << parsed.error().to_string() << " -- expected to start with: " << message;
  }
}

TEST(ParameterFile, FileStorageWritesAtomicallyAndReadsBack) {
  // Given a file storage in an empty directory
  // When it is read, written, and read again
  // Then a missing file is "nothing stored", the write leaves only the file, and it reads back
  test_support::TempDir dir;
  const std::string path = (dir / "params.txt").string();
  FileParameterStorage storage(path);
  const auto empty = storage.read();
  ASSERT_TRUE(empty) << empty.error();
  EXPECT_TRUE(empty->empty());
  const cia301::ObjectDictionary::StoredParameters parameters = {{0x1017, 0, {0x64, 0x00}}};
  ASSERT_TRUE(storage.write(parameters));
  EXPECT_FALSE(std::ifstream(path + ".tmp").good()) << "temporary file left behind";
  const auto back = storage.read();
  ASSERT_TRUE(back) << back.error();
  EXPECT_EQ(*back, parameters);
}

TEST(ParameterFile, DriveWithAFileStoresAcrossInstances) {
  // Given a drive whose storage is a file, 1017h = 40 saved
  // When a second drive is created on the same file
  // Then its 1017h is 40 from power on
  test_support::TempDir dir;
  FileParameterStorage storage((dir / "node5.txt").string());
  {
    DriveConfig config;
    config.storage = &storage;
    DriveRig rig(5, config);
    ASSERT_EQ(rig.write(0x1017, 0, 40, 2), 0u);
    ASSERT_EQ(rig.write(0x1010, 1, 0x65766173, 4), 0u);
  }
  DriveConfig config;
  config.storage = &storage;
  DriveRig rig(5, config);
  EXPECT_EQ(rig.read(0x1017, 0).value, 40u);
}

TEST(ParameterFile, CorruptFileMakesCreateFail) {
  // Given a parameter file with a bad line
  // When a drive is created on it
  // Then create() fails with the file:line message
  test_support::TempDir dir;
  const std::string path = (dir / "bad.txt").string();
  std::ofstream(path) << "# drivecheck stored parameters v1\nnonsense\n";
  FileParameterStorage storage(path);
  can::SimBus bus;
  auto port = bus.attach("drive");
  DriveConfig config;
  config.storage = &storage;
  const auto drive = ReferenceDrive::create(*port, config);
  ASSERT_FALSE(drive);
  EXPECT_EQ(drive.error(),
            path + ":2: 'nonsense' is not 'IIII:SS BYTES' (index and sub-index in hex)");
}

}  // namespace
}  // namespace drivecheck::reference_drive::testing
