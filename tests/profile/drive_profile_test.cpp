#include "protocol/profile/drive_profile.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <map>
#include <random>
#include <string>

#include "tests/support/temp_dir.hpp"

namespace drivecheck::profile {
namespace {

using namespace std::chrono_literals;
using test_support::TempDir;

// A small valid profile; tests append or replace lines to make it wrong.
constexpr std::string_view kMinimal = R"(name: test-drive
title: "A test drive"
features: [sdo.segmented, emcy, cia402]
modes: [1, 6, -3]
homing_methods: [1, 35, -1]
option_codes: {quick-stop: [0, 2], halt: [1]}
)";

Expected<DriveProfile, TextError> parse(std::string_view text,
                                        std::string file = "test-drive.yaml") {
  ParseOptions options;
  options.file_name = std::move(file);
  return parse_profile(text, options);
}

// The error of parsing `text` (fails the test if it parsed).
TextError error_of(std::string_view text) {
  auto result = parse(text);
  EXPECT_FALSE(result.has_value()) << "parsed, but should not have:\n" << text;
  return result ? TextError{} : result.error();
}

TEST(DriveProfileLoad, MinimalProfileParses) {
  // Given a minimal profile / When parsed / Then its sections are typed
  auto p = parse(kMinimal);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_EQ(p->name, "test-drive");
  EXPECT_EQ(p->modes, (std::vector<int>{1, 6, -3}));
  EXPECT_EQ(p->option_codes.at(OptionCode::quick_stop), (std::vector<int>{0, 2}));
  EXPECT_TRUE(p->deviations.empty());
}

TEST(DriveProfileLoad, ListsImplyTheirFeatures) {
  // Given modes, homing methods and option codes / When parsed / Then their features are added
  auto p = parse(kMinimal);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_TRUE(p->supports("mode.pp"));
  EXPECT_TRUE(p->supports("mode.hm"));
  EXPECT_FALSE(p->supports("mode.csp"));
  EXPECT_TRUE(p->supports("homing.method.35"));
  EXPECT_TRUE(p->supports("homing.method.-1"));
  EXPECT_TRUE(p->supports("option.quick-stop.2"));
  EXPECT_TRUE(p->supports("option.halt.1"));
  EXPECT_FALSE(p->supports("option.quick-stop.6"));
  EXPECT_TRUE(p->supports("emcy"));
}

TEST(DriveProfileLoad, ModeOnOneLinkIsClaimedThereOnly) {
  // Given csp in modes and in modes_only_on for EtherCAT / When parsed / Then mode.csp is
  // claimed, limited to EtherCAT, and the CAN modes lack 8
  auto p = parse(R"(name: test-drive
title: "A test drive"
features: [cia402]
modes: [1, 8]
modes_only_on:
  - {mode: 8, link: ethercat, source: "000_33c1d912b8b6010a.txt §7.1.2 L5979"}
)");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_TRUE(p->supports("mode.csp"));
  EXPECT_EQ(p->only_on("mode.csp"), Link::ethercat);
  EXPECT_FALSE(p->only_on("mode.pp").has_value());
  EXPECT_EQ(p->modes_on(Link::can), (std::vector<int>{1}));
  EXPECT_EQ(p->modes_on(Link::ethercat), (std::vector<int>{1, 8}));
  auto again = parse(to_yaml(*p));
  ASSERT_TRUE(again.has_value()) << again.error().to_string();
  EXPECT_EQ(*again, *p);
}

TEST(DriveProfileLoad, ModeOnlyOnErrorsNameTheirLine) {
  // Given a modes_only_on entry for a mode not in modes, one with an unknown link and one
  // without a source / When parsed / Then each is an error at its line
  const std::string head =
      "name: test-drive\ntitle: \"t\"\nfeatures: [cia402]\nmodes: [1, 8]\n"
      "modes_only_on:\n";
  const auto e1 = error_of(head + "  - {mode: 9, link: ethercat, source: \"x\"}\n");
  EXPECT_EQ(e1.line, 6) << e1.to_string();
  EXPECT_NE(e1.message.find("not in modes"), std::string::npos) << e1.to_string();
  const auto e2 = error_of(head + "  - {mode: 8, link: profinet, source: \"x\"}\n");
  EXPECT_EQ(e2.line, 6) << e2.to_string();
  EXPECT_NE(e2.message.find("can, ethercat"), std::string::npos) << e2.to_string();
  const auto e3 = error_of(head + "  - {mode: 8, link: ethercat}\n");
  EXPECT_EQ(e3.line, 6) << e3.to_string();
}

TEST(DriveProfileLoad, TheHardwareEnableTransitionImpliesTheInput) {
  // Given a personality whose transition 2 waits for the hardware enable
  auto p = parse(std::string(kMinimal) + "personality:\n  hardware_enable: transition-2\n");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  // Then the profile supports that transition's feature and the input, not the other one
  EXPECT_TRUE(p->supports("hardware-enable.transition-2"));
  EXPECT_TRUE(p->supports("hardware-enable"));
  EXPECT_FALSE(p->supports("hardware-enable.transition-3"));
  // And a listed transition feature alone implies the input too
  auto listed = parse(R"(name: test-drive
title: "A test drive"
features: [cia402, hardware-enable.transition-3]
)");
  ASSERT_TRUE(listed.has_value()) << listed.error().to_string();
  EXPECT_TRUE(listed->supports("hardware-enable"));
}

TEST(DriveProfileLoad, DetectIsNotAClaim) {
  // Given a profile that detects heartbeat.producer and mode.pp (no modes list)
  auto p = parse(
      "name: test-drive\ntitle: T\nfeatures: [sdo.expedited]\n"
      "detect: [heartbeat.producer, mode.pp]\n");
  // When parsed; Then the features are detected, not claimed, and survive to_yaml
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_TRUE(p->detects("mode.pp"));
  EXPECT_FALSE(p->supports("mode.pp"));
  auto again = parse(to_yaml(*p));
  ASSERT_TRUE(again.has_value()) << again.error().to_string();
  EXPECT_EQ(*again, *p);
}

TEST(DriveProfileLoad, ObjectNeedIsNotAFeatureClaim) {
  // Given a profile listing an object need as a feature; When parsed; Then refused
  const TextError e =
      error_of("name: test-drive\ntitle: T\nfeatures: [sdo.expedited, object.1029]\n");
  EXPECT_NE(e.message.find("object need"), std::string::npos) << e.to_string();
}

TEST(DriveProfileLoad, TimingOverridesAndDefaults) {
  // Given a timing override / When looked up / Then the override wins, others keep defaults
  auto p = parse(std::string(kMinimal) + "timing: {ack_latency: 4ms, homing: 1min}\n");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_EQ(*p->timing_value("ack_latency"), 4ms);
  EXPECT_EQ(*p->timing_value("homing"), 60s);
  EXPECT_EQ(*p->timing_value("response"), 100ms);
  EXPECT_FALSE(p->timing_value("unknown").has_value());
}

TEST(DriveProfileLoad, DeviationsListExactIdsWithTheirObservation) {
  // Given a deviation with exact ids, one with its own observation
  auto p = parse(std::string(kMinimal) + R"(deviations:
  - id: no-transition-16
    vectors: ["cia402/fsa/transition-16/x", {id: "cia402/option/quick-stop-6", observed: {value: 2}}]
    observed: {state: switch-on-disabled}
    source: "000_33c1d912b8b6010a.txt §6.1.6 L5841-5922"
    description: "605Ah fixed"
  - id: also-16
    vectors: ["cia402/fsa/transition-16/x"]
    observed: [{abort: 0x06090030}, {missing: frame}, {no_answer: true}, {accepted: true},
               {statusword: {mask: 0x6F, value: 0x27}}, {text: "late"}]
    source: s
    description: d
)");
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  // When vector ids are looked up
  const auto found = p->deviations_for("cia402/fsa/transition-16/x");
  // Then only listed ids are found, in file order, each with its documented observation
  ASSERT_EQ(found.size(), 2u);
  EXPECT_EQ(found[0]->id, "no-transition-16");
  const auto& own = found[0]->observed_for(*found[0]->find("cia402/fsa/transition-16/x"));
  ASSERT_EQ(own.size(), 1u);
  EXPECT_EQ(own[0].kind, DeviationObservation::Kind::state);
  EXPECT_EQ(own[0].state, cia402::State::switch_on_disabled);
  const auto& q = found[0]->observed_for(*found[0]->find("cia402/option/quick-stop-6"));
  ASSERT_EQ(q.size(), 1u);
  EXPECT_EQ(q[0].kind, DeviationObservation::Kind::value);
  EXPECT_EQ(q[0].value, 2);
  EXPECT_EQ(found[1]->observed.size(), 6u);
  EXPECT_EQ(found[1]->observed[1].kind, DeviationObservation::Kind::nothing);
  EXPECT_EQ(found[1]->observed[4].describe(), "statusword & 006Fh == 0027h");
  EXPECT_TRUE(p->deviations_for("cia402/fsa/transition-16/y").empty());
  EXPECT_TRUE(p->deviations_for("cia402/fsa/transition-16").empty());
  // And the profile survives a round trip through YAML
  auto again = parse(to_yaml(*p));
  ASSERT_TRUE(again.has_value()) << again.error().to_string();
  EXPECT_EQ(*again, *p);
}

struct ErrorCase {
  const char* name;
  std::string text;
  int line;
  const char* message_part;
};

class DriveProfileErrors : public ::testing::TestWithParam<ErrorCase> {};

TEST_P(DriveProfileErrors, NamesFileLineAndCause) {
  // Given a broken profile / When parsed / Then the error names file, line and the cause
  const ErrorCase& c = GetParam();
  const TextError e = error_of(c.text);
  EXPECT_EQ(e.file, "test-drive.yaml");
  EXPECT_EQ(e.line, c.line) << e.to_string();
  EXPECT_NE(e.message.find(c.message_part), std::string::npos) << e.to_string();
}

std::string with(std::string_view extra) {
  return std::string(kMinimal) + std::string(extra);
}

INSTANTIATE_TEST_SUITE_P(
    EveryErrorClass, DriveProfileErrors,
    ::testing::Values(
        ErrorCase{"YamlSyntax", with("modes: [1, 2\n"), 8, ""},
        ErrorCase{"NotAMap", "- a\n- b\n", 1, "must be a map"}, ErrorCase{"Empty", "", 0, "empty"},
        ErrorCase{"UnknownTopKey", with("featurez: []\n"), 7, "unknown key 'featurez'"},
        ErrorCase{"DetectUnprobeable", with("detect: [transition.16]\n"), 7, "cannot be probed"},
        ErrorCase{"DetectAndClaim", with("detect: [emcy]\n"), 7, "also claimed in features"},
        ErrorCase{"DetectTwice", with("detect: [store, store]\n"), 7, "listed twice"},
        ErrorCase{"DuplicateKey", with("title: again\n"), 7, "duplicate key 'title'"},
        ErrorCase{"MissingFeatures", "name: test-drive\ntitle: t\n", 1,
                  "missing required key 'features'"},
        ErrorCase{"MissingTitle", "name: test-drive\nfeatures: []\n", 1,
                  "missing required key 'title'"},
        ErrorCase{"NameNotFileName", "name: other\ntitle: t\nfeatures: []\n", 1,
                  "not the file name"},
        ErrorCase{"NameBadCharacters", "name: Test Drive\ntitle: t\nfeatures: []\n", 1,
                  "must be [a-z0-9_-]+"},
        ErrorCase{"UnknownFeature",
                  "name: test-drive\ntitle: t\nfeatures:\n  - emcy\n  - sdo.blocks\n", 5,
                  "unknown feature 'sdo.blocks'"},
        ErrorCase{"FeatureTwice", "name: test-drive\ntitle: t\nfeatures: [emcy, emcy]\n", 3,
                  "listed twice"},
        ErrorCase{"FamilyFeatureWithoutList",
                  "name: test-drive\ntitle: t\nfeatures: [mode.csp]\nmodes: [1]\n", 3,
                  "needs its value"},
        ErrorCase{"ModeOutOfRange", "name: test-drive\ntitle: t\nfeatures: []\nmodes: [1, 300]\n",
                  4, "out of range"},
        ErrorCase{"ModeNotInteger", "name: test-drive\ntitle: t\nfeatures: []\nmodes: [pp]\n", 4,
                  "not an integer"},
        ErrorCase{"ModeTwice", "name: test-drive\ntitle: t\nfeatures: []\nmodes: [1, 1]\n", 4,
                  "listed twice"},
        ErrorCase{"UnknownOptionObject",
                  with("timing: {}\n") + "personality:\n  option_codes: {quickstop: [1]}\n", 9,
                  "unknown key 'quickstop'"},
        ErrorCase{"UnknownTimingName", with("timing:\n  ack: 5ms\n"), 8, "unknown name 'ack'"},
        ErrorCase{"BadDuration", with("timing:\n  ack_latency: 5 ms\n"), 8,
                  "unknown duration unit"},
        ErrorCase{"BadDataType",
                  with("objects:\n  - {index: 0x6041, type: UINT16, access: ro, source: s}\n"), 8,
                  "unknown data type 'UINT16'"},
        ErrorCase{"BadAccess",
                  with("objects:\n  - {index: 0x6041, type: UNSIGNED16, access: r, source: s}\n"),
                  8, "not one of ro wo rw"},
        ErrorCase{"ObjectMissingSource",
                  with("objects:\n  - {index: 0x6041, type: UNSIGNED16, access: ro}\n"), 8,
                  "missing required key 'source'"},
        ErrorCase{"ObjectMinAboveMax",
                  with("objects:\n  - {index: 0x6060, type: INTEGER8, access: rw, min: 5, max: 1, "
                       "source: s}\n"),
                  8, "min is above max"},
        ErrorCase{"ObjectTwice",
                  with("objects:\n  - {index: 0x6041, type: UNSIGNED16, access: ro, source: s}\n"
                       "  - {index: 0x6041, type: UNSIGNED16, access: ro, source: s}\n"),
                  9, "listed twice"},
        ErrorCase{"EmcyCodeTooLarge",
                  with("emcy_codes:\n  - {code: 0x12345, text: t, source: s}\n"), 8,
                  "out of range"},
        ErrorCase{"EmcyCodeTwice",
                  with("emcy_codes:\n  - {code: 0x2320, text: t, source: s}\n"
                       "  - {code: 0x2320, text: u, source: s}\n"),
                  9, "listed twice"},
        ErrorCase{"PdoBadName",
                  with("pdo_defaults:\n  - {pdo: tpdo0, cob_id: 180+N, mapping: [], source: s}\n"),
                  8, "tpdo1..tpdo512"},
        ErrorCase{"PdoBadCobId",
                  with("pdo_defaults:\n  - {pdo: tpdo1, cob_id: 18G+N, mapping: [], source: s}\n"),
                  8, "not a COB-ID"},
        ErrorCase{"PdoMappingOver64Bits",
                  with("pdo_defaults:\n  - {pdo: tpdo1, cob_id: 180+N, mapping: [0x60640020, "
                       "0x606C0020, 0x60410010], source: s}\n"),
                  8, "more than 64 bits"},
        ErrorCase{"DeviationBadId",
                  with("deviations:\n  - id: x\n    observed: {value: 1}\n"
                       "    vectors: [\"CiA402/x\"]\n    source: s\n    description: d\n"),
                  10, "not a vector id"},
        ErrorCase{"DeviationGlobRefused",
                  with("deviations:\n  - id: x\n    observed: {value: 1}\n"
                       "    vectors: [\"cia402/fsa/*\"]\n    source: s\n    description: d\n"),
                  10, "is a glob"},
        ErrorCase{"DeviationWithoutObserved",
                  with("deviations:\n  - id: x\n    vectors: [\"cia402/a\"]\n    source: s\n"
                       "    description: d\n"),
                  9, "has no observed"},
        ErrorCase{"DeviationObservedTwoKinds",
                  with("deviations:\n  - id: x\n    observed: {value: 1, abort: 0x06090030}\n"
                       "    vectors: [a]\n    source: s\n    description: d\n"),
                  9, "exactly one of"},
        ErrorCase{"DeviationObservedUnknownState",
                  with("deviations:\n  - id: x\n    observed: {state: enabled}\n"
                       "    vectors: [a]\n    source: s\n    description: d\n"),
                  9, "is not a state"},
        ErrorCase{"DeviationNoDescription",
                  with("deviations:\n  - id: x\n    vectors: [{id: a, observed: {value: 1}}]\n"
                       "    source: s\n"),
                  8, "missing required key 'description'"},
        ErrorCase{"DeviationIdTwice",
                  with("deviations:\n  - {id: x, vectors: [a], observed: {value: 1}, source: s, "
                       "description: d}\n"
                       "  - {id: x, vectors: [b], observed: {value: 1}, source: s, "
                       "description: d}\n"),
                  9, "used twice"},
        ErrorCase{"DeviationUnknownKey",
                  with("deviations:\n  - {id: x, vectors: [a], observed: {value: 1}, source: s, "
                       "description: d, severity: low}\n"),
                  8, "unknown key 'severity'"},
        ErrorCase{"PersonalityUnknownKey", with("personality:\n  emcy_twice: true\n"), 8,
                  "unknown key 'emcy_twice'"},
        ErrorCase{"PersonalityBadChoice", with("personality:\n  homing: fast\n"), 8,
                  "not one of standard, set-position"},
        ErrorCase{"PersonalityBadBool", with("personality:\n  emcy_follow_up: yes\n"), 8,
                  "true or false"},
        ErrorCase{"ManufacturerModeNotListed",
                  with("personality:\n  manufacturer_modes: [{value: -7, behaves_as: 1}]\n"), 8,
                  "not in the modes list"},
        ErrorCase{"ManufacturerModeBadBehaviour",
                  with("personality:\n  manufacturer_modes: [{value: -3, behaves_as: 5}]\n"), 8,
                  "not a CiA 402 mode"},
        ErrorCase{"ManufacturerObjectsBadChoice",
                  with("personality:\n  manufacturer_objects: festo\n"), 8,
                  "personality.manufacturer_objects: 'festo' is not one of none, kollmorgen"},
        ErrorCase{"PositionSamplingBadChoice",
                  with("personality:\n  position_sampling: kollmorgen\n"), 8,
                  "personality.position_sampling: 'kollmorgen' is not one of none, festo"},
        ErrorCase{"HardwareEnableContradiction",
                  "name: test-drive\ntitle: T\nfeatures: [cia402, hardware-enable.transition-3]\n"
                  "personality:\n  hardware_enable: transition-2\n",
                  5, "contradicts the feature hardware-enable.transition-3"},
        ErrorCase{"HardwareEnableBothTransitions",
                  "name: test-drive\ntitle: T\nfeatures: [hardware-enable.transition-2, "
                  "hardware-enable.transition-3]\n",
                  3, "exclude each other"},
        ErrorCase{"ManufacturerModeBadLogic",
                  with("personality:\n  manufacturer_modes: [{value: -3, logic: jog}]\n"), 8,
                  "manufacturer_modes.logic: 'jog' is not one of behaves-as, irtsa-mpp"},
        ErrorCase{"OptionDefaultNotAccepted",
                  with("personality:\n  option_defaults: {quick-stop: 6}\n"), 8,
                  "not an accepted value"},
        ErrorCase{"ObjectTypeNotInteger",
                  with("personality:\n  object_types: [{index: 0x6060, type: REAL32}]\n"), 8,
                  "only integer types"},
        ErrorCase{"ListFileWithoutDirectory", with("objects: objects.yaml\n"), 7,
                  "has no directory"},
        ErrorCase{"CommissioningUnknownKey",
                  with("commissioning:\n  vectors: [\"cia402/*\"]\n  writes:\n"
                       "    - {index: 0x6094, sub: 1, value: 15, size: 4, source: s, why: w}\n"
                       "    - {index: 0x6094, sub: 2, value: 4, size: 4, source: s, wy: w}\n"),
                  11, "unknown key 'wy'"},
        ErrorCase{"CommissioningValueTooWide",
                  with("commissioning:\n  vectors: [\"cia402/*\"]\n  writes:\n"
                       "    - {index: 0x6060, value: 300, size: 1, source: s, why: w}\n"),
                  10, "commissioning.writes.value (1 bytes)"},
        ErrorCase{"CommissioningWrittenTwice",
                  with("commissioning:\n  vectors: [\"cia402/*\"]\n  writes:\n"
                       "    - {index: 0x6094, sub: 1, value: 15, size: 4, source: s, why: w}\n"
                       "    - {index: 0x6094, sub: 1, value: 16, size: 4, source: s, why: w}\n"),
                  11, "written twice"},
        ErrorCase{"CommissioningWithoutWhy",
                  with("commissioning:\n  vectors: [\"cia402/*\"]\n  writes:\n"
                       "    - {index: 0x6094, sub: 1, value: 15, size: 4, source: s}\n"),
                  10, "missing required key 'why'"},
        ErrorCase{"CommissioningBadGlob",
                  with("commissioning:\n  vectors: [\"Cia402/*\"]\n  writes:\n"
                       "    - {index: 0x6094, sub: 1, value: 15, size: 4, source: s, why: w}\n"),
                  8, "not a glob"},
        ErrorCase{"CommissioningNoWrites",
                  with("commissioning:\n  vectors: [\"cia402/*\"]\n  writes: []\n"), 9,
                  "at least one write"},
        ErrorCase{"InternalUnitsNotAFraction",
                  with("personality:\n  internal_units: {velocity: [4]}\n"), 8,
                  "[numerator, divisor]"},
        ErrorCase{"EncoderResolutionBelowFour", with("personality:\n  encoder_resolution: 2\n"), 8,
                  "encoder_resolution"},
        ErrorCase{"InvalidUtf8", with("manual: \"a\xC3(b\"\n"), 7, "not valid UTF-8"},
        ErrorCase{"Utf8Surrogate", with("manual: \"\xED\xA0\x80\"\n"), 7, "not valid UTF-8"}),
    [](const ::testing::TestParamInfo<ErrorCase>& param_info) {
      return std::string(param_info.param.name);
    });

TEST(DriveProfileLoad, DeepNestingIsAnErrorNotACrash) {
  // Given 100000 nested flow sequences / When parsed / Then an error, no stack overflow
  const TextError e = error_of(std::string(100000, '[') + "\n");
  EXPECT_NE(e.message.find("nested too deeply"), std::string::npos) << e.to_string();
}

TEST(DriveProfileFiles, ListSectionFromFileNextToProfile) {
  // Given a profile naming its object list file / When loaded / Then the list is read from it
  TempDir dir;
  dir.write("objects-x.yaml",
            "- {index: 0x6041, type: UNSIGNED16, access: ro, pdo: true, source: s}\n");
  const auto path = dir.write("test-drive.yaml", with("objects: objects-x.yaml\n"));
  auto p = load_profile(path);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  ASSERT_EQ(p->objects.size(), 1U);
  EXPECT_EQ(p->objects[0].index, 0x6041);
  EXPECT_TRUE(p->objects[0].pdo);
}

TEST(DriveProfileFiles, ErrorInListFileNamesThatFile) {
  // Given a list file with a bad entry on line 2 / When loaded / Then the error names that file:2
  TempDir dir;
  const auto list = dir.write(
      "emcy-x.yaml", "- {code: 0x2320, text: t, source: s}\n- {code: zz, text: t, source: s}\n");
  const auto path = dir.write("test-drive.yaml", with("emcy_codes: emcy-x.yaml\n"));
  auto p = load_profile(path);
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().file, list.string());
  EXPECT_EQ(p.error().line, 2);
}

TEST(DriveProfileFiles, MissingListFileIsAnError) {
  // Given a profile naming a list file that does not exist / When loaded / Then file:line error
  TempDir dir;
  const auto path = dir.write("test-drive.yaml", with("pdo_defaults: nope.yaml\n"));
  auto p = load_profile(path);
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().file, path.string());
  EXPECT_EQ(p.error().line, 7);
  EXPECT_NE(p.error().message.find("cannot read"), std::string::npos);
}

TEST(DriveProfileFiles, ListFileOutsideDirectoryRefused) {
  // Given a list file path with '..' / When loaded / Then it is refused
  TempDir dir;
  const auto path = dir.write("test-drive.yaml", with("objects: ../x.yaml\n"));
  auto p = load_profile(path);
  ASSERT_FALSE(p.has_value());
  EXPECT_NE(p.error().message.find("without '..'"), std::string::npos);
}

TEST(DriveProfileFiles, FindProfileByNameAndUnknownName) {
  // Given a directory with one profile / When found by name / Then it loads; unknown lists names
  TempDir dir;
  dir.write("test-drive.yaml", kMinimal);
  auto p = find_profile("test-drive", dir.path());
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_EQ(p->path, dir / "test-drive.yaml");
  auto missing = find_profile("festo", dir.path());
  ASSERT_FALSE(missing.has_value());
  EXPECT_NE(missing.error().message.find("known: test-drive"), std::string::npos)
      << missing.error().message;
}

TEST(DriveProfileFiles, UnreadableFileIsAnError) {
  // Given a path that does not exist / When loaded / Then the error names the file
  auto p = load_profile("/nonexistent/x.yaml");
  ASSERT_FALSE(p.has_value());
  EXPECT_EQ(p.error().file, "/nonexistent/x.yaml");
}

TEST(DriveProfileYaml, SerialiseParseRoundTrip) {
  // Given a profile using every section / When serialised and parsed / Then it is equal
  auto p = parse(with(R"(manual: 000_33c1d912b8b6010a.txt
identity: {vendor_id: 0x1D, device_name: "CMMP: AS", software_version: "null"}
timing: {ack_latency: 4ms}
objects:
  - {index: 0x6041, type: UNSIGNED16, access: ro, pdo: true, default: 0, name: "statusword", source: s}
  - {index: 0x1008, type: VISIBLE_STRING, access: const, default: "yes", source: [a, b]}
  - {index: 0x6060, type: INTEGER8, access: rw, min: -3, max: 10, source: s}
emcy_codes:
  - {code: 0x2320, text: "Short: circuit", register: 0x03, diagnostic: "06-0", source: s}
pdo_defaults:
  - {pdo: tpdo1, cob_id: 0x180+N, transmission: 255, event_timer: 10, mapping: [0x60410010], source: s}
  - {pdo: rpdo2, cob_id: "301", transmission: 1, inhibit_time: 5, mapping: [], source: s}
deviations:
  - {id: x, vectors: ["a/b", {id: c, observed: {abort: 0x06090030}}], observed: [{value: -2}, {state: fault}], source: [s, t], description: "d: e", contradiction: "c"}
personality:
  identity: {product_code: 7}
  manufacturer_modes: [{value: -3, behaves_as: 1, logic: irtsa-mpp, name: "user jog"}]
  option_defaults: {quick-stop: 2}
  hardware_enable: transition-3
  manufacturer_homing: irtsa
  homing_default_method: -127
  homing_halt_sets_error: true
  emcy_follow_up: true
  error_code_format: error-number
  homing: set-position
  object_types: [{index: 0x6060, type: INTEGER16}]
  guarding_loss: pre-operational
  ack_latency_cycles: 3
  control_cycle: 250us
  sdo_dlc: minimal
  sdo_short_requests: pad
  heartbeat_time_ms: 100
  guard_time_ms: 50
  life_time_factor: 3
  internal_units: {velocity: [4, 15], acceleration: [64, 15]}
  encoder_resolution: 65536
  pp_change_on_set_point: false
  ip_submode: -2
  power_stage_in_switched_on: true
  nmt_min_spacing: 1ms
  manufacturer_objects: kollmorgen
  position_sampling: festo
  note: "why"
commissioning:
  vectors: ["cia402/*"]
  except: ["cia402/factor/*"]
  writes:
    - {index: 0x6094, sub: 1, value: 15, size: 4, source: [s, t], why: "15/4: increments/s"}
    - {index: 0x6060, value: -1, size: 1, source: s, why: w}
)"));
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const std::string yaml = to_yaml(*p);
  auto again = parse(yaml);
  ASSERT_TRUE(again.has_value()) << again.error().to_string() << "\n" << yaml;
  EXPECT_EQ(*again, *p) << yaml;
  EXPECT_EQ(to_yaml(*again), yaml);
}

TEST(DriveProfileCommissioning, AppliesToItsGlobsButNotTheExceptions) {
  // Given a commissioning for cia402/* except cia402/factor/* / When asked per vector id /
  // Then only the motion vectors get it; a profile without writes commissions nothing
  auto p = parse(with(R"(commissioning:
  vectors: ["cia402/*"]
  except: ["cia402/factor/*"]
  writes:
    - {index: 0x6094, sub: 1, value: 15, size: 4, source: s, why: w}
    - {index: 0x6097, sub: 2, value: 64, size: 4, source: s, why: w}
)"));
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const Commissioning& c = p->commissioning;
  ASSERT_EQ(c.writes.size(), 2U);
  EXPECT_EQ(c.writes[1].index, 0x6097);
  EXPECT_EQ(c.writes[1].sub, 2);
  EXPECT_EQ(c.writes[1].value, 64);
  EXPECT_EQ(c.writes[1].size, 4);
  EXPECT_TRUE(c.applies_to("cia402/pp/relative"));
  EXPECT_FALSE(c.applies_to("cia402/factor/festo/defaults"));
  EXPECT_FALSE(c.applies_to("cia301/sdo/abort/timeout"));
  EXPECT_FALSE(Commissioning{}.applies_to("cia402/pp/relative"));
}

TEST(DriveProfilePersonality, DefaultsComeFromTheProfile) {
  // Given a personality without identity, modes, option codes / When resolved / Then profile's
  auto p =
      parse(with("identity: {vendor_id: 0x1D}\npersonality: {hardware_enable: transition-2}\n"));
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const Personality e = p->effective_personality();
  ASSERT_TRUE(e.identity.has_value());
  EXPECT_EQ(e.identity->vendor_id, 0x1DU);
  EXPECT_EQ(*e.modes, p->modes);
  EXPECT_EQ(*e.option_codes, p->option_codes);
  EXPECT_EQ(e.hardware_enable, HardwareEnable::transition_2);
}

TEST(DriveProfilePersonality, ObjectRulesParseAndRefuseNonsense) {
  // Given personality objects, a mapping flag and transmit masks / When parsed / Then typed;
  // an action without type, access const, a duplicate and min above max are errors
  auto p =
      parse(with("personality:\n"
                 "  objects:\n"
                 "    - {index: 0x2030, type: INTEGER32, access: wo, action: set-actual-position}\n"
                 "    - {index: 0x1005, values: [0x80, 0x80000080]}\n"
                 "    - {index: 0x604D, type: UNSIGNED8, default: 4, min: 2, max: 254}\n"
                 "  pdo_mapping_while_valid: true\n"
                 "  tpdo_transmit_masks: 0x2014\n"));
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const Personality& e = p->personality;
  ASSERT_EQ(e.objects.size(), 3U);
  EXPECT_EQ(e.objects[0].action, ObjectAction::set_actual_position);
  EXPECT_EQ(e.objects[0].access, cia301::AccessType::wo);
  EXPECT_EQ(e.objects[1].values, (std::vector<std::int64_t>{0x80, 0x80000080}));
  EXPECT_EQ(e.objects[2].min, 2);
  EXPECT_TRUE(e.pdo_mapping_while_valid);
  EXPECT_EQ(e.tpdo_transmit_masks, 0x2014);
  error_of(with("personality: {objects: [{index: 0x2030, action: set-actual-position}]}\n"));
  error_of(with("personality: {objects: [{index: 0x2030, access: const}]}\n"));
  error_of(
      with("personality: {objects: [{index: 0x2030, access: ro}, {index: 0x2030, access: "
           "wo}]}\n"));
  error_of(with("personality: {objects: [{index: 0x604D, min: 5, max: 2}]}\n"));
  error_of(with("personality: {tpdo_transmit_masks: 0x1000}\n"));
}

TEST(DriveProfilePersonality, PermittedChoiceKeysParseAndRoundTrip) {
  // Given the keys of issue 17's permitted choices / When parsed and serialised / Then typed
  // and equal after the round trip
  auto p =
      parse(with("personality:\n"
                 "  cia402: false\n"
                 "  absent_objects: [0x1003, [0x1005, 0x1007]]\n"
                 "  abort_codes: {write_read_only: 0x06010000, 0x06090011: general_error}\n"
                 "  sdo_response_delay: [20ms, 40ms]\n"
                 "  pdo_mapping: static\n"
                 "  empty_pdo_valid: refuse\n"
                 "  tpdo_sync_phase: first-sync\n"
                 "  setpoint_buffer: 4\n"));
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const Personality& e = p->personality;
  EXPECT_FALSE(e.cia402);
  EXPECT_EQ(e.absent_objects, (std::vector<ObjectRange>{{0x1003, 0x1003}, {0x1005, 0x1007}}));
  EXPECT_EQ(e.abort_codes, (std::map<std::uint32_t, std::uint32_t>{{0x06010002, 0x06010000},
                                                                   {0x06090011, 0x08000000}}));
  EXPECT_EQ(e.sdo_response_delay.min, 20ms);
  EXPECT_EQ(e.sdo_response_delay.max, 40ms);
  EXPECT_EQ(e.pdo_mapping, PdoMapping::fixed);
  EXPECT_EQ(e.empty_pdo_valid, EmptyPdoValid::refuse);
  EXPECT_EQ(e.tpdo_sync_phase, TpdoSyncPhase::first_sync);
  EXPECT_EQ(e.setpoint_buffer, 4U);
  auto again = parse(to_yaml(*p));
  ASSERT_TRUE(again.has_value()) << again.error().to_string() << "\n" << to_yaml(*p);
  EXPECT_EQ(again->personality, e);
  // A single delay is [d, d]; the defaults are the standard drive's.
  auto single = parse(with("personality: {sdo_response_delay: 30ms}\n"));
  ASSERT_TRUE(single.has_value()) << single.error().to_string();
  EXPECT_EQ(single->personality.sdo_response_delay.min, 30ms);
  EXPECT_EQ(single->personality.sdo_response_delay.max, 30ms);
  const Personality standard;
  EXPECT_TRUE(standard.cia402);
  EXPECT_EQ(standard.pdo_mapping, PdoMapping::dynamic);
  EXPECT_EQ(standard.setpoint_buffer, 1U);
}

TEST(DriveProfilePersonality, PermittedChoiceKeysRefuseNonsense) {
  // Given a mandatory object made absent, a reversed range, codes the table lacks, a delay
  // above 1 s or reversed, a buffer of 0 / When parsed / Then errors naming the line
  for (std::string_view bad : {
           "personality: {absent_objects: [0x1018]}\n",
           "personality: {absent_objects: [[0x1000, 0x1002]]}\n",
           "personality: {absent_objects: [[0x1007, 0x1005]]}\n",
           "personality: {absent_objects: [[0x1005]]}\n",
           "personality: {abort_codes: {0x12345678: 0x06010000}}\n",
           "personality: {abort_codes: {write_read_only: no_such_code}}\n",
           "personality: {abort_codes: [0x06010002]}\n",
           "personality: {sdo_response_delay: [40ms, 20ms]}\n",
           "personality: {sdo_response_delay: 2s}\n",
           "personality: {setpoint_buffer: 0}\n",
           "personality: {pdo_mapping: fixed}\n",
           "personality: {tpdo_sync_phase: third}\n",
           "personality: {cia402: maybe}\n",
       }) {
    const TextError error = error_of(with(bad));
    EXPECT_GT(error.line, 0) << bad;
  }
}

TEST(DriveProfileCoe, RulesParseAndRoundTrip) {
  // Given a coe: section with every key / When parsed and serialised / Then typed and equal
  // after the round trip, and a profile without one has the standard drive's rules
  auto p =
      parse(with("coe:\n"
                 "  max_sdo_size: 4\n"
                 "  absent_objects: [[0x1008, 0x100A], 0x6089]\n"
                 "  pdo_assignment_evaluated: false\n"
                 "  pdo_configuration_in: any\n"
                 "  source: [\"000_33c1d912b8b6010a.txt §4.8 L2157\"]\n"));
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  const CoeRules& c = p->coe;
  EXPECT_EQ(c.max_sdo_size, 4u);
  EXPECT_EQ(c.absent_objects, (std::vector<ObjectRange>{{0x1008, 0x100A}, {0x6089, 0x6089}}));
  EXPECT_TRUE(c.is_absent(0x1009));
  EXPECT_TRUE(c.is_absent(0x6089));
  EXPECT_FALSE(c.is_absent(0x100B));
  EXPECT_FALSE(c.pdo_assignment_evaluated);
  EXPECT_EQ(c.pdo_configuration_in, PdoConfigurationIn::any);
  EXPECT_EQ(c.sources, std::vector<std::string>{"000_33c1d912b8b6010a.txt §4.8 L2157"});
  auto again = parse(to_yaml(*p));
  ASSERT_TRUE(again.has_value()) << again.error().to_string() << "\n" << to_yaml(*p);
  EXPECT_EQ(again->coe, c);
  auto standard = parse(kMinimal);
  ASSERT_TRUE(standard.has_value());
  EXPECT_EQ(standard->coe, CoeRules{});
  EXPECT_FALSE(standard->coe.max_sdo_size);
  EXPECT_TRUE(standard->coe.pdo_assignment_evaluated);
  EXPECT_EQ(standard->coe.pdo_configuration_in, PdoConfigurationIn::preop);
}

TEST(DriveProfileCoe, BadRulesNameTheirLine) {
  // Given a coe: section with an unknown key, a value out of range, a mandatory object made
  // absent, a reversed range, an unknown state, a non-boolean, no source / When parsed / Then
  // an error at the offending line (the minimal profile has 6 lines: coe: is line 7)
  struct Case {
    std::string_view text;
    int line;
    std::string_view says;
  };
  for (const Case& bad : {
           Case{"coe:\n  source: x\n  max_sdo_bytes: 4\n", 9, "unknown key 'max_sdo_bytes'"},
           Case{"coe:\n  source: x\n  max_sdo_size: 0\n", 9, "coe.max_sdo_size"},
           Case{"coe:\n  source: x\n  absent_objects: [0x1018]\n", 9, "mandatory"},
           Case{"coe:\n  source: x\n  absent_objects: [[0x100A, 0x1008]]\n", 9, "below"},
           Case{"coe:\n  source: x\n  absent_objects: [0x0FFF]\n", 9, "absent_objects"},
           Case{"coe:\n  source: x\n  pdo_configuration_in: safeop\n", 9, "preop, any"},
           Case{"coe:\n  source: x\n  pdo_assignment_evaluated: perhaps\n", 9,
                "pdo_assignment_evaluated"},
           Case{"coe:\n  max_sdo_size: 4\n", 8, "missing required key 'source'"},
           Case{"coe: [4]\n", 7, "coe must be a map"},
       }) {
    const TextError error = error_of(with(bad.text));
    EXPECT_EQ(error.file, "test-drive.yaml") << bad.text;
    EXPECT_EQ(error.line, bad.line) << bad.text << error.to_string();
    EXPECT_NE(error.message.find(bad.says), std::string::npos) << error.to_string();
  }
}

TEST(DriveProfilePersonality, ErrorNumberCode) {
  // Given an IRTSA error number / When encoded / Then n * 256 + 80h
  EXPECT_EQ(error_number_code(5), 0x0580);
  EXPECT_EQ(error_number_code(0), 0x0080);
  EXPECT_EQ(error_number_code(255), 0xFF80);
}

}  // namespace
}  // namespace drivecheck::profile

namespace drivecheck::profile {
namespace {

const std::filesystem::path kDrives =
    std::filesystem::path(DRIVECHECK_SOURCE_DIR) / "vectors/drives";

class ShippedProfile : public ::testing::TestWithParam<const char*> {};

TEST_P(ShippedProfile, LoadsAndRoundTrips) {
  // Given a profile in vectors/drives / When loaded, serialised, parsed / Then equal, no errors
  auto p = find_profile(GetParam(), kDrives);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_EQ(p->name, GetParam());
  EXPECT_TRUE(p->supports("cia402"));
  auto again = parse(to_yaml(*p), std::string(GetParam()) + ".yaml");
  ASSERT_TRUE(again.has_value()) << again.error().to_string();
  EXPECT_EQ(*again, *p);
}

TEST_P(ShippedProfile, DeviationsCiteTheirManual) {
  // Given a manual's profile / When its deviations are read / Then each cites that manual
  auto p = find_profile(GetParam(), kDrives);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  for (const auto& d : p->deviations) {
    ASSERT_FALSE(d.sources.empty()) << d.id;
    EXPECT_NE(d.sources.front().find(p->manual), std::string::npos) << d.id;
    EXPECT_FALSE(p->manual.empty()) << d.id;
  }
}

INSTANTIATE_TEST_SUITE_P(VectorsDrives, ShippedProfile,
                         ::testing::Values("cia402-reference", "festo-cmmp", "kollmorgen-s300-s700",
                                           "irtsa-drive-fb", "esr-triodrive"),
                         [](const ::testing::TestParamInfo<const char*>& param_info) {
                           std::string name;
                           for (const char* c = param_info.param; *c != '\0'; ++c)
                             if (*c != '-') name += *c;
                           return name;
                         });

TEST(ShippedProfiles, MutatedProfilesRoundTripOrFailCleanly) {
  // Given 20 random byte mutations of each shipped profile (fixed seed) / When parsed / Then
  // each is an error, or serialises to YAML that parses back to an equal profile
  std::mt19937 rng(20261121);
  int parsed = 0;
  for (const char* name : {"cia402-reference", "festo-cmmp", "kollmorgen-s300-s700",
                           "irtsa-drive-fb", "esr-triodrive"}) {
    const std::string base = test_support::read_file(kDrives / (std::string(name) + ".yaml"));
    ASSERT_FALSE(base.empty()) << name;
    for (int i = 0; i < 20; ++i) {
      std::string text = base;
      const std::size_t pos = rng() % text.size();
      switch (rng() % 3) {
        case 0:
          text.erase(pos, 1 + rng() % 6);
          break;
        case 1:
          text.insert(pos, 1, static_cast<char>(rng() % 256));
          break;
        default:
          text[pos] = static_cast<char>(rng() % 128);
          break;
      }
      ParseOptions options;
      options.base_dir = kDrives;
      options.check_name = false;
      auto p = parse_profile(text, options);
      if (!p) continue;
      ++parsed;
      auto again = parse_profile(to_yaml(*p), options);
      ASSERT_TRUE(again.has_value()) << again.error().to_string();
      ASSERT_EQ(*again, *p) << "mutation " << i << " of " << name;
    }
  }
  EXPECT_GT(parsed, 8);  // the mutations do not all break the YAML
}

TEST(ShippedProfiles, ReferenceHasNoDeviationsAndEveryOptionCode) {
  // Given the standard profile / When loaded / Then no deviations, CiA 402's option values
  auto p = find_profile("cia402-reference", kDrives);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_TRUE(p->deviations.empty());
  EXPECT_TRUE(p->supports("option.quick-stop.8"));
  EXPECT_TRUE(p->supports("transition.16"));
  EXPECT_TRUE(p->supports("homing.method.37"));
  EXPECT_TRUE(p->manual.empty());
}

TEST(ShippedProfiles, FestoQuickStopFixedNoTransition16) {
  // Given the Festo profile / When loaded / Then 605Ah accepts 2 only, transition 16 is absent
  // and csp is there over EtherCAT only (000 §7.1.2 L5979)
  auto p = find_profile("festo-cmmp", kDrives);
  ASSERT_TRUE(p.has_value()) << p.error().to_string();
  EXPECT_EQ(p->option_codes.at(OptionCode::quick_stop), (std::vector<int>{2}));
  EXPECT_FALSE(p->supports("transition.16"));
  EXPECT_TRUE(p->supports("mode.csp"));
  EXPECT_EQ(p->only_on("mode.csp"), Link::ethercat);
  EXPECT_EQ(p->modes_on(Link::can), (std::vector<int>{1, 3, 4, 6, 7}));
  // The deviation is documented; no vector observes it (transition.16 makes them N/A)
  const auto no16 = std::find_if(p->deviations.begin(), p->deviations.end(),
                                 [](const Deviation& d) { return d.id == "no-transition-16"; });
  ASSERT_NE(no16, p->deviations.end());
  EXPECT_TRUE(no16->vectors.empty());
  EXPECT_EQ(p->effective_personality().hardware_enable, HardwareEnable::transition_2);
}

}  // namespace
}  // namespace drivecheck::profile
