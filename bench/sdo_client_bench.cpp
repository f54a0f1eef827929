// SDO client throughput on the simulated bus, against a scripted server (tests/support).
//
//  - BM_SdoExpeditedUpload: expedited SDO reads (request + answer) per wall-clock second,
//    blocking client <-> scripted server, whole network simulated (target >= 1,000,000/s).
//    Wall time (UseRealTime) suffers when other processes share the core: compare the CPU
//    column, which is the same work on one core.
//  - BM_SdoTransferStateMachine: the same transaction through the client state machine alone
//    (encode, decode, checks), without a bus: the protocol code's share of the cost.
//  - BM_SdoBlockUpload64KiB{Worst,Exact}Stuffing: a 64 KiB block upload at 1 Mbit/s (blksize 127,
//    CRC on). Counters: payload bytes per simulated second, and that rate as a share of the
//    wire limit for SDO block segments: 7 payload bytes per 8-byte frame, each frame 135 bits
//    with worst-case stuffing (11-bit id, intermission included) -> 51,852 B/s at 1 Mbit/s
//    (target >= 95%). With exact stuffing frames are shorter, so the share can exceed 100%.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "protocol/can/frame_timing.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "tests/support/scripted_peer.hpp"

namespace drivecheck::cia301 {
namespace {

constexpr std::uint32_t kBitrate = 1'000'000;
constexpr Multiplexer k6064{0x6064, 0x00};  // position actual value
constexpr Multiplexer k1F51{0x1F51, 0x01};  // a program download area: a big domain

void fail_on_mismatch(test_support::ScriptedPeer& peer, benchmark::State& state) {
  peer.set_mismatch_handler(
      [&state](const std::string& text) { state.SkipWithError(text.c_str()); });
}

void BM_SdoExpeditedUpload(benchmark::State& state) {
  can::SimBus bus({.bitrate = kBitrate});
  auto master = bus.attach("master");
  auto server = bus.attach("server");
  test_support::ScriptedPeer peer(*server, {0x605});
  peer.set_repeat(true);
  peer.set_transcript(false);
  fail_on_mismatch(peer, state);
  // ccs=2, index 6064h sub 0 → scs=2 n=0 e=1 s=1, data 00012345h
  peer.expect(encode(InitiateUploadRequest{k6064}, 0x605))
      .reply(encode(InitiateUploadResponse::make_expedited(
                        k6064, std::vector<std::uint8_t>{0x45, 0x23, 0x01, 0x00}),
                    0x585));
  SdoClient client(*master, 5);
  for (auto _ : state) {
    auto value = client.upload(k6064);
    if (!value) {
      state.SkipWithError(value.error().message().c_str());
      break;
    }
    benchmark::DoNotOptimize(value);
  }
  state.counters["transactions/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SdoExpeditedUpload)->UseRealTime();

void BM_SdoTransferStateMachine(benchmark::State& state) {
  SdoClientTransfer transfer(5);
  const can::Frame answer = encode(
      InitiateUploadResponse::make_expedited(k6064, std::vector<std::uint8_t>{1, 2, 3, 4}), 0x585);
  can::TimePoint now{};
  for (auto _ : state) {
    benchmark::DoNotOptimize(transfer.start_upload(k6064, now));
    now += std::chrono::microseconds(250);
    benchmark::DoNotOptimize(transfer.on_frame(answer, now));
    if (!transfer.succeeded()) state.SkipWithError("transfer failed");
  }
  state.counters["transactions/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SdoTransferStateMachine)->UseRealTime();

// The server's side of a block upload of `data` with CRC, every sub-block of 127 segments.
void script_block_upload(test_support::ScriptedPeer& peer, const std::vector<std::uint8_t>& data) {
  constexpr std::uint8_t kBlockSize = kSdoMaxBlockSize;
  peer.expect(encode(BlockUploadInitiateRequest{k1F51, true, kBlockSize, 0}, 0x605))
      .reply(encode(
          BlockUploadInitiateResponse{k1F51, true, true, static_cast<std::uint32_t>(data.size())},
          0x585));
  peer.expect(encode(BlockUploadStart{}, 0x605));
  std::size_t at = 0;
  std::uint8_t seqno = 0;
  while (at < data.size()) {
    const std::size_t length = std::min<std::size_t>(7, data.size() - at);
    const bool last = at + length == data.size();
    ++seqno;
    peer.reply(encode(BlockSegment::make(seqno, last, std::span(data).subspan(at, length)), 0x585));
    at += length;
    if (seqno == kBlockSize || last) {
      peer.expect(encode(BlockUploadAck{seqno, kBlockSize}, 0x605));
      seqno = 0;
    }
  }
  const auto unused = static_cast<std::uint8_t>((7 - data.size() % 7) % 7);
  peer.reply(encode(BlockUploadEndRequest{unused, crc16_ccitt(data)}, 0x585));
  peer.expect(encode(BlockUploadEndResponse{}, 0x605));
}

void block_upload(benchmark::State& state, can::BitStuffing stuffing) {
  can::SimBus bus({.bitrate = kBitrate, .stuffing = stuffing});
  auto master = bus.attach("master");
  auto server = bus.attach("server");
  std::vector<std::uint8_t> data(64 * 1024);
  std::iota(data.begin(), data.end(), std::uint8_t{0});
  test_support::ScriptedPeer peer(*server, {0x605});
  peer.set_repeat(true);
  peer.set_transcript(false);
  fail_on_mismatch(peer, state);
  script_block_upload(peer, data);
  SdoClient client(*master, 5);

  can::Duration simulated{0};
  for (auto _ : state) {
    const can::TimePoint start = bus.now();
    auto result = client.upload(k1F51, SdoTransferMode::block);
    simulated += bus.now() - start;
    if (!result || result->size() != data.size()) {
      state.SkipWithError(result ? "wrong size" : result.error().message().c_str());
      break;
    }
  }
  const double seconds = std::chrono::duration<double>(simulated).count();
  const double bytes = static_cast<double>(data.size()) * static_cast<double>(state.iterations());
  const double rate = seconds > 0 ? bytes / seconds : 0;
  // The wire limit: 7 payload bytes per 8-byte SDO segment frame, worst-case stuffed.
  const can::Frame segment = can::Frame::standard(0x585, {0, 0, 0, 0, 0, 0, 0, 0});
  const double frame_seconds =
      static_cast<double>(can::frame_bits(segment, can::BitStuffing::worst_case)) / kBitrate;
  const double limit = 7.0 / frame_seconds;
  state.counters["payload_B_per_sim_s"] = rate;
  state.counters["wire_limit_B_per_s"] = limit;
  state.counters["share_of_limit_pct"] = 100.0 * rate / limit;
  state.counters["sim_ms_per_upload"] =
      seconds * 1000.0 /
      static_cast<double>(std::max<benchmark::IterationCount>(1, state.iterations()));
}

void BM_SdoBlockUpload64KiBWorstStuffing(benchmark::State& state) {
  block_upload(state, can::BitStuffing::worst_case);
}
BENCHMARK(BM_SdoBlockUpload64KiBWorstStuffing)->Unit(benchmark::kMillisecond);

void BM_SdoBlockUpload64KiBExactStuffing(benchmark::State& state) {
  block_upload(state, can::BitStuffing::exact);
}
BENCHMARK(BM_SdoBlockUpload64KiBExactStuffing)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace drivecheck::cia301
