#include "protocol/can/pcap.hpp"

#include <gtest/gtest.h>

#include <random>
#include <sstream>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::can {
namespace {

using std::chrono::nanoseconds;
using Bytes = std::vector<std::uint8_t>;

Frame frame_of(const char* text) {
  auto frame = parse_candump(text);
  EXPECT_TRUE(frame) << text;
  return frame ? *frame : Frame{};
}

// One record of every frame shape, timestamps from 1700000000.000100000 on.
std::vector<PcapRecord> sample_records() {
  const char* frames[] = {
      "605#2341600000000000",       // SDO rx node 5: ccs=1 e=1 s=1, 6041h sub 0
      "12345678#DEADBEEF",          // 29-bit id, 4 bytes
      "704#R3",                     // remote request, DLC 3
      "1FFFFFFF#R",                 // 29-bit remote request, DLC 0
      "20000080#0000000000000000",  // error frame, class CAN_ERR_BUSERROR
      "080#",                       // SYNC without counter
      "123#1122334455667788_C",     // 8 bytes, DLC 12
      "7FF#FF",
  };
  std::vector<PcapRecord> records;
  std::int64_t ns = 1'700'000'000'000'100'000;
  for (const char* text : frames) {
    records.push_back({nanoseconds(ns), frame_of(text)});
    ns += 123'456'789;
  }
  return records;
}

Bytes encode_file(const std::vector<PcapRecord>& records) {
  const auto header = pcap_file_header();
  Bytes bytes(header.begin(), header.end());
  for (const auto& record : records) {
    const auto encoded = encode_pcap_record(record);
    EXPECT_TRUE(encoded);
    if (encoded) bytes.insert(bytes.end(), encoded->begin(), encoded->end());
  }
  return bytes;
}

TEST(PcapLayout, FileHeaderIsNanosecondSocketcan) {
  // Given the file header we write
  // When its bytes are compared with the pcap and LINKTYPE_CAN_SOCKETCAN specifications
  // Then magic, version, zone, sigfigs, snaplen and link type are as specified, little-endian
  const Bytes expected = {
      0x4D, 0x3C, 0xB2, 0xA1,  // magic A1B23C4Dh: nanosecond timestamps
      0x02, 0x00, 0x04, 0x00,  // version 2.4
      0x00, 0x00, 0x00, 0x00,  // thiszone 0
      0x00, 0x00, 0x00, 0x00,  // sigfigs 0
      0x10, 0x00, 0x00, 0x00,  // snaplen 16
      0xE3, 0x00, 0x00, 0x00,  // network 227 = LINKTYPE_CAN_SOCKETCAN
  };
  const auto header = pcap_file_header();
  EXPECT_EQ(Bytes(header.begin(), header.end()), expected);
}

TEST(PcapLayout, RecordCarriesCanIdInNetworkByteOrder) {
  // Given the SDO frame 605#2341600000000000 at Unix time 1700000000.000100000
  // When encoded as a pcap record
  // Then the header is little-endian and the can_frame has its can_id big-endian
  const auto encoded = encode_pcap_record(
      {nanoseconds(1'700'000'000'000'100'000), frame_of("605#2341600000000000")});
  ASSERT_TRUE(encoded) << encoded.error();
  const Bytes expected = {
      0x00, 0xF1, 0x53, 0x65,                          // ts_sec 1700000000 = 6553F100h
      0xA0, 0x86, 0x01, 0x00,                          // ts_nsec 100000 = 186A0h
      0x10, 0x00, 0x00, 0x00,                          // incl_len 16
      0x10, 0x00, 0x00, 0x00,                          // orig_len 16
      0x00, 0x00, 0x06, 0x05,                          // can_id 605h, big-endian, no flags
      0x08, 0x00, 0x00, 0x00,                          // len 8, pad, reserved, len8_dlc 0
      0x23, 0x41, 0x60, 0x00, 0x00, 0x00, 0x00, 0x00,  // ccs=1 e=1 s=1, 6041h sub 0, data 0
  };
  EXPECT_EQ(Bytes(encoded->begin(), encoded->end()), expected);
}

TEST(PcapLayout, FlagsLengthAndLen8Dlc) {
  // Given extended, remote, error and DLC>8 frames
  // When encoded
  // Then EFF/RTR/ERR flags are in can_id, a remote frame's len is its DLC, and DLC 9..15
  //      goes to len8_dlc with len 8
  struct Case {
    const char* frame;
    std::uint32_t can_id;
    std::uint8_t len;
    std::uint8_t len8_dlc;
  };
  const Case cases[] = {
      {"12345678#DEADBEEF", 0x92345678, 4, 0},          // EFF
      {"704#R3", 0x40000704, 3, 0},                     // RTR, DLC 3
      {"1FFFFFFF#R8", 0xDFFFFFFF, 8, 0},                // EFF + RTR
      {"20000080#0000000000000000", 0x20000080, 8, 0},  // ERR, class 80h
      {"123#1122334455667788_C", 0x00000123, 8, 12},    // DLC 12
  };
  for (const auto& c : cases) {
    const auto encoded = encode_pcap_record({nanoseconds(0), frame_of(c.frame)});
    ASSERT_TRUE(encoded) << c.frame;
    const std::uint8_t* can = encoded->data() + kPcapRecordHeaderSize;
    const std::uint32_t can_id = std::uint32_t{can[0]} << 24 | std::uint32_t{can[1]} << 16 |
                                 std::uint32_t{can[2]} << 8 | can[3];
    EXPECT_EQ(can_id, c.can_id) << c.frame;
    EXPECT_EQ(can[4], c.len) << c.frame;
    EXPECT_EQ(can[7], c.len8_dlc) << c.frame;
  }
}

TEST(PcapLayout, TimestampsPcapCannotHoldAreErrors) {
  // Given timestamps before 1970 and after 2106
  // When encoded
  // Then each is an error saying why, never a wrapped-around time
  const auto before = encode_pcap_record({nanoseconds(-1), frame_of("080#")});
  ASSERT_FALSE(before);
  EXPECT_NE(before.error().find("before 1970"), std::string::npos);
  const auto after =
      encode_pcap_record({nanoseconds(std::int64_t{1} << 32) * 1'000'000'000, frame_of("080#")});
  ASSERT_FALSE(after);
  EXPECT_NE(after.error().find("after 2106"), std::string::npos);
}

TEST(PcapReader, RoundTripsEveryFrameShape) {
  // Given records of every frame shape
  // When encoded as a capture and parsed back
  // Then records are identical, nanoseconds included
  const auto records = sample_records();
  const auto parsed = parse_pcap(encode_file(records));
  ASSERT_TRUE(parsed) << parsed.error();
  EXPECT_EQ(*parsed, records);
}

TEST(PcapReader, ReadsBigEndianMicrosecondCaptures) {
  // Given a capture written by a big-endian host with microsecond timestamps
  // When parsed
  // Then the frame and the time (µs scaled to ns) are read
  const Bytes bytes = {
      0xA1, 0xB2, 0xC3, 0xD4, 0x00, 0x02, 0x00, 0x04,  // µs magic and version, big-endian
      0,    0,    0,    0,    0,    0,    0,    0,     // zone, sigfigs
      0x00, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00, 0xE3,  // snaplen 16, link type 227
      0x65, 0x53, 0xF1, 0x00, 0x00, 0x00, 0x00, 0x64,  // 1700000000 s, 100 µs
      0x00, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00, 0x10,  // incl_len, orig_len 16
      0x00, 0x00, 0x07, 0x05, 0x01, 0,    0,    0,     // 705h, len 1
      0x7F, 0,    0,    0,    0,    0,    0,    0,     // heartbeat: pre-operational
  };
  const auto parsed = parse_pcap(bytes);
  ASSERT_TRUE(parsed) << parsed.error();
  ASSERT_EQ(parsed->size(), 1u);
  EXPECT_EQ((*parsed)[0].timestamp, nanoseconds(1'700'000'000'000'100'000));
  EXPECT_EQ(to_candump((*parsed)[0].frame), "705#7F");
}

TEST(PcapReader, AcceptsRecordsShortenedToTheirPayload) {
  // Given a record stored as 8 + len bytes (as some capture tools do)
  // When parsed
  // Then the frame is complete
  const auto header = pcap_file_header();
  Bytes bytes(header.begin(), header.end());
  const Bytes record = {
      1,    0,    0,    0,    0,    0, 0, 0,  // 1 s, 0 ns
      10,   0,    0,    0,    16,   0, 0, 0,  // incl_len 10, orig_len 16
      0x00, 0x00, 0x01, 0x85, 0x02, 0, 0, 0,  // 185h (TPDO1 node 5), len 2
      0xAB, 0xCD,
  };
  bytes.insert(bytes.end(), record.begin(), record.end());
  const auto parsed = parse_pcap(bytes);
  ASSERT_TRUE(parsed) << parsed.error();
  ASSERT_EQ(parsed->size(), 1u);
  EXPECT_EQ(to_candump((*parsed)[0].frame), "185#ABCD");
}

TEST(PcapReader, RejectsMalformedCaptures) {
  // Given captures broken in each field in turn
  // When parsed
  // Then each gives an error naming the problem and, for records, the record and offset
  const Bytes good = encode_file({{nanoseconds(1'000'000'000), frame_of("605#2341600000000000")}});
  const auto with = [&](std::size_t offset, std::initializer_list<std::uint8_t> patch) {
    Bytes bytes = good;
    for (const std::uint8_t byte : patch)
      bytes.at(offset++) = byte;
    return bytes;
  };
  constexpr std::size_t kRec = kPcapFileHeaderSize;           // record header
  constexpr std::size_t kCan = kRec + kPcapRecordHeaderSize;  // can_frame
  const std::pair<Bytes, const char*> cases[] = {
      {Bytes{}, "truncated file header: 0 of 24"},
      {Bytes(good.begin(), good.begin() + 23), "truncated file header: 23 of 24"},
      {with(0, {0x00, 0x11, 0x22, 0x33}), "not a pcap file: magic number 33221100"},
      {with(0, {0x0A, 0x0D, 0x0D, 0x0A}), "pcapng"},
      {with(4, {0x01, 0x00}), "pcap version 1.4"},
      {with(20, {0x01, 0x00}), "link type 1 is not LINKTYPE_CAN_SOCKETCAN"},
      {Bytes(good.begin(), good.begin() + kRec + 15),
       "record 1 at byte 24: truncated record header"},
      {Bytes(good.begin(), good.end() - 1),
       "record 1 at byte 24: truncated: 16 bytes stored but only 15"},
      {with(kRec + 4, {0x00, 0xCA, 0x9A, 0x3B}), "fraction 1000000000 is not below 1000000000"},
      {with(kRec + 8, {0xFF, 0xFF, 0xFF, 0xFF}), "4294967295 bytes stored"},
      {with(kRec + 8, {7, 0, 0, 0}), "shorter than the 8-byte can_frame header"},
      {with(kRec + 12, {8, 0, 0, 0}), "orig_len 8 is below incl_len 16"},
      {with(kCan + 4, {9}), "payload length 9 is above 8: CAN FD"},
      {with(kCan, {0x60, 0x00, 0x00, 0x80}), "both ERR and RTR"},
      {with(kCan, {0x00, 0x00, 0x08, 0x00}), "identifier bits above 7FF"},
  };
  for (const auto& [bytes, expected] : cases) {
    const auto parsed = parse_pcap(bytes);
    ASSERT_FALSE(parsed) << "accepted, expected: " << expected;
    EXPECT_NE(parsed.error().find(expected), std::string::npos)
        << "error: " << parsed.error() << "\nexpected: " << expected;
  }
  // CAN FD: a 72-byte canfd_frame record
  Bytes fd(good.begin(), good.begin() + kRec);
  const Bytes fd_header = {1, 0, 0, 0, 0, 0, 0, 0, 72, 0, 0, 0, 72, 0, 0, 0};
  fd.insert(fd.end(), fd_header.begin(), fd_header.end());
  fd.resize(fd.size() + 72);
  const auto parsed = parse_pcap(fd);
  ASSERT_FALSE(parsed);
  EXPECT_NE(parsed.error().find("CAN FD frames are not supported"), std::string::npos)
      << parsed.error();
}

TEST(PcapReader, RandomCorruptionNeverCrashes) {
  // Given 20000 captures with random bytes changed, cut or appended (fixed seed)
  // When parsed
  // Then each gives records or a non-empty error; accepted records re-encode to valid records
  std::mt19937_64 random(77);
  const Bytes good = encode_file(sample_records());
  int accepted = 0;
  for (int i = 0; i < 20000; ++i) {
    Bytes bytes = good;
    const int edits = 1 + static_cast<int>(random() % 3);
    for (int e = 0; e < edits; ++e) {
      const std::size_t pos = random() % bytes.size();
      switch (random() % 4) {
        case 0:
          bytes.resize(pos);
          break;
        case 1:
          bytes.push_back(static_cast<std::uint8_t>(random()));
          break;
        default:
          bytes[pos] = static_cast<std::uint8_t>(random());
          break;
      }
      if (bytes.empty()) break;
    }
    const auto parsed = parse_pcap(bytes);
    if (!parsed) {
      EXPECT_FALSE(parsed.error().empty());
      continue;
    }
    ++accepted;
    for (const auto& record : *parsed) {
      const auto encoded = encode_pcap_record(record);
      ASSERT_TRUE(encoded) << to_candump(record.frame);
    }
  }
  EXPECT_GT(accepted, 100);
}

TEST(PcapWriter, FileIsValidAfterEveryRecord) {
  // Given a writer on a new file
  // When records are written one by one and the file is read back after each, unclosed
  // Then it always parses to exactly the records written so far
  test_support::TempDir dir;
  auto writer = PcapWriter::create(dir / "run.pcap");
  ASSERT_TRUE(writer) << writer.error();
  EXPECT_TRUE(read_pcap_file(dir / "run.pcap")->empty());
  std::vector<PcapRecord> written;
  for (const auto& record : sample_records()) {
    ASSERT_TRUE(writer->write(record));
    written.push_back(record);
    const auto back = read_pcap_file(dir / "run.pcap");
    ASSERT_TRUE(back) << back.error().to_string();
    EXPECT_EQ(*back, written);
  }
}

TEST(PcapWriter, ErrorsNameThePath) {
  test_support::TempDir dir;
  const auto writer = PcapWriter::create(dir / "missing-dir" / "x.pcap");
  ASSERT_FALSE(writer);
  EXPECT_NE(writer.error().find("missing-dir"), std::string::npos);
  const auto read = read_pcap_file(dir / "nothing.pcap");
  ASSERT_FALSE(read);
  EXPECT_NE(read.error().to_string().find("nothing.pcap: cannot open"), std::string::npos);
}

// tshark (Wireshark's engine) is a bootstrap dependency: this test fails, not skips, if absent.
TEST(PcapTshark, DecodesOurCaptureAsWeDo) {
  // Given a capture of every frame shape written by PcapWriter
  // When tshark reads it and prints time, id, flags, length and data of each frame
  // Then every field is what we wrote
  test_support::TempDir dir;
  const auto records = sample_records();
  {
    auto writer = PcapWriter::create(dir / "shapes.pcap");
    ASSERT_TRUE(writer) << writer.error();
    for (const auto& record : records)
      ASSERT_TRUE(writer->write(record));
  }
  const auto result = test_support::run_command({"tshark",
                                                 "-r",
                                                 (dir / "shapes.pcap").string(),
                                                 "-T",
                                                 "fields",
                                                 "-E",
                                                 "separator=;",
                                                 "-e",
                                                 "frame.time_epoch",
                                                 "-e",
                                                 "can.id",
                                                 "-e",
                                                 "can.flags.xtd",
                                                 "-e",
                                                 "can.flags.rtr",
                                                 "-e",
                                                 "can.flags.err",
                                                 "-e",
                                                 "can.len",
                                                 "-e",
                                                 "data.data",
                                                 "-e",
                                                 "can.err.buserror"});
  ASSERT_EQ(result.exit_code, 0) << "tshark failed (is it installed? scripts/bootstrap installs it)"
                                 << "\nstderr: " << result.err;
  std::vector<std::string> lines;
  std::istringstream out(result.out);
  for (std::string line; std::getline(out, line);)
    lines.push_back(line);
  ASSERT_EQ(lines.size(), records.size()) << result.out << result.err;
  for (std::size_t i = 0; i < records.size(); ++i) {
    const Frame& frame = records[i].frame;
    const std::int64_t ns = records[i].timestamp.count();
    const std::string time = fmt::format("{}.{:09}", ns / 1'000'000'000, ns % 1'000'000'000);
    std::string expected;
    if (frame.is_error()) {
      // tshark shows no id for error frames, only the class bits (80h = bus error)
      expected = fmt::format("{};;;;1;{};;1", time, frame.length());
    } else {
      std::string data;
      for (std::uint8_t byte : frame.payload())
        data += fmt::format("{:02x}", byte);
      // tshark shows a remote frame's DLC worth of bytes as data: the zeros we store
      if (frame.is_remote()) data = std::string(2u * frame.dlc, '0');
      expected = fmt::format("{};{};{};{};0;{};{};", time, frame.id, frame.is_extended() ? 1 : 0,
                             frame.is_remote() ? 1 : 0,
                             frame.is_remote() ? frame.dlc : frame.length(), data);
    }
    EXPECT_EQ(lines[i], expected) << "record " << i << ": " << to_candump(frame);
  }
}

}  // namespace
}  // namespace drivecheck::can
