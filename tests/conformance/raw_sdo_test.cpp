// The transport-neutral raw SDO steps (FORMAT.md "Raw SDO steps"): `sdo_request` and
// `expect_sdo_response` load, lint and write back; and they judge the same SDO octets on both
// links, the reference drive on the simulated CAN bus and the reference drive as an emulated
// EtherCAT slave (CoE SDO in the mailbox): each check passing against the compliant drive and
// failing against the named deviation that breaks it, on CAN and on EtherCAT.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "conformance/engine.hpp"
#include "conformance/ethercat_port.hpp"
#include "conformance/vector_file.hpp"
#include "conformance/vector_lint.hpp"
#include "conformance/verdict.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/data_type.hpp"
#include "reference_drive/device.hpp"
#include "tests/support/ethercat_rig.hpp"

namespace drivecheck::conformance {
namespace {

using namespace std::chrono_literals;
using reference_drive::Deviation;
using reference_drive::DeviationSet;

profile::DriveProfile make_profile() {
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [sdo.segmented, heartbeat.producer, store]\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return *parsed;
}

// One vector with `steps` (YAML, indented 4).
std::string vector_text(const std::string& id, const std::string& steps) {
  return fmt::format("- id: t/{}\n  title: t\n  source: \"CiA 301 §7.2.4.3\"\n  steps:\n{}", id,
                     steps);
}

std::vector<Vector> parse(const std::string& text) {
  const auto set = parse_vectors(text, "t.yaml");
  EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
  return set.vectors;
}

// The first load error of `text`, "" when it loads.
std::string load_error(const std::string& text) {
  const auto set = parse_vectors(text, "t.yaml");
  return set.errors.empty() ? std::string() : set.errors.front().to_string();
}

// An expedited upload of 1018h sub 0 (UNSIGNED8): scs=2 e=1 s=1 n=3.
const std::string kUploadU8 =
    "    - sdo_request: \"4018100000000000\"\n"
    "    - expect_sdo_response: \"4F181000........\"\n"
    "      within: $timing.sdo_response\n";
// A request with ccs=7: abort, a code of the invalid-command set.
const std::string kInvalidCommand =
    "    - sdo_request: \"E000100000000000\"\n"
    "    - expect_sdo_response: \"80..............\"\n"
    "      abort: invalid-command\n"
    "      within: $timing.sdo_response\n";
// A write to the read-only 1000h: abort naming 1000h sub 0, a write-read-only code.
const std::string kWriteReadOnly =
    "    - sdo_request: \"2300100000000000\"\n"
    "    - expect_sdo_response: \"80001000........\"\n"
    "      abort: write-read-only\n"
    "      within: $timing.sdo_response\n";

// ---- the format ----

TEST(RawSdoFormatTest, StepsLoadAsTheirCanFrames) {
  // Given a vector with the two raw SDO steps
  const auto vectors = parse(vector_text("x", kWriteReadOnly));
  // When it is loaded
  ASSERT_EQ(vectors.size(), 1U);
  const auto& steps = vectors[0].steps;
  ASSERT_EQ(steps.size(), 2U);
  // Then the request is the frame 600h+N and the response the pattern on 580h+N with its set
  const auto& request = std::get<SdoRequestStep>(steps[0].action);
  EXPECT_EQ(request.send.frame.to_frame(5),
            can::Frame::standard(0x605, {0x23, 0x00, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00}));
  const auto& response = std::get<ExpectSdoResponseStep>(steps[1].action);
  EXPECT_TRUE(response.expect.pattern.matches(
      can::Frame::standard(0x585, {0x80, 0x00, 0x10, 0x00, 0x02, 0x00, 0x01, 0x06}), 5));
  ASSERT_TRUE(response.expect.abort);
  EXPECT_EQ(response.expect.abort->set, "write-read-only");
  EXPECT_EQ(action_name(steps[0].action), "sdo_request");
  EXPECT_EQ(action_name(steps[1].action), "expect_sdo_response");
}

TEST(RawSdoFormatTest, RequestOfSevenOctetsIsAnErrorAtItsLine) {
  // Given a request of 7 octets (line 5 of the file)
  const auto text = vector_text("x", "    - sdo_request: \"40001000000000\"\n");
  // When it is loaded
  const auto error = load_error(text);
  // Then the error names the file and line and says an SDO message has 8 octets
  EXPECT_NE(error.find("t.yaml:5"), std::string::npos) << error;
  EXPECT_NE(error.find("exactly 8"), std::string::npos) << error;
}

TEST(RawSdoFormatTest, RequestWithACobIdIsAnError) {
  // Given a request written as a CAN frame
  const auto text = vector_text("x", "    - sdo_request: \"600+N#4000100000000000\"\n");
  // When it is loaded
  const auto error = load_error(text);
  // Then it is refused: the link decides the COB-ID or mailbox
  EXPECT_NE(error.find("without COB-ID"), std::string::npos) << error;
}

TEST(RawSdoFormatTest, ResponseRefusesSinceAndWildcardsInTheRequest) {
  // Given a response with since: and a request with a don't-care octet
  const auto since = vector_text("x",
                                 "    - mark: t0\n"
                                 "    - expect_sdo_response: \"4F181000........\"\n"
                                 "      since: t0\n");
  const auto wildcard = vector_text("x", "    - sdo_request: \"40..100000000000\"\n");
  // When they are loaded
  // Then both are errors
  EXPECT_NE(load_error(since).find("unknown key 'since'"), std::string::npos) << load_error(since);
  EXPECT_NE(load_error(wildcard).find("only in expectations"), std::string::npos)
      << load_error(wildcard);
}

TEST(RawSdoFormatTest, AbortOnANonAbortPatternIsAnError) {
  // Given abort: beside a pattern that is no SDO abort
  const auto text = vector_text("x",
                                "    - expect_sdo_response: \"4F181000........\"\n"
                                "      abort: write-read-only\n");
  // When it is loaded
  const auto error = load_error(text);
  // Then the error says the pattern must be an abort with its code as don't care
  EXPECT_NE(error.find("expect_sdo_response: with abort:"), std::string::npos) << error;
}

TEST(RawSdoFormatTest, WriterGivesTheStepsBack) {
  // Given a vector with both raw steps, an or: alternative and a mark
  const auto vectors = parse(vector_text("x",
                                         "    - sdo_request: \"4018100000000000\"\n"
                                         "    - expect_sdo_response: \"4F181000........\"\n"
                                         "      or: [\"80181000........\"]\n"
                                         "      mark: answered\n"
                                         "      within: 50ms\n"
                                         "      clause: \"CiA 301 §7.2.4.3.6 (a test bound)\"\n"));
  ASSERT_EQ(vectors.size(), 1U);
  // When it is written and read again
  const auto again = parse(to_yaml(vectors));
  // Then it has the same content
  ASSERT_EQ(again.size(), 1U);
  EXPECT_TRUE(same_content(vectors[0], again[0])) << to_yaml(vectors);
}

TEST(RawSdoFormatTest, LintRefusesAFixedAbortCodeWithoutClause) {
  // Given an expected SDO response that is an abort with a fixed code and no clause
  const auto vectors = parse(vector_text("x", "    - expect_sdo_response: \"8000100002000106\"\n"));
  ASSERT_EQ(vectors.size(), 1U);
  // When the lint checks its abort expectation
  const auto message = check_abort_expectation(vectors[0].steps[0]);
  // Then it asks for a set or a clause, naming the step
  EXPECT_NE(message.find("expect_sdo_response"), std::string::npos) << message;
  EXPECT_NE(message.find("fixed code"), std::string::npos) << message;
}

TEST(RawSdoFormatTest, RawStepsRunOnBothLinksAndSendOnlyOnCan) {
  // Given a vector with raw SDO steps and one with a CAN frame
  const auto raw = parse(vector_text("raw", kUploadU8));
  const auto frame = parse(vector_text("frame", "    - send: \"600+N#4018100000000000\"\n"));
  ASSERT_EQ(raw.size(), 1U);
  ASSERT_EQ(frame.size(), 1U);
  const auto profile = make_profile();
  ApplicabilityContext ethercat;
  ethercat.link = LinkKind::ethercat;
  // When applicability is decided on EtherCAT and on CAN
  // Then the raw vector applies on both, the frame vector only on CAN
  EXPECT_EQ(not_applicable_reason(raw[0], profile, ethercat), "");
  EXPECT_EQ(not_applicable_reason(raw[0], profile, {}), "");
  EXPECT_NE(not_applicable_reason(frame[0], profile, ethercat).find("needs the CAN link"),
            std::string::npos);
}

// ---- both links against the reference drive ----

// The reference drive on the simulated CAN bus, node 1.
class CanDrive {
 public:
  explicit CanDrive(DeviationSet deviations) {
    reference_drive::DriveConfig config;
    config.dictionary.node_id = 1;
    config.deviations = deviations;
    auto drive = reference_drive::ReferenceDrive::create(*dut_, std::move(config));
    EXPECT_TRUE(drive) << drive.error();
    if (!drive) return;
    drive_ = std::move(*drive);
    drive_->power_on();
    bus_.run_for(10ms);
  }
  RunResult run(const std::vector<Vector>& vectors, const profile::DriveProfile& profile) {
    Engine engine(*harness_, profile, {});
    return engine.run(vectors);
  }

 private:
  can::SimBus bus_{{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> harness_ = bus_.attach("harness");
  std::unique_ptr<can::SimPort> dut_ = bus_.attach("dut");
  std::unique_ptr<reference_drive::ReferenceDrive> drive_;
};

// The reference drive as an emulated EtherCAT slave with `deviations` (tests/support).
class EthercatDrive {
 public:
  explicit EthercatDrive(DeviationSet deviations) : rig_(options(deviations)) {}
  RunResult run(const std::vector<Vector>& vectors, const profile::DriveProfile& profile) {
    if (!rig_.ready()) return {};
    Engine engine(rig_.clock(), rig_.port(), profile, {});
    return engine.run(vectors);
  }
  ethercat::Master& master() { return rig_.master(); }

 private:
  static reference_drive::ethercat::EthercatDriveOptions options(DeviationSet deviations) {
    reference_drive::ethercat::EthercatDriveOptions options;
    options.deviations = deviations;
    return options;
  }
  test_support::EthercatRig rig_;
};

class RawSdoLinkTest : public ::testing::TestWithParam<LinkKind> {
 protected:
  // `steps` as one vector on the link of the test, against the drive with `deviations`.
  VectorResult run(const std::string& steps, DeviationSet deviations = {}) {
    const auto vectors = parse(vector_text("x", steps));
    EXPECT_EQ(vectors.size(), 1U);
    RunResult result;
    if (GetParam() == LinkKind::can) {
      CanDrive drive(deviations);
      result = drive.run(vectors, profile_);
    } else {
      EthercatDrive drive(deviations);
      result = drive.run(vectors, profile_);
    }
    EXPECT_EQ(result.vectors.size(), 1U);
    return result.vectors.empty() ? VectorResult{} : result.vectors[0];
  }
  profile::DriveProfile profile_ = make_profile();
};

TEST_P(RawSdoLinkTest, UploadSizeIndicationIsJudged) {
  // Given the expedited upload of a 1-octet object
  // When it runs against the compliant drive and against one that indicates 4 octets
  const auto good = run(kUploadU8);
  const auto bad = run(kUploadU8, {Deviation::sdo_upload_size_wrong});
  // Then the first passes and the second fails at the response (43h instead of 4Fh)
  EXPECT_EQ(good.verdict, Verdict::pass) << good.message;
  EXPECT_EQ(bad.verdict, Verdict::fail) << bad.message;
  EXPECT_NE(bad.message.find("step 2 expect_sdo_response"), std::string::npos) << bad.message;
  const bool shown = bad.message.find("581#43181000") != std::string::npos ||  // CAN frame
                     bad.message.find("CoE SDO response 43 18 10 00") != std::string::npos;
  EXPECT_TRUE(shown) << bad.message;
}

TEST_P(RawSdoLinkTest, InvalidCommandSpecifierIsAborted) {
  // Given a request with command specifier 7
  // When it runs against the compliant drive and against one that does not answer it
  const auto good = run(kInvalidCommand);
  const auto bad = run(kInvalidCommand, {Deviation::sdo_invalid_command_ignored});
  // Then the first passes (an abort in the set) and the second fails: nothing came
  EXPECT_EQ(good.verdict, Verdict::pass) << good.message;
  EXPECT_EQ(bad.verdict, Verdict::fail) << bad.message;
  ASSERT_FALSE(bad.checks.empty());
  EXPECT_TRUE(bad.checks.back().observed.nothing);
}

TEST_P(RawSdoLinkTest, AbortMultiplexerIsJudged) {
  // Given a write to the read-only 1000h, whose abort must name 1000h sub 0
  // When it runs against the compliant drive and against one whose aborts name 0000h sub 0
  const auto good = run(kWriteReadOnly);
  const auto bad = run(kWriteReadOnly, {Deviation::sdo_abort_wrong_multiplexer});
  // Then the first passes and the second fails at the response
  EXPECT_EQ(good.verdict, Verdict::pass) << good.message;
  EXPECT_EQ(bad.verdict, Verdict::fail) << bad.message;
  EXPECT_NE(bad.message.find("step 2 expect_sdo_response"), std::string::npos) << bad.message;
}

TEST_P(RawSdoLinkTest, AbortCodeOutsideTheSetFails) {
  // Given the write to the read-only 1000h, expecting the abort set of a missing object
  const std::string steps =
      "    - sdo_request: \"2300100000000000\"\n"
      "    - expect_sdo_response: \"80001000........\"\n"
      "      abort: object-does-not-exist\n"
      "      within: $timing.sdo_response\n";
  // When it runs against the compliant drive (which answers 06010002h)
  const auto result = run(steps);
  // Then it fails with that code as the observation
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  ASSERT_FALSE(result.checks.empty());
  EXPECT_EQ(result.checks.back().observed.abort, 0x06010002U) << result.message;
}

TEST_P(RawSdoLinkTest, RawDownloadIsWrittenAndUndone) {
  // Given a raw expedited download of 1017h := 300 ms, confirmed, then read back
  const std::string steps =
      "    - sdo_request: \"2B1710002C010000\"\n"
      "    - expect_sdo_response: \"60171000........\"\n"
      "      within: $timing.sdo_response\n"
      "    - sdo_read: {index: 0x1017, sub: 0}\n"
      "      expect: {value: 300}\n";
  // When it runs against the compliant drive
  const auto result = run(steps);
  // Then it passes, and the engine's restore put 1017h back (it learnt of the raw write)
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  bool restored = false;
  for (const auto& check : result.checks)
    restored |= check.ok && check.action == "restore" &&
                check.actual.find("1017h sub 0 := ") != std::string::npos;
  EXPECT_TRUE(restored);
}

std::string link_name(const ::testing::TestParamInfo<LinkKind>& link) {
  return link.param == LinkKind::can ? "Can" : "Ethercat";
}

INSTANTIATE_TEST_SUITE_P(Links, RawSdoLinkTest,
                         ::testing::Values(LinkKind::can, LinkKind::ethercat), link_name);

TEST(RawSdoEthercatTest, AnswerNotTakenDoesNotDisturbTheNextTransfer) {
  // Given a raw upload of 1000h whose answer no step takes, then an SDO read of 1018h sub 0
  // through the engine (on CAN the engine's client would take the unread answer, as after a
  // `send:`; over CoE the port keeps it apart)
  EthercatDrive drive({});
  const auto vectors = parse(vector_text("x",
                                         "    - sdo_request: \"4000100000000000\"\n"
                                         "    - sdo_read: {index: 0x1018, sub: 0}\n"
                                         "      expect: {value: 4}\n"));
  // When it runs against the compliant drive
  const auto result = drive.run(vectors, make_profile());
  // Then the read gets its own answer, not the one to the raw request
  ASSERT_EQ(result.vectors.size(), 1U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << result.vectors[0].message;
}

TEST(RawSdoEthercatTest, RequestIsACoeSdoRequestInTheMailbox) {
  // Given the emulated slave and a vector with a raw upload of 1018h sub 0
  EthercatDrive drive({});
  const auto vectors = parse(vector_text("x", kUploadU8));
  // When it runs
  const auto result = drive.run(vectors, make_profile());
  // Then the request went as a CoE SDO request and the check shows the CoE SDO response
  ASSERT_EQ(result.vectors.size(), 1U);
  const auto& vector = result.vectors[0];
  EXPECT_EQ(vector.verdict, Verdict::pass) << vector.message;
  bool request = false;
  bool response = false;
  for (const auto& check : vector.checks) {
    request |=
        check.action == "sdo_request" && check.actual == "CoE SDO request 40 18 10 00 00 00 00 00";
    response |= check.action == "expect_sdo_response" &&
                check.actual.starts_with("CoE SDO response 4F 18 10 00 04 00 00 00");
  }
  EXPECT_TRUE(request);
  EXPECT_TRUE(response);
  // and no CAN frame is among the evidence
  EXPECT_TRUE(vector.frames.empty());
}

}  // namespace
}  // namespace drivecheck::conformance
