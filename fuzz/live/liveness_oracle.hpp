// The live fuzzer's liveness oracle: is the node still alive and well after a case?
//
// Fed the frames the harness sees and the outcome of its probes, never the bus itself (pure,
// testable without a device). One check per case, in three phases:
//
//   begin_case(t)      the case's frames go out; boot-ups and EMCYs are noted
//   begin_observation  after the case (and after the harness's NMT reset communication when the
//                      case needed one, see case_generator.hpp): a window of at least
//                      ObservationConfig::window, at least 2.5 heartbeat periods
//   end_observation    with the result of the SDO ping (read 1000h, after an SDO abort that
//                      closes any transfer the case left open) and of the guarding request
//
// Anomalies, most specific first (verdict() reports one):
//   babbling            the node sent more than babble_limit frames/s in the window
//   device-silent       no SDO answer and not one frame from the node in the window
//   sdo-no-answer       no SDO answer, but the node sends other frames (heartbeat, guarding)
//   no-boot-up          the harness reset the node and no boot-up came (CiA 301 §7.2.8.3.2.1)
//   unexpected-boot-up  a boot-up that no NMT reset asked for: the device reset itself
//   heartbeat-lost      a heartbeat producer (1017h > 0 at start) sent none in the window
//   guarding-lost       a node that answered guarding at start did not answer it
// EMCY frames (80h+N) are no anomaly by themselves; they are counted and logged.
//
// Frame layouts (CiA 301): boot-up 700h+N DLC 1 data 00h; heartbeat 700h+N DLC 1 data = NMT
// state (04h stopped, 05h operational, 7Fh pre-operational); guarding answer 700h+N DLC 1
// data = t(bit 7) | state; EMCY 80h+N DLC 8 error code(2) error register(1) vendor(5).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/bus.hpp"

namespace drivecheck::fuzz_live {

enum class AnomalyKind : std::uint8_t {
  babbling,
  device_silent,
  sdo_no_answer,
  no_boot_up,
  unexpected_boot_up,
  heartbeat_lost,
  guarding_lost,
};
std::string_view to_string(AnomalyKind kind);  // "babbling", "device-silent", ...
std::optional<AnomalyKind> anomaly_kind_from_string(std::string_view text);

struct Anomaly {
  AnomalyKind kind = AnomalyKind::device_silent;
  std::string detail;
};

struct OracleConfig {
  std::uint8_t node = 1;
  can::Duration heartbeat_period{0};  // 1017h at start; 0: not checked
  bool guarding = false;              // the node answered a guarding request at start
  double babble_limit = 2000.0;       // frames per second from the node
};

class LivenessOracle {
 public:
  explicit LivenessOracle(OracleConfig config) : config_(config) {}

  void begin_case(can::TimePoint now);
  // The harness sent an NMT reset to the node: one boot-up is expected.
  void expect_boot_up() { boot_up_expected_ = true; }
  // Every frame the harness receives (its own frames are ignored).
  void on_frame(const can::TimedFrame& frame);
  void begin_observation(can::TimePoint now);
  // `sdo_answered`: the ping got an SDO response (upload response or abort);
  // `guarding_answered`: only read when OracleConfig::guarding.
  void end_observation(can::TimePoint now, bool sdo_answered, bool guarding_answered);

  std::optional<Anomaly> verdict() const;

  // Since begin_case.
  std::size_t emcy_frames() const { return emcy_; }
  std::size_t boot_ups() const { return boot_ups_; }
  const std::vector<can::Frame>& emcys() const { return emcy_list_; }
  // The observation window's length (the caller waits at least this long): 2.5 heartbeat
  // periods, at least 100 ms, at most kMaxWindow.
  can::Duration window() const;
  // The cap on window(), independent of 1017h: a case that set the producer time to FFFFh
  // (65.5 s), which a communication reset need not undo, must not make every later case wait
  // 164 s. A window shorter than 2.5 periods does not require a heartbeat (the SDO answer and
  // the other checks still judge the node).
  static constexpr can::Duration kMaxWindow = std::chrono::seconds(2);
  // After the harness reset the node's communication: 1017h as it reads now (guarding is only
  // checked while the heartbeat is off, CiA 301 §7.2.8.3.2).
  void set_heartbeat_period(can::Duration period, bool guarding) {
    config_.heartbeat_period = period;
    config_.guarding = guarding;
  }
  const OracleConfig& config() const { return config_; }

 private:
  OracleConfig config_;
  bool boot_up_expected_ = false;
  bool observing_ = false;
  bool observed_ = false;
  can::TimePoint observation_start_{};
  can::TimePoint observation_end_{};
  std::size_t node_frames_ = 0;  // in the window
  std::size_t heartbeats_ = 0;   // in the window
  std::size_t boot_ups_ = 0;
  std::size_t emcy_ = 0;
  std::vector<can::Frame> emcy_list_;  // the first few, for the log
  bool sdo_answered_ = true;
  bool guarding_answered_ = true;
};

}  // namespace drivecheck::fuzz_live
