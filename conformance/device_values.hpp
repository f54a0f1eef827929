// Values a vector takes from the device under test at run time, where CiA 301/402 leave the
// device a choice that a fixed value in the vector would make for it (issue 17 §6): which
// object it can map into a TPDO, which mode of operation it does not support. A vector writes
// `$dut.<name>` wherever it takes a value (sdo_write value, sdo_read expect value); the engine
// finds the value once per run, after the setup of the first vector that uses it, and the
// evidence shows the reads it took (vectors/FORMAT.md "Values from the device").
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

namespace drivecheck::conformance {

struct DeviceValueInfo {
  std::string_view name;  // without "$": "dut.tpdo_object"
  std::string_view meaning;
};

// The closed list (FORMAT.md prints it):
//   dut.tpdo_object: a PDO mapping entry (index << 16 | sub << 8 | length in bits, CiA 301
//     §7.5.2.36) of an object the DUT can map into a TPDO. From the EDS when one is given
//     (PDOMapping=1, readable, 8..32 bits; 1001h first, else the lowest index); else the first
//     entry of the DUT's default mapping of TPDO1..4 (1A00h..1A03h sub 1, read right after the
//     reset); else 10010008h (1001h error register) as the last resort.
//   dut.unsupported_mode: a mode of operation of CiA 402-2 (6060h: 1 pp, 2 vl, 3 pv, 4 tq,
//     6 hm, 7 ip, 8 csp, 9 csv, 10 cst) that 6502h (supported drive modes, bit n-1 for mode n)
//     does not list: read 6502h; the lowest such mode. A drive that lists every one: the
//     vector is not applicable.
//   dut.node_id: the DUT's node-ID, the one the run addresses it with (--node): for values
//     CiA 301 defines as a base plus the node-ID (1200h sub 01h = 600h + node-ID), written
//     `$dut.node_id+0x600`.
std::span<const DeviceValueInfo> device_value_table();
bool is_device_value(std::string_view name);  // name without "$"

// The standard modes of CiA 402-2 whose support 6502h shows (bit mode-1).
inline constexpr std::int8_t kStandardModes[] = {1, 2, 3, 4, 6, 7, 8, 9, 10};
// The lowest standard mode whose bit is clear in `supported` (6502h), or 0 when none is.
std::int8_t unsupported_mode(std::uint32_t supported);

}  // namespace drivecheck::conformance
