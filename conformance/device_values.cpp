// Values from the device (device_values.hpp): the table. The engine finds them on the DUT in
// device_value_steps.cpp.
#include "conformance/device_values.hpp"

#include <algorithm>
#include <array>

namespace drivecheck::conformance {
namespace {

constexpr std::array kDeviceValues{
    DeviceValueInfo{"dut.tpdo_object",
                    "a mapping entry of an object the DUT can map into a TPDO (EDS, else its "
                    "default TPDO mapping, else 1001h)"},
    DeviceValueInfo{"dut.unsupported_mode",
                    "a CiA 402-2 mode of operation that the DUT's 6502h does not list"},
    DeviceValueInfo{"dut.node_id", "the DUT's node-ID (the one the run addresses it with, --node)"},
};

}  // namespace

std::span<const DeviceValueInfo> device_value_table() {
  return kDeviceValues;
}

bool is_device_value(std::string_view name) {
  return std::any_of(kDeviceValues.begin(), kDeviceValues.end(),
                     [&](const DeviceValueInfo& row) { return row.name == name; });
}

std::int8_t unsupported_mode(std::uint32_t supported) {
  for (const auto mode : kStandardModes) {
    if ((supported & (1U << (mode - 1))) == 0) return mode;
  }
  return 0;
}

}  // namespace drivecheck::conformance
