// The EtherCAT dissector (protocol/ethercat/dissector.hpp): registers, AL states and codes,
// mailboxes found through the SyncManager configuration, CoE SDO and emergency, the pass of a
// frame, shapes for summarising, and malformed input as labelled lines.
#include "protocol/ethercat/dissector.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::ethercat {
namespace {

using Bytes = std::vector<std::uint8_t>;

Bytes frame_of(std::vector<Datagram> datagrams) {
  Frame frame;
  frame.source = {0x02, 0, 0, 0, 0, 1};
  frame.datagrams = std::move(datagrams);
  return *encode_frame(frame);
}

Datagram answered(Datagram d, std::uint16_t wkc, Bytes data = {}) {
  d.working_counter = wkc;
  if (!data.empty()) d.data = std::move(data);
  return d;
}

Bytes coe_mailbox(std::uint8_t counter, const Bytes& data) {
  MailboxHeader header;
  header.type = static_cast<std::uint8_t>(MailboxType::coe);
  header.counter = counter;
  return build_mailbox(header, data, 128);
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// The SyncManager configuration of station 1001h: SM0 write mailbox 1000h, SM1 read 1080h.
void configure(FrameDissector& dissector) {
  const Bytes sms = [] {
    Bytes b = sync_manager_block(0x1000, 128, 0x26);
    const Bytes sm1 = sync_manager_block(0x1080, 128, 0x22);
    b.insert(b.end(), sm1.begin(), sm1.end());
    return b;
  }();
  const auto d = answered(Datagram::physical(Command::fpwr, 1, 0x1001, reg::kSyncManager, sms), 1);
  const auto out = dissector.dissect(frame_of({d}), FramePass::returned);
  ASSERT_EQ(out.lines.size(), 1U);
  EXPECT_TRUE(contains(out.lines[0], "SM0..SM1")) << out.lines[0];
}

TEST(EthercatDissector, NamesRegistersAlStateAndStatusCode) {
  // Given a returned FPRD of AL status and AL status code (6 bytes: PREOP + error, 001Dh)
  // When dissected
  // Then the line names the command, station, registers, length, wkc, state and code by name
  FrameDissector dissector;
  const auto d = answered(Datagram::physical(Command::fprd, 1, 0x1001, reg::kAlStatus, Bytes(6)), 1,
                          {0x12, 0, 0, 0, 0x1D, 0});
  const auto out = dissector.dissect(frame_of({d}), FramePass::returned);
  ASSERT_EQ(out.lines.size(), 1U);
  const std::string& line = out.lines[0];
  for (const char* part : {"FPRD station 1001h 0130h", "AL status, ", "AL status code", "len 6",
                           "wkc 1", "PREOP + error", "code 001Dh"})
    EXPECT_TRUE(contains(line, part)) << part << " not in: " << line;
}

TEST(EthercatDissector, DescribesRegisterBlocks) {
  // Given accesses to SyncManager, FMMU, SII and reserved addresses
  // When their registers are described
  // Then each is named from the tables
  EXPECT_EQ(describe_registers(0x080D, 1), "SM1 status");
  EXPECT_EQ(describe_registers(0x0800, 16), "SM0..SM1");
  EXPECT_EQ(describe_registers(0x0610, 16), "FMMU1");
  EXPECT_EQ(describe_registers(0x0508, 4), "SII EEPROM data");
  EXPECT_EQ(describe_registers(0x050C, 2), "SII EEPROM data +4");
  EXPECT_EQ(describe_registers(0x0F00, 2), "reserved 0F00h");
  EXPECT_EQ(describe_registers(0x1400, 2), "process RAM");
}

TEST(EthercatDissector, DecodesCoeSdoInTheMailboxesTheConfigurationNamed) {
  // Given a dissector that saw station 1001h's mailbox SyncManagers configured
  // When an SDO upload request is written into SM0 and the response and an abort are read
  // from SM1
  // Then the lines say which mailbox, the mailbox header and counter, the SDO with its
  // index:sub, the data, and the abort code by name
  FrameDissector dissector;
  configure(dissector);
  const Bytes request =
      coe_mailbox(1, encode(CoeSdoRequest{CoeUploadInitiate{{0x6041, 0}, false}}));
  const auto write = dissector.dissect(
      frame_of({answered(Datagram::physical(Command::fpwr, 2, 0x1001, 0x1000, request), 1)}),
      FramePass::returned);
  ASSERT_EQ(write.lines.size(), 1U);
  for (const char* part :
       {"1000h SM0 write mailbox", "CoE len 10", "cnt 1", "SDO upload initiate 6041h:00"})
    EXPECT_TRUE(contains(write.lines[0], part)) << part << " not in: " << write.lines[0];
  EXPECT_TRUE(write.shapes.empty()) << "mailbox content is never summarised";

  const Bytes response = coe_mailbox(1, encode(CoeSdoResponse{CoeUploadInitiateResponse{
                                            {0x6041, 0}, false, true, true, 2, {0x40, 0x02}}}));
  const auto read = dissector.dissect(
      frame_of({answered(Datagram::physical(Command::fprd, 3, 0x1001, 0x1080, Bytes(128)), 1,
                         response)}),
      FramePass::returned);
  for (const char* part : {"1080h SM1 read mailbox", "SDO upload response 6041h:00", "data 40 02"})
    EXPECT_TRUE(contains(read.lines[0], part)) << part << " not in: " << read.lines[0];

  const Bytes abort = coe_mailbox(2, encode(CoeSdoResponse{CoeAbort{{0x6040, 0}, 0x06010002}}));
  const auto aborted = dissector.dissect(
      frame_of(
          {answered(Datagram::physical(Command::fprd, 4, 0x1001, 0x1080, Bytes(128)), 1, abort)}),
      FramePass::returned);
  for (const char* part :
       {"cnt 2", "SDO abort by the server 6040h:00", "06010002h write_read_only"})
    EXPECT_TRUE(contains(aborted.lines[0], part)) << part << " not in: " << aborted.lines[0];
}

TEST(EthercatDissector, DecodesCoeEmergencyAndMailboxErrorReplies) {
  // Given a configured dissector
  // When SM1 returns a CoE emergency, then a mailbox ERR reply
  // Then the emergency code is named and the ERR code is named
  FrameDissector dissector;
  configure(dissector);
  cia301::Emcy emcy;
  emcy.error_code = 0x8611;
  emcy.error_register = 0x20;
  const auto emergency = dissector.dissect(
      frame_of({answered(Datagram::physical(Command::fprd, 2, 0x1001, 0x1080, Bytes(128)), 1,
                         coe_mailbox(3, encode(CoeEmergency{emcy, {}})))}),
      FramePass::returned);
  EXPECT_TRUE(contains(emergency.lines[0], "emergency 8611h")) << emergency.lines[0];
  EXPECT_TRUE(contains(emergency.lines[0], "register 20h")) << emergency.lines[0];
  MailboxHeader header;
  header.type = static_cast<std::uint8_t>(MailboxType::err);
  header.counter = 4;
  const auto error = dissector.dissect(
      frame_of({answered(
          Datagram::physical(Command::fprd, 3, 0x1001, 0x1080, Bytes(128)), 1,
          build_mailbox(header, mailbox_error_data(MailboxError::service_not_supported), 128))}),
      FramePass::returned);
  EXPECT_TRUE(contains(error.lines[0], "ERR")) << error.lines[0];
  EXPECT_TRUE(contains(error.lines[0], "0004h service_not_supported")) << error.lines[0];
}

TEST(EthercatDissector, InfersThePassAndShowsAnEmptyMailbox) {
  // Given a configured dissector fed frames without their pass (a pcap)
  // When an SM1 read goes out and comes back with wkc 0
  // Then the first is outgoing (no content decoded), the second returned and "empty"
  FrameDissector dissector;
  configure(dissector);
  const auto d = Datagram::physical(Command::fprd, 7, 0x1001, 0x1080, Bytes(128));
  const auto out = dissector.dissect(frame_of({d}));
  EXPECT_EQ(out.pass, FramePass::outgoing);
  EXPECT_FALSE(contains(out.lines[0], "empty")) << out.lines[0];
  const auto back = dissector.dissect(frame_of({d}));
  EXPECT_EQ(back.pass, FramePass::returned);
  EXPECT_TRUE(contains(back.lines[0], ": empty")) << back.lines[0];
  // A third frame with the same tag is a new outgoing frame, not a second return.
  EXPECT_EQ(dissector.dissect(frame_of({d})).pass, FramePass::outgoing);
}

TEST(EthercatDissector, WithoutConfigurationAMailboxAddressIsProcessRam) {
  // Given a dissector that saw no SyncManager configuration, or only one that no slave took
  // (wkc 0)
  // When station 1001h's 1000h is written
  // Then the line says process RAM, not a mailbox
  FrameDissector dissector;
  Bytes sms = sync_manager_block(0x1000, 128, 0x26);
  (void)dissector.dissect(
      frame_of({Datagram::physical(Command::fpwr, 1, 0x1001, reg::kSyncManager, sms)}),
      FramePass::returned);
  const auto out = dissector.dissect(
      frame_of({answered(Datagram::physical(Command::fpwr, 1, 0x1001, 0x1000, Bytes(128)), 1)}),
      FramePass::returned);
  EXPECT_TRUE(contains(out.lines[0], "1000h process RAM")) << out.lines[0];
  EXPECT_FALSE(contains(out.lines[0], "mailbox")) << out.lines[0];
}

TEST(EthercatDissector, CyclicFramesDifferingInProcessDataHaveEqualShapes) {
  // Given two LRW + BRD AL status frames whose process data differ, and a third whose AL
  // status differs
  // When dissected
  // Then the first two have equal shapes (summarisable), the third another shape, and the
  // lines show the data
  FrameDissector dissector;
  const auto cycle = [&](Bytes data, std::uint8_t al) {
    return dissector.dissect(
        frame_of({answered(Datagram::logical(Command::lrw, 1, 0x10000, Bytes(4)), 3, data),
                  answered(Datagram::physical(Command::brd, 1, 0, reg::kAlStatus, Bytes(2)), 1,
                           {al, 0})}),
        FramePass::returned);
  };
  const auto a = cycle({0x0F, 0, 0x37, 0x06}, 0x08);
  const auto b = cycle({0x0F, 0, 0x33, 0x06}, 0x08);
  const auto c = cycle({0x0F, 0, 0x33, 0x06}, 0x14);
  ASSERT_EQ(a.lines.size(), 2U);
  EXPECT_TRUE(contains(a.lines[0], "LRW logical 00010000h len 4 wkc 3 data=0F 00 37 06"))
      << a.lines[0];
  EXPECT_TRUE(contains(a.lines[1], ": OP")) << a.lines[1];
  EXPECT_FALSE(a.shapes.empty());
  EXPECT_EQ(a.shapes, b.shapes);
  EXPECT_NE(b.shapes, c.shapes);
  EXPECT_TRUE(contains(c.lines[1], "SAFEOP + error")) << c.lines[1];
}

TEST(EthercatDissector, MalformedInputGivesLabelledLines) {
  // Given a frame cut inside its datagram, a frame of another EtherType, and a mailbox whose
  // Length runs past its buffer
  // When dissected
  // Then each says "malformed: " and why, and nothing throws
  FrameDissector dissector;
  Bytes good = frame_of({Datagram::physical(Command::aprd, 1, 0, reg::kAlStatus, Bytes(2))});
  const auto cut = dissector.dissect(Bytes(good.begin(), good.begin() + 20));
  ASSERT_EQ(cut.lines.size(), 1U);
  EXPECT_TRUE(cut.malformed);
  EXPECT_EQ(cut.lines[0].rfind("malformed: ", 0), 0U) << cut.lines[0];
  Bytes ip = good;
  ip[12] = 0x08;
  ip[13] = 0x00;
  EXPECT_EQ(dissector.dissect(ip).lines[0].rfind("malformed: ", 0), 0U);
  EXPECT_TRUE(dissector.dissect(Bytes{}).malformed);

  configure(dissector);
  Bytes lying = coe_mailbox(1, encode(CoeSdoRequest{CoeUploadInitiate{{0x1000, 0}, false}}));
  lying[0] = 0xFF;  // Length 255 in a 128-octet SyncManager
  const auto out = dissector.dissect(
      frame_of({answered(Datagram::physical(Command::fpwr, 2, 0x1001, 0x1000, lying), 1)}),
      FramePass::returned);
  EXPECT_TRUE(contains(out.lines[0], "malformed: mailbox Length 255")) << out.lines[0];
  EXPECT_EQ(describe_mailbox(Bytes{1, 2}).rfind("malformed: ", 0), 0U);
  Bytes short_sdo = coe_mailbox(1, {0x00, 0x20, 0x40});
  EXPECT_TRUE(contains(describe_mailbox(short_sdo), "malformed: SDO request"))
      << describe_mailbox(short_sdo);
}

}  // namespace
}  // namespace drivecheck::ethercat
