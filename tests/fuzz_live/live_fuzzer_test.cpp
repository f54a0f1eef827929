#include "fuzz/live/live_fuzzer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/store_restore.hpp"
#include "reference_drive/deviations.hpp"
#include "reference_drive/servo_drive.hpp"

namespace drivecheck::fuzz_live {
namespace {

using namespace std::chrono_literals;

constexpr std::uint8_t kNode = 4;

// The reference servo drive on a simulated bus; power_cycle() builds both anew.
class ServoTarget final : public Target {
 public:
  // `storage`: where 1010h saves to, kept across power cycles (nullptr: the drive's own memory,
  // lost at each power cycle).
  explicit ServoTarget(std::vector<std::string> deviations,
                       cia301::ParameterStorage* storage = nullptr)
      : deviations_(std::move(deviations)), storage_(storage) {
    EXPECT_TRUE(power_cycle());
  }
  can::Bus& port() override { return *port_; }
  bool power_cycle() override {
    drive_.reset();  // before the port it talks through
    drive_port_.reset();
    port_.reset();
    bus_ = std::make_unique<can::SimBus>(can::SimBusConfig{.bitrate = 1'000'000, .seed = 1});
    port_ = bus_->attach("harness");
    drive_port_ = bus_->attach("drive");
    auto parsed = reference_drive::DeviationSet::parse(deviations_);
    if (!parsed) return false;
    reference_drive::ServoDriveOptions options;
    options.node = kNode;
    options.deviations = std::move(*parsed);
    options.storage = storage_;
    auto drive = reference_drive::ServoDrive::create(*drive_port_, std::move(options));
    if (!drive) return false;
    drive_ = std::move(*drive);
    drive_->power_on();
    ++power_cycles_;
    return true;
  }
  std::string interface_name() const override { return "sim"; }
  int power_cycles() const { return power_cycles_; }

 private:
  std::vector<std::string> deviations_;
  cia301::ParameterStorage* storage_ = nullptr;
  std::unique_ptr<can::SimBus> bus_;
  std::unique_ptr<can::SimPort> port_;
  std::unique_ptr<can::SimPort> drive_port_;
  std::unique_ptr<reference_drive::ServoDrive> drive_;
  int power_cycles_ = 0;
};

std::filesystem::path fresh_dir(const std::string& name) {
  const auto dir = std::filesystem::path(::testing::TempDir()) / ("fuzz_live_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

LiveFuzzerOptions options_for(const std::filesystem::path& out, can::Duration duration) {
  LiveFuzzerOptions options;
  options.node = kNode;
  options.seed = 1;
  options.duration = duration;
  options.out_dir = out;
  return options;
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(LiveFuzzer, StandardDriveShowsNoAnomaly) {
  // Given the conformant reference drive
  // When it is fuzzed for 15 s of simulated time
  // Then many cases run and nothing is found
  ServoTarget target({});
  const auto summary = run_live_fuzzer(target, options_for(fresh_dir("standard"), 15s));
  EXPECT_EQ(summary.outcome, FuzzOutcome::clean);
  EXPECT_GT(summary.cases_run, 40U);
  for (const auto& a : summary.anomalies)
    ADD_FAILURE() << "case " << a.case_number << " " << a.case_kind << ": " << a.anomaly.detail;
  EXPECT_GE(summary.elapsed, 15s);
}

TEST(LiveFuzzer, DeviceTypeLineNamesTheProfileOf1000h) {
  // Given the reference drive (1000h names CiA 402), fuzzed as if it were no drive
  ServoTarget target({});
  auto options = options_for(fresh_dir("device_type"), 1s);
  options.cia402 = false;
  std::vector<std::string> lines;
  options.progress = [&lines](std::string_view line) { lines.emplace_back(line); };
  // When the fuzzer starts
  (void)run_live_fuzzer(target, options);
  // Then its device line names the profile 1000h gives, and how the node is fuzzed
  const auto device_line = std::find_if(lines.begin(), lines.end(), [](const std::string& line) {
    return line.find("device type") != std::string::npos;
  });
  ASSERT_NE(device_line, lines.end());
  EXPECT_NE(device_line->find("(CiA 402; not fuzzed as a drive)"), std::string::npos)
      << *device_line;
}

TEST(LiveFuzzer, SdoHangIsFoundMinimisedAndReplayed) {
  // Given a drive whose SDO server hangs on a missing sub-index
  // When it is fuzzed
  // Then sdo-no-answer is found, minimised to a few frames, and the reproducer replays to the
  // same anomaly on a fresh hanging drive but to none on a conformant one
  const auto dir = fresh_dir("hang");
  ServoTarget target({"fatal-sdo-hang-on-missing-sub"});
  auto options = options_for(dir, 30s);
  const auto summary = run_live_fuzzer(target, options);
  ASSERT_EQ(summary.outcome, FuzzOutcome::anomalies);
  ASSERT_FALSE(summary.anomalies.empty());
  const AnomalyRecord& first = summary.anomalies.front();
  EXPECT_EQ(first.anomaly.kind, AnomalyKind::sdo_no_answer);
  ASSERT_TRUE(first.minimised) << first.minimisation_note;
  EXPECT_GE(first.minimised_frames, 1U);
  EXPECT_LE(first.minimised_frames, 5U);
  EXPECT_LE(first.minimised_frames, first.case_frames);
  ASSERT_TRUE(std::filesystem::exists(first.log));
  ASSERT_TRUE(std::filesystem::exists(first.minimised_log));

  const std::string text = read_text(first.minimised_log);
  EXPECT_EQ(reproducer_anomaly(text), AnomalyKind::sdo_no_answer);
  auto records = can::read_candump_log(text);
  ASSERT_TRUE(records) << records.error().to_string();
  ServoTarget hanging({"fatal-sdo-hang-on-missing-sub"});
  const auto replayed = replay_reproducer(hanging, *records, options);
  EXPECT_TRUE(replayed.device_answered);
  EXPECT_EQ(replayed.frames_sent, first.minimised_frames);
  ASSERT_TRUE(replayed.anomaly);
  EXPECT_EQ(replayed.anomaly->kind, AnomalyKind::sdo_no_answer);
  ServoTarget conformant({});
  EXPECT_FALSE(replay_reproducer(conformant, *records, options).anomaly);
}

TEST(LiveFuzzer, SameSeedGivesTheSameRun) {
  // Given a drive that crashes on an invalid SDO command specifier
  // When it is fuzzed twice with the same seed for 80 cases
  // Then both runs find the same anomalies in the same cases
  const auto run = [](const std::string& name) {
    ServoTarget target({"fatal-crash-on-invalid-command"});
    auto options = options_for(fresh_dir(name), 1h);
    options.max_cases = 80;
    return run_live_fuzzer(target, options);
  };
  const auto a = run("seed_a");
  const auto b = run("seed_b");
  EXPECT_EQ(a.cases_run, 80U);
  EXPECT_EQ(a.cases_run, b.cases_run);
  EXPECT_EQ(a.elapsed, b.elapsed);
  EXPECT_EQ(a.cases_by_kind, b.cases_by_kind);
  ASSERT_EQ(a.anomalies.size(), b.anomalies.size());
  ASSERT_FALSE(a.anomalies.empty());
  for (std::size_t i = 0; i < a.anomalies.size(); ++i) {
    EXPECT_EQ(a.anomalies[i].case_number, b.anomalies[i].case_number);
    EXPECT_EQ(a.anomalies[i].anomaly.kind, b.anomalies[i].anomaly.kind);
    EXPECT_EQ(a.anomalies[i].reproducer, b.anomalies[i].reproducer);
  }
  EXPECT_EQ(a.anomalies.front().anomaly.kind, AnomalyKind::device_silent);
}

// Expedited SDO exchange on the harness port: the answer's 8 bytes, or nullopt.
std::optional<can::Frame> sdo(can::Bus& port, std::initializer_list<std::uint8_t> request) {
  (void)port.send(can::Frame::standard(0x600 + kNode, request));
  const can::TimePoint deadline = port.now() + 100ms;
  while (auto frame = port.receive(deadline)) {
    if (frame->frame.id == 0x580U + kNode) return frame->frame;
  }
  return std::nullopt;
}

std::uint16_t statusword(can::Bus& port) {
  // ccs=2 initiate upload, index 6041h sub 0
  const auto answer = sdo(port, {0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0});
  return answer ? static_cast<std::uint16_t>(answer->data[4] | (answer->data[5] << 8)) : 0xFFFF;
}

TEST(LiveFuzzer, DriveFoundInOperationEnabledIsStoppedFirst) {
  // Given the reference drive brought to OPERATION ENABLED (controlword 0006h, 0007h, 000Fh)
  // When the fuzzer runs one case without --allow-motion
  // Then it notes that it stopped the drive, and the drive ends in SWITCH ON DISABLED
  ServoTarget target({});
  can::Bus& port = target.port();
  port.run_for(50ms);
  for (std::uint8_t command : {0x06, 0x07, 0x0F}) {
    // ccs=1 e=1 s=1 n=2, index 6040h sub 0, controlword
    ASSERT_TRUE(sdo(port, {0x2B, 0x40, 0x60, 0x00, command, 0x00, 0, 0}));
    port.run_for(20ms);
  }
  ASSERT_EQ(statusword(port) & 0x006F, 0x0027) << "operation enabled";
  auto options = options_for(fresh_dir("enabled"), 1h);
  options.max_cases = 1;
  const auto summary = run_live_fuzzer(target, options);
  EXPECT_TRUE(summary.cia402);
  ASSERT_FALSE(summary.notes.empty());
  EXPECT_NE(summary.notes.front().find("Operation Enabled at the start"), std::string::npos);
  port.run_for(50ms);
  EXPECT_EQ(statusword(target.port()) & 0x004F, 0x0040) << "switch on disabled";
}

TEST(LiveFuzzer, HeartbeatSetAtRunTimeIsFollowedAcrossResets) {
  // Given the standard drive made a 30 ms heartbeat producer at run time (1017h, not stored:
  // an NMT reset communication brings back 0)
  // When it is fuzzed for 20 s (cases with NMT commands make the fuzzer reset it)
  // Then the fuzzer saw the heartbeat at the start, and finds nothing: the period it checks
  // follows the reset
  ServoTarget target({});
  can::Bus& port = target.port();
  port.run_for(50ms);
  // ccs=1 e=1 s=1 n=2, index 1017h sub 0, 30 ms
  ASSERT_TRUE(sdo(port, {0x2B, 0x17, 0x10, 0x00, 30, 0x00, 0, 0}));
  auto options = options_for(fresh_dir("heartbeat"), 20s);
  const auto summary = run_live_fuzzer(target, options);
  EXPECT_EQ(summary.heartbeat_period, 30ms);
  EXPECT_GT(summary.cases_by_kind.at("nmt"), 0U);
  EXPECT_EQ(summary.outcome, FuzzOutcome::clean);
  for (const auto& a : summary.anomalies)
    ADD_FAILURE() << "case " << a.case_number << " " << a.case_kind << ": " << a.anomaly.detail;
}

// The drive of issue 19's report: 1017h = FFFFh (65.5 s), saved (1010h sub 2, communication
// parameters), so that neither NMT reset communication nor a power cycle undoes it. Every
// observation window wants 2.5 periods (capped at LivenessOracle::kMaxWindow) and every reset
// brings the period back.
void store_long_heartbeat(can::Bus& port) {
  port.run_for(50ms);
  // ccs=1 e=1 s=1 n=2, index 1017h sub 0, FFFFh
  ASSERT_TRUE(sdo(port, {0x2B, 0x17, 0x10, 0x00, 0xFF, 0xFF, 0, 0}));
  // ccs=1 e=1 s=1 n=0, index 1010h sub 2, "save" (73 61 76 65)
  const auto saved = sdo(port, {0x23, 0x10, 0x10, 0x02, 0x73, 0x61, 0x76, 0x65});
  ASSERT_TRUE(saved);
  ASSERT_EQ(saved->data[0], 0x60) << "save refused";
}

// What may pass the end of the run: the final safe stop of a CiA 402 drive, two SDO writes of
// at most sdo_timeout (100 ms) each when the drive does not answer (live_fuzzer.hpp).
constexpr can::Duration kOverrunMargin = 250ms;

TEST(LiveFuzzer, DurationIsHonouredAgainstALongStoredHeartbeat) {
  // Given the standard drive with a stored 1017h of FFFFh (65.5 s): windows of 2 s per case
  cia301::MemoryParameterStorage storage;
  ServoTarget target({}, &storage);
  store_long_heartbeat(target.port());
  ASSERT_TRUE(target.power_cycle());
  // When it is fuzzed for 9 s (the start probe already counts)
  auto options = options_for(fresh_dir("long_heartbeat"), 9s);
  const auto summary = run_live_fuzzer(target, options);
  // Then it saw the 65.5 s heartbeat, ran cases, found nothing, and ended within 9 s + margin
  EXPECT_EQ(summary.heartbeat_period, 65535ms);
  EXPECT_GT(summary.cases_run, 0U);
  EXPECT_EQ(summary.outcome, FuzzOutcome::clean);
  ::testing::Test::RecordProperty("elapsed_us", std::to_string(summary.elapsed.count() / 1000));
  EXPECT_GE(summary.elapsed, 9s);
  EXPECT_LE(summary.elapsed, 9s + kOverrunMargin)
      << "overrun "
      << std::chrono::duration_cast<std::chrono::milliseconds>(summary.elapsed - 9s).count()
      << " ms";
}

TEST(LiveFuzzer, DurationBoundsMinimisationAgainstALongStoredHeartbeat) {
  // Given a drive with a stored 1017h of FFFFh whose SDO server also hangs on a missing
  // sub-index: case 11 (seed 1) makes it device-silent (no SDO answer, and no heartbeat within
  // a 2 s window), and each minimisation try takes 2 s or more
  cia301::MemoryParameterStorage storage;
  ServoTarget target({"fatal-sdo-hang-on-missing-sub"}, &storage);
  store_long_heartbeat(target.port());
  ASSERT_TRUE(target.power_cycle());
  // When it is fuzzed for 24 s: the anomaly comes at about 22 s
  constexpr can::Duration kDuration = 24s;
  const auto summary = run_live_fuzzer(target, options_for(fresh_dir("long_hang"), kDuration));
  // Then the anomaly is found, its minimisation stops at the end of the run, and the run ends
  // within 24 s + margin
  std::string notes;
  for (const auto& note : summary.notes)
    notes += note + "\n";
  ASSERT_FALSE(summary.anomalies.empty()) << summary.cases_run << " cases\n" << notes;
  const AnomalyRecord& first = summary.anomalies.front();
  EXPECT_EQ(first.anomaly.kind, AnomalyKind::device_silent);
  EXPECT_FALSE(first.minimised);
  EXPECT_NE(first.minimisation_note.find("end of --duration"), std::string::npos)
      << first.minimisation_note;
  ::testing::Test::RecordProperty("elapsed_us", std::to_string(summary.elapsed.count() / 1000));
  EXPECT_GE(summary.elapsed, kDuration);
  EXPECT_LE(summary.elapsed, kDuration + kOverrunMargin)
      << "overrun "
      << std::chrono::duration_cast<std::chrono::milliseconds>(summary.elapsed - kDuration).count()
      << " ms";
}

TEST(LiveFuzzer, DurationCountsFromTheStartNotFromTheClockEpoch) {
  // Given a bus whose clock reads 100 s when the fuzzer starts (as CLOCK_MONOTONIC does on a
  // real bus)
  // When it fuzzes for 5 s
  // Then cases run, for about 5 s of bus time
  ServoTarget target({});
  target.port().run_for(100s);
  const auto summary = run_live_fuzzer(target, options_for(fresh_dir("epoch"), 5s));
  EXPECT_GT(summary.cases_run, 10U);
  EXPECT_GE(summary.elapsed, 5s);
  EXPECT_LT(summary.elapsed, 7s);
}

TEST(LiveFuzzer, SilentDeviceAtStartIsLost) {
  // Given a port with no device behind it
  // When the fuzzer starts
  // Then it reports the device lost at the start and runs no case
  class Empty final : public Target {
   public:
    Empty() : bus_(can::SimBusConfig{}), port_(bus_.attach("harness")) {}
    can::Bus& port() override { return *port_; }
    bool power_cycle() override { return false; }
    std::string interface_name() const override { return "sim"; }

   private:
    can::SimBus bus_;
    std::unique_ptr<can::SimPort> port_;
  } target;
  const auto summary = run_live_fuzzer(target, options_for(fresh_dir("empty"), 5s));
  EXPECT_EQ(summary.outcome, FuzzOutcome::device_lost_at_start);
  EXPECT_EQ(summary.cases_run, 0U);
}

}  // namespace
}  // namespace drivecheck::fuzz_live
