#include "protocol/cia301/sdo_abort_sets.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "protocol/cia301/sdo_abort.hpp"

namespace drivecheck::cia301 {
namespace {

using Codes = std::set<std::uint32_t>;

// The CTT's accepted sets, case by case, written out independently of sdo_abort_sets.inc from
// shared/notes/ctt-catalogue.md (CTT 3.0.3.10, CANopenDemo's published run log). Cases whose
// accepted codes the catalogue does not give are absent.
const std::map<std::string, Codes>& ctt_cases() {
  static const std::map<std::string, Codes> kCases{
      {"2.3", {0x06010000, 0x06010002, 0x08000000}},
      {"2.4", {0x06010000, 0x06010001, 0x08000000}},
      {"2.5", {0x06090011, 0x08000000}},
      {"2.6", {0x06020000, 0x08000000}},
      {"2.7", {0x05040001, 0x08000000}},
      {"2.8", {0x06070010, 0x06070012, 0x08000000}},
      {"2.9", {0x06070010, 0x06070013, 0x08000000}},
      {"2.10", {0x06090030, 0x06090031, 0x08000000}},
      {"2.17", {0x05030000}},
      {"2.26", {0x05040001, 0x05040002, 0x08000000}},
      {"2.27", {0x05040001, 0x05040003, 0x08000000}},
      {"2.28", {0x06020000, 0x08000000}},
      {"3.23", {0x06010000, 0x06040041, 0x08000000}},
      {"3.24", {0x06010000, 0x06040041, 0x08000000}},
      {"3.25", {0x06020000, 0x06040041, 0x06040042}},
      {"3.26", {0x06020000, 0x06040041, 0x06040042}},
      {"3.28", {0x06020000, 0x06040041}},
      {"3.29", {0x06020000, 0x06040041}},
      {"3.31", {0x06020000, 0x06040041}},
      {"3.32", {0x06020000, 0x06040041}},
      {"4.3", {0x06010000, 0x06010002, 0x08000000}},
      {"4.4", {0x06010000, 0x06010001, 0x08000000}},
      {"6.5", {0x06090030}},
      {"6.9", {0x08000022}},
      {"7.104", {0x06040043}},
  };
  return kCases;
}

// The sets as they should be, written out independently of the .inc: the CTT's codes plus
// those CiA 301 Table 22 gives the situation (see each citation).
const std::map<std::string, Codes>& expected_sets() {
  static const std::map<std::string, Codes> kSets{
      {"write-read-only", {0x06010000, 0x06010002, 0x08000000}},
      {"read-write-only", {0x06010000, 0x06010001, 0x08000000}},
      {"object-does-not-exist", {0x06020000, 0x08000000}},
      {"sub-index-does-not-exist", {0x06090011, 0x08000000}},
      {"invalid-command", {0x05040001, 0x08000000}},
      {"toggle", {0x05030000}},
      {"protocol-timed-out", {0x05040000}},
      {"block-size-invalid", {0x05040001, 0x05040002, 0x08000000}},
      {"block-sequence-invalid", {0x05040001, 0x05040003, 0x08000000}},
      {"crc-error", {0x05040004}},
      {"length-too-high", {0x06070010, 0x06070012, 0x08000000}},
      {"length-too-low", {0x06070010, 0x06070013, 0x08000000}},
      {"length-mismatch", {0x06070010, 0x06070012, 0x06070013, 0x08000000}},
      {"value-too-high", {0x06090030, 0x06090031, 0x08000000}},
      {"value-too-low", {0x06090030, 0x06090032}},
      {"value-range", {0x06090030, 0x06090031, 0x06090032}},
      {"mapping-while-valid", {0x06010000, 0x06040041, 0x08000000, 0x08000022}},
      {"mapping-too-long", {0x06020000, 0x06040041, 0x06040042}},
      {"mapping-count-invalid", {0x06020000, 0x06040041, 0x06040042, 0x06090030, 0x06090031}},
      {"not-mappable", {0x06020000, 0x06040041}},
      {"mapping-entry-invalid", {0x06020000, 0x06040041, 0x06040043, 0x06070010, 0x06090030}},
      {"parameter-while-valid", {0x06040043, 0x06090030, 0x08000020, 0x08000022}},
      {"cob-id-while-valid",
       {0x06010000, 0x06010002, 0x06040043, 0x06090030, 0x08000020, 0x08000022}},
      {"pdo-cob-id-fixed", {0x06090030, 0x08000000}},
      {"sync-counter-reserved", {0x06090030}},
      {"sync-counter-while-producing", {0x08000022}},
      {"heartbeat-consumer-duplicate", {0x06040043}},
      {"store-wrong-signature", {0x08000020, 0x08000021, 0x08000022, 0x08000023, 0x08000024}},
      {"store-wrong-length",
       {0x06070010, 0x06070013, 0x08000000, 0x08000020, 0x08000021, 0x08000022, 0x08000023,
        0x08000024}},
      {"not-in-present-state", {0x06010000, 0x08000020, 0x08000021, 0x08000022}},
      {"any", {}},
  };
  return kSets;
}

Codes codes_of(const SdoAbortSet& set) {
  return {set.codes().begin(), set.codes().end()};
}

// The CTT case numbers a citation names ("CTT 2.3, 4.3; CiA ..." -> 2.3, 4.3).
std::vector<std::string> ctt_cases_cited(std::string_view citation) {
  std::vector<std::string> cases;
  const std::string text(citation);
  const auto at = text.find("CTT ");
  if (at == std::string::npos) return cases;
  const auto end = text.find(';', at);
  const std::string list = text.substr(at + 4, end == std::string::npos ? end : end - at - 4);
  static const std::regex kCase(R"(\d+\.\d+)");
  for (auto it = std::sregex_iterator(list.begin(), list.end(), kCase);
       it != std::sregex_iterator(); ++it)
    cases.push_back(it->str());
  return cases;
}

TEST(SdoAbortSets, EqualTheIndependentCopy) {
  // Given the table and the sets written out independently above
  // When both are compared name by name
  // Then they hold the same sets with the same codes
  std::map<std::string, Codes> table;
  for (const auto& set : sdo_abort_sets())
    table[std::string(set.name)] = codes_of(set);
  EXPECT_EQ(table, expected_sets());
}

TEST(SdoAbortSets, EveryCodeIsAKnownAbortCode) {
  // Given every set
  // When each code is looked up in sdo_abort_codes.inc
  // Then it is there (the .cpp's static_assert says the same at compile time)
  for (const auto& set : sdo_abort_sets()) {
    for (const auto code : set.codes())
      EXPECT_TRUE(find_sdo_abort(code)) << set.name << " " << std::hex << code;
  }
}

TEST(SdoAbortSets, HoldEveryCodeOfTheCttCasesTheyCite) {
  // Given a set citing CTT cases
  // When its codes are compared with what each cited case accepts
  // Then none of the CTT's codes is missing (a conformant device that the CTT passes must pass)
  for (const auto& set : sdo_abort_sets()) {
    const auto codes = codes_of(set);
    for (const auto& number : ctt_cases_cited(set.citation)) {
      const auto it = ctt_cases().find(number);
      if (it == ctt_cases().end()) continue;  // the catalogue gives no set for this case
      for (const auto code : it->second)
        EXPECT_TRUE(codes.contains(code))
            << set.name << " lacks " << std::hex << code << " that CTT " << number << " accepts";
    }
  }
}

TEST(SdoAbortSets, GeneralErrorOnlyWhereTheCttOrTheClauseAcceptsIt) {
  // Given a set holding 08000000h (general error)
  // When the CTT cases it cites are looked at, and its citation
  // Then one of them accepts 08000000h, or the citation says the clause itself names it
  for (const auto& set : sdo_abort_sets()) {
    if (!codes_of(set).contains(0x08000000)) continue;
    const bool named_by_clause = set.citation.find("CiA 301 §") != std::string_view::npos &&
                                 set.citation.find("08000000h") != std::string_view::npos &&
                                 set.citation.find("named by the clause") != std::string_view::npos;
    bool accepted = named_by_clause;
    for (const auto& number : ctt_cases_cited(set.citation)) {
      const auto it = ctt_cases().find(number);
      if (it != ctt_cases().end() && it->second.contains(0x08000000)) accepted = true;
    }
    EXPECT_TRUE(accepted) << set.name << " holds 08000000h but cites no CTT case accepting it";
  }
}

TEST(SdoAbortSets, EveryCitationNamesAClauseOrACttCase) {
  // Given every set
  // When its citation is read
  // Then it names a CiA 301 clause (§) or a CTT case
  for (const auto& set : sdo_abort_sets()) {
    const bool clause = set.citation.find("CiA 301 §") != std::string_view::npos;
    EXPECT_TRUE(clause || !ctt_cases_cited(set.citation).empty()) << set.name;
  }
}

TEST(SdoAbortSets, FindAndDescribe) {
  // Given the set write-read-only and the any set
  // When they are found by name and described
  // Then the text carries the name, the codes and the citation; unknown names give nullopt
  const auto set = find_sdo_abort_set("write-read-only");
  ASSERT_TRUE(set);
  EXPECT_EQ(
      describe(*set),
      "write-read-only {06010000h, 06010002h, 08000000h} (CTT 2.3, 4.3; CiA 301 §7.2.4.3.17)");
  EXPECT_TRUE(set->accepts(0x06010000));
  EXPECT_FALSE(set->accepts(0x06090030));
  const auto any = find_sdo_abort_set("any");
  ASSERT_TRUE(any);
  EXPECT_TRUE(any->accepts(0x12345678));
  EXPECT_NE(describe(*any).find("{any abort code}"), std::string::npos);
  EXPECT_FALSE(find_sdo_abort_set("write-readonly"));
  EXPECT_NE(sdo_abort_set_names().find("block-size-invalid"), std::string::npos);
}

}  // namespace
}  // namespace drivecheck::cia301
