// The SDO client state machine fed frames and time directly, without a bus: every frame it
// emits is compared as candump text.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <numeric>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/cia301/sdo_client.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;
using Frames = std::vector<std::string>;

constexpr Multiplexer k1008{0x1008, 0x00};
constexpr Multiplexer k6041{0x6041, 0x00};

// Drives one SdoClientTransfer for node 5 (605h / 585h) with a hand-held clock.
class Driver {
 public:
  explicit Driver(SdoClientOptions options = {}) : transfer_(5, std::move(options)) {}

  Frames upload(Multiplexer mux) { return text(transfer_.start_upload(mux, now_)); }
  Frames upload(Multiplexer mux, SdoTransferMode mode) {
    return text(transfer_.start_upload(mux, now_, mode));
  }
  Frames download(Multiplexer mux, const std::vector<std::uint8_t>& data) {
    return text(transfer_.start_download(mux, data, now_));
  }
  Frames download(Multiplexer mux, const std::vector<std::uint8_t>& data, SdoTransferMode mode) {
    return text(transfer_.start_download(mux, data, now_, mode));
  }
  // The server's frame arrives 1 ms later.
  Frames reply(std::string_view candump) {
    now_ += 1ms;
    auto frame = can::parse_candump(candump);
    EXPECT_TRUE(frame) << candump;
    return frame ? text(transfer_.on_frame(*frame, now_)) : Frames{};
  }
  Frames advance(can::Duration by) {
    now_ += by;
    return text(transfer_.on_time(now_));
  }

  SdoClientTransfer& transfer() { return transfer_; }
  std::vector<std::uint8_t> data() const {
    return {transfer_.data().begin(), transfer_.data().end()};
  }

 private:
  static Frames text(std::span<const can::Frame> frames) {
    Frames out;
    for (const auto& frame : frames)
      out.push_back(can::to_candump(frame));
    return out;
  }

  SdoClientTransfer transfer_;
  can::TimePoint now_{};
};

std::vector<std::uint8_t> iota_bytes(std::size_t size, std::uint8_t first = 1) {
  std::vector<std::uint8_t> bytes(size);
  std::iota(bytes.begin(), bytes.end(), first);
  return bytes;
}

std::uint32_t code(SdoAbort abort) {
  return static_cast<std::uint32_t>(abort);
}

// --- Expedited -------------------------------------------------------------------------------

TEST(SdoClientExpedited, UploadReturnsIndicatedBytes) {
  // Given a client reading 6041h:00
  // When the server answers expedited with 2 bytes
  // Then the client sent one initiate upload and returns exactly those 2 bytes
  Driver d;
  // ccs=2, index 6041h sub 0
  EXPECT_EQ(d.upload(k6041), Frames{"605#4041600000000000"});
  // scs=2 n=2 e=1 s=1, index 6041h sub 0, data 1234h
  EXPECT_EQ(d.reply("585#4B41600034120000"), Frames{});
  EXPECT_TRUE(d.transfer().succeeded());
  EXPECT_EQ(d.data(), (std::vector<std::uint8_t>{0x34, 0x12}));
  EXPECT_EQ(d.transfer().kind(), SdoTransferKind::expedited);
  EXPECT_EQ(d.transfer().next_deadline(), can::kForever);
}

TEST(SdoClientExpedited, UploadWithoutSizeReturnsFourBytes) {
  // Given a client reading 6041h:00
  // When the server answers expedited without size indicator (42h)
  // Then the client returns all 4 data bytes
  Driver d;
  d.upload(k6041);
  // scs=2 e=1 s=0, index 6041h sub 0, data 01 02 03 04
  d.reply("585#4241600001020304");
  EXPECT_EQ(d.data(), (std::vector<std::uint8_t>{1, 2, 3, 4}));
}

TEST(SdoClientExpedited, DownloadSendsSizedRequest) {
  // Given a client writing 03E8h to 6040h:00 (Festo 000 L751)
  // When the server acknowledges
  // Then the request was 2B 40 60 00 E8 03 and the transfer succeeded
  Driver d;
  // ccs=1 n=2 e=1 s=1, index 6040h sub 0, data 03E8h
  EXPECT_EQ(d.download({0x6040, 0}, {0xE8, 0x03}), Frames{"605#2B406000E8030000"});
  // scs=3, index 6040h sub 0
  EXPECT_EQ(d.reply("585#6040600000000000"), Frames{});
  EXPECT_TRUE(d.transfer().succeeded());
}

// --- Segmented -------------------------------------------------------------------------------

TEST(SdoClientSegmented, UploadTogglesAndCollects) {
  // Given a client reading 1008h:00
  // When the server announces 10 bytes and sends them in two segments
  // Then the client asks with toggle 0, then 1, and returns the 10 bytes
  Driver d;
  d.upload(k1008);
  // scs=2 e=0 s=1, index 1008h sub 0, size 10
  EXPECT_EQ(d.reply("585#410810000A000000"), Frames{"605#6000000000000000"});  // ccs=3 t=0
  // scs=0 t=0 n=0 c=0, data "drivech"
  EXPECT_EQ(d.reply("585#0064726976656368"), Frames{"605#7000000000000000"});  // ccs=3 t=1
  // scs=0 t=1 n=4 c=1, data "eck"
  EXPECT_EQ(d.reply("585#1965636B00000000"), Frames{});
  ASSERT_TRUE(d.transfer().succeeded()) << d.transfer().error().message();
  const auto data = d.data();
  EXPECT_EQ(std::string(data.begin(), data.end()), "drivecheck");
  EXPECT_EQ(d.transfer().kind(), SdoTransferKind::segmented);
}

TEST(SdoClientSegmented, UploadWithoutSizeIndicated) {
  // Given a client reading 1008h:00
  // When the server does not indicate the size and sends one last segment of 3 bytes
  // Then the client returns the 3 bytes
  Driver d;
  d.upload(k1008);
  // scs=2 e=0 s=0, index 1008h sub 0
  d.reply("585#4008100000000000");
  // scs=0 t=0 n=4 c=1, data 01 02 03
  d.reply("585#0901020300000000");
  EXPECT_EQ(d.data(), (std::vector<std::uint8_t>{1, 2, 3}));
}

TEST(SdoClientSegmented, DownloadSplitsIntoSevenByteSegments) {
  // Given a client writing 10 bytes to 1008h:00
  // When the server acknowledges each step with the right toggle
  // Then the client sent the size, a full segment (t=0), and a last segment of 3 bytes (t=1)
  Driver d;
  // ccs=1 e=0 s=1, index 1008h sub 0, size 10
  EXPECT_EQ(d.download(k1008, iota_bytes(10)), Frames{"605#210810000A000000"});
  // scs=3, index 1008h sub 0 → ccs=0 t=0 n=0 c=0, data 01..07
  EXPECT_EQ(d.reply("585#6008100000000000"), Frames{"605#0001020304050607"});
  // scs=1 t=0 → ccs=0 t=1 n=4 c=1, data 08 09 0A
  EXPECT_EQ(d.reply("585#2000000000000000"), Frames{"605#1908090A00000000"});
  // scs=1 t=1
  EXPECT_EQ(d.reply("585#3000000000000000"), Frames{});
  EXPECT_TRUE(d.transfer().succeeded());
}

TEST(SdoClientSegmented, ForcedSegmentedDownloadOfTwoBytes) {
  // Given a client writing 2 bytes with SdoTransferMode::segmented
  // When the server acknowledges
  // Then the client used a segmented initiate (size 2) and one last segment
  Driver d;
  // ccs=1 e=0 s=1, index 6040h sub 0, size 2
  EXPECT_EQ(d.download({0x6040, 0}, {0x0F, 0x00}, SdoTransferMode::segmented),
            Frames{"605#2140600002000000"});
  // scs=3 → ccs=0 t=0 n=5 c=1, data 0F 00
  EXPECT_EQ(d.reply("585#6040600000000000"), Frames{"605#0B0F000000000000"});
  d.reply("585#2000000000000000");
  EXPECT_TRUE(d.transfer().succeeded());
}

TEST(SdoClientSegmented, EmptyDownloadIsOneEmptySegment) {
  // Given a client writing 0 bytes
  // When the server acknowledges
  // Then the client announced size 0 and sent one last segment with n=7
  Driver d;
  EXPECT_EQ(d.download(k1008, {}), Frames{"605#2108100000000000"});
  // ccs=0 t=0 n=7 c=1
  EXPECT_EQ(d.reply("585#6008100000000000"), Frames{"605#0F00000000000000"});
  d.reply("585#2000000000000000");
  EXPECT_TRUE(d.transfer().succeeded());
}

// --- Block download ---------------------------------------------------------------------------

TEST(SdoClientBlockDownload, WithCrcInOneSubBlock) {
  // Given a client writing 20 bytes in block mode with CRC
  // When the server offers blksize 127 with CRC and acknowledges all 3 segments
  // Then the client sends 3 segments (c on the last), the end request with n=1 and the CRC
  Driver d;
  const auto data = iota_bytes(20);
  // ccs=6 cc=1 s=1 cs=0, index 1008h sub 0, size 20
  EXPECT_EQ(d.download(k1008, data, SdoTransferMode::block), Frames{"605#C608100014000000"});
  // scs=5 sc=1 ss=0, blksize 127 → seqno 1, 2, and 3 with c=1
  EXPECT_EQ(d.reply("585#A40810007F000000"),
            (Frames{"605#0101020304050607", "605#0208090A0B0C0D0E", "605#830F101112131400"}));
  const std::uint16_t crc = crc16_ccitt(data);
  // scs=5 ss=2 ackseq 3 blksize 127 → ccs=6 n=1 cs=1, CRC
  EXPECT_EQ(d.reply("585#A2037F0000000000"),
            Frames{fmt::format("605#C5{:02X}{:02X}0000000000", crc & 0xFF, crc >> 8)});
  // scs=5 ss=1
  EXPECT_EQ(d.reply("585#A100000000000000"), Frames{});
  EXPECT_TRUE(d.transfer().succeeded());
  EXPECT_EQ(d.transfer().kind(), SdoTransferKind::block);
}

TEST(SdoClientBlockDownload, SubBlocksFollowTheServersBlockSize) {
  // Given a client writing 30 bytes in block mode
  // When the server asks for sub-blocks of 2 segments
  // Then the client sends 2 + 2 + 1 segments, each sub-block numbered from 1
  Driver d;
  d.download(k1008, iota_bytes(30), SdoTransferMode::block);
  // scs=5 sc=0 ss=0, blksize 2
  EXPECT_EQ(d.reply("585#A008100002000000").size(), 2u);
  // ackseq 2 blksize 2
  const auto second = d.reply("585#A202020000000000");
  EXPECT_EQ(second, (Frames{"605#010F101112131415", "605#02161718191A1B1C"}));
  // ackseq 2 blksize 2 → the last 2 bytes: seqno 1, c=1
  EXPECT_EQ(d.reply("585#A202020000000000"), Frames{"605#811D1E0000000000"});
  // ackseq 1 → end request without CRC (server did not support it): n=5, crc 0
  EXPECT_EQ(d.reply("585#A201020000000000"), Frames{"605#D500000000000000"});
}

TEST(SdoClientBlockDownload, RetransmitsSegmentsAfterAckseq) {
  // Given a client that sent 3 segments of a 20-byte block download
  // When the server acknowledges only segment 1
  // Then the client sends segments 2 and 3 again, renumbered 1 and 2
  Driver d;
  d.download(k1008, iota_bytes(20), SdoTransferMode::block);
  d.reply("585#A40810007F000000");
  // scs=5 ss=2 ackseq 1 blksize 127
  EXPECT_EQ(d.reply("585#A2017F0000000000"),
            (Frames{"605#0108090A0B0C0D0E", "605#820F101112131400"}));
  EXPECT_TRUE(d.transfer().running());
}

TEST(SdoClientBlockDownload, FallsBackToSegmentedOnInvalidCommandSpecifier) {
  // Given a client writing 10 bytes in block mode with fallback enabled (default)
  // When the server aborts the block initiate with 05040001h
  // Then the client starts a segmented download of the same data and completes it
  Driver d;
  d.download(k1008, iota_bytes(10), SdoTransferMode::block);
  // cs=4, index 1008h sub 0, abort 05040001h → ccs=1 e=0 s=1 size 10
  EXPECT_EQ(d.reply("585#8008100001000405"), Frames{"605#210810000A000000"});
  d.reply("585#6008100000000000");
  d.reply("585#2000000000000000");
  d.reply("585#3000000000000000");
  EXPECT_TRUE(d.transfer().succeeded());
  EXPECT_TRUE(d.transfer().fell_back());
  EXPECT_EQ(d.transfer().kind(), SdoTransferKind::segmented);
}

TEST(SdoClientBlockDownload, NoFallbackWhenDisabled) {
  // Given a client with block_fallback off
  // When the server aborts the block initiate with 05040001h
  // Then the transfer fails with that abort code and nothing more is sent
  SdoClientOptions options;
  options.block_fallback = false;
  Driver d(options);
  d.download(k1008, iota_bytes(10), SdoTransferMode::block);
  EXPECT_EQ(d.reply("585#8008100001000405"), Frames{});
  EXPECT_EQ(d.transfer().error(), SdoAbort::invalid_command_specifier);
}

TEST(SdoClientBlockDownload, AckseqBeyondSegmentsSentAborts) {
  // Given a client that sent 3 segments
  // When the server acknowledges segment 5
  // Then the client aborts with 05040003h (invalid sequence number)
  Driver d;
  d.download(k1008, iota_bytes(20), SdoTransferMode::block);
  d.reply("585#A40810007F000000");
  // ackseq 5
  EXPECT_EQ(d.reply("585#A2057F0000000000"), Frames{"605#8008100003000405"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::sequence_error);
}

TEST(SdoClientBlockDownload, InvalidServerBlockSizeAborts) {
  // Given a client starting a block download
  // When the server offers blksize 0, or 128
  // Then the client aborts with 05040002h (invalid block size)
  for (const char* response : {"585#A408100000000000", "585#A408100080000000"}) {
    Driver d;
    d.download(k1008, iota_bytes(20), SdoTransferMode::block);
    EXPECT_EQ(d.reply(response), Frames{"605#8008100002000405"}) << response;
    EXPECT_EQ(d.transfer().error(), SdoClientError::invalid_block_size);
  }
}

// --- Block upload -----------------------------------------------------------------------------

// A server's block upload of `data`: segments of 7 bytes, c on the last, no loss.
Frames block_segments(const std::vector<std::uint8_t>& data, std::size_t first_seqno = 1) {
  Frames frames;
  for (std::size_t at = 0, seqno = first_seqno; at < data.size(); at += 7, ++seqno) {
    std::string text = fmt::format("585#{:02X}", (at + 7 >= data.size() ? 0x80 : 0) | seqno);
    for (std::size_t i = at; i < at + 7; ++i) {
      text += fmt::format("{:02X}", i < data.size() ? data[i] : 0);
    }
    frames.push_back(text);
  }
  return frames;
}

TEST(SdoClientBlockUpload, WithCrcInOneSubBlock) {
  // Given a client reading 1008h:00 in block mode (CRC, blksize 127, pst 0)
  // When the server sends 20 bytes in 3 segments, then n=1 and the right CRC
  // Then the client starts, acknowledges seqno 3, confirms the end and returns the 20 bytes
  Driver d;
  const auto data = iota_bytes(20);
  // ccs=5 cc=1 cs=0, index 1008h sub 0, blksize 127, pst 0
  EXPECT_EQ(d.upload(k1008, SdoTransferMode::block), Frames{"605#A40810007F000000"});
  // scs=6 sc=1 s=1 ss=0, size 20 → ccs=5 cs=3 (start)
  EXPECT_EQ(d.reply("585#C608100014000000"), Frames{"605#A300000000000000"});
  const Frames segments = block_segments(data);
  EXPECT_EQ(d.reply(segments[0]), Frames{});
  EXPECT_EQ(d.reply(segments[1]), Frames{});
  // last segment → ccs=5 cs=2 ackseq 3 blksize 127
  EXPECT_EQ(d.reply(segments[2]), Frames{"605#A2037F0000000000"});
  const std::uint16_t crc = crc16_ccitt(data);
  // scs=6 n=1 ss=1, CRC → ccs=5 cs=1
  EXPECT_EQ(d.reply(fmt::format("585#C5{:02X}{:02X}0000000000", crc & 0xFF, crc >> 8)),
            Frames{"605#A100000000000000"});
  ASSERT_TRUE(d.transfer().succeeded()) << d.transfer().error().message();
  EXPECT_EQ(d.data(), data);
  EXPECT_EQ(d.transfer().kind(), SdoTransferKind::block);
}

TEST(SdoClientBlockUpload, AcknowledgesEverySubBlock) {
  // Given a client with block_size 2 reading 30 bytes
  // When the server sends sub-blocks of 2 segments
  // Then the client acknowledges seqno 2 after each full sub-block and 1 after the last
  SdoClientOptions options;
  options.block_size = 2;
  options.block_crc = false;
  Driver d(options);
  const auto data = iota_bytes(30);
  // ccs=5 cc=0 cs=0, index 1008h sub 0, blksize 2, pst 0
  EXPECT_EQ(d.upload(k1008, SdoTransferMode::block), Frames{"605#A008100002000000"});
  // scs=6 sc=0 s=1 ss=0, size 30
  EXPECT_EQ(d.reply("585#C20810001E000000"), Frames{"605#A300000000000000"});
  const Frames all = block_segments(data);
  // the server numbers each sub-block from 1
  const Frames sub1 = {all[0], all[1]};
  const Frames sub2 = block_segments({data.begin() + 14, data.end()});
  EXPECT_EQ(d.reply(sub1[0]), Frames{});
  EXPECT_EQ(d.reply(sub1[1]), Frames{"605#A202020000000000"});
  EXPECT_EQ(d.reply(sub2[0]), Frames{});
  EXPECT_EQ(d.reply(sub2[1]), Frames{"605#A202020000000000"});
  // last sub-block: 2 bytes, seqno 1 with c
  EXPECT_EQ(d.reply(block_segments({data.begin() + 28, data.end()})[0]),
            Frames{"605#A201020000000000"});
  // scs=6 n=5 ss=1, no CRC
  EXPECT_EQ(d.reply("585#D500000000000000"), Frames{"605#A100000000000000"});
  EXPECT_EQ(d.data(), data);
}

TEST(SdoClientBlockUpload, LostSegmentIsAcknowledgedUpToTheGap) {
  // Given a client receiving a 20-byte block upload
  // When segment 2 is lost and segment 3 (c=1) arrives
  // Then the client acknowledges seqno 1, and accepts segments 2 and 3 resent as 1 and 2
  Driver d;
  const auto data = iota_bytes(20);
  d.upload(k1008, SdoTransferMode::block);
  d.reply("585#C608100014000000");
  const Frames segments = block_segments(data);
  d.reply(segments[0]);
  // seqno 3 with c=1 out of sequence → ackseq 1
  EXPECT_EQ(d.reply(segments[2]), Frames{"605#A2017F0000000000"});
  const Frames resent = block_segments({data.begin() + 7, data.end()});
  d.reply(resent[0]);
  EXPECT_EQ(d.reply(resent[1]), Frames{"605#A2027F0000000000"});
  const std::uint16_t crc = crc16_ccitt(data);
  d.reply(fmt::format("585#C5{:02X}{:02X}0000000000", crc & 0xFF, crc >> 8));
  ASSERT_TRUE(d.transfer().succeeded()) << d.transfer().error().message();
  EXPECT_EQ(d.data(), data);
}

TEST(SdoClientBlockUpload, EmptyObject) {
  // Given a server block-uploading an empty object (size 0)
  // When it sends one segment with c=1 and then n=7
  // Then the client returns 0 bytes
  Driver d;
  d.upload(k1008, SdoTransferMode::block);
  // scs=6 sc=1 s=1 ss=0, size 0
  EXPECT_EQ(d.reply("585#C608100000000000"), Frames{"605#A300000000000000"});
  // c=1 seqno=1, no data
  EXPECT_EQ(d.reply("585#8100000000000000"), Frames{"605#A2017F0000000000"});
  // scs=6 n=7 ss=1, CRC of no data = 0
  EXPECT_EQ(d.reply("585#DD00000000000000"), Frames{"605#A100000000000000"});
  ASSERT_TRUE(d.transfer().succeeded()) << d.transfer().error().message();
  EXPECT_TRUE(d.data().empty());
}

TEST(SdoClientBlockUpload, ProtocolSwitchToExpedited) {
  // Given a client reading in block mode with pst 10
  // When the server answers with an expedited initiate upload response
  // Then the client accepts the switch and returns the data
  SdoClientOptions options;
  options.protocol_switch_threshold = 10;
  Driver d(options);
  // ccs=5 cc=1, blksize 127, pst 10
  EXPECT_EQ(d.upload(k6041, SdoTransferMode::block), Frames{"605#A44160007F0A0000"});
  // scs=2 n=2 e=1 s=1, data 1234h
  EXPECT_EQ(d.reply("585#4B41600034120000"), Frames{});
  EXPECT_TRUE(d.transfer().succeeded());
  EXPECT_EQ(d.transfer().kind(), SdoTransferKind::expedited);
  EXPECT_EQ(d.data(), (std::vector<std::uint8_t>{0x34, 0x12}));
}

TEST(SdoClientBlockUpload, ProtocolSwitchWithoutThresholdIsUnexpected) {
  // Given a client reading in block mode with pst 0 (no switch allowed)
  // When the server answers with an expedited initiate upload response
  // Then the client aborts with 05040001h
  Driver d;
  d.upload(k6041, SdoTransferMode::block);
  EXPECT_EQ(d.reply("585#4B41600034120000"), Frames{"605#8041600001000405"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::unexpected_response);
}

TEST(SdoClientBlockUpload, FallsBackToSegmentedOnInvalidCommandSpecifier) {
  // Given a client reading in block mode
  // When the server aborts the block initiate with 05040001h
  // Then the client sends a normal initiate upload request
  Driver d;
  d.upload(k1008, SdoTransferMode::block);
  EXPECT_EQ(d.reply("585#8008100001000405"), Frames{"605#4008100000000000"});
  d.reply("585#4F08100041000000");
  EXPECT_TRUE(d.transfer().succeeded());
  EXPECT_TRUE(d.transfer().fell_back());
}

TEST(SdoClientBlockUpload, WrongCrcAborts) {
  // Given a client receiving a 20-byte block upload with CRC
  // When the end request carries a wrong CRC
  // Then the client aborts with 05040004h (CRC error)
  Driver d;
  const auto data = iota_bytes(20);
  d.upload(k1008, SdoTransferMode::block);
  d.reply("585#C608100014000000");
  for (const auto& segment : block_segments(data))
    d.reply(segment);
  const std::uint16_t wrong = crc16_ccitt(data) ^ 0x0001;
  EXPECT_EQ(d.reply(fmt::format("585#C5{:02X}{:02X}0000000000", wrong & 0xFF, wrong >> 8)),
            Frames{"605#8008100004000405"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::crc_mismatch);
}

TEST(SdoClientBlockUpload, CrcIgnoredWhenServerLacksIt) {
  // Given a client offering CRC
  // When the server's initiate response says it has no CRC and the end request carries 0
  // Then the client does not check the CRC and succeeds
  Driver d;
  const auto data = iota_bytes(20);
  d.upload(k1008, SdoTransferMode::block);
  // scs=6 sc=0 s=1 ss=0, size 20
  d.reply("585#C208100014000000");
  for (const auto& segment : block_segments(data))
    d.reply(segment);
  EXPECT_EQ(d.reply("585#C500000000000000"), Frames{"605#A100000000000000"});
  EXPECT_TRUE(d.transfer().succeeded());
}

TEST(SdoClientBlockUpload, SizeMismatchAborts) {
  // Given a server that announces 10 bytes
  // When it sends 20 bytes of segments
  // Then the client aborts with 06070010h once the data exceed the size
  Driver d;
  d.upload(k1008, SdoTransferMode::block);
  // size 10
  d.reply("585#C60810000A000000");
  const Frames segments = block_segments(iota_bytes(20));
  d.reply(segments[0]);
  EXPECT_EQ(d.reply(segments[1]), Frames{"605#8008100010000706"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::size_mismatch);
}

TEST(SdoClientBlockUpload, FinalSizeShorterThanIndicatedAborts) {
  // Given a server that announces 20 bytes
  // When its end request says the last segment held only 1 byte (13 bytes in all)
  // Then the client aborts with 06070010h
  Driver d;
  d.upload(k1008, SdoTransferMode::block);
  d.reply("585#C608100014000000");
  const Frames segments = block_segments(iota_bytes(14));
  d.reply(segments[0]);
  d.reply(segments[1]);
  // scs=6 n=6 ss=1
  EXPECT_EQ(d.reply("585#D900000000000000"), Frames{"605#8008100010000706"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::size_mismatch);
}

TEST(SdoClientBlockUpload, SequenceNumberOutOfRangeAborts) {
  // Given a client with blksize 4 in a block upload
  // When a segment with seqno 0, or seqno 5, arrives
  // Then the client aborts with 05040003h
  for (const char* segment : {"585#0011223344556677", "585#0511223344556677"}) {
    SdoClientOptions options;
    options.block_size = 4;
    Driver d(options);
    d.upload(k1008, SdoTransferMode::block);
    d.reply("585#C608100014000000");
    EXPECT_EQ(d.reply(segment), Frames{"605#8008100003000405"}) << segment;
    EXPECT_EQ(d.transfer().error(), SdoClientError::sequence_error);
  }
}

TEST(SdoClientBlockUpload, InvalidBlockSizeOptionFailsAtStart) {
  // Given a client whose block_size option is 0
  // When a block upload starts
  // Then it fails at once with invalid_argument and sends nothing
  SdoClientOptions options;
  options.block_size = 0;
  Driver d(options);
  EXPECT_EQ(d.upload(k1008, SdoTransferMode::block), Frames{});
  EXPECT_EQ(d.transfer().error(), SdoClientError::invalid_argument);
}

// --- Timeouts in every phase -------------------------------------------------------------------

struct Phase {
  const char* name;
  SdoTransferMode mode;
  bool upload;
  std::vector<const char*> server;  // the server's frames before it goes silent
};

class SdoClientTimeout : public ::testing::TestWithParam<Phase> {};

TEST_P(SdoClientTimeout, SendsTimeoutAbort) {
  // Given a transfer that reached the phase under test
  // When the server stays silent past the timeout (1 s)
  // Then nothing happens before the deadline, and at it the client sends abort 05040000h
  const Phase& phase = GetParam();
  Driver d;
  if (phase.upload) {
    d.upload(k1008, phase.mode);
  } else {
    d.download(k1008, iota_bytes(20), phase.mode);
  }
  for (const char* frame : phase.server)
    d.reply(frame);
  ASSERT_TRUE(d.transfer().running()) << phase.name;
  EXPECT_EQ(d.advance(999ms), Frames{});
  EXPECT_TRUE(d.transfer().running());
  EXPECT_EQ(d.advance(1ms), Frames{"605#8008100000000405"});  // abort 05040000h
  EXPECT_EQ(d.transfer().error(), SdoClientError::timeout);
  EXPECT_EQ(d.transfer().sent_abort(), code(SdoAbort::protocol_timed_out));
}

INSTANTIATE_TEST_SUITE_P(
    EveryPhase, SdoClientTimeout,
    ::testing::Values(
        Phase{"UploadInitiate", SdoTransferMode::automatic, true, {}},
        Phase{"UploadSegment", SdoTransferMode::automatic, true, {"585#4108100014000000"}},
        Phase{"DownloadInitiate", SdoTransferMode::automatic, false, {}},
        Phase{"DownloadSegment", SdoTransferMode::automatic, false, {"585#6008100000000000"}},
        Phase{"BlockDownloadInitiate", SdoTransferMode::block, false, {}},
        Phase{"BlockDownloadSubBlock", SdoTransferMode::block, false, {"585#A40810007F000000"}},
        Phase{"BlockDownloadEnd",
              SdoTransferMode::block,
              false,
              {"585#A40810007F000000", "585#A2037F0000000000"}},
        Phase{"BlockUploadInitiate", SdoTransferMode::block, true, {}},
        Phase{"BlockUploadSubBlock", SdoTransferMode::block, true, {"585#C608100014000000"}},
        Phase{"BlockUploadMidSubBlock",
              SdoTransferMode::block,
              true,
              {"585#C608100014000000", "585#0101020304050607"}},
        Phase{"BlockUploadEnd",
              SdoTransferMode::block,
              true,
              {"585#C608100014000000", "585#0101020304050607", "585#0208090A0B0C0D0E",
               "585#830F101112131400"}}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

// --- Server aborts in every phase ---------------------------------------------------------------

class SdoClientServerAbort : public ::testing::TestWithParam<Phase> {};

TEST_P(SdoClientServerAbort, EndsWithTheServersCode) {
  // Given a transfer that reached the phase under test
  // When the server aborts with 08000022h (device state)
  // Then the transfer fails with exactly that code and the client sends nothing back
  const Phase& phase = GetParam();
  Driver d;
  if (phase.upload) {
    d.upload(k1008, phase.mode);
  } else {
    d.download(k1008, iota_bytes(20), phase.mode);
  }
  for (const char* frame : phase.server)
    d.reply(frame);
  ASSERT_TRUE(d.transfer().running()) << phase.name;
  // cs=4, index 1008h sub 0, abort 08000022h
  EXPECT_EQ(d.reply("585#8008100022000008"), Frames{});
  EXPECT_EQ(d.transfer().error(), SdoAbort::cannot_transfer_device_state);
  EXPECT_EQ(server_abort_code(d.transfer().error()), 0x08000022u);
  EXPECT_FALSE(d.transfer().sent_abort());
}

INSTANTIATE_TEST_SUITE_P(
    EveryPhase, SdoClientServerAbort,
    ::testing::Values(
        Phase{"UploadInitiate", SdoTransferMode::automatic, true, {}},
        Phase{"UploadSegment", SdoTransferMode::automatic, true, {"585#4108100014000000"}},
        Phase{"DownloadInitiate", SdoTransferMode::automatic, false, {}},
        Phase{"DownloadSegment", SdoTransferMode::automatic, false, {"585#6008100000000000"}},
        Phase{"BlockDownloadInitiate", SdoTransferMode::block, false, {}},
        Phase{"BlockDownloadSubBlock", SdoTransferMode::block, false, {"585#A40810007F000000"}},
        Phase{"BlockDownloadEnd",
              SdoTransferMode::block,
              false,
              {"585#A40810007F000000", "585#A2037F0000000000"}},
        Phase{"BlockUploadInitiate", SdoTransferMode::block, true, {}},
        Phase{"BlockUploadSubBlock", SdoTransferMode::block, true, {"585#C608100014000000"}},
        Phase{"BlockUploadEnd",
              SdoTransferMode::block,
              true,
              {"585#C608100014000000", "585#0101020304050607", "585#0208090A0B0C0D0E",
               "585#830F101112131400"}}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

// --- Strict checks ------------------------------------------------------------------------------

TEST(SdoClientStrict, WrongMultiplexerAborts) {
  // Given a client reading 6041h:00
  // When the server answers for 6040h:00
  // Then the client aborts with 08000000h and reports wrong_multiplexer
  Driver d;
  d.upload(k6041);
  // scs=2 n=2 e=1 s=1, index 6040h sub 0
  EXPECT_EQ(d.reply("585#4B40600034120000"), Frames{"605#8041600000000008"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::wrong_multiplexer);
}

TEST(SdoClientStrict, WrongSubIndexAborts) {
  // Given a client writing 6093h:01
  // When the server acknowledges 6093h:02
  // Then the client reports wrong_multiplexer
  Driver d;
  d.download({0x6093, 1}, {1, 2, 3, 4});
  d.reply("585#6093600200000000");
  EXPECT_EQ(d.transfer().error(), SdoClientError::wrong_multiplexer);
}

TEST(SdoClientSegmented, WrongToggleAbortsUpload) {
  // Given a segmented upload waiting for the segment with toggle 0
  // When the server sends toggle 1
  // Then the client aborts with 05030000h
  Driver d;
  d.upload(k1008);
  d.reply("585#410810000A000000");
  // scs=0 t=1 n=0 c=0
  EXPECT_EQ(d.reply("585#1064726976656368"), Frames{"605#8008100000000305"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::toggle_mismatch);
}

TEST(SdoClientSegmented, WrongToggleAbortsDownload) {
  // Given a segmented download whose second segment had toggle 1
  // When the server confirms it with toggle 0
  // Then the client aborts with 05030000h
  Driver d;
  d.download(k1008, iota_bytes(10));
  d.reply("585#6008100000000000");
  d.reply("585#2000000000000000");
  // scs=1 t=0 (expected t=1)
  EXPECT_EQ(d.reply("585#2000000000000000"), Frames{"605#8008100000000305"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::toggle_mismatch);
}

TEST(SdoClientSegmented, MoreDataThanIndicatedAborts) {
  // Given a server that announced 5 bytes
  // When its first segment carries 7
  // Then the client aborts with 06070010h
  Driver d;
  d.upload(k1008);
  d.reply("585#4108100005000000");
  EXPECT_EQ(d.reply("585#0064726976656368"), Frames{"605#8008100010000706"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::size_mismatch);
}

TEST(SdoClientSegmented, LessDataThanIndicatedAborts) {
  // Given a server that announced 10 bytes
  // When its last segment ends the transfer after 3
  // Then the client aborts with 06070010h
  Driver d;
  d.upload(k1008);
  d.reply("585#410810000A000000");
  EXPECT_EQ(d.reply("585#0965636B00000000"), Frames{"605#8008100010000706"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::size_mismatch);
}

TEST(SdoClientSegmented, OversizeUploadAborts) {
  // Given a client that accepts at most 8 bytes
  // When the server announces 100 bytes, or sends more than 8 without a size
  // Then the client aborts with 05040005h (out of memory)
  SdoClientOptions options;
  options.max_upload_size = 8;
  Driver d(options);
  d.upload(k1008);
  EXPECT_EQ(d.reply("585#4108100064000000"), Frames{"605#8008100005000405"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::data_too_large);

  Driver e(options);
  e.upload(k1008);
  e.reply("585#4008100000000000");
  e.reply("585#0064726976656368");
  EXPECT_EQ(e.reply("585#1064726976656368"), Frames{"605#8008100005000405"});
  EXPECT_EQ(e.transfer().error(), SdoClientError::data_too_large);
}

TEST(SdoClientStrict, UnexpectedCommandSpecifierAborts) {
  // Given a client reading 6041h:00
  // When the server answers with a download response (scs=3)
  // Then the client aborts with 05040001h
  Driver d;
  d.upload(k6041);
  EXPECT_EQ(d.reply("585#6041600000000000"), Frames{"605#8041600001000405"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::unexpected_response);
}

TEST(SdoClientStrict, ReservedCommandSpecifierAborts) {
  // Given a client reading 6041h:00
  // When the server answers with scs=7
  // Then the client aborts with 05040001h and reports invalid_response
  Driver d;
  d.upload(k6041);
  EXPECT_EQ(d.reply("585#E041600000000000"), Frames{"605#8041600001000405"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::invalid_response);
}

TEST(SdoClientStrict, ShortFrameAborts) {
  // Given a client reading 6061h:00
  // When the server answers with the Festo response as printed (DLC 5)
  // Then the client aborts with 05040001h: a short frame is not an SDO frame
  Driver d;
  d.upload({0x6061, 0});
  EXPECT_EQ(d.reply("585#4F61600001"), Frames{"605#8061600001000405"});
  EXPECT_EQ(d.transfer().error(), SdoClientError::invalid_response);
}

TEST(SdoClientStrict, UnknownServerAbortCodeKeepsItsValue) {
  // Given a client reading 6041h:00
  // When the server aborts with a code no table lists (12345678h)
  // Then the error carries exactly that value in the sdo-abort category
  Driver d;
  d.upload(k6041);
  d.reply("585#8041600078563412");
  EXPECT_EQ(server_abort_code(d.transfer().error()), 0x12345678u);
  EXPECT_EQ(d.transfer().error().category(), sdo_abort_category());
}

TEST(SdoClientStrict, FramesOnOtherIdentifiersAreIgnored) {
  // Given a client of node 5 waiting for an answer
  // When frames arrive on 586h, on 605h and as an extended 585h
  // Then none of them changes the transfer
  Driver d;
  d.upload(k6041);
  EXPECT_EQ(d.reply("586#4B41600034120000"), Frames{});
  EXPECT_EQ(d.reply("605#4B41600034120000"), Frames{});
  EXPECT_EQ(d.reply("00000585#4B41600034120000"), Frames{});
  EXPECT_TRUE(d.transfer().running());
}

TEST(SdoClientStrict, FramesAfterTheEndAreIgnored) {
  // Given a finished transfer
  // When another answer arrives
  // Then the client sends nothing and keeps its result
  Driver d;
  d.upload(k6041);
  d.reply("585#4B41600034120000");
  EXPECT_EQ(d.reply("585#8041600000000008"), Frames{});
  EXPECT_TRUE(d.transfer().succeeded());
}

// --- The client's own actions -------------------------------------------------------------------

TEST(SdoClientAbort, ClientAbortSendsItsCode) {
  // Given a segmented upload in progress
  // When the client's user aborts with 08000020h
  // Then the client sends that abort and the transfer fails with aborted_locally
  Driver d;
  d.upload(k1008);
  d.reply("585#410810000A000000");
  const auto frames = d.transfer().abort(SdoAbort::cannot_transfer);
  ASSERT_EQ(frames.size(), 1u);
  // cs=4, index 1008h sub 0, abort 08000020h
  EXPECT_EQ(can::to_candump(frames[0]), "605#8008100020000008");
  EXPECT_TRUE(d.transfer().abort(SdoAbort::cannot_transfer).empty());  // nothing runs any more
  EXPECT_EQ(d.transfer().error(), SdoClientError::aborted_locally);
  EXPECT_EQ(d.transfer().sent_abort(), 0x08000020u);
}

TEST(SdoClientAbort, AbortFrameNamesTheTransfer) {
  // Given an expedited upload of 6041h:00 in progress
  // When the client aborts with 08000000h
  // Then the abort frame names 6041h:00
  Driver d;
  d.upload(k6041);
  const auto frames = d.transfer().abort(SdoAbort::general_error);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(can::to_candump(frames[0]), "605#8041600000000008");
}

TEST(SdoClientStart, StartWhileRunningChangesNothing) {
  // Given a running upload of 6041h:00
  // When another transfer is started
  // Then no frame is sent and the first transfer goes on
  Driver d;
  d.upload(k6041);
  EXPECT_EQ(d.download(k1008, {1}), Frames{});
  d.reply("585#4B41600034120000");
  EXPECT_TRUE(d.transfer().succeeded());
}

TEST(SdoClientStart, ConfigurableCobIds) {
  // Given a client configured for COB-IDs 641h / 5C1h
  // When it reads and the server answers on 5C1h
  // Then the request goes to 641h and the answer is accepted
  SdoClientOptions options;
  options.cob_ids = SdoCobIds{0x641, 0x5C1};
  SdoClientTransfer transfer(5, options);
  const auto frames = transfer.start_upload(k6041, can::TimePoint{});
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(frames[0].id, 0x641u);
  transfer.on_frame(*can::parse_candump("5C1#4B41600034120000"), can::TimePoint{});
  EXPECT_TRUE(transfer.succeeded());
}

TEST(SdoClientErrorCodes, EveryErrorHasAMessageAndItsAbort) {
  // Given every SdoClientError
  // When its message and abort code are asked for
  // Then each has a message, and the protocol errors name the abort CiA 301 gives them
  for (int e = 1; e <= static_cast<int>(SdoClientError::interrupted); ++e) {
    const std::error_code error = static_cast<SdoClientError>(e);
    EXPECT_EQ(error.category().name(), std::string("sdo-client"));
    EXPECT_EQ(error.message().find("unknown"), std::string::npos) << e;
  }
  EXPECT_EQ(abort_code_for(SdoClientError::timeout), SdoAbort::protocol_timed_out);
  EXPECT_EQ(abort_code_for(SdoClientError::toggle_mismatch), SdoAbort::toggle_bit_not_alternated);
  EXPECT_EQ(abort_code_for(SdoClientError::crc_mismatch), SdoAbort::crc_error);
  EXPECT_EQ(abort_code_for(SdoClientError::sequence_error), SdoAbort::invalid_sequence_number);
  EXPECT_EQ(abort_code_for(SdoClientError::invalid_block_size), SdoAbort::invalid_block_size);
  EXPECT_EQ(abort_code_for(SdoClientError::data_too_large), SdoAbort::out_of_memory);
  EXPECT_FALSE(abort_code_for(SdoClientError::busy));
}

}  // namespace
}  // namespace drivecheck::cia301
