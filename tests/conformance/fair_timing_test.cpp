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

// Three SYNCs sent 20 ms apart (as the harness means to), then the TPDO that follows them,
// and the SYNCs counted on the bus between the mark and the TPDO.
const std::string kEveryThird =
    "    - mark: syncs\n"
    "    - send: \"080#\"\n    - wait: 20ms\n"
    "    - send: \"080#\"\n    - wait: 20ms\n"
    "    - send: \"080#\"\n    - wait: 20ms\n"
    "    - expect_frame: \"1A0#01\"\n      since: syncs\n      within: 1s\n      mark: tpdo\n"
    "    - measure: {from: syncs, to: tpdo, frames: \"080#\", min: 3, max: 3}\n";

TEST(FairTiming, SyncsAreCountedOnTheBusNotInTime) {
  // Given a harness descheduled for 15 ms after each SYNC it sends (SYNCs on the bus at 1, 36
  // and 71 ms instead of 20 ms apart) and a DUT whose TPDO follows the third SYNC at 72 ms
  test_support::ManualBus bus;
  bus.set_echo_delay(1ms);
  bus.set_send_lag(15ms);
  bus.inject(*can::parse_candump("1A0#01"), TimePoint{} + 72ms);
  // When the vector counts the SYNCs before the TPDO
  const auto result = run(bus, make_vector(kEveryThird));
  // Then it passes: three SYNCs were on the bus before it, whatever their spacing
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
}

TEST(FairTiming, WrongSyncCountFailsTheDeviceEvenWhenTheHarnessWasLate) {
  // Given SYNCs that leave 20 ms late (the harness is late: beyond $timing.harness_slack) and
  // a DUT whose TPDO follows the second SYNC
  test_support::ManualBus bus;
  bus.set_echo_delay(20ms);
  bus.inject(*can::parse_candump("1A0#01"), TimePoint{} + 45ms);
  // When the vector counts the SYNCs before the TPDO
  const auto result = run(bus, make_vector(kEveryThird));
  // Then it fails the device: two SYNCs were on the bus before its TPDO, which no lateness of
  // the harness changes (a count, not a timing)
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  EXPECT_EQ(result.message.find("harness late"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("frames matching 080#"), std::string::npos) << result.message;
}

// One SYNC, then at most one frame on 1A0h or 1A1h together (a list of patterns).
const std::string kOneOfTwo =
    "    - mark: s\n"
    "    - send: \"080#\"\n    - wait: 20ms\n"
    "    - mark: e\n"
    "    - measure: {from: s, to: e, frames: [\"1A0#*\", \"1A1#*\"], max: 1}\n";

TEST(FairTiming, FramesOfAListOfPatternsAreCountedTogether) {
  // Given a DUT that sends one frame on 1A0h and one on 1A1h after the SYNC
  test_support::ManualBus bus;
  bus.inject(*can::parse_candump("1A0#01"), TimePoint{} + 2ms);
  bus.inject(*can::parse_candump("1A1#02"), TimePoint{} + 3ms);
  // When the vector allows at most one frame matching either pattern
  const auto result = run(bus, make_vector(kOneOfTwo));
  // Then it fails: two frames matched the list, and the message names both patterns
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  EXPECT_NE(result.message.find("1A0#* or 1A1#*"), std::string::npos) << result.message;
  // And one frame on either COB-ID alone passes
  test_support::ManualBus one;
  one.inject(*can::parse_candump("1A1#02"), TimePoint{} + 3ms);
  EXPECT_EQ(run(one, make_vector(kOneOfTwo)).verdict, Verdict::pass);
}

// 21 frames on 1A0h at `period` apart, each `jitter` late or early in turn (not adding up).
void inject_periodic(test_support::ManualBus& bus, can::Duration period, can::Duration jitter) {
  for (int n = 0; n < 21; ++n) {
    const auto offset = n % 2 == 0 ? jitter : -jitter;
    bus.inject(*can::parse_candump("1A0#01"), TimePoint{} + 5ms + n * period + offset);
  }
}

const std::string kAveragePeriod =
    "    - expect_periodic: \"1A0\"\n      period: 10ms\n      tolerance: 10ms\n"
    "      count: 21\n      mark: first\n      last: last\n"
    "    - measure: {from: first, to: last, min: 180ms, max: 220ms}\n";

TEST(FairTiming, AveragePeriodIgnoresOneFramesJitter) {
  // Given a 10 ms timer whose frames go out 4 ms late or early in turn (bus arbitration, a
  // late task), never adding up
  test_support::ManualBus bus;
  inject_periodic(bus, 10ms, 4ms);
  // When the vector measures the average period over 20 periods
  const auto result = run(bus, make_vector(kAveragePeriod));
  // Then it passes: the timer holds 10 ms
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
}

TEST(FairTiming, AveragePeriodCatchesASlowTimer) {
  // Given a timer that runs at 12 ms instead of 10 ms, without jitter
  test_support::ManualBus bus;
  inject_periodic(bus, 12ms, 0ms);
  // When the vector measures the average period over 20 periods
  const auto result = run(bus, make_vector(kAveragePeriod));
  // Then it fails: 20 periods take 240 ms
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  EXPECT_NE(result.message.find("first → last"), std::string::npos) << result.message;
}

}  // namespace
}  // namespace drivecheck::conformance
