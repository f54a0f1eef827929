#include "protocol/ethercat/datagram.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>

namespace drivecheck::ethercat {
namespace {

constexpr CommandInfo kCommands[] = {
#define DRIVECHECK_ECAT_COMMAND(name, code, mnemonic, addressing, access, wkc, source) \
  {Command::name, mnemonic, Addressing::addressing, Access::access, WkcRule::wkc, source},
#include "protocol/ethercat/datagram_commands.inc"
#undef DRIVECHECK_ECAT_COMMAND
};

constexpr bool codes_are_dense() {
  for (std::size_t i = 0; i < std::size(kCommands); ++i) {
    if (static_cast<std::size_t>(kCommands[i].command) != i) return false;
  }
  return true;
}
static_assert(codes_are_dense(), "datagram_commands.inc must list codes 0, 1, 2, ... in order");

constexpr std::uint16_t kLengthMask = 0x07FF;
constexpr std::uint16_t kCirculatingBit = 0x4000;
constexpr std::uint16_t kMoreFollowsBit = 0x8000;

std::uint16_t read_u16(std::span<const std::uint8_t> bytes, std::size_t at) {
  return static_cast<std::uint16_t>(bytes[at] | (bytes[at + 1] << 8));
}

class FrameCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "ethercat-frame"; }
  std::string message(int value) const override {
    switch (static_cast<FrameError>(value)) {
      case FrameError::truncated_ethernet_header:
        return "frame shorter than its Ethernet header";
      case FrameError::wrong_ethertype:
        return "EtherType is not 88A4h (EtherCAT)";
      case FrameError::truncated_ethercat_header:
        return "no room for the EtherCAT header";
      case FrameError::unsupported_type:
        return "EtherCAT header type is not 1 (datagrams)";
      case FrameError::length_past_end:
        return "EtherCAT header length runs past the end of the frame";
      case FrameError::no_datagrams:
        return "EtherCAT header length is 0 (no datagram)";
      case FrameError::truncated_datagram_header:
        return "datagram header cut off by the EtherCAT length";
      case FrameError::datagram_length_past_end:
        return "datagram length runs past the EtherCAT length";
      case FrameError::more_follows_past_end:
        return "more-follows bit set on the last datagram the EtherCAT length holds";
      case FrameError::trailing_bytes:
        return "bytes within the EtherCAT length after the last datagram (M=0)";
      case FrameError::unknown_command:
        return "unknown datagram command code";
      case FrameError::datagram_too_long:
        return "datagram data longer than 2047 bytes (11-bit length field)";
      case FrameError::frame_too_long:
        return "frame longer than 1514 bytes";
    }
    return fmt::format("unknown ethercat-frame error {}", value);
  }
};

}  // namespace

std::span<const CommandInfo> command_table() {
  return kCommands;
}

std::optional<CommandInfo> find_command(std::uint8_t code) {
  if (code >= std::size(kCommands)) return std::nullopt;
  return kCommands[code];
}

std::string command_name(Command command) {
  if (const auto info = find_command(static_cast<std::uint8_t>(command))) {
    return std::string(info->mnemonic);
  }
  return fmt::format("CMD {:02X}h", static_cast<unsigned>(command));
}

Datagram Datagram::physical(Command command, std::uint8_t index, std::uint16_t adp,
                            std::uint16_t ado, std::vector<std::uint8_t> data) {
  Datagram datagram;
  datagram.command = command;
  datagram.index = index;
  datagram.address = static_cast<std::uint32_t>(adp) | (static_cast<std::uint32_t>(ado) << 16);
  datagram.data = std::move(data);
  return datagram;
}

Datagram Datagram::logical(Command command, std::uint8_t index, std::uint32_t address,
                           std::vector<std::uint8_t> data) {
  Datagram datagram;
  datagram.command = command;
  datagram.index = index;
  datagram.address = address;
  datagram.data = std::move(data);
  return datagram;
}

const std::error_category& frame_category() {
  static const FrameCategory category;
  return category;
}

std::error_code make_error_code(FrameError error) {
  return {static_cast<int>(error), frame_category()};
}

std::string DecodeError::message() const {
  if (detail.empty()) return fmt::format("at byte {}: {}", offset, code.message());
  return fmt::format("at byte {}: {} ({})", offset, code.message(), detail);
}

std::size_t encoded_size(std::span<const Datagram> datagrams) {
  std::size_t size = 0;
  for (const Datagram& datagram : datagrams)
    size += kDatagramOverhead + datagram.data.size();
  return size;
}

std::error_code encode_datagrams(std::span<const Datagram> datagrams,
                                 std::vector<std::uint8_t>& out) {
  for (const Datagram& datagram : datagrams) {
    if (datagram.data.size() > kMaxDatagramDataLength) return FrameError::datagram_too_long;
  }
  out.reserve(out.size() + encoded_size(datagrams));
  for (std::size_t i = 0; i < datagrams.size(); ++i) {
    const Datagram& datagram = datagrams[i];
    auto len = static_cast<std::uint16_t>(datagram.data.size());
    len |= static_cast<std::uint16_t>((datagram.reserved & 0x07) << 11);
    if (datagram.circulating) len |= kCirculatingBit;
    if (i + 1 < datagrams.size()) len |= kMoreFollowsBit;
    const std::uint8_t header[kDatagramHeaderSize] = {
        static_cast<std::uint8_t>(datagram.command),
        datagram.index,
        static_cast<std::uint8_t>(datagram.address),
        static_cast<std::uint8_t>(datagram.address >> 8),
        static_cast<std::uint8_t>(datagram.address >> 16),
        static_cast<std::uint8_t>(datagram.address >> 24),
        static_cast<std::uint8_t>(len),
        static_cast<std::uint8_t>(len >> 8),
        static_cast<std::uint8_t>(datagram.irq),
        static_cast<std::uint8_t>(datagram.irq >> 8),
    };
    out.insert(out.end(), std::begin(header), std::end(header));
    out.insert(out.end(), datagram.data.begin(), datagram.data.end());
    out.push_back(static_cast<std::uint8_t>(datagram.working_counter));
    out.push_back(static_cast<std::uint8_t>(datagram.working_counter >> 8));
  }
  return {};
}

std::optional<DecodeError> walk_datagrams(std::span<const std::uint8_t> payload, std::size_t base,
                                          std::vector<DatagramSpan>& spans) {
  spans.clear();
  if (payload.empty()) return DecodeError{FrameError::no_datagrams, base, {}};
  std::size_t at = 0;
  for (;;) {
    const std::size_t number = spans.size() + 1;
    if (payload.size() - at < kDatagramHeaderSize) {
      return DecodeError{FrameError::truncated_datagram_header, base + at,
                         fmt::format("datagram {}: {} bytes left, the header needs 10", number,
                                     payload.size() - at)};
    }
    const std::uint16_t len_field = read_u16(payload, at + 6);
    const std::size_t length = len_field & kLengthMask;
    const std::size_t left = payload.size() - at - kDatagramHeaderSize;
    if (length + kWorkingCounterSize > left) {
      return DecodeError{
          FrameError::datagram_length_past_end, base + at,
          fmt::format("datagram {}: Len {} plus WKC, {} bytes left", number, length, left)};
    }
    spans.push_back({at, length});
    at += kDatagramOverhead + length;
    const bool more = (len_field & kMoreFollowsBit) != 0;
    if (!more) {
      if (at != payload.size()) {
        return DecodeError{FrameError::trailing_bytes, base + at,
                           fmt::format("{} bytes after datagram {}", payload.size() - at, number)};
      }
      return std::nullopt;
    }
    if (at == payload.size()) {
      return DecodeError{FrameError::more_follows_past_end, base + spans.back().offset,
                         fmt::format("datagram {}", number)};
    }
  }
}

Expected<std::vector<Datagram>, DecodeError> decode_datagrams(std::span<const std::uint8_t> payload,
                                                              std::size_t base) {
  std::vector<DatagramSpan> spans;
  if (auto error = walk_datagrams(payload, base, spans)) return Unexpected(std::move(*error));
  std::vector<Datagram> datagrams;
  datagrams.reserve(spans.size());
  for (std::size_t i = 0; i < spans.size(); ++i) {
    const DatagramSpan& span = spans[i];
    const auto bytes = payload.subspan(span.offset, kDatagramOverhead + span.data_length);
    if (!find_command(bytes[0])) {
      return Unexpected(DecodeError{FrameError::unknown_command, base + span.offset,
                                    fmt::format("datagram {}: command {:02X}h", i + 1, bytes[0])});
    }
    Datagram datagram;
    datagram.command = static_cast<Command>(bytes[0]);
    datagram.index = bytes[1];
    datagram.address =
        static_cast<std::uint32_t>(bytes[2]) | (static_cast<std::uint32_t>(bytes[3]) << 8) |
        (static_cast<std::uint32_t>(bytes[4]) << 16) | (static_cast<std::uint32_t>(bytes[5]) << 24);
    const std::uint16_t len_field = read_u16(bytes, 6);
    datagram.reserved = static_cast<std::uint8_t>((len_field >> 11) & 0x07);
    datagram.circulating = (len_field & kCirculatingBit) != 0;
    datagram.more_follows = (len_field & kMoreFollowsBit) != 0;
    datagram.irq = read_u16(bytes, 8);
    datagram.data.assign(bytes.begin() + kDatagramHeaderSize,
                         bytes.begin() + kDatagramHeaderSize + span.data_length);
    datagram.working_counter = read_u16(bytes, kDatagramHeaderSize + span.data_length);
    datagrams.push_back(std::move(datagram));
  }
  return datagrams;
}

}  // namespace drivecheck::ethercat

fmt::format_context::iterator fmt::formatter<drivecheck::ethercat::Datagram>::format(
    const drivecheck::ethercat::Datagram& datagram, fmt::format_context& ctx) const {
  using namespace drivecheck::ethercat;
  std::string text = command_name(datagram.command);
  const auto info = find_command(static_cast<std::uint8_t>(datagram.command));
  if (info && info->addressing == Addressing::logical) {
    fmt::format_to(std::back_inserter(text), " idx={:02X} addr={:08X}h", datagram.index,
                   datagram.address);
  } else {
    fmt::format_to(std::back_inserter(text), " idx={:02X} adp={:04X}h ado={:04X}h", datagram.index,
                   datagram.adp(), datagram.ado());
  }
  fmt::format_to(std::back_inserter(text), " len={} wkc={}", datagram.data.size(),
                 datagram.working_counter);
  if (datagram.circulating) text += " C";
  if (datagram.irq != 0) fmt::format_to(std::back_inserter(text), " irq={:04X}h", datagram.irq);
  if (!datagram.data.empty()) {
    text += " data=";
    const std::size_t shown = std::min<std::size_t>(datagram.data.size(), 32);
    for (std::size_t i = 0; i < shown; ++i) {
      if (i != 0) text += ' ';
      fmt::format_to(std::back_inserter(text), "{:02X}", datagram.data[i]);
    }
    if (shown < datagram.data.size()) text += " ...";
  }
  return fmt::formatter<std::string_view>::format(text, ctx);
}
