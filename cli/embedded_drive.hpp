// The embedded default of `drivecheck run`: a drive on the simulated bus, on its own port, for
// the engine to test over another port. The engine never sees this class except through
// conformance::SimulationControl (and only when the drive has simulated inputs).
//
// The drive is the full servo drive (reference_drive/servo_drive.hpp: CiA 301 device, CiA 402
// application with its simulated axis and inputs), impersonating the profile's drive (no
// personality for the standard profile cia402-reference), with the named deviations injected.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "conformance/dut_port.hpp"
#include "conformance/simulation_control.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/ethercat/master.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::cli {

class EmbeddedDrive {
 public:
  // Attaches the drive to `bus` as node `node` and powers it on. `bus` must outlive it.
  // Errors: a deviation name the drive does not have, a bad node-ID.
  static Expected<std::unique_ptr<EmbeddedDrive>, std::string> create(
      can::SimBus& bus, std::uint8_t node, const profile::DriveProfile& profile,
      const std::vector<std::string>& deviations);
  ~EmbeddedDrive();
  EmbeddedDrive(const EmbeddedDrive&) = delete;
  EmbeddedDrive& operator=(const EmbeddedDrive&) = delete;

  // The simulated inputs, or nullptr when the drive has none.
  conformance::SimulationControl* simulation();
  // What goes into RunInfo: the personality taken ("" = none) and the deviations injected.
  std::string personality() const;
  const std::vector<std::string>& deviations() const { return deviations_; }

 private:
  struct State;
  explicit EmbeddedDrive(std::unique_ptr<State> state, std::vector<std::string> deviations);
  std::unique_ptr<State> state_;
  std::vector<std::string> deviations_;
};

// `drivecheck run --bus ethercat:sim`: the same drive as an emulated EtherCAT slave
// (reference_drive/ethercat) on a simulated segment, an EtherCAT master brought up to PREOP,
// and the engine's DUT port (CoE SDO) and clock over it (conformance/ethercat_port.hpp).
class EmbeddedEthercat {
 public:
  // Every frame on the segment, from the first of the bring-up on (e.g. a pcap writer).
  using Monitor = std::function<void(const ethercat::TimedFrame&, ethercat::FrameDirection)>;
  // `monitor` (may be empty) is attached before the drive powers on; the engine's datagram
  // evidence is fed from the segment as well (conformance/datagram_evidence.hpp).
  static Expected<std::unique_ptr<EmbeddedEthercat>, std::string> create(
      const profile::DriveProfile& profile, const std::vector<std::string>& deviations,
      Monitor monitor = {});
  ~EmbeddedEthercat();
  EmbeddedEthercat(const EmbeddedEthercat&) = delete;
  EmbeddedEthercat& operator=(const EmbeddedEthercat&) = delete;

  conformance::DutPort& port();
  ethercat::Master& master();  // slave 0 is the drive (its SII as the master read it)
  can::Bus& clock();  // the engine's time: the segment's clock, the process data cycle in it
  conformance::SimulationControl* simulation();
  std::string personality() const;
  const std::vector<std::string>& deviations() const { return deviations_; }

 private:
  struct State;
  explicit EmbeddedEthercat(std::unique_ptr<State> state, std::vector<std::string> deviations);
  std::unique_ptr<State> state_;
  std::vector<std::string> deviations_;
};

}  // namespace drivecheck::cli
