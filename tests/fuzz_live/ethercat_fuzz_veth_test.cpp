// `drivecheck fuzz --bus ethercat:IF` for real: `drivecheck drive --bus ethercat:<b>` (the
// reference drive as an EtherCAT slave) on one end of a veth pair in a namespace the test creates
// (tests/ethercat/veth_pair.hpp; skipped with the reason when that is impossible), the fuzzer on
// the other end, in real time: the conformant drive shows nothing, the drive that ignores the
// mailbox counter is found, with pcap reproducers.
#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/ethercat/veth_pair.hpp"
#include "tests/support/child_process.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::fuzz_live {
namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

using test_support::spawn;
using test_support::wait_for;

std::string slurp(const fs::path& path) {
  return test_support::read_file(path);
}

class FuzzOnVeth : public ethercat::test::VethPair {
 protected:
  void SetUp() override {
    VethPair::SetUp();
    if (IsSkipped() || HasFatalFailure()) return;
    dir_ = fs::temp_directory_path() / fmt::format("dc-fuzz-veth-{}", ::getpid());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (drive_pid_ > 0) (void)wait_for(drive_pid_, 3s, SIGTERM);
    drive_pid_ = -1;
    VethPair::TearDown();
    if (!dir_.empty() && !HasFailure()) fs::remove_all(dir_);
  }

  // Serves the drive (with `deviation`, if any) on b, fuzzes it from a for 5 s; the summary.
  nlohmann::json fuzz(const std::string& deviation, int expected_exit) {
    std::vector<std::string> drive = {DRIVECHECK_BINARY, "drive",  "--bus",
                                      "ethercat:" + b_,  "--node", "1"};
    if (!deviation.empty()) {
      drive.push_back("--deviation");
      drive.push_back(deviation);
    }
    drive_pid_ = spawn(drive, dir_ / "drive.log");
    std::this_thread::sleep_for(200ms);  // the drive opens its end (the master retries anyway)
    const auto out = dir_ / "out";
    const auto fuzz_exit =
        wait_for(spawn({DRIVECHECK_BINARY, "fuzz", "--bus", "ethercat:" + a_, "--duration", "5s",
                        "--seed", "1", "--out", out.string()},
                       dir_ / "fuzz.log"),
                 60s);
    const auto drive_exit = wait_for(drive_pid_, 3s, SIGTERM);
    drive_pid_ = -1;
    EXPECT_EQ(fuzz_exit, std::optional<int>(expected_exit))
        << slurp(dir_ / "fuzz.log") << "\ndrive:\n"
        << slurp(dir_ / "drive.log");
    EXPECT_EQ(drive_exit, std::optional<int>(0)) << slurp(dir_ / "drive.log");
    std::ifstream in(out / "summary.json");
    return nlohmann::json::parse(in, nullptr, false);
  }

  fs::path dir_;
  pid_t drive_pid_ = -1;
};

TEST_F(FuzzOnVeth, ConformantDriveShowsNothing) {
  // Given `drivecheck drive --bus ethercat:<b>`, the conformant reference drive
  // When `drivecheck fuzz --bus ethercat:<a>` runs 5 s over the veth pair
  // Then exit 0, cases ran in PREOP, SAFEOP and OP, and no anomaly is listed
  const auto json = fuzz("", 0);
  ASSERT_FALSE(json.is_discarded());
  EXPECT_EQ(json["outcome"], "clean");
  EXPECT_GT(json["cases_run"].get<int>(), 20);
  EXPECT_EQ(json["device"]["al_states"].size(), 3U) << json.dump(2);
  EXPECT_TRUE(json["anomalies"].empty()) << json.dump(2);
}

TEST_F(FuzzOnVeth, MailboxCounterIgnoredIsFound) {
  // Given the drive that executes a repeated mailbox request again
  // When the fuzzer runs 5 s over the veth pair
  // Then exit 1 with mailbox-repeat-executed and its pcap and text reproducers (no minimisation
  //      on a link: the note says why)
  const auto json = fuzz("mailbox-counter-ignored", 1);
  ASSERT_FALSE(json.is_discarded());
  ASSERT_FALSE(json["anomalies"].empty());
  const auto& first = json["anomalies"][0];
  EXPECT_EQ(first["kind"], "mailbox-repeat-executed") << json.dump(2);
  EXPECT_TRUE(fs::exists(first["pcap"].get<std::string>()));
  EXPECT_TRUE(fs::exists(first["text"].get<std::string>()));
  EXPECT_EQ(first["minimised"], false);
  EXPECT_FALSE(first["note"].get<std::string>().empty());
}

}  // namespace
}  // namespace drivecheck::fuzz_live
