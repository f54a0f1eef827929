// The isolation planner (conformance/isolation.hpp): which objects a vector may change, which
// confirmations count as writes, and the order in which changed objects are put back.
#include "conformance/isolation.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "conformance/vector_file.hpp"

namespace drivecheck::conformance {
namespace {

Vector parse_one(const std::string& body) {
  const auto set =
      parse_vectors("- id: t/x\n  title: t\n  source: \"CiA 301 §1\"\n" + body, "t.yaml");
  EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
  return set.vectors.empty() ? Vector{} : set.vectors.front();
}

Bytes u32(std::uint32_t value) {
  return {static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8),
          static_cast<std::uint8_t>(value >> 16), static_cast<std::uint8_t>(value >> 24)};
}
Bytes u16(std::uint16_t value) {
  return {static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8)};
}
Bytes u8(std::uint8_t value) {
  return {value};
}

std::vector<std::string> describe(const RestorePlan& plan) {
  std::vector<std::string> out;
  for (const auto& write : plan.writes) {
    std::string bytes;
    for (const auto byte : write.data)
      bytes += fmt::format("{:02X}", byte);
    out.push_back(to_string(write.ref) + " := " + bytes);
  }
  return out;
}

TEST(IsolationSnapshot, WritesRawDownloadsAndFinallyStepsCommandsLeftOut) {
  // Given a vector that writes 1017h, sends a raw expedited download of 1800h sub 2, maps
  // 1A00h sub 1, stores (1010h), writes the controlword, and writes 6060h in finally:
  const auto vector = parse_one(
      "  steps:\n"
      "    - sdo_write: {index: 0x1017, sub: 0, value: 50, size: 2}\n"
      "    - send: \"600+N#2F001802FE000000\"\n"  // ccs=1 n=3 e=1 s=1, 1800h sub 2, FEh
      "    - sdo_write: {index: 0x1A00, sub: 1, value: 0x60410010, size: 4}\n"
      "    - sdo_write: {index: 0x1010, sub: 1, value: 0x65766173, size: 4}\n"
      "    - controlword: 6\n"
      "    - send: \"600+N#4017100000000000\"\n"  // ccs=2: an upload, not a write
      "  finally:\n"
      "    - sdo_write: {index: 0x6060, sub: 0, value: 1, size: 1}\n");
  // When the snapshot objects are listed for node 5
  const auto objects = snapshot_objects(vector, 5);
  // Then they are the written parameters plus what the PDO restore needs, in index order
  std::vector<std::string> names;
  for (const auto& ref : objects)
    names.push_back(to_string(ref));
  EXPECT_EQ(names, (std::vector<std::string>{"1017h sub 0", "1800h sub 1", "1800h sub 2",
                                             "1A00h sub 0", "1A00h sub 1", "6060h sub 0"}));
}

TEST(IsolationSnapshot, WritesInsideARepeatAreLearnedAsOutside) {
  // Given a vector whose only writes are inside a repeat (an sdo_write and a raw download)
  const auto vector = parse_one(
      "  steps:\n"
      "    - repeat:\n"
      "        times: 3\n"
      "        steps:\n"
      "          - sdo_write: {index: 0x1017, sub: 0, value: 50, size: 2}\n"
      "          - send: \"600+N#2F001802FE000000\"\n");  // 1800h sub 2, FEh
  // When the snapshot objects are listed for node 5
  const auto objects = snapshot_objects(vector, 5);
  // Then they are the objects the repeat writes, each once
  std::vector<std::string> names;
  for (const auto& ref : objects)
    names.push_back(to_string(ref));
  EXPECT_EQ(names, (std::vector<std::string>{"1017h sub 0", "1800h sub 1", "1800h sub 2"}));
}

TEST(IsolationSnapshot, RawDownloadToAnotherNodeIsNotTheDuts) {
  // Given a raw download to 600h + 3; When the DUT is node 5; Then it writes nothing of it
  const auto vector = parse_one("  steps:\n    - send: \"603#2F001802FE000000\"\n");
  EXPECT_TRUE(snapshot_objects(vector, 5).empty());
  EXPECT_EQ(snapshot_objects(vector, 3).size(), 2U);  // 1800h sub 2 and its COB-ID
}

TEST(IsolationConfirmation, DownloadResponsesCountOthersDoNot) {
  // Given the DUT's (node 5) frames: a download response for 1017h, an upload response and an
  // abort for 1018h, a block download initiate response for 1F50h
  const auto frame = [](const char* text) { return *can::parse_candump(text); };
  // When decoded; Then only the download responses name an object
  EXPECT_EQ(confirmed_download(frame("585#6017100000000000"), 5), (ObjectRef{0x1017, 0}));
  EXPECT_FALSE(confirmed_download(frame("585#4B17100032000000"), 5));
  EXPECT_FALSE(confirmed_download(frame("585#8018100100000206"), 5));
  EXPECT_EQ(confirmed_download(frame("585#A4501F0107000000"), 5), (ObjectRef{0x1F50, 1}));
  EXPECT_FALSE(confirmed_download(frame("586#6017100000000000"), 5));  // another node
}

TEST(IsolationPlan, PdoGoesInvalidThenMappingThenCobIdLast) {
  // Given TPDO1 (1800h/1A00h) remapped and its transmission type changed while valid
  RestoreInput input;
  input.before = {{{0x1800, 1}, u32(0x181)},
                  {{0x1800, 2}, u8(0xFF)},
                  {{0x1A00, 0}, u8(1)},
                  {{0x1A00, 1}, u32(0x60410010)},
                  {{0x1A00, 2}, u32(0x60640020)}};
  input.after = {{{0x1800, 1}, u32(0x181)},
                 {{0x1800, 2}, u8(0x01)},
                 {{0x1A00, 0}, u8(2)},
                 {{0x1A00, 1}, u32(0x10010008)},
                 {{0x1A00, 2}, u32(0x60640020)}};
  input.written = {{0x1800, 2}, {0x1A00, 0}, {0x1A00, 1}, {0x1A00, 2}};
  // When the restore is planned
  const auto plan = plan_restore(input);
  // Then the CiA 301 procedure: COB-ID invalid, transmission type, count 0, the entry that
  // differs, the count, the COB-ID as it was
  EXPECT_EQ(describe(plan),
            (std::vector<std::string>{"1800h sub 1 := 81010080", "1800h sub 2 := FF",
                                      "1A00h sub 0 := 00", "1A00h sub 1 := 10004160",
                                      "1A00h sub 0 := 01", "1800h sub 1 := 81010000"}));
}

TEST(IsolationPlan, InvalidPdoIsNotInvalidatedAgain) {
  // Given RPDO1's COB-ID that the vector made invalid (bit 31) from valid
  RestoreInput input;
  input.before = {{{0x1400, 1}, u32(0x201)}};
  input.after = {{{0x1400, 1}, u32(0x80000201)}};
  input.written = {{0x1400, 1}};
  // When planned; Then one write puts the valid COB-ID back
  EXPECT_EQ(describe(plan_restore(input)), (std::vector<std::string>{"1400h sub 1 := 01020000"}));
}

TEST(IsolationPlan, SkipsEqualUnwrittenReadOnlyUnreadableAndCommands) {
  // Given written objects that are equal again, read-only, unreadable before or commands, and
  // one changed object the vector did not write
  RestoreInput input;
  input.before = {{{0x6060, 0}, u8(1)},
                  {{0x6041, 0}, u16(0x250)},
                  {{0x1010, 1}, u32(1)},
                  {{0x6081, 0}, u32(5)},
                  {{0x607A, 0}, u32(0)}};
  input.after = {{{0x6060, 0}, u8(1)},
                 {{0x6041, 0}, u16(0x237)},
                 {{0x1010, 1}, u32(1)},
                 {{0x6081, 0}, u32(9)},
                 {{0x607A, 0}, u32(100)}};
  input.written = {{0x6060, 0}, {0x6041, 0}, {0x1010, 1}, {0x2000, 0}, {0x607A, 0}};
  input.read_only = {{0x6041, 0}};
  // When planned
  const auto plan = plan_restore(input);
  // Then only 607Ah is written; 6041h and 2000h are reported skipped
  EXPECT_EQ(describe(plan), (std::vector<std::string>{"607Ah sub 0 := 00000000"}));
  EXPECT_EQ(plan.skipped, (std::vector<std::string>{"2000h sub 0: unreadable before the vector",
                                                    "6041h sub 0: read-only"}));
}

TEST(IsolationPlan, ObjectUnreadableAfterIsWrittenBack) {
  // Given 6060h readable before, unreadable after the vector; When planned
  RestoreInput input;
  input.before = {{{0x6060, 0}, u8(1)}};
  input.written = {{0x6060, 0}};
  // Then it is written back (its value now is unknown)
  EXPECT_EQ(describe(plan_restore(input)), (std::vector<std::string>{"6060h sub 0 := 01"}));
}

TEST(IsolationPlan, ErrorControlLastMonitoringOffBeforeOn) {
  // Given 1017h (was 0, now 50), 1016h sub 1 (was node 7Dh, now 7Eh), 100Ch (was 100, now 0)
  // and 6060h, all changed
  RestoreInput input;
  input.before = {{{0x1017, 0}, u16(0)},
                  {{0x1016, 1}, u32(0x007D00C8)},
                  {{0x100C, 0}, u16(100)},
                  {{0x6060, 0}, u8(1)}};
  input.after = {{{0x1017, 0}, u16(50)},
                 {{0x1016, 1}, u32(0x007E00C8)},
                 {{0x100C, 0}, u16(0)},
                 {{0x6060, 0}, u8(3)}};
  input.written = {{0x1017, 0}, {0x1016, 1}, {0x100C, 0}, {0x6060, 0}};
  // When planned
  const auto plan = plan_restore(input);
  // Then the application object first, the heartbeat off, the consumer entry through 0, and
  // what switches monitoring on last
  EXPECT_EQ(describe(plan),
            (std::vector<std::string>{"6060h sub 0 := 01", "1017h sub 0 := 0000",
                                      "1016h sub 1 := 00000000", "1016h sub 1 := C8007D00",
                                      "100Ch sub 0 := 6400"}));
}

TEST(IsolationPlan, EmcyCobIdDisabledBeforeItsIdentifierChanges) {
  // Given 1014h moved from 81h to 85h while valid
  RestoreInput input;
  input.before = {{{0x1014, 0}, u32(0x81)}};
  input.after = {{{0x1014, 0}, u32(0x85)}};
  input.written = {{0x1014, 0}};
  // When planned; Then it goes invalid (bit 31) at 85h first, then back to 81h
  EXPECT_EQ(describe(plan_restore(input)),
            (std::vector<std::string>{"1014h sub 0 := 85000080", "1014h sub 0 := 81000000"}));
}

TEST(IsolationPlan, SubIndexZeroAfterTheOthersOfItsIndex) {
  // Given 2100h sub 0 and sub 2 changed; When planned; Then sub 2 first, sub 0 last
  RestoreInput input;
  input.before = {{{0x2100, 0}, u8(2)}, {{0x2100, 2}, u8(7)}};
  input.after = {{{0x2100, 0}, u8(1)}, {{0x2100, 2}, u8(8)}};
  input.written = {{0x2100, 0}, {0x2100, 2}};
  EXPECT_EQ(describe(plan_restore(input)),
            (std::vector<std::string>{"2100h sub 2 := 07", "2100h sub 0 := 02"}));
}

}  // namespace
}  // namespace drivecheck::conformance
