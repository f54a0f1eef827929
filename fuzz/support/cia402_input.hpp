// The input format of the cia402 fuzz target: fixed 6-byte operation records, so that
// mutations keep the operations aligned and dictionary tokens are whole operations.
//
//   byte 0     operation kind, % kCia402OpKinds (Cia402OpKind below)
//   byte 1     selector: which table row (% the table's size), or a sub-kind
//   bytes 2..5 value, little-endian u32 (each kind says how much of it it uses)
//
// Kinds (what the target does with the record; every record is followed by one drive cycle):
//   controlword  6040h := the table row (selector < size) or value bits 0..15 (raw)
//   mode         6060h := kModes row (selector < size) or value bits 0..7 (raw INTEGER8)
//   target       a kTargets object := value (sizes 2 or 4; rows with INTEGER types sign-extend)
//   option_code  a kOptionCodes object := (value % 12) - 2 (selector bit 7 = 0) or raw INT16
//   factor       a kFactors object := value (factor group, 6080h max motor speed, 6072h ...)
//   simulate     a kInputs input := value as that input wants it (cia402_fuzzer.cpp)
//   sync         SYNC (080h), with a counter byte when selector bit 0 is set
//   nmt          kNmtCommands row to the drive's node
//   time         value % 256 ms of time (one cycle per ms)
//   sdo_write    any CiA 402 object 6000h..60FFh (+ value bits 16..23 of the index), sub =
//                selector % 4, size 1/2/4 by value bits 30..31 (an expedited SDO download)
//   personality  as the FIRST record only: the drive impersonates kPersonalities[selector %
//                size] (vectors/drives/<name>.yaml; row 0 the standard drive, which is also
//                the drive of an input that starts with any other record); later: a drive
//                cycle only
// decode_cia402_op() never fails (FuzzInput reads past the end as zeros); encode_cia402_op()
// is its inverse, for the corpus generator.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "fuzz/support/fuzz_input.hpp"

namespace drivecheck::fuzz {

inline constexpr std::size_t kCia402OpSize = 6;

enum class Cia402OpKind : std::uint8_t {
  controlword,
  mode,
  target,
  option_code,
  factor,
  simulate,
  sync,
  nmt,
  time,
  sdo_write,
  personality,
};
inline constexpr std::uint8_t kCia402OpKinds = 11;

// The drives a cia402 input can start as: the standard reference drive, then the manuals'
// personalities (reference_drive/personality.hpp), by profile name.
inline constexpr std::array<std::string_view, 5> kPersonalities{
    "", "festo-cmmp", "kollmorgen-s300-s700", "irtsa-drive-fb", "esr-triodrive"};

struct Cia402Op {
  Cia402OpKind kind = Cia402OpKind::time;
  std::uint8_t selector = 0;
  std::uint32_t value = 0;
};

// Controlword commands (CiA 402-2 §8.4.1 Table "Command coding"; bits 4-6, 8 mode-specific).
inline constexpr std::array<std::uint16_t, 14> kControlwords{
    0x0000,  // disable voltage (transitions 7, 9, 10, 12)
    0x0002,  // quick stop (7, 10, 11)
    0x0006,  // shutdown (2, 6, 8)
    0x0007,  // switch on (3) / disable operation (5)
    0x000F,  // enable operation (4, 16)
    0x0080,  // fault reset (15) on the rising edge
    0x001F,  // enable operation + bit 4 (pp new set-point, hm start, ip enable)
    0x003F,  // + bit 5 (pp change set immediately)
    0x005F,  // + bit 6 (pp relative)
    0x010F,  // enable operation + halt
    0x011F,  // halt with a new set-point
    0x000B,  // quick stop pattern with switch on bits
    0x008F,  // enable operation with fault reset bit (no transition from OE)
    0x000E,  // shutdown with bit 3
};

// 6060h values (CiA 402-2 §6.3.1): pp vl pv hm ip csp csv cst tq, 0 none, negative ones
// (-1 Festo's display, -127 IRTSA mpp / Kollmorgen analogue speed, -128 Kollmorgen digital
// speed).
inline constexpr std::array<std::int8_t, 13> kModes{1, 2, 3, 6, 7, 8, 9, 10, 4, 0, -1, -127, -128};

struct Cia402Object {
  std::uint16_t index;
  std::uint8_t sub;
  std::uint8_t size;  // bytes of the expedited download
  std::string_view name;
};

// Set-points and profile parameters the modes read (CiA 402-2 §11-§14; object list in
// reference_drive/cia402_application.hpp).
inline constexpr std::array<Cia402Object, 13> kTargets{{
    {0x607A, 0, 4, "target position"},
    {0x60FF, 0, 4, "target velocity"},
    {0x6071, 0, 2, "target torque"},
    {0x60C1, 1, 4, "interpolation data record 1"},
    {0x6081, 0, 4, "profile velocity"},
    {0x6083, 0, 4, "profile acceleration"},
    {0x6084, 0, 4, "profile deceleration"},
    {0x6085, 0, 4, "quick stop deceleration"},
    {0x607F, 0, 4, "max profile velocity"},
    {0x6087, 0, 4, "torque slope"},
    {0x6086, 0, 2, "motion profile type"},
    {0x60B1, 0, 4, "velocity offset"},
    {0x60B2, 0, 2, "torque offset"},
}};

// Option codes (CiA 402-2 §8.4: 605Ah quick stop, 605Bh shutdown, 605Ch disable operation,
// 605Dh halt, 605Eh fault reaction; CiA 402-2 6007h abort connection).
inline constexpr std::array<std::uint16_t, 6> kOptionCodes{0x605A, 0x605B, 0x605C,
                                                           0x605D, 0x605E, 0x6007};

// Scaling and limits (CiA 402-2 §6.4 factor group; 6080h, 6072h, 607Dh, 607Eh).
inline constexpr std::array<Cia402Object, 14> kFactors{{
    {0x6091, 1, 4, "gear ratio motor revolutions"},
    {0x6091, 2, 4, "gear ratio shaft revolutions"},
    {0x6092, 1, 4, "feed"},
    {0x6092, 2, 4, "shaft revolutions"},
    {0x6093, 1, 4, "position factor numerator"},
    {0x6093, 2, 4, "position factor divisor"},
    {0x6094, 1, 4, "velocity encoder factor numerator"},
    {0x6094, 2, 4, "velocity encoder factor divisor"},
    {0x6097, 1, 4, "acceleration factor numerator"},
    {0x6097, 2, 4, "acceleration factor divisor"},
    {0x6080, 0, 4, "max motor speed"},
    {0x6072, 0, 2, "max torque"},
    {0x607E, 0, 1, "polarity"},
    {0x607D, 2, 4, "software position limit max"},
}};

// Simulated inputs (reference_drive/cia402_application.hpp "simulate"); not axis-position
// (it teleports the axis) and not load-torque (an external torque may move a free axis).
// The mechanical end stops (stop-negative-at, stop-positive-at) stop an axis dead, and
// axis-coast-to-rest puts an unpowered axis at rest: the target's physics oracle knows both
// (cia402_fuzzer.cpp).
// sample-input exists only in the Festo personality (position sampling, §5.15); any other
// drive refuses it.
struct Cia402Input {
  std::string_view name;
  bool position;  // the value is a position (INTEGER32); else 0/1 or -1/0/1 (switches)
  bool tristate;  // -1 layout, 0 off, 1 on
  bool one;       // the value is always 1 (an act, not a level)
  std::string_view personality = {};  // only this kPersonalities row has it ("": all)
};
inline constexpr std::array<Cia402Input, 16> kInputs{{
    {"hardware-enable", false, false, false},
    {"limit-positive", false, true, false},
    {"limit-negative", false, true, false},
    {"home-switch", false, true, false},
    {"limit-positive-at", true, false, false},
    {"limit-negative-at", true, false, false},
    {"home-switch-from", true, false, false},
    {"fault:following-error", false, false, false},
    {"fault:limit-switch", false, false, false},
    {"fault:overcurrent", false, false, false},
    {"fault:over-voltage", false, false, false},
    {"fault:over-temperature", false, false, false},
    {"stop-negative-at", true, false, false},
    {"stop-positive-at", true, false, false},
    {"axis-coast-to-rest", false, false, true},
    {"sample-input", false, false, false, "festo-cmmp"},
}};

// NMT command specifiers (CiA 301 §7.2.8.3.1): start, pre-operational, stop, reset node,
// reset communication.
inline constexpr std::array<std::uint8_t, 5> kNmtCommands{0x01, 0x80, 0x02, 0x81, 0x82};

inline Cia402Op decode_cia402_op(FuzzInput& input) {
  Cia402Op op;
  op.kind = static_cast<Cia402OpKind>(input.u8() % kCia402OpKinds);
  op.selector = input.u8();
  op.value = input.u32();
  return op;
}

inline std::array<std::uint8_t, kCia402OpSize> encode_cia402_op(const Cia402Op& op) {
  return {static_cast<std::uint8_t>(op.kind),        op.selector,
          static_cast<std::uint8_t>(op.value),       static_cast<std::uint8_t>(op.value >> 8),
          static_cast<std::uint8_t>(op.value >> 16), static_cast<std::uint8_t>(op.value >> 24)};
}

}  // namespace drivecheck::fuzz
