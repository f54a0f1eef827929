// The whole conformance suite (every vector in vectors/) against the embedded drive on the
// simulated bus at 1 Mbit/s, with the standard profile: wall time per suite run, vectors run,
// and simulated seconds per wall second (how much faster than real time the suite runs).
// A watchdog stops a run whose simulation stalls (as `drivecheck run` does); the counter
// `stalled` then says so and the figures cover only the vectors run before.
#include <benchmark/benchmark.h>

#include <chrono>
#include <stdexcept>
#include <thread>

#include "cli/embedded_drive.hpp"
#include "conformance/engine.hpp"
#include "conformance/vector_file.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace {

using namespace drivecheck;

void BM_ConformanceSuite(benchmark::State& state) {
  const auto vectors = conformance::load_vector_tree(DRIVECHECK_VECTORS_DIR);
  if (!vectors.ok()) {
    state.SkipWithError(vectors.errors.front().to_string().c_str());
    return;
  }
  auto profile =
      profile::find_profile("cia402-reference", std::string(DRIVECHECK_VECTORS_DIR) + "/drives");
  if (!profile) {
    state.SkipWithError(profile.error().to_string().c_str());
    return;
  }
  double simulated = 0.0;
  double wall = 0.0;
  std::size_t run = 0;
  std::size_t passed = 0;
  bool stalled = false;
  for (auto _ : state) {
    can::SimBus bus({.bitrate = 1'000'000, .seed = 1});
    auto harness = bus.attach("harness");
    auto drive = cli::EmbeddedDrive::create(bus, 1, *profile, {});
    if (!drive) {
      state.SkipWithError(drive.error().c_str());
      return;
    }
    conformance::EngineOptions options;
    options.simulation = (*drive)->simulation();
    conformance::Engine engine(*harness, *profile, options);
    std::jthread watchdog([&engine](const std::stop_token& stop) {
      auto last = engine.progress();
      auto still = std::chrono::milliseconds(0);
      while (!stop.stop_requested()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        const auto now = engine.progress();
        still = now == last ? still + std::chrono::milliseconds(100) : std::chrono::milliseconds(0);
        last = now;
        if (still >= std::chrono::seconds(10)) engine.declare_stalled();
      }
    });
    const auto result = engine.run(vectors.vectors);
    watchdog.request_stop();
    state.SetIterationTime(result.wall_seconds);  // the watchdog's last sleep is not the suite's
    simulated += std::chrono::duration<double>(result.simulated).count();
    wall += result.wall_seconds;
    run = result.vectors.size();
    passed = result.counts()[conformance::Tally::pass];
    stalled = stalled || result.dut_lost;
  }
  state.counters["vectors"] = static_cast<double>(run);
  state.counters["passed"] = static_cast<double>(passed);
  state.counters["simulated_s"] = simulated / static_cast<double>(state.iterations());
  state.counters["sim_s_per_wall_s"] = wall > 0 ? simulated / wall : 0.0;
  state.counters["stalled"] = stalled ? 1 : 0;
}
BENCHMARK(BM_ConformanceSuite)->Unit(benchmark::kSecond)->Iterations(3)->UseManualTime();

}  // namespace
