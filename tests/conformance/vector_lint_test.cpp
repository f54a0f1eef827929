// The linter's manual checks (conformance/vector_lint.hpp): citations against manuals.yaml,
// the manuals' sha256, and the SHA-256 itself.
#include "conformance/vector_lint.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "conformance/sha256.hpp"
#include "conformance/vector_file.hpp"

namespace drivecheck::conformance {
namespace {

TEST(Sha256, KnownDigests) {
  // Given the FIPS 180-4 examples; When hashed; Then the published digests
  EXPECT_EQ(sha256_hex(std::string_view("abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(std::string_view("")),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(
      sha256_hex(std::string_view("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq")),
      "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

class LintTree : public ::testing::Test {
 protected:
  void SetUp() override {
    // One directory per process: CTest runs these tests in parallel, one process each.
    root_ = std::filesystem::temp_directory_path() /
            ("drivecheck_lint_test_" + std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_ / "vectors");
    std::filesystem::create_directories(root_ / "manuals");
    std::ofstream(root_ / "manuals" / "m.txt") << "one\ntwo\nthree\n";
  }
  void TearDown() override { std::filesystem::remove_all(root_); }
  void write(const std::string& name, const std::string& text) {
    std::ofstream(root_ / "vectors" / name) << text;
  }
  std::string manuals(const std::string& sha) {
    return "- file: m.txt\n  device: \"d\"\n  sha256: " + sha + "\n  lines: 3\n";
  }
  std::filesystem::path root_;
};

TEST_F(LintTree, CitationPastTheManualsEnd) {
  // Given a vector citing L2-4 of a 3-line manual
  write("manuals.yaml", manuals(sha256_hex(std::string_view("one\ntwo\nthree\n"))));
  write("v.yaml", "- id: a/b\n  title: t\n  source: \"m.txt §1 L2-4\"\n  steps: [{wait: 1ms}]\n");
  // When linted with the manuals available
  const auto report = lint_vector_tree({root_ / "vectors", root_ / "manuals", {}});
  // Then one error at the source's line; the sha256 matched
  ASSERT_EQ(report.errors.size(), 1U);
  EXPECT_NE(report.errors[0].to_string().find(
                "v.yaml:3: source 'm.txt §1 L2-4': line 4 is past the end of m.txt (3 lines)"),
            std::string::npos)
      << report.errors[0].to_string();
  EXPECT_TRUE(report.manuals_checked);
}

TEST_F(LintTree, AbortCodesNeedASetOrAClause) {
  // Given a literal abort list without clause, a raw abort frame with a fixed code, and the same
  // two with clause: / a set
  write("manuals.yaml", manuals(sha256_hex(std::string_view("one\ntwo\nthree\n"))));
  write("v.yaml", R"(- id: a/literal
  title: t
  source: "CiA 301 §1"
  steps:
    - sdo_write: {index: 0x1000, sub: 0, value: 0, size: 4}
      expect: {abort: [0x06010002]}
- id: a/frame
  title: t
  source: "CiA 301 §1"
  steps:
    - expect_frame: "580+N#8000100002000106"
- id: a/fine
  title: t
  source: "CiA 301 §1"
  steps:
    - sdo_write: {index: 0x1000, sub: 0, value: 0, size: 4}
      expect: {abort: [0x06010002], clause: "CiA 301 §7.2.4.3.17"}
    - expect_frame: "580+N#8000100002000106"
      clause: "CiA 301 §7.2.4.3.17"
    - expect_frame: "580+N#80001000........"
      abort: write-read-only
    - expect_frame: "580+N#80001000........"
)");
  // When linted
  const auto report = lint_vector_tree({root_ / "vectors", root_ / "manuals", {}});
  // Then exactly the two without set or clause are errors, at their steps' lines
  ASSERT_EQ(report.errors.size(), 2U);
  EXPECT_NE(report.errors[0].to_string().find(
                "v.yaml:5: vector a/literal: sdo_write expect: a literal list of abort codes "
                "needs clause:"),
            std::string::npos)
      << report.errors[0].to_string();
  EXPECT_NE(report.errors[1].to_string().find(
                "v.yaml:11: vector a/frame: expect_frame '580+N#8000100002000106' is an SDO "
                "abort with a fixed code"),
            std::string::npos)
      << report.errors[1].to_string();
}

TEST_F(LintTree, RefusalMeansNotApplicableIsCitedAndNotOfAMandatoryObject) {
  // Given refused_means_not_applicable without clause, on 6060h (mandatory with cia402) in a
  // must-level vector, in finally:, and once as it should be (an optional object, cited)
  write("manuals.yaml", manuals(sha256_hex(std::string_view("one\ntwo\nthree\n"))));
  write("v.yaml", R"yaml(- id: a/no-clause
  title: t
  source: "CiA 402-2 §1"
  requires: [cia402, object.6088]
  steps:
    - sdo_write: {index: 0x6088, sub: 0, value: 1, size: 2}
      refused_means_not_applicable: value-range
- id: a/mandatory
  title: t
  source: "CiA 402-2 §1"
  requires: [cia402]
  steps:
    - sdo_write: {index: 0x6060, sub: 0, value: 4, size: 1}
      refused_means_not_applicable: value-range
      clause: "CiA 402-2 §6060h"
- id: a/finally
  title: t
  source: "CiA 402-2 §1"
  level: should
  requires: [cia402, object.6088]
  steps:
    - wait: 1ms
  finally:
    - sdo_write: {index: 0x6088, sub: 0, value: 1, size: 2}
      refused_means_not_applicable: value-range
      clause: "CiA 402-2 §6088h"
- id: a/fine
  title: t
  source: "CiA 402-2 §1"
  requires: [cia402, object.6088]
  steps:
    - sdo_write: {index: 0x6088, sub: 0, value: 1, size: 2}
      refused_means_not_applicable: value-range
      clause: "CiA 402-2 §6088h torque profile type (1: a value a drive may support)"
- id: a/should-mandatory
  title: t
  source: "CiA 402-2 §1"
  level: should
  requires: [cia402]
  steps:
    - sdo_write: {index: 0x6060, sub: 0, value: 4, size: 1}
      refused_means_not_applicable: value-range
      clause: "CiA 402-2 §6060h"
- id: a/clause-of-the-object
  title: t
  source: "CiA 301 §1"
  requires: [pdo]
  steps:
    - sdo_write: {index: 0x1800, sub: 1, value: 0x800001A0, size: 4}
      refused_means_not_applicable: pdo-cob-id-fixed
      clause: "CiA 301 §7.5.2.37"
- id: a/other-clause
  title: t
  source: "CiA 301 §1"
  requires: [pdo]
  steps:
    - sdo_write: {index: 0x1800, sub: 1, value: 0x800001A0, size: 4}
      refused_means_not_applicable: value-range
      clause: "CiA 301 §7.5.2.37"
)yaml");
  // When linted
  const auto report = lint_vector_tree({root_ / "vectors", root_ / "manuals", {}});
  // Then the first three and the last are errors at their steps' lines; a/fine, a/should-
  // mandatory and a/clause-of-the-object (a set citing the object's own clause, §7.5.2.37,
  // which lets the device refuse the value) are fine
  ASSERT_EQ(report.errors.size(), 4U) << report.errors[0].to_string();
  EXPECT_NE(report.errors[0].to_string().find(
                "v.yaml:6: vector a/no-clause: sdo_write refused_means_not_applicable: give "
                "clause:"),
            std::string::npos)
      << report.errors[0].to_string();
  EXPECT_NE(report.errors[1].to_string().find(
                "v.yaml:13: vector a/mandatory: sdo_write refused_means_not_applicable: 6060h "
                "sub 0 (modes of operation) is mandatory here"),
            std::string::npos)
      << report.errors[1].to_string();
  EXPECT_NE(report.errors[2].to_string().find(
                "v.yaml:24: vector a/finally: sdo_write refused_means_not_applicable: not in "
                "finally:"),
            std::string::npos)
      << report.errors[2].to_string();
  EXPECT_NE(report.errors[3].to_string().find(
                "vector a/other-clause: sdo_write refused_means_not_applicable: 1800h sub 1 "
                "(TPDO1 communication parameter) is mandatory here"),
            std::string::npos)
      << report.errors[3].to_string();
}

TEST_F(LintTree, DeviationIdsMustBeVectors) {
  // Given a profile whose deviation names one existing vector and one that does not exist
  write("manuals.yaml", manuals(sha256_hex(std::string_view("one\ntwo\nthree\n"))));
  write("v.yaml", "- id: a/b\n  title: t\n  source: \"CiA 301 §1\"\n  steps: [{wait: 1ms}]\n");
  std::filesystem::create_directories(root_ / "vectors" / "drives");
  write("drives/p.yaml", R"(name: p
title: P
features: []
deviations:
  - id: d
    vectors: ["a/b", "a/c"]
    observed: {value: 1}
    source: "m.txt §1 L1-2"
    description: x
  - id: e
    vectors: []
    source: "m.txt §1 L1-2"
    description: y
)");
  // When linted
  const auto report = lint_vector_tree({root_ / "vectors", root_ / "manuals", {}});
  // Then the unknown id is an error at the deviation's line, the empty one a warning
  ASSERT_EQ(report.errors.size(), 1U);
  EXPECT_NE(report.errors[0].to_string().find("p.yaml:5: deviation d: no vector 'a/c'"),
            std::string::npos)
      << report.errors[0].to_string();
  ASSERT_EQ(report.warnings.size(), 1U);
  EXPECT_NE(report.warnings[0].message.find("deviation e: covers no vector"), std::string::npos);
}

TEST_F(LintTree, UnlistedManualAndChangedManual) {
  // Given a wrong sha256 in manuals.yaml and a citation of an unlisted manual
  write("manuals.yaml", manuals(std::string(64, '0')));
  write("v.yaml",
        "- id: a/b\n  title: t\n  source: \"other.txt §1 L1-1\"\n  steps: [{wait: 1ms}]\n");
  // When linted
  const auto report = lint_vector_tree({root_ / "vectors", root_ / "manuals", {}});
  // Then both are errors
  ASSERT_EQ(report.errors.size(), 2U);
  EXPECT_NE(report.errors[0].message.find("the text changed"), std::string::npos);
  EXPECT_NE(report.errors[1].message.find("manual 'other.txt' is not listed in manuals.yaml"),
            std::string::npos);
}

TEST_F(LintTree, WithoutManualsTheShaIsNotChecked) {
  // Given a wrong sha256 but no manuals directory; When linted; Then no error, not checked
  write("manuals.yaml", manuals(std::string(64, '0')));
  write("v.yaml", "- id: a/b\n  title: t\n  source: \"m.txt §1 L1-3\"\n  steps: [{wait: 1ms}]\n");
  const auto report = lint_vector_tree({root_ / "vectors", std::nullopt, {}});
  EXPECT_TRUE(report.ok());
  EXPECT_FALSE(report.manuals_checked);
}

TEST_F(LintTree, BadManualListHasLines) {
  // Given an unknown key in manuals.yaml; When linted; Then its line
  write("manuals.yaml", "- file: m.txt\n  device: d\n  sha256: x\n  lines: 3\n  pages: 2\n");
  const auto report = lint_vector_tree({root_ / "vectors", std::nullopt, {}});
  ASSERT_FALSE(report.errors.empty());
  EXPECT_EQ(report.errors[0].line, 5);
}

TEST_F(LintTree, RestoreDefaultsOnlyForRestoreOrDefaultsAndCleanUpInFinally) {
  // Given a vector using restore-defaults as a clean slate, one about restore (it writes
  // 1011h), one about a default value, and one with a clean-up step at the end of its steps
  write("manuals.yaml", manuals(sha256_hex(std::string_view("one\ntwo\nthree\n"))));
  const std::string head = "  title: t\n  source: \"CiA 301 §1\"\n";
  write("v.yaml", "- id: a/clean-slate\n" + head +
                      "  setup: restore-defaults\n  steps: [{wait: 1ms}]\n" + "- id: a/restore\n" +
                      head + "  requires: [restore]\n  setup: restore-defaults\n  steps:\n" +
                      "    - sdo_write: {index: 0x1011, sub: 1, value: 0x64616F6C, size: 4}\n" +
                      "- id: a/heartbeat-default\n" + head +
                      "  setup: restore-defaults\n  steps: [{wait: 1ms}]\n" +
                      "- id: a/cleans-up\n" + head +
                      "  steps:\n    - nmt: reset-node\n      note: \"clean up: reset\"\n");
  // When linted
  const auto report = lint_vector_tree({root_ / "vectors", std::nullopt, {}});
  // Then the clean slate is an error at its line, the clean-up step a warning
  ASSERT_EQ(report.errors.size(), 1U);
  EXPECT_NE(report.errors[0].to_string().find("v.yaml:1: vector a/clean-slate: setup: "
                                              "restore-defaults wipes"),
            std::string::npos)
      << report.errors[0].to_string();
  ASSERT_EQ(report.warnings.size(), 1U);
  EXPECT_NE(report.warnings[0].message.find("move it to finally:"), std::string::npos);
}

TEST_F(LintTree, RepeatedStepIsJudgedOnceAndARepeatOfOneIsAWarning) {
  // Given a repeat of 50 passes holding a raw abort frame with a fixed code (an error), and a
  // repeat of one pass, and a repeat whose body is malformed
  write("manuals.yaml", manuals(sha256_hex(std::string_view("one\ntwo\nthree\n"))));
  write("v.yaml", R"(- id: a/repeated
  title: t
  source: "CiA 301 §1"
  steps:
    - repeat:
        times: 50
        steps:
          - expect_frame: "580+N#8000100002000106"
    - repeat: {times: 1, steps: [{wait: 1ms}]}
- id: a/malformed
  title: t
  source: "CiA 301 §1"
  steps:
    - repeat: {times: 0, steps: [{wait: 1ms}]}
)");
  // When linted
  const auto report = lint_vector_tree({root_ / "vectors", root_ / "manuals", {}});
  // Then the fixed code is one error at its line (not 50), the repeat of one a warning at the
  // repeat's line, and the malformed repeat a load error at its line
  ASSERT_EQ(report.errors.size(), 2U);
  EXPECT_NE(report.errors[0].to_string().find("v.yaml:14: repeat: times: 0 is out of range"),
            std::string::npos)
      << report.errors[0].to_string();
  EXPECT_NE(report.errors[1].to_string().find(
                "v.yaml:8: vector a/repeated: expect_frame '580+N#8000100002000106' is an SDO "
                "abort with a fixed code"),
            std::string::npos)
      << report.errors[1].to_string();
  ASSERT_EQ(report.warnings.size(), 1U);
  EXPECT_NE(report.warnings[0].to_string().find("v.yaml:9: vector a/repeated: repeat: times: 1 "
                                                "repeats nothing"),
            std::string::npos)
      << report.warnings[0].to_string();
}

TEST_F(LintTree, MotionVectorResetsOnlyInItsSetup) {
  // Given a motion vector with a reset node step, one sending a raw reset communication, a
  // motion vector without a reset, and a vector without motion that resets
  write("manuals.yaml", manuals(sha256_hex(std::string_view("one\ntwo\nthree\n"))));
  const std::string head = "  title: t\n  source: \"CiA 402 §1\"\n";
  write("v.yaml", "- id: a/nmt\n" + head + "  motion: true\n  steps:\n    - nmt: reset-node\n" +
                      "- id: a/raw\n" + head + "  motion: true\n  steps:\n" +
                      "    - send: \"000#8201\"\n" + "- id: a/quiet\n" + head +
                      "  motion: true\n  steps: [{wait: 1ms}]\n" + "- id: a/still\n" + head +
                      "  steps:\n    - nmt: reset-node\n");
  // When linted
  const auto report = lint_vector_tree({root_ / "vectors", std::nullopt, {}});
  // Then the two motion vectors that reset are errors at their steps' lines, nothing else
  ASSERT_EQ(report.errors.size(), 2U);
  EXPECT_NE(report.errors[0].to_string().find("v.yaml:6: vector a/nmt: a motion vector must not "
                                              "reset the DUT in its steps"),
            std::string::npos)
      << report.errors[0].to_string();
  EXPECT_NE(report.errors[1].to_string().find("vector a/raw: a motion vector must not reset"),
            std::string::npos)
      << report.errors[1].to_string();
}

TEST_F(LintTree, MustLevelLiteralTimeBoundNeedsItsClause) {
  // Given must-level vectors with a literal within:, for:, tolerance: and min:/max: and no
  // clause, one with a clause citing a CiA clause, one citing the manual, one with a clause that
  // is no citation, one using $timing keys, and a should-level vector with a literal bound
  write("manuals.yaml", manuals(sha256_hex(std::string_view("one\ntwo\nthree\n"))));
  const std::string head = "  title: t\n  source: \"CiA 301 §1\"\n";
  write("v.yaml",
        "- id: a/bare\n" + head +
            "  steps:\n"
            "    - expect_frame: \"701#05\"\n      within: 40ms\n"
            "    - expect_silence: any\n      for: 20ms\n"
            "    - expect_periodic: \"700+N\"\n      period: 50ms\n      tolerance: 3ms\n"
            "    - mark: a\n    - mark: b\n"
            "    - measure: {from: a, to: b, min: 1ms, max: 2ms}\n" +
            "- id: a/cia\n" + head +
            "  steps:\n    - expect_heartbeat: operational\n      within: 100ms\n"
            "      clause: \"CiA 301 §7.2.8.3.2.2 (two periods of 1017h = 50 ms)\"\n" +
            "- id: a/manual\n" + head +
            "  steps:\n    - poll: {index: 0x2000, sub: 0, value: 1}\n      within: 10ms\n"
            "      clause: \"m.txt §1 L1-2 (within 10 ms)\"\n" +
            "- id: a/not-a-citation\n" + head +
            "  steps:\n    - expect_bootup: {}\n      within: 1s\n"
            "      clause: \"fast enough\"\n" +
            "- id: a/keys\n" + head +
            "  steps:\n    - expect_frame: \"701#05\"\n      within: $timing.response\n"
            "    - expect_bootup: {}\n" +
            "- id: a/should\n" + head + "  level: should\n" +
            "  steps:\n    - expect_frame: \"701#05\"\n      within: 1ms\n");
  // When linted
  const auto report = lint_vector_tree({root_ / "vectors", std::nullopt, {}});
  // Then each bare bound of a/bare is an error at its step's line, and so is the clause that
  // cites nothing; the cited, $timing and should-level bounds pass
  std::vector<std::string> texts;
  for (const auto& e : report.errors)
    texts.push_back(e.to_string());
  ASSERT_EQ(texts.size(), 6U) << ::testing::PrintToString(texts);
  EXPECT_NE(texts[0].find("v.yaml:5: vector a/bare: expect_frame within: 40ms is a literal time "
                          "bound in a must-level vector"),
            std::string::npos)
      << texts[0];
  EXPECT_NE(texts[1].find("expect_silence for: 20ms"), std::string::npos) << texts[1];
  EXPECT_NE(texts[2].find("expect_periodic tolerance: 3ms"), std::string::npos) << texts[2];
  EXPECT_NE(texts[3].find("measure min: 1ms"), std::string::npos) << texts[3];
  EXPECT_NE(texts[4].find("measure max: 2ms"), std::string::npos) << texts[4];
  EXPECT_NE(texts[5].find("vector a/not-a-citation: expect_bootup clause: 'fast enough' does not "
                          "begin with a citation"),
            std::string::npos)
      << texts[5];
}

TEST_F(LintTree, TimingClauseCitesAListedManualWithinItsLines) {
  // Given a must-level bound whose clause cites lines past the end of the listed manual, and one
  // citing a manual that manuals.yaml does not list
  write("manuals.yaml", manuals(sha256_hex(std::string_view("one\ntwo\nthree\n"))));
  const std::string head = "  title: t\n  source: \"CiA 301 §1\"\n";
  write("v.yaml", "- id: a/past\n" + head +
                      "  steps:\n    - expect_frame: \"701#05\"\n      within: 5ms\n"
                      "      clause: \"m.txt §1 L3-9\"\n" +
                      "- id: a/unlisted\n" + head +
                      "  steps:\n    - expect_frame: \"701#05\"\n      within: 5ms\n"
                      "      clause: \"other.txt §1 L1-2; the manual's bound\"\n");
  // When linted
  const auto report = lint_vector_tree({root_ / "vectors", std::nullopt, {}});
  // Then both clauses are errors naming the problem
  ASSERT_EQ(report.errors.size(), 2U);
  EXPECT_NE(report.errors[0].message.find("line 9 is past the end of m.txt"), std::string::npos)
      << report.errors[0].to_string();
  EXPECT_NE(report.errors[1].message.find("manual 'other.txt' is not listed"), std::string::npos)
      << report.errors[1].to_string();
}

}  // namespace
}  // namespace drivecheck::conformance
