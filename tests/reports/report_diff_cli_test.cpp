// `drivecheck report diff A.json B.json` run as a program: output and exit codes 0 / 1 / 2.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "reports/report_writers.hpp"
#include "tests/reports/synthetic_run.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::reports {
namespace {

using test_support::TempDir;

test_support::CommandResult diff(const std::filesystem::path& a, const std::filesystem::path& b) {
  return test_support::run_command({DRIVECHECK_EXE, "report", "diff", a.string(), b.string()});
}

TEST(ReportDiffCli, NoRegressionExitsZeroNewFailureExitsOne) {
  // Given run A (synthetic) and run B where the passing SDO upload now fails
  // When `drivecheck report diff` compares A with A, then A with B
  // Then A→A prints the zero summary and exits 0; A→B lists the new failure first and exits 1
  TempDir dir;
  auto a = test_support::synthetic_run();
  auto b = a;
  b.vectors[0].verdict = conformance::Verdict::fail;
  b.vectors[0].message = "Expected: 585#4B416000....0000\nActual: nothing within 100 ms";
  ASSERT_TRUE(write_json_report(dir / "a.json", a));
  ASSERT_TRUE(write_json_report(dir / "b.json", b));

  const auto same = diff(dir / "a.json", dir / "a.json");
  EXPECT_EQ(same.exit_code, 0) << same.err;
  EXPECT_EQ(same.out, "0 new failures, 0 fixed, 0 changed, 0 added, 0 removed\n");

  const auto worse = diff(dir / "a.json", dir / "b.json");
  EXPECT_EQ(worse.exit_code, 1) << worse.err;
  EXPECT_EQ(worse.out,
            "new failure  cia301/sdo/expedited-upload  pass -> fail: Expected: "
            "585#4B416000....0000\n"
            "1 new failures, 0 fixed, 0 changed, 0 added, 0 removed\n");
}

TEST(ReportDiffCli, BadReportExitsTwoWithFileAndLine) {
  // Given a JSON report and a file that is a JUnit XML file, not JSON
  // When diffed
  // Then nothing is printed on stdout, stderr has one "file:1: not valid JSON" line, exit 2
  TempDir dir;
  ASSERT_TRUE(write_json_report(dir / "a.json", test_support::synthetic_run()));
  ASSERT_TRUE(write_junit_report(dir / "junit.xml", test_support::synthetic_run()));
  const auto result = diff(dir / "a.json", dir / "junit.xml");
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_TRUE(result.out.empty()) << result.out;
  EXPECT_EQ(result.err.rfind((dir / "junit.xml").string() + ":1: not valid JSON", 0), 0u)
      << result.err;
  EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1);
}

}  // namespace
}  // namespace drivecheck::reports
