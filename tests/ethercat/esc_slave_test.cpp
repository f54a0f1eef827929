#include "protocol/ethercat/esc_slave.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <vector>

#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/sim_segment.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

Bytes u16(std::uint16_t v) {
  return {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8)};
}

// The drive-like SII of sii_test: mailboxes 1000h/1080h (128), SM2 outputs 1100h/2, SM3
// inputs 1180h/2.
std::vector<std::uint8_t> drive_sii() {
  SiiImage image;
  image.header.standard_receive = {0x1000, 128};
  image.header.standard_send = {0x1080, 128};
  image.header.bootstrap_receive = {0x1000, 256};
  image.header.bootstrap_send = {0x1100, 256};
  image.header.mailbox_protocols = kSiiMailboxCoe;
  image.sync_managers = {
      {0x1000, 128, 0x26, 0, 1, SiiSyncManagerType::mailbox_out},
      {0x1080, 128, 0x22, 0, 1, SiiSyncManagerType::mailbox_in},
      {0x1100, 2, 0x64, 0, 1, SiiSyncManagerType::outputs},
      {0x1180, 2, 0x20, 0, 1, SiiSyncManagerType::inputs},
  };
  return *build_sii(image);
}

// A master's view for the tests: one datagram per frame over the segment.
class Rig {
 public:
  explicit Rig(EscSlaveConfig config = {}) : slave_(with_sii(std::move(config))) {
    segment_.attach(slave_);
  }

  Datagram exchange(Datagram datagram) {
    Frame frame;
    frame.datagrams = {std::move(datagram)};
    EXPECT_FALSE(segment_.send(*encode_frame(frame)));
    const auto back = segment_.receive(segment_.now() + 1ms);
    EXPECT_TRUE(back);
    if (!back) return {};
    return decode_frame(back->bytes)->datagrams.at(0);
  }
  void write(std::uint16_t address, Bytes data) {
    EXPECT_EQ(
        exchange(Datagram::physical(Command::apwr, 0, 0, address, std::move(data))).working_counter,
        1);
  }
  // AL status and AL status code, read in one datagram (0130h..0135h).
  std::pair<std::uint16_t, std::uint16_t> al_status() {
    const auto d = exchange(Datagram::physical(Command::aprd, 0, 0, reg::kAlStatus, Bytes(6)));
    return {static_cast<std::uint16_t>(d.data[0] | (d.data[1] << 8)),
            static_cast<std::uint16_t>(d.data[4] | (d.data[5] << 8))};
  }
  std::pair<std::uint16_t, std::uint16_t> request(std::uint16_t control) {
    write(reg::kAlControl, u16(control));
    return al_status();
  }
  void configure_mailbox() {
    Bytes sms = sync_manager_block(0x1000, 128, 0x26);
    const Bytes sm1 = sync_manager_block(0x1080, 128, 0x22);
    sms.insert(sms.end(), sm1.begin(), sm1.end());
    write(reg::kSyncManager, sms);
  }
  void configure_process_data(std::uint16_t outputs_length = 2) {
    Bytes sms = sync_manager_block(0x1100, outputs_length, 0x64);
    const Bytes sm3 = sync_manager_block(0x1180, 2, 0x20);
    sms.insert(sms.end(), sm3.begin(), sm3.end());
    write(reg::sync_manager(2), sms);
  }
  SimSegment& segment() { return segment_; }
  EscSlave& slave() { return slave_; }

 private:
  static EscSlaveConfig with_sii(EscSlaveConfig config) {
    config.esc.sii = drive_sii();
    return config;
  }
  EscSlave slave_;
  SimSegment segment_;
};

TEST(EscSlave, IpNeedsTheMailboxSyncManagersOfTheSii) {
  // Given a slave in INIT whose SII names mailboxes at 1000h/1080h
  // When PREOP is requested before SM0/SM1 are configured, then after (with acknowledge)
  // Then the first is refused with 0016h (INIT + error), the second reaches PREOP
  Rig rig;
  EXPECT_EQ(rig.al_status(), std::make_pair(std::uint16_t{0x0001}, std::uint16_t{0}));
  EXPECT_EQ(rig.request(0x0002), std::make_pair(std::uint16_t{0x0011}, std::uint16_t{0x0016}));
  rig.configure_mailbox();
  EXPECT_EQ(rig.request(0x0012), std::make_pair(std::uint16_t{0x0002}, std::uint16_t{0}));
}

TEST(EscSlave, BootNeedsTheBootstrapMailbox) {
  // Given a slave with BOOT whose SII names bootstrap mailboxes 1000h/1100h of 256 bytes
  // When BOOT is requested with the standard mailboxes (128 bytes) configured
  // Then it is refused with 0015h (invalid mailbox configuration, BOOT)
  EscSlaveConfig config;
  config.bootstrap = true;
  Rig rig(config);
  rig.configure_mailbox();
  EXPECT_EQ(rig.request(0x0003), std::make_pair(std::uint16_t{0x0011}, std::uint16_t{0x0015}));
}

TEST(EscSlave, PsNeedsTheProcessDataSyncManagers) {
  // Given a slave in PREOP
  // When SAFEOP is requested with SM2 of the wrong length, then with SM2/SM3 as the SII says
  // Then the first is refused with 001Dh, the second reaches SAFEOP, and OP follows
  Rig rig;
  rig.configure_mailbox();
  rig.request(0x0002);
  rig.configure_process_data(4);
  EXPECT_EQ(rig.request(0x0004), std::make_pair(std::uint16_t{0x0012}, std::uint16_t{0x001D}));
  // SM2 must be disabled before it can be changed (its configuration is locked while on).
  rig.write(reg::sync_manager(2) + 6, {0});
  rig.configure_process_data(2);
  EXPECT_EQ(rig.request(0x0014), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
  EXPECT_EQ(rig.request(0x0008), std::make_pair(std::uint16_t{0x0008}, std::uint16_t{0}));
}

TEST(EscSlave, RefusedStateChangesShowTheirCodes) {
  // Given a slave in INIT
  // When OP (not reachable from INIT) and then 5 (no state) are requested
  // Then AL status shows INIT + error with 0011h, then 0012h
  Rig rig;
  EXPECT_EQ(rig.request(0x0008), std::make_pair(std::uint16_t{0x0011}, std::uint16_t{0x0011}));
  EXPECT_EQ(rig.request(0x0015), std::make_pair(std::uint16_t{0x0011}, std::uint16_t{0x0012}));
}

TEST(EscSlave, SmWatchdogDropsOpToSafeop) {
  // Given a slave in OP fed outputs by LWR every 10 ms for 200 ms
  // When the outputs stop for 150 ms
  // Then it stayed in OP while fed, and then shows SAFEOP + error with 001Bh
  Rig rig;
  rig.configure_mailbox();
  rig.request(0x0002);
  rig.configure_process_data();
  rig.write(0x0600, {0x00, 0x00, 0x01, 0x00, 0x02, 0x00, 0x00, 0x07, 0x00, 0x11, 0x00, 0x02, 0x01,
                     0, 0, 0});  // FMMU0: logical 10000h, 2 bytes -> 1100h, write
  rig.request(0x0004);
  ASSERT_EQ(rig.request(0x0008).first, 0x0008);
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(rig.exchange(Datagram::logical(Command::lwr, 0, 0x10000, Bytes(2))).working_counter,
              1);
    rig.segment().run_for(10ms);
  }
  EXPECT_EQ(rig.al_status().first, 0x0008);
  rig.segment().run_for(150ms);
  EXPECT_EQ(rig.al_status(), std::make_pair(std::uint16_t{0x0014}, std::uint16_t{0x001B}));
}

TEST(EscSlave, InjectedCheckRefusesWithItsCode) {
  // Given a slave whose injected check (as the CoE layer would) refuses PS with 0024h
  // When SAFEOP is requested with valid SyncManagers
  // Then the slave stays in PREOP + error with 0024h (invalid input mapping)
  EscSlaveConfig config;
  config.check = [](const AlTransition& t) {
    return t.requirement == AlRequirement::process_data ? AlStatusCode::invalid_input_mapping
                                                        : AlStatusCode::no_error;
  };
  Rig rig(config);
  rig.configure_mailbox();
  rig.request(0x0002);
  rig.configure_process_data();
  EXPECT_EQ(rig.request(0x0004), std::make_pair(std::uint16_t{0x0012}, std::uint16_t{0x0024}));
}

TEST(EscSlave, MailboxEventsReachTheHook) {
  // Given a slave in PREOP with an on_events hook (where the CoE layer attaches)
  // When the master writes a whole mailbox to SM0
  // Then the hook sees sm_written bit 0 and can take the mailbox from the PDI side
  std::optional<Bytes> taken;
  EscSlaveConfig config;
  config.on_events = [&](EscSlave& slave, const EscEvents& events) {
    if ((events.sm_written & 1) != 0) taken = slave.esc().pdi_take_mailbox(0);
  };
  Rig rig(config);
  rig.configure_mailbox();
  rig.request(0x0002);
  Bytes message(128, 0);
  message[0] = 10;
  rig.write(0x1000, message);
  ASSERT_TRUE(taken);
  EXPECT_EQ(*taken, message);
}

}  // namespace
}  // namespace drivecheck::ethercat
