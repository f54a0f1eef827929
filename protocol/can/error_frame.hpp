// SocketCAN error frames (linux/can/error.h): what a CAN controller reports about the bus,
// decoded into fields and described in words.
//
// An error frame is a Frame with FrameKind::error. Its id carries the error classes (one bit
// each, several may be set); its 8 data bytes (CAN_ERR_DLC) carry the details:
//
//   id bit 0  0x001  tx_timeout        transmit timeout (by the network device driver)
//   id bit 1  0x002  lost_arbitration  data[0]: bit number where arbitration was lost (0: unknown)
//   id bit 2  0x004  controller        data[1]: controller status (ControllerStatus bits)
//   id bit 3  0x008  protocol          data[2]: violation type (ProtocolViolation bits)
//                                      data[3]: where in the frame (ProtocolLocation)
//   id bit 4  0x010  transceiver       data[4]: transceiver status (CAN-H / CAN-L wiring)
//   id bit 5  0x020  no_ack            no other node acknowledged a transmitted frame
//   id bit 6  0x040  bus_off           the controller went bus-off
//   id bit 7  0x080  bus_error         a bus error (may flood)
//   id bit 8  0x100  restarted         the controller restarted (after bus-off)
//   id bit 9  0x200  counters          data[6]: transmit error counter, data[7]: receive error
//   counter data[5]: controller-specific additional information
//
// The numeric values are the Linux ABI (static_asserts in socketcan_bus.cpp check them
// against the kernel headers); this header itself is plain C++ and includes no Linux header.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "protocol/can/frame.hpp"

namespace drivecheck::can {

// Error classes: bits of an error frame's id.
namespace error_class {
inline constexpr std::uint32_t kTxTimeout = 0x001;
inline constexpr std::uint32_t kLostArbitration = 0x002;
inline constexpr std::uint32_t kController = 0x004;
inline constexpr std::uint32_t kProtocol = 0x008;
inline constexpr std::uint32_t kTransceiver = 0x010;
inline constexpr std::uint32_t kNoAck = 0x020;
inline constexpr std::uint32_t kBusOff = 0x040;
inline constexpr std::uint32_t kBusError = 0x080;
inline constexpr std::uint32_t kRestarted = 0x100;
inline constexpr std::uint32_t kCounters = 0x200;
inline constexpr std::uint32_t kAll = 0x1FFFFFFF;  // CAN_ERR_MASK
}  // namespace error_class

// data[1] of a controller-class error frame.
namespace controller_status {
inline constexpr std::uint8_t kRxOverflow = 0x01;
inline constexpr std::uint8_t kTxOverflow = 0x02;
inline constexpr std::uint8_t kRxWarning = 0x04;  // receive error counter reached 96
inline constexpr std::uint8_t kTxWarning = 0x08;  // transmit error counter reached 96
inline constexpr std::uint8_t kRxPassive = 0x10;  // receive error counter reached 128
inline constexpr std::uint8_t kTxPassive = 0x20;  // transmit error counter reached 128
inline constexpr std::uint8_t kActive = 0x40;     // back to error active
}  // namespace controller_status

// data[2] of a protocol-class error frame.
namespace protocol_violation {
inline constexpr std::uint8_t kBit = 0x01;       // single bit error
inline constexpr std::uint8_t kForm = 0x02;      // frame format error
inline constexpr std::uint8_t kStuff = 0x04;     // bit stuffing error
inline constexpr std::uint8_t kBit0 = 0x08;      // unable to send a dominant bit
inline constexpr std::uint8_t kBit1 = 0x10;      // unable to send a recessive bit
inline constexpr std::uint8_t kOverload = 0x20;  // bus overload
inline constexpr std::uint8_t kActive = 0x40;    // active error announcement
inline constexpr std::uint8_t kTx = 0x80;        // the error occurred on transmission
}  // namespace protocol_violation

// Decoded error frame. Only the fields of the classes that are set carry meaning.
struct ErrorFrameInfo {
  std::uint32_t classes = 0;                   // error_class bits
  std::uint8_t lost_arbitration_bit = 0;       // data[0]; 0 = unspecified
  std::uint8_t controller = 0;                 // data[1]: controller_status bits
  std::uint8_t protocol = 0;                   // data[2]: protocol_violation bits
  std::uint8_t protocol_location = 0;          // data[3]: CAN_ERR_PROT_LOC_* value
  std::uint8_t transceiver = 0;                // data[4]: CAN_ERR_TRX_* value
  std::uint8_t controller_specific = 0;        // data[5]
  std::optional<std::uint8_t> tx_error_count;  // data[6] when kCounters is set
  std::optional<std::uint8_t> rx_error_count;  // data[7] when kCounters is set

  bool has(std::uint32_t error_class_bits) const { return (classes & error_class_bits) != 0; }
};

// The decoded fields of an error frame; nullopt for data and remote frames.
std::optional<ErrorFrameInfo> decode_error_frame(const Frame& frame);

// One line in words, classes in bit order, joined by "; ", e.g.
//   "bus-off"
//   "controller problem: transmit error passive; error counters: tx 128, rx 0"
//   "protocol violation: bit stuffing error, on transmission, at the CRC sequence"
// "not an error frame" for data and remote frames; "error frame without error class" for
// an error frame whose id has no class bit set.
std::string describe_error_frame(const Frame& frame);

// The name of a protocol-violation location (data[3]), e.g. "the ACK slot"; "location 0xNN"
// for values linux/can/error.h does not name.
std::string describe_protocol_location(std::uint8_t location);

}  // namespace drivecheck::can
