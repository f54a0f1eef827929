// drivecheck report diff A.json B.json: what changed between two runs (reports/report_diff.cpp:
// new failures first, then fixed, other verdict changes, added and removed vectors).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.hpp"
#include "reports/report_writers.hpp"

namespace drivecheck::cli {

void add_report_command(CLI::App& app) {
  // The callbacks own the option storage: CLI11 writes into it during parse().
  auto files = std::make_shared<std::pair<std::string, std::string>>();
  CLI::App* report = app.add_subcommand("report", "Work with JSON reports of earlier runs");
  report->require_subcommand(1);

  CLI::App* diff = report->add_subcommand("diff", "Verdicts that changed from run A to run B");
  diff->add_option("A.json", files->first, "The earlier run's JSON report")
      ->required()
      ->check(CLI::ExistingFile);
  diff->add_option("B.json", files->second, "The later run's JSON report")
      ->required()
      ->check(CLI::ExistingFile);
  diff->callback([files] {
    // 0 no new failures, 1 new failures, 2 a report cannot be read ("file:line: message").
    exit_with(reports::report_diff_command(files->first, files->second, stdout, stderr));
  });
}

}  // namespace drivecheck::cli
