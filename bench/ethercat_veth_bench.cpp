// CoE SDO over a real link against a raw AF_PACKET ping-pong on the same veth pair, in one run
// (issue 20: "over veth: CoE SDO round trips at least 90 % of a raw AF_PACKET ping-pong").
//
// The program makes a network namespace with a veth pair (a <-> b) and enters it; both are
// removed at the end, also when a benchmark aborts (atexit). A thread on end b serves:
//  - raw_ping_pong: it sends every frame back unchanged; the master side sends one frame of
//    the size of an SM1 read (one FPRD of 128 octets) and waits for it. Round trips per
//    second of wall time.
//  - coe_sdo_upload: it lets the emulated slave of tests/ethercat/master_test_slave.hpp (ESC +
//    CoE front end) process every frame in place and sends it back; the master uploads 1018h:01
//    (expedited) through its mailbox polling. SDO per second, the frames each SDO took, and
//    those frames per second.
// The comparison printed at the end: the SDO path's frame round trips per second as a share of
// the ping-pong's (the master's and slave's own cost per frame), and SDO/s against the
// ping-pong divided by the frames one SDO needs at least (an SDO is a write of SM0 and at least
// one read of SM1: two round trips). Needs root (netns, AF_PACKET); exits 0 with a note when
// that is impossible, so the `bench` label does not fail on a machine without it.
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <sched.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>

#include "protocol/ethercat/master.hpp"
#include "protocol/ethercat/raw_link.hpp"
#include "tests/ethercat/master_test_slave.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;

std::string g_ns;
std::string g_a;
std::string g_b;

int run(const std::string& command) {
  return std::system((command + " >/dev/null 2>&1").c_str());
}

void remove_namespace() {
  if (!g_ns.empty()) run("ip netns del " + g_ns);
}

// The namespace and the pair; false (with the reason printed) when they cannot be made.
bool make_veth() {
  const int pid = static_cast<int>(::getpid());
  g_ns = fmt::format("dcbench{}", pid);
  g_a = fmt::format("dcba{}", pid % 100000);
  g_b = fmt::format("dcbb{}", pid % 100000);
  if (run("ip netns add " + g_ns) != 0) {
    fmt::print("ethercat_veth_bench: cannot create a network namespace (not root?): skipped\n");
    g_ns.clear();
    return false;
  }
  std::atexit(remove_namespace);
  if (run(fmt::format("ip -n {} link add {} type veth peer name {}", g_ns, g_a, g_b)) != 0 ||
      run(fmt::format("ip -n {} link set {} up", g_ns, g_a)) != 0 ||
      run(fmt::format("ip -n {} link set {} up", g_ns, g_b)) != 0) {
    fmt::print("ethercat_veth_bench: cannot create a veth pair: skipped\n");
    return false;
  }
  const int target = ::open(("/var/run/netns/" + g_ns).c_str(), O_RDONLY | O_CLOEXEC);
  if (target < 0 || ::setns(target, CLONE_NEWNET) != 0) {
    fmt::print("ethercat_veth_bench: cannot enter namespace {}: skipped\n", g_ns);
    return false;
  }
  ::close(target);
  // Carrier: the pair needs a moment after `up`.
  for (int i = 0; i < 300; ++i) {
    auto a = RawLink::open(g_a);
    auto b = RawLink::open(g_b);
    if (a && b) return true;
    std::this_thread::sleep_for(10ms);
  }
  fmt::print("ethercat_veth_bench: the veth pair did not come up: skipped\n");
  return false;
}

// End b: every frame back, processed by `slave` first when there is one.
class PeerEnd {
 public:
  PeerEnd(Link& link, test::TestSlave* slave) : link_(link), slave_(slave) {
    thread_ = std::thread([this] { serve(); });
  }
  ~PeerEnd() {
    stop_ = true;
    thread_.join();
  }
  PeerEnd(const PeerEnd&) = delete;
  PeerEnd& operator=(const PeerEnd&) = delete;

 private:
  void serve() {
    while (!stop_) {
      auto request = link_.receive(link_.now() + 20ms);
      if (!request) continue;
      if (slave_ != nullptr) slave_->on_frame(request->bytes, link_.now(), std::nullopt);
      (void)link_.send(request->bytes);
    }
  }
  Link& link_;
  test::TestSlave* slave_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

double g_ping_pong_per_s = 0;
double g_sdo_per_s = 0;
double g_sdo_frames_per_s = 0;
double g_frames_per_sdo = 0;

void raw_ping_pong(benchmark::State& state) {
  auto master = RawLink::open(g_a);
  auto peer = RawLink::open(g_b);
  if (!master || !peer) {
    state.SkipWithError("cannot open the veth ends");
    return;
  }
  PeerEnd end(**peer, nullptr);
  Frame frame;
  frame.source = {0x02, 0, 0, 0, 0, 1};
  frame.datagrams = {
      Datagram::physical(Command::fprd, 0, 0x1001, 0x1080, std::vector<std::uint8_t>(128))};
  const auto bytes = *encode_frame(frame);
  std::int64_t trips = 0;
  for (auto _ : state) {
    if ((*master)->send(bytes)) {
      state.SkipWithError("send failed");
      return;
    }
    auto back = (*master)->receive((*master)->now() + 1s);
    if (!back) {
      state.SkipWithError("a frame did not come back within 1 s");
      return;
    }
    benchmark::DoNotOptimize(back);
    ++trips;
  }
  state.counters["round trips/s"] =
      benchmark::Counter(static_cast<double>(trips), benchmark::Counter::kIsRate);
}

void coe_sdo_upload(benchmark::State& state) {
  auto master_link = RawLink::open(g_a);
  auto peer = RawLink::open(g_b);
  if (!master_link || !peer) {
    state.SkipWithError("cannot open the veth ends");
    return;
  }
  test::TestSlave slave;
  PeerEnd end(**peer, &slave);
  MasterConfig config;
  config.port.response_timeout = 200ms;
  config.scan.expected_slaves = 1;
  // The emulated slave answers within the frame that wrote SM0; the master's pause between two
  // SM1 polls is not wanted on a link whose round trip is the pause.
  config.mailbox.poll_interval = std::chrono::microseconds(0);
  Master master(**master_link, config);
  if (auto up = master.bring_up(AlState::preop); !up) {
    state.SkipWithError(up.error().message().c_str());
    return;
  }
  const auto frames_before = (*master_link)->stats().frames_sent;
  std::int64_t transfers = 0;
  for (auto _ : state) {
    auto value = master.sdo_upload(0, {0x1018, 1});
    if (!value) {
      state.SkipWithError(value.error().message().c_str());
      return;
    }
    benchmark::DoNotOptimize(value);
    ++transfers;
  }
  const double frames = static_cast<double>((*master_link)->stats().frames_sent - frames_before);
  state.counters["SDO/s"] =
      benchmark::Counter(static_cast<double>(transfers), benchmark::Counter::kIsRate);
  state.counters["frames/s"] = benchmark::Counter(frames, benchmark::Counter::kIsRate);
  state.counters["frames/SDO"] = frames / static_cast<double>(transfers);
}

BENCHMARK(raw_ping_pong)->UseRealTime()->MinTime(2.0);
BENCHMARK(coe_sdo_upload)->UseRealTime()->MinTime(2.0);

// Keeps the last run's rates for the summary.
class Summary : public benchmark::ConsoleReporter {
 public:
  Summary() : ConsoleReporter(OO_Tabular) {}
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const Run& run : runs) {
      const auto value = [&](const char* name) {
        const auto it = run.counters.find(name);
        return it == run.counters.end() ? 0.0 : static_cast<double>(it->second);
      };
      if (run.benchmark_name().find("raw_ping_pong") != std::string::npos)
        g_ping_pong_per_s = value("round trips/s");
      if (run.benchmark_name().find("coe_sdo_upload") != std::string::npos) {
        g_sdo_per_s = value("SDO/s");
        g_sdo_frames_per_s = value("frames/s");
        g_frames_per_sdo = value("frames/SDO");
      }
    }
    ConsoleReporter::ReportRuns(runs);
  }
};

}  // namespace
}  // namespace drivecheck::ethercat

int main(int argc, char** argv) {
  using namespace drivecheck::ethercat;
  benchmark::Initialize(&argc, argv);
  if (!make_veth()) return 0;
  Summary reporter;
  benchmark::RunSpecifiedBenchmarks(&reporter);
  benchmark::Shutdown();
  if (g_ping_pong_per_s > 0 && g_sdo_per_s > 0) {
    fmt::print(
        "veth, same run: raw ping-pong {:.0f} round trips/s; CoE SDO {:.0f}/s at {:.2f} "
        "frames each = {:.0f} frame round trips/s\n"
        "  SDO path frames vs ping-pong: {:.1f} % (issue 20 asks >= 90 %)\n"
        "  SDO/s vs ping-pong / {:.0f} (the frames an SDO needs at least): {:.1f} %\n",
        g_ping_pong_per_s, g_sdo_per_s, g_frames_per_sdo, g_sdo_frames_per_s,
        100.0 * g_sdo_frames_per_s / g_ping_pong_per_s, 2.0,
        100.0 * g_sdo_per_s / (g_ping_pong_per_s / 2.0));
  }
  return 0;
}
