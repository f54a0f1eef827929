// The dead-harness guarantee, tested for real (issue "Catch what the standard forbids" §2):
// `drivecheck run --allow-motion` makes itself a heartbeat producer and the drive a consumer of
// it (1016h sub 1 = 3 harness periods), so that a harness that dies in the middle of a motion
// vector stops the motor through the drive's own reaction (CiA 301 §7.2.8.3.2.2 heartbeat
// event, then CiA 402-2 6007h abort connection option code: 1 fault, 2 disable voltage,
// 3 quick stop). This program kills `drivecheck run` with SIGKILL against `drivecheck drive` on
// vcan0 and judges from the bus what the drive did:
//   - the drive leaves Operation enabled within three harness heartbeat periods of the kill
//     (statusword polled by SDO once the harness is gone: an upper bound on the moment);
//   - the state it ends in is the one its 6007h names;
//   - the trace (a candump log, printed around the kill) shows the last harness heartbeat.
// The same observation against the drive with the named deviation `abort-connection-ignored`
// must fail: the check can fail. Runs inside the test VM (tests/vm/run-in-vm with --extra
// <drivecheck> and the vector tree as --data); outside it, pass --drivecheck=PATH,
// --vectors=DIR and have vcan0.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "protocol/can/candump_log.hpp"
#include "protocol/can/socketcan_bus.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "tests/vm/drive_process.hpp"

namespace drivecheck::vm {
namespace {

using namespace std::chrono_literals;

constexpr const char* kInterface = "vcan0";
constexpr std::uint8_t kNode = 1;
// EngineOptions::harness_node: the harness's heartbeat producer id on a real bus.
constexpr std::uint32_t kHarnessHeartbeatId = 0x700 + 127;
// The motion vector the harness dies in: profile velocity, accelerates to 1000 and back.
constexpr const char* kMotionVector = "cia402/pv/velocity/deceleration-ramp";

std::string g_drivecheck = "drivecheck";
std::string g_vectors;

bool operation_enabled(std::uint16_t statusword) {
  return (statusword & 0x006F) == 0x0027;  // CiA 402-2 statusword coding of the FSA states
}

// An expedited upload response of 6041h sub 0 from the drive: its statusword.
std::optional<std::uint16_t> statusword_in(const can::Frame& frame) {
  if (frame.id != 0x580U + kNode || frame.length() < 6) return std::nullopt;
  const auto& d = frame.data;
  if ((d[0] & 0xE3) != 0x43 || d[1] != 0x41 || d[2] != 0x60 || d[3] != 0x00) return std::nullopt;
  return static_cast<std::uint16_t>(d[4] | d[5] << 8);
}

// The harness commanding a nonzero target velocity (expedited download of 60FFh): motion.
bool motion_command(const can::Frame& frame) {
  if (frame.id != 0x600U + kNode || frame.length() != 8) return false;
  const auto& d = frame.data;
  return (d[0] & 0xE3) == 0x23 && d[1] == 0xFF && d[2] == 0x60 && d[3] == 0x00 &&
         (d[4] | d[5] | d[6] | d[7]) != 0;
}

struct Observation {
  std::string failure_to_start;  // non-empty: the experiment could not be made
  can::TimePoint kill{};         // SIGKILL sent to drivecheck run
  can::TimePoint last_harness_heartbeat{};
  can::Duration harness_period{};      // measured between the harness's heartbeats
  std::optional<can::TimePoint> left;  // first statusword read outside Operation enabled
  std::optional<std::uint16_t> final_statusword;
  std::optional<std::uint8_t> abort_connection_option;  // 6007h
  std::size_t heartbeats_after_kill = 0;
  std::vector<can::TimedFrame> trace;
  std::string trace_file;
};

// What the guarantee demands of an observation; the reason when it is not met.
std::optional<std::string> judge(const Observation& o) {
  if (!o.failure_to_start.empty()) return "no observation: " + o.failure_to_start;
  if (o.heartbeats_after_kill != 0)
    return fmt::format("{} harness heartbeats after SIGKILL", o.heartbeats_after_kill);
  const auto bound = 3 * o.harness_period;
  if (!o.left) {
    return fmt::format(
        "the drive was still in Operation enabled {} ms after the harness died (bound: three "
        "harness heartbeat periods, {} ms; last statusword {:04X}h)",
        std::chrono::duration_cast<std::chrono::milliseconds>(
            o.trace.empty() ? can::Duration{} : o.trace.back().timestamp - o.kill)
            .count(),
        std::chrono::duration_cast<std::chrono::milliseconds>(bound).count(),
        o.final_statusword.value_or(0));
  }
  if (*o.left - o.kill > bound) {
    return fmt::format(
        "the drive left Operation enabled {} ms after the harness died: more than three harness "
        "heartbeat periods ({} ms)",
        std::chrono::duration_cast<std::chrono::milliseconds>(*o.left - o.kill).count(),
        std::chrono::duration_cast<std::chrono::milliseconds>(bound).count());
  }
  if (!o.final_statusword || !o.abort_connection_option)
    return "6041h or 6007h could not be read after the reaction";
  const std::uint16_t sw = *o.final_statusword;
  const bool fault = (sw & 0x004F) == 0x0008 || (sw & 0x004F) == 0x000F;
  const bool switch_on_disabled = (sw & 0x004F) == 0x0040;
  const bool quick_stop_active = (sw & 0x006F) == 0x0007;
  bool as_named = false;
  switch (*o.abort_connection_option) {
    case 1:
      as_named = fault;
      break;  // malfunction: fault
    case 2:
      as_named = switch_on_disabled;
      break;  // disable voltage
    case 3:
      as_named = quick_stop_active || switch_on_disabled;
      break;  // quick stop (605Ah)
    default:
      as_named = !operation_enabled(sw);
      break;  // manufacturer-specific (negative)
  }
  if (!as_named) {
    return fmt::format("6007h = {} names another reaction than the state reached (6041h = {:04X}h)",
                       *o.abort_connection_option, sw);
  }
  return std::nullopt;
}

class DeadHarness : public ::testing::Test {
 protected:
  void TearDown() override {
    if (run_) run_->stop(SIGKILL, 1000ms);
    if (drive_) drive_->stop(SIGTERM, 3000ms);
    std::remove(store_.c_str());
  }

  // Drains the recording socket into the trace (non-blocking), and returns what came.
  std::vector<can::TimedFrame> drain(Observation& o) {
    std::vector<can::TimedFrame> frames;
    while (auto timed = recorder_->receive(recorder_->now())) {
      o.trace.push_back(*timed);
      frames.push_back(*timed);
    }
    return frames;
  }

  Observation observe(const std::vector<std::string>& drive_options) {
    Observation o;
    store_ = (std::filesystem::temp_directory_path() /
              fmt::format("dead-harness-{}-{}.txt", ::getpid(), ++runs_))
                 .string();
    std::remove(store_.c_str());
    can::SocketCanOptions options;
    options.receive_buffer_bytes = 4 << 20;
    auto recorder = can::SocketCanBus::open(kInterface, options);
    if (!recorder) {
      o.failure_to_start = can::describe_open_error(kInterface, recorder.error());
      return o;
    }
    recorder_ = std::move(*recorder);

    std::string error;
    std::vector<std::string> drive_args{"drive",
                                        "--bus",
                                        fmt::format("socketcan:{}", kInterface),
                                        "--node",
                                        std::to_string(kNode),
                                        "--store",
                                        store_};
    drive_args.insert(drive_args.end(), drive_options.begin(), drive_options.end());
    drive_ = DriveProcess::start(g_drivecheck, drive_args, error);
    if (!drive_) {
      o.failure_to_start = error;
      return o;
    }
    const auto booted = [&] {
      const auto deadline = recorder_->now() + 5s;
      while (auto timed = recorder_->receive(deadline)) {
        o.trace.push_back(*timed);
        if (timed->frame.id == 0x700U + kNode && timed->frame.length() == 1 &&
            timed->frame.data[0] == 0)
          return true;
      }
      return false;
    }();
    if (!booted) {
      o.failure_to_start = "no boot-up message from drivecheck drive";
      return o;
    }

    // The harness, with motion allowed (it may move: the reference drive's simulated axis).
    run_ = DriveProcess::start(
        g_drivecheck,
        {"run", "--bus", fmt::format("socketcan:{}", kInterface), "--node", std::to_string(kNode),
         "--profile", "cia402-reference", "--allow-motion", "--allow-factory-restore", "--filter",
         kMotionVector, "--json",
         (std::filesystem::temp_directory_path() / fmt::format("dead-harness-run-{}.json", runs_))
             .string()},
        error);
    if (!run_) {
      o.failure_to_start = error;
      return o;
    }

    // Wait for the motion command, then for the next harness heartbeat; kill the harness half
    // a period after it, so the drive's consumer time (3 periods from that heartbeat) ends
    // 2.5 periods after the kill.
    std::vector<can::TimePoint> heartbeats;
    bool moving = false;
    std::optional<can::TimePoint> heartbeat_after_motion;
    const auto give_up = recorder_->now() + 60s;
    // Two heartbeats at least, so that the period can be measured.
    while ((!heartbeat_after_motion || heartbeats.size() < 2) && recorder_->now() < give_up) {
      auto timed = recorder_->receive(recorder_->now() + 100ms);
      if (!timed) continue;
      o.trace.push_back(*timed);
      if (motion_command(timed->frame)) moving = true;
      if (timed->frame.id == kHarnessHeartbeatId) {
        heartbeats.push_back(timed->timestamp);
        if (moving && (!heartbeat_after_motion || heartbeats.size() <= 2))
          heartbeat_after_motion = timed->timestamp;
      }
    }
    if (!heartbeat_after_motion || heartbeats.size() < 2) {
      o.failure_to_start = fmt::format(
          "the harness never reached the motion of {} with its heartbeat running ({} harness "
          "heartbeats seen, motion command {})",
          kMotionVector, heartbeats.size(), moving ? "seen" : "not seen");
      return o;
    }
    std::vector<can::Duration> gaps;
    for (std::size_t i = 1; i < heartbeats.size(); ++i)
      gaps.push_back(heartbeats[i] - heartbeats[i - 1]);
    std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
    o.harness_period = gaps[gaps.size() / 2];
    o.last_harness_heartbeat = *heartbeat_after_motion;
    const auto kill_at = *heartbeat_after_motion + o.harness_period / 2;
    while (recorder_->now() < kill_at) {
      if (auto timed = recorder_->receive(kill_at)) {
        o.trace.push_back(*timed);
        if (timed->frame.id == kHarnessHeartbeatId) o.last_harness_heartbeat = timed->timestamp;
      }
    }
    o.kill = recorder_->now();
    run_->stop(SIGKILL, 1000ms);
    run_.reset();

    // The harness is gone: this process reads the statusword, every few milliseconds.
    auto opened = can::SocketCanBus::open(kInterface);
    if (!opened) {
      o.failure_to_start = can::describe_open_error(kInterface, opened.error());
      return o;
    }
    auto poller = std::move(*opened);
    cia301::SdoClientOptions sdo_options;
    sdo_options.timeout = 50ms;
    cia301::SdoClient sdo(*poller, kNode, sdo_options);
    const auto observe_until = o.kill + 3 * o.harness_period + 500ms;
    while (poller->now() < observe_until) {
      if (const auto sw = sdo.upload_value<std::uint16_t>({0x6041, 0})) o.final_statusword = *sw;
      for (const auto& timed : drain(o)) {
        if (timed.timestamp <= o.kill) continue;
        if (timed.frame.id == kHarnessHeartbeatId) ++o.heartbeats_after_kill;
        const auto sw = statusword_in(timed.frame);
        if (sw && !operation_enabled(*sw) && !o.left) o.left = timed.timestamp;
      }
      if (o.left) break;
      std::this_thread::sleep_for(2ms);
    }
    // Where the drive ends (its reaction may take a ramp), and what its 6007h names.
    std::this_thread::sleep_for(1s);
    if (const auto sw = sdo.upload_value<std::uint16_t>({0x6041, 0})) o.final_statusword = *sw;
    if (const auto code = sdo.upload_value<std::int16_t>({0x6007, 0}))
      o.abort_connection_option = static_cast<std::uint8_t>(*code);
    drain(o);

    o.trace_file =
        (std::filesystem::temp_directory_path() / fmt::format("dead-harness-{}.log", runs_))
            .string();
    std::ofstream log(o.trace_file);
    for (const auto& timed : o.trace) {
      can::LogRecord record;
      record.timestamp = can::to_unix_time(timed.timestamp, recorder_->unix_offset());
      record.interface = kInterface;
      record.frame = timed.frame;
      log << can::to_candump_log(record) << '\n';
    }
    return o;
  }

  // The trace from one heartbeat period before the last harness heartbeat to the end of the
  // reaction, with times relative to the kill.
  static std::string around_the_kill(const Observation& o) {
    std::string text;
    for (const auto& timed : o.trace) {
      if (timed.timestamp < o.last_harness_heartbeat - o.harness_period) continue;
      if (o.left && timed.timestamp > *o.left + 50ms) break;
      text +=
          fmt::format("  {:+8.1f} ms  {}\n",
                      std::chrono::duration<double, std::milli>(timed.timestamp - o.kill).count(),
                      can::to_candump(timed.frame));
    }
    return text;
  }

  std::unique_ptr<can::SocketCanBus> recorder_;
  std::unique_ptr<DriveProcess> drive_;
  std::unique_ptr<DriveProcess> run_;
  std::string store_;
  int runs_ = 0;
};

TEST_F(DeadHarness, DriveLeavesOperationEnabledWithinThreeHeartbeatPeriods) {
  // Given drivecheck drive on vcan0 and `drivecheck run --allow-motion` in a profile velocity
  //       vector, the harness producing its heartbeat and the drive consuming it (1016h)
  // When the harness is killed with SIGKILL half a heartbeat period after a heartbeat
  // Then no harness heartbeat follows, the drive leaves Operation enabled within three harness
  //      heartbeat periods of the kill, and ends in the state its 6007h names
  const Observation o = observe({});
  ASSERT_TRUE(o.failure_to_start.empty()) << o.failure_to_start;
  const auto verdict = judge(o);
  EXPECT_FALSE(verdict) << *verdict << "\ntrace (" << o.trace_file << "), ms from the kill:\n"
                        << around_the_kill(o);
  ASSERT_TRUE(o.left);
  fmt::print(
      "dead harness: harness period {} ms, last heartbeat {:.1f} ms before the kill, Operation "
      "enabled left at most {:.1f} ms after it (bound {} ms); 6007h = {}, 6041h = {:04X}h; trace "
      "{}\n",
      std::chrono::duration_cast<std::chrono::milliseconds>(o.harness_period).count(),
      std::chrono::duration<double, std::milli>(o.kill - o.last_harness_heartbeat).count(),
      std::chrono::duration<double, std::milli>(*o.left - o.kill).count(),
      std::chrono::duration_cast<std::chrono::milliseconds>(3 * o.harness_period).count(),
      o.abort_connection_option.value_or(0), o.final_statusword.value_or(0), o.trace_file);
  fmt::print("{}", around_the_kill(o));
}

TEST_F(DeadHarness, CheckFailsAgainstADriveThatIgnoresTheLoss) {
  // Given the same, with the drive's deviation abort-connection-ignored (a heartbeat loss has
  //       no effect whatever 6007h says)
  // When the harness is killed in the motion vector
  // Then the check above fails: the drive is still in Operation enabled after three periods
  const Observation o = observe({"--deviation", "abort-connection-ignored"});
  ASSERT_TRUE(o.failure_to_start.empty()) << o.failure_to_start;
  const auto verdict = judge(o);
  ASSERT_TRUE(verdict) << "the check passed a drive that ignores the harness's death";
  EXPECT_NE(verdict->find("still in Operation enabled"), std::string::npos) << *verdict;
  fmt::print("dead harness with abort-connection-ignored: {}\n", *verdict);
}

}  // namespace
}  // namespace drivecheck::vm

int main(int argc, char** argv) {
  drivecheck::vm::g_drivecheck = drivecheck::vm::take_drivecheck_path(argc, argv);
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg.rfind("--vectors=", 0) == 0) {
      drivecheck::vm::g_vectors = arg.substr(10);
      ::setenv("DRIVECHECK_VECTORS", drivecheck::vm::g_vectors.c_str(), 1);
      for (int j = i; j + 1 < argc; ++j)
        argv[j] = argv[j + 1];
      --argc;
      --i;
    }
  }
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
