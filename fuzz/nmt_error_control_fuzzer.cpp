// Fuzz target: NMT, heartbeat, node guarding and SYNC frames (and the SDO writes that configure
// error control) into a whole reference drive (reference_drive/device.hpp) on the simulated
// bus, node 5. Each input runs on the bus reset to time 0 (SimBus::reset: as a new bus) with
// the drive restarted on it (ReferenceDrive::restart: as created, without building the
// dictionary again).
//
// Input (fuzz/support/fuzz_input.hpp reads past the end as zeros):
//   byte 0   producer heartbeat time 1017h at power on: {0, 10, 100, 1000} ms by byte % 4
//   then operations, one byte each (op % 7) and their operands; a frame is followed by bus time
//   until it was on the wire (at most 100 ms) plus 1 ms:
//     0 NMT command      u8 command {start, stop, pre-operational, reset node, reset
//                        communication, u8 as given} by % 6 (+ u8 when raw), u8 addressee
//                        {the drive, all (0), another node} by % 3 (+ u8 for the other node)
//     1 any frame        u16 identifier (11 bit; not 600h-67Fh, not 705h), u8 DLC (% 9),
//                        8 data bytes
//     2 guarding RTR     705h, DLC 1 (CiA 301 §7.2.8.3.2.1)
//     3 SYNC             u8: bit 0 with a counter byte, the rest the counter
//     4 SDO write        u8 object {1017h, 100Ch, 100Dh, 1016h:1, 1016h:2, 1029h:1, 1005h,
//                        1006h} by % 8, u32 value; expedited
//     5 time step        u16 % 2000 milliseconds
//     6 heartbeat        u8 producer node (1..127), u8 state byte
//   Time stops once 4,000 frames were on the wire (kMaxFramesPerInput).
//
// Oracles (CiA 301 §7.3.2 NMT state machine, §7.2.8.3.2.3 boot-up):
//   - the drive's NMT state is always pre-operational, operational or stopped once the bus
//     ran (initialisation is over: its time is 0);
//   - a well-formed NMT command (that made it onto the wire) to the drive or to all nodes puts
//     it exactly in the state
//     CiA 301 Fig. 48 names; one to another node or with an undefined command changes
//     nothing — unless error control is configured (then an error reaction, 1029h, may also
//     have moved it to pre-operational or stopped);
//   - a boot-up message (705h, 1 byte 00h) appears only after a reset command, and after a
//     well-formed reset command it appears within 50 ms;
//   - every frame on 705h is a boot-up, a heartbeat (04h, 05h, 7Fh) or a guarding answer
//     (the same with the toggle in bit 7), always 1 data byte.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fuzz/support/drive_rig.hpp"
#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/nmt.hpp"
#include "reference_drive/device.hpp"

namespace {

using namespace drivecheck;
using namespace std::chrono_literals;
using cia301::NmtState;
using drivecheck::fuzz::DriveRig;
using drivecheck::fuzz::FuzzInput;

constexpr std::uint8_t kNode = 5;
constexpr std::uint32_t kErrorControlId = 0x700 + kNode;
constexpr can::Duration kBootUpBound = 50ms;
// Work per input: time stops (and no further operation runs) once this many frames were on the
// wire. A SYNC period below the frame's own duration saturates the bus, and 256 time steps of
// up to 2 s each then simulate millions of frames (inputs of 15 s and more under ASan, found as
// libFuzzer timeouts). Every oracle still holds for the time that was simulated.
constexpr std::uint64_t kMaxFramesPerInput = 4'000;
constexpr can::Duration kTimeSlice = 10ms;

struct SdoTarget {
  std::uint16_t index;
  std::uint8_t sub;
  std::uint8_t size;
};
constexpr std::array<SdoTarget, 8> kSdoTargets{{
    {0x1017, 0, 2},  // producer heartbeat time
    {0x100C, 0, 2},  // guard time
    {0x100D, 0, 1},  // life time factor
    {0x1016, 1, 4},  // consumer heartbeat time 1
    {0x1016, 2, 4},  // consumer heartbeat time 2
    {0x1029, 1, 1},  // error behaviour: communication error
    {0x1005, 0, 4},  // COB-ID SYNC
    {0x1006, 0, 4},  // communication cycle period
}};

bool valid_state(NmtState state) {
  return state == NmtState::pre_operational || state == NmtState::operational ||
         state == NmtState::stopped;
}

std::optional<NmtState> state_after(std::uint8_t command, NmtState before) {
  switch (command) {
    case 0x01:
      return NmtState::operational;
    case 0x02:
      return NmtState::stopped;
    case 0x80:
      return NmtState::pre_operational;
    case 0x81:
    case 0x82:
      return NmtState::pre_operational;
    default:
      return before;  // undefined command specifier: ignored
  }
}

// The drives live across inputs, one per 1017h default: each input restarts its drive on the
// reset bus and releases it at its end (fuzz/support/drive_rig.hpp).
struct DriveSlot {
  std::unique_ptr<reference_drive::ReferenceDrive> drive;
};

constexpr std::array<std::uint16_t, 4> kHeartbeats{0, 10, 100, 1000};

// Every drive, created at the first input (an input that creates one ends with more mallocs
// than frees, and libFuzzer runs it again to look for a leak), released until an input needs it.
std::array<DriveSlot, kHeartbeats.size()> make_drives() {
  std::array<DriveSlot, kHeartbeats.size()> slots;
  DriveRig rig;
  for (std::size_t i = 0; i < slots.size(); ++i) {
    reference_drive::DriveConfig config;
    config.dictionary.node_id = kNode;
    // No application cycle: nothing here needs one, and 1000 wake-ups per simulated second
    // would dominate the target's cost.
    config.control_cycle = can::Duration{0};
    config.dictionary.producer_heartbeat_ms = kHeartbeats[i];
    auto drive = reference_drive::ReferenceDrive::create(*rig.drive_port, config);
    DRIVECHECK_FUZZ_CHECK(drive.has_value(), "the reference drive could not be created");
    slots[i].drive = std::move(*drive);
    slots[i].drive->release_bus();
  }
  return slots;
}

class Harness {
 public:
  Harness(DriveRig& rig, DriveSlot& slot)
      : session_(rig, *slot.drive, [this](const can::TimedFrame& seen) { on_frame(seen); }),
        bus_(session_.bus()),
        tester_(&session_.tester()),
        drive_(&session_.drive()) {
    reset_pending_ = true;  // power on: a boot-up is due
    reset_since_ = bus_.now();
    must_boot_ = true;
    drive_->power_on();
    run(1ms);
  }

  Harness(const Harness&) = delete;
  Harness& operator=(const Harness&) = delete;

  NmtState state() const { return drive_->state(); }
  std::uint64_t frames_on_wire() const { return bus_.frames_on_wire(); }

  // Sends a frame and runs until it has been on the wire (or 100 ms passed: a saturated bus,
  // e.g. a SYNC producer configured to a 29-bit COB-ID with a tiny period, may hold it back),
  // then 1 ms for the drive to react. Whether it went out.
  bool send(const can::Frame& frame) {
    const std::uint64_t before = session_.delivered();
    if (tester_->send(frame)) return false;
    for (int waited = 0; session_.delivered() == before && waited < 100; ++waited)
      run(1ms);
    if (session_.delivered() == before) return false;
    run(1ms);
    return true;
  }

  void nmt(std::uint8_t command, std::uint8_t node) {
    const NmtState before = state();
    const bool addressed = node == 0 || node == kNode;
    const bool reset = addressed && (command == 0x81 || command == 0x82);
    if (reset) note_reset();
    const std::uint64_t boot_ups = boot_ups_;
    if (!send(can::Frame::standard(0x000, {command, node}))) return;
    if (reset && boot_ups_ == boot_ups) expect_boot_up();
    const NmtState expected = addressed ? *state_after(command, before) : before;
    if (!error_control_configured_) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(state() == expected,
                                   "an NMT command left the drive in the wrong state",
                                   fmt::format("command {:02X}h to node {}: state {:02X}h, "
                                               "expected {:02X}h",
                                               command, node, static_cast<unsigned>(state()),
                                               static_cast<unsigned>(expected)));
    } else {
      DRIVECHECK_FUZZ_CHECK_DETAIL(
          state() == expected || state() == NmtState::pre_operational ||
              state() == NmtState::stopped,
          "an NMT command left the drive in a state no error reaction explains",
          fmt::format("command {:02X}h to node {}: state {:02X}h", command, node,
                      static_cast<unsigned>(state())));
    }
  }

  void raw(const can::Frame& frame) {
    // Anything on 000h that could be a reset of this node: a boot-up may follow.
    if (frame.id == 0 && !frame.is_remote() && frame.length() >= 2 &&
        (frame.data[0] == 0x81 || frame.data[0] == 0x82) &&
        (frame.data[1] == 0 || frame.data[1] == kNode)) {
      note_reset();
    }
    if ((frame.id & 0x780) == 0x600 || frame.id == 0x000 || (frame.id & 0x780) == 0x700) {
      error_control_configured_ = true;  // raw SDO/NMT/heartbeat frames: anything may follow
    }
    send(frame);
  }

  void sdo_write(const SdoTarget& target, std::uint32_t value) {
    error_control_configured_ = true;
    // 1006h takes any value: a SYNC period shorter than the SYNC frame saturates the bus (that
    // is CAN), but the producer skips a SYNC whose predecessor is still queued, so no backlog
    // delays the boot-up after a reset (found by this target; fuzz/README.md).
    const std::uint8_t command = static_cast<std::uint8_t>(0x23 | ((4 - target.size) << 2));
    send(can::Frame::standard(
        0x600 + kNode,
        {command, static_cast<std::uint8_t>(target.index),
         static_cast<std::uint8_t>(target.index >> 8), target.sub, static_cast<std::uint8_t>(value),
         static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value >> 16),
         static_cast<std::uint8_t>(value >> 24)}));
  }

  void guarding_request() {
    error_control_configured_ = true;  // the first RTR starts life guarding
    send(can::Frame::remote(kErrorControlId, 1));
  }

  void run(can::Duration duration) {
    const can::TimePoint until = bus_.now() + duration;
    if (frames_on_wire() < kMaxFramesPerInput) {
      do {
        bus_.run_until(std::min(until, bus_.now() + kTimeSlice));
      } while (bus_.now() < until && frames_on_wire() < kMaxFramesPerInput);
    }
    DRIVECHECK_FUZZ_CHECK_DETAIL(valid_state(state()), "the NMT state is not one of the three",
                                 fmt::format("state {:02X}h", static_cast<unsigned>(state())));
    if (must_boot_ && bus_.now() - reset_since_ >= kBootUpBound) {
      oracle_no_boot_up();
    }
  }

 private:
  [[noreturn]] void oracle_no_boot_up() {
    std::string recent;
    for (const can::TimedFrame& seen : recent_) {
      recent +=
          fmt::format("\n    {:>12} ns  {}", seen.timestamp.time_since_epoch().count(), seen.frame);
    }
    ::drivecheck::fuzz::oracle_failed(
        __FILE__, __LINE__, "boot-up after reset",
        "no boot-up message within 50 ms of a reset command",
        fmt::format("reset on the wire at {} ns, now {} ns; last frames:{}",
                    reset_since_.time_since_epoch().count(), bus_.now().time_since_epoch().count(),
                    recent));
  }

  void note_reset() { reset_pending_ = true; }
  void expect_boot_up() {
    if (!must_boot_) {
      must_boot_ = true;
      reset_since_ = bus_.now();
    }
  }

  DRIVECHECK_FUZZ_ORACLE_CODE void on_frame(const can::TimedFrame& seen) {
    if (recent_.size() == 12) recent_.erase(recent_.begin());
    recent_.push_back(seen);
    const can::Frame& frame = seen.frame;
    if (frame.id != kErrorControlId || frame.is_remote() || frame.is_extended()) return;
    // Only the drive sends on 705h (the tester never does: heartbeats use other nodes).
    DRIVECHECK_FUZZ_CHECK_DETAIL(frame.dlc == 1, "an error control frame without 1 data byte",
                                 fmt::format("{}", frame));
    const std::uint8_t byte = frame.data[0];
    if (byte == 0x00) {
      DRIVECHECK_FUZZ_CHECK(reset_pending_, "a boot-up message without a reset");
      reset_pending_ = false;
      must_boot_ = false;
      ++boot_ups_;
      return;
    }
    const std::uint8_t state_byte = byte & 0x7F;
    DRIVECHECK_FUZZ_CHECK_DETAIL(state_byte == 0x04 || state_byte == 0x05 || state_byte == 0x7F,
                                 "a heartbeat or guarding answer with an invalid state",
                                 fmt::format("{}", frame));
  }

  fuzz::DriveSession session_;  // first: the bus reset, the drive restarted, released last
  can::SimBus& bus_;
  can::SimPort* tester_;
  reference_drive::ReferenceDrive* drive_;
  bool reset_pending_ = false;  // a reset was sent (maybe malformed): a boot-up may come
  bool must_boot_ = false;      // a well-formed reset was sent: a boot-up must come
  can::TimePoint reset_since_{};
  bool error_control_configured_ = false;
  std::uint64_t boot_ups_ = 0;           // boot-up messages seen
  std::vector<can::TimedFrame> recent_;  // the last frames on the bus, for oracle messages
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzInput in(data, size);
  static std::array<DriveSlot, kHeartbeats.size()> slots = make_drives();
  static fuzz::DriveRig rig;
  Harness harness(rig, slots[in.u8() % kHeartbeats.size()]);

  static constexpr std::array<std::uint8_t, 5> kCommands{0x01, 0x02, 0x80, 0x81, 0x82};
  int operations = 0;
  while (!in.empty() && ++operations <= 256 && harness.frames_on_wire() < kMaxFramesPerInput) {
    switch (in.u8() % 7) {
      case 0: {
        const std::uint8_t pick = in.u8() % 6;
        const std::uint8_t command = pick < kCommands.size() ? kCommands[pick] : in.u8();
        const std::uint8_t which = in.u8() % 3;
        std::uint8_t node = which == 0 ? kNode : 0;
        if (which == 2) {
          node = static_cast<std::uint8_t>(in.u8() % 127 + 1);
          if (node == kNode) node = kNode + 1;
        }
        harness.nmt(command, node);
        break;
      }
      case 1: {
        const std::uint32_t id = in.u16() & 0x7FFu;
        const std::uint8_t dlc = static_cast<std::uint8_t>(in.u8() % 9);
        const auto bytes = in.bytes(8);
        if (id == kErrorControlId) break;  // 705h belongs to the drive
        // SDO requests go through operation 4, whose values keep the bus unsaturated.
        if ((id & 0x780) == 0x600) break;
        can::Frame frame =
            can::Frame::standard(id, bytes.first(std::min<std::size_t>(dlc, bytes.size())));
        frame.dlc = dlc;
        harness.raw(frame);
        break;
      }
      case 2:
        harness.guarding_request();
        break;
      case 3: {
        const std::uint8_t sync = in.u8();
        harness.raw((sync & 1) != 0
                        ? can::Frame::standard(0x080, {static_cast<std::uint8_t>(sync >> 1)})
                        : can::Frame::standard(0x080, {}));
        break;
      }
      case 4: {
        const SdoTarget target = kSdoTargets[in.u8() % kSdoTargets.size()];
        harness.sdo_write(target, in.u32());
        break;
      }
      case 5:
        harness.run(std::chrono::milliseconds(in.u16() % 2000));
        break;
      default: {
        std::uint8_t node = static_cast<std::uint8_t>(in.u8() % 127 + 1);
        if (node == kNode) node = kNode + 1;
        harness.raw(can::Frame::standard(0x700 + node, {in.u8()}));
        break;
      }
    }
  }
  harness.run(200ms);
  return 0;
}
