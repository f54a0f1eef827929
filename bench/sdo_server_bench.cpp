// SDO server throughput (protocol/cia301/sdo_server.hpp): SDO transactions per wall second
// between our SdoClient and the server on the simulated bus (target: >= 500,000 expedited
// transactions/s on one core), and the server state machine alone.
//
//   items_per_second = completed SDO transactions (request + answer) per wall second
//   bytes_per_second = payload bytes per wall second (block transfers)
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/cia301/sdo_server.hpp"

namespace drivecheck::cia301 {
namespace {

constexpr std::uint8_t kNode = 5;

void populate(ObjectDictionary& od) {
  static_cast<void>(od.add_var(0x6040, "controlword", DataType::unsigned16, AccessType::rww));
  static_cast<void>(od.add_var(0x6041, "statusword", DataType::unsigned16, AccessType::ro,
                               Value::of_unsigned(0x0237)));
  static_cast<void>(od.add_var(0x2000, "domain", DataType::domain, AccessType::rw));
}

// A drive (the server on its own port) and a master (SdoClient on another) on one SimBus.
struct Network {
  Network()
      : drive_port(bus.attach("drive")),
        master_port(bus.attach("master")),
        server(od, SdoServerConfig::for_node(kNode)),
        runner(*drive_port, server),
        client(*master_port, kNode) {
    populate(od);
    runner.attach();
  }

  can::SimBus bus;
  std::unique_ptr<can::SimPort> drive_port;
  std::unique_ptr<can::SimPort> master_port;
  ObjectDictionary od{kNode};
  SdoServer server;
  SdoServerRunner runner;
  SdoClient client;
};

void BM_ExpeditedUploadOnSimBus(benchmark::State& state) {
  Network net;
  for (auto _ : state) {
    auto value = net.client.upload_value<std::uint16_t>({0x6041, 0});
    if (!value) state.SkipWithError("upload failed");
    benchmark::DoNotOptimize(value);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}
BENCHMARK(BM_ExpeditedUploadOnSimBus)->UseRealTime();

void BM_ExpeditedDownloadOnSimBus(benchmark::State& state) {
  Network net;
  std::uint16_t value = 0;
  for (auto _ : state) {
    auto written = net.client.download_value<std::uint16_t>({0x6040, 0}, ++value);
    if (!written) state.SkipWithError("download failed");
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}
BENCHMARK(BM_ExpeditedDownloadOnSimBus)->UseRealTime();

// The server alone: an expedited read request in, the answer out (decode, OD lookup, encode).
void BM_ServerExpeditedUploadStateMachine(benchmark::State& state) {
  ObjectDictionary od(kNode);
  populate(od);
  SdoServer server(od, SdoServerConfig::for_node(kNode));
  const can::Frame request = encode(InitiateUploadRequest{{0x6041, 0}}, kSdoRequestBase + kNode);
  can::TimePoint now{};
  for (auto _ : state) {
    now += std::chrono::microseconds(250);
    auto answer = server.on_frame(request, now);
    benchmark::DoNotOptimize(answer.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}
BENCHMARK(BM_ServerExpeditedUploadStateMachine);

void BM_ServerExpeditedDownloadStateMachine(benchmark::State& state) {
  ObjectDictionary od(kNode);
  populate(od);
  SdoServer server(od, SdoServerConfig::for_node(kNode));
  const std::uint8_t data[2] = {0x0F, 0x00};
  const can::Frame request =
      encode(InitiateDownloadRequest::make_expedited({0x6040, 0}, data), kSdoRequestBase + kNode);
  can::TimePoint now{};
  for (auto _ : state) {
    now += std::chrono::microseconds(250);
    auto answer = server.on_frame(request, now);
    benchmark::DoNotOptimize(answer.data());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
}
BENCHMARK(BM_ServerExpeditedDownloadStateMachine);

// Block and segmented transfers of `size` bytes on the simulated bus.
void BM_BlockDownloadOnSimBus(benchmark::State& state) {
  Network net;
  const std::vector<std::uint8_t> data(static_cast<std::size_t>(state.range(0)), 0x5A);
  for (auto _ : state) {
    if (!net.client.download({0x2000, 0}, data, SdoTransferMode::block)) {
      state.SkipWithError("download failed");
    }
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(0));
}
BENCHMARK(BM_BlockDownloadOnSimBus)->Arg(1024)->UseRealTime();

void BM_SegmentedUploadOnSimBus(benchmark::State& state) {
  Network net;
  const std::vector<std::uint8_t> data(static_cast<std::size_t>(state.range(0)), 0xA5);
  static_cast<void>(net.od.find(0x2000, 0)->assign_bytes(data));
  for (auto _ : state) {
    auto read = net.client.upload({0x2000, 0});
    if (!read) state.SkipWithError("upload failed");
    benchmark::DoNotOptimize(read);
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * state.range(0));
}
BENCHMARK(BM_SegmentedUploadOnSimBus)->Arg(1024)->UseRealTime();

}  // namespace
}  // namespace drivecheck::cia301
