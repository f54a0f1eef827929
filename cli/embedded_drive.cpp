#include "cli/embedded_drive.hpp"

#include <fmt/format.h>

#include <string_view>
#include <utility>

#include "conformance/ethercat_port.hpp"
#include "protocol/ethercat/master.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "reference_drive/deviations.hpp"
#include "reference_drive/ethercat/ethercat_drive.hpp"
#include "reference_drive/servo_drive.hpp"

namespace drivecheck::cli {

// The servo drive's simulated inputs, as the engine's `simulate` steps name them.
class ServoSimulation final : public conformance::SimulationControl {
 public:
  // `port`: the drive's CAN port (bus_off); nullptr behind EtherCAT (no bus-off).
  ServoSimulation(reference_drive::ServoDrive& drive, can::SimPort* port)
      : drive_(drive), port_(port) {}
  std::string set_input(std::string_view input, std::int64_t value) override {
    auto done = drive_.simulate(input, value);
    return done ? std::string() : std::move(done).error();
  }
  // The port goes bus-off first and recovers first: the drive's controller reports the change
  // (ReferenceDrive::set_bus_off) once the port is in that state, so the recovery EMCY goes out.
  bool can_bus_off() const override { return port_ != nullptr; }
  std::string set_bus_off(bool bus_off) override {
    if (port_ == nullptr) return "no CAN controller on this link";
    port_->set_bus_off(bus_off);
    drive_.device().set_bus_off(bus_off);
    return {};
  }
  std::string reset_inputs() override {
    if (port_ != nullptr && port_->bus_off())
      set_bus_off(false);  // a bus_off step that did not end
    // The inputs cia402_application.hpp documents, at their power-on values.
    static constexpr std::pair<std::string_view, std::int64_t> kPowerOn[] = {
        {"hardware-enable", 1},
        {"switch-layout-clear", 0},
        {"limit-positive", -1},
        {"limit-negative", -1},
        {"home-switch", -1},
        {"load-torque", 0},
        {"fault:following-error", 0},
        {"fault:limit-switch", 0},
        {"fault:overcurrent", 0},
        {"fault:over-voltage", 0},
        {"fault:over-temperature", 0},
        // Not an input: a vector that ended with the power stage off (a fault reaction that
        // coasts, e.g. Festo's) leaves the load spinning for minutes on its friction. An
        // operator waits for standstill between tests; on the simulated axis it is immediate.
        {"axis-coast-to-rest", 1},
    };
    for (const auto& [input, value] : kPowerOn) {
      if (auto error = set_input(input, value); !error.empty()) {
        return fmt::format("{} := {}: {}", input, value, error);
      }
    }
    // Festo's sample input (festo_position_sampling.hpp), only where the personality has it.
    if (drive_.position_sampling() != nullptr) {
      if (auto error = set_input("sample-input", 0); !error.empty()) {
        return fmt::format("sample-input := 0: {}", error);
      }
    }
    return {};
  }

 private:
  reference_drive::ServoDrive& drive_;
  can::SimPort* port_;
};

struct EmbeddedDrive::State {
  std::unique_ptr<can::SimPort> port;
  std::unique_ptr<reference_drive::ServoDrive> drive;
  std::unique_ptr<ServoSimulation> simulation;
  std::string personality;
};

EmbeddedDrive::EmbeddedDrive(std::unique_ptr<State> state, std::vector<std::string> deviations)
    : state_(std::move(state)), deviations_(std::move(deviations)) {}

EmbeddedDrive::~EmbeddedDrive() = default;

Expected<std::unique_ptr<EmbeddedDrive>, std::string> EmbeddedDrive::create(
    can::SimBus& bus, std::uint8_t node, const profile::DriveProfile& profile,
    const std::vector<std::string>& deviations) {
  auto parsed = reference_drive::DeviationSet::parse(deviations);
  if (!parsed) return Unexpected(std::move(parsed).error());
  auto state = std::make_unique<State>();
  state->port = bus.attach("drive");
  reference_drive::ServoDriveOptions options;
  options.node = node;
  // The standard profile describes the reference drive as it is: no personality to take.
  const bool standard = profile.name == "cia402-reference";
  options.profile = standard ? nullptr : &profile;
  options.deviations = std::move(*parsed);
  auto drive = reference_drive::ServoDrive::create(*state->port, std::move(options));
  if (!drive) return Unexpected(std::move(drive).error());
  state->drive = std::move(*drive);
  state->simulation = std::make_unique<ServoSimulation>(*state->drive, state->port.get());
  state->personality = standard ? std::string() : profile.name;
  state->drive->power_on();
  return std::unique_ptr<EmbeddedDrive>(new EmbeddedDrive(std::move(state), deviations));
}

conformance::SimulationControl* EmbeddedDrive::simulation() {
  return state_->simulation.get();
}

std::string EmbeddedDrive::personality() const {
  return state_->personality;
}

struct EmbeddedEthercat::State {
  ethercat::SimSegment segment;
  std::unique_ptr<reference_drive::ethercat::EthercatDrive> drive;
  std::unique_ptr<ethercat::Master> master;
  std::unique_ptr<conformance::EthercatPort> port;
  std::unique_ptr<conformance::EthercatClock> clock;
  std::unique_ptr<ServoSimulation> simulation;
  std::string personality;
};

EmbeddedEthercat::EmbeddedEthercat(std::unique_ptr<State> state,
                                   std::vector<std::string> deviations)
    : state_(std::move(state)), deviations_(std::move(deviations)) {}

EmbeddedEthercat::~EmbeddedEthercat() = default;

Expected<std::unique_ptr<EmbeddedEthercat>, std::string> EmbeddedEthercat::create(
    const profile::DriveProfile& profile, const std::vector<std::string>& deviations,
    Monitor monitor) {
  auto parsed = reference_drive::DeviationSet::parse(deviations);
  if (!parsed) return Unexpected(std::move(parsed).error());
  auto state = std::make_unique<State>();
  const bool standard = profile.name == "cia402-reference";
  reference_drive::ethercat::EthercatDriveOptions options;
  options.profile = standard ? nullptr : &profile;
  options.deviations = std::move(*parsed);
  auto drive = reference_drive::ethercat::EthercatDrive::create(state->segment, std::move(options));
  if (!drive) return Unexpected(std::move(drive).error());
  state->drive = std::move(*drive);
  state->segment.attach(*state->drive);
  if (monitor) state->segment.add_monitor(std::move(monitor));
  state->drive->power_on();
  ethercat::MasterConfig config;
  config.scan.expected_slaves = 1;
  state->master = std::make_unique<ethercat::Master>(state->segment, config);
  state->port = std::make_unique<conformance::EthercatPort>(*state->master);
  // The evidence follows the segment from the bring-up on (no vector records yet, but its
  // dissector learns where the mailboxes are).
  state->segment.add_monitor(
      [port = state->port.get()](const ethercat::TimedFrame& frame, ethercat::FrameDirection d) {
        port->evidence().on_frame(frame, d == ethercat::FrameDirection::received);
      });
  if (auto up = state->master->bring_up(ethercat::AlState::preop); !up)
    return Unexpected(fmt::format("EtherCAT bring-up to PREOP: {}", up.error().message()));
  // reset-node on the simulated segment: the drive's own NMT reset node (its application and
  // dictionary as after a reset; ServoDrive::power_on is once only), then the ESC as at power-on.
  state->port->set_power_cycle([drive = state->drive.get()] {
    drive->servo().device().command(cia301::NmtCommand::reset_node);
    drive->power_on();
  });
  state->clock = std::make_unique<conformance::EthercatClock>(state->segment, *state->port);
  state->simulation = std::make_unique<ServoSimulation>(state->drive->servo(), nullptr);
  state->personality = standard ? std::string() : profile.name;
  return std::unique_ptr<EmbeddedEthercat>(new EmbeddedEthercat(std::move(state), deviations));
}

conformance::DutPort& EmbeddedEthercat::port() {
  return *state_->port;
}

ethercat::Master& EmbeddedEthercat::master() {
  return *state_->master;
}

can::Bus& EmbeddedEthercat::clock() {
  return *state_->clock;
}

conformance::SimulationControl* EmbeddedEthercat::simulation() {
  return state_->simulation.get();
}

std::string EmbeddedEthercat::personality() const {
  return state_->personality;
}

}  // namespace drivecheck::cli
