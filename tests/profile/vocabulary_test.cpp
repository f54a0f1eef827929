#include "protocol/profile/vocabulary.hpp"

#include <gtest/gtest.h>

#include <chrono>

namespace drivecheck::profile {
namespace {

using namespace std::chrono_literals;

TEST(GlobMatch, StarMatchesAnyRunIncludingSlash) {
  // Given a deviation glob with a trailing star / When matched / Then sub-paths match too
  EXPECT_TRUE(glob_match("cia402/fsa/transition-16*", "cia402/fsa/transition-16"));
  EXPECT_TRUE(glob_match("cia402/fsa/transition-16*", "cia402/fsa/transition-16/from-qs"));
  EXPECT_TRUE(glob_match("cia301/*/abort", "cia301/sdo/x/abort"));
  EXPECT_FALSE(glob_match("cia402/fsa/transition-16*", "cia402/fsa/transition-1"));
}

TEST(GlobMatch, QuestionMarkMatchesOneCharacter) {
  // Given a glob with '?' / When matched / Then exactly one character is consumed
  EXPECT_TRUE(glob_match("cia402/homing/method-?", "cia402/homing/method-7"));
  EXPECT_FALSE(glob_match("cia402/homing/method-?", "cia402/homing/method-17"));
  EXPECT_FALSE(glob_match("a?", "a"));
}

TEST(GlobMatch, LiteralGlobMatchesOnlyItself) {
  // Given a glob without operators / When matched / Then only the identical id matches
  EXPECT_TRUE(glob_match("cia301/nmt/bootup", "cia301/nmt/bootup"));
  EXPECT_FALSE(glob_match("cia301/nmt/bootup", "cia301/nmt/bootup2"));
  EXPECT_FALSE(glob_match("cia301/nmt/bootup", "cia301/nmt/boot"));
}

TEST(GlobMatch, ManyStarsDoNotBlowUp) {
  // Given a pathological glob / When matched against a long id / Then it answers (no backtracking)
  const std::string glob(60, '*');
  const std::string id(4000, 'a');
  EXPECT_TRUE(glob_match(glob + "b", id + "b"));
  EXPECT_FALSE(glob_match(glob + "b", id));
}

TEST(GlobSyntax, RejectsUppercaseAndSpaces) {
  // Given glob texts / When validated / Then only the vector-id alphabet and * ? pass
  EXPECT_TRUE(is_valid_glob("cia402/fsa/*"));
  EXPECT_FALSE(is_valid_glob("cia402/FSA/*"));
  EXPECT_FALSE(is_valid_glob("cia402 fsa"));
  EXPECT_FALSE(is_valid_glob(""));
}

TEST(Duration, ParsesEveryUnit) {
  // Given duration texts / When parsed / Then the value is exact
  EXPECT_EQ(*parse_duration("5ns"), 5ns);
  EXPECT_EQ(*parse_duration("250us"), 250us);
  EXPECT_EQ(*parse_duration("100ms"), 100ms);
  EXPECT_EQ(*parse_duration("2s"), 2s);
  EXPECT_EQ(*parse_duration("1min"), 60s);
  EXPECT_EQ(*parse_duration("0ms"), 0ms);
}

TEST(Duration, RejectsBadText) {
  // Given malformed durations / When parsed / Then each is an error
  for (const char* text : {"", "ms", "10", "10 ms", "-5ms", "1.5s", "10h", "99999999999999min"}) {
    EXPECT_FALSE(parse_duration(text).has_value()) << text;
  }
}

TEST(Duration, HoursOnlyWhereAsked) {
  // Given "2h" / When parsed for a file and for the command line / Then only the latter takes it
  EXPECT_FALSE(parse_duration("2h").has_value());
  EXPECT_EQ(*parse_duration("2h", DurationUnits::up_to_hours), 7200s);
  EXPECT_FALSE(parse_duration("9999999999999h", DurationUnits::up_to_hours).has_value());
}

TEST(Duration, FormatsShortestExactUnit) {
  // Given durations / When formatted / Then the text parses back to the same value
  EXPECT_EQ(format_duration(2s), "2s");
  EXPECT_EQ(format_duration(1500ms), "1500ms");
  EXPECT_EQ(format_duration(0ms), "0ms");
  EXPECT_EQ(format_duration(120s), "2min");
  EXPECT_EQ(*parse_duration(format_duration(1234567ns)), 1234567ns);
}

TEST(Features, FixedAndFamiliesAreKnown) {
  // Given feature names / When checked / Then the closed vocabulary decides
  EXPECT_TRUE(is_known_feature("sdo.block"));
  EXPECT_TRUE(is_known_feature("mode.csp"));
  EXPECT_TRUE(is_known_feature("homing.method.35"));
  EXPECT_TRUE(is_known_feature("homing.method.-1"));
  EXPECT_TRUE(is_known_feature("option.quick-stop.6"));
  EXPECT_TRUE(is_known_feature("option.abort-connection.-1"));
  EXPECT_FALSE(is_known_feature("sdo.blocks"));
  EXPECT_FALSE(is_known_feature("homing.method.07"));
  EXPECT_FALSE(is_known_feature("homing.method.200"));
  EXPECT_FALSE(is_known_feature("option.quickstop.6"));
  EXPECT_FALSE(is_known_feature("option.quick-stop"));
  EXPECT_FALSE(is_known_feature("mode.xx"));
}

TEST(OptionCodes, TableNamesTheCia402Objects) {
  // Given the option-code table / When looked up / Then names and indices are CiA 402's
  EXPECT_EQ(info(OptionCode::quick_stop).index, 0x605A);
  EXPECT_EQ(info(OptionCode::abort_connection).index, 0x6007);
  EXPECT_EQ(parse_option_code("fault-reaction"), OptionCode::fault_reaction);
  EXPECT_FALSE(parse_option_code("quick_stop").has_value());
}

TEST(Timing, DefaultsAreFormatMdTable) {
  // Given the timing table / When looked up / Then FORMAT.md's defaults come back
  ASSERT_NE(find_timing("ack_latency"), nullptr);
  EXPECT_EQ(find_timing("ack_latency")->default_value, 100ms);
  EXPECT_EQ(find_timing("homing")->default_value, 30s);
  EXPECT_EQ(find_timing("nope"), nullptr);
}

TEST(Timing, EveryKeyStatesItsBasis) {
  // Given the timing table / When each row is read / Then it says what gives the bound: a
  // clause, or that it is a timeout, a tolerance or a harness value (timing_defaults.inc)
  for (const auto& row : timing_table()) {
    const bool named = row.basis.starts_with("timeout:") || row.basis.starts_with("tolerance:") ||
                       row.basis.starts_with("harness:") || row.basis.starts_with("CiA ");
    EXPECT_TRUE(named) << row.name << ": " << row.basis;
  }
  ASSERT_NE(find_timing("harness_slack"), nullptr);
}

}  // namespace
}  // namespace drivecheck::profile
