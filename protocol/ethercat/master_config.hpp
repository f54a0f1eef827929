// SyncManager and FMMU setup from the SII (sii.hpp), and the logical addresses of the process
// image. Sources: ESC datasheet Section I §6 (FMMU), §8 (SyncManager), Section II 0600h+
// (FMMU: logical start u32, length u16, logical start bit, logical stop bit, physical start
// u16, physical start bit, type (bit 0 read, bit 1 write), activate) and 0800h+ (SyncManager:
// start u16, length u16, control, status, activate, PDI control); ETG.2010 / the SII layout of
// sii.hpp for the mailbox words and the SyncM, FMMU, RxPDO and TxPDO categories.
//
// The plan of one slave:
//  - mailbox: SM0 (master writes) at the SII's standard receive mailbox offset and size, SM1
//    (master reads) at the standard send mailbox; control bytes from the SII's SyncM entries of
//    type mailbox out / mailbox in when it has them, else 26h (mailbox, ECAT writes, PDI
//    interrupt) and 22h (mailbox, ECAT reads, PDI interrupt). A size of 0: no mailbox.
//  - process data: every SyncM entry of type outputs (3) or inputs (4), in SM order. Its length
//    is the sum of the bit lengths of the SII's RxPDOs (outputs) or TxPDOs (inputs) assigned to
//    that SM, in whole bytes, when the SII lists any for it; else the SyncM entry's length.
//    Length 0: the SM stays disabled. Control from the SyncM entry (64h: buffered, ECAT
//    writes, watchdog trigger for outputs; 20h: buffered, ECAT reads for inputs when it is 0).
//  - FMMUs: one per process data SM, numbered 0, 1, ...: a write FMMU (type 2) for outputs, a
//    read FMMU (type 1) for inputs, byte-aligned, mapping the SM's buffer to its logical range.
// The process image (assign_logical_addresses): per slave in position order its outputs, then
// its inputs, from the logical base on; the LRW over the image expects per slave +2 for any
// output FMMU written and +1 for any input FMMU read (ESC Section I Table 5: LRW counts +1
// read, +2 write, +3 both, per slave).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "protocol/ethercat/master_link.hpp"
#include "protocol/ethercat/sii.hpp"

namespace drivecheck::ethercat {

struct SyncManagerSetup {
  unsigned index = 0;
  std::uint16_t start = 0;
  std::uint16_t length = 0;
  std::uint8_t control = 0;
  bool outputs = false;  // process data: master -> slave
};

struct FmmuSetup {
  unsigned index = 0;
  std::uint32_t logical = 0;
  std::uint16_t length = 0;
  std::uint16_t physical = 0;
  std::uint8_t type = 0;  // 1 read (inputs), 2 write (outputs)
};

struct SlaveLayout {
  std::uint16_t station = 0;
  std::optional<SyncManagerSetup> mailbox_out;  // SM0
  std::optional<SyncManagerSetup> mailbox_in;   // SM1
  std::vector<SyncManagerSetup> process_data;   // enabled process data SMs
  std::vector<FmmuSetup> fmmus;                 // after assign_logical_addresses
  std::size_t output_bytes = 0;
  std::size_t input_bytes = 0;
  std::size_t output_offset = 0;  // in the process image (bytes from the logical base)
  std::size_t input_offset = 0;
  std::uint16_t expected_wkc() const {
    return static_cast<std::uint16_t>((output_bytes > 0 ? 2 : 0) + (input_bytes > 0 ? 1 : 0));
  }
};

// The plan of one slave from its SII. Errors: sii_unsupported (a mailbox SM of odd shape, a
// process data SM without room).
Expected<SlaveLayout, MasterError> plan_slave(const SiiImage& sii, std::uint16_t station);

// Logical addresses for every slave's process data (FMMUs filled in); returns the image size.
std::size_t assign_logical_addresses(std::vector<SlaveLayout>& slaves, std::uint32_t base);

// Writes SM0/SM1 (disabled first, then the whole block enabled). Nothing without a mailbox.
Expected<void, MasterError> write_mailbox_setup(MasterPort& port, const SlaveLayout& layout);
// Writes the process data SMs and the FMMUs.
Expected<void, MasterError> write_process_data_setup(MasterPort& port, const SlaveLayout& layout);

// Where a mapped object lies in a slave's process data, by the SII's PDO list: the slave's
// outputs (RxPDOs) or inputs (TxPDOs) are its process data SMs of that direction in SM order,
// each the PDOs the SII assigns to it in SII order, each its entries in order (bit-packed).
// This is the SII's default mapping; a PDO configuration changed by CoE (1C12h/1C13h,
// 1600h+/1A00h+) is not reflected. nullopt: no PDO entry maps the object, or the SM's length
// did not come from PDOs.
struct PdoEntryPlace {
  bool outputs = false;        // in the slave's outputs (RxPDO) or inputs (TxPDO)
  std::size_t bit_offset = 0;  // from the first bit of the slave's outputs / inputs
  std::uint8_t bit_length = 0;
};
std::optional<PdoEntryPlace> locate_pdo_entry(const SiiImage& sii, const SlaveLayout& layout,
                                              std::uint16_t index, std::uint8_t sub_index);
// Reads / writes up to 64 bits little-endian at a bit offset (bits past the span read 0 and are
// not written).
std::uint64_t get_bits(std::span<const std::uint8_t> bytes, std::size_t bit_offset,
                       unsigned bit_length);
void set_bits(std::span<std::uint8_t> bytes, std::size_t bit_offset, unsigned bit_length,
              std::uint64_t value);

// The 8 register bytes of a SyncManager / 16 of an FMMU.
std::vector<std::uint8_t> sync_manager_bytes(const SyncManagerSetup& sm, bool enable);
std::vector<std::uint8_t> fmmu_bytes(const FmmuSetup& fmmu);

}  // namespace drivecheck::ethercat
