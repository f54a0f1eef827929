// Fuzz target: the reference servo drive's CiA 402 side (reference_drive/servo_drive.hpp, built
// as cli/embedded_drive.cpp builds it: node 5 on the simulated bus, the standard drive or, when
// the input starts with a personality record, one of the manuals' personalities):
// controlword, 6060h modes, targets, option codes, the factor group and limits, simulated
// inputs (hardware enable, limit and home switches, mechanical end stops, coasting to rest,
// fault causes), SYNC, NMT and time.
//
// Input: fuzz/support/cia402_input.hpp (6-byte operation records, at most 200 of them and
// 2 s of simulated time). The personalities' profiles (vectors/drives/<name>.yaml) are read once
// per process from $DRIVECHECK_VECTORS_DIR/drives, else <this program's folder>/drives
// (fuzz/build.sh copies them there), else the source tree's vectors/drives; a profile that
// cannot be read is reported once on stderr and its inputs run the standard drive. Objects are
// written by expedited SDO downloads from a tester node (the answers are not checked here:
// sdo_server is another target's business). After every operation and every millisecond of time the
// drive's state is observed (one drive cycle).
//
// Oracles, checked after every observation (CiA 402-2 §8 "Device control"):
//   1. the statusword 6041h as the dictionary holds it decodes to a valid state
//      (protocol/cia402/state_machine.hpp decode_statusword), and that state is the power
//      drive system's state (the drive shows what it is in);
//   2. the axis model is finite: physical position, velocity, acceleration, motor torque,
//      max speed and torque limit are never NaN or infinite, |physical position| < 2^53
//      increments (a double still counts single increments), 6063h/6064h are integers the
//      drive could compute (the position in range of INTEGER32 is not required: 6064h wraps);
//   3. physics: per observation window dt, |Δv| <= (torque limit + friction) x rated
//      acceleration / 1000 x dt while |v| stayed within the max speed (a lowered max speed
//      only ever brings |v| down), |v| <= max(max speed before, after), and
//      |Δposition| <= max(|v0|, |v1|) x dt (trapezoid integration, no jumps); an axis that
//      ends the window against a mechanical end stop may have lost more speed than the torque
//      explains (the stop stops it dead), never gained it; axis-coast-to-rest (an operator's
//      act) leaves a powered axis alone and stops an unpowered one where it is, and the next
//      window starts after it;
//   4. no motion outside OPERATION ENABLED, QUICK STOP ACTIVE and FAULT REACTION ACTIVE
//      (states as the statusword shows them, before and after the window):
//      - an axis at rest stays at rest (velocity exactly 0, position unchanged);
//      - an axis that still moves (the drive function was switched off while it moved:
//        605Ah/605Bh/605Ch/605Eh = 0 "disable drive function", transitions 7, 9, 10, 12
//        by disable voltage or the hardware enable, CiA 402-2 §8.4 "the motor is free to
//        rotate") only coasts: no motor torque, |v| never grows;
//      - except a personality whose power stage stays on in SWITCHED ON (Kollmorgen,
//        power_stage_in_switched_on): there the axis is stopped and held, |v| never grows;
//   5. the option-code ramps in OPERATION ENABLED: CiA 402-2 §8.4.5/§8.4.6 (605Bh/605Ch = 1,
//      "slow down with slow down ramp and then disable the drive function") let the drive
//      decelerate while still showing OPERATION ENABLED; this drive does exactly that and
//      reports the pending transition (PowerDriveSystem::pending_transition). From the first
//      whole window after a shutdown or disable operation command took effect until the state
//      changes, |v| never grows (the ramp only decelerates; halt release and new set-points
//      must not restart the motor).
// Load torque and axis-position (an outside push, a teleport) are not among the inputs: with
// them oracles 4 and 5 would not hold for a correct drive.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fuzz/support/cia402_input.hpp"
#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/cia402/state_machine.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/servo_drive.hpp"

namespace {

using namespace drivecheck;
using namespace std::chrono_literals;
using cia402::State;
using fuzz::Cia402Op;
using fuzz::Cia402OpKind;

constexpr std::uint8_t kNode = 5;
constexpr int kMaxOperations = 200;
constexpr can::Duration kMaxTime = 2s;
constexpr double kMaxPosition = 9007199254740992.0;  // 2^53
constexpr double kEpsilon = 1e-6;

bool motion_allowed(State state) {
  return state == State::operation_enabled || state == State::quick_stop_active ||
         state == State::fault_reaction_active;
}

struct Observation {
  can::TimePoint at{};
  double position = 0.0;  // physical increments
  double velocity = 0.0;
  double acceleration = 0.0;
  double torque = 0.0;
  double max_speed = 0.0;
  double torque_limit = 0.0;
  reference_drive::AxisControl control = reference_drive::AxisControl::free;
  bool at_end_stop = false;  // against a mechanical end stop (simulate stop-*-at)
  std::uint16_t statusword = 0;
  std::optional<State> shown;  // decoded from the statusword
  State state = State::not_ready_to_switch_on;
  std::optional<std::uint8_t> pending;  // ramped transition 5 or 8
};

#ifndef DRIVECHECK_VECTORS_DIR
#error "DRIVECHECK_VECTORS_DIR must be defined by the build (fuzz/CMakeLists.txt)"
#endif

// Where the personalities' profiles are (see the file comment).
std::filesystem::path drives_dir() {
  namespace fs = std::filesystem;
  if (const char* dir = std::getenv("DRIVECHECK_VECTORS_DIR")) return fs::path(dir) / "drives";
  std::error_code error;
  const fs::path beside = fs::read_symlink("/proc/self/exe", error).parent_path() / "drives";
  if (!error && fs::is_directory(beside, error)) return beside;
  return fs::path(DRIVECHECK_VECTORS_DIR) / "drives";
}

// The profile of kPersonalities[row] (null: the standard drive, or the profile could not be
// read), loaded once per process.
const profile::DriveProfile* personality_profile(std::size_t row) {
  static const auto profiles = [] {
    std::array<std::optional<profile::DriveProfile>, fuzz::kPersonalities.size()> loaded;
    const std::filesystem::path dir = drives_dir();
    for (std::size_t i = 1; i < loaded.size(); ++i) {
      auto found = profile::find_profile(fuzz::kPersonalities[i], dir);
      if (found) {
        loaded[i] = std::move(*found);
      } else {
        std::fprintf(stderr, "cia402_fuzzer: %s: %s; its inputs run the standard drive\n",
                     std::string(fuzz::kPersonalities[i]).c_str(),
                     found.error().to_string().c_str());
      }
    }
    return loaded;
  }();
  return row < profiles.size() && profiles[row] ? &*profiles[row] : nullptr;
}

class Harness {
 public:
  explicit Harness(std::size_t personality)
      : bus_(can::SimBusConfig{.bitrate = 1'000'000}),
        drive_port_(bus_.attach("drive")),
        tester_(bus_.attach("tester")),
        personality_(personality) {
    reference_drive::ServoDriveOptions options;
    options.node = kNode;
    options.profile = personality_profile(personality);
    if (options.profile == nullptr) personality_ = 0;
    // The oracles' own check (CTest fuzz.cia402-catches-deviation): a named deviation of
    // reference_drive/deviations.inc makes the drive wrong on purpose.
    if (const char* deviation = std::getenv("DRIVECHECK_FUZZ_CIA402_DEVIATION")) {
      const std::vector<std::string> names{deviation};
      auto parsed = reference_drive::DeviationSet::parse(names);
      DRIVECHECK_FUZZ_CHECK_DETAIL(parsed.has_value(), "unknown deviation",
                                   parsed ? std::string() : parsed.error());
      options.deviations = std::move(*parsed);
    }
    auto drive = reference_drive::ServoDrive::create(*drive_port_, std::move(options));
    DRIVECHECK_FUZZ_CHECK_DETAIL(drive.has_value(), "the servo drive could not be created",
                                 drive ? std::string() : drive.error());
    drive_ = std::move(*drive);
    drive_->power_on();
    start_ = bus_.now();
    last_ = observe();
    step(1ms);
  }

  bool out_of_time() const { return bus_.now() - start_ >= kMaxTime; }

  void apply(const Cia402Op& op) {
    switch (op.kind) {
      case Cia402OpKind::controlword: {
        const std::uint16_t cw = op.selector < fuzz::kControlwords.size()
                                     ? fuzz::kControlwords[op.selector]
                                     : static_cast<std::uint16_t>(op.value);
        sdo_write(0x6040, 0, 2, cw);
        break;
      }
      case Cia402OpKind::mode: {
        const auto mode = op.selector < fuzz::kModes.size()
                              ? static_cast<std::uint8_t>(fuzz::kModes[op.selector])
                              : static_cast<std::uint8_t>(op.value);
        sdo_write(0x6060, 0, 1, mode);
        break;
      }
      case Cia402OpKind::target: {
        const auto& object = fuzz::kTargets[op.selector % fuzz::kTargets.size()];
        sdo_write(object.index, object.sub, object.size, op.value);
        break;
      }
      case Cia402OpKind::option_code: {
        const std::uint16_t index = fuzz::kOptionCodes[op.selector % fuzz::kOptionCodes.size()];
        const auto value =
            (op.selector & 0x80) == 0
                ? static_cast<std::uint32_t>(static_cast<std::int32_t>(op.value % 12) - 2)
                : op.value;
        sdo_write(index, 0, 2, value);
        break;
      }
      case Cia402OpKind::factor: {
        const auto& object = fuzz::kFactors[op.selector % fuzz::kFactors.size()];
        sdo_write(object.index, object.sub, object.size, op.value);
        break;
      }
      case Cia402OpKind::simulate: {
        const auto& input = fuzz::kInputs[op.selector % fuzz::kInputs.size()];
        std::int64_t value = 0;
        if (input.one) {
          value = 1;
        } else if (input.position) {
          value = static_cast<std::int32_t>(op.value);
        } else if (input.tristate) {
          value = static_cast<std::int64_t>(op.value % 3) - 1;
        } else {
          value = op.value % 2;
        }
        const auto done = drive_->simulate(input.name, value);
        const bool documented =
            input.personality.empty() || input.personality == fuzz::kPersonalities[personality_];
        DRIVECHECK_FUZZ_CHECK_DETAIL(
            done.has_value() == documented,
            documented ? "a documented simulated input was refused"
                       : "a drive accepted another personality's simulated input",
            fmt::format("{} := {}: {}", input.name, value, done ? std::string() : done.error()));
        if (input.one) coasted_to_rest();
        break;
      }
      case Cia402OpKind::sync:
        send((op.selector & 1) != 0
                 ? can::Frame::standard(0x080, {static_cast<std::uint8_t>(op.value)})
                 : can::Frame::standard(0x080, {}));
        break;
      case Cia402OpKind::nmt:
        send(can::Frame::standard(
            0x000, {fuzz::kNmtCommands[op.selector % fuzz::kNmtCommands.size()], kNode}));
        break;
      case Cia402OpKind::time:
        for (std::uint32_t ms = op.value % 256; ms > 0 && !out_of_time(); --ms)
          step(1ms);
        break;
      case Cia402OpKind::personality:
        break;  // chosen by the first record only (LLVMFuzzerTestOneInput)
      case Cia402OpKind::sdo_write: {
        const auto index = static_cast<std::uint16_t>(0x6000 + ((op.value >> 16) & 0xFF));
        static constexpr std::array<std::size_t, 4> kSizes{1, 2, 4, 4};
        sdo_write(index, static_cast<std::uint8_t>(op.selector % 4), kSizes[op.value >> 30],
                  op.value & 0xFFFF);
        break;
      }
    }
    step(1ms);
  }

 private:
  // Expedited download (CiA 301 §7.2.4.3.3):
  //   600h+N [cs = 0x23 | (4 - size) << 2 | index LE | sub | data LE, 4 bytes]
  void sdo_write(std::uint16_t index, std::uint8_t sub, std::size_t size, std::uint32_t value) {
    const auto command = static_cast<std::uint8_t>(0x23 | ((4 - size) << 2));
    send(can::Frame::standard(
        0x600 + kNode,
        {command, static_cast<std::uint8_t>(index), static_cast<std::uint8_t>(index >> 8), sub,
         static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8),
         static_cast<std::uint8_t>(value >> 16), static_cast<std::uint8_t>(value >> 24)}));
  }

  void send(const can::Frame& frame) { static_cast<void>(tester_->send(frame)); }

  // axis-coast-to-rest, an outside act at this instant (no time passed since last_): a powered
  // axis is left alone, an unpowered one stands still where it is. The next window starts
  // after the act (its velocity step is the operator's, not the drive's).
  DRIVECHECK_FUZZ_ORACLE_CODE void coasted_to_rest() {
    const Observation now = observe();
    // The message is built only when a check fails (every step would pay for it).
    const auto where = [&] { return context(last_, now); };
    if (last_.control != reference_drive::AxisControl::free) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(now.velocity == last_.velocity && now.position == last_.position,
                                   "axis-coast-to-rest changed a powered axis", where());
    } else {
      DRIVECHECK_FUZZ_CHECK_DETAIL(now.velocity == 0.0 && now.position == last_.position,
                                   "axis-coast-to-rest left an unpowered axis moving", where());
    }
    last_ = now;
  }

  DRIVECHECK_FUZZ_ORACLE_CODE Observation observe() {
    const auto& axis = drive_->application().axis();
    const auto& pds = drive_->application().pds();
    Observation o;
    o.at = bus_.now();
    o.position = axis.physical_position();
    o.velocity = axis.velocity();
    o.acceleration = axis.acceleration();
    o.torque = axis.torque();
    o.max_speed = axis.max_speed();
    o.torque_limit = axis.torque_limit();
    o.control = axis.control();
    o.at_end_stop = axis.at_end_stop();
    if (statusword_ == nullptr) {
      statusword_ = drive_->device().dictionary().find(0x6041, 0);
      DRIVECHECK_FUZZ_CHECK(statusword_ != nullptr, "6041h statusword is missing");
    }
    o.statusword = static_cast<std::uint16_t>(statusword_->as_unsigned());
    o.shown = cia402::decode_statusword(o.statusword);
    o.state = pds.state();
    o.pending = pds.pending_transition();
    return o;
  }

  std::string context(const Observation& before, const Observation& after) const {
    return fmt::format(
        "t={}us state {} -> {} (sw {:04X}h -> {:04X}h), pending {}, control {} -> {}\n"
        "  position {} -> {}, velocity {} -> {}, acceleration {}, torque {}, max speed {} -> "
        "{}, torque limit {} -> {}",
        std::chrono::duration_cast<std::chrono::microseconds>(after.at - start_).count(),
        cia402::to_string(before.state), cia402::to_string(after.state), before.statusword,
        after.statusword, after.pending ? fmt::format("{}", *after.pending) : "none",
        static_cast<int>(before.control), static_cast<int>(after.control), before.position,
        after.position, before.velocity, after.velocity, after.acceleration, after.torque,
        before.max_speed, after.max_speed, before.torque_limit, after.torque_limit);
  }

  // One millisecond of bus time (one drive cycle), then the oracles on the window.
  void step(can::Duration duration) {
    bus_.run_for(duration);
    const Observation now = observe();
    if (trace_) std::fprintf(stderr, "%s\n", context(last_, now).c_str());
    check(last_, now);
    last_ = now;
  }

  DRIVECHECK_FUZZ_ORACLE_CODE void check(const Observation& before, const Observation& after) {
    // The message is built only when a check fails (every step would pay for it).
    const auto where = [&] { return context(before, after); };
    // 1. The statusword shows a valid state, the one the drive is in.
    DRIVECHECK_FUZZ_CHECK_DETAIL(after.shown.has_value(), "the statusword shows no valid state",
                                 where());
    DRIVECHECK_FUZZ_CHECK_DETAIL(*after.shown == after.state,
                                 "the statusword shows another state than the drive is in",
                                 where());

    // 2. The axis model is finite.
    for (const double value : {after.position, after.velocity, after.acceleration, after.torque,
                               after.max_speed, after.torque_limit}) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(std::isfinite(value), "NaN or infinity in the axis model",
                                   where());
    }
    DRIVECHECK_FUZZ_CHECK_DETAIL(std::abs(after.position) < kMaxPosition,
                                 "the axis position left the range a double counts exactly",
                                 where());

    // 3. Physics within the window.
    const double dt = std::chrono::duration<double>(after.at - before.at).count();
    const auto& config = drive_->application().axis().config();
    const double per_mille = config.rated_acceleration / 1000.0;
    const double torque_limit = std::max(before.torque_limit, after.torque_limit);
    const double max_dv = (torque_limit + config.friction_torque) * per_mille * dt;
    const double speed_limit = std::max(before.max_speed, after.max_speed);
    const double dv = after.velocity - before.velocity;
    const double tolerance =
        kEpsilon * (1.0 + std::abs(before.velocity) + std::abs(after.velocity));
    DRIVECHECK_FUZZ_CHECK_DETAIL(std::abs(after.velocity) <= speed_limit * (1 + 1e-12) + kEpsilon,
                                 "the axis runs faster than its max speed", where());
    if (after.at_end_stop && std::abs(dv) > max_dv * (1 + 1e-9) + tolerance) {
      // An end stop stops the axis dead (axis_model.hpp): it only takes speed away, and the
      // axis stands at it.
      DRIVECHECK_FUZZ_CHECK_DETAIL(
          after.velocity == 0.0 || std::abs(after.velocity) < std::abs(before.velocity) + tolerance,
          "an end stop made the axis faster", where());
    } else if (std::abs(before.velocity) <= after.max_speed) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(std::abs(dv) <= max_dv * (1 + 1e-9) + tolerance,
                                   "the velocity changed more than the torque limit allows",
                                   fmt::format("{}\n  dv {} > {}", where(), dv, max_dv));
    } else {
      DRIVECHECK_FUZZ_CHECK_DETAIL(
          std::abs(after.velocity) <= std::abs(before.velocity) + tolerance,
          "above a lowered max speed the axis got faster", where());
    }
    const double max_dp =
        std::max(std::abs(before.velocity), std::abs(after.velocity)) * dt * (1 + 1e-9) + kEpsilon;
    // Several cycles in one window: the velocity in between is bounded by the speed limit.
    const double max_dp_cycles = std::max(max_dp, speed_limit * dt * (1 + 1e-9) + kEpsilon);
    DRIVECHECK_FUZZ_CHECK_DETAIL(std::abs(after.position - before.position) <= max_dp_cycles,
                                 "the position jumped", where());

    // 4. No motion outside OPERATION ENABLED, QUICK STOP ACTIVE, FAULT REACTION ACTIVE.
    const bool outside = !motion_allowed(after.state) && before.shown &&
                         !motion_allowed(*before.shown) && !motion_allowed(before.state);
    // A personality whose power stage stays on in SWITCHED ON (Kollmorgen:
    // power_stage_in_switched_on) stops the axis there and holds it: the motor has torque,
    // but the axis only ever slows down.
    const bool held = after.state == State::switched_on &&
                      after.control != reference_drive::AxisControl::free &&
                      drive_->application().pds().config().power_stage_in_switched_on;
    if (outside && held) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(
          std::abs(after.velocity) <= std::abs(before.velocity) + tolerance,
          "an axis held in SWITCHED ON got faster", where());
    } else if (outside) {
      if (before.velocity == 0.0) {
        DRIVECHECK_FUZZ_CHECK_DETAIL(after.velocity == 0.0 && after.position == before.position,
                                     "an axis at rest moved outside the motion states", where());
      } else {
        DRIVECHECK_FUZZ_CHECK_DETAIL(
            after.control == reference_drive::AxisControl::free && after.torque == 0.0,
            "the drive function acts on the motor outside the motion states", where());
        DRIVECHECK_FUZZ_CHECK_DETAIL(std::abs(after.velocity) <= std::abs(before.velocity),
                                     "a coasting axis got faster outside the motion states",
                                     where());
      }
    }

    // 5. A ramped shutdown / disable operation only decelerates.
    const bool ramping = after.state == State::operation_enabled &&
                         before.state == State::operation_enabled && after.pending.has_value() &&
                         before.pending.has_value() && ramp_seen_;
    if (ramping) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(
          std::abs(after.velocity) <= std::abs(before.velocity) + tolerance,
          "the axis got faster during a ramped shutdown/disable operation", where());
    }
    ramp_seen_ = after.state == State::operation_enabled && after.pending.has_value();
  }

  can::SimBus bus_;
  std::unique_ptr<can::SimPort> drive_port_;
  std::unique_ptr<can::SimPort> tester_;
  std::size_t personality_;  // kPersonalities row of the drive
  std::unique_ptr<reference_drive::ServoDrive> drive_;
  const cia301::Entry* statusword_ = nullptr;  // 6041h, found at the first observation
  can::TimePoint start_{};
  Observation last_;
  bool ramp_seen_ = false;
  // DRIVECHECK_FUZZ_TRACE=1: every observation window on stderr (to read a finding).
  bool trace_ = std::getenv("DRIVECHECK_FUZZ_TRACE") != nullptr;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fuzz::FuzzInput in(data, size);
  const Cia402Op first = fuzz::decode_cia402_op(in);
  const bool chosen = first.kind == Cia402OpKind::personality;
  Harness harness(chosen ? first.selector % fuzz::kPersonalities.size() : 0);
  if (!chosen && size > 0) harness.apply(first);
  for (int operations = 1; !in.empty() && operations < kMaxOperations && !harness.out_of_time();
       ++operations) {
    harness.apply(fuzz::decode_cia402_op(in));
  }
  return 0;
}
