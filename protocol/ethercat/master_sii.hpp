// Reading a slave's SII EEPROM through the ESC's EEPROM interface, and parsing it (sii.hpp).
// Sources: ESC datasheet Section I §11 (SII EEPROM, the master's read sequence) and Section II
// 0500h-050Fh:
//   0500h  EEPROM configuration: bit 0 = the EEPROM is offered to the PDI (the master writes 0
//          to own it)
//   0501h  PDI access state: bit 0 = the PDI accesses the EEPROM now (ECAT commands ignored)
//   0502h  control/status: bit 0 write enable, bit 6 read size (1: 8 bytes, 0: 4 bytes),
//          bits 8..10 command (000 none / clear errors, 001 read, 010 write, 100 reload),
//          bit 11 checksum error, bit 12 device information error, bit 13 command error,
//          bit 14 write enable error, bit 15 busy
//   0504h  EEPROM address in words (u32)
//   0508h  data: 4 or 8 bytes read
//
// One read of 4 (or 2) words: wait until not busy (and clear a pending error with command
// 000); write command 001 and the word address in one FPWR of 0502h..0507h; poll 0502h..050Fh
// until busy clears; bit 13/14 set is sii_error naming the word; else the data. Busy for longer
// than SiiReadOptions::timeout is sii_timeout; the PDI holding the EEPROM is sii_error.
//
// The image: the 64 header words, then the category list word by word (type, length in words)
// until the end marker FFFFh. A list without end marker within max_words, or one whose read
// runs past the EEPROM (the ESC refuses the address), is sii_malformed; so is an image
// parse_sii refuses (its SiiParseError in the detail).
#pragma once

#include <cstdint>
#include <vector>

#include "protocol/ethercat/master_link.hpp"
#include "protocol/ethercat/sii.hpp"

namespace drivecheck::ethercat {

struct SiiReadOptions {
  Duration timeout = std::chrono::milliseconds(100);  // busy longer than this: sii_timeout
  Duration poll_interval = std::chrono::microseconds(10);
  std::size_t max_words = 8192;  // 128 Kbit: more without end marker is malformed
  SiiParseOptions parse;
};

// Reads words [word, word + count) of the station's EEPROM.
Expected<std::vector<std::uint8_t>, MasterError> read_sii_words(MasterPort& port,
                                                                std::uint16_t station,
                                                                std::uint32_t word,
                                                                std::size_t count,
                                                                const SiiReadOptions& options = {});

struct SiiRead {
  std::vector<std::uint8_t> bytes;  // header and categories up to and with the end marker
  SiiImage image;
};
Expected<SiiRead, MasterError> read_sii(MasterPort& port, std::uint16_t station,
                                        const SiiReadOptions& options = {});

}  // namespace drivecheck::ethercat
