// The process data image of the EtherCAT front end: what SM2 (outputs, RxPDOs) and SM3 (inputs,
// TxPDOs) carry, read from the PDO assignment 1C12h/1C13h (ETG.1000.6 CoE, Festo 000 §4.6.2)
// and the mapping records it names (1600h+ / 1A00h+, the CiA 301 §7.5.2.36/38 entry layout:
// bits 31..16 index, 15..8 sub-index, 7..0 length in bits).
//
// Layout: the assigned PDOs in assignment order (1C1xh sub 1, 2, ...), each PDO's entries in
// mapping order (sub 1..sub 0), packed from bit 0 of byte 0 upwards, each value little-endian,
// with no gap between PDOs; the SM length is the total rounded up to whole bytes. (A master
// computes the SM length the same way from the PDO descriptions; the reference drive's
// mappings are byte-aligned.) Dummy entries (0002h..0007h) take their bits and carry nothing.
//
// Outputs (SM2 → dictionary): each mapped object is written through ObjectDictionary::write,
// as a CAN RPDO is (access, limits, validators and write observers apply; an entry refused
// there is skipped and counted). Inputs (dictionary → SM3): each mapped object's current
// value, no read hooks (the application keeps mapped objects current each cycle), as a TPDO.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::reference_drive::ethercat {

enum class ProcessDataDirection : std::uint8_t { outputs, inputs };  // SM2 RxPDO, SM3 TxPDO

struct ProcessDataEntry {
  std::uint16_t index = 0;
  std::uint8_t sub_index = 0;
  std::uint8_t bits = 0;
  unsigned bit_offset = 0;  // in the SM image
  bool dummy = false;
};

struct ProcessDataLayout {
  std::vector<std::uint16_t> pdos;  // the assigned mapping records, in order
  std::vector<ProcessDataEntry> entries;
  unsigned bits = 0;
  std::size_t bytes() const { return (bits + 7u) / 8u; }
};

// The layout the dictionary's assignment (1C12h outputs, 1C13h inputs) gives now. Errors (an
// assignment or mapping that does not read, an entry naming no object): a text saying which.
Expected<ProcessDataLayout, std::string> read_process_data_layout(
    const cia301::ObjectDictionary& od, ProcessDataDirection direction);

// Writes the SM2 image's values to the mapped objects; returns how many writes were refused.
// An image shorter than the layout writes nothing (returns the entry count).
std::size_t apply_outputs(cia301::ObjectDictionary& od, const ProcessDataLayout& layout,
                          std::span<const std::uint8_t> image);

// The SM3 image: the mapped objects' current values (layout.bytes() octets).
std::vector<std::uint8_t> collect_inputs(const cia301::ObjectDictionary& od,
                                         const ProcessDataLayout& layout);

}  // namespace drivecheck::reference_drive::ethercat
