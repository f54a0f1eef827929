// The master subset against emulated slaves (EscSlave + CoeSlave over a small dictionary) on
// the simulated segment: bring-up to OP, SDO through mailbox polling, cyclic LRW, and the
// error cases (refused transition, slave missing, SII stuck busy or malformed, lost frames,
// wrong working counter, SM watchdog expiry).
#include "protocol/ethercat/master.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <vector>

#include "protocol/ethercat/sim_segment.hpp"
#include "tests/ethercat/master_test_slave.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;
using test::drive_sii;
using test::drive_sii_image;
using test::kInputs;
using test::kSm0;
using test::kSm1;
using test::SlaveOptions;
using test::TestSlave;

// Whether the frame holds a datagram with `command` at register/offset `ado`.
bool has_datagram(std::span<const std::uint8_t> bytes, Command command, std::uint16_t ado) {
  auto frame = decode_frame(bytes);
  if (!frame) return false;
  for (const Datagram& d : frame->datagrams) {
    if (d.command == command && d.ado() == ado) return true;
  }
  return false;
}

class MasterRig {
 public:
  explicit MasterRig(std::size_t count, SlaveOptions options = {}) {
    for (std::size_t i = 0; i < count; ++i) {
      SlaveOptions o = options;
      if (o.alias == 0) o.alias = static_cast<std::uint16_t>(0x0100 + i);
      slaves.push_back(std::make_unique<TestSlave>(o));
      segment.attach(*slaves.back());
    }
  }
  Master make_master(std::optional<std::size_t> expected = std::nullopt) {
    MasterConfig config;
    config.scan.expected_slaves = expected;
    return Master(segment, config);
  }

  SimSegment segment;
  std::vector<std::unique_ptr<TestSlave>> slaves;
};

TEST(MasterBringUp, OneSlaveReachesOpAndExchangesProcessData) {
  // Given one emulated drive on the segment
  MasterRig rig(1);
  Master master = rig.make_master(1);
  // When the master brings it up to OP and runs a cycle with outputs 000Fh and inputs 0237h
  const auto up = master.bring_up(AlState::op);
  ASSERT_TRUE(up) << up.error().message();
  rig.slaves[0]->set_inputs({0x37, 0x02});
  master.outputs(0)[0] = 0x0F;
  const auto cycle = master.cycle();
  // Then the slave is in OP at station 1001h, and the cycle moved both directions with WKC 3
  ASSERT_TRUE(cycle) << cycle.error().message();
  EXPECT_EQ(cycle->wkc, 3);
  EXPECT_EQ(cycle->expected_wkc, 3);
  EXPECT_EQ(rig.slaves[0]->esc_slave().al_status().state, AlState::op);
  EXPECT_EQ(master.slaves()[0].info.station, 0x1001);
  EXPECT_EQ(master.slaves()[0].info.alias, 0x0100);
  EXPECT_EQ(master.slaves()[0].sii.image.header.vendor_id, 0x1Du);
  EXPECT_EQ(rig.slaves[0]->outputs(), (Bytes{0x0F, 0x00}));
  EXPECT_EQ(Bytes(master.inputs(0).begin(), master.inputs(0).end()), (Bytes{0x37, 0x02}));
}

TEST(MasterBringUp, MappedObjectsAreFoundByTheSiiPdoList) {
  // Given a drive in OP whose SII maps 6040h in its RxPDO and 6041h in its TxPDO
  MasterRig rig(1);
  Master master = rig.make_master(1);
  ASSERT_TRUE(master.bring_up(AlState::op));
  rig.slaves[0]->set_inputs({0x37, 0x02});
  // When the master sets the controlword 000Fh by its object and cycles
  ASSERT_TRUE(master.set_output(0, {0x6040, 0}, 0x000F));
  ASSERT_TRUE(master.cycle());
  // Then the slave has the controlword, the statusword reads 0237h, and unmapped objects or
  // inputs as outputs are refused
  EXPECT_EQ(rig.slaves[0]->outputs(), (Bytes{0x0F, 0x00}));
  EXPECT_EQ(master.input(0, {0x6041, 0}), 0x0237u);
  EXPECT_EQ(master.input(0, {0x6040, 0}), 0x000Fu);
  EXPECT_FALSE(master.set_output(0, {0x6041, 0}, 1));
  EXPECT_FALSE(master.locate(0, {0x6064, 0}));
  const auto place = master.locate(0, {0x6041, 0});
  ASSERT_TRUE(place);
  EXPECT_FALSE(place->outputs);
  EXPECT_EQ(place->bit_offset, 0u);
  EXPECT_EQ(place->bit_length, 16);
}

TEST(MasterConfigPlan, BitsAreReadAndWrittenAtAnyOffset) {
  // Given three zero bytes
  Bytes bytes(3, 0);
  // When 11 bits of 5A5h are written at bit 5 and read back
  set_bits(bytes, 5, 11, 0x5A5);
  // Then they read back unchanged and no other bit is set
  EXPECT_EQ(get_bits(bytes, 5, 11), 0x5A5u);
  EXPECT_EQ(get_bits(bytes, 0, 5), 0u);
  EXPECT_EQ(get_bits(bytes, 16, 8), 0u);
  EXPECT_EQ(bytes, (Bytes{0xA0, 0xB4, 0x00}));
}

TEST(MasterBringUp, ThreeSlavesGetAddressesAliasesAndTheSumOfWorkingCounters) {
  // Given three drives with aliases 0100h..0102h
  MasterRig rig(3);
  Master master = rig.make_master(3);
  // When the master brings them up to OP and cycles
  const auto up = master.bring_up(AlState::op);
  ASSERT_TRUE(up) << up.error().message();
  const auto cycle = master.cycle();
  // Then each has its own station address and alias, each is in OP, and the LRW counts 3 x 3
  ASSERT_TRUE(cycle) << cycle.error().message();
  EXPECT_EQ(cycle->wkc, 9);
  EXPECT_EQ(cycle->al_wkc, 3);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(master.slaves()[i].info.station, 0x1001 + i);
    EXPECT_EQ(master.slaves()[i].info.alias, 0x0100 + i);
    EXPECT_EQ(rig.slaves[i]->esc_slave().al_status().state, AlState::op);
  }
  // And each slave's outputs land in its own SM2
  master.outputs(1)[0] = 0xAB;
  master.outputs(2)[1] = 0xCD;
  ASSERT_TRUE(master.cycle());
  EXPECT_EQ(rig.slaves[0]->outputs(), (Bytes{0x00, 0x00}));
  EXPECT_EQ(rig.slaves[1]->outputs(), (Bytes{0xAB, 0x00}));
  EXPECT_EQ(rig.slaves[2]->outputs(), (Bytes{0x00, 0xCD}));
}

TEST(MasterBringUp, GoesBackDownAndUpAgain) {
  // Given a slave in OP
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::op));
  // When the master requests PREOP, then OP again
  ASSERT_TRUE(master.request_state(AlState::preop));
  EXPECT_EQ(rig.slaves[0]->esc_slave().al_status().state, AlState::preop);
  const auto again = master.request_state(AlState::op);
  // Then the slave is in OP again and cycles
  ASSERT_TRUE(again) << again.error().message();
  EXPECT_EQ(rig.slaves[0]->esc_slave().al_status().state, AlState::op);
  EXPECT_TRUE(master.cycle());
}

TEST(MasterSdo, MailboxCountersRestartWithTheSlaveAfterInit) {
  // Given a slave in PREOP that answered one SDO (its reply counter is at 1)
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  ASSERT_TRUE(master.sdo_upload(0, {0x1018, 1}));
  // When the master takes it to INIT and back to PREOP (the slave's mailbox handler stops and
  // starts again: its counters restart) and reads again
  ASSERT_TRUE(master.request_state(AlState::init));
  ASSERT_TRUE(master.request_state(AlState::preop));
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  // Then the reply with the restarted counter 1 is taken as new, not dropped as a duplicate,
  // and the master's next request starts the sequence again at 1
  ASSERT_TRUE(vendor) << vendor.error().message();
  EXPECT_EQ(*vendor, (Bytes{0x1D, 0, 0, 0}));
  EXPECT_EQ(master.mailbox(0)->protocol().last_request_counter(), 1);
  // And the same through the per-slave request
  ASSERT_TRUE(master.request_state(0, AlState::init));
  ASSERT_TRUE(master.request_state(0, AlState::preop));
  const auto again = master.sdo_upload(0, {0x1018, 1});
  ASSERT_TRUE(again) << again.error().message();
}

// An input-only slave without mailbox: SM0 holds one byte of inputs (TxPDO 1A00h, 8 bit).
Bytes input_only_sii() {
  SiiImage image;
  image.sync_managers = {{0x1000, 1, 0x00, 0, 1, SiiSyncManagerType::inputs}};
  image.tx_pdos = {{0x1A00, 0, 0, 0, 0, {{0x6000, 1, 0, 5, 8, 0}}}};
  return *build_sii(image);
}

TEST(MasterBringUp, MixedSegmentWithAnInputOnlySlaveWithoutMailbox) {
  // Given a drive and an input-only slave without mailbox behind it
  MasterRig rig(1);
  SlaveOptions io_options;
  io_options.sii = input_only_sii();
  TestSlave io(io_options);
  rig.segment.attach(io);
  Master master = rig.make_master(2);
  // When the master brings both up to OP and cycles with the input byte 5Ah
  const auto up = master.bring_up(AlState::op);
  ASSERT_TRUE(up) << up.error().message();
  ASSERT_TRUE(io.esc_slave().esc().pdi_write8(0x1000, 0x5A));
  const auto cycle = master.cycle();
  // Then the LRW counts 3 + 1, the input arrives, and SDO to the slave without mailbox says so
  ASSERT_TRUE(cycle) << cycle.error().message();
  EXPECT_EQ(cycle->wkc, 4);
  EXPECT_EQ(cycle->expected_wkc, 4);
  EXPECT_TRUE(master.outputs(1).empty());
  ASSERT_EQ(master.inputs(1).size(), 1u);
  EXPECT_EQ(master.inputs(1)[0], 0x5A);
  EXPECT_EQ(master.input(1, {0x6000, 1}), 0x5Au);
  EXPECT_EQ(io.esc_slave().al_status().state, AlState::op);
  const auto sdo = master.sdo_upload(1, {0x1018, 1});
  ASSERT_FALSE(sdo);
  EXPECT_EQ(sdo.error().code, MasterErrc::not_configured);
}

TEST(MasterSdo, ExpeditedAndSegmentedTransfersThroughMailboxPolling) {
  // Given a slave in PREOP
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  // When the master reads 1018h:01, writes 6040h and reads it back, reads the 40-octet 1008h
  // and writes and reads 300 octets of the domain 2000h (segments: the mailbox is 128)
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  const Bytes control{0x0F, 0x00};
  const auto written = master.sdo_download(0, {0x6040, 0}, control);
  const auto control_back = master.sdo_upload(0, {0x6040, 0});
  const auto name = master.sdo_upload(0, {0x1008, 0});
  Bytes blob(300);
  for (std::size_t i = 0; i < blob.size(); ++i)
    blob[i] = static_cast<std::uint8_t>(i * 3);
  const auto blob_written = master.sdo_download(0, {0x2000, 0}, blob);
  const auto blob_back = master.sdo_upload(0, {0x2000, 0});
  // Then every transfer succeeds with the values of the dictionary
  ASSERT_TRUE(vendor) << vendor.error().message();
  EXPECT_EQ(*vendor, (Bytes{0x1D, 0, 0, 0}));
  ASSERT_TRUE(written) << written.error().message();
  ASSERT_TRUE(control_back);
  EXPECT_EQ(*control_back, control);
  ASSERT_TRUE(name) << name.error().message();
  EXPECT_EQ(*name, Bytes(40, 'N'));
  ASSERT_TRUE(blob_written) << blob_written.error().message();
  ASSERT_TRUE(blob_back) << blob_back.error().message();
  EXPECT_EQ(*blob_back, blob);
}

TEST(MasterSdo, SdoOnTheSecondSlaveWhileCycling) {
  // Given two slaves in OP
  MasterRig rig(2);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::op));
  // When the master writes 6040h on slave 1 between cycles
  ASSERT_TRUE(master.cycle());
  const auto written = master.sdo_download(1, {0x6040, 0}, Bytes{0x06, 0x00});
  ASSERT_TRUE(master.cycle());
  // Then slave 1's dictionary holds it and slave 0's does not
  ASSERT_TRUE(written) << written.error().message();
  EXPECT_EQ(*master.sdo_upload(1, {0x6040, 0}), (Bytes{0x06, 0x00}));
  EXPECT_EQ(*master.sdo_upload(0, {0x6040, 0}), (Bytes{0x00, 0x00}));
}

TEST(MasterSdo, SlaveAbortIsReportedWithItsCode) {
  // Given a slave in PREOP
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  // When the master writes the read-only 1018h:01 and reads the absent 5555h
  const auto written = master.sdo_download(0, {0x1018, 1}, Bytes{1, 0, 0, 0});
  const auto absent = master.sdo_upload(0, {0x5555, 0});
  // Then both end with sdo_abort and the slave's codes 06010002h and 06020000h
  ASSERT_FALSE(written);
  EXPECT_EQ(written.error().code, MasterErrc::sdo_abort);
  EXPECT_EQ(written.error().abort_code, 0x06010002u);
  ASSERT_FALSE(absent);
  EXPECT_EQ(absent.error().abort_code, 0x06020000u);
  // And the mailbox still works afterwards
  EXPECT_TRUE(master.sdo_upload(0, {0x1018, 1}));
}

TEST(MasterSdo, EmergencyReadWhilePollingIsQueued) {
  // Given a slave in PREOP that raised an emergency 8611h
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  rig.slaves[0]->post_emergency(0x8611);
  // When the master reads 1018h:01 (the emergency waits in SM1 before the reply)
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  // Then the upload succeeds and the emergency is queued, once
  ASSERT_TRUE(vendor) << vendor.error().message();
  const auto emergencies = master.take_emergencies(0);
  ASSERT_EQ(emergencies.size(), 1u);
  EXPECT_EQ(emergencies[0].emcy.error_code, 0x8611);
  EXPECT_TRUE(master.take_emergencies(0).empty());
}

TEST(MasterSdo, PollMailboxQueuesAnUnsolicitedEmergency) {
  // Given a slave in OP that raised an emergency 2310h
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::op));
  rig.slaves[0]->post_emergency(0x2310);
  // When the master polls the mailbox
  ASSERT_TRUE(master.poll_mailbox(0));
  // Then the emergency is queued
  const auto emergencies = master.take_emergencies(0);
  ASSERT_EQ(emergencies.size(), 1u);
  EXPECT_EQ(emergencies[0].emcy.error_code, 0x2310);
}

TEST(MasterSdo, LostMailboxReadIsRecoveredByTheRepeatRequest) {
  // Given a slave in PREOP and a segment that loses the next frame reading SM1 after the slave
  // processed it (the reply left SM1 and never reached the master)
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  FrameFaultRule rule;
  rule.match = [](std::span<const std::uint8_t> bytes) {
    return has_datagram(bytes, Command::fprd, kSm1);
  };
  rule.max_count = 1;
  const FaultId fault = rig.segment.drop(rule, 1);
  // When the master reads 1018h:01
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  // Then the reply comes through a repeat request
  EXPECT_EQ(rig.segment.fault_hits(fault), 1u);
  ASSERT_TRUE(vendor) << vendor.error().message();
  EXPECT_EQ(*vendor, (Bytes{0x1D, 0, 0, 0}));
  EXPECT_EQ(master.mailbox(0)->repeat_requests(), 1u);
}

TEST(MasterSdo, LostAnswerToAMailboxWriteIsSentAgainWithTheSameCounter) {
  // Given a slave in PREOP and a segment that loses the answer to the next SM0 write after the
  // slave took the request
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  FrameFaultRule rule;
  rule.match = [](std::span<const std::uint8_t> bytes) {
    return has_datagram(bytes, Command::fpwr, kSm0);
  };
  rule.max_count = 1;
  const FaultId fault = rig.segment.drop(rule, 1);
  // When the master reads 1018h:01
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  // Then the write is sent again (the slave sees a repeat and does not answer twice) and the
  // upload succeeds with one reply
  EXPECT_EQ(rig.segment.fault_hits(fault), 1u);
  ASSERT_TRUE(vendor) << vendor.error().message();
  EXPECT_EQ(*vendor, (Bytes{0x1D, 0, 0, 0}));
  const auto more = master.mailbox(0)->poll();
  ASSERT_TRUE(more);
  EXPECT_FALSE(*more) << "a second reply to the repeated request";
}

TEST(MasterSdo, SlaveThatNeverAnswersTimesOut) {
  // Given a slave in PREOP whose every SM1 read is lost from now on
  MasterRig rig(1);
  MasterConfig config;
  config.mailbox.timeout = 10ms;
  Master master(rig.segment, config);
  ASSERT_TRUE(master.bring_up(AlState::preop));
  FrameFaultRule rule;
  rule.match = [](std::span<const std::uint8_t> bytes) {
    return has_datagram(bytes, Command::fprd, kSm1);
  };
  rig.segment.drop(rule, 0);
  // When the master reads 1018h:01
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  // Then it ends with mailbox_timeout after its repeat requests, never hanging
  ASSERT_FALSE(vendor);
  EXPECT_EQ(vendor.error().code, MasterErrc::mailbox_timeout) << vendor.error().message();
}

TEST(MasterSdo, MailboxErrorReplyIsReadWithItsCode) {
  // Given a slave in PREOP that serves CoE only
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  // When the master sends it a FoE message and reads the reply
  const Bytes foe{0x01, 0x00, 0x00, 0x00};
  ASSERT_TRUE(master.mailbox(0)->send(MailboxType::foe, foe));
  const auto reply = master.mailbox(0)->receive(master.port().now() + 10ms);
  // Then the reply is a mailbox ERR with 0002h (unsupported protocol)
  ASSERT_TRUE(reply) << reply.error().message();
  ASSERT_TRUE(*reply);
  ASSERT_TRUE((*reply)->error);
  EXPECT_EQ(*(*reply)->error, 0x0002);
}

TEST(MasterSdo, RawMailboxIsWrittenExactlyAsGiven) {
  // Given a slave in PREOP with a 128-octet write mailbox
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  // When the master writes a raw buffer whose header Length (200) lies past SM0, and a buffer
  // longer than SM0
  const Bytes lying{0xC8, 0x00, 0x00, 0x00, 0x00, 0x13, 0x00, 0x20, 0x40, 0x00, 0x10, 0x00};
  ASSERT_TRUE(master.mailbox(0)->send_raw(lying));
  const auto reply = master.mailbox(0)->receive(master.port().now() + 10ms);
  const auto too_long = master.mailbox(0)->send_raw(Bytes(129, 0));
  // Then the slave saw the lying Length (ERR 0008h invalid size: the header was not rebuilt),
  // and the long buffer is refused before anything is sent
  ASSERT_TRUE(reply) << reply.error().message();
  ASSERT_TRUE(*reply);
  ASSERT_TRUE((*reply)->error);
  EXPECT_EQ(*(*reply)->error, 0x0008);
  ASSERT_FALSE(too_long);
  EXPECT_EQ(too_long.error().code, MasterErrc::mailbox_error);
}

TEST(MasterSdo, GarbageInTheReadMailboxIsAClearError) {
  // Given a slave in PREOP whose read mailbox holds a header claiming FFFFh octets
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  Bytes garbage(128, 0xA5);
  garbage[0] = 0xFF;
  garbage[1] = 0xFF;
  ASSERT_TRUE(rig.slaves[0]->esc_slave().esc().pdi_put_mailbox(1, garbage));
  // When the master reads 1018h:01
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  // Then it ends with mailbox_error naming the invalid size, and nothing crashes
  ASSERT_FALSE(vendor);
  EXPECT_EQ(vendor.error().code, MasterErrc::mailbox_error);
  EXPECT_NE(vendor.error().detail.find("no valid mailbox"), std::string::npos)
      << vendor.error().detail;
}

TEST(MasterErrors, RefusedTransitionReportsTheAlStatusCodeByName) {
  // Given a slave whose application refuses PS with 001Dh (invalid output configuration)
  SlaveOptions options;
  options.check = [](const AlTransition& t) {
    return t.name == "PS" ? AlStatusCode::invalid_output_configuration : AlStatusCode::no_error;
  };
  MasterRig rig(1, options);
  Master master = rig.make_master();
  // When the master brings it up to OP
  const auto up = master.bring_up(AlState::op);
  // Then it fails with al_refused, the code 001Dh and its name, and the error is acknowledged
  ASSERT_FALSE(up);
  EXPECT_EQ(up.error().code, MasterErrc::al_refused);
  EXPECT_EQ(up.error().al_status_code, 0x001D);
  EXPECT_EQ(up.error().station, 0x1001);
  EXPECT_NE(up.error().message().find("invalid_output_configuration"), std::string::npos)
      << up.error().message();
  const AlStatus& status = rig.slaves[0]->esc_slave().al_status();
  EXPECT_EQ(status.state, AlState::preop);
  EXPECT_FALSE(status.error);
}

TEST(MasterErrors, InvalidStateRequestIsRefusedWithItsCode) {
  // Given a slave in INIT
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::init));
  // When the master asks one slave for BOOT (it has no bootstrap)
  const auto boot = master.request_state(0, AlState::boot);
  // Then the refusal carries 0013h
  ASSERT_FALSE(boot);
  EXPECT_EQ(boot.error().code, MasterErrc::al_refused);
  EXPECT_EQ(boot.error().al_status_code, 0x0013);
}

// Brings up `present` slaves where the configuration expects `expected`: the scan error.
MasterError scan_error(std::size_t present, std::size_t expected) {
  MasterRig rig(present);
  Master master = rig.make_master(expected);
  const auto up = master.bring_up();
  if (up) return {};
  return up.error();
}

TEST(MasterErrors, MissingSlaveIsReported) {
  // Given one slave where the configuration expects two
  // When the master scans
  const MasterError error = scan_error(1, 2);
  // Then the scan says a slave is missing
  EXPECT_EQ(error.code, MasterErrc::slave_count);
  EXPECT_NE(error.detail.find("slave missing"), std::string::npos) << error.detail;
}

TEST(MasterErrors, ExtraSlaveIsReported) {
  // Given three slaves where the configuration expects two
  // When the master scans
  const MasterError error = scan_error(3, 2);
  // Then the scan says there is one too many
  EXPECT_EQ(error.code, MasterErrc::slave_count);
  EXPECT_NE(error.detail.find("extra slave"), std::string::npos) << error.detail;
}

TEST(MasterErrors, EmptySegmentIsALinkError) {
  // Given a segment without slaves (an open port)
  SimSegment segment;
  Master master(segment);
  // When the master scans
  const auto up = master.bring_up();
  // Then the link's refusal is reported
  ASSERT_FALSE(up);
  EXPECT_EQ(up.error().code, MasterErrc::link_error);
  EXPECT_EQ(up.error().link, LinkError::link_down);
}

TEST(MasterErrors, SiiStuckBusyTimesOut) {
  // Given a slave whose EEPROM interface stays busy for an hour after a command
  SlaveOptions options;
  options.sii_busy_time = std::chrono::hours(1);
  MasterRig rig(1, options);
  Master master = rig.make_master();
  // When the master reads its SII
  const auto start = rig.segment.now();
  const auto up = master.bring_up();
  // Then it gives up with sii_timeout after the 100 ms timeout, not an hour
  ASSERT_FALSE(up);
  EXPECT_EQ(up.error().code, MasterErrc::sii_timeout) << up.error().message();
  EXPECT_GE(rig.segment.now() - start, 100ms);
  EXPECT_LT(rig.segment.now() - start, 200ms);
}

TEST(MasterErrors, SiiHeldByThePdiIsAnSiiError) {
  // Given a slave whose application holds the EEPROM (0501h bit 0)
  // (the PDI may take it only while ECAT offers it: 0500h bit 0, written by ECAT)
  MasterRig rig(1);
  Frame offer;
  offer.datagrams = {Datagram::physical(Command::apwr, 0, 0, reg::kSiiConfiguration, {0x01})};
  Bytes bytes = *encode_frame(offer);
  rig.slaves[0]->esc_slave().esc().process_frame(bytes, rig.segment.now());
  ASSERT_TRUE(rig.slaves[0]->esc_slave().esc().pdi_write8(reg::kSiiPdiAccess, 0x01));
  Master master = rig.make_master();
  // When the master reads its SII
  const auto up = master.bring_up();
  // Then it says the PDI holds the EEPROM
  ASSERT_FALSE(up);
  EXPECT_EQ(up.error().code, MasterErrc::sii_error);
  EXPECT_NE(up.error().detail.find("PDI holds"), std::string::npos) << up.error().detail;
}

TEST(MasterErrors, SiiWithoutEndMarkerIsMalformed) {
  // Given a slave whose SII ends inside its category list (the end marker cut off)
  Bytes sii = drive_sii();
  sii.resize(sii.size() - 2);
  SlaveOptions options;
  options.sii = sii;
  MasterRig rig(1, options);
  Master master = rig.make_master();
  // When the master reads it
  const auto up = master.bring_up();
  // Then it is sii_malformed: the list runs past the EEPROM
  ASSERT_FALSE(up);
  EXPECT_EQ(up.error().code, MasterErrc::sii_malformed) << up.error().message();
}

TEST(MasterErrors, SiiWithBadChecksumIsMalformed) {
  // Given a slave whose SII checksum (word 7) is wrong
  Bytes sii = drive_sii();
  sii[14] ^= 0xFF;
  SlaveOptions options;
  options.sii = sii;
  MasterRig rig(1, options);
  Master master = rig.make_master();
  // When the master reads it
  const auto up = master.bring_up();
  // Then the parse error is reported as sii_malformed, naming the checksum
  ASSERT_FALSE(up);
  EXPECT_EQ(up.error().code, MasterErrc::sii_malformed);
  EXPECT_NE(up.error().detail.find("checksum"), std::string::npos) << up.error().detail;
}

TEST(MasterErrors, DroppedFrameIsSentAgain) {
  // Given a segment that loses the first station address write before any slave sees it
  MasterRig rig(2);
  FrameFaultRule rule;
  rule.match = [](std::span<const std::uint8_t> bytes) {
    return has_datagram(bytes, Command::apwr, reg::kStationAddress);
  };
  rule.max_count = 1;
  const FaultId fault = rig.segment.drop(rule, 0);
  Master master = rig.make_master(2);
  // When the master brings the slaves up
  const auto up = master.bring_up(AlState::op);
  // Then the lost frame was sent again and the bring-up succeeded
  ASSERT_TRUE(up) << up.error().message();
  EXPECT_EQ(rig.segment.fault_hits(fault), 1u);
  EXPECT_EQ(master.port().frames_lost(), 1u);
}

TEST(MasterErrors, FramesLostForGoodGiveNoResponse) {
  // Given a slave in OP and a segment that loses every frame from now on
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::op));
  rig.segment.drop(FrameFaultRule{}, 0);
  // When the master reads the AL status
  const auto states = master.read_states();
  // Then it reports no_response after its retries
  ASSERT_FALSE(states);
  EXPECT_EQ(states.error().code, MasterErrc::no_response);
  EXPECT_EQ(master.port().frames_lost(), 4u);
}

TEST(MasterErrors, RandomlyCorruptedAnswersEndInAResultOrAClearError) {
  // Given 100 segments of two slaves, each with its own seed, on which one answer in 20 comes
  // back with one random bit flipped (a device that rewrote the frame and its FCS)
  for (std::uint64_t seed = 1; seed <= 100; ++seed) {
    SimSegment segment({.seed = seed});
    TestSlave a;
    TestSlave b;
    segment.attach(a);
    segment.attach(b);
    FrameFaultRule rule;
    rule.probability = 0.05;
    segment.corrupt(rule);
    MasterConfig config;
    config.al.timeout = 50ms;
    config.mailbox.timeout = 20ms;
    Master master(segment, config);
    // When the master brings them up, reads 1008h (segmented) and cycles 20 times
    std::vector<MasterError> errors;
    if (auto up = master.bring_up(AlState::op); !up) errors.push_back(up.error());
    if (auto name = master.sdo_upload(1, {0x1008, 0}); !name) errors.push_back(name.error());
    for (int i = 0; i < 20; ++i) {
      if (auto cycle = master.cycle(); !cycle) errors.push_back(cycle.error());
      master.port().wait(1ms);
    }
    // Then every failure is a master error with a code of its category and a detail, and the
    // whole run ends within simulated seconds (no hang)
    for (const MasterError& error : errors) {
      EXPECT_EQ(&error.code.category(), &master_category()) << seed << ": " << error.message();
      EXPECT_FALSE(error.detail.empty()) << seed << ": " << error.message();
    }
    EXPECT_LT(segment.now() - TimePoint{}, 30s) << seed;
  }
}

TEST(MasterCycle, WorkingCounterMismatchWhenASlaveIsNotInSafeop) {
  // Given two slaves in OP, the second of which is power-cycled (INIT, no SM/FMMU setup)
  MasterRig rig(2);
  Master master = rig.make_master(2);
  ASSERT_TRUE(master.bring_up(AlState::op));
  ASSERT_TRUE(master.cycle());
  rig.slaves[1]->power_on();
  // When the master runs the next cycle
  const auto cycle = master.cycle();
  // Then it reports process_data_wkc: 3 of the expected 6
  ASSERT_FALSE(cycle);
  EXPECT_EQ(cycle.error().code, MasterErrc::process_data_wkc);
  EXPECT_EQ(master.last_cycle().wkc, 3);
  EXPECT_EQ(master.last_cycle().expected_wkc, 6);
  EXPECT_NE(cycle.error().detail.find("LRW working counter 3, expected 6"), std::string::npos)
      << cycle.error().detail;
}

TEST(MasterCycle, CyclingKeepsTheWatchdogFed) {
  // Given a slave in OP (SM watchdog 100 ms)
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::op));
  // When the master cycles every millisecond for half a second
  for (int i = 0; i < 500; ++i) {
    const auto cycle = master.cycle();
    ASSERT_TRUE(cycle) << i << ": " << cycle.error().message();
    master.port().wait(1ms);
  }
  // Then the slave stays in OP without error
  EXPECT_EQ(rig.slaves[0]->esc_slave().al_status().state, AlState::op);
  EXPECT_FALSE(rig.slaves[0]->esc_slave().al_status().error);
}

TEST(MasterCycle, WatchdogExpiryWhenTheCycleStopsIsReported) {
  // Given a slave in OP whose cycle stops for 200 ms (SM watchdog 100 ms)
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::op));
  ASSERT_TRUE(master.cycle());
  master.port().wait(200ms);
  // When the master runs the next cycle
  const auto cycle = master.cycle();
  // Then it reports al_state_lost with 001Bh (sync manager watchdog) for station 1001h
  ASSERT_FALSE(cycle);
  EXPECT_EQ(cycle.error().code, MasterErrc::al_state_lost);
  EXPECT_EQ(cycle.error().al_status_code, 0x001B);
  EXPECT_EQ(cycle.error().station, 0x1001);
  EXPECT_NE(cycle.error().detail.find("sync_manager_watchdog"), std::string::npos)
      << cycle.error().detail;
  EXPECT_EQ(rig.slaves[0]->esc_slave().al_status().state, AlState::safeop);
  // And requesting OP again acknowledges the error and brings it back
  const auto again = master.request_state(AlState::op);
  ASSERT_TRUE(again) << again.error().message();
  EXPECT_TRUE(master.cycle());
}

TEST(MasterCycle, CycleBeforeSafeopIsNotConfigured) {
  // Given a slave in PREOP
  MasterRig rig(1);
  Master master = rig.make_master();
  ASSERT_TRUE(master.bring_up(AlState::preop));
  // When the master runs a cycle
  const auto cycle = master.cycle();
  // Then it says the process data is not configured yet
  ASSERT_FALSE(cycle);
  EXPECT_EQ(cycle.error().code, MasterErrc::not_configured);
}

TEST(MasterConfigPlan, LayoutFollowsTheSiiAndPdoSizes) {
  // Given the drive SII with its SyncM length raised to 8 but 16 bits of RxPDO for SM2
  SiiImage image = drive_sii_image(0);
  image.sync_managers[2].length = 8;
  // When the master plans the slave and assigns logical addresses from 10000h
  auto layout = plan_slave(image, 0x1001);
  ASSERT_TRUE(layout);
  std::vector<SlaveLayout> layouts{*layout, *layout};
  const std::size_t size = assign_logical_addresses(layouts, 0x10000);
  // Then the mailbox SMs follow the SII words, SM2 has the PDO size, and the FMMUs map
  // outputs then inputs per slave
  ASSERT_TRUE(layouts[0].mailbox_out);
  EXPECT_EQ(layouts[0].mailbox_out->start, kSm0);
  EXPECT_EQ(layouts[0].mailbox_in->start, kSm1);
  ASSERT_EQ(layouts[0].process_data.size(), 2u);
  EXPECT_EQ(layouts[0].process_data[0].length, 2);
  EXPECT_EQ(layouts[0].process_data[0].control, 0x64);
  EXPECT_EQ(size, 8u);
  ASSERT_EQ(layouts[1].fmmus.size(), 2u);
  EXPECT_EQ(layouts[1].fmmus[0].logical, 0x10004u);
  EXPECT_EQ(layouts[1].fmmus[0].type, 2);
  EXPECT_EQ(layouts[1].fmmus[1].logical, 0x10006u);
  EXPECT_EQ(layouts[1].fmmus[1].physical, kInputs);
  EXPECT_EQ(layouts[1].expected_wkc(), 3);
}

}  // namespace
}  // namespace drivecheck::ethercat
