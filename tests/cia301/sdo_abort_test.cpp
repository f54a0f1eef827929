#include "protocol/cia301/sdo_abort.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace drivecheck::cia301 {
namespace {

// CiA 301 v4.2.0 Table 22, every code, written out independently of sdo_abort_codes.inc.
constexpr std::uint32_t kCia301Codes[] = {
    0x05030000, 0x05040000, 0x05040001, 0x05040002, 0x05040003, 0x05040004, 0x05040005, 0x06010000,
    0x06010001, 0x06010002, 0x06020000, 0x06040041, 0x06040042, 0x06040043, 0x06040047, 0x06060000,
    0x06070010, 0x06070012, 0x06070013, 0x06090011, 0x06090030, 0x06090031, 0x06090032, 0x06090036,
    0x060A0023, 0x08000000, 0x08000020, 0x08000021, 0x08000022, 0x08000023, 0x08000024,
};

TEST(SdoAbortTable, HasEveryCia301Code) {
  // Given the 31 abort codes of CiA 301 Table 22
  // When each is looked up
  // Then the table knows it, with CiA 301 as its source
  for (std::uint32_t code : kCia301Codes) {
    const auto info = find_sdo_abort(code);
    ASSERT_TRUE(info) << std::hex << code;
    EXPECT_EQ(info->source, "CiA 301 §7.2.4.3.17") << std::hex << code;
  }
}

TEST(SdoAbortTable, HasNoCodesCia301DoesNotDefine) {
  // Given 06040040h and 06080000h, which a manual digest names as CiA codes, and 0
  // When they are looked up
  // Then the table does not know them (they are reported as unknown codes)
  for (std::uint32_t code : {0x06040040u, 0x06080000u, 0x00000000u}) {
    EXPECT_FALSE(find_sdo_abort(code)) << std::hex << code;
  }
  EXPECT_EQ(describe_sdo_abort(0x06080000), "06080000h (unknown abort code)");
}

TEST(SdoAbortTable, CoeCodesCiteEtherCatNotCia) {
  // Given the two EtherCAT CoE codes 06010003h and 06010004h (ETG.1000.6)
  // When they are looked up
  // Then the table knows them with ETG.1000.6 as their source, never CiA 301
  for (std::uint32_t code : {0x06010003u, 0x06010004u}) {
    const auto info = find_sdo_abort(code);
    ASSERT_TRUE(info) << std::hex << code;
    EXPECT_EQ(info->source, "ETG.1000.6 CoE") << std::hex << code;
  }
}

TEST(SdoAbortTable, KnowsEveryCodeTheManualsList) {
  // Given the abort tables of the Festo (000 L775-798) and Kollmorgen (002 L914-940) manuals
  // When each listed code is looked up
  // Then the table knows it; FF030000h is the Kollmorgen manufacturer-specific code
  constexpr std::uint32_t festo[] = {
      0x05030000, 0x05040001, 0x06060000, 0x06010000, 0x06010001, 0x06010002,
      0x06020000, 0x06040041, 0x06040042, 0x06040043, 0x06040047, 0x06070010,
      0x06070012, 0x06070013, 0x06090011, 0x06090030, 0x06090031, 0x06090032,
      0x06090036, 0x08000020, 0x08000021, 0x08000022, 0x08000023,
  };
  constexpr std::uint32_t kollmorgen[] = {
      0x06010000, 0x06010001, 0x06010002, 0x06020000, 0x06040041,
      0x06040042, 0x06040043, 0x06070010, 0x06090011, 0x06090030,
      0x06090031, 0x06090032, 0x08000020, 0x08000022, 0xFF030000,
  };
  for (std::uint32_t code : festo)
    EXPECT_TRUE(find_sdo_abort(code)) << std::hex << code;
  for (std::uint32_t code : kollmorgen)
    EXPECT_TRUE(find_sdo_abort(code)) << std::hex << code;
  const auto manual_only = find_sdo_abort(0xFF030000);
  ASSERT_TRUE(manual_only);
  EXPECT_EQ(manual_only->code, SdoAbort::kollmorgen_command_buffer_full);
  EXPECT_EQ(manual_only->source, "002_953174ea6ca45cdb.txt §4.4.5.6 L940");
  // The CiA codes, the Kollmorgen code and the two EtherCAT CoE codes.
  EXPECT_EQ(sdo_abort_table().size(), std::size(kCia301Codes) + 1 + 2);
}

TEST(SdoAbortTable, KeepsCiaTextWhereManualsDiffer) {
  // Given 06040047h, which Festo calls "Overflow of an internal variable / general error"
  // When its text is read
  // Then it is CiA 301's sentence
  EXPECT_EQ(find_sdo_abort(0x06040047)->text, "General internal incompatibility in the device");
}

TEST(SdoAbortErrorCode, ComparesAsEnumAndDescribes) {
  // Given an error code made from an abort value a server sent
  // When it is compared and printed
  // Then it equals the enumerator and its message names value, name and text
  const std::error_code error(static_cast<int>(0x06010002u), sdo_abort_category());
  EXPECT_EQ(error, SdoAbort::write_read_only);
  EXPECT_EQ(error.message(), "06010002h write_read_only: Attempt to write a read only object");
  const std::error_code high = SdoAbort::kollmorgen_command_buffer_full;
  EXPECT_EQ(static_cast<std::uint32_t>(high.value()), 0xFF030000u);
  EXPECT_NE(high.message().find("FF030000h"), std::string::npos);
}

TEST(SdoAbortFuzzDictionary, OneTokenPerCodeWithItsSource) {
  // Given the fuzz dictionary text
  // When it is read line by line
  // Then every table row gives a comment citing its source and a libFuzzer token of the 4
  // little-endian bytes, and nothing else
  const std::string text = sdo_abort_fuzz_dictionary();
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');
  std::istringstream lines(text);
  std::vector<std::string> comments;
  std::vector<std::string> tokens;
  for (std::string line; std::getline(lines, line);) {
    if (line.starts_with("#")) {
      comments.push_back(line);
    } else {
      tokens.push_back(line);
    }
  }
  const auto table = sdo_abort_table();
  ASSERT_EQ(tokens.size(), table.size());
  ASSERT_EQ(comments.size(), table.size());
  const std::regex token_form(R"(sdo_abort_[0-9A-F]{8}="(\\x[0-9A-F]{2}){4}")");
  for (std::size_t i = 0; i < table.size(); ++i) {
    EXPECT_TRUE(std::regex_match(tokens[i], token_form)) << tokens[i];
    EXPECT_NE(comments[i].find(table[i].source), std::string::npos) << comments[i];
  }
  EXPECT_NE(text.find("# 06010002h write_read_only: Attempt to write a read only object "
                      "(CiA 301 §7.2.4.3.17)\nsdo_abort_06010002=\"\\x02\\x00\\x01\\x06\"\n"),
            std::string::npos);
}

}  // namespace
}  // namespace drivecheck::cia301
