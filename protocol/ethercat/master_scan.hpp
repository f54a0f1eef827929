// Scan: how many slaves the segment holds, configured station addresses for them, and what each
// one is (ESC information, alias). Sources: ESC datasheet Section I §2.5 (broadcast reads count
// every ESC in the working counter; auto-increment addressing: the slave at position k is
// addressed with ADP = -k), Section II 0000h-0008h (ESC information), 0010h (configured station
// address, written by the master), 0012h (configured station alias, loaded from SII word 4).
//
// Steps, each checked:
//  1. BRD 0000h (1 byte): the working counter is the number of slaves; 0 is an error
//     (slave_count), and so is a count other than ScanOptions::expected_slaves (a slave
//     missing, or one too many), naming both numbers;
//  2. per position k: APWR 0010h (station = first_station + k), working counter 1;
//  3. per station: FPRD 0000h..0013h in one datagram: ESC type, revision, build, FMMU/SM
//     counts, RAM size, the station address read back (station_address when it differs) and
//     the alias.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "protocol/ethercat/master_link.hpp"

namespace drivecheck::ethercat {

struct SlaveInfo {
  std::size_t position = 0;   // 0 = the slave next to the master
  std::uint16_t station = 0;  // configured station address (0010h)
  std::uint16_t alias = 0;    // configured station alias (0012h)
  std::uint8_t esc_type = 0;
  std::uint8_t esc_revision = 0;
  std::uint16_t esc_build = 0;
  std::uint8_t fmmus = 0;
  std::uint8_t sync_managers = 0;
  std::uint8_t ram_kbytes = 0;
};

struct ScanOptions {
  std::optional<std::size_t> expected_slaves;  // nullopt: any number (at least one)
  std::uint16_t first_station = 0x1001;
};

Expected<std::vector<SlaveInfo>, MasterError> scan_segment(MasterPort& port,
                                                           const ScanOptions& options = {});

// The number of slaves answering a BRD now (the working counter of BRD 0000h).
Expected<std::size_t, MasterError> count_slaves(MasterPort& port);

}  // namespace drivecheck::ethercat
