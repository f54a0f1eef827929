// diff_reports and the `drivecheck report diff` command logic.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <cstdio>
#include <string>

#include "reports/report_writers.hpp"
#include "tests/reports/synthetic_run.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::reports {
namespace {

using conformance::Verdict;
using test_support::synthetic_run;
using test_support::TempDir;

conformance::VectorResult& find(conformance::RunResult& run, std::string_view id) {
  for (auto& vector : run.vectors)
    if (vector.id == id) return vector;
  ADD_FAILURE() << "no vector " << id;
  return run.vectors.front();
}

// B differs from A in every way a diff reports.
conformance::RunResult changed_run() {
  auto run = synthetic_run();
  find(run, "cia301/sdo/expedited-upload").verdict = Verdict::fail;  // new failure
  find(run, "cia301/sdo/expedited-upload").message = "Expected: x\nActual: y";
  find(run, "cia301/sdo/abort/write-read-only").verdict = Verdict::pass;  // fixed
  find(run, "cia402/homing/method-35").verdict = Verdict::pass;           // changed
  find(run, "cia301/heartbeat/producer-period").warning = false;          // warning → failure
  find(run, "cia301/nmt/reset-communication").verdict = Verdict::error;   // unchanged
  run.vectors.erase(run.vectors.begin() + 2);                             // removed: transition-16
  auto added = test_support::vector("cia301/sync/added", Verdict::pass, 300);
  run.vectors.push_back(added);
  auto added_failing = test_support::vector("cia301/emcy/added-failing", Verdict::fail, 320);
  run.vectors.push_back(added_failing);
  return run;
}

TEST(ReportDiff, OrdersNewFailuresFixedChangedAddedRemoved) {
  // Given run A (synthetic) and run B with a new failure, a warning turned failure, a new failing
  //       vector, a fix, a verdict change, an added and a removed vector
  // When diffed
  // Then new failures come first (by id), then fixed, changed, added, removed; unchanged
  //      vectors are not listed
  const auto changes = diff_reports(synthetic_run(), changed_run());
  std::vector<std::pair<ChangeKind, std::string>> got;
  for (const auto& change : changes)
    got.emplace_back(change.kind, change.id);
  const std::vector<std::pair<ChangeKind, std::string>> expected = {
      {ChangeKind::new_failure, "cia301/emcy/added-failing"},
      {ChangeKind::new_failure, "cia301/heartbeat/producer-period"},
      {ChangeKind::new_failure, "cia301/sdo/expedited-upload"},
      {ChangeKind::fixed, "cia301/sdo/abort/write-read-only"},
      {ChangeKind::verdict_changed, "cia402/homing/method-35"},
      {ChangeKind::added, "cia301/sync/added"},
      {ChangeKind::removed, "cia402/fsa/transition-16"},
  };
  EXPECT_EQ(got, expected);
  EXPECT_EQ(changes[2].before, Verdict::pass);
  EXPECT_EQ(changes[2].after, Verdict::fail);
  EXPECT_FALSE(changes[0].before.has_value());
  EXPECT_FALSE(changes[6].after.has_value());
}

TEST(ReportDiff, IdenticalRunsHaveNoChanges) {
  // Given the same run twice
  // When diffed
  // Then nothing is listed and the summary says 0 of everything
  const auto changes = diff_reports(synthetic_run(), synthetic_run());
  EXPECT_TRUE(changes.empty());
  EXPECT_EQ(format_diff(changes), "0 new failures, 0 fixed, 0 changed, 0 added, 0 removed\n");
}

TEST(ReportDiff, FormatsOneLinePerChange) {
  // Given the diff of A and B
  // When formatted
  // Then each line is kind, id, before -> after (and the first message line for failures)
  const std::string text = format_diff(diff_reports(synthetic_run(), changed_run()));
  EXPECT_NE(text.find("new failure  cia301/sdo/expedited-upload  pass -> fail: Expected: x\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("new failure  cia301/heartbeat/producer-period  fail+warning -> fail"),
            std::string::npos);
  EXPECT_NE(text.find("removed      cia402/fsa/transition-16  deviation -> (absent)\n"),
            std::string::npos);
  EXPECT_NE(text.find("\n3 new failures, 1 fixed, 1 changed, 1 added, 1 removed\n"),
            std::string::npos);
}

// Runs report_diff_command with stdout/stderr captured in files.
struct DiffOutcome {
  int code = -1;
  std::string out;
  std::string err;
};

DiffOutcome run_diff(const TempDir& dir, const std::filesystem::path& a,
                     const std::filesystem::path& b) {
  std::FILE* out = std::fopen((dir / "out.txt").c_str(), "w");
  std::FILE* err = std::fopen((dir / "err.txt").c_str(), "w");
  DiffOutcome outcome;
  outcome.code = report_diff_command(a, b, out, err);
  std::fclose(out);
  std::fclose(err);
  outcome.out = test_support::read_file(dir / "out.txt");
  outcome.err = test_support::read_file(dir / "err.txt");
  return outcome;
}

TEST(ReportDiffCommand, ExitCodesZeroOneTwo) {
  // Given JSON reports of A and B (B with new failures) and a file that is not a report
  // When diffed A→A, A→B, A→C (C only fixes and removes) and A→bad
  // Then the exit codes are 0, 1, 0 (only fixes and removals) and 2 with a "file:line:" message
  TempDir dir;
  ASSERT_TRUE(write_json_report(dir / "a.json", synthetic_run()));
  ASSERT_TRUE(write_json_report(dir / "b.json", changed_run()));
  auto fixed_only = synthetic_run();
  find(fixed_only, "cia301/sdo/abort/write-read-only").verdict = Verdict::pass;
  fixed_only.vectors.pop_back();
  ASSERT_TRUE(write_json_report(dir / "c.json", fixed_only));
  const auto bad = dir.write("bad.json", "{\"schema_version\": 1,\n\"run\": nope}\n");

  EXPECT_EQ(run_diff(dir, dir / "a.json", dir / "a.json").code, 0);
  const auto regress = run_diff(dir, dir / "a.json", dir / "b.json");
  EXPECT_EQ(regress.code, 1);
  EXPECT_EQ(regress.out.rfind("new failure  cia301/emcy/added-failing", 0), 0u) << regress.out;
  const auto fixes = run_diff(dir, dir / "a.json", dir / "c.json");
  EXPECT_EQ(fixes.code, 0) << fixes.out;
  EXPECT_EQ(fixes.out,
            "fixed        cia301/sdo/abort/write-read-only  fail -> pass\n"
            "removed      cia402/pp/single-set-point  pass -> (absent)\n"
            "0 new failures, 1 fixed, 0 changed, 0 added, 1 removed\n");
  const auto broken = run_diff(dir, dir / "a.json", bad);
  EXPECT_EQ(broken.code, 2);
  EXPECT_TRUE(broken.out.empty());
  EXPECT_EQ(broken.err.rfind(bad.string() + ":2: not valid JSON", 0), 0u) << broken.err;
}

}  // namespace
}  // namespace drivecheck::reports
