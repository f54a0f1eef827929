// Throughput of the simulated EtherCAT segment (issue 20: at least 1 M datagram round trips per
// second): the master sends a frame, every ESC on the line processes it in place, the master
// receives it, then the next. Rates are per CPU second of the benchmark thread.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <deque>
#include <vector>

#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/sim_segment.hpp"

namespace drivecheck::ethercat {
namespace {

// One FPRD of AL status (2 bytes) per frame through `slaves` bare ESCs.
void round_trips(benchmark::State& state) {
  const auto slaves = static_cast<std::size_t>(state.range(0));
  std::deque<Esc> escs(slaves);
  std::deque<EscDevice> devices;
  SimSegment segment;
  for (Esc& esc : escs)
    segment.attach(devices.emplace_back(esc));
  Frame frame;
  frame.datagrams = {Datagram::physical(Command::fprd, 0, 0, reg::kAlStatus, {0, 0})};
  const std::vector<std::uint8_t> bytes = *encode_frame(frame);
  std::int64_t trips = 0;
  for (auto _ : state) {
    (void)segment.send(bytes);
    auto back = segment.receive(kForever);
    benchmark::DoNotOptimize(back);
    ++trips;
  }
  state.counters["round trips/s"] =
      benchmark::Counter(static_cast<double>(trips), benchmark::Counter::kIsRate);
}
BENCHMARK(round_trips)->Arg(1)->Arg(4);

// One LRW of 4 bytes per frame through one ESC with two FMMUs and two buffered SMs mapped.
void lrw_cycle(benchmark::State& state) {
  Esc esc;
  EscDevice device(esc);
  SimSegment segment;
  segment.attach(device);
  auto send_one = [&](Datagram d) {
    Frame f;
    f.datagrams = {std::move(d)};
    (void)segment.send(*encode_frame(f));
    (void)segment.receive(kForever);
  };
  send_one(Datagram::physical(Command::apwr, 0, 0, reg::sync_manager(2),
                              {0x00, 0x11, 2, 0, 0x64, 0, 1, 0, 0x80, 0x11, 2, 0, 0x20, 0, 1, 0}));
  send_one(Datagram::physical(Command::apwr, 0, 0, reg::kFmmu,
                              {0, 0, 1, 0, 2, 0, 0, 7, 0x00, 0x11, 0, 2, 1, 0, 0, 0,  //
                               2, 0, 1, 0, 2, 0, 0, 7, 0x80, 0x11, 0, 1, 1, 0, 0, 0}));
  Frame frame;
  frame.datagrams = {Datagram::logical(Command::lrw, 0, 0x10000, {0x0F, 0, 0, 0})};
  const std::vector<std::uint8_t> bytes = *encode_frame(frame);
  std::int64_t cycles = 0;
  for (auto _ : state) {
    (void)segment.send(bytes);
    auto back = segment.receive(kForever);
    benchmark::DoNotOptimize(back);
    ++cycles;
  }
  state.counters["LRW cycles/s"] =
      benchmark::Counter(static_cast<double>(cycles), benchmark::Counter::kIsRate);
}
BENCHMARK(lrw_cycle);

}  // namespace
}  // namespace drivecheck::ethercat
