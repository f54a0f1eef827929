#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <vector>

#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::ethercat {
namespace {

using Bytes = std::vector<std::uint8_t>;
using std::chrono::milliseconds;

// A CoE request of 10 data octets with the given counter, in a 16-octet buffer.
Bytes coe_request(std::uint8_t counter, std::uint8_t channel = 0) {
  // Length 000Ah, Address 0000h, channel/priority, type 3 (CoE) | counter << 4
  Bytes b{0x0A, 0x00, 0x00, 0x00, channel, static_cast<std::uint8_t>(0x03 | (counter << 4))};
  // CoE header: number 0, service 2 (SDO request); upload initiate 1018h:01
  const Bytes coe{0x00, 0x20, 0x40, 0x18, 0x10, 0x01, 0x00, 0x00, 0x00, 0x00};
  b.insert(b.end(), coe.begin(), coe.end());
  return b;
}

TEST(MailboxHeader, EncodesEveryField) {
  // Given a header with every field set
  MailboxHeader h;
  h.length = 0x0123;
  h.address = 0x1001;
  h.channel = 5;
  h.priority = 2;
  h.type = 3;
  h.counter = 6;
  // When it is encoded and decoded again
  std::uint8_t out[6]{};
  encode_mailbox_header(h, out);
  // Then the octets follow the layout and the round trip is exact
  EXPECT_EQ(Bytes(out, out + 6), (Bytes{0x23, 0x01, 0x01, 0x10, 0x85, 0x63}));
  EXPECT_EQ(decode_mailbox_header(out), h);
}

TEST(MailboxParse, RefusesShortAndLyingBuffers) {
  // Given a buffer shorter than a header, and one whose Length points past its end
  const Bytes short_buffer{0x00, 0x00, 0x00};
  Bytes lying = coe_request(1);
  lying[0] = 0x40;  // Length 64 in a 16-octet buffer
  // When they are parsed
  // Then the first is size_too_short, the second invalid_size
  EXPECT_EQ(parse_mailbox(short_buffer).error(), MailboxError::size_too_short);
  EXPECT_EQ(parse_mailbox(lying).error(), MailboxError::invalid_size);
}

TEST(MailboxErrorTable, NamesEveryEtgCode) {
  // Given the nine mailbox error codes of ETG.1000.6 (01h..09h)
  // When each is looked up
  // Then the table knows it and the error code compares as the enum
  for (std::uint16_t code = 1; code <= 9; ++code)
    EXPECT_TRUE(find_mailbox_error(code)) << code;
  EXPECT_FALSE(find_mailbox_error(0));
  EXPECT_EQ(describe_mailbox_error(0x42), "0042h (unknown mailbox error code)");
  const std::error_code ec = MailboxError::invalid_channel;
  EXPECT_EQ(ec.value(), 3);
  EXPECT_NE(ec.message().find("invalid_channel"), std::string::npos);
}

TEST(MailboxSlave, DeliversANewRequestOnce) {
  // Given a slave serving CoE
  MailboxSlave slave;
  // When a request with counter 1 arrives, then the same again
  const auto first = slave.receive(coe_request(1));
  const auto again = slave.receive(coe_request(1));
  // Then the first is delivered with its data and the second is a repeat
  ASSERT_EQ(first.receipt, MailboxReceipt::deliver);
  EXPECT_EQ(first.message.data.size(), 10u);
  EXPECT_EQ(again.receipt, MailboxReceipt::repeated);
  EXPECT_EQ(slave.pending(), 0u);
}

TEST(MailboxSlave, RepeatedRequestGetsTheLastReplyAgain) {
  // Given a slave that answered request 1 and whose reply the master took
  MailboxSlave slave;
  ASSERT_EQ(slave.receive(coe_request(1)).receipt, MailboxReceipt::deliver);
  const Bytes answer{0x00, 0x30, 0x60, 0x00, 0x10, 0x00, 0, 0, 0, 0};
  ASSERT_TRUE(slave.post(MailboxType::coe, answer));
  const auto taken = slave.take_reply();
  ASSERT_TRUE(taken);
  // When the master sends request 1 again (it lost the reply)
  EXPECT_EQ(slave.receive(coe_request(1)).receipt, MailboxReceipt::repeated);
  // Then the same reply, same counter, waits in the read mailbox again
  const auto repeated = slave.take_reply();
  ASSERT_TRUE(repeated);
  EXPECT_EQ(*repeated, *taken);
  EXPECT_EQ(slave.repeat_last(), taken);
}

TEST(MailboxSlave, DiscardPolicyDropsRepeats) {
  // Given a slave with RepeatPolicy::discard that answered request 3
  MailboxSlaveConfig config;
  config.repeat = RepeatPolicy::discard;
  MailboxSlave slave(config);
  ASSERT_EQ(slave.receive(coe_request(3)).receipt, MailboxReceipt::deliver);
  ASSERT_TRUE(slave.post(MailboxType::coe, Bytes(10, 0)));
  ASSERT_TRUE(slave.take_reply());
  // When request 3 comes again
  // Then it is a repeat and nothing is queued
  EXPECT_EQ(slave.receive(coe_request(3)).receipt, MailboxReceipt::repeated);
  EXPECT_EQ(slave.pending(), 0u);
}

TEST(MailboxSlave, IgnoringTheCounterIsAFault) {
  // Given a slave with the fault "mailbox counter ignored" (honour_counter = false)
  MailboxSlaveConfig config;
  config.honour_counter = false;
  MailboxSlave slave(config);
  // When request 4 arrives twice
  // Then both are delivered (a repeated SDO download would be executed twice)
  EXPECT_EQ(slave.receive(coe_request(4)).receipt, MailboxReceipt::deliver);
  EXPECT_EQ(slave.receive(coe_request(4)).receipt, MailboxReceipt::deliver);
}

TEST(MailboxSlave, CounterZeroIsNeverARepeat) {
  // Given a master that does not count (Cnt 0)
  MailboxSlave slave;
  // When two requests with counter 0 arrive
  // Then both are delivered
  EXPECT_EQ(slave.receive(coe_request(0)).receipt, MailboxReceipt::deliver);
  EXPECT_EQ(slave.receive(coe_request(0)).receipt, MailboxReceipt::deliver);
}

TEST(MailboxSlave, RefusesWithErrorReplies) {
  // Given a slave serving CoE only, SM0 of 16 octets
  MailboxSlaveConfig config;
  config.write_size = 16;
  MailboxSlave slave(config);
  Bytes foe = coe_request(1);
  foe[5] = 0x14;  // type 4 FoE, counter 1
  Bytes too_long = coe_request(2);
  too_long[0] = 0x0B;  // Length 11 > 16 - 6: past SM0 (and past the buffer)
  too_long.push_back(0);
  // When an FoE request, a request on channel 1, a request past SM0 and 3 octets arrive
  const auto r1 = slave.receive(foe);
  const auto r2 = slave.receive(coe_request(2, 1));
  const auto r3 = slave.receive(too_long);
  const auto r4 = slave.receive(Bytes{1, 2, 3});
  // Then each is refused with its ERR reply: unsupported protocol, invalid channel, invalid
  // size, size too short
  EXPECT_EQ(r1.error, MailboxError::unsupported_protocol);
  EXPECT_EQ(r2.error, MailboxError::invalid_channel);
  EXPECT_EQ(r3.error, MailboxError::invalid_size);
  EXPECT_EQ(r4.error, MailboxError::size_too_short);
  for (MailboxError expected : {MailboxError::unsupported_protocol, MailboxError::invalid_channel,
                                MailboxError::invalid_size, MailboxError::size_too_short}) {
    const auto reply = slave.take_reply();
    ASSERT_TRUE(reply);
    const auto message = parse_mailbox(*reply);
    ASSERT_TRUE(message);
    EXPECT_EQ(message->header.type, 0);
    EXPECT_EQ(*parse_mailbox_error_data(message->data), static_cast<std::uint16_t>(expected));
  }
}

TEST(MailboxSlave, RepliesCountOneToSevenAndWrap) {
  // Given a slave posting nine replies
  MailboxSlave slave;
  std::vector<int> counters;
  for (int i = 0; i < 9; ++i) {
    ASSERT_TRUE(slave.post(MailboxType::coe, Bytes(10, 0)));
    const auto reply = slave.take_reply();
    counters.push_back(
        decode_mailbox_header(std::span<const std::uint8_t, 6>(reply->data(), 6)).counter);
  }
  // When their counters are read
  // Then they run 1..7 and wrap to 1 (never 0)
  EXPECT_EQ(counters, (std::vector<int>{1, 2, 3, 4, 5, 6, 7, 1, 2}));
}

TEST(MailboxSlave, QueueLimitAnswersNoMoreMemory) {
  // Given a slave whose reply queue holds two messages, SM1 of 32 octets
  MailboxSlaveConfig config;
  config.queue_limit = 2;
  config.read_size = 32;
  MailboxSlave slave(config);
  // When three replies and one too long for SM1 are posted
  // Then the third is no_more_memory and the long one invalid_size
  EXPECT_TRUE(slave.post(MailboxType::coe, Bytes(10, 0)));
  EXPECT_TRUE(slave.post(MailboxType::coe, Bytes(10, 0)));
  EXPECT_EQ(slave.post(MailboxType::coe, Bytes(10, 0)).error(), MailboxError::no_more_memory);
  EXPECT_EQ(slave.post(MailboxType::coe, Bytes(27, 0)).error(), MailboxError::invalid_size);
}

TEST(MailboxMaster, CountsRequestsAndDetectsLostAndDuplicateReplies) {
  // Given a master and a slave's replies with counters 1, 2, 2, 5
  MailboxMaster master;
  const auto r1 = master.request(MailboxType::coe, Bytes(10, 0), milliseconds(0));
  const auto r2 = master.request(MailboxType::coe, Bytes(10, 0), milliseconds(1));
  EXPECT_EQ(r1[5], 0x13);
  EXPECT_EQ(r2[5], 0x23);
  EXPECT_EQ(r1.size(), 128u);
  auto reply = [](std::uint8_t counter) {
    MailboxHeader h;
    h.type = 3;
    h.counter = counter;
    return build_mailbox(h, Bytes(10, 0), 32);
  };
  // When they are accepted in turn
  const auto a = master.accept(reply(1));
  const auto b = master.accept(reply(2));
  const auto c = master.accept(reply(2));
  const auto d = master.accept(reply(5));
  // Then 1 and 2 are next, the second 2 a duplicate, 5 a gap of two lost replies
  ASSERT_TRUE(a && b && c && d);
  EXPECT_EQ(a->order, ReplyOrder::next);
  EXPECT_EQ(b->order, ReplyOrder::next);
  EXPECT_EQ(c->order, ReplyOrder::duplicate);
  EXPECT_EQ(d->order, ReplyOrder::gap);
  EXPECT_EQ(d->lost, 2);
}

TEST(MailboxMaster, GapAcrossTheWrap) {
  // Given a master that saw reply 6
  MailboxMaster master;
  MailboxHeader h;
  h.type = 3;
  h.counter = 6;
  ASSERT_TRUE(master.accept(build_mailbox(h, Bytes(10, 0))));
  // When reply 2 arrives (7 and 1 were lost)
  h.counter = 2;
  const auto r = master.accept(build_mailbox(h, Bytes(10, 0)));
  // Then it is a gap of 2
  ASSERT_TRUE(r);
  EXPECT_EQ(r->order, ReplyOrder::gap);
  EXPECT_EQ(r->lost, 2);
}

TEST(MailboxMaster, ReadsErrorRepliesAndTimesOut) {
  // Given a master waiting for a reply since t = 0 (timeout 100 ms)
  MailboxMaster master;
  (void)master.request(MailboxType::coe, Bytes(10, 0), milliseconds(0));
  // When 150 ms pass, and then an ERR reply (invalid channel) arrives
  EXPECT_FALSE(master.reply_overdue(milliseconds(50)));
  EXPECT_TRUE(master.reply_overdue(milliseconds(150)));
  MailboxHeader h;
  h.type = 0;
  h.counter = 1;
  const auto r = master.accept(build_mailbox(h, mailbox_error_data(MailboxError::invalid_channel)));
  // Then the wait was overdue and the reply carries the error code
  ASSERT_TRUE(r);
  EXPECT_EQ(r->error, 0x0003);
  master.reply_matched();
  EXPECT_FALSE(master.reply_overdue(milliseconds(500)));
  // And an ERR reply shorter than 4 octets is refused
  EXPECT_EQ(master.accept(build_mailbox(h, Bytes{1, 0})).error(), MailboxError::size_too_short);
}

TEST(MailboxMaster, RepeatRequestRecoversALostReply) {
  // Given a slave whose reply to request 1 the master lost (read, then corrupted on the wire)
  MailboxSlave slave;
  MailboxMaster master;
  ASSERT_EQ(slave.receive(master.request(MailboxType::coe, Bytes(10, 1), milliseconds(0))).receipt,
            MailboxReceipt::deliver);
  ASSERT_TRUE(slave.post(MailboxType::coe, Bytes(10, 2)));
  const auto lost = slave.take_reply();
  ASSERT_TRUE(lost);
  // When the master toggles the repeat request and the front end answers with repeat_last()
  const bool request_bit = master.toggle_repeat_request();
  EXPECT_FALSE(master.repeat_acknowledged(!request_bit));
  const auto again = slave.repeat_last();
  // Then the slave's ack bit (toggled to the request bit) completes it and the same reply, same
  // counter, reaches the master as its next reply
  EXPECT_TRUE(master.repeat_acknowledged(request_bit));
  ASSERT_TRUE(again);
  EXPECT_EQ(*again, *lost);
  const auto reply = master.accept(*again);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->order, ReplyOrder::next);
  EXPECT_EQ(reply->message.data[0], 2);
}

}  // namespace
}  // namespace drivecheck::ethercat
