// Applicability and verdict mapping (conformance/verdict.hpp), FORMAT.md "Verdicts".
#include "conformance/verdict.hpp"

#include <gtest/gtest.h>

#include "conformance/vector_file.hpp"

namespace drivecheck::conformance {
namespace {

profile::DriveProfile make_profile() {
  const auto parsed = profile::parse_profile(
      R"(name: p
title: "P"
features: [sdo.segmented, cia402]
deviations:
  - id: no-16
    vectors: ["cia402/fsa/transition-16/from-qsa"]
    observed: {state: switch-on-disabled}
    source: "CiA 402-2 §1"
    description: "quick stop always ends in switch on disabled"
  - id: homing-offset-negated
    vectors: [{id: "cia402/homing/method-35/position", observed: {value: 1000}}]
    source: "000_33c1d912b8b6010a.txt §7.2.1 L6025-6040"
    description: "homing sets 6064h to the home offset"
  - id: fixed-abort
    vectors: ["cia301/sdo/abort/x", "cia301/sdo/abort/y", "cia301/sdo/abort/z",
              "cia301/sdo/abort/w", "cia301/sdo/abort/v"]
    observed: [{abort: 0x06090030}, {no_answer: true}, {accepted: true},
               {statusword: {mask: 0x00FF, value: 0x0027}}, {text: "late by"}]
    source: "CiA 301 §1"
    description: "documented answers"
)",
      {.file_name = "p.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return *parsed;
}

Vector make_vector(std::string id, Level level = Level::must) {
  Vector vector;
  vector.id = std::move(id);
  vector.level = level;
  return vector;
}

TEST(Applicability, MissingFeatureNamesIt) {
  // Given a vector requiring sdo.block, which the profile lacks
  auto vector = make_vector("cia301/sdo/block");
  vector.requires_features = {"sdo.segmented", "sdo.block"};
  // When checked; Then not applicable, naming the feature
  EXPECT_EQ(not_applicable_reason(vector, make_profile(), {}),
            "requires sdo.block (profile p lacks it)");
}

TEST(Applicability, SimulationMotionAndProfiles) {
  // Given vectors needing simulation, motion, or another profile
  auto simulated = make_vector("a/b");
  simulated.requires_features = {"simulation"};
  auto moving = make_vector("a/c");
  moving.requires_features = {"motion"};
  auto festo = make_vector("a/d");
  festo.profiles = {"festo-cmmp"};
  const auto p = make_profile();
  // When checked with and without a simulation control / motion permission; Then
  EXPECT_NE(not_applicable_reason(simulated, p, {false, true}), "");
  EXPECT_EQ(not_applicable_reason(simulated, p, {true, true}), "");
  EXPECT_NE(not_applicable_reason(moving, p, {true, false}), "");
  EXPECT_EQ(not_applicable_reason(moving, p, {true, true}), "");
  EXPECT_EQ(not_applicable_reason(festo, p, {}), "only for profile festo-cmmp (selected: p)");
}

TEST(Applicability, BusOffStepNeedsTheSimulatedBus) {
  // Given a vector with a bus_off step
  auto vector = make_vector("cia301/bus-off/x");
  vector.steps.push_back(
      Step{BusOffStep{DurationSpec{std::chrono::milliseconds(50), {}}}, {}, 1, {}});
  const auto p = make_profile();
  // When checked with and without bus-off control; Then not applicable without it, by name
  EXPECT_EQ(not_applicable_reason(vector, p, {true, true, false}),
            "the bus_off step needs the DUT's CAN controller on the simulated bus (embedded "
            "drive)");
  EXPECT_EQ(not_applicable_reason(vector, p, {true, true, true}), "");
}

TEST(Applicability, FrameStepsNeedTheCanLink) {
  // Given a vector of SDO steps only, one with a send step, one with an expect_heartbeat in
  // finally:, and one with a block SDO read
  const auto set = parse_vectors(
      "- id: t/sdo\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n    - controlword: 0x0006\n"
      "- id: t/send\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n    - send: \"080#\"\n"
      "- id: t/finally\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n  finally:\n"
      "    - expect_heartbeat: pre-operational\n"
      "- id: t/block\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n      transfer: block\n",
      "t.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  ASSERT_EQ(set.vectors.size(), 4u);
  const auto p = make_profile();
  ApplicabilityContext can;
  ApplicabilityContext ethercat;
  ethercat.link = LinkKind::ethercat;
  // When checked on CAN and on EtherCAT; Then all apply on CAN, and on EtherCAT only the SDO
  // vector, the others naming the step that needs the CAN link
  for (const auto& vector : set.vectors)
    EXPECT_EQ(not_applicable_reason(vector, p, can), "") << vector.id;
  EXPECT_EQ(not_applicable_reason(set.vectors[0], p, ethercat), "");
  EXPECT_EQ(not_applicable_reason(set.vectors[1], p, ethercat),
            "needs the CAN link (steps: step 2 (send))");
  EXPECT_EQ(not_applicable_reason(set.vectors[2], p, ethercat),
            "needs the CAN link (finally: step 1 (expect_heartbeat))");
  EXPECT_EQ(not_applicable_reason(set.vectors[3], p, ethercat),
            "needs the CAN link (steps: step 1 (sdo_read))");
}

TEST(Applicability, TransportsLimitTheLinks) {
  // Given a vector of SDO steps written for CAN only, and one for EtherCAT only
  const auto set = parse_vectors(
      "- id: t/can\n  title: t\n  source: \"CiA 301 §1\"\n  transports: [can]\n  steps:\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n"
      "- id: t/ecat\n  title: t\n  source: \"CiA 301 §1\"\n  transports: [ethercat]\n"
      "  steps:\n    - sdo_read: {index: 0x1000, sub: 0}\n",
      "t.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto p = make_profile();
  ApplicabilityContext can;
  ApplicabilityContext ethercat;
  ethercat.link = LinkKind::ethercat;
  // When checked on both links; Then each applies only on its own
  EXPECT_EQ(not_applicable_reason(set.vectors[0], p, can), "");
  EXPECT_EQ(not_applicable_reason(set.vectors[0], p, ethercat),
            "only on can (transports:; this link: ethercat)");
  EXPECT_EQ(not_applicable_reason(set.vectors[1], p, ethercat), "");
  EXPECT_EQ(not_applicable_reason(set.vectors[1], p, can),
            "only on ethercat (transports:; this link: can)");
}

TEST(Applicability, EthercatStepsNeedTheEthercatLink) {
  // Given a vector with an AL request (no transports:) and one with expect_emcy only
  const auto set = parse_vectors(
      "- id: t/al\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n    - al_request: safeop\n"
      "- id: t/emcy\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - expect_emcy: {code: 0}\n",
      "t.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  const auto p = make_profile();
  ApplicabilityContext can;
  ApplicabilityContext ethercat;
  ethercat.link = LinkKind::ethercat;
  // When checked on both links
  // Then the AL vector applies only on EtherCAT, naming its step on CAN; expect_emcy on both
  EXPECT_EQ(not_applicable_reason(set.vectors[0], p, ethercat), "");
  EXPECT_EQ(not_applicable_reason(set.vectors[0], p, can),
            "needs the EtherCAT link (steps: step 2 (al_request))");
  EXPECT_EQ(not_applicable_reason(set.vectors[1], p, can), "");
  EXPECT_EQ(not_applicable_reason(set.vectors[1], p, ethercat), "");
}

TEST(VectorFile, UnknownTransportIsAnError) {
  // Given a vector naming a link that does not exist
  const auto set = parse_vectors(
      "- id: t/x\n  title: t\n  source: \"CiA 301 §1\"\n  transports: [profibus]\n  steps:\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n",
      "t.yaml");
  // When parsed; Then an error naming the file, line and the link
  ASSERT_FALSE(set.ok());
  EXPECT_NE(set.errors.front().to_string().find("t.yaml:4"), std::string::npos)
      << set.errors.front().to_string();
  EXPECT_NE(set.errors.front().to_string().find("profibus"), std::string::npos);
}

TEST(Applicability, FactoryRestoreNeedsTheOptIn) {
  // Given a profile with restore, and vectors that restore the factory defaults in their setup,
  // by an sdo_write of 1011h, by a raw SDO download of 1011h to node 5, in finally:, and one
  // that only reads 1011h
  const auto parsed = profile::parse_profile(
      "name: r\ntitle: R\nfeatures: [store, restore]\n",
      {.file_name = "r.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  const auto set = parse_vectors(
      "- id: t/setup\n  title: t\n  source: \"CiA 301 §1\"\n  setup: restore-defaults\n"
      "  steps:\n    - sdo_read: {index: 0x1018, sub: 0}\n"
      "- id: t/write\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_write: {index: 0x1011, sub: 1, value: 0x64616F6C, size: 4}\n"
      "- id: t/send\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - send: \"605#2311100164616F6C\"\n"
      "- id: t/finally\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1018, sub: 0}\n  finally:\n"
      "    - sdo_write: {index: 0x1011, sub: 4, value: 0x64616F6C, size: 4}\n"
      "- id: t/read\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1011, sub: 1}\n",
      "t.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  ApplicabilityContext real_bus;
  real_bus.motion_allowed = true;
  real_bus.node = 5;
  ApplicabilityContext allowed = real_bus;
  allowed.factory_restore_allowed = true;
  // When checked without and with the opt-in
  // Then each restoring vector is not applicable without it, with the reason, and applies with
  // it; the read of 1011h applies either way
  for (std::size_t i = 0; i < 4; ++i) {
    const Vector& vector = set.vectors[i];
    EXPECT_TRUE(restores_factory_defaults(vector, 5)) << vector.id;
    EXPECT_EQ(not_applicable_reason(vector, *parsed, real_bus),
              "would restore factory defaults and wipe the device's stored parameters; pass "
              "--allow-factory-restore")
        << vector.id;
    EXPECT_EQ(not_applicable_reason(vector, *parsed, allowed), "") << vector.id;
  }
  EXPECT_FALSE(restores_factory_defaults(set.vectors[4], 5));
  EXPECT_EQ(not_applicable_reason(set.vectors[4], *parsed, real_bus), "");
}

// A result whose one check failed with `observed` (and `actual`).
VectorResult failed_with(Observation observed, std::string actual = "x") {
  VectorResult result;
  Check passed{0, "sdo_write", "ok", "ok", true, {}, {}};
  Check failed{1, "expect_state", "e", std::move(actual), false, {}, observed};
  result.checks = {passed, failed};
  return result;
}

Observation statusword(std::uint16_t sw) {
  Observation o;
  o.statusword = sw;
  return o;
}

TEST(Verdict, DocumentedObservationIsADeviation) {
  // Given a failing vector a deviation lists, whose failing check shows the documented state
  auto result = failed_with(statusword(0x0250));
  // When the verdict is decided
  decide_verdict(result, make_vector("cia402/fsa/transition-16/from-qsa"), make_profile(),
                 Outcome::fail, "Expected: x", false);
  // Then a documented deviation with its id, source and description
  EXPECT_EQ(result.verdict, Verdict::deviation);
  EXPECT_EQ(result.deviation_id, "no-16");
  EXPECT_EQ(result.deviation_source, "CiA 402-2 §1");
  EXPECT_NE(result.message.find("quick stop always ends"), std::string::npos);
}

TEST(Verdict, OtherObservationStaysAFailure) {
  // Given the listed vector failing with another state (operation enabled, not the documented
  // switch on disabled)
  auto result = failed_with(statusword(0x0237));
  // When the verdict is decided
  decide_verdict(result, make_vector("cia402/fsa/transition-16/from-qsa"), make_profile(),
                 Outcome::fail, "Expected: x", false);
  // Then a failure naming the deviation that was near and why it did not match
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_TRUE(result.deviation_id.empty());
  EXPECT_NE(result.message.find("not the documented deviation no-16"), std::string::npos)
      << result.message;
  EXPECT_NE(result.message.find("state switch on disabled"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("statusword 0237h (operation enabled)"), std::string::npos)
      << result.message;
}

TEST(Verdict, BrokenHomingIsNotTheDocumentedDeviation) {
  // Given a deviation documenting 6064h = 1000 after homing, and a drive that reads -1000
  Observation minus;
  minus.value = -1000;
  auto broken = failed_with(minus);
  Observation plus;
  plus.value = 1000;
  auto documented = failed_with(plus);
  // When the verdicts are decided
  decide_verdict(broken, make_vector("cia402/homing/method-35/position"), make_profile(),
                 Outcome::fail, "Expected: value 0", false);
  decide_verdict(documented, make_vector("cia402/homing/method-35/position"), make_profile(),
                 Outcome::fail, "Expected: value 0", false);
  // Then -1000 fails (exit 1), 1000 is the documented deviation
  EXPECT_EQ(broken.verdict, Verdict::fail);
  EXPECT_NE(broken.message.find("it documents value 1000, the DUT showed value -1000"),
            std::string::npos)
      << broken.message;
  RunResult run;
  run.vectors = {broken};
  EXPECT_EQ(exit_code(run), 1);
  EXPECT_EQ(documented.verdict, Verdict::deviation);
  EXPECT_EQ(documented.deviation_id, "homing-offset-negated");
}

TEST(Verdict, UnlistedVectorIsAFailureEvenWithTheDocumentedObservation) {
  // Given a vector no deviation lists, failing with a documented observation of another vector
  auto result = failed_with(statusword(0x0250));
  // When the verdict is decided
  decide_verdict(result, make_vector("cia402/fsa/transition-16/from-qs"), make_profile(),
                 Outcome::fail, "m", false);
  // Then it fails
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_EQ(result.message, "m");
}

TEST(Verdict, EachObservationKindMatchesOnlyItself) {
  // Given failing checks of every observation kind
  Observation abort;
  abort.abort = 0x06090030;
  Observation other_abort;
  other_abort.abort = 0x06090031;
  Observation nothing;
  nothing.nothing = true;
  Observation accepted;
  accepted.accepted = true;
  const std::pair<VectorResult, Verdict> cases[] = {
      {failed_with(abort), Verdict::deviation},
      {failed_with(other_abort), Verdict::fail},
      {failed_with(nothing), Verdict::deviation},
      {failed_with(accepted), Verdict::deviation},
      {failed_with(statusword(0x1627)), Verdict::deviation},
      {failed_with(statusword(0x1637)), Verdict::fail},
      {failed_with({}, "answered late by 3 ms"), Verdict::deviation},
      {failed_with({}, "answered early"), Verdict::fail},
  };
  // When each is judged against a deviation documenting abort 06090030h, no answer, accepted,
  // statusword & 00FFh == 0027h or the text "late by"
  for (const auto& [given, want] : cases) {
    auto result = given;
    decide_verdict(result, make_vector("cia301/sdo/abort/x"), make_profile(), Outcome::fail, "m",
                   false);
    // Then only the documented ones are the deviation
    EXPECT_EQ(result.verdict, want) << result.message;
  }
}

TEST(Verdict, ShouldFailureIsWarningUnlessStrict) {
  // Given a failing SHOULD vector
  VectorResult lax;
  VectorResult strict;
  decide_verdict(lax, make_vector("a/b", Level::should), make_profile(), Outcome::fail, "m", false);
  decide_verdict(strict, make_vector("a/b", Level::should), make_profile(), Outcome::fail, "m",
                 true);
  // Then fail + warning without --strict, a plain fail with it
  EXPECT_EQ(lax.verdict, Verdict::fail);
  EXPECT_TRUE(lax.warning);
  EXPECT_EQ(strict.verdict, Verdict::fail);
  EXPECT_FALSE(strict.warning);
  RunResult run;
  run.vectors = {lax};
  EXPECT_EQ(exit_code(run), 0);
  run.vectors = {strict};
  EXPECT_EQ(exit_code(run), 1);
}

TEST(Verdict, HarnessErrorAndPass) {
  // Given a harness error and a pass; Then error (exit 1) and pass (exit 0)
  VectorResult error;
  decide_verdict(error, make_vector("a/b"), make_profile(), Outcome::harness_error, "unknown mark",
                 false);
  EXPECT_EQ(error.verdict, Verdict::error);
  EXPECT_EQ(error.message, "unknown mark");
  VectorResult pass;
  decide_verdict(pass, make_vector("a/b"), make_profile(), Outcome::pass, "", false);
  EXPECT_EQ(pass.verdict, Verdict::pass);
}

TEST(Verdict, NodeRelativeTextMatchesTheFrameOfAnyNode) {
  // Given a documented text naming the DUT's frame node-relative, and checks whose Actual shows
  // that frame from node 1, node 64 and node 127, another frame, and a frame of another range
  profile::DeviationObservation documented;
  documented.kind = profile::DeviationObservation::Kind::text;
  documented.text = "580+N#4B616000";
  const auto check = [](std::string actual) {
    Check c;
    c.actual = std::move(actual);
    return c;
  };
  // When each is matched; Then only the documented frame from a node 1..127 matches
  EXPECT_TRUE(observation_matches(documented, check("saw 581#4B61600000000000")));
  EXPECT_TRUE(observation_matches(documented, check("saw 5C0#4B61600000000000")));
  EXPECT_TRUE(observation_matches(documented, check("saw 5FF#4B61600000000000")));
  EXPECT_FALSE(observation_matches(documented, check("saw 5C0#4F61600000000000")));
  EXPECT_FALSE(observation_matches(documented, check("saw 580#4B61600000000000")));
  EXPECT_FALSE(observation_matches(documented, check("saw 600#4B61600000000000")));
  // And a plain text stays a substring
  documented.text = "ok, 2 byte(s)";
  EXPECT_TRUE(observation_matches(documented, check("read: ok, 2 byte(s)")));
}

}  // namespace
}  // namespace drivecheck::conformance
