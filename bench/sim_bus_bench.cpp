// Throughput of the simulated CAN bus: frames through the whole network per wall-clock second
// (handlers, arbitration, exact bit stuffing, delivery), and the cost of the timing model.
// The "frames/s" rates are per CPU second of the one benchmark thread (Google Benchmark's
// default): on an idle core that is per wall-clock second; on a shared machine it is the
// figure that does not depend on the other load.
#include <benchmark/benchmark.h>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "protocol/can/frame_timing.hpp"
#include "protocol/can/sim_bus.hpp"

namespace drivecheck::can {
namespace {

constexpr Duration kSimulatedPerIteration = std::chrono::milliseconds(100);

void report_frames(benchmark::State& state, const SimBus& bus, std::uint64_t first) {
  const auto frames = static_cast<double>(bus.frames_on_wire() - first);
  state.counters["frames/s"] = benchmark::Counter(frames, benchmark::Counter::kIsRate);
  state.counters["frames"] = frames;
}

// Node A sends an SDO request, B's handler answers, A's handler asks again, ...
// The payload changes every frame so that stuffing is computed on varying bits.
// With `timeouts`, every frame also restarts a 100 ms timeout timer on the receiving node
// (cancel + start, as an SDO client does).
void ping_pong(benchmark::State& state, bool timeouts) {
  SimBus bus({.bitrate = 1'000'000});
  auto a = bus.attach("master");
  auto b = bus.attach("drive");
  const Filter from_b[] = {Filter::standard(0x585)};
  const Filter from_a[] = {Filter::standard(0x605)};
  a->set_filters(from_b);
  b->set_filters(from_a);
  TimerId a_timeout = kNoTimer;
  TimerId b_timeout = kNoTimer;
  std::uint8_t counter = 0;
  a->set_frame_handler([&](const TimedFrame& frame) {
    if (timeouts) {
      a->cancel_timer(a_timeout);
      a_timeout = a->start_timer_after(std::chrono::milliseconds(100), [] {});
    }
    // SDO upload request of node 5: ccs=2, index 6064h sub 0 (position actual value)
    (void)a->send(Frame::standard(0x605, {0x40, 0x64, 0x60, 0x00, ++counter, 0, 0, 0}));
    benchmark::DoNotOptimize(frame);
  });
  b->set_frame_handler([&](const TimedFrame& frame) {
    if (timeouts) {
      b->cancel_timer(b_timeout);
      b_timeout = b->start_timer_after(std::chrono::milliseconds(100), [] {});
    }
    // SDO upload response: scs=2 e=1 s=1 n=0, index 6064h sub 0, 32-bit value
    const std::uint8_t v = frame.frame.data[4];
    (void)b->send(Frame::standard(0x585, {0x43, 0x64, 0x60, 0x00, v, 0x5A, ++counter, 0x00}));
  });
  (void)a->send(Frame::standard(0x605, {0x40, 0x64, 0x60, 0x00, 0, 0, 0, 0}));

  const std::uint64_t first = bus.frames_on_wire();
  for (auto _ : state)
    bus.run_for(kSimulatedPerIteration);
  report_frames(state, bus, first);
}

void BM_SimBusPingPong(benchmark::State& state) {
  ping_pong(state, false);
}
BENCHMARK(BM_SimBusPingPong)->Unit(benchmark::kMillisecond);

void BM_SimBusPingPongWithTimeouts(benchmark::State& state) {
  ping_pong(state, true);
}
BENCHMARK(BM_SimBusPingPongWithTimeouts)->Unit(benchmark::kMillisecond);

// Ten nodes in a ring, each filtering for its predecessor's TPDO and answering with its own:
// three tokens circulate, so frames contend in arbitration and every frame is offered to
// nine receivers' filters.
void BM_SimBusTenNodes(benchmark::State& state) {
  constexpr std::uint32_t kNodes = 10;
  SimBus bus({.bitrate = 1'000'000});
  std::vector<std::unique_ptr<SimPort>> nodes;
  for (std::uint32_t i = 0; i < kNodes; ++i)
    nodes.push_back(bus.attach("node"));
  for (std::uint32_t i = 0; i < kNodes; ++i) {
    const std::uint32_t predecessor = (i + kNodes - 1) % kNodes;
    const Filter filter[] = {Filter::standard(0x181 + predecessor)};
    nodes[i]->set_filters(filter);
    SimPort* node = nodes[i].get();
    node->set_frame_handler([node, i](const TimedFrame& frame) {
      // TPDO1 of node i+1: the token's hop count, then a status byte
      const std::uint8_t hops = static_cast<std::uint8_t>(frame.frame.data[0] + 1);
      (void)node->send(Frame::standard(0x181 + i, {hops, 0x37, 0x00, 0x10}));
    });
  }
  for (std::uint32_t start : {0u, 3u, 6u}) {
    (void)nodes[start]->send(Frame::standard(0x181 + start, {0x00, 0x37, 0x00, 0x10}));
  }
  const std::uint64_t first = bus.frames_on_wire();
  for (auto _ : state)
    bus.run_for(kSimulatedPerIteration);
  report_frames(state, bus, first);
}
BENCHMARK(BM_SimBusTenNodes)->Unit(benchmark::kMillisecond);

// The exact timing model alone: CRC-15 and bit stuffing of an 8-byte base frame.
void BM_FrameBitsExact(benchmark::State& state) {
  Frame frame = Frame::standard(0x181, {0x11, 0x22, 0x33, 0x44, 0x55, 0x66, 0x77, 0x88});
  std::uint32_t total = 0;
  for (auto _ : state) {
    ++frame.data[7];
    total += frame_bits(frame, BitStuffing::exact);
    benchmark::DoNotOptimize(total);
  }
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_FrameBitsExact);

}  // namespace
}  // namespace drivecheck::can
