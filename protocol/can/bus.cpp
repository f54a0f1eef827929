#include "protocol/can/bus.hpp"

#include <string>

namespace drivecheck::can {

namespace {

class BusCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "can-bus"; }
  std::string message(int value) const override {
    switch (static_cast<BusError>(value)) {
      case BusError::bus_off:
        return "the node is bus-off";
      case BusError::queue_full:
        return "transmit queue full (ENOBUFS) past the send timeout";
      case BusError::interface_down:
        return "the CAN interface is down";
      case BusError::no_such_interface:
        return "no CAN interface of that name";
      case BusError::no_can_in_kernel:
        return "the kernel has no SocketCAN support (socket(PF_CAN) failed)";
      case BusError::invalid_frame:
        return "invalid CAN frame (identifier or DLC out of range)";
      case BusError::io_error:
        return "CAN I/O error";
    }
    return "unknown CAN bus error";
  }
};

}  // namespace

const std::error_category& bus_category() {
  static const BusCategory category;
  return category;
}

std::error_code make_error_code(BusError error) {
  return {static_cast<int>(error), bus_category()};
}

}  // namespace drivecheck::can
