// `drivecheck run` and `drivecheck vectors` on bad input: exit 2 with file:line; the embedded
// default on a small vector tree: reports written, exit code from the verdicts. The small tree
// takes the shipped tree's place (DRIVECHECK_VECTORS); `--vectors DIR` would add to it
// (tests/cli/user_vectors_test.cpp).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/temp_dir.hpp"

namespace {

using drivecheck::test_support::read_file;
using drivecheck::test_support::run_command;

class CliRun : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("drivecheck_cli_run_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_ / "vectors" / "drives");
    std::filesystem::copy_file(
        std::string(DRIVECHECK_SOURCE_DIR) + "/vectors/drives/cia402-reference.yaml",
        dir_ / "vectors" / "drives" / "cia402-reference.yaml");
    std::filesystem::copy_file(std::string(DRIVECHECK_SOURCE_DIR) + "/vectors/manuals.yaml",
                               dir_ / "vectors" / "manuals.yaml");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  void write(const std::string& text) { std::ofstream(dir_ / "vectors" / "v.yaml") << text; }
  std::filesystem::path dir_;
};

TEST_F(CliRun, BadVectorIsExit2WithFileLine) {
  // Given a vector with an unknown key on line 4
  write("- id: t/x\n  title: t\n  source: \"CiA 301 §1\"\n  stesp: []\n  steps: [{wait: 1ms}]\n");
  // When run and linted
  const auto run = run_command(
      {"env", "DRIVECHECK_VECTORS=" + (dir_ / "vectors").string(), DRIVECHECK_EXE, "run"});
  const auto lint = run_command({DRIVECHECK_EXE, "vectors", "lint", (dir_ / "vectors").string()});
  // Then both exit 2 naming vectors/v.yaml:4
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("vectors/v.yaml:4: unknown vector key 'stesp'"), std::string::npos)
      << run.err;
  EXPECT_EQ(lint.exit_code, 2);
  EXPECT_NE(lint.err.find("vectors/v.yaml:4: error: unknown vector key 'stesp'"), std::string::npos)
      << lint.err;
}

TEST_F(CliRun, EmbeddedRunWritesReportsAndFailsOnAFailure) {
  // Given one passing and one failing vector against the embedded drive
  write(
      "- id: t/pass\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n    - sdo_read: {index: "
      "0x1000, sub: 0}\n"
      "- id: t/fail\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n    - sdo_read: {index: "
      "0x1000, sub: 0}\n"
      "      expect: {size: 3}\n");
  const auto json = (dir_ / "r.json").string();
  // When run
  const auto run = run_command({"env", "DRIVECHECK_VECTORS=" + (dir_ / "vectors").string(),
                                DRIVECHECK_EXE, "run", "--json", json});
  // Then exit 1, the JSON report exists and names both vectors
  EXPECT_EQ(run.exit_code, 1) << run.err;
  const std::string report = read_file(json);
  EXPECT_NE(report.find("\"t/pass\""), std::string::npos);
  EXPECT_NE(report.find("\"t/fail\""), std::string::npos);
}

TEST_F(CliRun, EmbeddedRunAllowsFactoryRestoreAndReportsTheChoice) {
  // Given a vector with setup restore-defaults (a factory restore) against the embedded drive
  write(
      "- id: t/defaults\n  title: t\n  source: \"CiA 301 §1\"\n  setup: restore-defaults\n"
      "  steps:\n    - sdo_read: {index: 0x1018, sub: 0}\n");
  const auto plain = (dir_ / "plain.json").string();
  const auto opted = (dir_ / "opted.json").string();
  // When run without and with --allow-factory-restore
  const std::string tree = "DRIVECHECK_VECTORS=" + (dir_ / "vectors").string();
  const auto run_plain = run_command({"env", tree, DRIVECHECK_EXE, "run", "--json", plain});
  const auto run_opted =
      run_command({"env", tree, DRIVECHECK_EXE, "run", "--allow-factory-restore", "--json", opted});
  // Then both pass (the simulated bus allows it), and the reports record the choice
  EXPECT_EQ(run_plain.exit_code, 0) << run_plain.out << run_plain.err;
  EXPECT_EQ(run_opted.exit_code, 0) << run_opted.out << run_opted.err;
  EXPECT_NE(read_file(plain).find("\"allow_factory_restore\": false"), std::string::npos);
  EXPECT_NE(read_file(opted).find("\"allow_factory_restore\": true"), std::string::npos);
  EXPECT_NE(read_file(plain).find("\"verdict\": \"pass\""), std::string::npos);
}

// The ids of the vectors in a JSON report, in report order.
std::vector<std::string> report_ids(const std::filesystem::path& json) {
  const std::string report = read_file(json);
  std::vector<std::string> ids;
  const std::string key = "\"id\": \"t/";
  for (auto at = report.find(key); at != std::string::npos; at = report.find(key, at + 1)) {
    const auto begin = at + key.size() - 2;
    ids.push_back(report.substr(begin, report.find('"', begin) - begin));
  }
  return ids;
}

class CliRunOrder : public CliRun {
 protected:
  void SetUp() override {
    CliRun::SetUp();
    std::string text;
    for (const char* name : {"a", "b", "c", "d", "e", "f"}) {
      text += std::string("- id: t/") + name +
              "\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n    - sdo_read: {index: "
              "0x1000, sub: 0}\n";
    }
    write(text);
  }
  drivecheck::test_support::CommandResult run(const std::string& order, const std::string& json) {
    return run_command({"env", "DRIVECHECK_VECTORS=" + (dir_ / "vectors").string(), DRIVECHECK_EXE,
                        "run", "--order", order, "--json", (dir_ / json).string()});
  }
};

TEST_F(CliRunOrder, ReverseRunsTheVectorsBackwards) {
  // Given vectors t/a..t/f / When run with --order reverse
  const auto result = run("reverse", "r.json");
  // Then they ran f..a, and the report and the console say so
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(report_ids(dir_ / "r.json"),
            (std::vector<std::string>{"t/f", "t/e", "t/d", "t/c", "t/b", "t/a"}));
  EXPECT_NE(result.out.find("--order reverse"), std::string::npos) << result.out;
  EXPECT_NE(read_file(dir_ / "r.json").find("\"order\": \"reverse\""), std::string::npos);
}

TEST_F(CliRunOrder, SameShuffleSeedRepeatsTheOrder) {
  // Given vectors t/a..t/f / When run twice with --order shuffle:11 and once with shuffle
  const auto first = run("shuffle:11", "1.json");
  const auto second = run("shuffle:11", "2.json");
  const auto drawn = run("shuffle", "3.json");
  ASSERT_EQ(first.exit_code, 0) << first.err;
  ASSERT_EQ(second.exit_code, 0) << second.err;
  ASSERT_EQ(drawn.exit_code, 0) << drawn.err;
  // Then both seeded runs have the same order, not the file order, and each run records
  // the seed it used
  const auto ids = report_ids(dir_ / "1.json");
  EXPECT_EQ(ids.size(), 6U);
  EXPECT_EQ(ids, report_ids(dir_ / "2.json"));
  EXPECT_NE(ids, (std::vector<std::string>{"t/a", "t/b", "t/c", "t/d", "t/e", "t/f"}));
  EXPECT_NE(first.out.find("--order shuffle:11"), std::string::npos) << first.out;
  EXPECT_NE(drawn.out.find("--order shuffle:"), std::string::npos) << drawn.out;
  EXPECT_NE(read_file(dir_ / "3.json").find("\"order\": \"shuffle:"), std::string::npos);
}

TEST_F(CliRunOrder, BadOrderIsExit2) {
  // Given --order sideways / When run / Then exit 2 with a message naming it
  const auto result = run("sideways", "x.json");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("sideways"), std::string::npos) << result.err;
}

}  // namespace

namespace {

// The JSON object of vector `id` in a report (from its "id" to the next vector), for finds.
std::string vector_json(const std::string& report, const std::string& id) {
  const auto at = report.find("\"id\": \"" + id + "\"");
  if (at == std::string::npos) return {};
  const auto next = report.find("\"id\": \"t/", at + 1);
  return report.substr(at, next == std::string::npos ? std::string::npos : next - at);
}

class CliRunNeeds : public CliRun {
 protected:
  void SetUp() override {
    CliRun::SetUp();
    // One vector per kind of need: an object the reference drive has (1029h), one it lacks
    // (2FFFh: manufacturer range, never in the reference dictionary).
    write(
        "- id: t/needs-1029\n  title: t\n  source: \"CiA 301 §7.5.2.32\"\n"
        "  requires: [object.1029]\n  steps:\n    - sdo_read: {index: 0x1029, sub: 0}\n"
        "- id: t/needs-2fff\n  title: t\n  source: \"CiA 301 §1\"\n"
        "  requires: [object.2FFF]\n  steps:\n    - sdo_read: {index: 0x2FFF, sub: 0}\n");
  }
};

// The JSON object of vector `id` in a report, up to the next vector's id.
std::string one_vector_json(const std::string& report, const std::string& id) {
  const auto at = report.find("\"id\": \"" + id + "\"");
  if (at == std::string::npos) return {};
  const auto next = report.find("\"id\": \"", at + 1);
  return report.substr(at, next == std::string::npos ? std::string::npos : next - at);
}

TEST_F(CliRun, TheEdsItselfAndTheDriveAgainstItAreJudged) {
  // Given the reference drive's EDS with a wrong NrOfTXPDO (an error of the file) and a
  //       ProductNumber the drive does not have (a lint warning, and a live mismatch)
  std::string eds =
      read_file(std::string(DRIVECHECK_SOURCE_DIR) + "/reference_drive/reference_drive.eds");
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"NrOfTXPDO=4", "NrOfTXPDO=3"},
                                 {"ProductNumber=0x402", "ProductNumber=0x403"}}) {
    const auto at = eds.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    eds.replace(at, from.size(), to);
  }
  const auto file = dir_ / "mismatch.eds";
  std::ofstream(file, std::ios::binary) << eds;
  const auto json = (dir_ / "r.json").string();
  // When the EDS checks run with it (eds/lint, eds/identity)
  const auto run = run_command({"env", "DRIVECHECK_VECTORS=" + (dir_ / "vectors").string(),
                                DRIVECHECK_EXE, "run", "--eds", file.string(), "--filter",
                                "eds/lint/*", "--filter", "eds/identity/*", "--json", json});
  // Then the run fails: the file's error and the product code; the warning is a warning, a
  //      clean rule passes, each with its clause
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  const std::string report = read_file(json);
  const auto count = one_vector_json(report, "eds/lint/pdo-count-mismatch");
  EXPECT_NE(count.find("\"verdict\": \"fail\""), std::string::npos) << count;
  EXPECT_NE(count.find("CiA 306 [DeviceInfo] NrOfRXPDO, NrOfTXPDO"), std::string::npos) << count;
  EXPECT_NE(count.find("mismatch.eds:32"), std::string::npos) << count;
  EXPECT_NE(one_vector_json(report, "eds/identity/product-code").find("\"verdict\": \"fail\""),
            std::string::npos);
  const auto hint = one_vector_json(report, "eds/lint/identity-mismatch");
  EXPECT_NE(hint.find("\"verdict\": \"fail\""), std::string::npos) << hint;
  EXPECT_NE(hint.find("\"warning\": true"), std::string::npos) << hint;
  EXPECT_NE(one_vector_json(report, "eds/lint/limits-inverted").find("\"verdict\": \"pass\""),
            std::string::npos);
}

}  // namespace

TEST_F(CliRunNeeds, AnObjectTheDriveLacksIsNotApplicableWithTheProbesAnswer) {
  // Given the embedded drive, which has 1029h and no 2FFFh
  const auto json = (dir_ / "r.json").string();
  // When run without an EDS
  const auto run = run_command({"env", "DRIVECHECK_VECTORS=" + (dir_ / "vectors").string(),
                                DRIVECHECK_EXE, "run", "--json", json});
  // Then 1029h's vector passes, 2FFFh's is not applicable with the upload's answer, exit 0, and
  // the report records the probe and the profile choice
  EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
  const std::string report = read_file(json);
  EXPECT_NE(vector_json(report, "t/needs-1029").find("\"verdict\": \"pass\""), std::string::npos)
      << report;
  EXPECT_NE(vector_json(report, "t/needs-2fff")
                .find("needs object 2FFFh: absent (upload answered 06020000h)"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("\"capabilities\""), std::string::npos);
  EXPECT_NE(report.find("\"choice\": \"the embedded default"), std::string::npos);
}

TEST_F(CliRunNeeds, TheEdsDecidesWhichObjectsThereAre) {
  // Given an EDS of the reference drive without 1029h
  const auto json = (dir_ / "r.json").string();
  const std::string eds = std::string(DRIVECHECK_SOURCE_DIR) +
                          "/tests/conformance/data/reference-drive-without-1029.eds";
  // When run with it (only the t/ vectors: the drive has 1029h, which the EDS check would catch)
  const auto run =
      run_command({"env", "DRIVECHECK_VECTORS=" + (dir_ / "vectors").string(), DRIVECHECK_EXE,
                   "run", "--eds", eds, "--filter", "t/*", "--json", json});
  // Then the vector needing 1029h is not applicable "(not in the EDS)"
  EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
  const std::string report = read_file(json);
  EXPECT_NE(vector_json(report, "t/needs-1029").find("needs object 1029h: absent (not in the EDS)"),
            std::string::npos)
      << report;
}
