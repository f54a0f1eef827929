// Report writers on a large run: 1000 vectors with 20 decoded frames, 4 checks and (every
// fourth vector) 400 timing-diagram samples each: render time of the HTML, JUnit and JSON
// reports, and reading the JSON back (report diff). Target: each well under a second.
#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <chrono>
#include <string>

#include "reports/report_writers.hpp"

namespace drivecheck::reports {
namespace {

conformance::RunResult large_run() {
  conformance::RunResult run;
  run.info.tool_version = "bench";
  run.info.bus = "sim";
  run.info.node = 5;
  run.info.profile_name = "cia402-reference";
  run.info.dut.device_name = "reference drive";
  run.info.dut.vendor_id = 0x1D;
  // ccs=2 initiate upload 6041h sub 0 / scs=2 e=1 s=1 n=2 6041h sub 0 = 0237h
  const auto request = *can::parse_candump("605#4041600000000000");
  const auto reply = *can::parse_candump("585#4B41600037020000");
  for (int i = 0; i < 1000; ++i) {
    conformance::VectorResult vector;
    vector.id = fmt::format("cia301/sdo/generated-{}", i);
    vector.family = i % 2 == 0 ? "cia301/sdo" : "cia402/pp";
    vector.title = "The device MUST answer an expedited upload of 6041h";
    vector.sources = {"CiA 301 §7.2.4.3.3"};
    vector.verdict = i % 10 == 0 ? conformance::Verdict::fail : conformance::Verdict::pass;
    vector.message = "Expected: 585#4B416000....0000\nActual:   nothing within 100 ms";
    const auto start = can::TimePoint(std::chrono::milliseconds(i * 100));
    vector.started = start;
    vector.finished = start + std::chrono::milliseconds(50);
    for (int f = 0; f < 20; ++f) {
      vector.frames.push_back({start + std::chrono::microseconds(f * 500),
                               f % 2 ? reply : request,
                               f % 2 == 0,
                               "SDO rx  node 5  initiate upload 6041:00 (statusword)",
                               {}});
    }
    for (std::size_t c = 0; c < 4; ++c)
      vector.checks.push_back(
          {c, "sdo_read", "{value: 0x0237, mask: 0x006F}", "0x0237", true, {}, {}});
    if (i % 4 == 0) {
      for (int s = 0; s < 100; ++s) {
        const auto at = start + std::chrono::microseconds(s * 500);
        vector.samples.push_back({at, "controlword", s < 50 ? 0x0F : 0x1F});
        vector.samples.push_back({at, "statusword", s < 60 ? 0x0237 : 0x1637});
        vector.samples.push_back({at, "position", s * 100});
        vector.samples.push_back({at, "velocity", s < 90 ? 1000 : 0});
      }
    }
    run.vectors.push_back(std::move(vector));
  }
  return run;
}

void BM_RenderHtml(benchmark::State& state) {
  const auto run = large_run();
  std::size_t bytes = 0;
  for (auto _ : state) {
    const std::string html = render_html(run);
    bytes = html.size();
    benchmark::DoNotOptimize(html.data());
  }
  state.counters["MB"] = static_cast<double>(bytes) / 1e6;
}
BENCHMARK(BM_RenderHtml)->Unit(benchmark::kMillisecond);

void BM_RenderJunit(benchmark::State& state) {
  const auto run = large_run();
  for (auto _ : state) {
    const std::string xml = render_junit(run);
    benchmark::DoNotOptimize(xml.data());
  }
}
BENCHMARK(BM_RenderJunit)->Unit(benchmark::kMillisecond);

void BM_RenderJson(benchmark::State& state) {
  const auto run = large_run();
  for (auto _ : state) {
    const std::string json = render_json(run);
    benchmark::DoNotOptimize(json.data());
  }
}
BENCHMARK(BM_RenderJson)->Unit(benchmark::kMillisecond);

void BM_ParseJson(benchmark::State& state) {
  const std::string json = render_json(large_run());
  for (auto _ : state) {
    auto run = parse_json_report(json);
    benchmark::DoNotOptimize(run);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) *
                          static_cast<std::int64_t>(json.size()));
}
BENCHMARK(BM_ParseJson)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace drivecheck::reports
