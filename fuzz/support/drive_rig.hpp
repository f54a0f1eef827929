// The rig of the fuzz targets that run a whole reference drive (nmt_error_control,
// pdo_mapping): one simulated bus at 1 Mbit/s with the drive's port and a tester port, kept
// for every input, and DriveSession, one input on it:
//   - the bus is reset (SimBus::reset: time 0, nothing queued, no timer: as a new bus);
//   - the drive is restarted on the drive port (ReferenceDrive::restart: as create() left it,
//     without building the dictionary again);
//   - `monitor` sees every frame on the wire; the tester's own frames come back when they have
//     been on the wire (loopback) and are counted (delivered());
//   - `tester_sees` (optional) sees every frame as the tester port receives it, its own
//     (loopback, `own` set) and the drive's (`own` clear): who sent a frame, which the monitor
//     does not tell;
//   - at the end the drive leaves the bus (release_bus), so that everything an input allocates
//     is freed in the same input (libFuzzer's leak detection re-runs an input that ends with
//     more mallocs than frees; the bus's queues keep their capacity, which grows only while the
//     first inputs warm them up), and the monitor and the tester's handler go.
// Powering the drive on is the target's: its oracles watch the boot-up.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>

#include "fuzz/support/fuzz_check.hpp"
#include "protocol/can/sim_bus.hpp"
#include "reference_drive/device.hpp"

namespace drivecheck::fuzz {

struct DriveRig {
  can::SimBus bus{can::SimBusConfig{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> drive_port = bus.attach("drive");
  std::unique_ptr<can::SimPort> tester = bus.attach("tester");
};

class DriveSession {
 public:
  DriveSession(DriveRig& rig, reference_drive::ReferenceDrive& drive,
               std::function<void(const can::TimedFrame&)> monitor,
               std::function<void(const can::TimedFrame&)> tester_sees = {})
      : rig_(rig), drive_(drive), tester_sees_(std::move(tester_sees)) {
    DRIVECHECK_FUZZ_CHECK(rig_.bus.reset(), "the bus did not reset");
    auto restarted = drive_.restart(*rig_.drive_port);
    DRIVECHECK_FUZZ_CHECK_DETAIL(restarted.has_value(), "the reference drive did not restart",
                                 restarted ? std::string() : restarted.error());
    monitor_ = rig_.bus.add_monitor(std::move(monitor));
    rig_.tester->set_loopback(true);
    rig_.tester->set_frame_handler([this](const can::TimedFrame& seen) {
      if (seen.own) ++delivered_;
      if (tester_sees_) tester_sees_(seen);
    });
  }
  ~DriveSession() {
    drive_.release_bus();  // before the next input resets the bus
    rig_.bus.remove_monitor(monitor_);
    rig_.tester->set_frame_handler({});
  }
  DriveSession(const DriveSession&) = delete;
  DriveSession& operator=(const DriveSession&) = delete;

  can::SimBus& bus() { return rig_.bus; }
  can::SimPort& tester() { return *rig_.tester; }
  reference_drive::ReferenceDrive& drive() { return drive_; }
  // The tester's frames that were on the wire so far.
  std::uint64_t delivered() const { return delivered_; }

 private:
  DriveRig& rig_;
  reference_drive::ReferenceDrive& drive_;
  std::function<void(const can::TimedFrame&)> tester_sees_;
  can::MonitorId monitor_ = 0;
  std::uint64_t delivered_ = 0;
};

}  // namespace drivecheck::fuzz
