// `drivecheck eds lint|dump FILE`: output and exit codes (0 clean, 1 error findings,
// 2 unreadable file), run on the test files of tests/cia306/data.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tests/support/run_command.hpp"

namespace drivecheck {
namespace {

using test_support::CommandResult;

const std::string kData = DRIVECHECK_EDS_TEST_DATA;

CommandResult drivecheck(const std::vector<std::string>& args) {
  std::vector<std::string> argv;
  argv.reserve(args.size() + 1);
  argv.emplace_back(DRIVECHECK_EXE);
  for (const auto& arg : args)
    argv.push_back(arg);
  return test_support::run_command(argv);
}

TEST(CliEdsLint, CleanFileExitsZero) {
  // Given a well-formed EDS
  // When linted
  // Then only the summary is printed and the exit code is 0
  const auto result = drivecheck({"eds", "lint", kData + "/minimal.eds"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, kData + "/minimal.eds: 0 errors, 0 warnings\n");
}

TEST(CliEdsLint, WarningsAloneExitZero) {
  // Given an EDS whose only finding is a warning
  // When linted, with and without --no-warnings
  // Then the warning is printed (or not) and the exit code is 0 both times
  const std::string file = kData + "/octal_and_hex.eds";
  const auto result = drivecheck({"eds", "lint", file});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(result.out, file +
                            ":94: warning: DefaultValue '1A' read as hex [hex-without-prefix]\n" +
                            file + ": 0 errors, 1 warning\n");
  const auto quiet = drivecheck({"eds", "lint", "--no-warnings", file});
  EXPECT_EQ(quiet.exit_code, 0);
  EXPECT_EQ(quiet.out, file + ": 0 errors, 1 warning\n");
}

TEST(CliEdsLint, ErrorFindingsExitOne) {
  // Given an EDS with a SubNumber inconsistent with its sub-objects
  // When linted
  // Then the finding is printed with file:line and the exit code is 1
  const std::string file = kData + "/bad_subnumber.eds";
  const auto result = drivecheck({"eds", "lint", file});
  EXPECT_EQ(result.exit_code, 1) << result.err;
  EXPECT_EQ(result.out, file +
                            ":44: error: [1018] SubNumber=3 but 2 sub-object sections follow "
                            "[subnumber-mismatch]\n" +
                            file + ": 1 error, 0 warnings\n");
}

TEST(CliEdsLint, UnreadableFileExitsTwo) {
  // Given a missing file and a directory
  // When linted
  // Then one line on stderr names the file and the exit code is 2
  const auto missing = drivecheck({"eds", "lint", kData + "/absent.eds"});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_EQ(missing.err, kData + "/absent.eds: No such file or directory\n");
  EXPECT_TRUE(missing.out.empty());
  const auto directory = drivecheck({"eds", "dump", kData});
  EXPECT_EQ(directory.exit_code, 2);
  EXPECT_EQ(directory.err, kData + ": is a directory\n");
}

TEST(CliEdsDump, PrintsTheDictionaryAsATable) {
  // Given the DCF for node 5
  // When dumped
  // Then a header line, the column titles and one row per entry, with the DCF values
  const auto result = drivecheck({"eds", "dump", kData + "/device.dcf"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  const std::string expected =
      "Example Motion GmbH Minimal node (DCF), vendor 0x000001A2, product 0x00000001, revision "
      "0x00010000, node-ID 5\n"
      "Index  Sub  Name                         Object  Type        Access  PDO  Default       "
      "Value\n"
      "1000h  0    Device type                  VAR     UNSIGNED32  ro      no   0x00020192    "
      "0x00020192\n"
      "1001h  0    Error register               VAR     UNSIGNED8   ro      no   0             0\n"
      "1014h  0    COB-ID EMCY                  VAR     UNSIGNED32  rw      no   $NODEID+0x80  "
      "0x85\n"
      "1016h       Consumer heartbeat time      ARRAY\n"
      "1016h  0    NrOfObjects                  VAR     UNSIGNED8   ro      no   2\n"
      "1016h  1    Consumer heartbeat time1     VAR     UNSIGNED32  rw      no   0             "
      "0x000101F4\n"
      "1016h  2    Consumer heartbeat time2     VAR     UNSIGNED32  rw      no   0             "
      "0x007F03E8\n"
      "1017h  0    Producer heartbeat time      VAR     UNSIGNED16  rw      no   0             "
      "100\n"
      "1018h       Identity object              RECORD\n"
      "1018h  0    Highest sub-index supported  VAR     UNSIGNED8   ro      no   1             1\n"
      "1018h  1    Vendor-ID                    VAR     UNSIGNED32  ro      no   0x000001A2    "
      "0x000001A2\n";
  EXPECT_EQ(result.out, expected);
}

TEST(CliEdsDump, ReaderErrorsGoToStderrAndExitOne) {
  // Given an EDS with a duplicate section
  // When dumped
  // Then the table is printed, the error is on stderr and the exit code is 1
  const std::string file = kData + "/bad_duplicate_section.eds";
  const auto result = drivecheck({"eds", "dump", file});
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_EQ(result.err, file +
                            ":58: error: section [1001] repeats the one at line 29; the repeat is "
                            "ignored [duplicate-section]\n");
  EXPECT_NE(result.out.find("1001h  0    Error register"), std::string::npos) << result.out;
}

}  // namespace
}  // namespace drivecheck
