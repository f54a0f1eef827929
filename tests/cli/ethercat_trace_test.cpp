// `drivecheck run --bus ethercat:sim --pcap` and `drivecheck decode` of EtherCAT pcaps: the
// capture of a run, decoded; a cut capture decoded up to the cut; pcapng refused with a hint;
// --trace refused on EtherCAT; the same run gives the same capture.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck {
namespace {

using test_support::CommandResult;

CommandResult drivecheck(const std::vector<std::string>& args,
                         const std::filesystem::path& cwd = {}) {
  std::vector<std::string> command{DRIVECHECK_EXE};
  command.insert(command.end(), args.begin(), args.end());
  if (!cwd.empty()) {
    // Reports of `run` go to the working directory's reports/out unless given: give them.
    command.push_back("--json");
    command.push_back((cwd / "report.json").string());
  }
  return test_support::run_command(command);
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream content;
  content << in.rdbuf();
  return std::move(content).str();
}

CommandResult run_with_pcap(const test_support::TempDir& dir, const std::string& name) {
  return drivecheck({"run", "--bus", "ethercat:sim", "--filter", "cia301/od/mandatory/device-type",
                     "--pcap", (dir / name).string()},
                    dir.path());
}

TEST(CliEthercatTrace, RunWritesAPcapThatDecodeReads) {
  // Given a run of one CoE vector on ethercat:sim with --pcap
  // When the capture is decoded
  // Then every frame is read, none malformed, out and returned frames alternate, and the
  // mailbox lines show the SDO upload of 1000h:00 and its response
  test_support::TempDir dir;
  const auto run = run_with_pcap(dir, "run.pcap");
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const auto decoded = drivecheck({"decode", (dir / "run.pcap").string()});
  ASSERT_EQ(decoded.exit_code, 0) << decoded.err;
  EXPECT_NE(decoded.err.find(", 0 malformed"), std::string::npos) << decoded.err;
  EXPECT_NE(decoded.out.find("  out  "), std::string::npos);
  EXPECT_NE(decoded.out.find("  ret  "), std::string::npos);
  EXPECT_NE(decoded.out.find("SM0 write mailbox len 128 wkc 1: CoE len 10"), std::string::npos);
  EXPECT_NE(decoded.out.find("SDO upload initiate 1000h:00"), std::string::npos);
  EXPECT_NE(decoded.out.find("SM1 read mailbox len 128 wkc 1: CoE"), std::string::npos);
  EXPECT_NE(decoded.out.find("SDO upload response 1000h:00 expedited 4 octets data 92 01 02 00"),
            std::string::npos);
}

TEST(CliEthercatTrace, TheSameRunGivesTheSameCapture) {
  // Given two runs of the same vector on the simulated segment
  // When their captures are compared
  // Then they are byte for byte the same (simulated time, no wall clock in the file)
  test_support::TempDir dir;
  ASSERT_EQ(run_with_pcap(dir, "a.pcap").exit_code, 0);
  ASSERT_EQ(run_with_pcap(dir, "b.pcap").exit_code, 0);
  const std::string a = read_file(dir / "a.pcap");
  EXPECT_GT(a.size(), 24U * 10);
  EXPECT_EQ(a, read_file(dir / "b.pcap"));
}

TEST(CliEthercatTrace, ACutCaptureIsDecodedUpToTheCut) {
  // Given the capture of a run with its last 10 bytes cut off (a writer killed mid-record)
  // When decoded
  // Then the records before the cut are decoded (exit 0) and stderr says where it stopped
  test_support::TempDir dir;
  ASSERT_EQ(run_with_pcap(dir, "run.pcap").exit_code, 0);
  std::string bytes = read_file(dir / "run.pcap");
  bytes.resize(bytes.size() - 10);
  const auto cut = dir.write("cut.pcap", bytes);
  const auto decoded = drivecheck({"decode", cut.string()});
  EXPECT_EQ(decoded.exit_code, 0) << decoded.err;
  EXPECT_FALSE(decoded.out.empty());
  EXPECT_NE(decoded.err.find("stopped: pcap: byte "), std::string::npos) << decoded.err;
}

TEST(CliEthercatTrace, PcapngAndTraceAreRefusedWithAHint) {
  // Given a pcapng file, and a run on ethercat:sim asking for a candump --trace
  // When decoded / run
  // Then each is a usage error (exit 2) that says what to do instead
  test_support::TempDir dir;
  const auto pcapng = dir.write(
      "capture.pcapng", std::string("\x0A\x0D\x0D\x0A\x1C\x00\x00\x00\x4D\x3C\x2B\x1A", 12));
  const auto decoded = drivecheck({"decode", pcapng.string()});
  EXPECT_EQ(decoded.exit_code, 2);
  EXPECT_NE(decoded.err.find("editcap -F pcap"), std::string::npos) << decoded.err;
  const auto run = drivecheck(
      {"run", "--bus", "ethercat:sim", "--trace", (dir / "run.log").string()}, dir.path());
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_TRUE(run.out.empty()) << run.out;
  EXPECT_NE(run.err.find("--pcap"), std::string::npos) << run.err;
}

TEST(CliEthercatTrace, ACanPcapIsDecodedAsTheCanopenTranscript) {
  // Given the pcap of a CAN run (--bus sim) of one SDO vector
  // When decoded
  // Then it is read as SocketCAN frames and each line is the CANopen dissector's
  test_support::TempDir dir;
  const auto run = drivecheck(
      {"run", "--filter", "cia301/od/mandatory/device-type", "--pcap", (dir / "can.pcap").string()},
      dir.path());
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const auto decoded = drivecheck({"decode", (dir / "can.pcap").string()});
  ASSERT_EQ(decoded.exit_code, 0) << decoded.err;
  EXPECT_NE(decoded.out.find("  pcap  "), std::string::npos) << decoded.out;
  EXPECT_NE(decoded.out.find("initiate upload 1000:00"), std::string::npos) << decoded.out;
}

}  // namespace
}  // namespace drivecheck
