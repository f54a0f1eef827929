// drivecheck drive: the options and bad input paths that need no CAN interface (the drive
// serving vcan0 is tested in the VM, tests/vm/drive_vm_test.cpp).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck {
namespace {

using test_support::CommandResult;

CommandResult drivecheck(const std::vector<std::string>& args) {
  std::vector<std::string> argv;
  argv.reserve(args.size() + 1);
  argv.emplace_back(DRIVECHECK_EXE);
  argv.insert(argv.end(), args.begin(), args.end());
  return test_support::run_command(argv);
}

TEST(DriveCommand, UnknownPersonalityIsAUsageError) {
  // Given a personality name that is no profile in vectors/drives
  // When drivecheck drive starts
  // Then it exits 2 naming the known profiles, before opening any bus
  const auto result =
      drivecheck({"drive", "--bus", "socketcan:vcan0", "--node", "5", "--profile", "festo-cmmpx"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("no profile 'festo-cmmpx'"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("festo-cmmp,"), std::string::npos) << result.err;
}

TEST(DriveCommand, UnknownDeviationIsAUsageError) {
  // Given a deviation name the drive does not have
  // When drivecheck drive starts
  // Then it exits 2 saying so, before opening any bus
  const auto result = drivecheck(
      {"drive", "--bus", "socketcan:vcan0", "--node", "5", "--deviation", "no-such-deviation"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("unknown deviation 'no-such-deviation'"), std::string::npos)
      << result.err;
}

TEST(DriveCommand, KnownPersonalityAndDeviationAreAccepted) {
  // Given a known personality and a known deviation
  // When drivecheck drive starts on an interface this machine cannot open
  // Then both are accepted: the only complaint is the interface (exit 2)
  const auto result = drivecheck({"drive", "--bus", "socketcan:vcan0", "--node", "5", "--profile",
                                  "kollmorgen-s300-s700", "--deviation", "bootup-missing"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_EQ(result.err.find("--profile"), std::string::npos) << result.err;
  EXPECT_EQ(result.err.find("--deviation"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("vcan0"), std::string::npos) << result.err;
}

TEST(DriveCommand, SimulatedBusIsAUsageError) {
  // Given drivecheck drive
  // When --bus sim is given
  // Then it exits 2: the drive serves a real bus
  const auto result = drivecheck({"drive", "--bus", "sim", "--node", "5"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("socketcan:IF"), std::string::npos) << result.err;
}

TEST(DriveCommand, CorruptParameterFileIsReportedWithItsLine) {
  // Given a --store file whose second line is not an entry
  // When drivecheck drive starts
  // Then it exits 2 with "file:2: ..." before opening the bus
  test_support::TempDir dir;
  const auto file = dir.write("params.txt", "# drivecheck stored parameters v1\n1017:00 XYZ\n");
  const auto result =
      drivecheck({"drive", "--bus", "socketcan:vcan0", "--node", "5", "--store", file.string()});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_EQ(result.err.rfind(file.string() + ":2: ", 0), 0u) << result.err;
}

TEST(DriveCommand, ReferenceEdsPassesEdsLint) {
  // Given the reference drive's checked-in EDS
  // When `drivecheck eds lint` checks it
  // Then it exits 0 with no error and no warning
  const auto result =
      drivecheck({"eds", "lint", DRIVECHECK_SOURCE_DIR "/reference_drive/reference_drive.eds"});
  EXPECT_EQ(result.exit_code, 0) << result.out << result.err;
  EXPECT_NE(result.out.find("0 errors, 0 warnings"), std::string::npos) << result.out;
}

TEST(DriveCommand, MissingInterfaceIsAUsageError) {
  // Given no interface named nosuchcan9 (or no CAN in the kernel at all)
  // When drivecheck drive is started on it
  // Then it exits 2 with a message naming the interface
  const auto result = drivecheck({"drive", "--bus", "socketcan:nosuchcan9", "--node", "5"});
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("nosuchcan9"), std::string::npos) << result.err;
}

}  // namespace
}  // namespace drivecheck
