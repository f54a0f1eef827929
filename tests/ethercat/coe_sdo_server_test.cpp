#include "protocol/ethercat/coe_sdo_server.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "tests/ethercat/coe_test_dictionary.hpp"

namespace drivecheck::ethercat {
namespace {

using Bytes = std::vector<std::uint8_t>;
using cia301::SdoAbort;

// The decoded response of the server to a request.
CoeSdoResponse ask(CoeSdoServer& server, const CoeSdoRequest& request) {
  const auto reply = server.handle(encode(request));
  EXPECT_TRUE(reply.coe) << to_string(request);
  if (!reply.coe) return CoeAbort{};
  auto decoded = decode_sdo_response(*reply.coe);
  EXPECT_TRUE(decoded);
  return decoded ? *decoded : CoeSdoResponse{CoeAbort{}};
}

std::uint32_t abort_code(const CoeSdoResponse& r) {
  const auto* a = std::get_if<CoeAbort>(&r);
  return a ? a->code : 0;
}

class CoeSdoServerTest : public ::testing::Test {
 protected:
  cia301::ObjectDictionary od = test::make_test_dictionary();
};

TEST_F(CoeSdoServerTest, ExpeditedUploadOfAVar) {
  // Given 6040h = 000Fh
  ASSERT_TRUE(od.set(0x6040, 0, cia301::Value::of_unsigned(0x0F)));
  CoeSdoServer server(od);
  // When the master uploads 6040h:00: CoE service 2, ccs=2, 6040h sub 0
  const auto reply = server.handle(Bytes{0x00, 0x20, 0x40, 0x40, 0x60, 0x00, 0, 0, 0, 0});
  // Then the reply is an expedited upload response: service 3, scs=2 n=2 e=1 s=1 (4Bh), data
  ASSERT_TRUE(reply.coe);
  EXPECT_EQ(*reply.coe, (Bytes{0x00, 0x30, 0x4B, 0x40, 0x60, 0x00, 0x0F, 0x00, 0x00, 0x00}));
}

TEST_F(CoeSdoServerTest, NormalUploadThenSegments) {
  // Given a 40-octet string and a read mailbox of 32 octets (16 in the initiate, 23 a segment)
  CoeSdoServer server(od, {.read_size = 32});
  // When it is uploaded and the segments are requested with alternating toggles
  const auto first = ask(server, CoeUploadInitiate{{0x1008, 0}, false});
  const auto& init = std::get<CoeUploadInitiateResponse>(first);
  EXPECT_FALSE(init.expedited);
  EXPECT_EQ(init.complete_size, 40u);
  ASSERT_EQ(init.data.size(), 16u);
  const auto s1 = std::get<CoeUploadSegment>(ask(server, CoeUploadSegmentRequest{false}));
  const auto s2 = std::get<CoeUploadSegment>(ask(server, CoeUploadSegmentRequest{true}));
  // Then 16 + 23 + 1 octets arrive, the last segment flagged, the toggles echoed
  EXPECT_EQ(s1.data.size(), 23u);
  EXPECT_FALSE(s1.last);
  EXPECT_FALSE(s1.toggle);
  EXPECT_EQ(s2.data.size(), 1u);
  EXPECT_TRUE(s2.last);
  EXPECT_TRUE(s2.toggle);
  EXPECT_FALSE(server.busy());
}

TEST_F(CoeSdoServerTest, UploadSegmentsOutOfToggleOrderAbort) {
  // Given an upload in progress
  CoeSdoServer server(od, {.read_size = 32});
  (void)ask(server, CoeUploadInitiate{{0x1008, 0}, false});
  // When the first segment request carries toggle 1
  const auto r = ask(server, CoeUploadSegmentRequest{true});
  // Then the server aborts 05030000h and the transfer is over
  EXPECT_EQ(abort_code(r), 0x05030000u);
  EXPECT_FALSE(server.busy());
  // And a further segment request, with no transfer, aborts 05040001h
  EXPECT_EQ(abort_code(ask(server, CoeUploadSegmentRequest{false})), 0x05040001u);
}

TEST_F(CoeSdoServerTest, SegmentedDownloadWritesOnceComplete) {
  // Given a domain and a download of 20 octets: 6 in the initiate, then 9 and 5
  CoeSdoServer server(od);
  Bytes value(20);
  for (std::size_t i = 0; i < value.size(); ++i)
    value[i] = static_cast<std::uint8_t>(i);
  // When the master sends them
  const auto r0 = ask(
      server, CoeDownloadInitiate{
                  {0x2000, 0}, false, false, true, 20, Bytes(value.begin(), value.begin() + 6)});
  const auto r1 =
      ask(server, CoeDownloadSegment{false, false, Bytes(value.begin() + 6, value.begin() + 15)});
  EXPECT_EQ(od.find(0x2000, 0)->bytes().size(), 0u);  // nothing stored before the end
  const auto r2 =
      ask(server, CoeDownloadSegment{true, true, Bytes(value.begin() + 15, value.end())});
  // Then each step is confirmed and the domain holds the 20 octets
  EXPECT_TRUE(std::holds_alternative<CoeDownloadInitiateResponse>(r0));
  EXPECT_EQ(std::get<CoeDownloadSegmentResponse>(r1).toggle, false);
  EXPECT_EQ(std::get<CoeDownloadSegmentResponse>(r2).toggle, true);
  const auto stored = od.find(0x2000, 0)->bytes();
  EXPECT_EQ(Bytes(stored.begin(), stored.end()), value);
}

TEST_F(CoeSdoServerTest, DownloadSegmentsOutOfToggleOrderAbort) {
  // Given a download of 20 octets in progress
  CoeSdoServer server(od);
  (void)ask(server, CoeDownloadInitiate{{0x2000, 0}, false, false, true, 20, Bytes(6, 1)});
  // When the first segment carries toggle 1
  const auto r = ask(server, CoeDownloadSegment{true, false, Bytes(7, 2)});
  // Then the server aborts 05030000h, stores nothing, and refuses further segments
  EXPECT_EQ(abort_code(r), 0x05030000u);
  EXPECT_EQ(od.find(0x2000, 0)->bytes().size(), 0u);
  EXPECT_EQ(abort_code(ask(server, CoeDownloadSegment{false, true, Bytes(7, 2)})), 0x05040001u);
}

TEST_F(CoeSdoServerTest, LyingSizesAbort) {
  // Given downloads whose announced complete size lies: 5 announced, 13 sent; 20 announced,
  // 8 sent and the last segment flagged; 2 announced with 6 octets in the initiate
  CoeSdoServer server(od);
  // When each is sent
  (void)ask(server, CoeDownloadInitiate{{0x2000, 0}, false, false, true, 5, {}});
  const auto too_many = ask(server, CoeDownloadSegment{false, true, Bytes(13, 1)});
  (void)ask(server, CoeDownloadInitiate{{0x2000, 0}, false, false, true, 20, Bytes(1, 1)});
  const auto too_few = ask(server, CoeDownloadSegment{false, true, Bytes(7, 1)});
  const auto initiate_long =
      ask(server, CoeDownloadInitiate{{0x2000, 0}, false, false, true, 2, Bytes(6, 1)});
  // Then each aborts with the length code, and nothing is stored
  EXPECT_EQ(abort_code(too_many), 0x06070012u);
  EXPECT_EQ(abort_code(too_few), 0x06070013u);
  EXPECT_EQ(abort_code(initiate_long), 0x06070012u);
  EXPECT_EQ(od.find(0x2000, 0)->bytes().size(), 0u);
}

TEST_F(CoeSdoServerTest, LyingExpeditedSizesAndTinyMailboxes) {
  // Given 6040h (UNSIGNED16) and a server whose read mailbox is the smallest for CoE (16)
  CoeSdoServer server(od, {.read_size = 16});
  // When an expedited download says 1 octet (n=3) and one says 3 octets (n=1)
  // ccs=1 n=3 e=1 s=1 (2Fh) and n=1 (27h), index 6040h sub 0
  const auto one = server.handle(Bytes{0x00, 0x20, 0x2F, 0x40, 0x60, 0x00, 0x01, 0x02, 0x03, 0x04});
  const auto three =
      server.handle(Bytes{0x00, 0x20, 0x27, 0x40, 0x60, 0x00, 0x01, 0x02, 0x03, 0x04});
  // Then the dictionary's length codes come back, too low and too high
  EXPECT_EQ(abort_code(*decode_sdo_response(*one.coe)), 0x06070013u);
  EXPECT_EQ(abort_code(*decode_sdo_response(*three.coe)), 0x06070012u);
  // And a 40-octet upload still works: nothing in the initiate, then segments of 7
  const auto init =
      std::get<CoeUploadInitiateResponse>(ask(server, CoeUploadInitiate{{0x1008, 0}}));
  EXPECT_TRUE(init.data.empty());
  std::size_t received = 0;
  bool toggle = false;
  for (int i = 0; i < 10 && server.busy(); ++i, toggle = !toggle) {
    const auto segment = std::get<CoeUploadSegment>(ask(server, CoeUploadSegmentRequest{toggle}));
    EXPECT_LE(segment.data.size(), 7u);
    received += segment.data.size();
  }
  EXPECT_EQ(received, 40u);
}

TEST_F(CoeSdoServerTest, DictionaryAbortsPassThrough) {
  // Given the dictionary's checks
  CoeSdoServer server(od);
  // When a missing object, a missing sub-index, and a read-only entry are accessed
  // Then the abort codes are the dictionary's (object_dictionary.hpp)
  EXPECT_EQ(abort_code(ask(server, CoeUploadInitiate{{0x7000, 0}, false})), 0x06020000u);
  EXPECT_EQ(abort_code(ask(server, CoeUploadInitiate{{0x1018, 9}, false})), 0x06090011u);
  EXPECT_EQ(abort_code(ask(
                server, CoeDownloadInitiate{{0x1018, 1}, false, true, true, 4, Bytes{1, 2, 3, 4}})),
            0x06010002u);
  EXPECT_EQ(abort_code(ask(
                server, CoeDownloadInitiate{{0x6040, 0}, false, true, true, 4, Bytes{1, 2, 3, 4}})),
            0x06070012u);
}

TEST_F(CoeSdoServerTest, CompleteAccessUploadWithAndWithoutSubIndexZero) {
  // Given 1018h with 4 UNSIGNED32 entries
  CoeSdoServer server(od);
  // When it is uploaded with complete access from sub-index 0 and from 1
  const auto from0 =
      std::get<CoeUploadInitiateResponse>(ask(server, CoeUploadInitiate{{0x1018, 0}, true}));
  const auto from1 =
      std::get<CoeUploadInitiateResponse>(ask(server, CoeUploadInitiate{{0x1018, 1}, true}));
  // Then SI0 takes 16 bits (04h, padding) before the entries; from 1 it is absent
  EXPECT_TRUE(from0.complete_access);
  EXPECT_EQ(from0.data,
            (Bytes{0x04, 0x00, 0x1D, 0, 0, 0, 0x78, 0x56, 0x34, 0x12, 2, 0, 0, 0, 7, 0, 0, 0}));
  EXPECT_EQ(from1.data.size(), 16u);
  EXPECT_EQ(from1.data[0], 0x1D);
}

TEST_F(CoeSdoServerTest, CompleteAccessPacksBits) {
  // Given 2001h: two BOOLEANs (1, 0) and an UNSIGNED16 BEEFh
  // When it is read with complete access from 0
  const auto data = read_complete_access(od, 0x2001, 0);
  // Then SI0 03 00, the two bits in one octet (01h), the word at the next octet: 5 octets
  ASSERT_TRUE(data);
  EXPECT_EQ(*data, (Bytes{0x03, 0x00, 0x01, 0xEF, 0xBE}));
  // And writing it back with both bits set and a new word stores each entry
  ASSERT_TRUE(write_complete_access(od, 0x2001, 0, Bytes{0x03, 0x00, 0x03, 0x34, 0x12}));
  EXPECT_EQ(od.find(0x2001, 2)->as_unsigned(), 1u);
  EXPECT_EQ(od.find(0x2001, 3)->as_unsigned(), 0x1234u);
}

TEST_F(CoeSdoServerTest, CompleteAccessDownloadOfTheAssignment) {
  // Given 1C12h with one RxPDO assigned
  CoeSdoServer server(od);
  // When the master writes it with complete access from 0: count 2, 1601h, 1603h
  const auto r = ask(
      server, CoeDownloadInitiate{
                  {0x1C12, 0}, true, false, true, 6, Bytes{0x02, 0x00, 0x01, 0x16, 0x03, 0x16}});
  // Then it is confirmed and the array holds count 2 and the two indices
  EXPECT_TRUE(std::holds_alternative<CoeDownloadInitiateResponse>(r));
  EXPECT_EQ(od.find(0x1C12, 0)->as_unsigned(), 2u);
  EXPECT_EQ(od.find(0x1C12, 1)->as_unsigned(), 0x1601u);
  EXPECT_EQ(od.find(0x1C12, 2)->as_unsigned(), 0x1603u);
}

TEST_F(CoeSdoServerTest, CompleteAccessRefusals) {
  // Given the server
  CoeSdoServer server(od);
  CoeSdoServer no_ca(od, {.complete_access = false});
  // When complete access addresses a VAR, sub-index 2, a record with a string, a wrong length;
  // and a server without complete access is asked
  // Then 06010000h, 06010000h, 06010004h, 06070012h and 06010000h
  EXPECT_EQ(abort_code(ask(server, CoeUploadInitiate{{0x6040, 0}, true})), 0x06010000u);
  EXPECT_EQ(abort_code(ask(server, CoeUploadInitiate{{0x1018, 2}, true})), 0x06010000u);
  EXPECT_EQ(abort_code(ask(server, CoeUploadInitiate{{0x2002, 0}, true})), 0x06010004u);
  EXPECT_EQ(
      abort_code(ask(
          server,
          CoeDownloadInitiate{
              {0x1C12, 0}, true, false, true, 7, Bytes{0x02, 0x00, 0x01, 0x16, 0x03, 0x16, 0x00}})),
      0x06070012u);
  EXPECT_EQ(abort_code(ask(no_ca, CoeUploadInitiate{{0x1018, 0}, true})), 0x06010000u);
  // And a failed complete write leaves every entry as it was
  EXPECT_EQ(od.find(0x1C12, 0)->as_unsigned(), 1u);
}

TEST_F(CoeSdoServerTest, ClientAbortEndsTheTransferSilently) {
  // Given an upload in progress
  CoeSdoServer server(od, {.read_size = 32});
  (void)ask(server, CoeUploadInitiate{{0x1008, 0}, false});
  // When the master aborts
  const auto reply = server.handle(encode(CoeSdoRequest{CoeAbort{{0x1008, 0}, 0x05040000}}));
  // Then there is no reply and the server is idle
  EXPECT_FALSE(reply.coe);
  EXPECT_FALSE(reply.mailbox_error);
  EXPECT_FALSE(server.busy());
}

// ---- The slave's CoE front ------------------------------------------------------------------

Bytes mailbox(std::uint8_t counter, const Bytes& data, std::size_t size = 128) {
  MailboxHeader h;
  h.type = static_cast<std::uint8_t>(MailboxType::coe);
  h.counter = counter;
  return build_mailbox(h, data, size);
}

TEST_F(CoeSdoServerTest, SlaveAnswersThroughTheMailbox) {
  // Given a CoE slave with SM0/SM1 of 128 octets
  CoeSlave slave(od);
  // When the master writes an upload of 1018h:01 into SM0
  slave.on_write_mailbox(mailbox(1, encode(CoeSdoRequest{CoeUploadInitiate{{0x1018, 1}}})));
  // Then SM1 gets a CoE mailbox with the expedited response
  const auto reply = slave.take_reply();
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->size(), 128u);
  const auto m = parse_mailbox(*reply);
  ASSERT_TRUE(m);
  EXPECT_EQ(m->header.type, 3);
  EXPECT_EQ(m->header.counter, 1);
  const auto r = decode_sdo_response(m->data);
  ASSERT_TRUE(r);
  EXPECT_EQ(std::get<CoeUploadInitiateResponse>(*r).data, (Bytes{0x1D, 0, 0, 0}));
}

TEST_F(CoeSdoServerTest, SlaveRefusesOtherCoeServicesAndShortMessages) {
  // Given a CoE slave without SDO information
  CoeSlave slave(od, {}, {.sdo_information = false});
  // When the master sends a CoE emergency, an SDO information request and a 1-octet CoE message
  slave.on_write_mailbox(mailbox(1, encode(CoeEmergency{})));
  slave.on_write_mailbox(mailbox(2, Bytes{0x00, 0x80, 0x01, 0x00, 0x00, 0x00, 0x01, 0x00}));
  slave.on_write_mailbox(mailbox(3, Bytes{0x00}));
  // Then each gets a mailbox ERR reply: service not supported twice, size too short
  for (MailboxError expected :
       {MailboxError::service_not_supported, MailboxError::service_not_supported,
        MailboxError::size_too_short}) {
    const auto reply = slave.take_reply();
    ASSERT_TRUE(reply);
    const auto m = parse_mailbox(*reply);
    ASSERT_TRUE(m);
    EXPECT_EQ(m->header.type, 0);
    EXPECT_EQ(*parse_mailbox_error_data(m->data), static_cast<std::uint16_t>(expected));
  }
}

TEST_F(CoeSdoServerTest, SlavePostsEmergencies) {
  // Given a CoE slave
  CoeSlave slave(od);
  // When the drive raises EMCY 8611h (following error), register 20h
  ASSERT_TRUE(slave.post_emergency(cia301::Emcy{0x8611, 0x20, {}}));
  // Then SM1 gets a CoE emergency with those fields
  const auto reply = slave.take_reply();
  ASSERT_TRUE(reply);
  const auto e = decode_emergency(parse_mailbox(*reply)->data);
  ASSERT_TRUE(e);
  EXPECT_EQ(e->emcy.error_code, 0x8611);
  EXPECT_EQ(e->emcy.error_register, 0x20);
}

TEST_F(CoeSdoServerTest, RandomMailboxesNeverCrashTheSlave) {
  // Given a CoE slave and 20000 random SM0 writes (sizes 0..140, CoE SDO headers half the time)
  CoeSlave slave(od, {.write_size = 128, .read_size = 64});
  std::mt19937 rng(20);
  std::uniform_int_distribution<int> octet(0, 255);
  for (int i = 0; i < 20000; ++i) {
    Bytes b(static_cast<std::size_t>(octet(rng) % 141));
    for (auto& x : b)
      x = static_cast<std::uint8_t>(octet(rng));
    if (b.size() >= 8 && (i & 1)) {
      b[5] = static_cast<std::uint8_t>((b[5] & 0x70) | 0x03);  // CoE
      b[7] = static_cast<std::uint8_t>((b[7] & 0x0F) | 0x20);  // SDO request
    }
    // When each is written and the read mailbox emptied
    slave.on_write_mailbox(b);
    while (auto reply = slave.take_reply()) {
      // Then every reply is a mailbox that fits SM1
      ASSERT_EQ(reply->size(), 64u);
      ASSERT_TRUE(parse_mailbox(*reply));
    }
  }
}

}  // namespace
}  // namespace drivecheck::ethercat
