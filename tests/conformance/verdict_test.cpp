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
    vectors: ["cia402/fsa/transition-16*"]
    source: "CiA 402-2 §1"
    description: "quick stop always ends in switch on disabled"
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
  vector.steps.push_back(Step{BusOffStep{DurationSpec{std::chrono::milliseconds(50), {}}}, {}, 1});
  const auto p = make_profile();
  // When checked with and without bus-off control; Then not applicable without it, by name
  EXPECT_EQ(not_applicable_reason(vector, p, {true, true, false}),
            "the bus_off step needs the DUT's CAN controller on the simulated bus (embedded "
            "drive)");
  EXPECT_EQ(not_applicable_reason(vector, p, {true, true, true}), "");
}

TEST(Verdict, FailureMatchedByDeviationGlob) {
  // Given a failing vector whose id a deviation's glob matches
  VectorResult result;
  decide_verdict(result, make_vector("cia402/fsa/transition-16/from-qsa"), make_profile(),
                 Outcome::fail, "Expected: x", false);
  // Then a documented deviation with its id, source and description
  EXPECT_EQ(result.verdict, Verdict::deviation);
  EXPECT_EQ(result.deviation_id, "no-16");
  EXPECT_EQ(result.deviation_source, "CiA 402-2 §1");
  EXPECT_NE(result.message.find("quick stop always ends"), std::string::npos);
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

}  // namespace
}  // namespace drivecheck::conformance
