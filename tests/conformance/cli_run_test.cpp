// `drivecheck run` and `drivecheck vectors` on bad input: exit 2 with file:line; the embedded
// default on a small vector tree: reports written, exit code from the verdicts.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/support/run_command.hpp"

namespace {

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
  const auto run = run_command({DRIVECHECK_EXE, "run", "--vectors", (dir_ / "vectors").string()});
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
  const auto run = run_command(
      {DRIVECHECK_EXE, "run", "--vectors", (dir_ / "vectors").string(), "--json", json});
  // Then exit 1, the JSON report exists and names both vectors
  EXPECT_EQ(run.exit_code, 1) << run.err;
  std::ifstream in(json);
  std::ostringstream text;
  text << in.rdbuf();
  const std::string report = text.str();
  EXPECT_NE(report.find("\"t/pass\""), std::string::npos);
  EXPECT_NE(report.find("\"t/fail\""), std::string::npos);
}

}  // namespace
