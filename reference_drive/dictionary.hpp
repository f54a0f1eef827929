// The reference drive's object dictionary: every CiA 301 object the device supports, defined
// once, here in code. The EDS (reference_drive/reference_drive.eds) is generated from it plus
// the CiA 402 application's objects (servo_drive_eds.hpp: reference_eds of the standard
// ServoDrive's dictionary, and the reference_drive_eds program), never written by hand.
//
// CiA 301 objects (§7.5.2), with where they come from:
//   1000h  device type, UNSIGNED32 ro: 00020192h = CiA 402 (0192h = 402) servo drive
//          (additional information 0002h)                                       here
//   1001h  error register; 1003h pre-defined error field (8 entries)           EMCY producer
//   1005h  COB-ID SYNC; 1006h cycle period; 1007h window; 1019h counter overflow  SYNC
//   1008h  manufacturer device name, VISIBLE_STRING const (long: segmented/block upload)
//   1009h  manufacturer hardware version, 100Ah software version, VISIBLE_STRING const  here
//   100Ch  guard time; 100Dh life time factor                                   guarding slave
//   1010h  store parameters; 1011h restore default parameters                   store_restore
//   1014h  COB-ID EMCY; 1015h inhibit time EMCY                                 EMCY producer
//   1016h  consumer heartbeat time (4 entries); 1017h producer heartbeat time   heartbeat
//   1018h  identity, RECORD ro: 01h vendor-ID, 02h product code, 03h revision, 04h serial
//   1020h  verify configuration, ARRAY of UNSIGNED32 rw (CiA 301 §7.5.2.23): 01h configuration
//          date (days since 1 January 1984), 02h configuration time (ms after midnight), both
//          default 0; a configuration tool writes them before it stores (1010h), so that they
//          come back with the stored configuration after a reset. Communication parameters
//          (store group 1000h-1FFFh). DictionaryOptions::verify_configuration       here
//   1029h  error behaviour                                                      NMT slave
//   1200h  SDO server parameter, RECORD: 01h COB-ID client->server ($NODEID+600h) ro,
//          02h COB-ID server->client ($NODEID+580h) ro                          here
//   1201h.. further SDO server channels (DictionaryOptions::extra_sdo_servers)
//                                                                       sdo_server_parameter
//   1400h-1403h, 1600h-1603h, 1800h-1803h, 1A00h-1A03h  4 RPDOs, 4 TPDOs        PDO service
// The application (the CiA 402 part, next) adds its own objects (6000h-9FFFh, 2000h-5FFFh).
#pragma once

#include <cstdint>
#include <string>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/pdo_service.hpp"
#include "protocol/cia301/sdo_server_parameter.hpp"
#include "protocol/cia306/eds.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::reference_drive {

inline constexpr std::uint16_t kDeviceTypeIndex = 0x1000;
inline constexpr std::uint16_t kDeviceNameIndex = 0x1008;
inline constexpr std::uint16_t kHardwareVersionIndex = 0x1009;
inline constexpr std::uint16_t kSoftwareVersionIndex = 0x100A;
inline constexpr std::uint16_t kIdentityIndex = 0x1018;
inline constexpr std::uint16_t kVerifyConfigurationIndex = 0x1020;
inline constexpr std::uint16_t kSdoServerParameterIndex = 0x1200;

// CiA 402 servo drive: bits 15..0 device profile 402 (0192h), bits 23..16 type 02h (servo).
inline constexpr std::uint32_t kServoDriveDeviceType = 0x00020192;

struct Identity {
  std::uint32_t device_type = kServoDriveDeviceType;
  // drivecheck holds no CiA vendor-ID: 0 ("not assigned") marks the reference drive as such.
  std::uint32_t vendor_id = 0x00000000;
  std::uint32_t product_code = 0x00000402;
  std::uint32_t revision = 0x00010000;  // major.minor in the high/low 16 bits
  std::uint32_t serial = 0x00000001;
  std::string vendor_name = "drivecheck project (no CiA vendor-ID)";
  std::string device_name =
      "drivecheck reference drive: CiA 301 communication, CiA 402 servo drive (simulated)";
  std::string hardware_version = "simulated axis, no hardware (rev A)";
  std::string software_version = "drivecheck reference drive 0.1.0";
};

struct DictionaryOptions {
  std::uint8_t node_id = 1;  // 1..127: $NODEID defaults
  Identity identity;
  std::uint16_t producer_heartbeat_ms = 0;      // 1017h default
  std::uint8_t heartbeat_consumer_entries = 4;  // 1016h
  std::uint8_t error_history_size = 8;          // 1003h
  cia301::PdoObjectOptions pdo;                 // 4 + 4 PDOs, 8 mapping entries each
  // Further SDO server channels: records 1201h.. (sdo_server_parameter.hpp), not valid until
  // written; sub 03h as sdo_node_id_sub says. 0..127; 0: the default channel 1200h only.
  std::uint8_t extra_sdo_servers = 0;
  cia301::SdoNodeIdSub sdo_node_id_sub = cia301::SdoNodeIdSub::client;
  // 1020h verify configuration (optional in CiA 301; the standard drive stores parameters, and
  // a device that does has it for its configuration tool). false: absent.
  bool verify_configuration = true;
};

// The CiA 301 part of the dictionary. Error: a node-ID outside 1..127 (or an inconsistent
// option, e.g. PDO defaults).
Expected<cia301::ObjectDictionary, std::string> build_dictionary(const DictionaryOptions& options);

// The EDS of a dictionary the reference drive runs with (CiA 306): fixed FileInfo (the text is
// reproducible byte for byte), DeviceInfo from the identity, dummy mapping 0002h-0007h enabled.
cia306::Eds reference_eds(const cia301::ObjectDictionary& od, const Identity& identity);

// reference_eds of build_dictionary({}) as CiA 306 text (CRLF): the CiA 301 part only
// (reference_drive.eds is servo_drive_eds_text(), servo_drive_eds.hpp).
Expected<std::string, std::string> reference_eds_text();

}  // namespace drivecheck::reference_drive
