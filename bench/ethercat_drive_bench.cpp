// The reference drive as an emulated EtherCAT slave on the simulated segment (issue 20: CoE
// expedited SDO at least 200 k/s; one drive in CSP at 1 kHz at least 200x real time). Rates
// are per CPU second of the benchmark thread.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdint>
#include <vector>

#include "protocol/ethercat/coe_sdo_client.hpp"
#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/mailbox.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "reference_drive/ethercat/ethercat_drive.hpp"
#include "reference_drive/ethercat/sii_image.hpp"

namespace drivecheck::reference_drive::ethercat {
namespace {

namespace ecat = drivecheck::ethercat;
using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

struct Rig {
  ecat::SimSegment segment;
  std::unique_ptr<EthercatDrive> drive;

  Rig() {
    drive = std::move(*EthercatDrive::create(segment));
    segment.attach(*drive);
    drive->power_on();
    Bytes sms = ecat::sync_manager_block(kMailboxOutStart, kMailboxSize, kSm0Control);
    const Bytes sm1 = ecat::sync_manager_block(kMailboxInStart, kMailboxSize, kSm1Control);
    sms.insert(sms.end(), sm1.begin(), sm1.end());
    send(ecat::Datagram::physical(ecat::Command::apwr, 0, 0, ecat::reg::kSyncManager, sms));
    send(ecat::Datagram::physical(ecat::Command::apwr, 0, 0, ecat::reg::kAlControl, {2, 0}));
  }
  ecat::Datagram send(ecat::Datagram datagram) {
    ecat::Frame frame;
    frame.datagrams = {std::move(datagram)};
    (void)segment.send(*ecat::encode_frame(frame));
    auto back = segment.receive(ecat::kForever);
    return ecat::decode_frame(back->bytes)->datagrams.at(0);
  }
};

// Expedited upload of 6041h: APWR SM0 (request), APRD SM1 (reply), client and mailbox master.
void coe_expedited_upload(benchmark::State& state) {
  Rig rig;
  ecat::MailboxMaster mailbox({.write_size = kMailboxSize, .address = 0, .reply_timeout = 1s});
  ecat::CoeSdoClient client({.write_size = kMailboxSize, .expedited = true});
  std::int64_t transfers = 0;
  for (auto _ : state) {
    const Bytes request = mailbox.request(ecat::MailboxType::coe, client.start_upload({0x6041, 0}),
                                          rig.segment.now().time_since_epoch());
    rig.send(ecat::Datagram::physical(ecat::Command::apwr, 0, 0, kMailboxOutStart, request));
    const auto reply = rig.send(
        ecat::Datagram::physical(ecat::Command::aprd, 0, 0, kMailboxInStart, Bytes(kMailboxSize)));
    auto accepted = mailbox.accept(reply.data);
    const auto step = client.on_response(accepted->message.data);
    mailbox.reply_matched();
    if (!step.done || step.error) state.SkipWithError("upload failed");
    ++transfers;
  }
  state.counters["SDO/s"] =
      benchmark::Counter(static_cast<double>(transfers), benchmark::Counter::kIsRate);
}
BENCHMARK(coe_expedited_upload);

// CSP at 1 kHz in OP: per simulated millisecond the drive's cycle runs and one LRW carries
// controlword + 607Ah out, statusword + 6064h in. Counter: simulated seconds per CPU second.
void csp_1khz(benchmark::State& state) {
  Rig rig;
  const auto download = [&rig](std::uint16_t index, std::uint8_t sub, Bytes value) {
    ecat::MailboxMaster mailbox({.write_size = kMailboxSize, .address = 0, .reply_timeout = 1s});
    ecat::CoeSdoClient client({.write_size = kMailboxSize, .expedited = true});
    (void)mailbox;
    ecat::MailboxHeader header;
    header.type = static_cast<std::uint8_t>(ecat::MailboxType::coe);
    header.counter = static_cast<std::uint8_t>(1 + index % 7);
    rig.send(ecat::Datagram::physical(
        ecat::Command::apwr, 0, 0, kMailboxOutStart,
        ecat::build_mailbox(header, client.start_download({index, sub}, value), kMailboxSize)));
    rig.send(
        ecat::Datagram::physical(ecat::Command::aprd, 0, 0, kMailboxInStart, Bytes(kMailboxSize)));
  };
  download(0x1C32, 1, {1, 0});
  download(0x6060, 0, {8});
  Bytes sms = ecat::sync_manager_block(kOutputsStart, 6, kSm2Control);
  const Bytes sm3 = ecat::sync_manager_block(kInputsStart, 6, kSm3Control);
  sms.insert(sms.end(), sm3.begin(), sm3.end());
  rig.send(ecat::Datagram::physical(ecat::Command::apwr, 0, 0, ecat::reg::sync_manager(2), sms));
  rig.send(ecat::Datagram::physical(ecat::Command::apwr, 0, 0, ecat::reg::kFmmu,
                                    {0, 0, 1, 0, 6, 0, 0, 7, 0x00, 0x11, 0, 2, 1, 0, 0, 0,  //
                                     6, 0, 1, 0, 6, 0, 0, 7, 0x00, 0x14, 0, 1, 1, 0, 0, 0}));
  rig.send(ecat::Datagram::physical(ecat::Command::apwr, 0, 0, ecat::reg::kAlControl, {4, 0}));
  Bytes data(12);
  const auto cycle = [&](std::uint16_t controlword, std::int32_t target) {
    data.assign(12, 0);
    data[0] = static_cast<std::uint8_t>(controlword);
    data[1] = static_cast<std::uint8_t>(controlword >> 8);
    for (int b = 0; b < 4; ++b)
      data[2 + b] = static_cast<std::uint8_t>(target >> (8 * b));
    rig.segment.run_for(1ms);
    return rig.send(ecat::Datagram::logical(ecat::Command::lrw, 0, 0x10000, data));
  };
  cycle(0, 0);
  rig.send(ecat::Datagram::physical(ecat::Command::apwr, 0, 0, ecat::reg::kAlControl, {8, 0}));
  for (std::uint16_t cw : {0x0006, 0x0007, 0x000F}) {
    for (int i = 0; i < 20; ++i)
      cycle(cw, 0);
  }
  const auto inputs = cycle(0x000F, 0).data;
  if ((inputs.at(6) & 0x6F) != 0x27)
    state.SkipWithError("the drive did not reach OPERATION ENABLED");
  std::int32_t target = 0;
  std::int64_t cycles = 0;
  for (auto _ : state) {
    target += 10;
    benchmark::DoNotOptimize(cycle(0x000F, target));
    ++cycles;
  }
  state.counters["x real time"] =
      benchmark::Counter(static_cast<double>(cycles) * 1e-3, benchmark::Counter::kIsRate);
}
BENCHMARK(csp_1khz);

}  // namespace
}  // namespace drivecheck::reference_drive::ethercat
