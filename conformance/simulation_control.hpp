// How `simulate` steps reach a simulated drive: the embedded reference drive implements this
// interface (cli/embedded_drive.hpp); a real drive has none, and vectors that need the
// `simulation` feature are then not applicable. The engine never includes reference-drive code:
// this interface is the only thing the two share besides the bus.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace drivecheck::conformance {

class SimulationControl {
 public:
  virtual ~SimulationControl() = default;
  // Sets a simulated input (FORMAT.md `simulate`: hardware-enable, limit-positive,
  // limit-negative, home-switch, fault NAME, axis-position, ...) to `value`. Returns "" on
  // success, else why not (an unknown input name, a value out of range): the vector then ends
  // with a harness error.
  virtual std::string set_input(std::string_view input, std::int64_t value) = 0;
  // Puts every simulated input back to its power-on condition (hardware enable present, no
  // forced switches and no switch layout, no fault cause, no load torque); the axis keeps its
  // position. The engine calls it before each vector's setup. Returns "" or why not.
  virtual std::string reset_inputs() = 0;
  // Puts the DUT's CAN controller bus-off (true) or lets it recover (false): FORMAT.md
  // `bus_off`. Returns "" or why not. Only a DUT on the simulated bus can do this.
  virtual bool can_bus_off() const { return false; }
  virtual std::string set_bus_off(bool bus_off) {
    (void)bus_off;
    return "the DUT's CAN controller cannot be put bus-off";
  }
};

}  // namespace drivecheck::conformance
