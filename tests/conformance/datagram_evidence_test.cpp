// The evidence of a vector on EtherCAT (conformance/datagram_evidence.hpp): returned frames
// decoded, runs of identical cyclic frames counted, mailbox content always shown, a lost frame
// marked, nothing recorded without a sink, long vectors bounded.
#include "conformance/datagram_evidence.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/mailbox.hpp"

namespace drivecheck::conformance {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;
using ethercat::Command;
using ethercat::Datagram;

ethercat::TimedFrame timed(std::vector<Datagram> datagrams, can::Duration at) {
  ethercat::Frame frame;
  frame.datagrams = std::move(datagrams);
  return {*ethercat::encode_frame(frame), can::TimePoint(at)};
}

Datagram with_wkc(Datagram d, std::uint16_t wkc) {
  d.working_counter = wkc;
  return d;
}

// The master's exchange: the frame out, and back with the working counters and data given.
void exchange(DatagramEvidence& evidence, std::vector<Datagram> out, std::vector<Datagram> back,
              can::Duration at) {
  evidence.on_frame(timed(std::move(out), at), false);
  evidence.on_frame(timed(std::move(back), at + 20us), true);
}

void cycle(DatagramEvidence& evidence, std::uint8_t position, can::Duration at) {
  const auto lrw = Datagram::logical(Command::lrw, 1, 0x10000, Bytes(4));
  auto back = lrw;
  back.working_counter = 3;
  back.data = {0x0F, 0, position, 0};
  exchange(evidence, {lrw}, {back}, at);
}

TEST(DatagramEvidence, CountsRunsOfIdenticalCyclicFrames) {
  // Given a sink and five cyclic LRW frames whose process data differ
  // When they pass
  // Then there is one entry with count 5, first and last time, and no one frame's data
  VectorResult result;
  DatagramEvidence evidence;
  evidence.set_sink(&result);
  for (int i = 0; i < 5; ++i)
    cycle(evidence, static_cast<std::uint8_t>(i), i * 1ms);
  ASSERT_EQ(result.datagrams.size(), 1U);
  const auto& entry = result.datagrams[0];
  EXPECT_EQ(entry.count, 5U);
  EXPECT_EQ(entry.at, can::TimePoint(20us));
  EXPECT_EQ(entry.last, can::TimePoint(4ms + 20us));
  EXPECT_EQ(entry.decoded, "LRW logical 00010000h len 4 wkc 3");
}

TEST(DatagramEvidence, ShowsEveryMailboxDatagramAndSplitsRunsAtThem) {
  // Given a sink, a slave whose mailbox SyncManagers were configured, and cycles around two
  // identical SDO requests
  // When they pass
  // Then each request is its own entry and the cycles before and after are separate runs
  VectorResult result;
  DatagramEvidence evidence;
  evidence.set_sink(&result);
  const Bytes sm0 = ethercat::sync_manager_block(0x1000, 128, 0x26);
  const auto config =
      Datagram::physical(Command::fpwr, 1, 0x1001, ethercat::reg::kSyncManager, sm0);
  exchange(evidence, {config}, {with_wkc(config, 1)}, 0ms);
  ethercat::MailboxHeader header;
  header.type = static_cast<std::uint8_t>(ethercat::MailboxType::coe);
  header.counter = 1;
  const Bytes request =
      ethercat::build_mailbox(header, Bytes{0x00, 0x20, 0x40, 0x00, 0x10, 0x00, 0, 0, 0, 0}, 128);
  const auto write = Datagram::physical(Command::fpwr, 2, 0x1001, 0x1000, request);
  cycle(evidence, 1, 1ms);
  cycle(evidence, 2, 2ms);
  exchange(evidence, {write}, {with_wkc(write, 1)}, 3ms);
  exchange(evidence, {write}, {with_wkc(write, 1)}, 4ms);
  cycle(evidence, 3, 5ms);
  ASSERT_EQ(result.datagrams.size(), 5U);
  EXPECT_EQ(result.datagrams[1].count, 2U);
  EXPECT_NE(result.datagrams[2].decoded.find("SDO upload initiate 1000h:00"), std::string::npos)
      << result.datagrams[2].decoded;
  EXPECT_EQ(result.datagrams[2].count, 1U);
  EXPECT_EQ(result.datagrams[3].count, 1U);
  EXPECT_EQ(result.datagrams[4].count, 1U);
}

TEST(DatagramEvidence, SummarisesTheSiiReadPatternKeepingFirstAndLast) {
  // Given a sink and an SII read of 20 words: for each, the address written to 0502h (control
  // and address, the address differing) and the interface polled twice at 0500h
  VectorResult result;
  DatagramEvidence evidence;
  evidence.set_sink(&result);
  const auto poll =
      Datagram::physical(Command::fprd, 1, 0x1001, ethercat::reg::kSiiConfiguration, Bytes(16));
  for (std::uint8_t word = 0; word < 20; ++word) {
    const auto address =
        Datagram::physical(Command::fpwr, 1, 0x1001, ethercat::reg::kSiiControl,
                           Bytes{0x00, 0x01, static_cast<std::uint8_t>(4 * word), 0, 0, 0});
    exchange(evidence, {address}, {with_wkc(address, 1)}, word * 1ms);
    exchange(evidence, {poll}, {with_wkc(poll, 1)}, word * 1ms + 100us);
    exchange(evidence, {poll}, {with_wkc(poll, 1)}, word * 1ms + 200us);
  }
  // When the vector ends
  evidence.set_sink(nullptr);
  // Then the first word's two entries stand for the 18 left out (until the 19th word's poll),
  //      and the last word follows in full, its own address shown
  ASSERT_EQ(result.datagrams.size(), 4U);
  EXPECT_EQ(result.datagrams[0].repeat.length, 2U);
  EXPECT_EQ(result.datagrams[0].repeat.times, 18U);
  EXPECT_EQ(result.datagrams[0].repeat.until, can::TimePoint(18ms + 220us));
  EXPECT_NE(result.datagrams[0].decoded.find("data=00 01 00 00 00 00"), std::string::npos)
      << result.datagrams[0].decoded;
  EXPECT_EQ(result.datagrams[1].count, 2U);
  EXPECT_EQ(result.datagrams[2].repeat.times, 0U);
  EXPECT_NE(result.datagrams[2].decoded.find("data=00 01 4C 00 00 00"), std::string::npos)
      << result.datagrams[2].decoded;
}

TEST(DatagramEvidence, MailboxPollsDifferingInTheCounterAreOnePattern) {
  // Given a sink, configured mailboxes, and the same SDO request sent with counters 1..7 twice
  VectorResult result;
  DatagramEvidence evidence;
  evidence.set_sink(&result);
  const Bytes sm0 = ethercat::sync_manager_block(0x1000, 128, 0x26);
  const auto config =
      Datagram::physical(Command::fpwr, 1, 0x1001, ethercat::reg::kSyncManager, sm0);
  exchange(evidence, {config}, {with_wkc(config, 1)}, 0ms);
  for (int i = 0; i < 14; ++i) {
    ethercat::MailboxHeader header;
    header.type = static_cast<std::uint8_t>(ethercat::MailboxType::coe);
    header.counter = static_cast<std::uint8_t>(i % 7 + 1);
    const Bytes request =
        ethercat::build_mailbox(header, Bytes{0x00, 0x20, 0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0}, 128);
    const auto write = Datagram::physical(Command::fpwr, 2, 0x1001, 0x1000, request);
    exchange(evidence, {write}, {with_wkc(write, 1)}, (i + 1) * 1ms);
  }
  // When the vector ends
  evidence.set_sink(nullptr);
  // Then the configuration, the first request standing for 12 left out, and the last (cnt 7)
  ASSERT_EQ(result.datagrams.size(), 3U);
  EXPECT_EQ(result.datagrams[1].repeat.length, 1U);
  EXPECT_EQ(result.datagrams[1].repeat.times, 12U);
  EXPECT_NE(result.datagrams[1].decoded.find("cnt 1"), std::string::npos);
  EXPECT_NE(result.datagrams[2].decoded.find("cnt 7"), std::string::npos);
}

TEST(DatagramEvidence, MarksAFrameThatNeverCameBack) {
  // Given a sink
  // When a frame goes out and the next frame goes out before it came back
  // Then the first is recorded as sent, "(no answer)"
  VectorResult result;
  DatagramEvidence evidence;
  evidence.set_sink(&result);
  const auto read =
      Datagram::physical(Command::fprd, 1, 0x1001, ethercat::reg::kAlStatus, Bytes(2));
  evidence.on_frame(timed({read}, 1ms), false);
  exchange(evidence, {read}, {with_wkc(read, 1)}, 2ms);
  ASSERT_EQ(result.datagrams.size(), 2U);
  EXPECT_NE(result.datagrams[0].decoded.find("(no answer)"), std::string::npos)
      << result.datagrams[0].decoded;
  EXPECT_EQ(result.datagrams[1].decoded.find("(no answer)"), std::string::npos);
}

TEST(DatagramEvidence, WithoutASinkRecordsNothingButFollowsTheConfiguration) {
  // Given no sink while the mailbox SyncManager is configured (the bring-up)
  // When a sink is set and an SDO request is written into SM0
  // Then only the request is recorded, decoded as a mailbox
  VectorResult result;
  DatagramEvidence evidence;
  const Bytes sm0 = ethercat::sync_manager_block(0x1000, 128, 0x26);
  const auto config =
      Datagram::physical(Command::fpwr, 1, 0x1001, ethercat::reg::kSyncManager, sm0);
  exchange(evidence, {config}, {with_wkc(config, 1)}, 0ms);
  EXPECT_EQ(evidence.set_sink(&result), nullptr);
  const auto write = Datagram::physical(Command::fpwr, 2, 0x1001, 0x1000, Bytes(128));
  exchange(evidence, {write}, {with_wkc(write, 1)}, 1ms);
  ASSERT_EQ(result.datagrams.size(), 1U);
  EXPECT_NE(result.datagrams[0].decoded.find("SM0 write mailbox"), std::string::npos)
      << result.datagrams[0].decoded;
  EXPECT_EQ(evidence.set_sink(nullptr), &result);
}

TEST(DatagramEvidence, KeepsTheHeadAndTheTailOfALongVector) {
  // Given a sink
  // When 5000 frames pass that alternate between two shapes and read a new value each time
  //      (never a run, never a pattern)
  // Then the head and a tail are kept, the rest counted as elided after the head
  VectorResult result;
  DatagramEvidence evidence;
  evidence.set_sink(&result);
  for (int i = 0; i < 5000; ++i) {
    const auto d = Datagram::physical(
        Command::fprd, 1, 0x1001, i % 2 == 0 ? ethercat::reg::kAlStatus : ethercat::reg::kDlStatus,
        Bytes(2));
    auto back = with_wkc(d, 1);
    back.data = {static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(i >> 8)};
    exchange(evidence, {d}, {back}, i * 1ms);
  }
  EXPECT_LT(result.datagrams.size(),
            DatagramEvidence::kHead + DatagramEvidence::kTail + DatagramEvidence::kBatch);
  EXPECT_GE(result.datagrams.size(), DatagramEvidence::kHead + DatagramEvidence::kTail);
  EXPECT_EQ(result.datagrams.size() + result.datagrams_elided, 5000U);
  EXPECT_EQ(result.datagrams_elided_at, DatagramEvidence::kHead);
  EXPECT_EQ(result.datagrams.back().at, can::TimePoint(4999ms + 20us));
}

TEST(DatagramEvidence, ALongPatternIsOneSummaryNotAnElision) {
  // Given a sink
  // When 5000 frames pass that alternate between two register reads with the same answers
  // Then a handful of entries remain, each pattern's repetitions counted, nothing elided
  VectorResult result;
  DatagramEvidence evidence;
  evidence.set_sink(&result);
  for (int i = 0; i < 5000; ++i) {
    const auto d = Datagram::physical(
        Command::fprd, 1, 0x1001, i % 2 == 0 ? ethercat::reg::kAlStatus : ethercat::reg::kDlStatus,
        Bytes(2));
    exchange(evidence, {d}, {with_wkc(d, 1)}, i * 1ms);
  }
  evidence.set_sink(nullptr);
  EXPECT_LT(result.datagrams.size(), 50U);
  EXPECT_EQ(result.datagrams_elided, 0U);
  std::size_t shown_or_left_out = 0;
  for (const auto& entry : result.datagrams)
    shown_or_left_out += 1 + entry.repeat.times * entry.repeat.length;
  EXPECT_EQ(shown_or_left_out, 5000U);
  EXPECT_EQ(result.datagrams.back().at, can::TimePoint(4999ms + 20us));
}

}  // namespace
}  // namespace drivecheck::conformance
