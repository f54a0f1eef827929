// `drivecheck fuzz --bus ethercat:sim` end to end: the reference drive as an emulated EtherCAT
// slave with an EtherCAT named deviation must be reported (with a minimised pcap reproducer);
// the conformant drive must show nothing in 60 s of simulated time.
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
  return drivecheck::fuzz_cli::fresh_dir("fuzz_ecat_cli_", name);
}

std::string read(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Fuzzes the EtherCAT drive with `deviation` for 10 s of simulated time; returns the minimised
// anomaly of `kind` from the summary (checked: exit 1, pcap files written).
nlohmann::json expect_found(const std::string& deviation, const std::string& kind) {
  const auto dir = fresh_dir(deviation);
  const auto out = dir / "out";
  const CommandRun run = drivecheck(
      fmt::format("fuzz --bus ethercat:sim --deviation {} --duration 10s --seed 1 --out {}",
                  deviation, out.string()),
      dir);
  EXPECT_EQ(run.exit_code, 1) << run.output;
  const auto json = summary(out);
  if (json.is_discarded()) {
    ADD_FAILURE() << run.output;
    return {};
  }
  EXPECT_EQ(json["transport"], "ethercat");
  EXPECT_EQ(json["outcome"], "anomalies");
  for (const auto& anomaly : json["anomalies"]) {
    if (anomaly["kind"] != kind || anomaly["minimised"] != true) continue;
    const std::string pcap = anomaly["pcap"];
    const std::string reproducer = anomaly["reproducer"];
    EXPECT_TRUE(std::filesystem::exists(pcap)) << pcap;
    EXPECT_TRUE(std::filesystem::exists(reproducer)) << reproducer;
    // A pcap of Ethernet frames: magic A1B23C4Dh (ns), LINKTYPE_ETHERNET.
    const std::string bytes = read(reproducer);
    EXPECT_GT(bytes.size(), 24U + 16U);
    EXPECT_EQ(bytes.substr(0, 4), std::string("\x4D\x3C\xB2\xA1", 4));
    EXPECT_EQ(static_cast<unsigned char>(bytes[20]), 1);
    return anomaly;
  }
  ADD_FAILURE() << "no minimised " << kind << " anomaly\n" << json.dump(2);
  return {};
}

TEST(FuzzCommandEthercat, FindsARepeatedMailboxRequestExecutedAgain) {
  // Given the EtherCAT reference drive that ignores the mailbox counter
  // When drivecheck fuzz runs 10 s of simulated time
  // Then mailbox-repeat-executed is reported, minimised to the request and its repeat
  const auto anomaly = expect_found("mailbox-counter-ignored", "mailbox-repeat-executed");
  ASSERT_FALSE(anomaly.is_null());
  const auto& steps = anomaly["minimised_steps"];
  ASSERT_EQ(steps.size(), 2U) << anomaly.dump(2);
  EXPECT_EQ(steps[0].get<std::string>().rfind("Cnt next", 0), 0U) << steps[0];
  EXPECT_EQ(steps[1].get<std::string>().rfind("Cnt repeat", 0), 0U) << steps[1];

  // The text reproducer replays to the same anomaly on a fresh drive with the deviation, and to
  // nothing on the conformant drive.
  const std::string text = anomaly["reproducer_text"];
  const auto dir = fresh_dir("replay");
  const CommandRun again = drivecheck(
      fmt::format("fuzz --bus ethercat:sim --deviation mailbox-counter-ignored --replay {}", text),
      dir);
  EXPECT_EQ(again.exit_code, 1) << again.output;
  EXPECT_NE(again.output.find("reproduces"), std::string::npos) << again.output;
  const CommandRun clean =
      drivecheck(fmt::format("fuzz --bus ethercat:sim --replay {}", text), dir);
  EXPECT_EQ(clean.exit_code, 0) << clean.output;
}

TEST(FuzzCommandEthercat, ReplayRefusesGuardedWritesAndBadLines) {
  // Given a reproducer that writes 1010h:01 (store parameters), and one with a line that is no
  // step
  // When drivecheck fuzz --replay reads them
  // Then exit 2 naming the step, and file:line
  const auto dir = fresh_dir("replay-guard");
  const auto store = dir / "store.txt";
  std::ofstream(store) << "# case 1 (coe-download) in PREOP, seed 1, on ethercat:sim\n"
                          "Cnt next Type 3 Length 10 Channel 0 Priority 0: x | "
                          "00 20 23 10 10 01 73 61 76 65\n";
  const CommandRun guarded =
      drivecheck(fmt::format("fuzz --bus ethercat:sim --replay {}", store.string()), dir);
  EXPECT_EQ(guarded.exit_code, 2) << guarded.output;
  EXPECT_NE(guarded.output.find("step 1 is not sent"), std::string::npos) << guarded.output;
  const auto bad = dir / "bad.txt";
  std::ofstream(bad) << "# case 1 (coe-upload) in OP\nnot a step\n";
  const CommandRun malformed =
      drivecheck(fmt::format("fuzz --bus ethercat:sim --replay {}", bad.string()), dir);
  EXPECT_EQ(malformed.exit_code, 2) << malformed.output;
  EXPECT_NE(malformed.output.find("bad.txt:2:"), std::string::npos) << malformed.output;
}

TEST(FuzzCommandEthercat, FindsAWrongWorkingCounter) {
  // Given the EtherCAT reference drive whose LRW working counter is wrong
  // When drivecheck fuzz runs
  // Then working-counter is reported (the cycle of SAFEOP/OP shows it without any step)
  const auto anomaly = expect_found("wrong-working-counter", "working-counter");
  ASSERT_FALSE(anomaly.is_null());
  EXPECT_NE(anomaly["detail"].get<std::string>().find("working counter 0, expected 3"),
            std::string::npos)
      << anomaly.dump(2);
}

TEST(FuzzCommandEthercat, ConformantDriveShowsNothingIn60Seconds) {
  // Given the conformant reference drive as an EtherCAT slave
  // When drivecheck fuzz runs 60 s of simulated time
  // Then exit 0, cases of every kind ran in PREOP, SAFEOP and OP, and no anomaly is listed
  const auto dir = fresh_dir("conformant");
  const auto out = dir / "out";
  const CommandRun run = drivecheck(
      fmt::format("fuzz --bus ethercat:sim --duration 60s --seed 1 --out {}", out.string()), dir);
  EXPECT_EQ(run.exit_code, 0) << run.output;
  const auto json = summary(out);
  ASSERT_FALSE(json.is_discarded()) << run.output;
  EXPECT_EQ(json["outcome"], "clean");
  EXPECT_GT(json["cases_run"].get<int>(), 500);
  EXPECT_EQ(json["cases_by_kind"].size(), 7U) << json.dump(2);
  EXPECT_EQ(json["cases_by_state"].size(), 3U) << json.dump(2);
  EXPECT_GT(json["mailbox_error_replies"].get<int>(), 0);  // the malformed cases reached it
  // --duration bounds the run; only an SDO exchange already started may end after it.
  EXPECT_LE(json["elapsed_s"].get<double>(), 60.01);
  EXPECT_TRUE(json["anomalies"].empty()) << json.dump(2);
}

TEST(FuzzCommandEthercat, SameSeedSameRun) {
  // Given the drive with a deviation, fuzzed twice with the same seed
  // When both runs end
  // Then both summaries list the same anomalies at the same cases
  const auto dir = fresh_dir("determinism");
  std::string cases[2];
  for (int i = 0; i < 2; ++i) {
    const auto out = dir / fmt::format("out{}", i);
    (void)drivecheck(fmt::format("fuzz --bus ethercat:sim --deviation mailbox-counter-ignored "
                                 "--duration 5s --seed 4 --no-minimise --out {}",
                                 out.string()),
                     dir);
    const auto json = summary(out);
    ASSERT_FALSE(json.is_discarded());
    for (const auto& a : json["anomalies"])
      cases[i] += fmt::format("{} {};", a["case"].get<int>(), a["kind"].get<std::string>());
    cases[i] += std::to_string(json["cases_run"].get<int>());
  }
  EXPECT_EQ(cases[0], cases[1]);
  EXPECT_NE(cases[0].find("mailbox-repeat-executed"), std::string::npos) << cases[0];
}

TEST(FuzzCommandEthercat, BadOptionsAreUsageErrors) {
  // Given a deviation on a real EtherCAT link, a CAN reproducer to replay, an unknown deviation
  // When drivecheck fuzz is called
  // Then exit 2 before anything runs
  const auto dir = fresh_dir("usage");
  EXPECT_EQ(
      drivecheck("fuzz --bus ethercat:veth0 --deviation mailbox-counter-ignored", dir).exit_code,
      2);
  const auto log = dir / "r.log";
  std::ofstream(log) << "(0.000000) vcan0 601#4000100000000000 T\n";
  EXPECT_EQ(
      drivecheck(fmt::format("fuzz --bus ethercat:sim --replay {}", log.string()), dir).exit_code,
      2);
  EXPECT_EQ(drivecheck("fuzz --bus ethercat:sim --deviation no-such-deviation", dir).exit_code, 2);
}

}  // namespace
