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
//   1012h  COB-ID TIME, UNSIGNED32 rw (CiA 301 §7.5.2.15), default 80000100h: bit 31 = 1 the
//          device consumes TIME, bit 30 produce (always 0: a consumer only, a write of 1 is
//          refused 06090030h), bit 29 frame (always 0: 11-bit CAN-IDs only, 1 refused
//          06090030h), bits 28..11 0, bits 10..0 the CAN-ID (a restricted one, CiA 301 §7.3.5,
//          refused 06090030h). DictionaryOptions::time_consumer                 time_consumer
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
//   1280h  SDO client parameter, RECORD (CiA 301 §7.5.2.34): 00h = 3 const, 01h COB-ID client->
//          server, 02h COB-ID server->client (UNSIGNED32 rw, default 80000000h: not valid, no
//          client), 03h node-ID of the SDO server (UNSIGNED8 rw, 0 or 1..127, default 0).
//          COB-IDs as 1201h's (bit 31 = 1 not valid, 11-bit only, a valid CAN-ID not changed in
//          one write) and CiA 301 §7.3.5's restricted CAN-IDs refused (06090030h) but for the
//          default SDO channels 601h-67Fh (sub 01h) and 581h-5FFh (sub 02h), which are what a
//          client uses towards another node's default server. DictionaryOptions::sdo_client
//                                                                           sdo_client_channel
//   1400h-1403h, 1600h-1603h, 1800h-1803h, 1A00h-1A03h  4 RPDOs, 4 TPDOs        PDO service
// Manufacturer-specific objects of the reference drive (CiA 301 part):
//   2F00h  SDO client request, RECORD (with 1280h; sdo_client_channel.hpp): what the drive's
//          application asks its SDO client to do, and how it ended:
//          01h multiplexer UNSIGNED32 rw: bits 31..16 index, 15..8 sub-index (7..0 ignored)
//          02h data OCTET_STRING rw (0..64 octets): what a download writes; an upload's result
//          03h command UNSIGNED8 rw: writing 1 reads the remote entry (upload), 2 writes 02h
//              (download; expedited for 1..4 octets, else segmented), 3 writes 02h segmented;
//              0 does nothing; 4..255 refused (06090030h). Reads the last command.
//          04h status UNSIGNED8 ro: 0 idle, 1 running, 2 succeeded, 3 failed (05h says why),
//              4 no client (1280h sub 01h or 02h not valid: no frame is sent)
//          05h abort code UNSIGNED32 ro: the server's abort code, or the one the client sent
//              (05040000h at the timeout), 0 otherwise
//          06h timeout UNSIGNED16 rw, ms, 1..65535, default 1000: how long the client waits
//              for each answer
//          None is stored (kStoreNone); a reset communication ends a running transfer without
//          a frame and sets every entry to its default.
//   2F01h  TIME received, RECORD ro (with 1012h; time_consumer.hpp): 01h ms after midnight
//          UNSIGNED32, 02h days since 1 January 1984 UNSIGNED16, of the last TIME consumed;
//          03h TIME frames consumed UNSIGNED32 (all 0 after power on and reset communication)
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
inline constexpr std::uint16_t kTimeCobIdIndex = 0x1012;
inline constexpr std::uint16_t kSdoClientParameterIndex = 0x1280;
inline constexpr std::uint16_t kSdoClientRequestIndex = 0x2F00;
inline constexpr std::uint16_t kTimeReceivedIndex = 0x2F01;

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
  // SDO client 1280h and its request object 2F00h (personality key sdo_client).
  bool sdo_client = true;
  // TIME consumer 1012h and the received time 2F01h (personality key time_consumer).
  bool time_consumer = true;
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
