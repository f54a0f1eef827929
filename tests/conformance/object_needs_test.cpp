// The object requirement tables (protocol/cia301, protocol/cia402 object_requirements.inc) and the
// lint that makes vectors declare what the tables do not make mandatory
// (conformance/vector_lint.hpp check_object_needs).
#include <gtest/gtest.h>

#include <string>

#include "conformance/vector_file.hpp"
#include "conformance/vector_lint.hpp"
#include "protocol/cia301/object_requirements.hpp"
#include "protocol/cia402/object_ids.hpp"
#include "protocol/cia402/object_requirements.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {
namespace {

Vector vector_of(const std::string& head, const std::string& steps) {
  const auto set = parse_vectors(
      "- id: t/x\n  title: t\n  source: \"CiA 301 §1\"\n" + head + "  steps:\n" + steps, "t.yaml");
  EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
  return set.vectors.empty() ? Vector{} : set.vectors.front();
}

TEST(ObjectRequirements, Cia301RowsAsCiA301Classes) {
  // Given the CiA 301 table; When looked up; Then the classes and conditions of CiA 301
  EXPECT_EQ(cia301::find_object_requirement(0x1000, 0)->kind, cia301::ObjectClass::mandatory);
  EXPECT_EQ(cia301::find_object_requirement(0x1017, 0)->condition, "heartbeat.producer");
  EXPECT_EQ(cia301::find_object_requirement(0x100C, 0)->condition, "nmt.guarding");
  EXPECT_EQ(cia301::find_object_requirement(0x1003, 3)->condition, "emcy.history");
  EXPECT_EQ(cia301::find_object_requirement(0x1029, 1)->kind, cia301::ObjectClass::optional);
  EXPECT_EQ(cia301::find_object_requirement(0x1018, 1)->kind, cia301::ObjectClass::mandatory);
  EXPECT_EQ(cia301::find_object_requirement(0x1018, 2)->kind, cia301::ObjectClass::optional);
  EXPECT_FALSE(cia301::find_object_requirement(0x2000, 0));
}

TEST(ObjectRequirements, EveryConditionIsAKnownFeatureAndEveryRowCited) {
  // Given both tables; When every row is read; Then each condition alternative is a feature
  // of the closed vocabulary and each clause cites CiA 301 or CiA 402
  for (const auto rows : {cia301::object_requirements(), cia402::object_requirements()}) {
    for (const auto& row : rows) {
      EXPECT_TRUE(row.clause.starts_with("CiA 301 §") || row.clause.starts_with("CiA 402-2 §"))
          << row.name;
      std::string_view condition = row.condition;
      while (!condition.empty()) {
        const auto bar = condition.find('|');
        EXPECT_TRUE(profile::is_known_feature(condition.substr(0, bar))) << row.name;
        if (bar == std::string_view::npos) break;
        condition.remove_prefix(bar + 1);
      }
    }
  }
}

TEST(ObjectRequirements, EveryNamedCia402ObjectIsClassed) {
  // Given every CiA 402 object drivecheck knows by name (object_ids.inc)
  // When looked up in the requirement table; Then each has a row
  for (const auto& object : cia402::object_table()) {
    EXPECT_TRUE(cia402::find_object_requirement(object.id.index, object.id.sub_index))
        << std::hex << object.id.index << " " << object.name;
  }
  EXPECT_EQ(cia402::find_object_requirement(0x6040, 0)->condition, "cia402");
  EXPECT_EQ(cia402::find_object_requirement(0x6081, 0)->condition, "mode.pp");
  EXPECT_EQ(cia402::find_object_requirement(0x6074, 0)->kind, cia301::ObjectClass::optional);
}

TEST(ObjectNeedsLint, UndeclaredOptionalObjectIsRefused) {
  // Given a vector that reads optional 1029h without declaring it
  const auto vector = vector_of("", "    - sdo_read: {index: 0x1029, sub: 0}\n");
  // When linted; Then one error at the step's line naming the token to add
  const auto errors = check_object_needs(vector);
  ASSERT_EQ(errors.size(), 1U);
  EXPECT_EQ(errors[0].line, 5);
  EXPECT_NE(errors[0].message.find("declare object.1029 in requires"), std::string::npos)
      << errors[0].message;
}

TEST(ObjectNeedsLint, DeclaredOptionalObjectPasses) {
  // Given the same vector declaring object.1029; When linted; Then no error
  const auto vector =
      vector_of("  requires: [object.1029]\n", "    - sdo_read: {index: 0x1029, sub: 0}\n");
  EXPECT_TRUE(check_object_needs(vector).empty());
}

TEST(ObjectNeedsLint, ConditionalObjectNeedsItsFeatureOrADeclaration) {
  // Given vectors writing 1017h with and without heartbeat.producer, and one with object.1017
  const std::string step = "    - sdo_write: {index: 0x1017, sub: 0, value: 100, size: 2}\n";
  const auto bare = vector_of("", step);
  const auto featured = vector_of("  requires: [heartbeat.producer]\n", step);
  const auto declared = vector_of("  requires: [object.1017]\n", step);
  // When linted; Then only the bare one is refused, with both ways out
  const auto errors = check_object_needs(bare);
  ASSERT_EQ(errors.size(), 1U);
  EXPECT_NE(errors[0].message.find("require heartbeat.producer or declare object.1017"),
            std::string::npos)
      << errors[0].message;
  EXPECT_TRUE(check_object_needs(featured).empty());
  EXPECT_TRUE(check_object_needs(declared).empty());
}

TEST(ObjectNeedsLint, SubFeaturesModesAndOptionCodesCount) {
  // Given a TPDO vector requiring pdo.dynamic-mapping, a homing vector requiring a method and an
  // option-code vector requiring a value
  const auto pdo =
      vector_of("  requires: [pdo.dynamic-mapping]\n", "    - sdo_read: {index: 0x1A00, sub: 0}\n");
  const auto homing = vector_of("  requires: [homing.method.35]\n",
                                "    - sdo_write: {index: 0x6098, sub: 0, value: 35, size: 1}\n");
  const auto option = vector_of("  requires: [option.quick-stop.6]\n",
                                "    - sdo_write: {index: 0x605A, sub: 0, value: 6, size: 2}\n");
  // When linted; Then none needs a declaration
  EXPECT_TRUE(check_object_needs(pdo).empty());
  EXPECT_TRUE(check_object_needs(homing).empty());
  EXPECT_TRUE(check_object_needs(option).empty());
}

TEST(ObjectNeedsLint, RawSdoRequestsCountAndSubIndicesAreExact) {
  // Given a raw upload of 1018h sub 2 (optional sub of a mandatory object) declared as object.1018
  const auto vector = vector_of("  requires: [object.1018]\n",
                                "    - send: \"600+N#4018100200000000\"\n"
                                "    - expect_frame: \"580+N#43181002*\"\n");
  // When linted; Then refused: the sub-index must be named
  const auto errors = check_object_needs(vector);
  ASSERT_EQ(errors.size(), 1U);
  EXPECT_NE(errors[0].message.find("object.1018.02"), std::string::npos) << errors[0].message;
}

TEST(ObjectNeedsLint, ExpectingAbsenceNeedsNothing) {
  // Given a vector that expects 1029h to be missing
  const auto vector = vector_of(
      "", "    - sdo_read: {index: 0x1029, sub: 0}\n      expect: {abort: [0x06020000]}\n");
  // When linted; Then no declaration is asked for
  EXPECT_TRUE(check_object_needs(vector).empty());
}

TEST(ObjectNeedTokens, CanonicalSpellingOnly) {
  // Given need tokens; When parsed; Then upper-case 4 (and 2) hex digits only
  EXPECT_EQ(profile::parse_object_need("object.1029"), (profile::ObjectNeed{0x1029, std::nullopt}));
  EXPECT_EQ(profile::parse_object_need("object.1018.02"), (profile::ObjectNeed{0x1018, 2}));
  EXPECT_FALSE(profile::parse_object_need("object.1a00"));
  EXPECT_FALSE(profile::parse_object_need("object.1018.2"));
  EXPECT_FALSE(profile::parse_object_need("object.10180"));
  EXPECT_TRUE(profile::is_known_feature("object.60C2.02"));
  EXPECT_EQ(profile::object_need_feature({0x1018, 2}), "object.1018.02");
}

}  // namespace
}  // namespace drivecheck::conformance
