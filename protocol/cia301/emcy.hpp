// EMCY, the emergency object (CiA 301 §7.2.7), and the error register 1001h.
//
// EMCY frame, CAN-ID 080h + node (configurable in 1014h), DLC 8, sent by a device when an
// error occurs and when errors are reset:
//
//   bytes 0..1  error code, UNSIGNED16 little-endian (0000h = error reset / no error)
//   byte 2      error register (object 1001h, bits below)
//   bytes 3..7  manufacturer-specific error field (Festo CMMP-AS: always 0)
//
//   Festo CMMP-AS §3.5.2 (000_33c1d912b8b6010a.txt L1276-1296): "consists of eight data
//   bytes", bytes 3-7 zero; Dunker §11.1 (004_956552dcd17e975a.txt L750-764) the same;
//   Kollmorgen example (002_953174ea6ca45cdb.txt L7832-7837): 081#1043080000000000 = 4310h
//   motor temperature, register 08h (temperature).
//
// Error register 1001h (UNSIGNED8):
//   bit 0  generic error (set whenever any error is present)
//   bit 1  current
//   bit 2  voltage
//   bit 3  temperature
//   bit 4  communication error (overrun, error state)
//   bit 5  device profile specific
//   bit 6  reserved (always 0)
//   bit 7  manufacturer specific
//
// 1014h COB-ID EMCY (UNSIGNED32): bit 31 = 1 EMCY not valid (not produced), bit 30 reserved,
// bit 29 = 1 29-bit CAN-ID, bits 28..0 CAN-ID. 1015h inhibit time EMCY: UNSIGNED16, 100 µs.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/decode_error.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kEmcyBase = 0x080;

// The codes of the table that name one code (mask FFFFh) or a class (mask FF00h/F000h; the
// enumerator is the class's base value).
enum class EmcyCode : std::uint16_t {
#define DRIVECHECK_EMCY_CODE(name, code, mask, text, source) name = code,
#include "protocol/cia301/emcy_codes.inc"
#undef DRIVECHECK_EMCY_CODE
};

struct EmcyCodeInfo {
  EmcyCode code;
  std::uint16_t mask;       // FFFFh one code, FF00h/F000h a class
  std::string_view name;    // enumerator name, e.g. "following_error"
  std::string_view text;    // the standard's words, e.g. "Following error"
  std::string_view source;  // where the code is defined / confirmed

  bool matches(std::uint16_t value) const {
    return (value & mask) == static_cast<std::uint16_t>(code);
  }
};

// Every row of emcy_codes.inc, in ascending order of code.
std::span<const EmcyCodeInfo> emcy_code_table();

// The most specific row that matches the value (a full code before its class), or nullopt for
// a value in no class of the table (e.g. 1100h, A000h).
std::optional<EmcyCodeInfo> find_emcy_code(std::uint16_t value);

// Every matching row, most general first: 8611h → Monitoring, Positioning controller,
// Following error.
std::vector<EmcyCodeInfo> emcy_code_hierarchy(std::uint16_t value);

// "8611h Following error", "7380h Sensor (class 73xxh)", "A000h (unknown error code)".
std::string describe_emcy_code(std::uint16_t value);

enum class ErrorRegisterBit : std::uint8_t {
  generic = 0x01,
  current = 0x02,
  voltage = 0x04,
  temperature = 0x08,
  communication = 0x10,
  device_profile = 0x20,
  reserved = 0x40,
  manufacturer = 0x80,
};
std::string_view to_string(ErrorRegisterBit bit);
// Names of the set bits joined by '+': "generic+temperature"; "none" for 0.
std::string describe_error_register(std::uint8_t value);

struct Emcy {
  std::uint16_t error_code = 0;
  std::uint8_t error_register = 0;
  std::array<std::uint8_t, 5> manufacturer{};

  bool is_error_reset() const { return error_code == 0x0000; }
  friend bool operator==(const Emcy&, const Emcy&) = default;
};

// An EMCY frame on `cob_id` (use emcy_cob_id(node) for the default 80h + node), in the frame
// format 1014h bit 29 selects. Precondition: cob_id fits the format.
can::Frame encode(const Emcy& message, std::uint32_t cob_id,
                  can::IdFormat format = can::IdFormat::standard);
// 80h + node. Precondition: node 1..127.
std::uint16_t emcy_cob_id(std::uint8_t node);

// Decodes the payload of an EMCY frame (the identifier is the caller's business: EMCY COB-IDs
// are configurable). Invalid: remote or error frame, DLC other than 8.
Expected<Emcy, DecodeError> decode_emcy(const can::Frame& frame);

// 1014h COB-ID EMCY.
struct EmcyCobIdEntry {
  bool valid = true;      // bit 31 = 0
  bool extended = false;  // bit 29
  std::uint32_t can_id = 0;

  std::uint32_t encode() const;
  friend bool operator==(const EmcyCobIdEntry&, const EmcyCobIdEntry&) = default;
};
// Invalid: an 11-bit CAN-ID with any of bits 28..11 set.
Expected<EmcyCobIdEntry, DecodeError> decode_emcy_cob_id_entry(std::uint32_t value);

}  // namespace drivecheck::cia301
