#include "protocol/ethercat/coe_sdo_client.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <vector>

#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/coe_sdo_server.hpp"
#include "tests/ethercat/coe_test_dictionary.hpp"

namespace drivecheck::ethercat {
namespace {

using Bytes = std::vector<std::uint8_t>;
using std::chrono::milliseconds;

// Runs a transfer between client and server directly (no mailbox) until it is done.
CoeClientStep run(CoeSdoClient& client, CoeSdoServer& server, Bytes request) {
  for (int i = 0; i < 10000; ++i) {
    const auto reply = server.handle(request);
    if (!reply.coe) return {};
    auto step = client.on_response(*reply.coe);
    if (step.done || !step.request) return step;
    request = *step.request;
  }
  ADD_FAILURE() << "transfer did not end";
  return {};
}

TEST(CoeSdoClient, RoundTripsEverySizeThroughTheServer) {
  // Given the test dictionary's domain, mailboxes of 32 octets, and values of 0..300 octets
  auto od = test::make_test_dictionary();
  CoeSdoServer server(od, {.read_size = 32});
  CoeSdoClient client({.write_size = 32});
  for (std::size_t size = 0; size <= 300; size += 7) {
    Bytes value(size);
    for (std::size_t i = 0; i < size; ++i)
      value[i] = static_cast<std::uint8_t>(i * 7 + size);
    // When the client downloads it, then uploads it again
    const auto down = run(client, server, client.start_download({0x2000, 0}, value));
    ASSERT_TRUE(down.done) << size;
    ASSERT_FALSE(down.error) << size << " " << down.error->detail;
    const auto up = run(client, server, client.start_upload({0x2000, 0}));
    // Then the value comes back unchanged
    ASSERT_TRUE(up.done) << size;
    ASSERT_FALSE(up.error) << size;
    EXPECT_EQ(client.value(), value) << size;
  }
}

TEST(CoeSdoClient, NormalTransferOfASmallValueWhenExpeditedIsOff) {
  // Given a client that may not send expedited downloads (a vector's `transfer: segmented`)
  auto od = test::make_test_dictionary();
  CoeSdoServer server(od, {.read_size = 32});
  CoeSdoClient client({.write_size = 32, .expedited = false});
  // When it downloads 2 octets
  const Bytes request = client.start_download({0x2000, 0}, Bytes{0x34, 0x12});
  // Then the initiate is a normal one: size indicated, the 2 octets after it, not expedited
  const auto m = decode_sdo_request(request);
  ASSERT_TRUE(m);
  const auto& d = std::get<CoeDownloadInitiate>(*m);
  EXPECT_FALSE(d.expedited);
  EXPECT_TRUE(d.size_indicated);
  EXPECT_EQ(d.complete_size, 2u);
  EXPECT_EQ(d.data, (Bytes{0x34, 0x12}));
  // And the server takes it
  const auto down = run(client, server, request);
  ASSERT_TRUE(down.done);
  EXPECT_FALSE(down.error);
}

TEST(CoeSdoClient, ReportsServerAborts) {
  // Given a write to a read-only identity entry
  auto od = test::make_test_dictionary();
  CoeSdoServer server(od);
  CoeSdoClient client;
  // When it is sent
  const auto step = run(client, server, client.start_download({0x1018, 1}, Bytes{1, 0, 0, 0}));
  // Then the transfer ends with the server's abort 06010002h and the client sends nothing
  ASSERT_TRUE(step.error);
  EXPECT_EQ(step.error->kind, CoeClientError::Kind::server_abort);
  EXPECT_EQ(step.error->code, 0x06010002u);
  EXPECT_FALSE(step.request);
}

CoeClientStep answer(CoeSdoClient& client, const CoeSdoResponse& response) {
  return client.on_response(encode(response));
}

TEST(CoeSdoClient, AbortsAHostileServer) {
  // Given uploads answered by a hostile slave: a wrong index, a download response, a normal
  // response with more octets than its size, a segment with the wrong toggle, a last segment
  // short of the size
  struct Case {
    std::vector<CoeSdoResponse> replies;
    std::uint32_t abort;
  };
  const std::vector<Case> cases{
      {{CoeUploadInitiateResponse{{0x6041, 0}, false, true, true, 2, {1, 2}}}, 0x08000000},
      {{CoeDownloadInitiateResponse{{0x6040, 0}}}, 0x05040001},
      {{CoeUploadInitiateResponse{{0x6040, 0}, false, false, true, 2, {1, 2, 3}}}, 0x06070012},
      {{CoeUploadInitiateResponse{{0x6040, 0}, false, false, true, 20, {1, 2}},
        CoeUploadSegment{true, false, {1, 2, 3}}},
       0x05030000},
      {{CoeUploadInitiateResponse{{0x6040, 0}, false, false, true, 20, {1, 2}},
        CoeUploadSegment{false, true, {1, 2, 3}}},
       0x06070013},
  };
  for (const auto& c : cases) {
    CoeSdoClient client;
    (void)client.start_upload({0x6040, 0});
    CoeClientStep step;
    // When the replies arrive
    for (const auto& r : c.replies)
      step = answer(client, r);
    // Then the client aborts with the code for the violation and reports a protocol error
    ASSERT_TRUE(step.error);
    EXPECT_EQ(step.error->kind, CoeClientError::Kind::protocol);
    EXPECT_EQ(step.error->code, c.abort) << step.error->detail;
    ASSERT_TRUE(step.request);
    const auto sent = decode_sdo_request(*step.request);
    ASSERT_TRUE(sent);
    EXPECT_EQ(std::get<CoeAbort>(*sent).code, c.abort);
    EXPECT_FALSE(client.busy());
  }
}

TEST(CoeSdoClient, IgnoresEmergenciesAndTimesOut) {
  // Given an upload waiting for its response
  CoeSdoClient client;
  (void)client.start_upload({0x6041, 0});
  // When an emergency arrives, then the time runs out
  const auto step = client.on_response(encode(CoeEmergency{cia301::Emcy{0x8611, 0x20, {}}, {}}));
  const auto abort = client.timeout();
  // Then the emergency is left to others and the timeout sends abort 05040000h
  EXPECT_TRUE(step.ignored);
  EXPECT_EQ(std::get<CoeAbort>(*decode_sdo_request(abort)).code, 0x05040000u);
  ASSERT_TRUE(client.last_error());
  EXPECT_EQ(client.last_error()->kind, CoeClientError::Kind::timeout);
}

TEST(CoeMasterAndSlave, SdoThroughBothMailboxes) {
  // Given a master with a CoE client and a CoE slave over the test dictionary, mailboxes of 48
  auto od = test::make_test_dictionary();
  CoeSlave slave(od, {.write_size = 48, .read_size = 48}, {.read_size = 48});
  MailboxMaster master({.write_size = 48});
  CoeSdoClient client({.write_size = 48});
  // When the master uploads 1008h (40 octets) request by request through SM0 and SM1
  auto request = client.start_upload({0x1008, 0});
  CoeClientStep step;
  for (int i = 0; i < 10 && !step.done; ++i) {
    slave.on_write_mailbox(master.request(MailboxType::coe, request, milliseconds(i)));
    const auto sm1 = slave.take_reply();
    ASSERT_TRUE(sm1);
    const auto reply = master.accept(*sm1);
    ASSERT_TRUE(reply);
    EXPECT_EQ(reply->order, ReplyOrder::next);
    master.reply_matched();
    step = client.on_response(reply->message.data);
    if (step.request) request = *step.request;
  }
  // Then the 40 octets arrive
  ASSERT_TRUE(step.done);
  EXPECT_FALSE(step.error);
  EXPECT_EQ(client.value(), Bytes(40, 'N'));
}

}  // namespace
}  // namespace drivecheck::ethercat
