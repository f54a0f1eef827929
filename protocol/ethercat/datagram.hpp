// EtherCAT datagrams (IEC 61158-4-12 / ETG.1000.4 DL PDU; ESC Technology §2.3): the command
// table, the datagram as a value, and the decode errors of the frame codec (frame.hpp).
//
// One datagram on the wire, little-endian, 10 + n + 2 bytes:
//
//   byte 0      Cmd      command code (datagram_commands.inc)
//   byte 1      Idx      index: the master's tag, returned unchanged
//   bytes 2..5  Address  position/station addressing: ADP (u16, bytes 2..3) then ADO
//                        (u16 register offset, bytes 4..5); logical: one u32
//   bytes 6..7  Len      bits 0..10 data length n, bits 11..13 reserved (0), bit 14 C
//                        (circulating frame), bit 15 M (more datagrams follow)
//   bytes 8..9  IRQ      event request, ORed in by the ESCs
//   10..10+n-1  Data
//   last 2      WKC      working counter
//
// `Datagram::address` holds bytes 2..5 as one little-endian u32, so ADP is its low half and ADO
// its high half: Datagram::physical(FPRD, idx, station 1001h, register 0130h, ...) has
// address 0130'1001h.
#pragma once

#include <fmt/format.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "protocol/common/expected.hpp"

namespace drivecheck::ethercat {

enum class Addressing : std::uint8_t { none, position, station, broadcast, logical };
enum class Access : std::uint8_t { none, read, write, read_write, read_multiple_write };
enum class WkcRule : std::uint8_t { none, one, read_write, multiple_write };

enum class Command : std::uint8_t {
#define DRIVECHECK_ECAT_COMMAND(name, code, mnemonic, addressing, access, wkc, source) name = code,
#include "protocol/ethercat/datagram_commands.inc"
#undef DRIVECHECK_ECAT_COMMAND
};

struct CommandInfo {
  Command command;
  std::string_view mnemonic;  // "APRD"
  Addressing addressing;
  Access access;
  WkcRule wkc;
  std::string_view source;
};

// Every command, in ascending order of code (0..14, no gaps).
std::span<const CommandInfo> command_table();
// The row of a code; nullopt for the codes 15..255 that no table defines.
std::optional<CommandInfo> find_command(std::uint8_t code);
// "APRD", or "CMD 1Fh" for an undefined code.
std::string command_name(Command command);

inline constexpr std::size_t kDatagramHeaderSize = 10;
inline constexpr std::size_t kWorkingCounterSize = 2;
inline constexpr std::size_t kDatagramOverhead = kDatagramHeaderSize + kWorkingCounterSize;
inline constexpr std::size_t kMaxDatagramDataLength = 0x7FF;  // the 11-bit Len field

struct Datagram {
  Command command = Command::nop;
  std::uint8_t index = 0;
  std::uint32_t address = 0;  // ADP | ADO << 16, or the logical address
  bool circulating = false;   // C bit
  std::uint8_t reserved = 0;  // Len bits 11..13 (0 on the wire; kept so decoding is exact)
  // M bit as decoded. The encoder writes M itself (set on every datagram but the last).
  bool more_follows = false;
  std::uint16_t irq = 0;
  std::vector<std::uint8_t> data;
  std::uint16_t working_counter = 0;

  std::uint16_t adp() const { return static_cast<std::uint16_t>(address & 0xFFFF); }
  std::uint16_t ado() const { return static_cast<std::uint16_t>(address >> 16); }

  // A position/station/broadcast datagram: ADP and ADO.
  static Datagram physical(Command command, std::uint8_t index, std::uint16_t adp,
                           std::uint16_t ado, std::vector<std::uint8_t> data);
  // A logical datagram.
  static Datagram logical(Command command, std::uint8_t index, std::uint32_t address,
                          std::vector<std::uint8_t> data);

  friend bool operator==(const Datagram&, const Datagram&) = default;
};

// Why a frame or datagram could not be decoded or encoded (std::error_code, category
// "ethercat-frame"). Tests compare these codes, never the text.
enum class FrameError {
  truncated_ethernet_header = 1,  // fewer than 14 bytes (or 18 with a VLAN tag)
  wrong_ethertype,                // not 88A4h (after an optional 8100h VLAN tag)
  truncated_ethercat_header,      // no room for the 2-byte EtherCAT header
  unsupported_type,               // EtherCAT header type is not 1 (DLPDU)
  length_past_end,                // EtherCAT header length runs past the end of the frame
  no_datagrams,                   // EtherCAT header length 0
  truncated_datagram_header,      // fewer than 10 bytes left for a datagram header
  datagram_length_past_end,       // a datagram's Len runs past the EtherCAT length
  more_follows_past_end,          // M set on the last datagram the length holds
  trailing_bytes,                 // bytes within the EtherCAT length after a datagram with M=0
  unknown_command,                // command code not in datagram_commands.inc
  datagram_too_long,              // encode: data longer than the 11-bit Len field allows
  frame_too_long,                 // encode: frame longer than 1514 bytes (no FCS)
};
const std::error_category& frame_category();
std::error_code make_error_code(FrameError error);

// A decode error and the byte offset in the frame where decoding stopped.
struct DecodeError {
  std::error_code code;
  std::size_t offset = 0;
  // "datagram 2 at byte 38: datagram length runs past the EtherCAT length (Len 200, 24 left)"
  std::string detail;
  std::string message() const;
};

// Appends the encoded datagrams (M set on all but the last). Errors: datagram_too_long.
std::error_code encode_datagrams(std::span<const Datagram> datagrams,
                                 std::vector<std::uint8_t>& out);
// The encoded size of the datagrams (header, data and WKC each).
std::size_t encoded_size(std::span<const Datagram> datagrams);

// Where each datagram of an EtherCAT payload starts and how long its data is (offsets relative
// to `payload`): the one structural parser, shared by decode_datagrams and the ESC model, which
// processes frames in place.
struct DatagramSpan {
  std::size_t offset = 0;       // the Cmd byte
  std::size_t data_length = 0;  // n
};
// Walks the datagrams of `payload` (exactly the EtherCAT header's length) into `spans`
// (cleared first). `base` is added to error offsets (the payload's offset in the frame).
// Command codes are not checked here: an ESC passes unknown commands on untouched.
std::optional<DecodeError> walk_datagrams(std::span<const std::uint8_t> payload, std::size_t base,
                                          std::vector<DatagramSpan>& spans);

// Decodes the datagrams of an EtherCAT payload (the bytes after the EtherCAT header, exactly
// its length). Unknown command codes are an error (unknown_command).
Expected<std::vector<Datagram>, DecodeError> decode_datagrams(std::span<const std::uint8_t> payload,
                                                              std::size_t base = 0);

}  // namespace drivecheck::ethercat

template <>
struct std::is_error_code_enum<drivecheck::ethercat::FrameError> : std::true_type {};

// "FPRD idx=03 adp=1001h ado=0130h len=2 wkc=1 data=08 00" (data in hex, at most 32 bytes then
// "..."); logical datagrams print "addr=00010000h".
template <>
struct fmt::formatter<drivecheck::ethercat::Datagram> : fmt::formatter<std::string_view> {
  fmt::format_context::iterator format(const drivecheck::ethercat::Datagram& datagram,
                                       fmt::format_context& ctx) const;
};
