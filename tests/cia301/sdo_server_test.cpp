// The SDO server (protocol/cia301/sdo_server.hpp) in scripted exchanges on the simulated bus,
// grouped the way CiA's conformance test tool groups its SDO tests: expedited, segmented and
// block transfers in both directions, every abort path, timeouts in every phase, one request
// at a time, frame format, and interoperability with our own SdoClient.
//
// The tester is a bare port on the bus: it sends the literal request frames and sees every
// answer with its time. Node 5: requests on 605h, answers on 585h. Server timeout 1 s.
#include "protocol/cia301/sdo_server.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <memory>
#include <numeric>
#include <random>
#include <source_location>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sdo_client.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;

constexpr std::uint8_t kNode = 5;
constexpr can::Duration kServerTimeout = 1s;
// Long enough for a sub-block of 127 segments at 500 kbit/s (about 35 ms), well inside the
// server's timeout.
constexpr can::Duration kAnswerWindow = 100ms;

can::Frame frame(std::string_view text) {
  auto parsed = can::parse_candump(text);
  EXPECT_TRUE(parsed) << text << ": " << parsed.error();
  return parsed ? *parsed : can::Frame{};
}

std::vector<std::uint8_t> pattern(std::size_t size, std::uint8_t seed = 0) {
  std::vector<std::uint8_t> bytes(size);
  for (std::size_t i = 0; i < size; ++i)
    bytes[i] = static_cast<std::uint8_t>(seed + i * 7 + i / 251);
  return bytes;
}

std::vector<std::uint8_t> iota_bytes(std::size_t size, std::uint8_t first = 0) {
  std::vector<std::uint8_t> bytes(size);
  std::iota(bytes.begin(), bytes.end(), first);
  return bytes;
}

// The dictionary every test runs against (values chosen to reproduce the Festo manual's
// examples, 000 §3.2.1 L744-756 and §3.2.2 L764-771).
void populate(ObjectDictionary& od) {
  auto add = [&](ObjectDefinition definition) {
    auto added = od.add_object(std::move(definition));
    ASSERT_TRUE(added) << added.error();
  };
  auto var = [](std::uint16_t index, DataType type, AccessType access, Value value = {}) {
    EntryDefinition entry;
    entry.type = type;
    entry.access = access;
    entry.default_value = std::move(value);
    return ObjectDefinition{index, "", ObjectCode::var, {entry}};
  };
  add(var(0x1000, DataType::unsigned32, AccessType::ro, Value::of_unsigned(0x00020192)));
  add(var(0x1008, DataType::visible_string, AccessType::constant, Value::of_string("drivecheck")));
  add(var(0x1017, DataType::unsigned16, AccessType::rw));
  {
    ObjectDefinition identity{0x1018, "identity", ObjectCode::record, {}};
    EntryDefinition sub0;
    sub0.type = DataType::unsigned8;
    sub0.access = AccessType::ro;
    sub0.default_value = Value::of_unsigned(1);
    EntryDefinition vendor;
    vendor.sub_index = 1;
    vendor.type = DataType::unsigned32;
    vendor.access = AccessType::ro;
    vendor.default_value = Value::of_unsigned(0x12345678);
    identity.entries = {sub0, vendor};
    add(identity);
  }
  {
    ObjectDefinition tpdo{0x1401, "RPDO2 communication", ObjectCode::record, {}};
    EntryDefinition sub0;
    sub0.type = DataType::unsigned8;
    sub0.access = AccessType::ro;
    sub0.default_value = Value::of_unsigned(2);
    EntryDefinition cob;
    cob.sub_index = 1;
    cob.type = DataType::unsigned32;
    EntryDefinition type;
    type.sub_index = 2;
    type.type = DataType::unsigned8;
    tpdo.entries = {sub0, cob, type};
    add(tpdo);
  }
  add(var(0x2000, DataType::domain, AccessType::rw));
  {
    auto text = var(0x2001, DataType::visible_string, AccessType::rw);
    text.entries[0].max_size = 16;
    add(text);
  }
  add(var(0x2002, DataType::unsigned32, AccessType::wo));
  {
    auto limited = var(0x2003, DataType::integer16, AccessType::rw);
    limited.entries[0].low_limit = Value::of_signed(-100);
    limited.entries[0].high_limit = Value::of_signed(100);
    add(limited);
  }
  add(var(0x2004, DataType::unsigned8, AccessType::rw));
  add(var(0x2005, DataType::unsigned64, AccessType::rw));
  add(var(0x2006, DataType::domain, AccessType::ro));
  add(var(0x2007, DataType::domain, AccessType::ro));
  add(var(0x6040, DataType::unsigned16, AccessType::rww));
  add(var(0x6041, DataType::unsigned16, AccessType::ro, Value::of_unsigned(0x1234)));
  add(var(0x6061, DataType::integer8, AccessType::ro, Value::of_signed(1)));
  {
    ObjectDefinition factor{0x6093, "position factor", ObjectCode::array, {}};
    EntryDefinition sub0;
    sub0.type = DataType::unsigned8;
    sub0.access = AccessType::ro;
    sub0.default_value = Value::of_unsigned(2);
    EntryDefinition numerator;
    numerator.sub_index = 1;
    numerator.type = DataType::unsigned32;
    numerator.default_value = Value::of_unsigned(1);
    EntryDefinition divisor = numerator;
    divisor.sub_index = 2;
    factor.entries = {sub0, numerator, divisor};
    add(factor);
  }
  // 2004h refuses EEh "in the present state"; 2007h has no data to read.
  od.find(0x2004, 0)->set_write_validator(
      [](const ObjectDictionary&, const Entry&,
         std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
        if (data[0] == 0xEE) return Unexpected(SdoAbort::cannot_transfer_device_state);
        return {};
      });
  od.find(0x2007, 0)->set_read_hook([](ObjectDictionary&, Entry&) -> Expected<void, SdoAbort> {
    return Unexpected(SdoAbort::no_data_available);
  });
  // 2006h: 30 bytes 00h..1Dh.
  const auto thirty = iota_bytes(30);
  ASSERT_TRUE(od.find(0x2006, 0)->assign_bytes(thirty));
}

SdoServerConfig test_config() {
  SdoServerConfig config = SdoServerConfig::for_node(kNode);
  config.timeout = kServerTimeout;
  config.max_download_size = 4096;
  return config;
}

// A drive reduced to its SDO server, on a simulated bus, and a tester port that sends the
// literal requests and sees every answer.
class ScriptedDrive {
 public:
  explicit ScriptedDrive(SdoServerConfig config = test_config())
      : drive_port_(bus_.attach("drive")),
        tester_(bus_.attach("tester")),
        server_(od_, config),
        runner_(*drive_port_, server_) {
    populate(od_);
    runner_.attach();
  }

  ObjectDictionary& od() { return od_; }
  SdoServer& server() { return server_; }
  SdoServerRunner& runner() { return runner_; }
  can::SimBus& bus() { return bus_; }
  can::SimPort& tester() { return *tester_; }
  can::SimPort& drive_port() { return *drive_port_; }

  void send(std::string_view request) {
    const auto error = tester_->send(frame(request));
    EXPECT_FALSE(error) << error.message();
  }

  // Every frame the tester receives within `window` from now.
  std::vector<can::TimedFrame> receive_for(can::Duration window) {
    std::vector<can::TimedFrame> frames;
    const can::TimePoint until = tester_->now() + window;
    while (auto received = tester_->receive(until))
      frames.push_back(*received);
    return frames;
  }

  // The answers within kAnswerWindow must be exactly `answers`, in order.
  void expect(std::vector<std::string_view> answers,
              std::source_location where = std::source_location::current()) {
    const ::testing::ScopedTrace trace(where.file_name(), static_cast<int>(where.line()), "expect");
    std::vector<std::string> expected;
    for (auto answer : answers)
      expected.push_back(can::to_candump(frame(answer)));
    std::vector<std::string> actual;
    for (const auto& received : receive_for(kAnswerWindow)) {
      actual.push_back(can::to_candump(received.frame));
    }
    EXPECT_EQ(actual, expected);
  }

  void exchange(std::string_view request, std::vector<std::string_view> answers,
                std::source_location where = std::source_location::current()) {
    send(request);
    expect(std::move(answers), where);
  }

  void expect_silence(can::Duration window,
                      std::source_location where = std::source_location::current()) {
    const ::testing::ScopedTrace trace(where.file_name(), static_cast<int>(where.line()),
                                       "silence");
    const auto frames = receive_for(window);
    for (const auto& received : frames)
      ADD_FAILURE() << "unexpected " << can::to_candump(received.frame);
  }

  std::vector<std::uint8_t> bytes_of(std::uint16_t index, std::uint8_t sub_index = 0) {
    const auto bytes = od_.find(index, sub_index)->bytes();
    return {bytes.begin(), bytes.end()};
  }

 private:
  can::SimBus bus_;
  std::unique_ptr<can::SimPort> drive_port_;
  std::unique_ptr<can::SimPort> tester_;
  ObjectDictionary od_{kNode};
  SdoServer server_;
  SdoServerRunner runner_;
};

// ============================================================================================
// Expedited transfer (CiA 301 §7.2.4.3.3, §7.2.4.3.6)
// ============================================================================================

TEST(SdoServerExpedited, UploadsOneTwoAndFourBytesAsTheFestoExamples) {
  // Given 6061h:00 = 01h, 6041h:00 = 1234h, 1000h:00 = 00020192h
  // When the tester reads each with an initiate upload request (000 L747-756)
  // Then each answer is an expedited upload response with s=1 and n = 4 - size
  ScriptedDrive drive;
  // ccs=2 initiate upload, 6061h:00
  drive.exchange("605#4061600000000000",
                 // scs=2 n=3 e=1 s=1, 6061h:00, data 01h
                 {"585#4F61600001000000"});
  // ccs=2 initiate upload, 6041h:00
  drive.exchange("605#4041600000000000",
                 // scs=2 n=2 e=1 s=1, 6041h:00, data 1234h
                 {"585#4B41600034120000"});
  // ccs=2 initiate upload, 1000h:00
  drive.exchange("605#4000100000000000",
                 // scs=2 n=0 e=1 s=1, 1000h:00, data 00020192h
                 {"585#4300100092010200"});
  EXPECT_EQ(drive.server().statistics().completed, 3u);
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerExpedited, DownloadsOneTwoAndFourBytesAsTheFestoExamples) {
  // Given writable entries 1401h:02 (U8), 6040h:00 (U16), 6093h:01 (U32)
  // When the tester writes them with the Festo manual's frames (000 L747-756)
  // Then each is answered 60h with the multiplexer and the dictionary holds the value
  ScriptedDrive drive;
  // ccs=1 n=3 e=1 s=1, 1401h:02, data EFh
  drive.exchange("605#2F011402EF000000",
                 // scs=3, 1401h:02
                 {"585#6001140200000000"});
  // ccs=1 n=2 e=1 s=1, 6040h:00, data 03E8h
  drive.exchange("605#2B406000E8030000",
                 // scs=3, 6040h:00
                 {"585#6040600000000000"});
  // ccs=1 n=0 e=1 s=1, 6093h:01, data 12345678h
  drive.exchange("605#2393600178563412",
                 // scs=3, 6093h:01
                 {"585#6093600100000000"});
  EXPECT_EQ(drive.bytes_of(0x1401, 2), (std::vector<std::uint8_t>{0xEF}));
  EXPECT_EQ(drive.bytes_of(0x6040), (std::vector<std::uint8_t>{0xE8, 0x03}));
  // ccs=2 initiate upload, 6093h:01
  drive.exchange("605#4093600100000000",
                 // scs=2 n=0 e=1 s=1, 6093h:01, data 12345678h
                 {"585#4393600178563412"});
}

TEST(SdoServerExpedited, DownloadWithoutSizeTakesTheEntrySize) {
  // Given 1017h:00 is UNSIGNED16
  // When the tester writes it expedited without size indication (s=0), 4 bytes E8 03 AA BB
  // Then the entry takes its 2 bytes, 03E8h, and the write is acknowledged
  ScriptedDrive drive;
  // ccs=1 e=1 s=0, 1017h:00, data E8 03 AA BB (size not indicated)
  drive.exchange("605#22171000E803AABB",
                 // scs=3, 1017h:00
                 {"585#6017100000000000"});
  EXPECT_EQ(drive.bytes_of(0x1017), (std::vector<std::uint8_t>{0xE8, 0x03}));
}

TEST(SdoServerExpedited, ExpeditedRequestsOpenNoTransfer) {
  // Given an idle server
  // When an expedited upload and download complete
  // Then the server stays idle with no deadline (no timer on the bus)
  ScriptedDrive drive;
  // ccs=2 initiate upload, 6041h:00
  drive.exchange("605#4041600000000000", {"585#4B41600034120000"});
  // ccs=1 n=2 e=1 s=1, 1017h:00, data 0064h
  drive.exchange("605#2B17100064000000", {"585#6017100000000000"});
  EXPECT_FALSE(drive.server().busy());
  EXPECT_EQ(drive.server().next_deadline(), can::kForever);
}

// ============================================================================================
// Segmented upload (CiA 301 §7.2.4.3.6-7)
// ============================================================================================

TEST(SdoServerSegmentedUpload, UploadsStringInTogglingSegments) {
  // Given 1008h:00 = "drivecheck" (10 bytes)
  // When the tester reads it and requests segments with toggle 0, 1
  // Then the server indicates size 10, sends 7 bytes, then 3 bytes with n=4 and c=1
  ScriptedDrive drive;
  // ccs=2 initiate upload, 1008h:00
  drive.exchange("605#4008100000000000",
                 // scs=2 e=0 s=1, 1008h:00, size 10
                 {"585#410810000A000000"});
  // ccs=3 t=0 upload segment request
  drive.exchange("605#6000000000000000",
                 // scs=0 t=0 n=0 c=0, "drivech"
                 {"585#0064726976656368"});
  EXPECT_EQ(drive.server().state(), SdoServer::State::upload_segment);
  // ccs=3 t=1 upload segment request
  drive.exchange("605#7000000000000000",
                 // scs=0 t=1 n=4 c=1, "eck"
                 {"585#1965636B00000000"});
  EXPECT_FALSE(drive.server().busy());
  EXPECT_EQ(drive.server().statistics().completed, 1u);
}

TEST(SdoServerSegmentedUpload, EmptyObjectIsOneEmptyLastSegment) {
  // Given 2000h:00 is an empty DOMAIN
  // When the tester reads it
  // Then the server answers segmented with size 0 and one segment with n=7, c=1
  ScriptedDrive drive;
  // ccs=2 initiate upload, 2000h:00
  drive.exchange("605#4000200000000000",
                 // scs=2 e=0 s=1, 2000h:00, size 0
                 {"585#4100200000000000"});
  // ccs=3 t=0 upload segment request
  drive.exchange("605#6000000000000000",
                 // scs=0 t=0 n=7 c=1, no data
                 {"585#0F00000000000000"});
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerSegmentedUpload, DataIsReadOnceAtTheInitiate) {
  // Given a segmented upload of 2000h:00 (10 bytes) has begun
  // When the application changes the entry between segments
  // Then the transfer goes on with the data read at the initiate
  ScriptedDrive drive;
  const auto before = iota_bytes(10, 0x40);
  ASSERT_TRUE(drive.od().find(0x2000, 0)->assign_bytes(before));
  // ccs=2 initiate upload, 2000h:00
  drive.exchange("605#4000200000000000",
                 // scs=2 e=0 s=1, 2000h:00, size 10
                 {"585#410020000A000000"});
  const auto after = iota_bytes(12, 0x80);
  ASSERT_TRUE(drive.od().find(0x2000, 0)->assign_bytes(after));
  // ccs=3 t=0
  drive.exchange("605#6000000000000000",
                 // scs=0 t=0 n=0 c=0, 40h..46h
                 {"585#0040414243444546"});
  // ccs=3 t=1
  drive.exchange("605#7000000000000000",
                 // scs=0 t=1 n=4 c=1, 47h..49h
                 {"585#1947484900000000"});
}

TEST(SdoServerSegmentedUpload, WrongToggleAbortsAndDropsTheTransfer) {
  // Given a segmented upload of 1008h:00 after its first segment (next toggle 1)
  // When the tester repeats toggle 0
  // Then the server aborts 05030000h naming 1008h:00 and the transfer is gone
  ScriptedDrive drive;
  drive.exchange("605#4008100000000000", {"585#410810000A000000"});
  drive.exchange("605#6000000000000000", {"585#0064726976656368"});
  // ccs=3 t=0 (should be 1)
  drive.exchange("605#6000000000000000",
                 // abort 1008h:00, 05030000h toggle bit not alternated
                 {"585#8008100000000305"});
  EXPECT_FALSE(drive.server().busy());
  // ccs=3 t=1: no transfer open any more
  drive.exchange("605#7000000000000000",
                 // abort 0000h:00, 05040001h command specifier not valid
                 {"585#8000000001000405"});
}

TEST(SdoServerSegmentedUpload, FirstSegmentWithToggleOneAborts) {
  // Given a segmented upload of 1008h:00 was initiated
  // When the first upload segment request carries t=1
  // Then the server aborts 05030000h (the first segment has toggle 0)
  ScriptedDrive drive;
  drive.exchange("605#4008100000000000", {"585#410810000A000000"});
  // ccs=3 t=1
  drive.exchange("605#7000000000000000",
                 // abort 1008h:00, 05030000h
                 {"585#8008100000000305"});
}

// ============================================================================================
// Segmented download (CiA 301 §7.2.4.3.3-4)
// ============================================================================================

TEST(SdoServerSegmentedDownload, WritesOnlyAfterTheLastSegment) {
  // Given 2001h:00 is an empty VISIBLE_STRING (max 16 bytes)
  // When the tester downloads "abcdefghij" in two segments
  // Then each segment is acknowledged with its toggle and the entry changes only at the end
  ScriptedDrive drive;
  // ccs=1 e=0 s=1, 2001h:00, size 10
  drive.exchange("605#210120000A000000",
                 // scs=3, 2001h:00
                 {"585#6001200000000000"});
  // ccs=0 t=0 n=0 c=0, "abcdefg"
  drive.exchange("605#0061626364656667",
                 // scs=1 t=0
                 {"585#2000000000000000"});
  EXPECT_TRUE(drive.bytes_of(0x2001).empty());
  // ccs=0 t=1 n=4 c=1, "hij"
  drive.exchange("605#1968696A00000000",
                 // scs=1 t=1
                 {"585#3000000000000000"});
  const std::string_view text = "abcdefghij";
  EXPECT_EQ(drive.bytes_of(0x2001), std::vector<std::uint8_t>(text.begin(), text.end()));
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerSegmentedDownload, SizeNotIndicatedEndsWithTheLastSegment) {
  // Given 2000h:00 is a DOMAIN
  // When the tester downloads 3 bytes segmented without a size (s=0)
  // Then the server accepts the c=1 segment as the end and stores 3 bytes
  ScriptedDrive drive;
  // ccs=1 e=0 s=0, 2000h:00
  drive.exchange("605#2000200000000000",
                 // scs=3, 2000h:00
                 {"585#6000200000000000"});
  // ccs=0 t=0 n=4 c=1, AA BB CC
  drive.exchange("605#09AABBCC00000000",
                 // scs=1 t=0
                 {"585#2000000000000000"});
  EXPECT_EQ(drive.bytes_of(0x2000), (std::vector<std::uint8_t>{0xAA, 0xBB, 0xCC}));
}

TEST(SdoServerSegmentedDownload, EightByteValueInTwoSegments) {
  // Given 2005h:00 is UNSIGNED64
  // When the tester downloads 0102030405060708h segmented with size 8
  // Then the value is stored little-endian
  ScriptedDrive drive;
  // ccs=1 e=0 s=1, 2005h:00, size 8
  drive.exchange("605#2105200008000000", {"585#6005200000000000"});
  // ccs=0 t=0 n=0 c=0, 08 07 06 05 04 03 02
  drive.exchange("605#0008070605040302", {"585#2000000000000000"});
  // ccs=0 t=1 n=6 c=1, 01
  drive.exchange("605#1D01000000000000", {"585#3000000000000000"});
  EXPECT_EQ(drive.bytes_of(0x2005), (std::vector<std::uint8_t>{8, 7, 6, 5, 4, 3, 2, 1}));
}

TEST(SdoServerSegmentedDownload, WrongToggleAbortsAndNothingIsWritten) {
  // Given a segmented download of 10 bytes to 2001h:00 after its first segment
  // When the second segment repeats toggle 0
  // Then the server aborts 05030000h naming 2001h:00 and the entry is unchanged
  ScriptedDrive drive;
  drive.exchange("605#210120000A000000", {"585#6001200000000000"});
  drive.exchange("605#0061626364656667", {"585#2000000000000000"});
  // ccs=0 t=0 (should be 1) n=4 c=1, "hij"
  drive.exchange("605#0968696A00000000",
                 // abort 2001h:00, 05030000h
                 {"585#8001200000000305"});
  EXPECT_TRUE(drive.bytes_of(0x2001).empty());
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerSegmentedDownload, MoreDataThanIndicatedAborts) {
  // Given a segmented download announcing 5 bytes to 2000h:00
  // When the first segment carries 7 bytes
  // Then the server aborts 06070010h (length does not match) and writes nothing
  ScriptedDrive drive;
  // ccs=1 e=0 s=1, 2000h:00, size 5
  drive.exchange("605#2100200005000000", {"585#6000200000000000"});
  // ccs=0 t=0 n=0 c=0, 7 bytes
  drive.exchange("605#0011223344556677",
                 // abort 2000h:00, 06070010h
                 {"585#8000200010000706"});
  EXPECT_TRUE(drive.bytes_of(0x2000).empty());
}

TEST(SdoServerSegmentedDownload, LessDataThanIndicatedAborts) {
  // Given a segmented download announcing 10 bytes to 2000h:00
  // When the only segment has c=1 and 3 bytes
  // Then the server aborts 06070010h and writes nothing
  ScriptedDrive drive;
  // ccs=1 e=0 s=1, 2000h:00, size 10
  drive.exchange("605#210020000A000000", {"585#6000200000000000"});
  // ccs=0 t=0 n=4 c=1, 3 bytes
  drive.exchange("605#09AABBCC00000000",
                 // abort 2000h:00, 06070010h
                 {"585#8000200010000706"});
  EXPECT_TRUE(drive.bytes_of(0x2000).empty());
}

TEST(SdoServerSegmentedDownload, ZeroBytesToADomain) {
  // Given 2000h:00 holds 3 bytes
  // When the tester downloads 0 bytes (size 0, one segment with n=7, c=1)
  // Then the domain is empty afterwards
  ScriptedDrive drive;
  const std::vector<std::uint8_t> three{1, 2, 3};
  ASSERT_TRUE(drive.od().find(0x2000, 0)->assign_bytes(three));
  // ccs=1 e=0 s=1, 2000h:00, size 0
  drive.exchange("605#2100200000000000", {"585#6000200000000000"});
  // ccs=0 t=0 n=7 c=1, no data
  drive.exchange("605#0F00000000000000", {"585#2000000000000000"});
  EXPECT_TRUE(drive.bytes_of(0x2000).empty());
}

// ============================================================================================
// Block download (CiA 301 §7.2.4.3.9-11, CRC §7.2.4.3.16)
// ============================================================================================

TEST(SdoServerBlockDownload, TenBytesWithCrc) {
  // Given 2000h:00 is an empty DOMAIN and the server offers blksize 127 and CRC
  // When the tester downloads 00h..09h in one sub-block of 2 segments, CRC 2378h
  // Then the server acknowledges ackseq 2, checks the CRC and stores the data at the end
  ScriptedDrive drive;
  // ccs=6 c=1 s=1 cs=0, 2000h:00, size 10
  drive.exchange("605#C60020000A000000",
                 // scs=5 c=1 ss=0, 2000h:00, blksize 127
                 {"585#A40020007F000000"});
  // seqno 1, 00h..06h
  drive.send("605#0100010203040506");
  drive.expect({});
  EXPECT_TRUE(drive.bytes_of(0x2000).empty());
  // c=1 seqno 2, 07h 08h 09h + padding
  drive.exchange("605#8207080900000000",
                 // scs=5 ss=2, ackseq 2, blksize 127
                 {"585#A2027F0000000000"});
  EXPECT_EQ(drive.server().state(), SdoServer::State::block_download_end);
  // ccs=6 n=4 cs=1, CRC 2378h
  drive.exchange("605#D178230000000000",
                 // scs=5 ss=1 end block download response
                 {"585#A100000000000000"});
  EXPECT_EQ(drive.bytes_of(0x2000), iota_bytes(10));
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerBlockDownload, ConfiguredBlockSizeAndNewBlockSizeInTheAck) {
  // Given a server configured for blksize 2, changed to 3 after the initiate
  // When the tester downloads 20 bytes (3 segments)
  // Then the initiate response offers 2, the first ack asks for 3, and all 20 bytes arrive
  SdoServerConfig config = test_config();
  config.block_size = 2;
  ScriptedDrive drive(config);
  // ccs=6 c=1 s=1, 2000h:00, size 20
  drive.exchange("605#C600200014000000",
                 // scs=5 c=1, 2000h:00, blksize 2
                 {"585#A400200002000000"});
  drive.server().set_block_size(3);
  // seqno 1, 00h..06h
  drive.send("605#0100010203040506");
  // seqno 2, 07h..0Dh
  drive.exchange("605#020708090A0B0C0D",
                 // scs=5 ss=2, ackseq 2, blksize 3
                 {"585#A202030000000000"});
  // c=1 seqno 1, 0Eh..13h
  drive.exchange("605#810E0F1011121300",
                 // scs=5 ss=2, ackseq 1, blksize 3
                 {"585#A201030000000000"});
  // ccs=6 n=1 cs=1, CRC ACCCh
  drive.exchange("605#C5CCAC0000000000", {"585#A100000000000000"});
  EXPECT_EQ(drive.bytes_of(0x2000), iota_bytes(20));
}

TEST(SdoServerBlockDownload, LostSegmentIsAcknowledgedWithTheLastGoodSequenceNumber) {
  // Given a block download of 20 bytes with blksize 4
  // When segment 2 of the sub-block is lost and 3 (c=1) arrives
  // Then the ack carries ackseq 1, and the client's retransmission from there completes it
  SdoServerConfig config = test_config();
  config.block_size = 4;
  ScriptedDrive drive(config);
  // ccs=6 c=1 s=1, 2000h:00, size 20
  drive.exchange("605#C600200014000000", {"585#A400200004000000"});
  // seqno 1, 00h..06h
  drive.send("605#0100010203040506");
  // (seqno 2 lost) c=1 seqno 3, 0Eh..13h
  drive.exchange("605#830E0F1011121300",
                 // scs=5 ss=2, ackseq 1, blksize 4
                 {"585#A201040000000000"});
  EXPECT_EQ(drive.server().state(), SdoServer::State::block_download_sub_block);
  // retransmission renumbered from 1: seqno 1, 07h..0Dh
  drive.send("605#010708090A0B0C0D");
  // c=1 seqno 2, 0Eh..13h
  drive.exchange("605#820E0F1011121300",
                 // scs=5 ss=2, ackseq 2, blksize 4
                 {"585#A202040000000000"});
  // ccs=6 n=1 cs=1, CRC ACCCh
  drive.exchange("605#C5CCAC0000000000", {"585#A100000000000000"});
  EXPECT_EQ(drive.bytes_of(0x2000), iota_bytes(20));
}

TEST(SdoServerBlockDownload, FirstSegmentLostGivesAckseqZero) {
  // Given a block download with blksize 2
  // When segment 1 is lost and segment 2 (= blksize) arrives
  // Then the ack carries ackseq 0: the whole sub-block must be sent again
  SdoServerConfig config = test_config();
  config.block_size = 2;
  ScriptedDrive drive(config);
  drive.exchange("605#C600200014000000", {"585#A400200002000000"});
  // seqno 2 only
  drive.exchange("605#020708090A0B0C0D",
                 // scs=5 ss=2, ackseq 0, blksize 2
                 {"585#A200020000000000"});
  EXPECT_EQ(drive.server().state(), SdoServer::State::block_download_sub_block);
}

TEST(SdoServerBlockDownload, CrcMismatchAborts) {
  // Given a block download of 10 bytes with CRC on both sides
  // When the end request carries CRC 0000h instead of 2378h
  // Then the server aborts 05040004h naming 2000h:00 and writes nothing
  ScriptedDrive drive;
  drive.exchange("605#C60020000A000000", {"585#A40020007F000000"});
  drive.send("605#0100010203040506");
  drive.exchange("605#8207080900000000", {"585#A2027F0000000000"});
  // ccs=6 n=4 cs=1, CRC 0000h (wrong)
  drive.exchange("605#D100000000000000",
                 // abort 2000h:00, 05040004h CRC error
                 {"585#8000200004000405"});
  EXPECT_TRUE(drive.bytes_of(0x2000).empty());
}

TEST(SdoServerBlockDownload, NoCrcCheckWhenTheClientHasNoCrc) {
  // Given a block download initiated with c=0 (the client does not support CRC)
  // When the end request carries CRC 0000h
  // Then the server does not check it and stores the data
  ScriptedDrive drive;
  // ccs=6 c=0 s=1, 2000h:00, size 10
  drive.exchange("605#C20020000A000000",
                 // scs=5 c=1 (server supports CRC), blksize 127
                 {"585#A40020007F000000"});
  drive.send("605#0100010203040506");
  drive.exchange("605#8207080900000000", {"585#A2027F0000000000"});
  // ccs=6 n=4 cs=1, CRC 0000h
  drive.exchange("605#D100000000000000", {"585#A100000000000000"});
  EXPECT_EQ(drive.bytes_of(0x2000), iota_bytes(10));
}

TEST(SdoServerBlockDownload, ServerWithoutCrcSupportSaysSo) {
  // Given a server configured without CRC support
  // When a client with CRC initiates a block download
  // Then the initiate response has c=0 and the CRC of the end request is not checked
  SdoServerConfig config = test_config();
  config.block_crc = false;
  ScriptedDrive drive(config);
  // ccs=6 c=1 s=1, 2000h:00, size 10
  drive.exchange("605#C60020000A000000",
                 // scs=5 c=0, 2000h:00, blksize 127
                 {"585#A00020007F000000"});
  drive.send("605#0100010203040506");
  drive.exchange("605#8207080900000000", {"585#A2027F0000000000"});
  // ccs=6 n=4 cs=1, CRC 1234h (ignored)
  drive.exchange("605#D134120000000000", {"585#A100000000000000"});
  EXPECT_EQ(drive.bytes_of(0x2000), iota_bytes(10));
}

TEST(SdoServerBlockDownload, SequenceNumberZeroAborts) {
  // Given a block download in its first sub-block
  // When a segment with seqno 0 arrives
  // Then the server aborts 05040003h (invalid sequence number)
  ScriptedDrive drive;
  drive.exchange("605#C60020000A000000", {"585#A40020007F000000"});
  // c=0 seqno 0
  drive.exchange("605#0000010203040506",
                 // abort 2000h:00, 05040003h
                 {"585#8000200003000405"});
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerBlockDownload, SequenceNumberAboveBlockSizeAborts) {
  // Given a block download with blksize 4
  // When a segment with seqno 5 arrives
  // Then the server aborts 05040003h
  SdoServerConfig config = test_config();
  config.block_size = 4;
  ScriptedDrive drive(config);
  drive.exchange("605#C600200014000000", {"585#A400200004000000"});
  // c=0 seqno 5
  drive.exchange("605#0500010203040506",
                 // abort 2000h:00, 05040003h
                 {"585#8000200003000405"});
}

TEST(SdoServerBlockDownload, RepeatedSegmentIsNotStoredTwice) {
  // Given a block download of 10 bytes with blksize 127
  // When segment 1 arrives twice before segment 2 (c=1)
  // Then the copy is ignored and exactly the 10 bytes are stored
  ScriptedDrive drive;
  drive.exchange("605#C60020000A000000", {"585#A40020007F000000"});
  drive.send("605#0100010203040506");
  drive.send("605#0100010203040506");
  drive.exchange("605#8207080900000000", {"585#A2027F0000000000"});
  drive.exchange("605#D178230000000000", {"585#A100000000000000"});
  EXPECT_EQ(drive.bytes_of(0x2000), iota_bytes(10));
}

TEST(SdoServerBlockDownload, SizeIndicatedDiffersFromDataAborts) {
  // Given a block download announcing 12 bytes
  // When the data end after 10 bytes (n=4 in the end request, CRC of the 10 bytes)
  // Then the server aborts 06070010h
  ScriptedDrive drive;
  // ccs=6 c=1 s=1, 2000h:00, size 12
  drive.exchange("605#C60020000C000000", {"585#A40020007F000000"});
  drive.send("605#0100010203040506");
  drive.exchange("605#8207080900000000", {"585#A2027F0000000000"});
  // ccs=6 n=4 cs=1, CRC 2378h
  drive.exchange("605#D178230000000000",
                 // abort 2000h:00, 06070010h
                 {"585#8000200010000706"});
  EXPECT_TRUE(drive.bytes_of(0x2000).empty());
}

TEST(SdoServerBlockDownload, MoreSegmentsThanTheSizeAllowsAbort) {
  // Given a block download announcing 7 bytes
  // When two segments without c arrive
  // Then the second one aborts 06070010h at once
  ScriptedDrive drive;
  // ccs=6 c=1 s=1, 2000h:00, size 7
  drive.exchange("605#C600200007000000", {"585#A40020007F000000"});
  drive.send("605#0100010203040506");
  // c=0 seqno 2: beyond 7 bytes
  drive.exchange("605#020708090A0B0C0D",
                 // abort 2000h:00, 06070010h
                 {"585#8000200010000706"});
}

TEST(SdoServerBlockDownload, EmptyDownload) {
  // Given 2000h:00 holds 3 bytes
  // When the tester block-downloads 0 bytes: one empty c=1 segment, end with n=7, CRC 0
  // Then the domain is empty
  ScriptedDrive drive;
  const std::vector<std::uint8_t> three{1, 2, 3};
  ASSERT_TRUE(drive.od().find(0x2000, 0)->assign_bytes(three));
  // ccs=6 c=1 s=1, 2000h:00, size 0
  drive.exchange("605#C600200000000000", {"585#A40020007F000000"});
  // c=1 seqno 1, no data
  drive.exchange("605#8100000000000000", {"585#A2017F0000000000"});
  // ccs=6 n=7 cs=1, CRC 0000h
  drive.exchange("605#DD00000000000000", {"585#A100000000000000"});
  EXPECT_TRUE(drive.bytes_of(0x2000).empty());
}

TEST(SdoServerBlockDownload, BlockTransferNotSupportedAbortsCommandSpecifier) {
  // Given a server configured without block transfers
  // When the tester initiates a block download and a block upload
  // Then both are aborted 05040001h (what a client takes as "fall back to segmented")
  SdoServerConfig config = test_config();
  config.block_transfer = false;
  ScriptedDrive drive(config);
  // ccs=6 c=1 s=1, 2000h:00, size 10
  drive.exchange("605#C60020000A000000",
                 // abort 2000h:00, 05040001h
                 {"585#8000200001000405"});
  // ccs=5 c=1 cs=0, 2006h:00, blksize 127, pst 0
  drive.exchange("605#A40620007F000000",
                 // abort 2006h:00, 05040001h
                 {"585#8006200001000405"});
  EXPECT_FALSE(drive.server().busy());
}

// ============================================================================================
// Block upload (CiA 301 §7.2.4.3.13-15)
// ============================================================================================

TEST(SdoServerBlockUpload, ThirtyBytesWithCrcAndRetransmission) {
  // Given 2006h:00 holds 00h..1Dh (30 bytes)
  // When the tester uploads it with blksize 3, acks only segment 1 of the first sub-block and
  //   asks for blksize 2 from then on
  // Then the server resends from byte 7, renumbered from 1, and ends with n=5 and CRC 1F11h
  ScriptedDrive drive;
  // ccs=5 c=1 cs=0, 2006h:00, blksize 3, pst 0
  drive.exchange("605#A406200003000000",
                 // scs=6 c=1 s=1 ss=0, 2006h:00, size 30
                 {"585#C60620001E000000"});
  // ccs=5 cs=3 start upload
  drive.exchange("605#A300000000000000",
                 {// seqno 1, 00h..06h
                  "585#0100010203040506",
                  // seqno 2, 07h..0Dh
                  "585#020708090A0B0C0D",
                  // seqno 3, 0Eh..14h
                  "585#030E0F1011121314"});
  // ccs=5 cs=2, ackseq 1, blksize 2
  drive.exchange("605#A201020000000000",
                 {// seqno 1, 07h..0Dh (resent)
                  "585#010708090A0B0C0D",
                  // seqno 2, 0Eh..14h (resent)
                  "585#020E0F1011121314"});
  // ccs=5 cs=2, ackseq 2, blksize 2
  drive.exchange("605#A202020000000000",
                 {// seqno 1, 15h..1Bh
                  "585#0115161718191A1B",
                  // c=1 seqno 2, 1Ch 1Dh
                  "585#821C1D0000000000"});
  // ccs=5 cs=2, ackseq 2, blksize 2
  drive.exchange("605#A202020000000000",
                 // scs=6 n=5 ss=1, CRC 1F11h
                 {"585#D5111F0000000000"});
  EXPECT_EQ(drive.server().state(), SdoServer::State::block_upload_end);
  // ccs=5 cs=1 end block upload response
  drive.send("605#A100000000000000");
  drive.expect({});
  EXPECT_FALSE(drive.server().busy());
  EXPECT_EQ(drive.server().statistics().completed, 1u);
}

TEST(SdoServerBlockUpload, WithoutClientCrcTheEndCarriesZero) {
  // Given 1008h:00 = "drivecheck"
  // When the tester uploads it by block without CRC (c=0)
  // Then the end request carries CRC 0000h
  ScriptedDrive drive;
  // ccs=5 c=0 cs=0, 1008h:00, blksize 127, pst 0
  drive.exchange("605#A00810007F000000", {"585#C60810000A000000"});
  // start
  drive.exchange("605#A300000000000000",
                 {// seqno 1, "drivech"
                  "585#0164726976656368",
                  // c=1 seqno 2, "eck"
                  "585#8265636B00000000"});
  // ack 2, blksize 127
  drive.exchange("605#A2027F0000000000",
                 // scs=6 n=4 ss=1, CRC 0000h
                 {"585#D100000000000000"});
}

TEST(SdoServerBlockUpload, ProtocolSwitchToExpedited) {
  // Given 6041h:00 is 2 bytes
  // When the tester initiates a block upload with pst 4
  // Then the server answers with an expedited initiate upload response (§7.2.4.3.13)
  ScriptedDrive drive;
  // ccs=5 c=1 cs=0, 6041h:00, blksize 127, pst 4
  drive.exchange("605#A44160007F040000",
                 // scs=2 n=2 e=1 s=1, 6041h:00, data 1234h
                 {"585#4B41600034120000"});
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerBlockUpload, ProtocolSwitchToSegmented) {
  // Given 1008h:00 is 10 bytes
  // When the tester initiates a block upload with pst 10
  // Then the server answers segmented (size 10) and serves upload segment requests
  ScriptedDrive drive;
  // ccs=5 c=1 cs=0, 1008h:00, blksize 127, pst 10
  drive.exchange("605#A40810007F0A0000",
                 // scs=2 e=0 s=1, 1008h:00, size 10
                 {"585#410810000A000000"});
  drive.exchange("605#6000000000000000", {"585#0064726976656368"});
  drive.exchange("605#7000000000000000", {"585#1965636B00000000"});
}

TEST(SdoServerBlockUpload, SizeAboveThresholdStaysBlock) {
  // Given 1008h:00 is 10 bytes
  // When the tester initiates a block upload with pst 9, and with pst 0
  // Then both answers are block upload initiate responses
  ScriptedDrive drive;
  // ccs=5 c=1, 1008h:00, blksize 127, pst 9
  drive.exchange("605#A40810007F090000", {"585#C60810000A000000"});
  // abort 1008h:00 by the client (general error), silently accepted
  drive.exchange("605#8008100000000008", {});
  // ccs=5 c=1, 1008h:00, blksize 127, pst 0
  drive.exchange("605#A40810007F000000", {"585#C60810000A000000"});
}

TEST(SdoServerBlockUpload, EmptyObjectIsOneEmptySegment) {
  // Given 2000h:00 is an empty DOMAIN
  // When the tester uploads it by block
  // Then there is one segment with c=1 and the end request has n=7, CRC 0000h
  ScriptedDrive drive;
  drive.exchange("605#A40020007F000000", {"585#C600200000000000"});
  drive.exchange("605#A300000000000000",
                 // c=1 seqno 1, no data
                 {"585#8100000000000000"});
  drive.exchange("605#A2017F0000000000",
                 // scs=6 n=7 ss=1, CRC 0000h
                 {"585#DD00000000000000"});
  drive.exchange("605#A100000000000000", {});
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerBlockUpload, InvalidBlockSizeInTheInitiateAborts) {
  // Given an idle server
  // When block uploads are initiated with blksize 0 and 128
  // Then each is aborted 05040002h (invalid block size)
  ScriptedDrive drive;
  // ccs=5 c=1, 2006h:00, blksize 0
  drive.exchange("605#A406200000000000",
                 // abort 2006h:00, 05040002h
                 {"585#8006200002000405"});
  // ccs=5 c=1, 2006h:00, blksize 128
  drive.exchange("605#A406200080000000", {"585#8006200002000405"});
}

TEST(SdoServerBlockUpload, InvalidBlockSizeInTheAckAborts) {
  // Given a block upload whose first sub-block was sent
  // When the client's ack asks for blksize 0
  // Then the server aborts 05040002h
  ScriptedDrive drive;
  drive.exchange("605#A406200001000000", {"585#C60620001E000000"});
  drive.exchange("605#A300000000000000", {"585#0100010203040506"});
  // ccs=5 cs=2, ackseq 1, blksize 0
  drive.exchange("605#A201000000000000",
                 // abort 2006h:00, 05040002h
                 {"585#8006200002000405"});
}

TEST(SdoServerBlockUpload, AckseqAboveSegmentsSentAborts) {
  // Given a block upload whose sub-block of 3 segments was sent
  // When the client acknowledges ackseq 4
  // Then the server aborts 05040003h (invalid sequence number)
  ScriptedDrive drive;
  drive.exchange("605#A406200003000000", {"585#C60620001E000000"});
  drive.send("605#A300000000000000");
  EXPECT_EQ(drive.receive_for(kAnswerWindow).size(), 3u);
  // ccs=5 cs=2, ackseq 4, blksize 3
  drive.exchange("605#A204030000000000",
                 // abort 2006h:00, 05040003h
                 {"585#8006200003000405"});
}

TEST(SdoServerBlockUpload, FullSubBlockOf127Segments) {
  // Given 2000h:00 holds 1000 bytes (143 segments)
  // When the tester uploads it by block with blksize 127
  // Then the first sub-block is 127 segments numbered 1..127, none with c=1
  ScriptedDrive drive;
  ASSERT_TRUE(drive.od().find(0x2000, 0)->assign_bytes(pattern(1000)));
  drive.exchange("605#A40020007F000000", {"585#C6002000E8030000"});
  drive.send("605#A300000000000000");
  const auto frames = drive.receive_for(kAnswerWindow);
  ASSERT_EQ(frames.size(), 127u);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(frames[i].frame.data[0], i + 1) << "segment " << i;
  }
}

// ============================================================================================
// Aborts for misuse (CiA 301 §7.2.4.3.17, Table 22)
// ============================================================================================

TEST(SdoServerAbort, UnknownObject) {
  // Given no object 3000h
  // When the tester reads and writes 3000h:00
  // Then both are aborted 06020000h naming 3000h:00
  ScriptedDrive drive;
  // ccs=2, 3000h:00
  drive.exchange("605#4000300000000000",
                 // abort 3000h:00, 06020000h object does not exist
                 {"585#8000300000000206"});
  // ccs=1 n=3 e=1 s=1, 3000h:00, data 01h
  drive.exchange("605#2F00300001000000", {"585#8000300000000206"});
  // ccs=1 e=0 s=1, 3000h:00, size 10 (checked at the initiate)
  drive.exchange("605#210030000A000000", {"585#8000300000000206"});
  // ccs=6 c=1 s=1, 3000h:00, size 10
  drive.exchange("605#C60030000A000000", {"585#8000300000000206"});
  // ccs=5 c=1, 3000h:00, blksize 127
  drive.exchange("605#A40030007F000000", {"585#8000300000000206"});
}

TEST(SdoServerAbort, UnknownSubIndex) {
  // Given 1018h has sub-indices 0 and 1 only
  // When the tester reads 1018h:05
  // Then the server aborts 06090011h naming 1018h:05
  ScriptedDrive drive;
  // ccs=2, 1018h:05
  drive.exchange("605#4018100500000000",
                 // abort 1018h:05, 06090011h
                 {"585#8018100511000906"});
}

TEST(SdoServerAbort, ReadOfWriteOnly) {
  // Given 2002h:00 is wo
  // When the tester reads it
  // Then the server aborts 06010001h
  ScriptedDrive drive;
  drive.exchange("605#4002200000000000",
                 // abort 2002h:00, 06010001h
                 {"585#8002200001000106"});
}

TEST(SdoServerAbort, WriteOfReadOnlyAsTheFestoExample) {
  // Given 6041h:00 (statusword) is ro
  // When the tester writes 32 bits to it (000 §3.2.2 L764-771)
  // Then the server answers 80 41 60 00 02 00 01 06 and the value is unchanged
  ScriptedDrive drive;
  // ccs=1 n=0 e=1 s=1, 6041h:00, 4 bytes
  drive.exchange("605#2341600000000000",
                 // abort 6041h:00, 06010002h write read only
                 {"585#8041600002000106"});
  EXPECT_EQ(drive.bytes_of(0x6041), (std::vector<std::uint8_t>{0x34, 0x12}));
}

TEST(SdoServerAbort, WriteOfConstAndReadOnlyBeforeAnySegment) {
  // Given 1008h:00 is const and 1000h:00 is ro
  // When the tester initiates a segmented and a block download to them
  // Then the initiates are aborted 06010002h at once
  ScriptedDrive drive;
  // ccs=1 e=0 s=1, 1008h:00, size 10
  drive.exchange("605#210810000A000000", {"585#8008100002000106"});
  // ccs=6 c=1 s=1, 1000h:00, size 4
  drive.exchange("605#C600100004000000", {"585#8000100002000106"});
}

TEST(SdoServerAbort, LengthTooHighAndTooLowExpedited) {
  // Given 1017h:00 is UNSIGNED16
  // When the tester writes 4 bytes, then 1 byte to it
  // Then the server aborts 06070012h, then 06070013h
  ScriptedDrive drive;
  // ccs=1 n=0 e=1 s=1, 1017h:00, 4 bytes
  drive.exchange("605#2317100001020304",
                 // abort 1017h:00, 06070012h length too high
                 {"585#8017100012000706"});
  // ccs=1 n=3 e=1 s=1, 1017h:00, 1 byte
  drive.exchange("605#2F17100001000000",
                 // abort 1017h:00, 06070013h length too low
                 {"585#8017100013000706"});
}

TEST(SdoServerAbort, IndicatedSizeCheckedAgainstTheEntryAtTheInitiate) {
  // Given 2005h:00 is UNSIGNED64 and 2001h:00 a string of at most 16 bytes
  // When segmented downloads announce 9 and 7 bytes to 2005h and 17 bytes to 2001h
  // Then the initiates are aborted 06070012h, 06070013h and 06070012h
  ScriptedDrive drive;
  // ccs=1 e=0 s=1, 2005h:00, size 9
  drive.exchange("605#2105200009000000", {"585#8005200012000706"});
  // ccs=1 e=0 s=1, 2005h:00, size 7
  drive.exchange("605#2105200007000000", {"585#8005200013000706"});
  // ccs=1 e=0 s=1, 2001h:00, size 17
  drive.exchange("605#2101200011000000", {"585#8001200012000706"});
}

TEST(SdoServerAbort, ValueAboveAndBelowTheLimits) {
  // Given 2003h:00 is INTEGER16 limited to -100..100
  // When the tester writes 101 and -101
  // Then the server aborts 06090031h and 06090032h; 100 is accepted
  ScriptedDrive drive;
  // ccs=1 n=2 e=1 s=1, 2003h:00, 0065h = 101
  drive.exchange("605#2B03200065000000",
                 // abort 2003h:00, 06090031h value too high
                 {"585#8003200031000906"});
  // ccs=1 n=2 e=1 s=1, 2003h:00, FF9Bh = -101
  drive.exchange("605#2B0320009BFF0000",
                 // abort 2003h:00, 06090032h value too low
                 {"585#8003200032000906"});
  // ccs=1 n=2 e=1 s=1, 2003h:00, 0064h = 100
  drive.exchange("605#2B03200064000000", {"585#6003200000000000"});
}

TEST(SdoServerAbort, DataCannotBeStoredInThePresentState) {
  // Given 2004h:00's validator refuses EEh with 08000022h
  // When the tester writes EEh expedited and by block download
  // Then both are aborted 08000022h and the entry is unchanged
  ScriptedDrive drive;
  // ccs=1 n=3 e=1 s=1, 2004h:00, EEh
  drive.exchange("605#2F042000EE000000",
                 // abort 2004h:00, 08000022h
                 {"585#8004200022000008"});
  // ccs=6 c=1 s=1, 2004h:00, size 1
  drive.exchange("605#C604200001000000", {"585#A40420007F000000"});
  // c=1 seqno 1, EEh
  drive.exchange("605#81EE000000000000", {"585#A2017F0000000000"});
  // ccs=6 n=6 cs=1, CRC of EEh
  const auto crc = crc16_ccitt(std::vector<std::uint8_t>{0xEE});
  drive.exchange(fmt::format("605#D9{:02X}{:02X}0000000000", crc & 0xFF, crc >> 8),
                 {"585#8004200022000008"});
  EXPECT_EQ(drive.bytes_of(0x2004), (std::vector<std::uint8_t>{0x00}));
}

TEST(SdoServerAbort, ReadHookRefusal) {
  // Given 2007h:00's read hook answers 08000024h (no data available)
  // When the tester reads it expedited and by block
  // Then both are aborted 08000024h
  ScriptedDrive drive;
  drive.exchange("605#4007200000000000", {"585#8007200024000008"});
  drive.exchange("605#A40720007F000000", {"585#8007200024000008"});
}

TEST(SdoServerAbort, OutOfMemory) {
  // Given a server that buffers at most 4096 bytes
  // When a download announces 5000 bytes, and an unindicated one sends more than 4096
  // Then the server aborts 05040005h
  ScriptedDrive drive;
  // ccs=1 e=0 s=1, 2000h:00, size 5000
  drive.exchange("605#2100200088130000",
                 // abort 2000h:00, 05040005h out of memory
                 {"585#8000200005000405"});
  // ccs=6 c=1 s=1, 2000h:00, size 5000
  drive.exchange("605#C600200088130000", {"585#8000200005000405"});
  // ccs=1 e=0 s=0, 2000h:00
  drive.exchange("605#2000200000000000", {"585#6000200000000000"});
  bool toggle = false;
  for (int i = 0; i < 585; ++i) {  // 585 * 7 = 4095 bytes
    drive.exchange(toggle ? "605#1011111111111111" : "605#0011111111111111",
                   {toggle ? "585#3000000000000000" : "585#2000000000000000"});
    toggle = !toggle;
  }
  // the 586th segment: 4102 bytes
  drive.exchange(toggle ? "605#1011111111111111" : "605#0011111111111111",
                 {"585#8000200005000405"});
  EXPECT_TRUE(drive.bytes_of(0x2000).empty());
}

TEST(SdoServerAbort, ReservedCommandSpecifier) {
  // Given an idle server, then one in a segmented download
  // When a frame with ccs=7 arrives
  // Then the server aborts 05040001h: with the frame's bytes 1..3 when idle, with the open
  //   transfer's multiplexer otherwise (and drops the transfer)
  ScriptedDrive drive;
  // ccs=7, bytes 1..3 = 6041h:00
  drive.exchange("605#E041600000000000",
                 // abort 6041h:00, 05040001h
                 {"585#8041600001000405"});
  drive.exchange("605#210120000A000000", {"585#6001200000000000"});
  // ccs=7
  drive.exchange("605#E000000000000000",
                 // abort 2001h:00, 05040001h
                 {"585#8001200001000405"});
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerAbort, SegmentWithNoTransferOpen) {
  // Given an idle server
  // When a download segment, an upload segment, a block ack and a block end arrive
  // Then each is aborted 05040001h naming 0000h:00
  ScriptedDrive drive;
  // ccs=0 t=0 c=1 download segment
  drive.exchange("605#0D01000000000000", {"585#8000000001000405"});
  // ccs=3 t=0 upload segment
  drive.exchange("605#6000000000000000", {"585#8000000001000405"});
  // ccs=5 cs=2 block upload ack
  drive.exchange("605#A2017F0000000000", {"585#8000000001000405"});
  // ccs=6 cs=1 block download end
  drive.exchange("605#C100000000000000", {"585#8000000001000405"});
}

TEST(SdoServerAbort, WrongCommandForThePhase) {
  // Given a segmented download of 2001h:00 is open
  // When an upload segment request arrives
  // Then the server aborts 05040001h naming 2001h:00 and drops the transfer
  ScriptedDrive drive;
  drive.exchange("605#210120000A000000", {"585#6001200000000000"});
  // ccs=3 t=0 upload segment
  drive.exchange("605#6000000000000000", {"585#8001200001000405"});
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerAbort, ClientAbortEndsTheTransferSilently) {
  // Given a segmented download of 2001h:00 after one segment
  // When the client aborts (08000000h)
  // Then the server sends nothing, drops the transfer and writes nothing
  ScriptedDrive drive;
  drive.exchange("605#210120000A000000", {"585#6001200000000000"});
  drive.exchange("605#0061626364656667", {"585#2000000000000000"});
  // abort 2001h:00, 08000000h
  drive.exchange("605#8001200000000008", {});
  EXPECT_FALSE(drive.server().busy());
  EXPECT_TRUE(drive.bytes_of(0x2001).empty());
  EXPECT_EQ(drive.server().statistics().aborts_received, 1u);
  // the next segment belongs to no transfer
  drive.exchange("605#1968696A00000000", {"585#8000000001000405"});
}

TEST(SdoServerAbort, ClientAbortInsideASubBlock) {
  // Given a block download in the middle of a sub-block
  // When the client sends an abort (byte 0 = 80h is never a segment)
  // Then the server drops the transfer without answering
  ScriptedDrive drive;
  drive.exchange("605#C60020000A000000", {"585#A40020007F000000"});
  drive.send("605#0100010203040506");
  // abort 2000h:00, 05040000h
  drive.exchange("605#8000200000000405", {});
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerAbort, AbortWhileIdleIsNotAnswered) {
  // Given an idle server
  // When an abort frame arrives
  // Then nothing is sent
  ScriptedDrive drive;
  drive.exchange("605#8041600000000008", {});
  EXPECT_EQ(drive.server().statistics().ignored, 1u);
}

TEST(SdoServerAbort, ApplicationAbortNamesTheTransfer) {
  // Given a segmented upload of 1008h:00 is open
  // When the application aborts it with 08000022h
  // Then the abort frame names 1008h:00 and the server is idle with no deadline
  ScriptedDrive drive;
  drive.exchange("605#4008100000000000", {"585#410810000A000000"});
  drive.runner().transmit(drive.server().abort(SdoAbort::cannot_transfer_device_state));
  drive.expect({"585#8008100022000008"});
  EXPECT_EQ(drive.server().next_deadline(), can::kForever);
}

// ============================================================================================
// Timeout (05040000h) in every phase
// ============================================================================================

struct TimeoutCase {
  const char* phase;
  std::vector<std::string_view> requests;  // sent one at a time, answers not checked
  std::string_view abort;                  // the abort expected after kServerTimeout
};

TEST(SdoServerTimeout, ClientSilentInEveryPhase) {
  // Given a transfer stopped in each phase of each protocol
  // When the client then stays silent
  // Then exactly at the timeout the server aborts 05040000h with the transfer's multiplexer,
  //   and a later segment belongs to no transfer
  const std::vector<TimeoutCase> cases = {
      {"segmented download after the initiate", {"605#210120000A000000"}, "585#8001200000000405"},
      {"segmented download after a segment",
       {"605#210120000A000000", "605#0061626364656667"},
       "585#8001200000000405"},
      {"segmented upload after the initiate", {"605#4008100000000000"}, "585#8008100000000405"},
      {"segmented upload after a segment",
       {"605#4008100000000000", "605#6000000000000000"},
       "585#8008100000000405"},
      {"block download after the initiate", {"605#C60020000A000000"}, "585#8000200000000405"},
      {"block download inside a sub-block",
       {"605#C60020000A000000", "605#0100010203040506"},
       "585#8000200000000405"},
      {"block download before the end request",
       {"605#C60020000A000000", "605#0100010203040506", "605#8207080900000000"},
       "585#8000200000000405"},
      {"block upload before the start", {"605#A40620007F000000"}, "585#8006200000000405"},
      {"block upload waiting for the ack",
       {"605#A406200003000000", "605#A300000000000000"},
       "585#8006200000000405"},
      {"block upload waiting for the end response",
       {"605#A40810007F000000", "605#A300000000000000", "605#A2027F0000000000"},
       "585#8008100000000405"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.phase);
    ScriptedDrive drive;
    for (auto request : c.requests) {
      drive.send(request);
      static_cast<void>(drive.receive_for(10ms));
    }
    ASSERT_TRUE(drive.server().busy());
    const can::TimePoint last_request = drive.bus().now() - 10ms;
    // Silence until just before the deadline...
    drive.expect_silence(kServerTimeout - 11ms);
    // ...then the abort, on the wire within one frame time of the deadline.
    const auto frames = drive.receive_for(10ms);
    ASSERT_EQ(frames.size(), 1u);
    EXPECT_EQ(can::to_candump(frames[0].frame), can::to_candump(frame(c.abort)));
    EXPECT_GE(frames[0].timestamp, last_request + kServerTimeout);
    EXPECT_LE(frames[0].timestamp, last_request + kServerTimeout + 1ms);
    EXPECT_FALSE(drive.server().busy());
    EXPECT_EQ(drive.server().statistics().timeouts, 1u);
    // The transfer is gone: a segment now is answered as one with no transfer open.
    drive.exchange("605#6000000000000000", {"585#8000000001000405"});
  }
}

TEST(SdoServerTimeout, EveryRequestRestartsTheTimer) {
  // Given a segmented download with a 1 s server timeout
  // When segments come every 900 ms
  // Then no abort is sent, and the download completes
  ScriptedDrive drive;
  drive.exchange("605#210120000A000000", {"585#6001200000000000"});
  drive.expect_silence(800ms);
  drive.exchange("605#0061626364656667", {"585#2000000000000000"});
  drive.expect_silence(800ms);
  drive.exchange("605#1968696A00000000", {"585#3000000000000000"});
  EXPECT_EQ(drive.server().statistics().timeouts, 0u);
}

TEST(SdoServerTimeout, FrameAfterTheDeadlineTimesTheTransferOutFirst) {
  // Given a state machine with a segmented download open and its deadline passed, but no
  //   on_time() call yet
  // When the next segment arrives
  // Then the answer is the timeout abort, then the abort for a segment with no transfer
  ObjectDictionary od(kNode);
  populate(od);
  SdoServer server(od, test_config());
  const can::TimePoint t0{};
  // ccs=1 e=0 s=1, 2001h:00, size 10
  ASSERT_EQ(server.on_frame(frame("605#210120000A000000"), t0).size(), 1u);
  EXPECT_EQ(server.next_deadline(), t0 + kServerTimeout);
  const auto answers = server.on_frame(frame("605#0061626364656667"), t0 + kServerTimeout);
  ASSERT_EQ(answers.size(), 2u);
  // abort 2001h:00, 05040000h
  EXPECT_EQ(answers[0], frame("585#8001200000000405"));
  // abort 0000h:00, 05040001h
  EXPECT_EQ(answers[1], frame("585#8000000001000405"));
}

TEST(SdoServerTimeout, OnTimeBeforeTheDeadlineDoesNothing) {
  // Given a segmented download opened at t0
  // When on_time() is called 1 ns before the deadline, then at it
  // Then the first call returns nothing, the second the abort
  ObjectDictionary od(kNode);
  populate(od);
  SdoServer server(od, test_config());
  const can::TimePoint t0{};
  server.on_frame(frame("605#210120000A000000"), t0);
  EXPECT_TRUE(server.on_time(t0 + kServerTimeout - 1ns).empty());
  const auto answers = server.on_time(t0 + kServerTimeout);
  ASSERT_EQ(answers.size(), 1u);
  EXPECT_EQ(answers[0], frame("585#8001200000000405"));
  EXPECT_EQ(server.next_deadline(), can::kForever);
}

// ============================================================================================
// One request at a time
// ============================================================================================

TEST(SdoServerOneRequestAtATime, NewInitiateDuringSegmentedDownloadAbortsTheOpenTransfer) {
  // Given a segmented download of 2001h:00 is open
  // When the client sends an initiate upload of 1000h:00
  // Then the server aborts 05040001h naming 2001h:00, does not execute the read, writes
  //   nothing, and the client's repeated read then succeeds
  ScriptedDrive drive;
  drive.exchange("605#210120000A000000", {"585#6001200000000000"});
  drive.exchange("605#0061626364656667", {"585#2000000000000000"});
  // ccs=2 initiate upload, 1000h:00
  drive.exchange("605#4000100000000000",
                 // abort 2001h:00, 05040001h
                 {"585#8001200001000405"});
  EXPECT_TRUE(drive.bytes_of(0x2001).empty());
  drive.exchange("605#4000100000000000", {"585#4300100092010200"});
}

TEST(SdoServerOneRequestAtATime, NewInitiateDuringSegmentedUploadAbortsTheOpenTransfer) {
  // Given a segmented upload of 1008h:00 is open
  // When the client sends an expedited download to 1017h:00
  // Then the server aborts 05040001h naming 1008h:00 and 1017h:00 is not written
  ScriptedDrive drive;
  drive.exchange("605#4008100000000000", {"585#410810000A000000"});
  // ccs=1 n=2 e=1 s=1, 1017h:00, 0064h
  drive.exchange("605#2B17100064000000", {"585#8008100001000405"});
  EXPECT_EQ(drive.bytes_of(0x1017), (std::vector<std::uint8_t>{0, 0}));
}

TEST(SdoServerOneRequestAtATime, NewInitiateWhileWaitingForABlockAck) {
  // Given a block upload whose sub-block was sent
  // When the client sends an initiate upload instead of the ack
  // Then the server aborts 05040001h naming the block transfer's object
  ScriptedDrive drive;
  drive.exchange("605#A406200003000000", {"585#C60620001E000000"});
  drive.send("605#A300000000000000");
  EXPECT_EQ(drive.receive_for(kAnswerWindow).size(), 3u);
  drive.exchange("605#4041600000000000", {"585#8006200001000405"});
}

TEST(SdoServerOneRequestAtATime, InitiateInsideASubBlockIsReadAsASegment) {
  // Given a block download with blksize 4 in its first sub-block
  // When an initiate upload request (byte 0 = 40h) arrives
  // Then it is read as a segment with seqno 64 > blksize: abort 05040003h
  SdoServerConfig config = test_config();
  config.block_size = 4;
  ScriptedDrive drive(config);
  drive.exchange("605#C600200014000000", {"585#A400200004000000"});
  // byte 0 = 40h: c=0 seqno 64 inside a sub-block
  drive.exchange("605#4041600000000000", {"585#8000200003000405"});
}

// ============================================================================================
// Frame format: DLC, remote frames, identifiers
// ============================================================================================

TEST(SdoServerFraming, ShortFrameIsIgnoredByDefault) {
  // Given the default policy (CiA 301: every SDO frame has 8 bytes)
  // When the Festo manual's read request arrives as printed, DLC 4 (000 L751)
  // Then the server does not answer
  ScriptedDrive drive;
  // ccs=2, 6041h:00, DLC 4
  drive.exchange("605#40416000", {});
  EXPECT_EQ(drive.server().statistics().ignored, 1u);
}

TEST(SdoServerFraming, ShortFrameIsPaddedWhenConfigured) {
  // Given ShortFramePolicy::pad
  // When the Festo requests arrive as printed (DLC 4 read, DLC 6 write)
  // Then the server answers as if the missing bytes were 00h
  SdoServerConfig config = test_config();
  config.short_frames = ShortFramePolicy::pad;
  ScriptedDrive drive(config);
  // ccs=2, 6041h:00, DLC 4
  drive.exchange("605#40416000", {"585#4B41600034120000"});
  // ccs=1 n=2 e=1 s=1, 6040h:00, data 03E8h, DLC 6
  drive.exchange("605#2B406000E803", {"585#6040600000000000"});
  EXPECT_EQ(drive.bytes_of(0x6040), (std::vector<std::uint8_t>{0xE8, 0x03}));
}

TEST(SdoServerFraming, ShortFrameInsideATransferDoesNotEndIt) {
  // Given a segmented upload of 1008h:00 is open (default policy)
  // When a 1-byte frame 60h arrives, then the proper 8-byte request
  // Then the short frame is ignored and the transfer goes on
  ScriptedDrive drive;
  drive.exchange("605#4008100000000000", {"585#410810000A000000"});
  drive.exchange("605#60", {});
  drive.exchange("605#6000000000000000", {"585#0064726976656368"});
}

TEST(SdoServerFraming, RemoteFrameIsIgnored) {
  // Given an idle server
  // When a remote frame on 605h arrives
  // Then nothing is sent
  ScriptedDrive drive;
  drive.exchange("605#R8", {});
}

TEST(SdoServerFraming, OtherIdentifiersAreIgnored) {
  // Given the server of node 5
  // When requests arrive on 606h, on 585h, and on the 29-bit identifier 00000605h
  // Then nothing is answered and the state machine does not count them
  ScriptedDrive drive;
  drive.exchange("606#4041600000000000", {});
  drive.exchange("585#4041600000000000", {});
  drive.exchange("00000605#4041600000000000", {});
  EXPECT_EQ(drive.server().statistics().requests, 0u);
}

TEST(SdoServerFraming, DlcAboveEightCarriesEightBytes) {
  // Given an idle server
  // When a read request arrives with DLC 15 (8 data bytes, ISO 11898-1)
  // Then it is answered as an 8-byte request
  ScriptedDrive drive;
  // ccs=2, 6041h:00, DLC 15
  drive.exchange("605#4041600000000000_F", {"585#4B41600034120000"});
}

TEST(SdoServerFraming, CobIdsFromTheConfiguration) {
  // Given a second server channel on 641h/5C1h (as 1201h could configure it)
  // When a read arrives on 641h
  // Then the answer goes out on 5C1h
  SdoServerConfig config = test_config();
  config.rx_cob_id = 0x641;
  config.tx_cob_id = 0x5C1;
  ScriptedDrive drive(config);
  drive.exchange("641#4041600000000000", {"5C1#4B41600034120000"});
  drive.exchange("605#4041600000000000", {});
}

// ============================================================================================
// Runner
// ============================================================================================

TEST(SdoServerRunnerOnBus, ResetDropsTheTransferAndItsTimer) {
  // Given a segmented upload is open
  // When the node resets the server (NMT) and the runner re-arms
  // Then no abort is ever sent and the server is idle
  ScriptedDrive drive;
  drive.exchange("605#4008100000000000", {"585#410810000A000000"});
  drive.server().reset();
  drive.runner().transmit({});
  drive.expect_silence(2 * kServerTimeout);
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerRunnerOnBus, DetachGivesThePortBack) {
  // Given a runner attached to the drive's port
  // When it is detached
  // Then requests are no longer answered
  ScriptedDrive drive;
  drive.runner().detach();
  drive.exchange("605#4041600000000000", {});
}

TEST(SdoServerRunnerOnBus, SendErrorsAreCounted) {
  // Given the drive's port is bus-off
  // When a read request reaches the server
  // Then the answer cannot be sent and the runner counts the error (bus_off)
  ScriptedDrive drive;
  drive.drive_port().set_bus_off(true);
  drive.exchange("605#4041600000000000", {});
  EXPECT_EQ(drive.runner().send_errors(), 0u);  // bus-off: the port receives nothing either
  drive.drive_port().set_bus_off(false);
  drive.runner().handle({frame("605#4041600000000000"), drive.bus().now(), false});
  EXPECT_EQ(drive.runner().send_errors(), 0u);
  drive.expect({"585#4B41600034120000"});
  drive.drive_port().set_bus_off(true);
  drive.runner().handle({frame("605#4041600000000000"), drive.bus().now(), false});
  EXPECT_EQ(drive.runner().send_errors(), 1u);
  EXPECT_EQ(drive.runner().last_send_error(), can::BusError::bus_off);
}

// ============================================================================================
// Robustness: any sequence of frames
// ============================================================================================

TEST(SdoServerRobustness, RandomFramesKeepTheServerConsistent) {
  // Given a server fed 200,000 seeded random frames, biased towards real command bytes and
  //   existing objects so that every protocol phase is reached, with time advancing
  // When each frame is handled (and on_time called at random)
  // Then every answer is an 8-byte frame on 585h, at most 128 per call, a valid SDO server
  //   frame outside block uploads, every phase is reached, and an open transfer always has
  //   a deadline ahead (none when idle)
  ObjectDictionary od(kNode);
  populate(od);
  SdoServerConfig config = test_config();
  config.block_size = 4;
  SdoServer server(od, config);
  std::mt19937 random(20240521);
  const std::uint8_t commands[] = {0x00, 0x01, 0x0F, 0x10, 0x11, 0x19, 0x20, 0x21, 0x22, 0x23,
                                   0x2F, 0x40, 0x60, 0x70, 0x80, 0x81, 0x82, 0x83, 0x84, 0xA0,
                                   0xA1, 0xA2, 0xA3, 0xA4, 0xC1, 0xC2, 0xC5, 0xC6, 0xD1, 0xE0};
  const Multiplexer objects[] = {{0x1000, 0}, {0x1008, 0}, {0x1017, 0}, {0x1018, 1},
                                 {0x2000, 0}, {0x2001, 0}, {0x2003, 0}, {0x2004, 0},
                                 {0x2006, 0}, {0x6041, 0}, {0x3000, 0}, {0x1018, 9}};
  can::TimePoint now{};
  std::size_t last_sub_block = 0;  // segments in the server's last answer
  std::size_t phases_seen = 0;
  std::array<bool, 8> seen{};
  for (int i = 0; i < 200'000; ++i) {
    can::Frame request;
    request.id = 0x605;
    request.dlc = static_cast<std::uint8_t>(random() % 4 == 0 ? random() % 16 : 8);
    for (auto& byte : request.data)
      byte = static_cast<std::uint8_t>(random());
    if (random() % 4 != 0) request.data[0] = commands[random() % std::size(commands)];
    if (random() % 2 == 0) {
      const Multiplexer mux = objects[random() % std::size(objects)];
      request.data[1] = static_cast<std::uint8_t>(mux.index);
      request.data[2] = static_cast<std::uint8_t>(mux.index >> 8);
      request.data[3] = mux.sub_index;
      if (random() % 2 == 0) request.data[4] = static_cast<std::uint8_t>(random() % 40);
      if (random() % 2 == 0) request.data[5] = request.data[6] = request.data[7] = 0;
    }
    if (random() % 3 == 0 && server.state() == SdoServer::State::block_upload_start) {
      request.data[0] = 0xA3;  // start
    } else if (random() % 3 == 0 && server.state() == SdoServer::State::block_upload_ack) {
      // ack of the whole sub-block just sent, with a valid blksize
      request.data[0] = 0xA2;
      request.data[1] = static_cast<std::uint8_t>(last_sub_block);
      request.data[2] = static_cast<std::uint8_t>(1 + random() % 127);
    }
    for (std::size_t b = request.length(); b < 8; ++b)
      request.data[b] = 0;
    now += std::chrono::microseconds(random() % 5'000);
    if (random() % 1000 == 0) now += kServerTimeout;
    const auto state_before = server.state();
    const auto answers = random() % 10 == 0 ? server.on_time(now) : server.on_frame(request, now);
    ASSERT_LE(answers.size(), 128u);
    last_sub_block = answers.size();
    for (const can::Frame& answer : answers) {
      ASSERT_EQ(answer.id, 0x585u);
      ASSERT_EQ(answer.dlc, 8u);
      const bool segment_phase = state_before == SdoServer::State::block_upload_start ||
                                 state_before == SdoServer::State::block_upload_ack;
      if (!segment_phase) {
        ASSERT_FALSE(std::holds_alternative<SdoInvalid>(decode_server_message(answer)))
            << can::to_candump(answer);
      }
    }
    ASSERT_TRUE(server.busy() ? server.next_deadline() > now
                              : server.next_deadline() == can::kForever);
    seen[static_cast<std::size_t>(server.state())] = true;
  }
  for (bool phase : seen)
    phases_seen += phase ? 1 : 0;
  EXPECT_EQ(phases_seen, seen.size())
      << "some protocol phase was never reached: " << ::testing::PrintToString(seen);
}

// ============================================================================================
// Interoperability with our SdoClient: every size 0..2000 in every transfer type
// ============================================================================================

void round_trip_all_sizes(SdoTransferMode mode, SdoClientOptions options,
                          SdoTransferKind expected_large_kind) {
  SdoServerConfig config = test_config();
  ScriptedDrive drive(config);
  SdoClient client(drive.tester(), kNode, options);
  for (std::size_t size = 0; size <= 2000; ++size) {
    SCOPED_TRACE(fmt::format("{} bytes", size));
    const auto data = pattern(size, static_cast<std::uint8_t>(size));
    const auto written = client.download({0x2000, 0}, data, mode);
    ASSERT_TRUE(written) << written.error().message();
    ASSERT_EQ(drive.bytes_of(0x2000), data);
    const SdoTransferKind download_kind = client.last_transfer().kind();
    // The empty block upload has its own test (BlockUploadOfAnEmptyObject).
    if (size == 0 && mode == SdoTransferMode::block) continue;
    const auto read = client.upload({0x2000, 0}, mode);
    ASSERT_TRUE(read) << read.error().message();
    ASSERT_EQ(*read, data);
    const SdoTransferKind upload_kind = client.last_transfer().kind();
    if (size >= 1 && size <= 4 && mode == SdoTransferMode::automatic) {
      EXPECT_EQ(download_kind, SdoTransferKind::expedited);
      EXPECT_EQ(upload_kind, SdoTransferKind::expedited);
    } else if (size > 4 || mode != SdoTransferMode::automatic) {
      EXPECT_EQ(download_kind, expected_large_kind);
    }
  }
  // The client's last frame (a block upload's end response) is still queued: deliver it.
  drive.bus().run_for(10ms);
  EXPECT_EQ(drive.server().statistics().aborts_sent, 0u);
  EXPECT_FALSE(drive.server().busy());
}

TEST(SdoServerInterop, ExpeditedAndSegmentedAllSizes) {
  // Given our SdoClient in automatic mode (expedited for 1..4 bytes, else segmented)
  // When it writes then reads back 2000h:00 with every size 0..2000
  // Then every round trip returns the data written, with no abort
  round_trip_all_sizes(SdoTransferMode::automatic, {}, SdoTransferKind::segmented);
}

TEST(SdoServerInterop, SegmentedAllSizes) {
  // Given our SdoClient forced to segmented transfer
  // When it writes then reads back every size 0..2000
  // Then every round trip returns the data written
  round_trip_all_sizes(SdoTransferMode::segmented, {}, SdoTransferKind::segmented);
}

TEST(SdoServerInterop, BlockWithCrcAllSizes) {
  // Given our SdoClient in block mode with CRC and blksize 127
  // When it writes then reads back every size 0..2000
  // Then every round trip returns the data written
  round_trip_all_sizes(SdoTransferMode::block, {}, SdoTransferKind::block);
}

TEST(SdoServerInterop, BlockWithoutCrcSmallBlocksAllSizes) {
  // Given our SdoClient in block mode without CRC, blksize 5
  // When it writes then reads back every size 0..2000
  // Then every round trip returns the data written
  SdoClientOptions options;
  options.block_crc = false;
  options.block_size = 5;
  round_trip_all_sizes(SdoTransferMode::block, options, SdoTransferKind::block);
}

TEST(SdoServerInterop, BlockUploadOfAnEmptyObject) {
  // Given 2000h:00 is an empty DOMAIN
  // When our SdoClient reads it by block upload
  // Then it gets 0 bytes: the server sends one segment with c=1 and n=7 in the end request,
  //   the same shape the client itself uses for an empty block download
  ScriptedDrive drive;
  SdoClient client(drive.tester(), kNode);
  const auto read = client.upload({0x2000, 0}, SdoTransferMode::block);
  ASSERT_TRUE(read) << read.error().message();
  EXPECT_TRUE(read->empty());
  EXPECT_EQ(client.last_transfer().kind(), SdoTransferKind::block);
}

TEST(SdoServerInterop, BlockUploadWithProtocolSwitch) {
  // Given our SdoClient in block mode with pst 20
  // When it reads objects of 2, 10, 20 and 21 bytes
  // Then the server switches to expedited/segmented up to 20 bytes and stays block above
  ScriptedDrive drive;
  SdoClientOptions options;
  options.protocol_switch_threshold = 20;
  SdoClient client(drive.tester(), kNode, options);
  for (const std::size_t size : {2, 10, 20, 21}) {
    SCOPED_TRACE(size);
    const auto data = pattern(size);
    ASSERT_TRUE(drive.od().find(0x2000, 0)->assign_bytes(data));
    const auto read = client.upload({0x2000, 0}, SdoTransferMode::block);
    ASSERT_TRUE(read) << read.error().message();
    EXPECT_EQ(*read, data);
    const auto expected = size <= 4    ? SdoTransferKind::expedited
                          : size <= 20 ? SdoTransferKind::segmented
                                       : SdoTransferKind::block;
    EXPECT_EQ(client.last_transfer().kind(), expected);
  }
}

TEST(SdoServerInterop, ClientFallsBackWhenBlockIsNotSupported) {
  // Given a server without block transfers
  // When our SdoClient writes and reads 100 bytes in block mode
  // Then the client falls back to segmented and the data arrive
  SdoServerConfig config = test_config();
  config.block_transfer = false;
  ScriptedDrive drive(config);
  SdoClient client(drive.tester(), kNode);
  const auto data = pattern(100);
  ASSERT_TRUE(client.download({0x2000, 0}, data, SdoTransferMode::block));
  EXPECT_TRUE(client.last_transfer().fell_back());
  const auto read = client.upload({0x2000, 0}, SdoTransferMode::block);
  ASSERT_TRUE(read);
  EXPECT_EQ(*read, data);
}

TEST(SdoServerInterop, AbortCodesReachTheClient) {
  // Given our SdoClient
  // When it writes a read-only object and reads a missing one
  // Then it reports the server's codes 06010002h and 06020000h
  ScriptedDrive drive;
  SdoClient client(drive.tester(), kNode);
  const auto written = client.download_value<std::uint16_t>({0x6041, 0}, 1);
  ASSERT_FALSE(written);
  EXPECT_EQ(written.error(), SdoAbort::write_read_only);
  const auto read = client.upload({0x3000, 0});
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error(), SdoAbort::object_does_not_exist);
}

TEST(SdoServerInterop, BlockDownloadSurvivesALostSegment) {
  // Given a bus that loses the 4th frame the client sends (segment 3 of the first sub-block)
  // When our SdoClient writes 500 bytes by block
  // Then the server acks ackseq 2, the client resends from segment 3 and the data arrive
  ScriptedDrive drive;
  SdoClient client(drive.tester(), kNode);
  std::uint64_t requests = 0;
  std::vector<std::uint8_t> acks;
  drive.bus().add_monitor([&](const can::TimedFrame& seen) {
    if (seen.frame.id == 0x605 && ++requests == 3) {
      // Armed after the 3rd request frame has reached the receivers: hits the 4th.
      can::FaultRule rule;
      rule.filter = can::Filter::standard(0x605);
      rule.max_count = 1;
      drive.bus().drop(rule);
    }
    if (seen.frame.id == 0x585 && seen.frame.data[0] == 0xA2) acks.push_back(seen.frame.data[1]);
  });
  const auto data = pattern(500);
  const auto written = client.download({0x2000, 0}, data, SdoTransferMode::block);
  ASSERT_TRUE(written) << written.error().message();
  EXPECT_EQ(drive.bytes_of(0x2000), data);
  ASSERT_FALSE(acks.empty());
  EXPECT_EQ(acks.front(), 2);
}

}  // namespace
}  // namespace drivecheck::cia301
