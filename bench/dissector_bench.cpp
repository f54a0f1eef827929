// Dissector throughput: frames per wall second turned into transcript lines (drivecheck decode,
// reports), for a mix of CANopen traffic, and the cost of the table lookups behind it.
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "protocol/cia301/dissector.hpp"
#include "protocol/cia301/emcy.hpp"
#include "protocol/cia402/state_machine.hpp"

namespace drivecheck::cia301 {
namespace {

// A mix of a drive's traffic: SYNC, mapped TPDO1, SDO request/response, heartbeat, EMCY, NMT.
std::vector<can::Frame> sample_frames() {
  const char* texts[] = {"080#01",
                         "181#37060104000000",
                         "601#4041600000000000",
                         "581#4B41600037060000",
                         "701#05",
                         "081#1186010000000000",
                         "000#0101",
                         "601#2B4060000F000000"};
  std::vector<can::Frame> frames;
  for (const char* text : texts)
    frames.push_back(*can::parse_candump(text));
  return frames;
}

void BM_DissectLine(benchmark::State& state) {
  const auto frames = sample_frames();
  DissectorOptions options;
  options.pdo_mappings[0x181] = PdoMapping{{{0x6041, 0, 16}, {0x6061, 0, 8}, {0x60FD, 0, 32}}};
  Dissector dissector(options);
  std::size_t i = 0;
  for (auto _ : state) {
    std::string line = dissector.line(frames[i++ % frames.size()]);
    benchmark::DoNotOptimize(line);
  }
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DissectLine);

void BM_EmcyCodeLookup(benchmark::State& state) {
  std::uint16_t code = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(find_emcy_code(code));
    code = static_cast<std::uint16_t>(code + 0x0101);
  }
}
BENCHMARK(BM_EmcyCodeLookup);

void BM_StatuswordDecode(benchmark::State& state) {
  std::uint16_t word = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(cia402::decode_statusword(word));
    ++word;
  }
}
BENCHMARK(BM_StatuswordDecode);

}  // namespace
}  // namespace drivecheck::cia301
