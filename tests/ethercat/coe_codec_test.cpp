#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::ethercat {
namespace {

using Bytes = std::vector<std::uint8_t>;

TEST(CoeHeader, PacksNumberAndService) {
  // Given a CoE header with number 123h and service 3 (SDO response)
  CoeHeader h{0x123, 0, 3};
  // When it is encoded and decoded
  std::uint8_t out[2]{};
  encode_coe_header(h, out);
  // Then number is bits 0..8, service bits 12..15, and the round trip is exact
  EXPECT_EQ(Bytes(out, out + 2), (Bytes{0x23, 0x31}));
  EXPECT_EQ(decode_coe_header(out), h);
  EXPECT_EQ(coe_service_name(8), "SDO information");
  EXPECT_FALSE(coe_service_name(0));
}

TEST(CoeSdoDecode, ReadsAnExpeditedDownload) {
  // Given the mailbox data of an expedited download of 000Fh to 6040h:00
  // CoE service 2; ccs=1 n=2 e=1 s=1; index 6040h sub 0; data 0F 00
  const Bytes data{0x00, 0x20, 0x2B, 0x40, 0x60, 0x00, 0x0F, 0x00, 0x00, 0x00};
  // When it is decoded
  const auto m = decode_sdo_request(data);
  // Then it is a download initiate of 2 octets
  ASSERT_TRUE(m);
  const auto& d = std::get<CoeDownloadInitiate>(*m);
  EXPECT_EQ(d.mux, (Multiplexer{0x6040, 0}));
  EXPECT_TRUE(d.expedited);
  EXPECT_FALSE(d.complete_access);
  EXPECT_EQ(d.data, (Bytes{0x0F, 0x00}));
  EXPECT_EQ(to_string(*m), "SDO download initiate 6040h:00 expedited 2 octets");
}

TEST(CoeSdoDecode, RefusesMalformedMessages) {
  // Given a 9-octet SDO request, a response sent as request, a block command, and a long
  // segment with n != 0
  const Bytes short_one{0x00, 0x20, 0x40, 0x18, 0x10, 0x01, 0x00, 0x00, 0x00};
  const Bytes wrong_service{0x00, 0x30, 0x40, 0x18, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00};
  const Bytes block{0x00, 0x20, 0xC0, 0x18, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00};
  // ccs=0 n=3 c=0, 8 data octets
  const Bytes long_segment{0x00, 0x20, 0x06, 1, 2, 3, 4, 5, 6, 7, 8};
  // When they are decoded
  const auto a = decode_sdo_request(short_one);
  const auto b = decode_sdo_request(wrong_service);
  const auto c = decode_sdo_request(block);
  const auto d = decode_sdo_request(long_segment);
  // Then each is an error; only the SDO-level ones name an abort code
  ASSERT_FALSE(a);
  EXPECT_FALSE(a.error().abort);
  ASSERT_FALSE(b);
  EXPECT_FALSE(b.error().abort);
  ASSERT_FALSE(c);
  EXPECT_EQ(c.error().abort, cia301::SdoAbort::invalid_command_specifier);
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().abort, cia301::SdoAbort::length_mismatch);
}

TEST(CoeSdoCodec, EveryMessageRoundTrips) {
  // Given one message of every kind, both directions
  const std::vector<CoeSdoRequest> requests{
      CoeDownloadInitiate{{0x6040, 0}, false, true, true, 2, {0x06, 0x00}},
      CoeDownloadInitiate{{0x2000, 0}, false, false, true, 20, {1, 2, 3, 4, 5, 6}},
      CoeDownloadInitiate{{0x1C12, 0}, true, true, true, 4, {1, 0, 0, 0x16}},
      CoeDownloadSegment{true, false, {1, 2, 3, 4, 5, 6, 7, 8, 9}},
      CoeDownloadSegment{false, true, {1, 2}},
      CoeUploadInitiate{{0x1018, 1}, false},
      CoeUploadInitiate{{0x1018, 0}, true},
      CoeUploadSegmentRequest{true},
      CoeAbort{{0x6060, 0}, 0x06090030},
  };
  const std::vector<CoeSdoResponse> responses{
      CoeUploadInitiateResponse{{0x6041, 0}, false, true, true, 2, {0x37, 0x02}},
      CoeUploadInitiateResponse{{0x1008, 0}, false, false, true, 40, Bytes(16, 'N')},
      CoeUploadSegment{false, true, {9}},
      CoeDownloadInitiateResponse{{0x6040, 0}},
      CoeDownloadSegmentResponse{true},
      CoeAbort{{0x6040, 0}, 0x06010002},
  };
  // When each is encoded and decoded
  // Then it comes back equal
  for (const auto& m : requests) {
    const auto bytes = encode(m);
    EXPECT_GE(bytes.size(), kCoeSdoMessageSize);
    const auto back = decode_sdo_request(bytes);
    ASSERT_TRUE(back) << to_string(m);
    EXPECT_EQ(*back, m) << to_string(m);
  }
  for (const auto& m : responses) {
    const auto back = decode_sdo_response(encode(m));
    ASSERT_TRUE(back) << to_string(m);
    EXPECT_EQ(*back, m) << to_string(m);
  }
}

TEST(CoeSdoCodec, ShortSegmentsArePaddedToSevenWithN) {
  // Given a last download segment of 2 octets with toggle 1
  const auto bytes = encode(CoeSdoRequest{CoeDownloadSegment{true, true, {0xAA, 0xBB}}});
  // When it is encoded
  // Then it is 10 octets: ccs=0 t=1 n=5 c=1 → 1Bh, then the data and 5 octets of padding
  EXPECT_EQ(bytes, (Bytes{0x00, 0x20, 0x1B, 0xAA, 0xBB, 0, 0, 0, 0, 0}));
}

TEST(CoeEmergency, CarriesTheCanopenEmcy) {
  // Given the Kollmorgen EMCY 4310h (motor temperature), register 08h (002 L7832-7837), as a
  // CoE emergency (Festo 000 §4.11 Fig. 4.7: CoE header, error code, register, 5 octets)
  const Bytes data{0x00, 0x10, 0x10, 0x43, 0x08, 0, 0, 0, 0, 0};
  // When it is decoded and encoded again
  const auto e = decode_emergency(data);
  // Then the fields are the EMCY's and the octets round trip
  ASSERT_TRUE(e);
  EXPECT_EQ(e->emcy.error_code, 0x4310);
  EXPECT_EQ(e->emcy.error_register, 0x08);
  EXPECT_EQ(encode(*e), data);
  // And a 9-octet or non-emergency message is refused
  EXPECT_FALSE(decode_emergency(Bytes(data.begin(), data.end() - 1)));
  EXPECT_FALSE(decode_emergency(Bytes{0x00, 0x20, 0x10, 0x43, 0x08, 0, 0, 0, 0, 0}));
}

TEST(MailboxDescription, OneLinePerMessage) {
  // Given an SDO request, an ERR reply, an emergency, an FoE message and 3 stray octets
  const auto wrap = [](std::uint8_t type, std::uint8_t counter, const Bytes& data) {
    MailboxHeader h;
    h.type = type;
    h.counter = counter;
    return build_mailbox(h, data, 32);
  };
  // When each is described
  // Then each line names type, counter and content, and garbage says why it is none
  EXPECT_EQ(
      describe_mailbox_message(wrap(3, 1, encode(CoeSdoRequest{CoeUploadInitiate{{0x1018, 1}}}))),
      "CoE cnt 1: SDO upload initiate 1018h:01");
  EXPECT_EQ(describe_mailbox_message(wrap(0, 2, mailbox_error_data(MailboxError::invalid_channel))),
            "ERR cnt 2: 0003h invalid_channel: Channel field contains a wrong value (a slave may "
            "ignore the channel)");
  EXPECT_EQ(describe_mailbox_message(
                wrap(3, 3, encode(CoeEmergency{cia301::Emcy{0x8611, 0x20, {}}, {}}))),
            "CoE cnt 3: emergency 8611h Following error, register 20h");
  EXPECT_EQ(describe_mailbox_message(wrap(4, 1, Bytes(12, 0))), "FoE cnt 1: 12 octets");
  EXPECT_EQ(describe_mailbox_message(Bytes{1, 2, 3}),
            "no mailbox: 0006h size_too_short: Length of the received mailbox data is too short");
}

}  // namespace
}  // namespace drivecheck::ethercat
