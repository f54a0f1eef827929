// Trace throughput: candump log parsing and formatting, pcap parsing, and the recorder writing
// both files per frame (flushed after every frame, as by default, and buffered).
#include <benchmark/benchmark.h>
#include <stdlib.h>

#include <filesystem>
#include <string>
#include <vector>

#include "protocol/can/candump_log.hpp"
#include "protocol/can/pcap.hpp"
#include "protocol/can/trace_recorder.hpp"

namespace drivecheck::can {
namespace {

using std::chrono::nanoseconds;

constexpr int kRecords = 100'000;

// A mix of CANopen traffic: SYNC, TPDO1, SDO request, heartbeat.
std::vector<LogRecord> sample_records() {
  const char* frames[] = {"080#", "185#3702000010270000", "605#4041600000000000", "705#05"};
  std::vector<LogRecord> records;
  records.reserve(kRecords);
  for (int i = 0; i < kRecords; ++i) {
    records.push_back({nanoseconds(1'700'000'000'000'000'000 + std::int64_t{i} * 250'000), "can0",
                       *parse_candump(frames[i % 4]), TraceDirection::receive});
  }
  return records;
}

std::string sample_log() {
  std::string text;
  for (const auto& record : sample_records())
    text += to_candump_log(record) + "\n";
  return text;
}

void BM_CandumpLogParse(benchmark::State& state) {
  const std::string text = sample_log();
  for (auto _ : state) {
    auto records = read_candump_log(text);
    benchmark::DoNotOptimize(records);
  }
  state.SetItemsProcessed(state.iterations() * kRecords);
  state.SetBytesProcessed(state.iterations() * static_cast<std::int64_t>(text.size()));
  state.counters["lines/s"] = benchmark::Counter(static_cast<double>(kRecords),
                                                 benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_CandumpLogParse)->Unit(benchmark::kMillisecond);

void BM_CandumpLogFormat(benchmark::State& state) {
  const auto records = sample_records();
  for (auto _ : state) {
    for (const auto& record : records) {
      auto line = to_candump_log(record);
      benchmark::DoNotOptimize(line);
    }
  }
  state.counters["lines/s"] = benchmark::Counter(static_cast<double>(kRecords),
                                                 benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_CandumpLogFormat)->Unit(benchmark::kMillisecond);

void BM_PcapParse(benchmark::State& state) {
  const auto header = pcap_file_header();
  std::vector<std::uint8_t> bytes(header.begin(), header.end());
  for (const auto& record : sample_records()) {
    const auto encoded = encode_pcap_record({record.timestamp, record.frame});
    bytes.insert(bytes.end(), encoded->begin(), encoded->end());
  }
  for (auto _ : state) {
    auto records = parse_pcap(bytes);
    benchmark::DoNotOptimize(records);
  }
  state.counters["records/s"] = benchmark::Counter(static_cast<double>(kRecords),
                                                   benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_PcapParse)->Unit(benchmark::kMillisecond);

// Arg 1: flush after every frame (the default); 0: buffered.
void BM_TraceRecorder(benchmark::State& state) {
  std::string dir = (std::filesystem::temp_directory_path() / "drivecheck-bench-XXXXXX").string();
  if (::mkdtemp(dir.data()) == nullptr) {
    state.SkipWithError("mkdtemp failed");
    return;
  }
  const auto records = sample_records();
  for (auto _ : state) {
    auto recorder = TraceRecorder::open(
        {std::filesystem::path(dir) / "run.log", std::filesystem::path(dir) / "run.pcap"},
        {.interface = "can0", .unix_offset = Duration{0}, .flush_each_frame = state.range(0) != 0});
    if (!recorder) {
      state.SkipWithError(recorder.error().c_str());
      break;
    }
    for (const auto& record : records) {
      (void)(*recorder)->record(record.frame, TimePoint(record.timestamp), record.direction);
    }
  }
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(kRecords),
                                                  benchmark::Counter::kIsIterationInvariantRate);
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_TraceRecorder)->Arg(1)->Arg(0)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace drivecheck::can
