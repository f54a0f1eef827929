// `drivecheck fuzz --bus sim` end to end: the reference drive with each fatal deviation of
// reference_drive/deviations.inc must be reported with a minimised reproducer that replays to
// the same anomaly; the standard drive must show nothing.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/fuzz_live/fuzz_cli.hpp"

namespace {

using drivecheck::fuzz_cli::CommandRun;
using drivecheck::fuzz_cli::drivecheck;
using drivecheck::fuzz_cli::summary;

std::filesystem::path fresh_dir(const std::string& name) {
  return drivecheck::fuzz_cli::fresh_dir("fuzz_cli_", name);
}

// Fuzzes the drive with `deviation` and checks the report, the reproducer and its replay.
void expect_found(const std::string& deviation, const std::string& kind) {
  const auto dir = fresh_dir(deviation);
  const auto out = dir / "out";
  const std::string drive = fmt::format("--bus sim --node 1 --deviation {}", deviation);
  const CommandRun run =
      drivecheck(fmt::format("fuzz {} --duration 60s --seed 1 --out {}", drive, out.string()), dir);
  ASSERT_EQ(run.exit_code, 1) << run.output;
  const auto json = summary(out);
  ASSERT_FALSE(json.is_discarded()) << run.output;
  EXPECT_EQ(json["outcome"], "anomalies");
  const nlohmann::json* found = nullptr;
  for (const auto& anomaly : json["anomalies"]) {
    if (anomaly["kind"] == kind && anomaly["minimised"] == true) {
      found = &anomaly;
      break;
    }
  }
  ASSERT_NE(found, nullptr) << "no minimised " << kind << " anomaly\n" << json.dump(2);
  const int frames = (*found)["minimised_frames"];
  EXPECT_GE(frames, 1);
  EXPECT_LE(frames, 5) << json.dump(2);
  const std::string reproducer = (*found)["reproducer"];
  ASSERT_TRUE(std::filesystem::exists(reproducer)) << reproducer;

  // The reproducer replays to the same anomaly on a fresh drive with the deviation...
  const CommandRun replay = drivecheck(fmt::format("fuzz --replay {} {}", reproducer, drive), dir);
  EXPECT_EQ(replay.exit_code, 1) << replay.output;
  EXPECT_NE(replay.output.find(kind), std::string::npos) << replay.output;
  // ...and to nothing on the conformant drive.
  const CommandRun clean =
      drivecheck(fmt::format("fuzz --replay {} --bus sim --node 1", reproducer), dir);
  EXPECT_EQ(clean.exit_code, 0) << clean.output;
}

TEST(FuzzCommandSim, FindsTheCrashOnAnInvalidCommand) {
  // Given the reference drive that crashes on SDO command specifier 7
  // When drivecheck fuzz runs 60 s of simulated time
  // Then device-silent is reported with a minimised reproducer that replays
  expect_found("fatal-crash-on-invalid-command", "device-silent");
}

TEST(FuzzCommandSim, FindsTheSdoHangOnAMissingSubIndex) {
  // Given the reference drive whose SDO server hangs on a missing sub-index
  // When drivecheck fuzz runs
  // Then sdo-no-answer is reported with a minimised reproducer that replays
  expect_found("fatal-sdo-hang-on-missing-sub", "sdo-no-answer");
}

TEST(FuzzCommandSim, FindsTheBabbleOnAnUnknownNmtCommand) {
  // Given the reference drive that floods the bus after an unknown NMT command
  // When drivecheck fuzz runs
  // Then babbling is reported with a minimised reproducer that replays
  expect_found("fatal-babble-on-unknown-nmt", "babbling");
}

TEST(FuzzCommandSim, StandardDriveShowsNothing) {
  // Given the conformant reference drive
  // When drivecheck fuzz runs 60 s of simulated time
  // Then exit 0, cases ran, and the summary lists no anomaly
  const auto dir = fresh_dir("standard");
  const auto out = dir / "out";
  const CommandRun run = drivecheck(
      fmt::format("fuzz --bus sim --node 1 --duration 60s --seed 1 --out {}", out.string()), dir);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  const auto json = summary(out);
  ASSERT_FALSE(json.is_discarded()) << run.output;
  EXPECT_EQ(json["outcome"], "clean");
  EXPECT_GT(json["cases_run"].get<int>(), 100);
  EXPECT_TRUE(json["anomalies"].empty()) << json.dump(2);
}

TEST(FuzzCommandSim, InterruptedRunExits130WithASummary) {
  // Given a run of 1000 h of simulated time
  // When it gets SIGINT after a second
  // Then it exits 130 and its summary says interrupted, with the cases run so far
  const auto dir = fresh_dir("interrupt");
  const auto out = dir / "out";
  const CommandRun run = drivecheck(
      fmt::format("--version > /dev/null && exec timeout --preserve-status -s INT 1 {} fuzz "
                  "--bus sim --node 1 --duration 1000h --out {}",
                  DRIVECHECK_EXE, out.string()),
      dir);
  EXPECT_EQ(run.exit_code, 130) << run.output;
  const auto json = summary(out);
  ASSERT_FALSE(json.is_discarded()) << run.output;
  EXPECT_EQ(json["outcome"], "interrupted");
  EXPECT_GT(json["cases_run"].get<int>(), 0);
}

TEST(FuzzCommandSim, BadOptionsAreUsageErrors) {
  // Given a deviation on a real bus, and an unknown deviation
  // When drivecheck fuzz is called
  // Then exit 2 before anything runs
  const auto dir = fresh_dir("usage");
  EXPECT_EQ(
      drivecheck("fuzz --bus socketcan:vcan0 --node 1 --deviation fatal-babble-on-unknown-nmt", dir)
          .exit_code,
      2);
  EXPECT_EQ(drivecheck("fuzz --bus sim --node 1 --deviation no-such-deviation", dir).exit_code, 2);
}

}  // namespace
