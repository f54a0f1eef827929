// One definition of the counts (conformance::VerdictCounts) in all four outputs: one run with
// every tally goes through the console, JUnit, HTML and JSON writers, and each shows the same
// numbers. Also: the JSON report of that run validates against reports/report.schema.json.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <pugixml.hpp>
#include <regex>
#include <string>

#include "reports/report_writers.hpp"
#include "tests/reports/synthetic_run.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::reports {
namespace {

using conformance::Tally;

std::map<std::string, std::size_t> expected_counts() {
  return {{"pass", 2},           {"fail", 1},  {"warning", 1},     {"deviation", 1},
          {"not-applicable", 1}, {"error", 1}, {"interrupted", 1}, {"total", 8}};
}

TEST(ReportCounts, EveryWriterShowsTheSameCounts) {
  // Given a run with every tally: a should-level failure (warning) and an interrupted vector
  const auto run = test_support::synthetic_run_every_tally();
  const auto counts = run.counts();
  ASSERT_EQ(counts.total(), 8U);
  ASSERT_EQ(counts[Tally::fail], 1U);
  ASSERT_EQ(counts[Tally::warning], 1U);
  ASSERT_EQ(counts[Tally::interrupted], 1U);

  // When each writer renders it
  const std::string console = ConsoleReporter::summary_line(run);
  const auto json = nlohmann::json::parse(render_json(run));
  pugi::xml_document junit;
  ASSERT_TRUE(junit.load_string(render_junit(run).c_str()));
  const std::string html = render_html(run);

  // Then JSON, HTML and the console give each tally the same number
  const auto expected = expected_counts();
  for (const auto& [name, n] : expected) {
    EXPECT_EQ(json["counts"][name].get<std::size_t>(), n) << "JSON " << name;
    const std::regex shown("data-count-" + name + ">(\\d+)<");
    std::smatch match;
    ASSERT_TRUE(std::regex_search(html, match, shown)) << "HTML " << name;
    EXPECT_EQ(std::stoul(match[1]), n) << "HTML " << name;
  }
  EXPECT_NE(console.find("8 vectors: 2 passed, 1 failed, 1 warnings, 1 deviations, 1 not "
                         "applicable, 1 errors, 1 interrupted"),
            std::string::npos)
      << console;
  // And JUnit counts failures = fail, errors = error, skipped = not-applicable + interrupted
  const auto root = junit.child("testsuites");
  EXPECT_EQ(root.attribute("tests").as_uint(), 8U);
  EXPECT_EQ(root.attribute("failures").as_uint(), 1U);
  EXPECT_EQ(root.attribute("errors").as_uint(), 1U);
  unsigned skipped = 0;
  unsigned failures = 0;
  for (const auto suite : root.children("testsuite")) {
    skipped += suite.attribute("skipped").as_uint();
    failures += suite.attribute("failures").as_uint();
  }
  EXPECT_EQ(skipped, 2U);
  EXPECT_EQ(failures, 1U);
  // And the exit code of an interrupted run is 130 in every output that shows it
  EXPECT_EQ(json["exit_code"].get<int>(), 130);
  EXPECT_NE(html.find("data-exit-code>130<"), std::string::npos);
  EXPECT_NE(console.find("(exit 130)"), std::string::npos);
}

TEST(ReportCounts, InterruptedIsNeitherPassedNorFailed) {
  // Given a run whose only vector was interrupted
  conformance::RunResult run;
  run.vectors.push_back(test_support::vector("t/x/y", conformance::Verdict::interrupted, 0));
  run.interrupted = true;
  // When counted and written as JUnit
  const auto counts = run.counts();
  pugi::xml_document junit;
  ASSERT_TRUE(junit.load_string(render_junit(run).c_str()));
  // Then it is counted as interrupted only, and JUnit skips it (no failure, no error)
  EXPECT_EQ(counts[Tally::interrupted], 1U);
  EXPECT_EQ(counts[Tally::pass] + counts[Tally::fail] + counts[Tally::error], 0U);
  const auto testcase = junit.child("testsuites").child("testsuite").child("testcase");
  EXPECT_TRUE(testcase.child("skipped"));
  EXPECT_FALSE(testcase.child("failure"));
  EXPECT_FALSE(testcase.child("error"));
  EXPECT_EQ(conformance::exit_code(run), 130);
}

TEST(ReportSchema, EveryVerdictValidatesAgainstTheJsonSchema) {
  // Given the JSON report of a run with every tally, frames between vectors and provenance
  test_support::TempDir dir;
  const auto path = dir.path() / "report.json";
  ASSERT_TRUE(write_json_report(path, test_support::synthetic_run_every_tally()));
  // When validated against reports/report.schema.json (python3-jsonschema)
  const auto result =
      test_support::run_command({"python3", DRIVECHECK_CHECK_REPORTS, "--schema",
                                 DRIVECHECK_REPORT_SCHEMA, "--json", path.string()});
  if (result.exit_code == 77) GTEST_SKIP() << result.out;
  // Then it is valid
  EXPECT_EQ(result.exit_code, 0) << result.out << result.err;
}

}  // namespace
}  // namespace drivecheck::reports
