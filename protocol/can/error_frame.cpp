#include "protocol/can/error_frame.hpp"

#include <fmt/format.h>

#include <string_view>
#include <vector>

namespace drivecheck::can {
namespace {

struct BitName {
  std::uint8_t bit;
  std::string_view name;
};

constexpr BitName kControllerNames[] = {
    {controller_status::kRxOverflow, "receive buffer overflow"},
    {controller_status::kTxOverflow, "transmit buffer overflow"},
    {controller_status::kRxWarning, "receive error warning"},
    {controller_status::kTxWarning, "transmit error warning"},
    {controller_status::kRxPassive, "receive error passive"},
    {controller_status::kTxPassive, "transmit error passive"},
    {controller_status::kActive, "back to error active"},
};

constexpr BitName kProtocolNames[] = {
    {protocol_violation::kBit, "bit error"},
    {protocol_violation::kForm, "form error"},
    {protocol_violation::kStuff, "bit stuffing error"},
    {protocol_violation::kBit0, "unable to send a dominant bit"},
    {protocol_violation::kBit1, "unable to send a recessive bit"},
    {protocol_violation::kOverload, "bus overload"},
    {protocol_violation::kActive, "active error announcement"},
    {protocol_violation::kTx, "on transmission"},
};

// CAN_ERR_PROT_LOC_* values of linux/can/error.h.
struct LocationName {
  std::uint8_t value;
  std::string_view name;
};
constexpr LocationName kLocationNames[] = {
    {0x03, "the start of frame"},
    {0x02, "identifier bits 28-21 (standard: 10-3)"},
    {0x06, "identifier bits 20-18 (standard: 2-0)"},
    {0x04, "the substitute RTR bit (standard: RTR)"},
    {0x05, "the identifier extension bit"},
    {0x07, "identifier bits 17-13"},
    {0x0F, "identifier bits 12-5"},
    {0x0E, "identifier bits 4-0"},
    {0x0C, "the RTR bit"},
    {0x0D, "reserved bit 1"},
    {0x09, "reserved bit 0"},
    {0x0B, "the data length code"},
    {0x0A, "the data field"},
    {0x08, "the CRC sequence"},
    {0x18, "the CRC delimiter"},
    {0x19, "the ACK slot"},
    {0x1B, "the ACK delimiter"},
    {0x1A, "the end of frame"},
    {0x12, "the intermission"},
};

std::string join_bits(std::uint8_t bits, std::span<const BitName> names) {
  std::string text;
  std::uint8_t known = 0;
  for (const auto& entry : names) {
    known = static_cast<std::uint8_t>(known | entry.bit);
    if ((bits & entry.bit) == 0) continue;
    if (!text.empty()) text += ", ";
    text += entry.name;
  }
  const auto unknown = static_cast<std::uint8_t>(bits & ~known);
  if (unknown != 0) {
    if (!text.empty()) text += ", ";
    text += fmt::format("unknown bits 0x{:02X}", unknown);
  }
  return text;
}

// data[4]: the low nibble is CAN-H, the high nibble CAN-L (CAN_ERR_TRX_*).
std::string describe_wire(std::string_view wire, std::uint8_t nibble) {
  switch (nibble) {
    case 0x0:
      return {};
    case 0x4:
      return fmt::format("{} not connected", wire);
    case 0x5:
      return fmt::format("{} short to battery", wire);
    case 0x6:
      return fmt::format("{} short to VCC", wire);
    case 0x7:
      return fmt::format("{} short to GND", wire);
    case 0x8:
      return fmt::format("{} short to CAN-H", wire);
    default:
      return fmt::format("{} status 0x{:X}", wire, nibble);
  }
}

std::string describe_transceiver(std::uint8_t status) {
  if (status == 0) return "unspecified";
  std::string text = describe_wire("CAN-H", status & 0x0F);
  const std::string low = describe_wire("CAN-L", static_cast<std::uint8_t>(status >> 4));
  if (!low.empty()) text += text.empty() ? low : ", " + low;
  return text;
}

}  // namespace

std::optional<ErrorFrameInfo> decode_error_frame(const Frame& frame) {
  if (!frame.is_error()) return std::nullopt;
  ErrorFrameInfo info;
  info.classes = frame.id & kErrorClassMask;
  // Error frames carry CAN_ERR_DLC (8) bytes; bytes past the DLC are zero in a Frame.
  info.lost_arbitration_bit = frame.data[0];
  info.controller = frame.data[1];
  info.protocol = frame.data[2];
  info.protocol_location = frame.data[3];
  info.transceiver = frame.data[4];
  info.controller_specific = frame.data[5];
  if (info.has(error_class::kCounters)) {
    info.tx_error_count = frame.data[6];
    info.rx_error_count = frame.data[7];
  }
  return info;
}

std::string describe_protocol_location(std::uint8_t location) {
  if (location == 0) return "an unspecified location";
  for (const auto& entry : kLocationNames) {
    if (entry.value == location) return std::string(entry.name);
  }
  return fmt::format("location 0x{:02X}", location);
}

std::string describe_error_frame(const Frame& frame) {
  const auto decoded = decode_error_frame(frame);
  if (!decoded) return "not an error frame";
  const ErrorFrameInfo& info = *decoded;
  std::vector<std::string> parts;
  if (info.has(error_class::kTxTimeout)) parts.emplace_back("transmit timeout");
  if (info.has(error_class::kLostArbitration)) {
    parts.push_back(info.lost_arbitration_bit == 0
                        ? std::string("lost arbitration")
                        : fmt::format("lost arbitration at bit {}", info.lost_arbitration_bit));
  }
  if (info.has(error_class::kController)) {
    parts.push_back("controller problem: " + (info.controller == 0
                                                  ? std::string("unspecified")
                                                  : join_bits(info.controller, kControllerNames)));
  }
  if (info.has(error_class::kProtocol)) {
    std::string text = "protocol violation: ";
    text +=
        info.protocol == 0 ? std::string("unspecified") : join_bits(info.protocol, kProtocolNames);
    if (info.protocol_location != 0)
      text += ", at " + describe_protocol_location(info.protocol_location);
    parts.push_back(std::move(text));
  }
  if (info.has(error_class::kTransceiver)) {
    parts.push_back("transceiver: " + describe_transceiver(info.transceiver));
  }
  if (info.has(error_class::kNoAck)) parts.emplace_back("no ACK: no other node acknowledged");
  if (info.has(error_class::kBusOff)) parts.emplace_back("bus-off");
  if (info.has(error_class::kBusError)) parts.emplace_back("bus error");
  if (info.has(error_class::kRestarted)) parts.emplace_back("controller restarted");
  if (info.has(error_class::kCounters)) {
    parts.push_back(
        fmt::format("error counters: tx {}, rx {}", *info.tx_error_count, *info.rx_error_count));
  }
  const std::uint32_t unknown = info.classes & ~0x3FFu;
  if (unknown != 0) parts.push_back(fmt::format("unknown error classes 0x{:X}", unknown));
  if (parts.empty()) return "error frame without error class";
  std::string text = parts.front();
  for (std::size_t i = 1; i < parts.size(); ++i)
    text += "; " + parts[i];
  return text;
}

}  // namespace drivecheck::can
