// The conformance engine: runs vectors (vector.hpp) against a device under test (DUT) on one
// can::Bus port, as a real master would (it never includes reference-drive code), and returns a
// RunResult (result.hpp) with a verdict and the evidence for every vector.
//
// Per vector:
//   1. applicability (verdict.hpp): `profiles:` must name the selected profile, every
//      `requires:` feature must be supported by the profile (`simulation`: a SimulationControl
//      is present; `motion`: the bus is simulated or --allow-motion was given); a vector that
//      restores the factory defaults (setup restore-defaults, a step writing 1011h) runs on a
//      real bus only with --allow-factory-restore (allow_factory_restore). Else N/A.
//   2. setup (setup.cpp): reset-node / reset-communication (boot-up awaited within
//      $timing.bootup) / restore-defaults (reset node, 1011h sub 1 "load", then
//      reset node) / none; then the profile's commissioning writes (FORMAT.md
//      "Commissioning"; not after setup none), the NMT state (`nmt:`), then the CiA 402 state
//      (`drive_state:`) by the standard path.
//      The NMT state is always commanded (Pre-operational too, after a boot-up) and confirmed:
//      by the heartbeat's state byte when the DUT produces one (1017h non-zero), else by
//      behaviour (SDO answered: not stopped; Stopped: an upload of 1000h gets no answer). A
//      state not reached, or a CiA 402 transition of the walk that did not happen, is an error
//      naming it (the vector never ran). Before the NMT state: the standing leaks are checked
//      and the objects the vector may change are read (isolation.hpp).
//   3. steps, in order, each with its own deadline (`within:` etc.) and the vector's `timeout:`
//      over all; the first failed check ends the steps.
//   4. `finally:` steps (when the steps started), with a time budget of their own; a failure
//      there is a harness note, not the verdict.
//   5. teardown (always): with CiA 402, after a motion vector or when the last statusword read
//      showed OPERATION ENABLED: quick stop (0002h) then disable voltage (0000h).
//   6. restore (isolation.hpp): every object the DUT confirmed a write of goes back to its
//      value before the vector, and what the vector stored (1010h) is stored again; what
//      cannot be put back is a leak (a harness note with the vector id).
//   7. verdict (verdict.hpp): pass / fail / deviation (a profile deviation's documented observation
//   matches) /
//      not applicable (also when a `$dut.<name>` value does not exist on the DUT) /
//      error (harness error: an unknown mark, a simulate input the drive does not know, a send
//      the bus refused); should/may failures are warnings unless strict. A failure while a
//      leak of an earlier vector stands is an error (message: which object holds what from
//      which vector).
//
// Time: waiting is receive(deadline) on the port, so on the simulated bus it advances simulated
// time and runs the drive; on SocketCAN it blocks in poll(). The engine turns loopback on and
// records its own frames from their echo, so every evidence frame carries its wire time.
// Timing is judged from those timestamps (FORMAT.md "Timing"): a window runs from the request's
// echo, a frame read late counts by its timestamp, and a timing check that fails after the
// harness itself was late (a `send:` frame or a wait later than $timing.harness_slack) is a
// harness error ("error: harness late"), not a failure. On a real bus the same holds for any
// check that fails in a vector during which the harness's machine stalled (no thread of the
// harness ran for longer than $timing.harness_slack: EngineOptions::stalls). Such a vector runs
// again (EngineOptions::harness_late_attempts); only a verdict reached without the harness
// being late stands.
//
// A DUT that sends nothing at all during `max_silent_vectors` consecutive applicable vectors
// (or does not answer the identity reads at the start) is lost: the run stops, dut_lost is set
// (exit 3). interrupt() (safe from a signal handler) stops the run after the current step;
// teardown still runs and the result is marked interrupted (exit 130).
//
// On a real bus (EngineOptions::real_bus), before the first motion vector the engine reads and
// records the motion envelope (607Dh, 607Fh, 6080h, 6072h, 6065h, 6066h, 6085h, 605Ah, 6007h),
// produces a heartbeat of its own (node EngineOptions::harness_node) and makes the DUT consume
// it through 1016h sub 1, so that a dead harness stops the drive (6007h).
#pragma once

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "conformance/dut_port.hpp"
#include "conformance/result.hpp"
#include "conformance/simulation_control.hpp"
#include "conformance/stall_log.hpp"
#include "conformance/vector.hpp"
#include "protocol/can/bus.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::cia301 {
class ObjectDictionary;
}  // namespace drivecheck::cia301

namespace drivecheck::conformance {

struct EngineOptions {
  std::uint8_t node = 1;  // the DUT's node-ID
  bool strict = false;    // should/may failures are failures
  bool allow_motion = false;
  // On a real bus, vectors that restore the factory defaults (setup restore-defaults, a step
  // writing 1011h) run only with this (--allow-factory-restore); else they are not applicable.
  bool allow_factory_restore = false;
  bool real_bus = false;  // SocketCAN: safety measures (motion guard, heartbeat, envelope)
  // Isolation (isolation.hpp): snapshot before and restore after each vector, leaks. Off only
  // for tests that script every frame of a peer.
  bool isolation = true;
  std::string filter;  // glob over vector ids; empty: all
  // Consecutive applicable vectors without a single frame from the DUT before it counts as lost.
  std::size_t max_silent_vectors = 3;
  std::uint8_t harness_node = 127;  // heartbeat producer id on a real bus (126 if the DUT is 127)
  can::Duration harness_heartbeat = std::chrono::milliseconds(100);
  SimulationControl* simulation = nullptr;  // not owned; nullptr: no `simulate`
  // Real bus: the harness's own stalls (stall_log.hpp; not owned; may be null). A check that
  // fails in a vector during which the harness stalled is `error: harness late`.
  const StallLog* stalls = nullptr;
  // A vector whose verdict is `error: harness late` runs again, up to this many attempts in
  // all; the report lists what the earlier attempts saw.
  int harness_late_attempts = 3;
  // The DUT's object dictionary as its EDS describes it (not owned; may be null): data sizes for
  // sdo_write without `size:`, object names for the dissector.
  const cia301::ObjectDictionary* eds = nullptr;
  // Called as each vector starts / ends (console progress).
  std::function<void(const Vector&)> on_vector_started;
  std::function<void(const VectorResult&)> on_vector_finished;
};

// The profile's commissioning as RunInfo::commissioning lines (empty: none).
std::vector<std::string> describe_commissioning(const profile::Commissioning& commissioning);

class Engine {
 public:
  // `port` and `profile` must outlive the engine. The engine takes the port in pull mode
  // (no frame handler) and turns its loopback on.
  Engine(can::Bus& port, const profile::DriveProfile& profile, EngineOptions options);
  // The DUT's services through `dut` (dut_port.hpp), e.g. CoE over EtherCAT; `clock` is the
  // engine's time (receive(deadline) lets simulated time pass) and carries the DUT's frames
  // only on CAN. Both must outlive the engine.
  Engine(can::Bus& clock, DutPort& dut, const profile::DriveProfile& profile,
         EngineOptions options);
  ~Engine();
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  // Runs every vector that passes the filter, in order. `info` is copied into the result
  // (the engine fills dut, strict, allow_motion, allow_factory_restore, filter, node, profile
  // name/title/file).
  RunResult run(const std::vector<Vector>& vectors, RunInfo info = {});
  // One vector, with setup and teardown (no identity read, no dut-lost accounting).
  VectorResult run_vector(const Vector& vector);
  // Reads the DUT's identity objects (absent: not readable).
  DutIdentity read_identity();
  // Reads 1000h only (nullopt: no answer or an abort), e.g. to choose a profile.
  std::optional<std::uint32_t> read_device_type();
  // `eds/od/undocumented-objects`: reads sub 0 of every index in 1000h-1FFFh and 6000h-67FFh
  // for which `documented(index)` is false; any answer but abort 06020000h (object does not
  // exist) is an object the description lacks (fail, listed). Evidence keeps the frames of the
  // objects found only (the probe is ~10,000 transfers).
  VectorResult probe_undocumented_objects(const std::function<bool(std::uint16_t)>& documented,
                                          const std::string& source);

  // Stop after the current step (teardown still runs). Async-signal-safe.
  void interrupt();
  bool interrupted() const { return interrupted_.load(); }

  // A watchdog (another thread) may watch progress(): it counts every return from the bus.
  // On a simulated bus that stops advancing (a livelock in a simulated node: events at one
  // instant forever), it calls declare_stalled(): the bus is stopped, the current vector ends
  // as a harness error without teardown, and the run ends with dut_lost. Thread-safe.
  std::uint64_t progress() const { return progress_.load(std::memory_order_relaxed); }
  void declare_stalled();

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
  std::atomic<bool> interrupted_{false};
  std::atomic<bool> stalled_{false};
  std::atomic<std::uint64_t> progress_{0};
};

}  // namespace drivecheck::conformance
