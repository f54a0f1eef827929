// The vector loader (conformance/vector_file.hpp): every error class names file:line, and a
// well-formed vector becomes the typed model.
#include "conformance/vector_file.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <variant>

namespace drivecheck::conformance {
namespace {

// The single error of `yaml`, as "file:line: message".
std::string only_error(const std::string& yaml) {
  const auto set = parse_vectors(yaml, "v.yaml");
  EXPECT_EQ(set.errors.size(), 1U) << [&] {
    std::string all;
    for (const auto& e : set.errors)
      all += e.to_string() + "\n";
    return all;
  }();
  return set.errors.empty() ? std::string() : set.errors.front().to_string();
}

constexpr const char* kHead = R"(- id: cia301/sdo/x
  title: "t"
  source: "CiA 301 §7.2.4"
  level: must
)";

TEST(VectorFile, FullVectorParses) {
  // Given a vector with setup, state, stimuli and expectations
  const std::string yaml = std::string(kHead) + R"(  requires: [sdo.segmented]
  motion: true
  setup: none
  nmt: operational
  timeout: 2s
  steps:
    - send: "600+N#4041600000000000"
    - expect_frame: "580+N#4B416000....0000"
      within: $timing.sdo_response
      mark: answer
    - sdo_read: {index: 0x6041, sub: 0}
      expect: {value: 0x0040, mask: 0x004F}
      save: sw
    - sdo_write: {index: 0x6040, sub: 0, value: $sw, size: 2}
    - measure: {from: answer, to: answer, max: 1ms}
)";
  // When it is parsed
  const auto set = parse_vectors(yaml, "v.yaml");
  // Then every value is in the model, motion implies the feature, lines are kept
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  ASSERT_EQ(set.vectors.size(), 1U);
  const auto& v = set.vectors.front();
  EXPECT_EQ(v.family(), "cia301/sdo");
  EXPECT_EQ(v.requires_features, (std::vector<std::string>{"sdo.segmented", "motion"}));
  EXPECT_EQ(v.setup, Setup::none);
  EXPECT_EQ(v.nmt, cia301::NmtState::operational);
  EXPECT_EQ(v.timeout.value, std::chrono::seconds(2));
  ASSERT_EQ(v.steps.size(), 5U);
  EXPECT_EQ(v.steps[1].line, 12U);
  const auto& expect = std::get<ExpectFrameStep>(v.steps[1].action);
  EXPECT_EQ(expect.within.timing, "sdo_response");
  EXPECT_EQ(expect.mark, "answer");
  // 581#4B41600040020000 matches 580+N#4B416000....0000 for node 1
  EXPECT_TRUE(expect.pattern.matches(*can::parse_candump("581#4B41600040020000"), 1));
  EXPECT_FALSE(expect.pattern.matches(*can::parse_candump("581#4B41600040020001"), 1));
  EXPECT_FALSE(expect.pattern.matches(*can::parse_candump("582#4B41600040020000"), 1));
  EXPECT_EQ(std::get<SdoWriteStep>(v.steps[3].action).value->saved, "sw");
}

TEST(VectorFile, FinallyStepsParseAfterTheSteps) {
  // Given a vector with finally: steps that use a saved value of the steps
  const std::string yaml = std::string(kHead) + R"(  steps:
    - sdo_read: {index: 0x1017, sub: 0}
      save: hb
  finally:
    - sdo_write: {index: 0x1017, sub: 0, value: $hb, size: 2}
    - nmt: pre-operational
)";
  // When parsed; Then the finally steps are in the model with their lines
  const auto set = parse_vectors(yaml, "v.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& v = set.vectors.front();
  ASSERT_EQ(v.finally_steps.size(), 2U);
  EXPECT_EQ(std::get<SdoWriteStep>(v.finally_steps[0].action).value->saved, "hb");
  EXPECT_GT(v.finally_steps[1].line, v.finally_steps[0].line);
}

TEST(VectorFile, EmptyOrBadFinallyIsAnErrorWithItsLine) {
  // Given an empty finally: list and one with an unknown action
  const auto empty =
      parse_vectors(std::string(kHead) + "  steps:\n    - wait: 1ms\n  finally: []\n", "v.yaml");
  const auto bad = parse_vectors(
      std::string(kHead) + "  steps:\n    - wait: 1ms\n  finally:\n    - jump: 1\n", "v.yaml");
  // When parsed; Then both are errors naming file:line
  ASSERT_FALSE(empty.ok());
  EXPECT_NE(empty.errors.front().to_string().find("finally: expected a non-empty list of steps"),
            std::string::npos)
      << empty.errors.front().to_string();
  EXPECT_EQ(empty.errors.front().file, "v.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_GT(bad.errors.front().line, 0);
}

TEST(VectorFile, RepeatUnrollsItsStepsNumberedAsTheFileListsThem) {
  // Given a step, a repeat of two steps three times over, and a step after it
  const std::string yaml = std::string(kHead) + R"(  steps:
    - wait: 1ms
    - repeat:
        times: 3
        steps:
          - send: "77D#05"
          - expect_emcy: {code: 0x8130}
      note: "three losses"
    - wait: 2ms
)";
  // When it is parsed
  const auto set = parse_vectors(yaml, "v.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& steps = set.vectors.front().steps;
  // Then the repeat's steps come three times, numbered 3 and 4 (the repeat is step 2), each
  // with its pass; the step after it is step 5
  ASSERT_EQ(steps.size(), 8U);
  std::vector<std::size_t> numbers;
  for (const auto& step : steps)
    numbers.push_back(step.number);
  EXPECT_EQ(numbers, (std::vector<std::size_t>{1, 3, 4, 3, 4, 3, 4, 5}));
  EXPECT_TRUE(steps[0].repeats.empty());
  ASSERT_EQ(steps[5].repeats.size(), 1U);
  EXPECT_EQ(steps[5].repeats[0].number, 2U);
  EXPECT_EQ(steps[5].repeats[0].iteration, 3U);
  EXPECT_EQ(steps[5].repeats[0].times, 3U);
  EXPECT_EQ(steps[5].repeats[0].note, "three losses");
  EXPECT_EQ(steps[5].repeats[0].line, 7U);
  EXPECT_EQ(steps[5].line, 10U);
  EXPECT_TRUE(std::holds_alternative<SendStep>(steps[5].action));
  EXPECT_EQ(step_place(steps, 6), "step 4 (iteration 3 of 3)");
  EXPECT_EQ(step_place(steps, 7), "step 5");
}

TEST(VectorFile, NestedRepeatUnrollsInsideOut) {
  // Given a repeat of 2 holding a send and a repeat of 3 waits
  const std::string yaml = std::string(kHead) + R"(  steps:
    - repeat:
        times: 2
        steps:
          - send: "080#"
          - repeat: {times: 3, steps: [{wait: 1ms}]}
)";
  // When it is parsed
  const auto set = parse_vectors(yaml, "v.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& steps = set.vectors.front().steps;
  // Then there are 2 x (1 + 3) steps; a wait knows both passes, outermost first
  ASSERT_EQ(steps.size(), 8U);
  EXPECT_EQ(steps[7].number, 4U);
  ASSERT_EQ(steps[7].repeats.size(), 2U);
  EXPECT_EQ(steps[7].repeats[0].iteration, 2U);
  EXPECT_EQ(steps[7].repeats[1].iteration, 3U);
  EXPECT_EQ(step_place(steps, 7), "step 4 (iteration 3 of 3 in iteration 2 of 2)");
}

TEST(VectorFile, MalformedRepeatIsAnErrorWithItsLine) {
  // Given repeats with times 0, times above 1000, no times, no steps, empty steps, unknown
  // keys inside and beside, a non-map, too deep a nesting and too many steps in all
  const auto steps = [](const std::string& body) {
    return std::string(kHead) + "  steps:\n" + body;
  };
  // When each is parsed; Then its single error names the line and what is wrong
  EXPECT_EQ(only_error(steps("    - repeat: {times: 0, steps: [{wait: 1ms}]}\n")),
            "v.yaml:6: repeat: times: 0 is out of range 1..1000");
  EXPECT_EQ(only_error(steps("    - repeat: {times: 1001, steps: [{wait: 1ms}]}\n")),
            "v.yaml:6: repeat: times: 1001 is out of range 1..1000");
  EXPECT_EQ(only_error(steps("    - repeat: {steps: [{wait: 1ms}]}\n")),
            "v.yaml:6: repeat: 'times:' is required (1..1000)");
  EXPECT_EQ(only_error(steps("    - repeat: {times: 2}\n")),
            "v.yaml:6: repeat: 'steps:' is required (a non-empty list of steps)");
  EXPECT_EQ(only_error(steps("    - repeat: {times: 2, steps: []}\n")),
            "v.yaml:6: repeat: steps: expected a non-empty list of steps");
  EXPECT_EQ(
      only_error(steps("    - repeat: {times: 2, step: [{wait: 1ms}], steps: [{wait: 1ms}]}\n")),
      "v.yaml:6: repeat: unknown key 'step' (allowed: times, steps)");
  EXPECT_EQ(only_error(steps("    - repeat: {times: 2, steps: [{wait: 1ms}]}\n      within: 1s\n")),
            "v.yaml:7: repeat: unknown key 'within' (allowed: repeat, note)");
  EXPECT_EQ(only_error(steps("    - repeat: 3\n")),
            "v.yaml:6: repeat: expected a map {times: N, steps: [...]}");
  EXPECT_EQ(only_error(steps("    - repeat:\n        times: 2\n        steps:\n"
                             "          - repeat:\n              times: 2\n              steps:\n"
                             "                - repeat: {times: 2, steps: [{wait: 1ms}]}\n")),
            "v.yaml:12: repeat: nested too deep (at most 2 repeats inside each other)");
  EXPECT_EQ(only_error(steps("    - repeat:\n        times: 1000\n        steps:\n"
                             "          - repeat: {times: 11, steps: [{wait: 1ms}]}\n")),
            "v.yaml:6: repeat: 1000 x 11 steps make more than 10000 steps in this list");
  // A bad step inside names its own line
  EXPECT_EQ(only_error(steps("    - repeat:\n        times: 2\n        steps:\n"
                             "          - wait: 1 ms\n"))
                .substr(0, 10),
            "v.yaml:9: ");
}

TEST(VectorFile, UnknownVectorKeyNamesLine) {
  // Given a typo in a vector key; When parsed; Then file:line and the allowed keys
  const auto error = only_error(std::string(kHead) + "  stpes: []\n  steps: [{wait: 1ms}]\n");
  EXPECT_NE(error.find("v.yaml:5: unknown vector key 'stpes'"), std::string::npos) << error;
}

TEST(VectorFile, UnlessTakesProfileFeatures) {
  // Given `unless: [pdo.dummy-mapping]`; When parsed; Then the vector keeps the feature
  const auto set = parse_vectors(std::string(kHead) +
                                     "  requires: [pdo]\n  unless: [pdo.dummy-mapping]\n"
                                     "  steps: [{wait: 1ms}]\n",
                                 "v.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  EXPECT_EQ(set.vectors.at(0).unless_features, std::vector<std::string>{"pdo.dummy-mapping"});
}

TEST(VectorFile, UnlessRefusesObjectNeedsUnknownAndRequiredFeatures) {
  // Given unless: with an object need, an unknown feature, and a feature requires: lists
  // When parsed
  // Then each is an error at the unless: line
  auto error = only_error(std::string(kHead) + "  unless: [object.1029]\n  steps: [{wait: 1ms}]\n");
  EXPECT_NE(error.find("v.yaml:5: unless: 'object.1029' is not a profile feature"),
            std::string::npos)
      << error;
  error = only_error(std::string(kHead) + "  unless: [pdo.dumy]\n  steps: [{wait: 1ms}]\n");
  EXPECT_NE(error.find("v.yaml:5: unless: 'pdo.dumy' is not a profile feature"), std::string::npos)
      << error;
  error = only_error(std::string(kHead) +
                     "  requires: [pdo]\n  unless: [pdo]\n  steps: [{wait: 1ms}]\n");
  EXPECT_NE(error.find("v.yaml:6: unless: 'pdo' is also in requires:"), std::string::npos) << error;
}

TEST(VectorFile, UnknownStepModifierIsAnError) {
  // Given `withn:` on an expectation; When parsed; Then the step's line and the allowed keys
  const auto error =
      only_error(std::string(kHead) + "  steps:\n    - expect_bootup: {}\n      withn: 1s\n");
  EXPECT_NE(error.find("v.yaml:7: expect_bootup: unknown key 'withn'"), std::string::npos) << error;
}

TEST(VectorFile, PollTakesARangeOfSignedValues) {
  // Given a poll of 6064h into [-10, $p+10] as signed, after a read saved as p
  const auto set = parse_vectors(std::string(kHead) + R"(  steps:
    - sdo_read: {index: 0x6064, sub: 0}
      save: p
    - poll: {index: 0x6064, sub: 0, range: [-10, "$p+10"]}
      signed: true
      within: 1s
)",
                                 "v.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  // When loaded; Then the step holds both bounds and reads signed
  const auto& poll = std::get<PollStep>(set.vectors.at(0).steps.at(1).action);
  ASSERT_TRUE(poll.range.has_value());
  EXPECT_EQ(poll.range->first.literal, -10);
  EXPECT_EQ(poll.range->second.saved, "p");
  EXPECT_EQ(poll.range->second.offset, 10);
  EXPECT_TRUE(poll.is_signed);
}

TEST(VectorFile, PollRangeErrorsNameTheirLine) {
  // Given a range with a value, a range upside down, one bound, and signed without a range
  // When each is parsed; Then one error each, at the step's line
  EXPECT_EQ(only_error(std::string(kHead) +
                       "  steps:\n    - poll: {index: 0x6064, sub: 0, value: 1, range: [0, 1]}\n"
                       "      within: 1s\n"),
            "v.yaml:6: poll: give either 'range' or 'value' (with 'mask'), not both");
  EXPECT_EQ(only_error(std::string(kHead) +
                       "  steps:\n    - poll: {index: 0x6064, sub: 0, range: [5, -5]}\n"
                       "      within: 1s\n"),
            "v.yaml:6: poll: range: low is above high");
  EXPECT_EQ(
      only_error(std::string(kHead) + "  steps:\n    - poll: {index: 0x6064, sub: 0, range: [5]}\n"
                                      "      within: 1s\n"),
      "v.yaml:6: poll: range: expected [low, high]");
  EXPECT_EQ(
      only_error(std::string(kHead) + "  steps:\n    - poll: {index: 0x6064, sub: 0, value: 5}\n"
                                      "      signed: true\n      within: 1s\n"),
      "v.yaml:7: poll: 'signed' goes with 'range'");
}

TEST(VectorFile, AbortNamesASetOrAListWithItsClause) {
  // Given an abort expectation by set name, one by literal list with clause, and a raw abort
  // frame judged by a set with an alternative frame
  const auto set = parse_vectors(std::string(kHead) + R"(  steps:
    - sdo_write: {index: 0x1000, sub: 0, value: 0, size: 4}
      expect: {abort: write-read-only}
    - sdo_read: {index: 0x1003, sub: 9}
      expect: {abort: [0x06090030], clause: "CiA 301 §7.5.2.4"}
    - expect_frame: "580+N#80171000........"
      abort: any
      or: ["580+N#A200............"]
)",
                                 "v.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  // When loaded; Then the set's codes and citation, the list with its clause, the frame's set
  const auto& steps = set.vectors.at(0).steps;
  const auto& write = std::get<SdoWriteStep>(steps.at(0).action).expect.abort;
  EXPECT_EQ(write.set, "write-read-only");
  EXPECT_EQ(write.codes, (std::vector<std::uint32_t>{0x06010000, 0x06010002, 0x08000000}));
  EXPECT_EQ(write.describe(),
            "abort in write-read-only {06010000h, 06010002h, 08000000h} (CTT 2.3, 4.3; CiA 301 "
            "§7.2.4.3.17)");
  const auto& read = std::get<SdoReadStep>(steps.at(1).action).expect.abort;
  EXPECT_TRUE(read.set.empty());
  EXPECT_EQ(read.clause, "CiA 301 §7.5.2.4");
  EXPECT_EQ(read.describe(), "abort in {06090030h} (CiA 301 §7.5.2.4)");
  const auto& frame = std::get<ExpectFrameStep>(steps.at(2).action);
  ASSERT_TRUE(frame.abort);
  EXPECT_TRUE(frame.abort->any());
  EXPECT_TRUE(frame.abort->accepts(0x12345678));
  ASSERT_EQ(frame.alternatives.size(), 1U);
  EXPECT_EQ(frame.alternatives[0].text, "580+N#A200............");
}

TEST(VectorFile, UnknownAbortSetNamesLineAndTheSets) {
  // Given a misspelt set name; When parsed; Then its line, the name and the known sets
  const auto error = only_error(std::string(kHead) +
                                "  steps:\n    - sdo_read: {index: 0x1000, sub: 1}\n"
                                "      expect: {abort: sub-index-missing}\n");
  EXPECT_NE(error.find("v.yaml:7: abort: unknown abort set 'sub-index-missing' (sets: "),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("sub-index-does-not-exist"), std::string::npos) << error;
}

TEST(VectorFile, FrameAbortNeedsTheCodeAsDontCare) {
  // Given abort: beside an SDO abort pattern with a fixed code; When parsed; Then an error
  const auto error = only_error(std::string(kHead) +
                                "  steps:\n    - expect_frame: \"580+N#8017100000000305\"\n"
                                "      abort: toggle\n");
  EXPECT_NE(error.find("v.yaml:6: expect_frame: with abort: the pattern must be an SDO abort"),
            std::string::npos)
      << error;
}

TEST(VectorFile, StepWithTwoActionsIsAnError) {
  // Given a step with send and wait; When parsed; Then an error at the second action
  const auto error =
      only_error(std::string(kHead) + "  steps:\n    - send: \"000#0101\"\n      wait: 1ms\n");
  EXPECT_NE(error.find("v.yaml:7: step has two actions: 'send' and 'wait'"), std::string::npos)
      << error;
}

TEST(VectorFile, MarkIsAModifierNextToAnAction) {
  // Given `mark:` beside expect_bootup and a measure using it; When parsed; Then no error
  const auto set = parse_vectors(std::string(kHead) +
                                     "  steps:\n    - expect_bootup: {}\n      mark: b\n    - "
                                     "mark: t\n    - measure: {from: b, to: t, max: 1s}\n",
                                 "v.yaml");
  EXPECT_TRUE(set.ok()) << set.errors.front().to_string();
}

TEST(VectorFile, StepWithoutActionIsAnError) {
  // Given a step of modifiers only; When parsed; Then "step has no action" at its line
  const auto error = only_error(std::string(kHead) + "  steps:\n    - within: 1s\n");
  EXPECT_NE(error.find("v.yaml:6: step has no action"), std::string::npos) << error;
}

TEST(VectorFile, BadDurationAndUnknownTiming) {
  // Given a duration without unit and an unknown timing name; When parsed; Then one error each
  auto error = only_error(std::string(kHead) + "  steps:\n    - wait: 100\n");
  EXPECT_NE(error.find("v.yaml:6: wait:"), std::string::npos) << error;
  error = only_error(std::string(kHead) + "  steps:\n    - wait: $timing.nope\n");
  EXPECT_NE(error.find("unknown timing name 'nope'"), std::string::npos) << error;
}

TEST(VectorFile, BusOffStepTakesAPositiveDuration) {
  // Given a bus_off step of 50 ms, and one of 0 ms
  const auto set = parse_vectors(std::string(kHead) + "  steps:\n    - bus_off: 50ms\n", "v.yaml");
  // When parsed; Then the first is a BusOffStep, the second an error at its line
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& step = set.vectors.front().steps.front();
  ASSERT_TRUE(std::holds_alternative<BusOffStep>(step.action));
  EXPECT_EQ(std::get<BusOffStep>(step.action).duration.value, std::chrono::milliseconds(50));
  EXPECT_EQ(action_name(step.action), "bus_off");
  EXPECT_TRUE(set.vectors.front().has_bus_off_step());
  const auto error = only_error(std::string(kHead) + "  steps:\n    - bus_off: 0ms\n");
  EXPECT_NE(error.find("v.yaml:6: bus_off: the duration must be above 0"), std::string::npos)
      << error;
}

TEST(VectorFile, SendRefusesPatterns) {
  // Given `..` in a frame to send; When parsed; Then an error naming the frame
  const auto error = only_error(std::string(kHead) + "  steps:\n    - send: \"600+N#40..\"\n");
  EXPECT_NE(error.find("v.yaml:6: send: '600+N#40..'"), std::string::npos) << error;
}

TEST(VectorFile, BadCobIdAndTooManyBytes) {
  // Given a 4-digit COB-ID and a 9-byte frame; When parsed; Then errors with their lines
  auto error = only_error(std::string(kHead) +
                          "  steps:\n    - expect_silence: [\"1800\"]\n      for: 1s\n");
  EXPECT_NE(error.find("v.yaml:6:"), std::string::npos) << error;
  EXPECT_NE(error.find("is not a COB-ID"), std::string::npos) << error;
  error = only_error(std::string(kHead) + "  steps:\n    - send: \"601#000000000000000000\"\n");
  EXPECT_NE(error.find("9 data bytes"), std::string::npos) << error;
  error = only_error(std::string(kHead) + "  steps:\n    - send: \"7FF+N#00\"\n");
  EXPECT_NE(error.find("out of range"), std::string::npos) << error;
}

TEST(VectorFile, UnknownFeatureIsAnError) {
  // Given requires: [sdo.segmentd]; When parsed; Then the feature is named
  const auto error =
      only_error(std::string(kHead) + "  requires: [sdo.segmentd]\n  steps: [{wait: 1ms}]\n");
  EXPECT_NE(error.find("v.yaml:5: requires: unknown feature 'sdo.segmentd'"), std::string::npos)
      << error;
}

TEST(VectorFile, BadSourceIsAnError) {
  // Given a manual source without line range and one with a reversed range
  auto error = only_error(
      "- id: a/b\n  title: t\n  source: \"000_33c1d912b8b6010a.txt §3.2\"\n  steps: [{wait: "
      "1ms}]\n");
  EXPECT_NE(error.find("v.yaml:3: source"), std::string::npos) << error;
  EXPECT_NE(error.find("line range"), std::string::npos) << error;
  error = only_error(
      "- id: a/b\n  title: t\n  source: \"000_33c1d912b8b6010a.txt §3.2 L20-10\"\n  steps: [{wait: "
      "1ms}]\n");
  EXPECT_NE(error.find("runs backwards"), std::string::npos) << error;
}

TEST(VectorFile, UnknownMarkAndSavedValue) {
  // Given a measure from a mark never set, and $x never saved; When parsed; Then both named
  const auto marks = parse_vectors(
      std::string(kHead) + "  steps:\n    - measure: {from: a, to: a, max: 1s}\n", "v.yaml");
  ASSERT_EQ(marks.errors.size(), 2U);
  EXPECT_EQ(marks.errors[0].to_string(),
            "v.yaml:6: from: unknown mark 'a' (marks must be set by an earlier step)");
  const auto set =
      parse_vectors(std::string(kHead) +
                        "  steps:\n    - sdo_write: {index: 0x6040, sub: 0, value: $x, size: 2}\n",
                    "v.yaml");
  ASSERT_EQ(set.errors.size(), 1U);
  EXPECT_NE(set.errors[0].to_string().find("v.yaml:6: value: '$x' names no value saved"),
            std::string::npos);
}

TEST(VectorFile, SavedValuePlusOrMinusALiteral) {
  // Given a saved value used as $p+k, $p-k in a value and in both range bounds, and a name
  // saved whole that ends in -<digits>
  const auto set =
      parse_vectors(std::string(kHead) +
                        "  steps:\n"
                        "    - sdo_read: {index: 0x6063, sub: 0}\n"
                        "      save: p\n"
                        "    - sdo_read: {index: 0x6064, sub: 0}\n"
                        "      save: q-2\n"
                        "    - sdo_read: {index: 0x6063, sub: 0}\n"
                        "      expect: {range: [\"$p+392\", \"$p+0x198\"]}\n"
                        "    - sdo_write: {index: 0x607A, sub: 0, value: $p-5, size: 4}\n"
                        "    - sdo_write: {index: 0x607A, sub: 0, value: $q-2, size: 4}\n"
                        "    - sdo_write: {index: 0x607A, sub: 0, value: $q-2-1, size: 4}\n",
                    "v.yaml");
  // When parsed
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& steps = set.vectors.at(0).steps;
  // Then the bounds and values carry the name and the offset
  const auto& range = std::get<SdoReadStep>(steps.at(2).action).expect;
  EXPECT_EQ(range.kind, SdoExpect::Kind::range);
  EXPECT_EQ(range.low, (ValueSpec{0, "p", 392}));
  EXPECT_EQ(range.high, (ValueSpec{0, "p", 0x198}));
  EXPECT_EQ(*std::get<SdoWriteStep>(steps.at(3).action).value, (ValueSpec{0, "p", -5}));
  // And a name saved whole wins over the split; a further -k applies to it
  EXPECT_EQ(*std::get<SdoWriteStep>(steps.at(4).action).value, (ValueSpec{0, "q-2", 0}));
  EXPECT_EQ(*std::get<SdoWriteStep>(steps.at(5).action).value, (ValueSpec{0, "q-2", -1}));
  // And a k that is not an integer, an unsaved name and literal bounds the wrong way round are
  // errors naming the line
  EXPECT_NE(only_error(std::string(kHead) +
                       "  steps:\n    - sdo_read: {index: 0x6063, sub: 0}\n      save: p\n"
                       "    - sdo_write: {index: 0x607A, sub: 0, value: $p+x, size: 4}\n")
                .find("v.yaml:8: value: '$p+x': expected $name+k or $name-k"),
            std::string::npos);
  EXPECT_NE(only_error(std::string(kHead) + "  steps:\n    - sdo_read: {index: 0x6063, sub: 0}\n"
                                            "      expect: {range: [\"$r+1\", 5]}\n")
                .find("v.yaml:7: range low: '$r+1' names no value saved"),
            std::string::npos);
  EXPECT_NE(only_error(std::string(kHead) +
                       "  steps:\n    - sdo_read: {index: 0x6063, sub: 0}\n      save: p\n"
                       "    - sdo_read: {index: 0x6063, sub: 0}\n"
                       "      expect: {range: [\"$p+5\", \"$p-5\"]}\n")
                .find("range: low is above high"),
            std::string::npos);
}

TEST(VectorFile, SavedValueScaledByALiteralRatio) {
  // Given a saved speed used as $v*3, $v*5/2+1 and $v/4 (a bound on a measured ratio)
  const auto set =
      parse_vectors(std::string(kHead) +
                        "  steps:\n"
                        "    - sdo_read: {index: 0x606C, sub: 0}\n"
                        "      save: v\n"
                        "    - sdo_read: {index: 0x606C, sub: 0}\n"
                        "      expect: {range: [\"$v*3\", \"$v*5/2+1\"]}\n"
                        "    - sdo_write: {index: 0x60FF, sub: 0, value: $v/4, size: 4}\n",
                    "v.yaml");
  // When parsed
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& steps = set.vectors.at(0).steps;
  // Then each carries the name, the multiplier, the divisor and the offset
  const auto& range = std::get<SdoReadStep>(steps.at(1).action).expect;
  EXPECT_EQ(range.low, (ValueSpec{0, "v", 0, 3, 1}));
  EXPECT_EQ(range.high, (ValueSpec{0, "v", 1, 5, 2}));
  EXPECT_EQ(*std::get<SdoWriteStep>(steps.at(2).action).value, (ValueSpec{0, "v", 0, 1, 4}));
  EXPECT_EQ(to_text(range.high), "$v*5/2+1");
  // And a zero, negative or non-integer factor, or the divisor first, is an error naming the line
  for (const char* bad : {"$v*0", "$v/-2", "$v*x", "$v/2*3"}) {
    EXPECT_NE(
        only_error(std::string(kHead) +
                   "  steps:\n    - sdo_read: {index: 0x606C, sub: 0}\n      save: v\n" +
                   "    - sdo_write: {index: 0x60FF, sub: 0, value: \"" + bad + "\", size: 4}\n")
            .find("v.yaml:8: value: '" + std::string(bad) + "': expected $name*m/d+k"),
        std::string::npos)
        << bad;
  }
}

TEST(VectorFile, ReadRelativeToASavedValue) {
  // Given a position saved, then read relative to it (the distance moved), saved in turn
  const auto set = parse_vectors(std::string(kHead) +
                                     "  steps:\n"
                                     "    - sdo_read: {index: 0x6064, sub: 0}\n"
                                     "      signed: true\n      save: start\n"
                                     "    - sdo_read: {index: 0x6064, sub: 0}\n"
                                     "      signed: true\n      relative_to: start\n"
                                     "      expect: {range: [10, 1000]}\n      save: moved\n",
                                 "v.yaml");
  // When parsed
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  // Then the read names the value it is relative to, and the difference may be saved
  const auto& read = std::get<SdoReadStep>(set.vectors.at(0).steps.at(1).action);
  EXPECT_EQ(read.relative_to, "start");
  EXPECT_EQ(read.save, "moved");
  // And an unknown name, an unsigned read or a bit mask is an error naming the line
  const std::string saved =
      std::string(kHead) +
      "  steps:\n    - sdo_read: {index: 0x6064, sub: 0}\n      signed: true\n      save: p\n";
  EXPECT_NE(only_error(saved + "    - sdo_read: {index: 0x6064, sub: 0}\n      signed: true\n"
                               "      relative_to: q\n")
                .find("v.yaml:11: relative_to: 'q' names no value saved earlier"),
            std::string::npos);
  EXPECT_NE(only_error(saved + "    - sdo_read: {index: 0x6064, sub: 0}\n      relative_to: p\n")
                .find("v.yaml:10: relative_to: needs signed: true"),
            std::string::npos);
  EXPECT_NE(only_error(saved + "    - sdo_read: {index: 0x6064, sub: 0}\n      signed: true\n"
                               "      relative_to: p\n      expect: {value: 4, mask: 0xF}\n")
                .find("relative_to: goes with expect: {value: X} or {range: [lo, hi]}"),
            std::string::npos);
}

TEST(VectorFile, DeviceValuesOkOrAbortAndSilencePatterns) {
  // Given $dut values, ok-or-abort and a frame pattern in expect_silence
  const auto set = parse_vectors(
      std::string(kHead) +
          "  steps:\n"
          "    - sdo_write: {index: 0x1A00, sub: 1, value: $dut.tpdo_object, size: 4}\n"
          "      expect: ok-or-abort\n"
          "    - sdo_read: {index: 0x6060, sub: 0}\n"
          "      expect: {value: $dut.unsupported_mode}\n"
          "    - expect_silence: [\"1A0#..*\", \"080\"]\n"
          "      for: 10ms\n",
      "v.yaml");
  // When parsed / Then they load as device values, the kind and a pattern beside a COB-ID
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& steps = set.vectors.at(0).steps;
  const auto& write = std::get<SdoWriteStep>(steps.at(0).action);
  EXPECT_EQ(write.value->saved, "dut.tpdo_object");
  EXPECT_EQ(write.expect.kind, SdoExpect::Kind::ok_or_abort);
  EXPECT_EQ(std::get<SdoReadStep>(steps.at(1).action).expect.value.saved, "dut.unsupported_mode");
  const auto& silence = std::get<ExpectSilenceStep>(steps.at(2).action);
  EXPECT_EQ(silence.patterns.size(), 1U);
  EXPECT_EQ(silence.cob_ids.size(), 1U);
  // And an unknown $dut value or expect keyword is an error naming the line
  EXPECT_NE(only_error(std::string(kHead) +
                       "  steps:\n    - sdo_write: {index: 0x6060, sub: 0, value: $dut.nope, "
                       "size: 1}\n")
                .find("v.yaml:6: value: '$dut.nope' names no value saved"),
            std::string::npos);
  EXPECT_NE(only_error(std::string(kHead) +
                       "  steps:\n    - sdo_write: {index: 0x6060, sub: 0, value: 1, size: 1}\n"
                       "      expect: maybe\n")
                .find("'ok-or-abort'"),
            std::string::npos);
}

TEST(VectorFile, MissingRequiredKeys) {
  // Given a vector without title and steps; When parsed; Then one error per key at its line
  const auto set = parse_vectors("- id: a/b\n  source: \"CiA 301 §1\"\n", "v.yaml");
  ASSERT_EQ(set.errors.size(), 2U);
  EXPECT_EQ(set.errors[0].to_string(), "v.yaml:1: vector a/b: 'title' is missing");
  EXPECT_EQ(set.errors[1].to_string(), "v.yaml:1: vector a/b: 'steps' is missing");
}

TEST(VectorFile, EthercatStepsParse) {
  // Given a vector with every EtherCAT-only step
  const std::string yaml = std::string(kHead) + R"(  transports: [ethercat]
  steps:
    - al_request: op
      expect: {state: init, error: true, code: [invalid-requested-state-change, unspecified_error]}
    - expect_al: {state: safeop, error: true, code: sync-manager-watchdog}
      within: 1s
      clause: "CiA 301 §7.2.4"
    - process_data: {cycles: 10}
    - pause_process_data: watchdog
    - mailbox_repeat: {index: 0x6083, sub: 0, size: 4, value: 1000, repeat: 2000}
    - power_cycle: {}
)";
  // When it is parsed
  const auto set = parse_vectors(yaml, "v.yaml");
  // Then the AL codes are the table's values and the vector names its first EtherCAT step
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& v = set.vectors.front();
  const auto& request = std::get<AlRequestStep>(v.steps[0].action);
  EXPECT_EQ(request.state, 8);
  EXPECT_EQ(request.expect.state, 1);
  EXPECT_EQ(request.expect.codes, (std::vector<std::uint16_t>{0x0011, 0x0001}));
  EXPECT_EQ(std::get<ExpectAlStep>(v.steps[1].action).expect.codes,
            (std::vector<std::uint16_t>{0x001B}));
  EXPECT_EQ(std::get<ProcessDataStep>(v.steps[2].action).cycles, 10U);
  EXPECT_FALSE(std::get<PauseProcessDataStep>(v.steps[3].action).duration);
  EXPECT_EQ(std::get<MailboxRepeatStep>(v.steps[4].action).repeat, 2000);
  EXPECT_TRUE(std::holds_alternative<PowerCycleStep>(v.steps[5].action));
  EXPECT_EQ(v.ethercat_only_step(), "steps: step 1 (al_request)");
}

TEST(VectorFile, EthercatStepErrorsNameTheLine) {
  // Given EtherCAT steps with an unknown state, an unknown code, a refusal without codes, a
  // code without the error indication and a repeat equal to the first value
  // When each is parsed
  // Then each is one error at the step's line
  const std::string steps = std::string(kHead) + "  steps:\n";
  EXPECT_EQ(only_error(steps + "    - al_request: operational\n"),
            "v.yaml:6: al_request: 'operational' is not an AL state (init, preop, safeop, op, "
            "boot)");
  EXPECT_EQ(only_error(steps + "    - expect_al: {state: init, error: true, code: nope}\n"),
            "v.yaml:6: expect_al: 'nope' is no AL status code of "
            "protocol/ethercat/al_status_codes.inc");
  EXPECT_EQ(only_error(steps + "    - expect_al: {state: init, error: true}\n"),
            "v.yaml:6: expect_al: 'error: true' needs 'code:' (the accepted AL status codes)");
  EXPECT_EQ(only_error(steps + "    - expect_al: {state: op, code: no-memory}\n"),
            "v.yaml:6: expect_al: 'code' goes with 'error: true'");
  EXPECT_EQ(only_error(steps + "    - mailbox_repeat: {index: 0x6083, sub: 0, size: 2, value: 7, "
                               "repeat: 7}\n"),
            "v.yaml:6: mailbox_repeat: 'repeat' must differ from 'value' (else a second "
            "execution could not be seen)");
  EXPECT_EQ(only_error(steps + "    - pause_process_data: 11s\n"),
            "v.yaml:6: pause_process_data: 'watchdog', or a duration above 0 and at most 10s");
  EXPECT_EQ(only_error(steps + "    - power_cycle: now\n"),
            "v.yaml:6: power_cycle: the value is {} (nothing to give)");
}

TEST(VectorFile, ExpectEmcyTakesAnyErrorCode) {
  // Given expect_emcy with `code: error` / When parsed / Then it accepts every code but 0000h
  const std::string yaml = std::string(kHead) + R"(  steps:
    - expect_emcy: {code: error, register: {mask: 0x01, value: 0x01}}
)";
  const auto set = parse_vectors(yaml, "v.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& e = std::get<ExpectEmcyStep>(set.vectors.front().steps[0].action);
  EXPECT_TRUE(e.any_error);
  EXPECT_TRUE(e.accepts(0x8130));
  EXPECT_TRUE(e.accepts(0xFF00));
  EXPECT_FALSE(e.accepts(0x0000));
}

TEST(VectorFile, CyclicStepTakesCyclesPeriodAndSetPoints) {
  // Given a cyclic step with two set-points, one of them a saved value
  const auto set = parse_vectors(std::string(kHead) +
                                     "  steps:\n"
                                     "    - sdo_read: {index: 0x6064, sub: 0}\n"
                                     "      save: p\n"
                                     "    - cyclic: {cycles: 5, period: 10ms}\n"
                                     "      set:\n"
                                     "        - {index: 0x607A, sub: 0, value: $p+10, size: 4}\n"
                                     "        - {index: 0x60B2, sub: 0, value: -100, size: 2}\n",
                                 "v.yaml");
  // When it is parsed
  // Then the step holds them, and the vector lists them as its set-points
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& v = set.vectors.front();
  const auto& cyclic = std::get<CyclicStep>(v.steps[1].action);
  EXPECT_EQ(cyclic.cycles, 5U);
  EXPECT_EQ(cyclic.period.value, std::chrono::milliseconds(10));
  ASSERT_EQ(cyclic.set.size(), 2U);
  EXPECT_EQ(cyclic.set[0].value.saved, "p");
  EXPECT_EQ(cyclic.set[0].value.offset, 10);
  EXPECT_EQ(cyclic.set[1].size, 2U);
  EXPECT_TRUE(v.has_cyclic_step());
  EXPECT_EQ(v.cyclic_set_points().size(), 2U);
  EXPECT_TRUE(v.ethercat_only_step().empty());
}

TEST(VectorFile, CyclicStepErrorsNameTheLine) {
  // Given cyclic steps without a period, with a period past 50 ms, with a set-point twice and
  // with a set-point without its size
  // When each is parsed
  // Then each is one error at the step's line
  const std::string steps = std::string(kHead) + "  steps:\n";
  EXPECT_EQ(only_error(steps + "    - cyclic: {cycles: 5}\n"),
            "v.yaml:6: cyclic: 'cycles' and 'period' are required");
  EXPECT_EQ(only_error(steps + "    - cyclic: {cycles: 5, period: 100ms}\n"),
            "v.yaml:6: cyclic: 'period' above 0 and at most 50ms");
  EXPECT_EQ(only_error(steps + "    - cyclic: {cycles: 1, period: 10ms}\n"
                               "      set:\n"
                               "        - {index: 0x607A, sub: 0, value: 1, size: 4}\n"
                               "        - {index: 0x607A, sub: 0, value: 2, size: 4}\n"),
            "v.yaml:9: cyclic set: 607Ah sub 0 twice");
  EXPECT_EQ(only_error(steps + "    - cyclic: {cycles: 1, period: 10ms}\n"
                               "      set: {index: 0x607A, sub: 0, value: 1}\n"),
            "v.yaml:7: cyclic set: 'value' and 'size' are required");
}

TEST(VectorFile, ValueMustFitItsSize) {
  // Given 0x1FF in one byte; When parsed; Then an error
  const auto error =
      only_error(std::string(kHead) +
                 "  steps:\n    - sdo_write: {index: 0x6060, sub: 0, value: 0x1FF, size: 1}\n");
  EXPECT_NE(error.find("does not fit in 1 byte"), std::string::npos) << error;
}

TEST(VectorFile, RefusedMeansNotApplicableTakesASetOnAPlainWrite) {
  // Given an sdo_write with refused_means_not_applicable and clause:
  const std::string steps = std::string(kHead) + "  steps:\n";
  const auto set = parse_vectors(steps +
                                     "    - sdo_write: {index: 0x6088, sub: 0, value: 1, size: 2}\n"
                                     "      refused_means_not_applicable: value-range\n"
                                     "      clause: \"CiA 402-2 §6088h\"\n",
                                 "v.yaml");
  // When parsed / Then the step holds the set (its codes from the table) and the clause
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto& write = std::get<SdoWriteStep>(set.vectors.at(0).steps.at(0).action);
  ASSERT_TRUE(write.refused_means_not_applicable);
  EXPECT_EQ(write.refused_means_not_applicable->set, "value-range");
  EXPECT_TRUE(write.refused_means_not_applicable->accepts(0x06090030));
  EXPECT_FALSE(write.refused_means_not_applicable->accepts(0x06010002));
  EXPECT_EQ(write.refused_means_not_applicable->clause, "CiA 402-2 §6088h");
  // And an unknown set, `any`, an expected abort beside it and a clause without it are errors
  const std::string write6088 = "    - sdo_write: {index: 0x6088, sub: 0, value: 1, size: 2}\n";
  EXPECT_NE(only_error(steps + write6088 + "      refused_means_not_applicable: nope\n")
                .find("v.yaml:7: refused_means_not_applicable: unknown abort set 'nope'"),
            std::string::npos);
  EXPECT_NE(only_error(steps + write6088 + "      refused_means_not_applicable: any\n")
                .find("v.yaml:7: refused_means_not_applicable: 'any' would make every refusal"),
            std::string::npos);
  EXPECT_NE(only_error(steps + write6088 +
                       "      expect: {abort: value-range}\n"
                       "      refused_means_not_applicable: value-range\n")
                .find("v.yaml:8: refused_means_not_applicable: goes with expect: ok"),
            std::string::npos);
  EXPECT_NE(only_error(steps + write6088 + "      clause: \"CiA 402-2 §6088h\"\n")
                .find("v.yaml:7: sdo_write: 'clause' goes with 'refused_means_not_applicable'"),
            std::string::npos);
}

TEST(VectorFile, InvalidLevelAndId) {
  // Given level "must!" and an upper-case id; When parsed; Then both are errors with lines
  const auto set = parse_vectors(
      "- id: CiA/X\n  title: t\n  source: \"CiA 301 §1\"\n  level: must!\n  steps: [{wait: 1ms}]\n",
      "v.yaml");
  ASSERT_EQ(set.errors.size(), 2U);
  EXPECT_EQ(set.errors[0].line, 1);
  EXPECT_EQ(set.errors[1].line, 4);
}

TEST(VectorFile, YamlSyntaxErrorHasLine) {
  // Given broken YAML; When parsed; Then the parser's line
  const auto set = parse_vectors("- id: a/b\n  title: [unclosed\n", "v.yaml");
  ASSERT_FALSE(set.ok());
  EXPECT_GT(set.errors[0].line, 0);
  EXPECT_EQ(set.errors[0].file, "v.yaml");
}

TEST(VectorFile, TopLevelMustBeASequence) {
  // Given a map at the top; When parsed; Then an error at line 1
  const auto error = only_error("id: a/b\n");
  EXPECT_NE(error.find("v.yaml:1: a vector file is a YAML sequence"), std::string::npos) << error;
}

TEST(VectorTree, DuplicateIdsAcrossFilesAndSkippedDirectories) {
  // Given two files with the same id, a drives/ profile, manuals.yaml and coverage.yaml
  const auto dir =
      std::filesystem::temp_directory_path() / "drivecheck_vector_tree_test" / "vectors";
  std::filesystem::remove_all(dir.parent_path());
  std::filesystem::create_directories(dir / "drives");
  std::filesystem::create_directories(dir / "cia301");
  const std::string vector =
      "- id: a/b\n  title: t\n  source: \"CiA 301 §1\"\n  steps: [{wait: 1ms}]\n";
  std::ofstream(dir / "cia301" / "one.yaml") << vector;
  std::ofstream(dir / "two.yaml") << vector;
  std::ofstream(dir / "drives" / "x.yaml") << "name: x\n";
  std::ofstream(dir / "manuals.yaml") << "- file: x\n";
  std::ofstream(dir / "coverage.yaml") << "m.txt:\n  \"1\": {kind: descriptive, why: w}\n";
  // When the tree is loaded
  const auto set = load_vector_tree(dir);
  // Then the second copy is an error naming the first, and drives/, manuals.yaml and
  // coverage.yaml (scripts/generate-coverage's explanations) are skipped
  ASSERT_EQ(set.errors.size(), 1U);
  EXPECT_EQ(set.errors[0].to_string(),
            "vectors/two.yaml:1: duplicate id 'a/b' (first at vectors/cia301/one.yaml:1)");
  EXPECT_EQ(set.vectors.size(), 1U);
  EXPECT_EQ(set.files.size(), 2U);
  std::filesystem::remove_all(dir.parent_path());
}

}  // namespace
}  // namespace drivecheck::conformance
