// The master against slaves that are not ours: variants of the emulated slave with what a real
// ESC and real SII contents allow but our own drive never shows (ESC datasheet Section II
// 0502h bit 6; ETG.2010 / Section I §11 Table 38 for the SII words and categories; ETG.1000.6
// for 1C12h/1C13h and the PDO mappings; ETG.1000.4 for the mailbox). Each SII image is built
// here, in the test.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "protocol/ethercat/al_state_machine.hpp"
#include "protocol/ethercat/master.hpp"
#include "protocol/ethercat/sii.hpp"
#include "tests/ethercat/master_test_slave.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;
using test::drive_sii_image;
using test::kInputs;
using test::kSm0;
using test::kSm1;
using test::SlaveOptions;
using test::TestSlave;

struct Rig {
  explicit Rig(SlaveOptions options) : slave(std::move(options)) { segment.attach(slave); }
  SimSegment segment;
  TestSlave slave;
};

Master make_master(SimSegment& segment) {
  MasterConfig config;
  config.scan.expected_slaves = 1;
  return Master(segment, config);
}

// The categories of a built SII (from word 40h) in reverse order, end marker last.
Bytes reversed_categories(const Bytes& sii) {
  std::vector<Bytes> categories;
  std::size_t at = kSiiFirstCategoryWord * 2;
  while (at + 4 <= sii.size()) {
    const auto type = static_cast<std::uint16_t>(sii[at] | (sii[at + 1] << 8));
    if (type == 0xFFFF) break;
    const std::size_t words = static_cast<std::size_t>(sii[at + 2] | (sii[at + 3] << 8));
    categories.emplace_back(sii.begin() + static_cast<std::ptrdiff_t>(at),
                            sii.begin() + static_cast<std::ptrdiff_t>(at + 4 + 2 * words));
    at += 4 + 2 * words;
  }
  Bytes out(sii.begin(), sii.begin() + kSiiFirstCategoryWord * 2);
  for (auto it = categories.rbegin(); it != categories.rend(); ++it)
    out.insert(out.end(), it->begin(), it->end());
  out.insert(out.end(), sii.begin() + static_cast<std::ptrdiff_t>(at), sii.end());
  return out;
}

TEST(MasterInterop, EepromReadsOfFourOctetsAreAssembled) {
  // Given a slave whose ESC reads 4 octets per EEPROM command (0502h bit 6 clear, as ET1200)
  SlaveOptions options;
  options.sii_read_bytes = 4;
  Rig rig(options);
  ASSERT_EQ(rig.slave.esc_slave().esc().peek(reg::kSiiControl) & sii::kReadEightBytes, 0);
  Master master = make_master(rig.segment);
  // When the master brings it up
  const auto up = master.bring_up(AlState::op);
  // Then the SII it read is the slave's, and the slave is in OP
  ASSERT_TRUE(up) << up.error().message();
  EXPECT_EQ(master.slaves()[0].sii.image, *parse_sii(rig.slave.esc_slave().esc().sii()));
  EXPECT_EQ(rig.slave.esc_slave().al_status().state, AlState::op);
}

TEST(MasterInterop, SiiCategoriesInReverseOrderGiveTheSamePlan) {
  // Given a slave whose SII lists its categories in reverse order (PDOs before SyncM)
  SlaveOptions options;
  options.sii = reversed_categories(test::drive_sii());
  ASSERT_NE(options.sii, test::drive_sii());
  Rig rig(options);
  Master master = make_master(rig.segment);
  // When the master brings it up and cycles
  const auto up = master.bring_up(AlState::op);
  ASSERT_TRUE(up) << up.error().message();
  const auto cycle = master.cycle();
  // Then the plan is the usual one: SM2/SM3 of 2 octets, WKC 3
  ASSERT_TRUE(cycle) << cycle.error().message();
  EXPECT_EQ(cycle->wkc, 3);
  ASSERT_EQ(master.slaves()[0].layout.process_data.size(), 2u);
  EXPECT_EQ(master.slaves()[0].layout.process_data[0].length, 2);
  EXPECT_EQ(master.slaves()[0].layout.process_data[1].length, 2);
}

TEST(MasterInterop, SiiWithOnlySyncManagersUsesTheirLengths) {
  // Given a SII with no General, Strings, FMMU, TxPDO or RxPDO category, only SyncM (SM2/SM3
  // 2 octets), and a slave whose CoE has no PDO mapping objects (1600h absent: aborted)
  SiiImage image = drive_sii_image(0);
  image.strings.clear();
  image.general.reset();
  image.fmmus.clear();
  image.rx_pdos.clear();
  image.tx_pdos.clear();
  SlaveOptions options;
  options.sii = *build_sii(image);
  Rig rig(options);
  Master master = make_master(rig.segment);
  // When the master brings it up and cycles
  const auto up = master.bring_up(AlState::op);
  ASSERT_TRUE(up) << up.error().message();
  const auto cycle = master.cycle();
  // Then SM2/SM3 take the SyncM lengths and process data flows
  ASSERT_TRUE(cycle) << cycle.error().message();
  EXPECT_EQ(cycle->wkc, 3);
  EXPECT_EQ(rig.slave.esc_slave().esc().sync_manager(2).length, 2);
  EXPECT_EQ(rig.slave.esc_slave().esc().sync_manager(3).length, 2);
}

// 1600h = {6040h:00, 16 bit}; 1C13h = {1A00h}; 1A00h = {6041h:00, 16 bit; 6064h:00, 32 bit}.
void add_pdo_objects(cia301::ObjectDictionary& od) {
  using cia301::AccessType;
  using cia301::DataType;
  using cia301::EntryDefinition;
  using cia301::ObjectCode;
  auto add = [&](cia301::ObjectDefinition def) {
    if (!od.add_object(std::move(def))) std::abort();
  };
  add({0x1600,
       "RxPDO 1",
       ObjectCode::record,
       {EntryDefinition::unsigned_entry(0, "count", DataType::unsigned8, AccessType::rw, 1),
        EntryDefinition::unsigned_entry(1, "e1", DataType::unsigned32, AccessType::rw,
                                        0x60400010)}});
  add({0x1A00,
       "TxPDO 1",
       ObjectCode::record,
       {EntryDefinition::unsigned_entry(0, "count", DataType::unsigned8, AccessType::rw, 2),
        EntryDefinition::unsigned_entry(1, "e1", DataType::unsigned32, AccessType::rw, 0x60410010),
        EntryDefinition::unsigned_entry(2, "e2", DataType::unsigned32, AccessType::rw,
                                        0x60640020)}});
  add({0x1C13,
       "TxPDO assign",
       ObjectCode::array,
       {EntryDefinition::unsigned_entry(0, "count", DataType::unsigned8, AccessType::rw, 1),
        EntryDefinition::unsigned_entry(1, "TxPDO", DataType::unsigned16, AccessType::rw,
                                        0x1A00)}});
}

TEST(MasterInterop, ProcessDataLengthsComeFromCoeWhenTheSiiHasNoPdos) {
  // Given a SII whose SyncM entries for SM2/SM3 have length 0 and no PDO categories, and a
  // slave whose 1C12h/1C13h assign 1600h (16 bit) and 1A00h (16 + 32 bit)
  SiiImage image = drive_sii_image(0);
  image.rx_pdos.clear();
  image.tx_pdos.clear();
  image.sync_managers[2].length = 0;
  image.sync_managers[3].length = 0;
  SlaveOptions options;
  options.sii = *build_sii(image);
  options.dictionary = add_pdo_objects;
  Rig rig(options);
  Master master = make_master(rig.segment);
  // When the master brings it up to OP and cycles with inputs 6041h = 0237h, 6064h = 12345678h
  const auto up = master.bring_up(AlState::op);
  ASSERT_TRUE(up) << up.error().message();
  rig.slave.set_inputs({0x37, 0x02, 0x78, 0x56, 0x34, 0x12});
  const auto cycle = master.cycle();
  // Then SM2 is 2 octets and SM3 6, read over CoE, and the objects are found in the image
  ASSERT_TRUE(cycle) << cycle.error().message();
  EXPECT_EQ(cycle->wkc, 3);
  EXPECT_EQ(rig.slave.esc_slave().esc().sync_manager(2).length, 2);
  EXPECT_EQ(rig.slave.esc_slave().esc().sync_manager(3).length, 6);
  EXPECT_EQ(master.input(0, {0x6041, 0}), 0x0237u);
  EXPECT_EQ(master.input(0, {0x6064, 0}), 0x12345678u);
  EXPECT_TRUE(master.set_output(0, {0x6040, 0}, 0x000F));
}

// A test slave whose SII (`image`) places SM0 at 1800h (96 octets) and SM1 at 1900h (64
// octets) in its SyncM entries, with mailboxes of those sizes.
SlaveOptions mailboxes_at_1800_and_1900(SiiImage image) {
  image.sync_managers[0].start = 0x1800;
  image.sync_managers[0].length = 96;
  image.sync_managers[1].start = 0x1900;
  image.sync_managers[1].length = 64;
  SlaveOptions options;
  options.sii = *build_sii(image);
  options.write_mailbox = 96;
  options.read_mailbox = 64;
  return options;
}

TEST(MasterInterop, MailboxFromSyncManagerEntriesWhenTheWordsAreZero) {
  // Given a SII whose standard mailbox words (18h..1Bh) are 0 and whose SyncM entries 0 and 1
  // place the mailboxes at 1800h (96 octets) and 1900h (64 octets)
  SiiImage image = drive_sii_image(0);
  image.header.standard_receive = {};
  image.header.standard_send = {};
  Rig rig(mailboxes_at_1800_and_1900(image));
  Master master = make_master(rig.segment);
  // When the master brings it up and uploads the 40-octet 1008h (segmented through SM1)
  const auto up = master.bring_up(AlState::preop);
  ASSERT_TRUE(up) << up.error().message();
  const auto name = master.sdo_upload(0, {0x1008, 0});
  // Then SM0/SM1 are where the SyncM entries say, and the upload completes
  ASSERT_TRUE(name) << name.error().message();
  EXPECT_EQ(*name, Bytes(40, 'N'));
  EXPECT_EQ(rig.slave.esc_slave().esc().sync_manager(0).start, 0x1800);
  EXPECT_EQ(rig.slave.esc_slave().esc().sync_manager(1).length, 64);
}

TEST(MasterInterop, MailboxSizesFromTheWordsMayDiffer) {
  // Given a SII whose words 18h..1Bh give SM0 1800h/96 and SM1 1900h/64 (and SyncM agrees)
  SiiImage image = drive_sii_image(0);
  image.header.standard_receive = {0x1800, 96};
  image.header.standard_send = {0x1900, 64};
  Rig rig(mailboxes_at_1800_and_1900(image));
  Master master = make_master(rig.segment);
  // When the master brings it up to OP and uploads 1008h
  const auto up = master.bring_up(AlState::op);
  ASSERT_TRUE(up) << up.error().message();
  const auto name = master.sdo_upload(0, {0x1008, 0});
  // Then the upload completes
  ASSERT_TRUE(name) << name.error().message();
  EXPECT_EQ(*name, Bytes(40, 'N'));
}

TEST(MasterInterop, RepliesThatComeOnlyAfterSeveralPollsAreWaitedFor) {
  // Given a slave whose application answers a mailbox request only after 7 more frames
  SlaveOptions options;
  options.reply_after_frames = 7;
  Rig rig(options);
  Master master = make_master(rig.segment);
  ASSERT_TRUE(master.bring_up(AlState::preop));
  // When the master uploads 1018h:01 (expedited) and the 40-octet 1008h (segmented)
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  const auto name = master.sdo_upload(0, {0x1008, 0});
  // Then both complete with the slave's values
  ASSERT_TRUE(vendor) << vendor.error().message();
  EXPECT_EQ(*vendor, (Bytes{0x1D, 0, 0, 0}));
  ASSERT_TRUE(name) << name.error().message();
  EXPECT_EQ(*name, Bytes(40, 'N'));
}

TEST(MasterInterop, ASlaveLeftInAnErrorStateIsAcknowledged) {
  // Given a slave a previous master left in PREOP + error: SAFEOP requested without the
  // process data SMs (refused with 001Dh), not acknowledged: AL status 0012h
  Rig rig(SlaveOptions{});
  {
    Master previous = make_master(rig.segment);
    ASSERT_TRUE(previous.bring_up(AlState::preop));
    AlOptions no_ack;
    no_ack.acknowledge = false;
    const auto refused = request_al_state(previous.port(), previous.slaves()[0].info.station,
                                          AlState::safeop, no_ack);
    ASSERT_FALSE(refused);
  }
  ASSERT_EQ(rig.slave.esc_slave().esc().peek(reg::kAlStatus), 0x12);
  Master master = make_master(rig.segment);
  // When a new master brings it up
  const auto up = master.bring_up(AlState::op);
  // Then it acknowledges the error on the way and the slave reaches OP
  ASSERT_TRUE(up) << up.error().message();
  EXPECT_EQ(rig.slave.esc_slave().al_status().state, AlState::op);
  EXPECT_FALSE(rig.slave.esc_slave().al_status().error);
}

}  // namespace
}  // namespace drivecheck::ethercat
