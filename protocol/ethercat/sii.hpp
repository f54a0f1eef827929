// The Slave Information Interface (SII) EEPROM image: the ESC configuration area, the identity
// and mailbox words, then categories. Build an image for the emulated slave; parse one read
// from a device, with errors (never a crash) for malformed images.
//
// Sources: ESC datasheet Section I §11 Table 38 ("SII EEPROM content excerpt": the word
// addresses below); ETG.1000.6 §5.4 / ETG.2010 (SII categories; the category layouts as
// publicly documented).
//
// Words (16 bit, little-endian; word address w is byte 2w):
//   00h PDI control           01h PDI configuration     02h SYNC impulse length
//   03h PDI configuration 2   04h configured station alias        05h..06h reserved
//   07h checksum: CRC-8 (x^8+x^2+x+1, initial FFh) over bytes 0..13, in the low byte
//   08h..09h vendor ID        0Ah..0Bh product code     0Ch..0Dh revision number
//   0Eh..0Fh serial number    10h execution delay       11h port 0 delay  12h port 1 delay
//   14h/15h bootstrap receive mailbox offset/size       16h/17h bootstrap send offset/size
//   18h/19h standard receive mailbox offset/size        1Ah/1Bh standard send offset/size
//   1Ch mailbox protocols (bit 0 AoE, 1 EoE, 2 CoE, 3 FoE, 4 SoE, 5 VoE)
//   3Eh size (EEPROM size in kbit - 1)                  3Fh version
//   40h.. categories: word type (bit 15: vendor specific), word length in words, data;
//         the list ends with type FFFFh.
//
// Category data (bytes):
//   Strings (10): count, then per string a length byte and its characters; index 0 means
//                 "no string", so strings are numbered from 1.
//   General (30): 0 group, 1 image, 2 order, 3 name (string indices), 4 reserved, 5 CoE
//                 details, 6 FoE details, 7 EoE details, 8 SoE channels, 9 DS402 channels,
//                 10 SysmanClass, 11 flags, 12..13 current on E-bus (mA, signed), 14 group
//                 (again), 15 reserved, 16..17 physical port, 18..19 physical memory address,
//                 20..31 reserved (32 bytes).
//   FMMU (40):    one byte per FMMU: 0 unused, 1 outputs, 2 inputs, 3 SyncM status.
//   SyncM (41):   8 bytes per SyncManager: start (u16), length (u16), control byte, status
//                 byte, enable byte (bit 0 enable), type (0 unused, 1 mailbox out, 2 mailbox
//                 in, 3 process data outputs, 4 process data inputs).
//   TxPDO (50) / RxPDO (51): PDOs back to back, each 8 bytes: index (u16), entry count,
//                 SyncManager, DC synchronization, name index, flags (u16); then 8 bytes per
//                 entry: index (u16), subindex, name index, data type, bit length, flags (u16).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <system_error>
#include <vector>

#include "protocol/common/expected.hpp"

namespace drivecheck::ethercat {

enum class SiiCategoryType : std::uint16_t {
  nop = 0,
  strings = 10,
  data_types = 20,
  general = 30,
  fmmu = 40,
  sync_manager = 41,
  tx_pdo = 50,
  rx_pdo = 51,
  distributed_clock = 60,
  end = 0xFFFF,
};

inline constexpr std::size_t kSiiFirstCategoryWord = 0x40;
inline constexpr std::uint16_t kSiiMailboxCoe = 0x0004;

struct SiiMailbox {
  std::uint16_t offset = 0;  // ESC address of the SyncManager buffer
  std::uint16_t size = 0;    // bytes
  friend bool operator==(const SiiMailbox&, const SiiMailbox&) = default;
};

struct SiiHeader {
  std::uint16_t pdi_control = 0;
  std::uint16_t pdi_configuration = 0;
  std::uint16_t sync_impulse_length = 0;
  std::uint16_t pdi_configuration2 = 0;
  std::uint16_t station_alias = 0;
  std::uint32_t vendor_id = 0;
  std::uint32_t product_code = 0;
  std::uint32_t revision = 0;
  std::uint32_t serial = 0;
  std::uint16_t execution_delay = 0;
  std::uint16_t port0_delay = 0;
  std::uint16_t port1_delay = 0;
  SiiMailbox bootstrap_receive;
  SiiMailbox bootstrap_send;
  SiiMailbox standard_receive;  // master -> slave (SM0)
  SiiMailbox standard_send;     // slave -> master (SM1)
  std::uint16_t mailbox_protocols = 0;
  std::uint16_t size = 0;
  std::uint16_t version = 1;
  friend bool operator==(const SiiHeader&, const SiiHeader&) = default;
};

struct SiiGeneral {
  std::uint8_t group_index = 0;
  std::uint8_t image_index = 0;
  std::uint8_t order_index = 0;
  std::uint8_t name_index = 0;
  std::uint8_t coe_details = 0;  // bit 0 SDO, 1 SDO info, 2 PDO assign, 3 PDO config,
                                 // 4 upload at startup, 5 SDO complete access
  std::uint8_t foe_details = 0;
  std::uint8_t eoe_details = 0;
  std::uint8_t soe_channels = 0;
  std::uint8_t ds402_channels = 0;
  std::uint8_t sysman_class = 0;
  std::uint8_t flags = 0;
  std::int16_t ebus_current = 0;
  std::uint16_t physical_port = 0;
  std::uint16_t physical_memory_address = 0;
  friend bool operator==(const SiiGeneral&, const SiiGeneral&) = default;
};

enum class SiiSyncManagerType : std::uint8_t {
  unused = 0,
  mailbox_out = 1,
  mailbox_in = 2,
  outputs = 3,
  inputs = 4,
};

struct SiiSyncManager {
  std::uint16_t start = 0;
  std::uint16_t length = 0;
  std::uint8_t control = 0;
  std::uint8_t status = 0;
  std::uint8_t enable = 0;
  SiiSyncManagerType type = SiiSyncManagerType::unused;
  friend bool operator==(const SiiSyncManager&, const SiiSyncManager&) = default;
};

struct SiiPdoEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::uint8_t name_index = 0;
  std::uint8_t data_type = 0;
  std::uint8_t bit_length = 0;
  std::uint16_t flags = 0;
  friend bool operator==(const SiiPdoEntry&, const SiiPdoEntry&) = default;
};

struct SiiPdo {
  std::uint16_t index = 0;
  std::uint8_t sync_manager = 0;
  std::uint8_t synchronization = 0;
  std::uint8_t name_index = 0;
  std::uint16_t flags = 0;
  std::vector<SiiPdoEntry> entries;
  friend bool operator==(const SiiPdo&, const SiiPdo&) = default;
};

// A category the image keeps as raw words (data types, DC, vendor specific, ...).
struct SiiRawCategory {
  std::uint16_t type = 0;
  std::vector<std::uint8_t> data;  // an even number of bytes
  friend bool operator==(const SiiRawCategory&, const SiiRawCategory&) = default;
};

struct SiiImage {
  SiiHeader header;
  std::vector<std::string> strings;  // string index i+1 is strings[i]
  std::optional<SiiGeneral> general;
  std::vector<std::uint8_t> fmmus;  // usage per FMMU (0..3, FFh unused)
  std::vector<SiiSyncManager> sync_managers;
  std::vector<SiiPdo> tx_pdos;
  std::vector<SiiPdo> rx_pdos;
  std::vector<SiiRawCategory> other;
  friend bool operator==(const SiiImage&, const SiiImage&) = default;
};

// The CRC-8 of the configuration area (bytes 0..13).
std::uint8_t sii_checksum(std::span<const std::uint8_t> first_14_bytes);

// Why an image could not be parsed (category "ethercat-sii").
enum class SiiError {
  too_short = 1,           // fewer than 64 words (the fixed header)
  odd_length,              // not a whole number of words
  checksum_mismatch,       // word 07h does not match the CRC of bytes 0..13
  category_past_end,       // a category's length runs past the end of the image
  no_end_marker,           // the category list reaches the end of the image without FFFFh
  malformed_strings,       // a string runs past its category
  malformed_general,       // General shorter than 32 bytes... (see detail)
  malformed_sync_manager,  // SyncM length not a multiple of 8
  malformed_pdo,           // a PDO header or entry runs past its category
  duplicate_category,      // General, Strings, FMMU or SyncM twice
  too_long,                // build: the image would exceed 65535 words or a string 255 bytes
};
const std::error_category& sii_category();
std::error_code make_error_code(SiiError error);

struct SiiParseError {
  std::error_code code;
  std::size_t word = 0;  // word address where the problem is
  std::string detail;
  std::string message() const;
};

// The image's bytes (checksum computed, categories in the order Strings, General, FMMU, SyncM,
// TxPDO, RxPDO, then `other`, then the end marker). Errors: too_long.
Expected<std::vector<std::uint8_t>, std::error_code> build_sii(const SiiImage& image);

struct SiiParseOptions {
  bool check_checksum = true;  // a conformance check wants it; a tolerant reader may not
};
Expected<SiiImage, SiiParseError> parse_sii(std::span<const std::uint8_t> bytes,
                                            SiiParseOptions options = {});

}  // namespace drivecheck::ethercat

template <>
struct std::is_error_code_enum<drivecheck::ethercat::SiiError> : std::true_type {};
