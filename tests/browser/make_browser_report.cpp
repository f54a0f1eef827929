// Writes the HTML and JSON reports the browser test opens in headless Chromium.
//
//   make_browser_report OUTDIR                  the synthetic run (every tally, hostile text)
//   make_browser_report OUTDIR --from RUN.json  a real run's JSON (e.g. `drivecheck run --json`
//                                               with an injected deviation), re-rendered
//   make_browser_report OUTDIR --many N         the synthetic run's vectors repeated to N
//                                               vectors with 20 frames each (load time check)
//
// Writes OUTDIR/report.html and OUTDIR/report.json; exit 0, or 2 with a message.
#include <fmt/format.h>

#include <cstdlib>
#include <string>
#include <string_view>

#include "reports/report_writers.hpp"
#include "tests/reports/synthetic_run.hpp"

namespace {

int usage() {
  fmt::print(stderr, "usage: make_browser_report OUTDIR [--from RUN.json | --many N]\n");
  return 2;
}

drivecheck::conformance::RunResult many_vectors(std::size_t count) {
  auto run = drivecheck::test_support::synthetic_run();
  const auto templates = run.vectors;
  run.vectors.clear();
  for (std::size_t i = 0; i < count; ++i) {
    auto vector = templates[i % templates.size()];
    vector.id += fmt::format("-{}", i);
    while (vector.frames.size() < 20 && !templates[0].frames.empty())
      vector.frames.push_back(templates[0].frames[vector.frames.size() % 2]);
    run.vectors.push_back(std::move(vector));
  }
  return run;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2 && argc != 4) return usage();
  const std::filesystem::path out = argv[1];
  drivecheck::conformance::RunResult run;
  if (argc == 2) {
    run = drivecheck::test_support::synthetic_run_every_tally();
  } else if (std::string_view(argv[2]) == "--from") {
    auto read = drivecheck::reports::read_json_report(argv[3]);
    if (!read) {
      fmt::print(stderr, "{}\n", read.error().to_string());
      return 2;
    }
    run = std::move(*read);
  } else if (std::string_view(argv[2]) == "--many") {
    char* end = nullptr;
    const unsigned long count = std::strtoul(argv[3], &end, 10);
    if (end == argv[3] || *end != '\0' || count == 0 || count > 100000) return usage();
    run = many_vectors(count);
  } else {
    return usage();
  }
  for (const auto& written : {drivecheck::reports::write_html_report(out / "report.html", run),
                              drivecheck::reports::write_json_report(out / "report.json", run)}) {
    if (!written) {
      fmt::print(stderr, "make_browser_report: {}\n", written.error());
      return 2;
    }
  }
  return 0;
}
