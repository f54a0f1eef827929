#include "protocol/cia301/dissector.hpp"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace drivecheck::cia301 {
namespace {

can::Frame frame_of(const char* text) {
  auto frame = can::parse_candump(text);
  EXPECT_TRUE(frame) << text;
  return frame.value_or(can::Frame{});
}

std::string line_of(const char* text, const DissectorOptions& options = {}) {
  Dissector dissector(options);
  return dissector.line(frame_of(text));
}

TEST(Dissector, SdoExpeditedDownloadOfControlword) {
  // Given an expedited download of 000Fh to 6040h:00 of node 5
  // ccs=1 n=2 e=1 s=1, index 6040h sub 0, data 0Fh 00h
  // When dissected
  // Then the line names service, node, object, value and its meaning
  EXPECT_EQ(line_of("605#2B4060000F000000"),
            "605 SDO rx  node 5  initiate download expedited 6040:00 (controlword) = 0x000F = "
            "enable operation");
}

TEST(Dissector, FestoSdoExamples) {
  // Given the Festo SDO examples (000_33c1d912b8b6010a.txt L744-756), node 1
  // When dissected
  // Then requests, responses and values read as the manual describes them
  // ccs=2 read 6061h:00
  EXPECT_EQ(line_of("601#4061600000000000"),
            "601 SDO rx  node 1  initiate upload 6061:00 (modes of operation display)");
  // scs=2 e=1 s=1 n=3, 6061h:00 = 01h
  EXPECT_EQ(line_of("581#4F61600001000000"),
            "581 SDO tx  node 1  initiate upload response expedited 6061:00 (modes of operation "
            "display) = 0x01 = profile position (pp)");
  // scs=2 n=0, 6093h:01 = 12345678h
  EXPECT_EQ(line_of("581#4393600178563412"),
            "581 SDO tx  node 1  initiate upload response expedited 6093:01 (position factor "
            "numerator) = 0x12345678 = 305419896");
  // scs=3, 1401h:02 written
  EXPECT_EQ(line_of("581#6001140200000000"),
            "581 SDO tx  node 1  initiate download response 1401:02 (RPDO2 communication "
            "parameter: transmission type)");
  // scs=4 abort 6041h:00 06010002h (L768-771)
  EXPECT_EQ(line_of("581#8041600002000106"),
            "581 SDO tx  node 1  abort 6041:00 (statusword) 06010002h write_read_only: Attempt to "
            "write a read only object");
}

TEST(Dissector, StatuswordAndPdoCobIdValues) {
  // Given an upload of statusword 0637h and a write of TPDO1 COB-ID 40000187h (Festo remap, L990)
  // Then the statusword shows its state and the COB-ID its bits
  EXPECT_EQ(line_of("585#4B41600037060000"),
            "585 SDO tx  node 5  initiate upload response expedited 6041:00 (statusword) = 0x0637 "
            "= operation enabled");
  EXPECT_EQ(line_of("601#2301180187010040"),
            "601 SDO rx  node 1  initiate download expedited 1801:01 (TPDO2 communication "
            "parameter: COB-ID) = 0x40000187 = valid, no RTR, CAN-ID 187h");
  EXPECT_EQ(line_of("601#23001A0110004160"),
            "601 SDO rx  node 1  initiate download expedited 1A00:01 (TPDO1 mapping parameter: "
            "mapped object 1) = 0x60410010 = 6041:00 (statusword) 16 bit");
}

TEST(Dissector, ShortSdoIsExplained) {
  // Given an SDO request with DLC 5 (Festo prints only significant bytes: a drive that sends
  //   such frames deviates from CiA 301)
  const Dissection d = dissect_frame(frame_of("605#2F01140200"));
  // Then it is invalid and says why
  EXPECT_FALSE(d.valid);
  EXPECT_EQ(d.text, "SDO rx with DLC 5: invalid (SDO frames carry 8 bytes)");
}

TEST(Dissector, NmtAndErrorControl) {
  // Given NMT commands and error-control frames (Festo §3.6-3.9)
  // Then each names the command or state
  EXPECT_EQ(line_of("000#0105"), "000 NMT     start node 5");
  EXPECT_EQ(line_of("000#8200"), "000 NMT     reset communication all nodes");
  EXPECT_EQ(line_of("000#0301"),
            "000 NMT     NMT node control with command specifier 03h: invalid (01h, 02h, 80h, "
            "81h, 82h)");
  EXPECT_EQ(line_of("701#00"), "701 NMT EC  node 1  boot-up");
  EXPECT_EQ(line_of("701#7F"), "701 NMT EC  node 1  heartbeat pre-operational");
  EXPECT_EQ(line_of("701#R"), "701 NMT EC  node 1  node-guarding request");
  EXPECT_EQ(line_of("701#85"), "701 NMT EC  node 1  node-guarding response toggle 1 operational");
}

TEST(Dissector, GuardingResponseWithToggleZeroNeedsTheRequest) {
  // Given a stateful dissector that saw a guarding request of node 1
  Dissector dissector;
  dissector.line(frame_of("701#R"));
  // When the answer 7Fh (toggle 0) comes
  // Then it is a guarding response; the same byte later, without request, is a heartbeat
  EXPECT_EQ(dissector.dissect(frame_of("701#7F")).text,
            "node-guarding response toggle 0 pre-operational");
  EXPECT_EQ(dissector.dissect(frame_of("701#7F")).text, "heartbeat pre-operational");
}

TEST(Dissector, EmcySyncTime) {
  // Given EMCY (Kollmorgen L8158-8169), SYNC with and without counter, and TIME
  EXPECT_EQ(line_of("081#1043080100000000"),
            "081 EMCY    node 1  4310h Excess temperature drive (motor); register 08h "
            "temperature; manufacturer 01 00 00 00 00");
  EXPECT_EQ(line_of("081#0000000000000000"),
            "081 EMCY    node 1  error reset (0000h); register 00h none");
  EXPECT_EQ(line_of("080#0C"), "080 SYNC    counter 12");
  EXPECT_EQ(line_of("080#"), "080 SYNC    no counter");
  EXPECT_EQ(line_of("080#00"), "080 SYNC    SYNC counter 0: invalid (the counter runs 1..240)");
  // 2024-03-01 12:34:56.789: ms 02B32C95h, days 394Eh
  EXPECT_EQ(line_of("100#952CB3024E39"),
            "100 TIME    2024-03-01 12:34:56.789 (day 14670, 45296789 ms)");
  EXPECT_EQ(line_of("081#1043"),
            "081 EMCY    node 1  EMCY with DLC 2: invalid (EMCY frames carry 8 bytes)");
}

TEST(Dissector, PdosRawAndMapped) {
  // Given TPDO1 of node 1 with the Festo remap mapping 6041h + 6061h + 60FDh (L946-994)
  DissectorOptions options;
  options.pdo_mappings[0x181] = PdoMapping{{{0x6041, 0, 16}, {0x6061, 0, 8}, {0x60FD, 0, 32}}};
  // When a TPDO1 frame with 7 bytes, a short one, and an unmapped RPDO1 are dissected
  // Then the mapped one shows values, the short one is invalid, the raw one shows bytes
  EXPECT_EQ(line_of("181#27060104000000", options),
            "181 TPDO1   node 1  27 06 01 04 00 00 00 (6041:00 (statusword) = 0x0627 = operation "
            "enabled, 6061:00 (modes of operation display) = 0x01 = profile position (pp), "
            "60FD:00 (digital inputs) = 0x00000004)");
  const Dissection short_pdo = Dissector(options).dissect(frame_of("181#2706"));
  EXPECT_FALSE(short_pdo.valid);
  EXPECT_NE(short_pdo.text.find("8210h"), std::string::npos);
  EXPECT_EQ(line_of("201#0F00", options), "201 RPDO1   node 1  0F 00");
  EXPECT_EQ(line_of("181#R"), "181 TPDO1   node 1  remote request (RTR DLC 0)");
}

TEST(Dissector, NodesAndNamesFromOutside) {
  // Given knowledge of node 5 only, and an EDS-like name lookup for 2000h
  DissectorOptions options;
  options.nodes.set(5);
  options.object_name = [](std::uint16_t index, std::uint8_t) -> std::optional<std::string> {
    if (index == 0x2000) return "manufacturer statuswords";
    return std::nullopt;
  };
  // When frames of node 5 and node 6 are dissected
  // Then node 6 is flagged; the lookup names 2000h; built-in names remain for others
  EXPECT_EQ(line_of("605#4000200100000000", options),
            "605 SDO rx  node 5  initiate upload 2000:01 (manufacturer statuswords)");
  EXPECT_EQ(line_of("606#4041600000000000", options),
            "606 SDO rx  node 6  initiate upload 6041:00 (statusword) (node 6 not configured)");
}

TEST(Dissector, BlockDownloadSegmentsFollowTheTransfer) {
  // Given a block download of 1008h:00 on node 5 (CiA 301 §7.2.4.3.9-11)
  Dissector dissector;
  const char* frames[] = {
      "605#C608100000000000",  // ccs=6 cs=0 c=1 s=1 initiate, 1008h:00, no size
      "585#A408100002000000",  // scs=5 ss=0 sc=1 initiate response, blksize 2
      "605#0141424344454647",  // segment seqno 1
      "605#8248490000000000",  // segment seqno 2, c=1 (last)
      "585#A202020000000000",  // block download response ackseq 2 blksize 2
      "605#D5E3A40000000000",  // end request n=5 crc A4E3h
      "585#A100000000000000",  // end response
  };
  std::vector<std::string> texts;
  for (const char* text : frames)
    texts.push_back(dissector.dissect(frame_of(text)).text);
  // Then the segments are shown as segments, and the end request as a command again
  EXPECT_EQ(texts[2], "block download segment 1 data 41 42 43 44 45 46 47");
  EXPECT_EQ(texts[3], "block download segment 2 (last) data 48 49 00 00 00 00 00");
  EXPECT_NE(texts[5].find("block download end request"), std::string::npos) << texts[5];
  EXPECT_NE(texts[6].find("block download end response"), std::string::npos) << texts[6];
}

TEST(Dissector, BlockUploadEndIsNotASegment) {
  // Given a block upload of 1008h:00 (9 bytes) on node 5 in two sub-blocks of blksize 1,
  // ending with the server's end request D5h (CiA 301 §7.2.4.3.12-15)
  Dissector dissector;
  const char* frames[] = {
      "605#A408100001000000",  // ccs=5 cc=1 cs=0 initiate, 1008h:00, blksize 1, pst 0
      "585#C608100009000000",  // scs=6 sc=1 s=1 ss=0 initiate response, 9 bytes
      "605#A300000000000000",  // ccs=5 cs=3 start upload
      "585#0141424344454647",  // segment seqno 1
      "605#A201010000000000",  // ccs=5 cs=2 response ackseq 1 blksize 1
      "585#8148490000000000",  // segment seqno 1, c=1 (last)
      "605#A201010000000000",  // ccs=5 cs=2 response ackseq 1 blksize 1
      "585#D5E3A40000000000",  // scs=6 n=5 ss=1 end request, crc A4E3h
      "605#A100000000000000",  // ccs=5 cs=1 end response
  };
  std::vector<std::string> texts;
  for (const char* text : frames)
    texts.push_back(dissector.dissect(frame_of(text)).text);
  // When dissected
  // Then both sub-blocks read as segments and the server's end request as a command
  EXPECT_EQ(texts[3], "block upload segment 1 data 41 42 43 44 45 46 47");
  EXPECT_EQ(texts[5], "block upload segment 1 (last) data 48 49 00 00 00 00 00");
  EXPECT_EQ(texts[7].find("block upload segment"), std::string::npos) << texts[7];
  EXPECT_NE(texts[7].find("block upload end"), std::string::npos) << texts[7];
  EXPECT_NE(texts[8].find("block upload end"), std::string::npos) << texts[8];
}

TEST(Dissector, BlockUploadRetransmitsAfterAShortAck) {
  // Given a block upload whose client acknowledges only segment 1 of 2 (the last)
  Dissector dissector;
  const char* frames[] = {
      "605#A008100002000000",  // ccs=5 cc=0 cs=0 initiate, 1008h:00, blksize 2
      "585#C208100009000000",  // scs=6 s=1 initiate response, 9 bytes
      "605#A300000000000000",  // start upload
      "585#0141424344454647",  // segment seqno 1
      "585#8248490000000000",  // segment seqno 2, c=1 (last)
      "605#A201020000000000",  // response ackseq 1 blksize 2: segment 2 is repeated
      "585#8148490000000000",  // segment seqno 1, c=1 (last)
  };
  std::vector<std::string> texts;
  for (const char* text : frames)
    texts.push_back(dissector.dissect(frame_of(text)).text);
  // When dissected
  // Then the repeated segment reads as a segment
  EXPECT_EQ(texts[6], "block upload segment 1 (last) data 48 49 00 00 00 00 00");
}

TEST(Dissector, OtherFrames) {
  // Given an error frame, a 29-bit frame, LSS, and unassigned ids
  EXPECT_EQ(line_of("20000004#0004000000000000"),
            "20000004 CAN     error frame, error class 00000004h");
  EXPECT_EQ(line_of("18FF1234#0102"),
            "18FF1234 29-bit  01 02: not in the CANopen pre-defined connection set");
  EXPECT_EQ(line_of("7E5#0401000000000000"),
            "7E5 LSS rx  cs 04h switch state global data 01 00 00 00 00 00 00");
  EXPECT_EQ(line_of("180#00"), "180 -       00 (CAN-ID 180h unassigned, restricted: reserved)");
  EXPECT_EQ(line_of("680#00"), "680 -       00 (CAN-ID 680h unassigned)");
}

TEST(Dissector, RandomFramesNeverCrashAndAlwaysSaySomething) {
  // Given 200000 random frames (ids weighted to the CANopen ranges, any DLC 0..15, RTR, 29-bit)
  std::mt19937_64 random(1234);
  Dissector dissector;
  DissectorOptions mapped;
  mapped.pdo_mappings[0x181] = PdoMapping{{{0x6041, 0, 16}, {0x2000, 1, 3}, {0x0005, 0, 8}}};
  Dissector with_mapping(mapped);
  for (int i = 0; i < 200000; ++i) {
    can::Frame frame;
    const std::uint64_t r = random();
    frame.format = (r & 0xF) == 0 ? can::IdFormat::extended : can::IdFormat::standard;
    frame.id = static_cast<std::uint32_t>((r >> 8) & (frame.is_extended() ? 0x1FFFFFFF : 0x7FF));
    frame.kind = ((r >> 4) & 0x1F) == 0 ? can::FrameKind::remote : can::FrameKind::data;
    if (((r >> 40) & 0xFF) == 0) frame.kind = can::FrameKind::error;
    frame.dlc = static_cast<std::uint8_t>((r >> 48) & 0xF);
    if (frame.is_remote() && frame.dlc > 8) frame.dlc = 8;
    const std::uint64_t bytes = random();
    for (std::size_t b = 0; b < frame.length(); ++b) {
      frame.data[b] = static_cast<std::uint8_t>(bytes >> (8 * b));
    }
    // When dissected, statefully and statelessly
    const std::string line = dissector.line(frame);
    const Dissection d = with_mapping.dissect(frame);
    // Then there is always a function and a text
    ASSERT_FALSE(line.empty());
    ASSERT_FALSE(d.function.empty()) << can::to_candump(frame);
    ASSERT_FALSE(d.text.empty()) << can::to_candump(frame);
  }
}

}  // namespace
}  // namespace drivecheck::cia301
