// The blocking SDO client against a scripted server on the simulated bus: every exchange is
// written out frame by frame, and the server side fails the test on any frame it does not
// expect.
#include "protocol/cia301/sdo_client.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "tests/support/scripted_peer.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;
using test_support::ScriptedPeer;

constexpr Multiplexer k1008{0x1008, 0x00};

std::vector<std::uint8_t> iota_bytes(std::size_t size, std::uint8_t first = 1) {
  std::vector<std::uint8_t> bytes(size);
  std::iota(bytes.begin(), bytes.end(), first);
  return bytes;
}

// "585#C5xxyy0000000000": an end frame with the CRC of `data` in bytes 1..2.
std::string with_crc(const char* prefix, const std::vector<std::uint8_t>& data) {
  const std::uint16_t crc = crc16_ccitt(data);
  return fmt::format("{}{:02X}{:02X}0000000000", prefix, crc & 0xFF, crc >> 8);
}

// A server's block segments of `data`, numbered from 1, c on the last.
std::vector<std::string> block_segments(const std::vector<std::uint8_t>& data) {
  std::vector<std::string> frames;
  for (std::size_t at = 0, seqno = 1; at < data.size(); at += 7, ++seqno) {
    std::string text = fmt::format("585#{:02X}", (at + 7 >= data.size() ? 0x80 : 0) | seqno);
    for (std::size_t i = at; i < at + 7; ++i) {
      text += fmt::format("{:02X}", i < data.size() ? data[i] : 0);
    }
    frames.push_back(text);
  }
  return frames;
}

class SdoClientOnBus : public ::testing::Test {
 protected:
  SdoClient& client(SdoClientOptions options = {}) {
    client_ = std::make_unique<SdoClient>(*master_, 5, std::move(options));
    return *client_;
  }

  // Lets the frames the client queued last (an abort, a block end response) reach the server:
  // the blocking client returns as soon as they are queued.
  bool server_saw_all() {
    bus_.run_for(10ms);
    return peer_.finished();
  }

  can::SimBus bus_{{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> master_ = bus_.attach("master");
  std::unique_ptr<can::SimPort> server_ = bus_.attach("server");
  ScriptedPeer peer_{*server_, {0x605}};
  std::unique_ptr<SdoClient> client_;
};

// --- Every transfer type ----------------------------------------------------------------------

TEST_F(SdoClientOnBus, ExpeditedUploadOfStatusword) {
  // Given a server that answers a read of 6041h:00 with 1234h (Festo 000 L751-752)
  // When the client reads it as a 16-bit value
  // Then the value is 1234h and the server saw exactly the one request
  peer_
      .expect("605#4041600000000000")  // ccs=2, index 6041h sub 0
      .reply("585#4B41600034120000");  // scs=2 n=2 e=1 s=1, data 1234h
  const auto value = client().upload_value<std::uint16_t>({0x6041, 0});
  ASSERT_TRUE(value) << value.error().message();
  EXPECT_EQ(*value, 0x1234);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, ExpeditedDownloadOfControlword) {
  // Given a server that acknowledges a write of 6040h:00
  // When the client writes the 16-bit value 000Fh
  // Then the request is 2B 40 60 00 0F 00 and the write succeeds
  peer_
      .expect("605#2B4060000F000000")  // ccs=1 n=2 e=1 s=1, index 6040h sub 0, data 000Fh
      .reply("585#6040600000000000");  // scs=3, index 6040h sub 0
  const auto result = client().download_value<std::uint16_t>({0x6040, 0}, 0x000F);
  EXPECT_TRUE(result) << result.error().message();
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, UploadValueChecksTheSize) {
  // Given a server that answers a 32-bit read with 2 bytes
  // When the client reads a 32-bit value
  // Then the result is size_mismatch
  peer_.expect("605#4093600100000000").reply("585#4B93600134120000");
  const auto value = client().upload_value<std::uint32_t>({0x6093, 1});
  ASSERT_FALSE(value);
  EXPECT_EQ(value.error(), SdoClientError::size_mismatch);
}

TEST_F(SdoClientOnBus, SegmentedUploadOfDeviceName) {
  // Given a server holding the 10-byte device name "drivecheck" in 1008h:00
  // When the client reads it
  // Then the client toggles 0, 1 and returns the 10 bytes
  peer_.expect("605#4008100000000000").reply("585#410810000A000000");  // size 10
  peer_.expect("605#6000000000000000").reply("585#0064726976656368");  // t=0 "drivech"
  peer_.expect("605#7000000000000000").reply("585#1965636B00000000");  // t=1 n=4 c=1 "eck"
  const auto data = client().upload(k1008);
  ASSERT_TRUE(data) << data.error().message();
  EXPECT_EQ(std::string(data->begin(), data->end()), "drivecheck");
  EXPECT_TRUE(server_saw_all());
  EXPECT_EQ(client_->last_transfer().kind(), SdoTransferKind::segmented);
}

TEST_F(SdoClientOnBus, SegmentedDownload) {
  // Given a server accepting a segmented download
  // When the client writes 10 bytes
  // Then it sends the size, then segments with toggles 0 and 1, the last with c=1
  peer_.expect("605#210810000A000000").reply("585#6008100000000000");
  peer_.expect("605#0001020304050607").reply("585#2000000000000000");
  peer_.expect("605#1908090A00000000").reply("585#3000000000000000");
  EXPECT_TRUE(client().download(k1008, iota_bytes(10)));
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, BlockDownloadWithCrc) {
  // Given a server accepting a block download with CRC and blksize 127
  // When the client writes 20 bytes in block mode
  // Then 3 segments go out back to back, then the end request with n=1 and the CRC
  const auto data = iota_bytes(20);
  peer_.expect("605#C608100014000000").reply("585#A40810007F000000");
  peer_.expect("605#0101020304050607");
  peer_.expect("605#0208090A0B0C0D0E");
  peer_.expect("605#830F101112131400").reply("585#A2037F0000000000");
  peer_.expect(with_crc("605#C5", data)).reply("585#A100000000000000");
  const auto result = client().download(k1008, data, SdoTransferMode::block);
  EXPECT_TRUE(result) << result.error().message();
  EXPECT_TRUE(server_saw_all());
  EXPECT_EQ(client_->last_transfer().kind(), SdoTransferKind::block);
}

TEST_F(SdoClientOnBus, BlockUploadWithCrc) {
  // Given a server sending 20 bytes by block upload with CRC
  // When the client reads in block mode
  // Then it starts, acknowledges seqno 3, confirms the end and returns the data
  const auto data = iota_bytes(20);
  const auto segments = block_segments(data);
  peer_.expect("605#A40810007F000000").reply("585#C608100014000000");
  peer_.expect("605#A300000000000000").reply(segments[0]).reply(segments[1]).reply(segments[2]);
  peer_.expect("605#A2037F0000000000").reply(with_crc("585#C5", data));
  peer_.expect("605#A100000000000000");
  const auto result = client().upload(k1008, SdoTransferMode::block);
  ASSERT_TRUE(result) << result.error().message();
  EXPECT_EQ(*result, data);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, BlockUploadWithoutCrcAndSmallBlocks) {
  // Given a client with CRC off and blksize 2
  // When the server sends 16 bytes in sub-blocks of 2 segments
  // Then the client acknowledges each sub-block and returns the data
  SdoClientOptions options;
  options.block_crc = false;
  options.block_size = 2;
  const auto data = iota_bytes(16);
  peer_.expect("605#A008100002000000").reply("585#C208100010000000");
  peer_.expect("605#A300000000000000").reply("585#0101020304050607").reply("585#0208090A0B0C0D0E");
  peer_.expect("605#A202020000000000").reply("585#810F100000000000");
  peer_.expect("605#A201020000000000").reply("585#D500000000000000");  // n=5, no CRC
  peer_.expect("605#A100000000000000");
  const auto result = client(options).upload(k1008, SdoTransferMode::block);
  ASSERT_TRUE(result) << result.error().message();
  EXPECT_EQ(*result, data);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, BlockDownloadFallsBackToSegmented) {
  // Given a server without block transfer, which aborts a block initiate with 05040001h
  // When the client writes 3 bytes in block mode
  // Then the client retries as a normal (expedited) download and succeeds
  peer_.expect("605#C608100003000000").reply("585#8008100001000405");
  peer_.expect("605#2708100001020300").reply("585#6008100000000000");
  EXPECT_TRUE(client().download(k1008, iota_bytes(3), SdoTransferMode::block));
  EXPECT_TRUE(client_->last_transfer().fell_back());
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, BlockUploadFallsBackToSegmented) {
  // Given a server without block transfer
  // When the client reads in block mode
  // Then it falls back to a normal upload after the 05040001h abort
  peer_.expect("605#A40810007F000000").reply("585#8008100001000405");
  peer_.expect("605#4008100000000000").reply("585#4F08100041000000");
  const auto result = client().upload(k1008, SdoTransferMode::block);
  ASSERT_TRUE(result);
  EXPECT_EQ(*result, std::vector<std::uint8_t>{0x41});
  EXPECT_TRUE(server_saw_all());
}

// --- Timeouts ---------------------------------------------------------------------------------

TEST_F(SdoClientOnBus, SilentServerTimesOutAfterTheTimeout) {
  // Given a server that never answers
  // When the client reads 6041h:00 with a 100 ms timeout
  // Then the client sends abort 05040000h 100 ms after it queued its request, reports timeout
  SdoClientOptions options;
  options.timeout = 100ms;
  peer_.expect("605#4041600000000000");
  peer_.expect("605#8041600000000405");  // cs=4, abort 05040000h
  const can::TimePoint start = bus_.now();
  const auto result = client(options).upload({0x6041, 0});
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error(), SdoClientError::timeout);
  EXPECT_TRUE(server_saw_all());
  ASSERT_EQ(peer_.transcript().size(), 2u);
  // The abort is queued at the deadline and ends one frame time (< 135 us) later.
  const auto abort_end = peer_.transcript()[1].timestamp - start;
  EXPECT_GE(abort_end, 100ms);
  EXPECT_LT(abort_end, 100ms + 135us);
}

TEST_F(SdoClientOnBus, TimeoutInSegmentPhase) {
  // Given a server that stops answering after the initiate of a segmented upload
  // When the client waits for the first segment
  // Then it times out and aborts with 05040000h
  SdoClientOptions options;
  options.timeout = 50ms;
  peer_.expect("605#4008100000000000").reply("585#410810000A000000");
  peer_.expect("605#6000000000000000");
  peer_.expect("605#8008100000000405");
  EXPECT_EQ(client(options).upload(k1008).error(), SdoClientError::timeout);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, TimeoutInBlockDownloadSubBlock) {
  // Given a server that receives a sub-block but never acknowledges it
  // When the client waits for the block response
  // Then it times out and aborts with 05040000h
  SdoClientOptions options;
  options.timeout = 50ms;
  peer_.expect("605#C608100005000000").reply("585#A40810007F000000");
  peer_.expect("605#8101020304050000");
  peer_.expect("605#8008100000000405");
  EXPECT_EQ(client(options).download(k1008, iota_bytes(5), SdoTransferMode::block).error(),
            SdoClientError::timeout);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, TimeoutInBlockUploadEnd) {
  // Given a server that sends its segments but never the end request
  // When the client waits after acknowledging
  // Then it times out and aborts with 05040000h
  SdoClientOptions options;
  options.timeout = 50ms;
  peer_.expect("605#A40810007F000000").reply("585#C608100005000000");
  peer_.expect("605#A300000000000000").reply("585#8101020304050000");
  peer_.expect("605#A2017F0000000000");
  peer_.expect("605#8008100000000405");
  EXPECT_EQ(client(options).upload(k1008, SdoTransferMode::block).error(), SdoClientError::timeout);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, LateAnswerWithinTimeoutIsAccepted) {
  // Given a server that answers 80 ms late, inside the 100 ms timeout
  // When the client reads
  // Then the answer is accepted
  SdoClientOptions options;
  options.timeout = 100ms;
  peer_.expect("605#4041600000000000").reply_after(80ms, "585#4B41600034120000");
  const auto before = bus_.now();
  EXPECT_EQ(*client(options).upload_value<std::uint16_t>({0x6041, 0}), 0x1234);
  EXPECT_GE(bus_.now() - before, 80ms);
}

TEST_F(SdoClientOnBus, AnswerAfterTimeoutIsNotTakenForTheNextOne) {
  // Given a server that answers a read of 6041h:00 only after the client timed out
  // When the client then reads 6061h:00
  // Then the late 6041h answer is dropped and the second read gets its own answer
  SdoClientOptions options;
  options.timeout = 100ms;
  peer_.expect("605#4041600000000000").reply_after(150ms, "585#4B41600034120000");
  peer_.expect("605#8041600000000405");
  peer_.expect("605#4061600000000000").reply("585#4F61600001000000");
  SdoClient& sdo = client(options);
  EXPECT_EQ(sdo.upload({0x6041, 0}).error(), SdoClientError::timeout);
  bus_.run_for(100ms);  // the late answer arrives while nobody asks
  const auto second = sdo.upload_value<std::uint8_t>({0x6061, 0});
  ASSERT_TRUE(second) << second.error().message();
  EXPECT_EQ(*second, 1);
  EXPECT_TRUE(server_saw_all());
}

// --- Server aborts and protocol errors ----------------------------------------------------------

TEST_F(SdoClientOnBus, ServerAbortIsTheResult) {
  // Given the Festo example: a 32-bit write to the read-only statusword (000 L768-769)
  // When the server aborts with 06010002h
  // Then the download fails with SdoAbort::write_read_only
  peer_.expect("605#2341600000000000").reply("585#8041600002000106");
  const auto result = client().download_value<std::uint32_t>({0x6041, 0}, 0);
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error(), SdoAbort::write_read_only);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, ServerAbortInSegmentPhase) {
  // Given a segmented download in progress
  // When the server aborts the first segment with 06070012h (length too high)
  // Then the transfer fails with that code and the client sends nothing more
  peer_.expect("605#210810000A000000").reply("585#6008100000000000");
  peer_.expect("605#0001020304050607").reply("585#8008100012000706");
  EXPECT_EQ(client().download(k1008, iota_bytes(10)).error(), SdoAbort::length_too_high);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, ServerAbortInBlockUploadSubBlock) {
  // Given a block upload in the middle of a sub-block
  // When the server aborts with 08000000h
  // Then the transfer fails with the general error code
  peer_.expect("605#A40810007F000000").reply("585#C608100014000000");
  peer_.expect("605#A300000000000000").reply("585#0101020304050607").reply("585#8008100000000008");
  EXPECT_EQ(client().upload(k1008, SdoTransferMode::block).error(), SdoAbort::general_error);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, WrongToggleIsAborted) {
  // Given a segmented upload
  // When the server's first segment carries toggle 1
  // Then the client aborts with 05030000h
  peer_.expect("605#4008100000000000").reply("585#410810000A000000");
  peer_.expect("605#6000000000000000").reply("585#1064726976656368");
  peer_.expect("605#8008100000000305");
  EXPECT_EQ(client().upload(k1008).error(), SdoClientError::toggle_mismatch);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, WrongCrcIsAborted) {
  // Given a block upload whose end request carries a wrong CRC
  // When the client checks it
  // Then the client aborts with 05040004h
  const auto data = iota_bytes(5);
  peer_.expect("605#A40810007F000000").reply("585#C608100005000000");
  peer_.expect("605#A300000000000000").reply("585#8101020304050000");
  peer_.expect("605#A2017F0000000000").reply("585#C9FFFF0000000000");
  peer_.expect("605#8008100004000405");
  EXPECT_EQ(client().upload(k1008, SdoTransferMode::block).error(), SdoClientError::crc_mismatch);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, WrongAckseqIsAborted) {
  // Given a block download of one segment
  // When the server acknowledges seqno 2
  // Then the client aborts with 05040003h
  peer_.expect("605#C608100005000000").reply("585#A40810007F000000");
  peer_.expect("605#8101020304050000").reply("585#A2027F0000000000");
  peer_.expect("605#8008100003000405");
  EXPECT_EQ(client().download(k1008, iota_bytes(5), SdoTransferMode::block).error(),
            SdoClientError::sequence_error);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, SizeMismatchIsAborted) {
  // Given a server that announces 10 bytes but ends after 3
  // When the client receives the last segment
  // Then the client aborts with 06070010h
  peer_.expect("605#4008100000000000").reply("585#410810000A000000");
  peer_.expect("605#6000000000000000").reply("585#0965636B00000000");
  peer_.expect("605#8008100010000706");
  EXPECT_EQ(client().upload(k1008).error(), SdoClientError::size_mismatch);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, ShortResponseIsAborted) {
  // Given a server that answers with the Festo bytes as printed (DLC 5, no padding)
  // When the client receives it
  // Then the client aborts with 05040001h: not a valid SDO frame
  peer_.expect("605#4061600000000000").reply("585#4F61600001");
  peer_.expect("605#8061600001000405");
  EXPECT_EQ(client().upload({0x6061, 0}).error(), SdoClientError::invalid_response);
  EXPECT_TRUE(server_saw_all());
}

// --- The bus around the transfer ----------------------------------------------------------------

TEST_F(SdoClientOnBus, OtherFramesArePassedOn) {
  // Given a third node sending a heartbeat while the server answers late
  // When the client waits for its answer
  // Then the heartbeat goes to other_frames and the transfer still succeeds
  auto drive = bus_.attach("drive");
  std::vector<std::string> others;
  SdoClientOptions options;
  options.other_frames = [&](const can::TimedFrame& f) {
    others.push_back(can::to_candump(f.frame));
  };
  peer_.expect("605#4041600000000000").reply_after(10ms, "585#4B41600034120000");
  drive->start_timer_after(5ms, [&] { (void)drive->send(*can::parse_candump("706#05")); });
  EXPECT_TRUE(client(options).upload({0x6041, 0}));
  EXPECT_EQ(others, std::vector<std::string>{"706#05"});
}

TEST_F(SdoClientOnBus, StopInterruptsTheWait) {
  // Given a server that never answers and a timer that stops the bus after 10 ms
  // When the client reads with a 1 s timeout
  // Then the wait ends early, the client sends abort 08000000h and reports interrupted
  peer_.expect("605#4041600000000000");
  peer_.expect("605#8041600000000008");
  server_->start_timer_after(10ms, [&] { bus_.stop(); });
  const auto result = client().upload({0x6041, 0});
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error(), SdoClientError::interrupted);
  EXPECT_LT(bus_.now(), can::TimePoint{} + 1s);
  EXPECT_TRUE(server_saw_all());
}

TEST_F(SdoClientOnBus, BusOffIsReported) {
  // Given a master port that is bus-off
  // When the client reads
  // Then the result is the bus error and nothing reaches the server
  master_->set_bus_off(true);
  const auto result = client().upload({0x6041, 0});
  ASSERT_FALSE(result);
  EXPECT_EQ(result.error(), can::BusError::bus_off);
  EXPECT_EQ(peer_.transcript().size(), 0u);
}

TEST_F(SdoClientOnBus, ConfigurableCobIds) {
  // Given a server on the second SDO channel, 641h / 5C1h
  // When the client is configured with those COB-IDs
  // Then requests go to 641h and answers on 5C1h are accepted
  auto other = bus_.attach("other server");
  ScriptedPeer second(*other, {0x641});
  second.expect("641#4041600000000000").reply("5C1#4B41600034120000");
  SdoClientOptions options;
  options.cob_ids = SdoCobIds{0x641, 0x5C1};
  EXPECT_EQ(*client(options).upload_value<std::uint16_t>({0x6041, 0}), 0x1234);
  EXPECT_TRUE(second.finished());
}

}  // namespace
}  // namespace drivecheck::cia301
