#include "protocol/cia301/emcy.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <set>
#include <vector>

namespace drivecheck::cia301 {
namespace {

can::Frame frame_of(const char* text) {
  auto frame = can::parse_candump(text);
  EXPECT_TRUE(frame) << text;
  return frame.value_or(can::Frame{});
}

TEST(EmcyCodec, KollmorgenMotorTemperatureExample) {
  // Given the Kollmorgen EMCY example (002_953174ea6ca45cdb.txt L8158-8169):
  // code 4310h (LE 10 43), register 08h (temperature), manufacturer byte 01h
  const auto emcy = decode_emcy(frame_of("081#1043080100000000"));
  // When decoded
  // Then code, register and manufacturer field are as printed
  ASSERT_TRUE(emcy) << emcy.error().reason;
  EXPECT_EQ(emcy->error_code, 0x4310);
  EXPECT_EQ(emcy->error_register, 0x08);
  EXPECT_EQ(emcy->manufacturer[0], 0x01);
  EXPECT_FALSE(emcy->is_error_reset());
  EXPECT_EQ(describe_emcy_code(emcy->error_code), "4310h Excess temperature drive (motor)");
  EXPECT_EQ(describe_error_register(emcy->error_register), "temperature");
}

TEST(EmcyCodec, FestoUndervoltageAndReset) {
  // Given Festo error 02-0 = 3220h with register 05h (generic + voltage), then the reset EMCY
  //   0000h after a successful acknowledge (digest vector 20; 000 L1255-1304, L7298)
  const Emcy error{0x3220, 0x05, {}};
  const Emcy reset{0x0000, 0x00, {}};
  // When encoded for node 1
  // Then the frames are 081#2032050000000000 and 081#0000000000000000
  EXPECT_EQ(can::to_candump(encode(error, emcy_cob_id(1))), "081#2032050000000000");
  EXPECT_EQ(can::to_candump(encode(reset, emcy_cob_id(1))), "081#0000000000000000");
  EXPECT_TRUE(decode_emcy(encode(reset, 0x081))->is_error_reset());
  EXPECT_EQ(describe_error_register(0x05), "generic+voltage");
}

TEST(EmcyCodec, EncodesTheFrameFormatThatTheCobIdEntrySelects) {
  // Given an EMCY whose 1014h entry selects a 29-bit frame (bit 29) with a small CAN-ID
  // When it is encoded with the extended format
  // Then the frame is a 29-bit frame with that id, and decoding it gives the EMCY back
  const Emcy emcy{0x8611, 0x81, {1, 2, 3, 4, 5}};
  const can::Frame frame = encode(emcy, 0x085, can::IdFormat::extended);
  EXPECT_TRUE(frame.is_extended());
  EXPECT_EQ(frame.id, 0x085u);
  // error code 8611h LE, register 81h, manufacturer bytes 01..05
  EXPECT_EQ(can::to_candump(frame), "00000085#1186810102030405");
  const auto decoded = decode_emcy(frame);
  ASSERT_TRUE(decoded) << decoded.error().reason;
  EXPECT_EQ(*decoded, emcy);
  EXPECT_FALSE(encode(emcy, 0x085).is_extended());
}

TEST(EmcyCodec, RejectsMalformedFrames) {
  // Given EMCY frames with DLC 0, 7 and an RTR
  // When decoded
  // Then each is invalid: EMCY carries 8 bytes
  const std::pair<const char*, const char*> cases[] = {
      {"081#", "DLC 0: invalid (EMCY frames carry 8 bytes)"},
      {"081#00000088000000", "DLC 7"},
      {"081#R", "remote request"},
  };
  for (const auto& [text, expected] : cases) {
    const auto emcy = decode_emcy(frame_of(text));
    ASSERT_FALSE(emcy) << text;
    EXPECT_NE(emcy.error().reason.find(expected), std::string::npos) << emcy.error().reason;
  }
}

TEST(EmcyCodeTable, Cia402CodesOfTheBrief) {
  // Given the CiA 402 codes every drive uses
  // When looked up
  // Then each is a full row with CiA 402's words
  const std::pair<std::uint16_t, const char*> cases[] = {
      {0x2310, "Continuous over-current"},
      {0x3210, "DC link over-voltage"},
      {0x4210, "Excess temperature device"},
      {0x7121, "Motor blocked"},
      {0x7305, "Incremental sensor 1 fault"},
      {0x8611, "Following error"},
      {0x8612, "Reference limit"},
      {0x8130, "Life guard error or heartbeat error"},
  };
  for (const auto& [code, text] : cases) {
    const auto row = find_emcy_code(code);
    ASSERT_TRUE(row) << std::hex << code;
    EXPECT_EQ(row->mask, 0xFFFF);
    EXPECT_EQ(row->text, text);
  }
  EXPECT_EQ(static_cast<std::uint16_t>(EmcyCode::following_error), 0x8611);
}

TEST(EmcyCodeTable, ClassesCatchManufacturerCodes) {
  // Given Festo's manufacturer codes 7380h (resolver, B.2 L7287-7406) and 8181h (CAN tx
  //   error), Kollmorgen FF01h, and codes in no class
  // When described
  // Then they fall back to their class; unknown codes say so
  EXPECT_EQ(describe_emcy_code(0x7380), "7380h Sensor (class 73xxh)");
  EXPECT_EQ(describe_emcy_code(0x8181), "8181h Communication (class 81xxh)");
  EXPECT_EQ(describe_emcy_code(0xFF01), "FF01h Device specific (class FFxxh)");
  EXPECT_EQ(describe_emcy_code(0xFF00), "FF00h Device specific");
  EXPECT_EQ(describe_emcy_code(0x2FFF), "2FFFh Current (class 2xxxh)");
  EXPECT_EQ(describe_emcy_code(0x1100), "1100h (unknown error code)");
  EXPECT_EQ(describe_emcy_code(0xA000), "A000h (unknown error code)");
}

TEST(EmcyCodeTable, HierarchyMostGeneralFirst) {
  // Given 8611h following error
  // When its hierarchy is asked
  // Then it reads Monitoring > Positioning controller > Following error
  const auto rows = emcy_code_hierarchy(0x8611);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].text, "Monitoring");
  EXPECT_EQ(rows[1].text, "Positioning controller");
  EXPECT_EQ(rows[2].text, "Following error");
}

TEST(EmcyCodeTable, UniqueNamesAndNoAmbiguousMatch) {
  // Given the one EMCY table
  // When every 16-bit value is looked up
  // Then no two rows of the same width match one value, and names are unique
  std::set<std::string_view> names;
  for (const EmcyCodeInfo& row : emcy_code_table()) {
    EXPECT_TRUE(names.insert(row.name).second) << row.name;
    EXPECT_FALSE(row.text.empty());
    EXPECT_FALSE(row.source.empty());
  }
  for (unsigned value = 0; value <= 0xFFFF; ++value) {
    std::set<std::uint16_t> masks;
    for (const EmcyCodeInfo& row : emcy_code_table()) {
      if (row.matches(static_cast<std::uint16_t>(value))) {
        EXPECT_TRUE(masks.insert(row.mask).second) << std::hex << value;
      }
    }
  }
}

TEST(EmcyCodeTable, LookupsAgreeWithAScanOfEveryRow) {
  // Given the one EMCY table and the definition of a match (value & mask == code)
  // When every 16-bit value is looked up (find_emcy_code, emcy_code_hierarchy search the table)
  // Then the hierarchy is exactly the matching rows of a scan, by ascending mask width, and
  //      the row found is the widest of them (none for a value no row matches)
  std::size_t matched_values = 0;
  for (unsigned value = 0; value <= 0xFFFF; ++value) {
    const auto v = static_cast<std::uint16_t>(value);
    std::vector<EmcyCodeInfo> scan;
    for (const EmcyCodeInfo& row : emcy_code_table()) {
      if (row.matches(v)) scan.push_back(row);
    }
    std::stable_sort(scan.begin(), scan.end(), [](const EmcyCodeInfo& a, const EmcyCodeInfo& b) {
      return std::popcount(a.mask) < std::popcount(b.mask);
    });
    const auto hierarchy = emcy_code_hierarchy(v);
    ASSERT_EQ(hierarchy.size(), scan.size()) << std::hex << value;
    for (std::size_t i = 0; i < scan.size(); ++i) {
      EXPECT_EQ(hierarchy[i].code, scan[i].code) << std::hex << value;
      EXPECT_EQ(hierarchy[i].mask, scan[i].mask) << std::hex << value;
    }
    const auto found = find_emcy_code(v);
    ASSERT_EQ(found.has_value(), !scan.empty()) << std::hex << value;
    if (found) {
      EXPECT_EQ(found->code, scan.back().code) << std::hex << value;
      ++matched_values;
    }
  }
  EXPECT_GT(matched_values, 0x4000u);  // 29952 values are in a class: the loop tested lookups
}

TEST(ErrorRegister, EveryBitNamed) {
  // Given the error register bits of CiA 301 (IRTSA Table 7, 003 L200-210)
  // When all bits are set
  // Then every name is printed in bit order
  EXPECT_EQ(describe_error_register(0xFF),
            "generic+current+voltage+temperature+communication+device-profile+reserved-bit-6+"
            "manufacturer");
  EXPECT_EQ(describe_error_register(0x00), "none");
  EXPECT_EQ(describe_error_register(0x81), "generic+manufacturer");  // IRTSA fault: 81h
}

TEST(EmcyCobIdEntry, ValidBitPolarity) {
  // Given 1014h values 00000081h (valid) and 80000081h (not valid)
  // When decoded
  // Then bit 31 = 1 means the EMCY is not produced
  EXPECT_TRUE(decode_emcy_cob_id_entry(0x00000081)->valid);
  EXPECT_FALSE(decode_emcy_cob_id_entry(0x80000081)->valid);
  EXPECT_EQ(decode_emcy_cob_id_entry(0x80000081)->encode(), 0x80000081u);
  EXPECT_FALSE(decode_emcy_cob_id_entry(0x00001081));
}

}  // namespace
}  // namespace drivecheck::cia301
