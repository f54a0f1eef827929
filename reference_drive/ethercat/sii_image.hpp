// The SII EEPROM image of the reference drive as an EtherCAT slave, generated from its object
// dictionary as generate_eds.cpp generates the EDS for CAN: one source (the dictionary), never
// written by hand. Layouts: protocol/ethercat/sii.hpp.
//
//   header    vendor ID, product code, revision, serial number: 1018h:01..04 (CiA 301
//             §7.5.2.21 identity = the ESC's identity words 08h..0Fh, ETG.1000.6); 0 for
//             the optional subs 2-4 a drive lacks
//             standard mailboxes: receive (SM0) 1000h, send (SM1) 1080h, 128 octets each;
//             no bootstrap mailbox (no BOOT: Festo 000 §4.7 "not implemented"); protocols CoE
//   Strings   1 the device name (1008h, else the identity's), 2 group, 3 order text
//   General   CoE details: SDO, SDO information, PDO assignment, PDO configuration, complete
//             access (as EthercatDriveOptions switch them); one CiA 402 (DS402) channel
//   FMMU      0 outputs, 1 inputs, 2 SyncM status
//   SyncM     SM0 1000h/128 control 26h (mailbox, ECAT writes, PDI interrupt), SM1 1080h/128
//             22h (mailbox, ECAT reads), SM2 1100h outputs control 64h (buffered, ECAT writes,
//             watchdog trigger), SM3 1400h inputs 20h (buffered, ECAT reads); SM2/SM3 lengths
//             the size of the default PDO assignment (process_data.hpp)
//   RxPDO / TxPDO  the PDOs 1C12h/1C13h assign by default, with their entries (index,
//             sub-index, CoE data type, bit length), SM 2 / SM 3
// SM2 and SM3 leave room for three buffers of 256 octets each (a real ESC's 3-buffer mode).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/ethercat/sii.hpp"

namespace drivecheck::reference_drive::ethercat {

// Where the emulated ESC's SyncManagers sit (process RAM from 1000h).
inline constexpr std::uint16_t kMailboxOutStart = 0x1000;  // SM0, master -> slave
inline constexpr std::uint16_t kMailboxInStart = 0x1080;   // SM1, slave -> master
inline constexpr std::uint16_t kMailboxSize = 128;
inline constexpr std::uint16_t kOutputsStart = 0x1100;  // SM2
inline constexpr std::uint16_t kInputsStart = 0x1400;   // SM3
inline constexpr std::uint16_t kProcessDataMax = 256;   // octets per direction
inline constexpr std::uint8_t kSm0Control = 0x26;
inline constexpr std::uint8_t kSm1Control = 0x22;
inline constexpr std::uint8_t kSm2Control = 0x64;
inline constexpr std::uint8_t kSm3Control = 0x20;

struct DriveSiiOptions {
  bool sdo_information = true;
  bool pdo_assignment = true;     // 1C12h/1C13h writable
  bool pdo_configuration = true;  // 1600h+/1A00h+ writable
  bool complete_access = true;
};

// The image (as parsed) and its bytes. Errors: the dictionary lacks 1018h or 1C12h/1C13h, a
// default mapping does not read, the image would be too long.
Expected<drivecheck::ethercat::SiiImage, std::string> drive_sii_image(
    const cia301::ObjectDictionary& od, const DriveSiiOptions& options = {});
Expected<std::vector<std::uint8_t>, std::string> drive_sii_bytes(
    const cia301::ObjectDictionary& od, const DriveSiiOptions& options = {});

}  // namespace drivecheck::reference_drive::ethercat
