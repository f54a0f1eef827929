// Fair timing (vectors/FORMAT.md "Timing"): the engine judges a DUT's reaction by frame
// timestamps, measured from the request's actual send time (its loopback echo), and says
// `error: harness late` instead of failing when the harness itself was late. The bus is a
// ManualBus whose delivery or transmission is late while the timestamps tell the truth.
#include <gtest/gtest.h>

#include <string>

#include "conformance/engine.hpp"
#include "conformance/vector_file.hpp"
#include "tests/can/manual_bus.hpp"

namespace drivecheck::conformance {
namespace {

using namespace std::chrono_literals;
using can::TimePoint;

profile::DriveProfile make_profile() {
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [heartbeat.consumer]\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return *parsed;
}

// A vector without setup (nothing boots on a ManualBus), with `steps` (YAML, indented 4).
Vector make_vector(const std::string& steps) {
  const auto set = parse_vectors(
      "- id: t/x\n  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n  steps:\n" +
          steps,
      "t.yaml");
  EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
  return set.vectors.empty() ? Vector{} : set.vectors.front();
}

const can::Frame kAnswer = *can::parse_candump("181#00");
const std::string kAsk =
    "    - send: \"123#01\"\n    - expect_frame: \"181#00\"\n      within: 5ms\n";

VectorResult run(test_support::ManualBus& bus, const Vector& vector) {
  const auto profile = make_profile();
  Engine engine(bus, profile, EngineOptions{});
  return engine.run_vector(vector);
}

TEST(FairTiming, AnswerReadLateButStampedInTimePasses) {
  // Given a DUT that answers 1 ms after the request, and a harness descheduled for 10 ms right
  // after it sent the request (it reads the answer only then)
  test_support::ManualBus bus;
  bus.set_send_lag(10ms);
  bus.inject(kAnswer, TimePoint{} + 1ms);
  // When the vector expects the answer within 5 ms
  const auto result = run(bus, make_vector(kAsk));
  // Then it passes: the answer's timestamp is 1 ms after the request
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
}

TEST(FairTiming, WindowStartsAtTheRequestsActualSendTime) {
  // Given a request that leaves the transmit queue 20 ms after send() (its echo says so) and a
  // DUT that answers 2 ms after that
  test_support::ManualBus bus;
  bus.set_echo_delay(20ms);
  bus.inject(kAnswer, TimePoint{} + 22ms);
  // When the vector expects the answer within 5 ms
  const auto result = run(bus, make_vector(kAsk));
  // Then it passes: 2 ms after the request went out
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
}

TEST(FairTiming, TimingFailureAfterALateRequestIsAHarnessError) {
  // Given the same late request (out at 20 ms, beyond $timing.harness_slack) and a DUT that
  // answers 10 ms after it
  test_support::ManualBus bus;
  bus.set_echo_delay(20ms);
  bus.inject(kAnswer, TimePoint{} + 30ms);
  // When the vector expects the answer within 5 ms
  const auto result = run(bus, make_vector(kAsk));
  // Then the harness says it was late (error, not charged to the device)
  EXPECT_EQ(result.verdict, Verdict::error) << result.message;
  EXPECT_NE(result.message.find("harness late"), std::string::npos) << result.message;
}

TEST(FairTiming, SlowAnswerToAnOnTimeRequestFails) {
  // Given a request that goes out at once and a DUT that answers after 10 ms
  test_support::ManualBus bus;
  bus.inject(kAnswer, TimePoint{} + 10ms);
  // When the vector expects the answer within 5 ms
  const auto result = run(bus, make_vector(kAsk));
  // Then it fails: the device was late, not the harness
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  EXPECT_EQ(result.message.find("harness late"), std::string::npos) << result.message;
}

TEST(FairTiming, HarnessLateHeartbeatIsAnErrorNotAFailure) {
  // Given a heartbeat the vector sends that leaves 20 ms late, and a DUT that reacts to the
  // gap with an EMCY at 30 ms
  const std::string steps =
      "    - send: \"77D#05\"\n    - expect_silence: [\"081\"]\n      for: 50ms\n";
  test_support::ManualBus late_bus;
  late_bus.set_echo_delay(20ms);
  late_bus.inject(*can::parse_candump("081#3081110000000000"), TimePoint{} + 30ms);
  // When the vector wants no EMCY
  const auto late = run(late_bus, make_vector(steps));
  // Then the verdict is error: harness late, naming the late frame
  EXPECT_EQ(late.verdict, Verdict::error) << late.message;
  EXPECT_NE(late.message.find("error: harness late"), std::string::npos) << late.message;
  EXPECT_NE(late.message.find("77D#05"), std::string::npos) << late.message;
  ASSERT_FALSE(late.checks.empty());
  EXPECT_NE(late.checks.back().actual.find("error: harness late"), std::string::npos);
  // And with the heartbeat on time the same EMCY fails the DUT
  test_support::ManualBus bus;
  bus.inject(*can::parse_candump("081#3081110000000000"), TimePoint{} + 30ms);
  const auto on_time = run(bus, make_vector(steps));
  EXPECT_EQ(on_time.verdict, Verdict::fail) << on_time.message;
}

}  // namespace
}  // namespace drivecheck::conformance
