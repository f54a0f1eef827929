// The pp vectors against a drive that keeps its homing over a reset (issue 20: pp over veth).
// The reference drive as an emulated EtherCAT slave on the simulated segment with no power
// cycle at reset node, as over veth where the drive is another process: AL INIT then PREOP
// leaves the CiA 402 application alone, so the homing mode still shows "homing attained"
// (statusword bit 12) from the homing of the vector before, and the axis stands where that
// vector left it. CiA 402-2 lets a drive keep a homing over a reset (a real drive keeps its
// homed position frame), so such a drive is conformant.
// The vector as it was (homing attained taken right after the start, then 6064h read) reads the
// old position and fails it; as it is now (6064h polled into [-10, 10] first, FORMAT.md `poll`
// with `range:`) it passes.
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <variant>
#include <vector>

#include "conformance/engine.hpp"
#include "conformance/ethercat_port.hpp"
#include "conformance/vector_file.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "tests/support/ethercat_rig.hpp"

namespace drivecheck::conformance {
namespace {

constexpr const char* kVector = "cia402/pp/target-reached/absolute-move";

// The vector of vectors/cia402/pp.yaml with id `id`.
Vector shipped(const std::string& id) {
  const auto set = load_vector_file(std::string(DRIVECHECK_VECTORS_DIR) + "/cia402/pp.yaml");
  EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
  const auto it = std::find_if(set.vectors.begin(), set.vectors.end(),
                               [&](const Vector& v) { return v.id == id; });
  EXPECT_NE(it, set.vectors.end()) << id;
  return it == set.vectors.end() ? Vector{} : *it;
}

// The same vector as it was before `poll` took a range: without its 6064h range polls.
Vector without_range_polls(Vector vector) {
  const auto removed = std::erase_if(vector.steps, [](const Step& step) {
    const auto* poll = std::get_if<PollStep>(&step.action);
    return poll != nullptr && poll->range.has_value();
  });
  EXPECT_EQ(removed, 1U);
  return vector;
}

class PpHomingKeptTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(rig_.ready());
    auto profile = profile::load_profile(std::string(DRIVECHECK_VECTORS_DIR) +
                                         "/drives/cia402-reference.yaml");
    ASSERT_TRUE(profile) << profile.error().to_string();
    profile_ = *profile;
  }

  // Runs `vectors` in one engine run (motion allowed, as the embedded run does).
  RunResult run(const std::vector<Vector>& vectors) {
    EngineOptions options;
    options.allow_motion = true;
    Engine engine(rig_.clock(), rig_.port(), profile_, options);
    return engine.run(vectors);
  }

  test_support::EthercatRig rig_;  // no power cycle hook
  profile::DriveProfile profile_;
};

TEST_F(PpHomingKeptTest, OldVectorTrustsTheEarlierHomingAndMisjudgesTheDrive) {
  // Given a first run of the vector that homes, moves the axis to 1000 and passes
  const Vector now = shipped(kVector);
  // When the vector as it was runs next, the drive still showing that homing
  const RunResult result = run({now, without_range_polls(now)});
  // Then it fails the conformant drive: 6064h read at the old position, outside [-10, 10]
  ASSERT_EQ(result.vectors.size(), 2U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << result.vectors[0].message;
  EXPECT_EQ(result.vectors[1].verdict, Verdict::fail) << result.vectors[1].message;
  EXPECT_NE(result.vectors[1].message.find("6064h"), std::string::npos)
      << result.vectors[1].message;
}

TEST_F(PpHomingKeptTest, VectorWaitsForItsOwnHoming) {
  // Given the same first run
  const Vector now = shipped(kVector);
  // When the vector as it is now runs next
  const RunResult result = run({now, now});
  // Then it waits until its homing has put 6064h into [-10, 10] and passes
  ASSERT_EQ(result.vectors.size(), 2U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << result.vectors[0].message;
  EXPECT_EQ(result.vectors[1].verdict, Verdict::pass) << result.vectors[1].message;
}

TEST_F(PpHomingKeptTest, EveryHomingPpVectorPassesTwiceInARow) {
  // Given every pp vector that homes with method 35 and polls 6064h into its window
  const auto set = load_vector_file(std::string(DRIVECHECK_VECTORS_DIR) + "/cia402/pp.yaml");
  ASSERT_TRUE(set.ok());
  std::vector<Vector> vectors;
  for (const auto& vector : set.vectors) {
    const bool polls = std::any_of(vector.steps.begin(), vector.steps.end(), [](const Step& s) {
      const auto* poll = std::get_if<PollStep>(&s.action);
      return poll != nullptr && poll->range.has_value();
    });
    if (polls) vectors.push_back(vector);
  }
  ASSERT_GE(vectors.size(), 12U);
  // When they run one after the other, each after a homing the drive keeps
  const RunResult result = run(vectors);
  // Then each passes or is not applicable (it needs the simulator's inputs)
  for (const auto& v : result.vectors) {
    EXPECT_TRUE(v.verdict == Verdict::pass || v.verdict == Verdict::not_applicable)
        << v.id << ": " << v.message;
  }
}

}  // namespace
}  // namespace drivecheck::conformance
