// One definition of the counts (conformance::VerdictCounts) in all four outputs: one run with
// every tally goes through the console, JUnit, HTML and JSON writers, and each shows the same
// numbers. Also: the JSON report of that run validates against reports/report.schema.json.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
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

// A run with EtherCAT evidence: the first vector's datagrams, a run of cyclic frames counted
// and entries left out after the head.
conformance::RunResult run_with_datagrams() {
  auto run = test_support::synthetic_run_every_tally();
  auto& vector = run.vectors.front();
  const auto at = [&](int us) { return vector.started + std::chrono::microseconds(us); };
  vector.datagrams = {
      {at(100),
       at(100),
       1,
       "FPWR station 1001h 1000h SM0 write mailbox len 128 wkc 1: CoE len 10 addr 0000h cnt 1: "
       "SDO upload initiate 1000h:00",
       {}},
      {at(1000), at(120000), 120, "LRW logical 00010000h len 14 wkc 3", {}},
      {at(121000),
       at(121000),
       1,
       "FPRD station 1001h 1080h SM1 read mailbox len 128 wkc 1: CoE len 14 addr 0000h cnt 1: "
       "SDO abort by the server 1018h:01 06010002h write_read_only: Attempt to write a read only "
       "object",
       {}}};
  vector.datagrams_elided = 800;
  vector.datagrams_elided_at = 1;
  return run;
}

TEST(ReportSchema, EthercatDatagramsValidateRoundTripAndRender) {
  // Given a run whose first vector has EtherCAT datagrams (a counted run, elided entries)
  test_support::TempDir dir;
  const auto path = dir.path() / "report.json";
  const auto run = run_with_datagrams();
  ASSERT_TRUE(write_json_report(path, run));
  // When its JSON is validated and read back, and its HTML and JUnit rendered
  const auto result =
      test_support::run_command({"python3", DRIVECHECK_CHECK_REPORTS, "--schema",
                                 DRIVECHECK_REPORT_SCHEMA, "--json", path.string()});
  if (result.exit_code == 77) GTEST_SKIP() << result.out;
  // Then it is valid, reads back the same, and both show each entry, the count and the elision
  EXPECT_EQ(result.exit_code, 0) << result.out << result.err;
  const auto read = read_json_report(path);
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_EQ(read->vectors.front().datagrams, run.vectors.front().datagrams);
  EXPECT_EQ(read->vectors.front().datagrams_elided, 800U);
  EXPECT_EQ(render_json(*read), render_json(run));
  EXPECT_TRUE(read->vectors.back().datagrams.empty());
  for (const std::string& text : {render_html(run), render_junit(run)}) {
    EXPECT_NE(text.find("LRW logical 00010000h len 14 wkc 3  ×120 (to 0.120000)"),
              std::string::npos);
    EXPECT_NE(text.find("06010002h write_read_only"), std::string::npos);
    EXPECT_NE(text.find("800 datagram entries not kept"), std::string::npos);
  }
}

TEST(ReportSchema, DatagramsWithoutTheirElisionCountAreInvalid) {
  // Given a report whose datagrams lack datagrams_elided (and one with a count of 0)
  test_support::TempDir dir;
  auto document = nlohmann::json::parse(render_json(run_with_datagrams()));
  document["vectors"][0].erase("datagrams_elided");
  const auto path = dir.path() / "report.json";
  {
    std::ofstream out(path);
    out << document.dump();
  }
  auto zero = nlohmann::json::parse(render_json(run_with_datagrams()));
  zero["vectors"][0]["datagrams"][0]["count"] = 0;
  const auto zero_path = dir.path() / "zero.json";
  {
    std::ofstream out(zero_path);
    out << zero.dump();
  }
  // When validated against the schema
  // Then both are refused
  for (const auto& file : {path, zero_path}) {
    const auto result =
        test_support::run_command({"python3", DRIVECHECK_CHECK_REPORTS, "--schema",
                                   DRIVECHECK_REPORT_SCHEMA, "--json", file.string()});
    if (result.exit_code == 77) GTEST_SKIP() << result.out;
    EXPECT_NE(result.exit_code, 0) << file << ": " << result.out;
  }
}

}  // namespace
}  // namespace drivecheck::reports
