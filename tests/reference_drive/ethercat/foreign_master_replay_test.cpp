// The emulated drive under a foreign master's bring-up: a table of datagrams in the order and
// shape independent open-source masters send them (ethercrab's reset_subdevices and EEPROM
// reads; SOEM's ecx_detect_slaves, ecx_set_slaves_to_default, ecx_config_init,
// ecx_config_map_group, ecx_mbxreceive's repeat request, ecx_configdc and its cyclic FRMW; IgH's
// 12-octet base read and SII check/fetch; as read in their public source, nothing of their
// code), each with the answer a real ESC gives by the Beckhoff ESC datasheet (Section I
// "Technology", Section II "Register Description", public) and the working counter. The table
// is replayed against the reference drive's EthercatDrive on the simulated segment: every
// answer and every working counter must match, the drive reaches OP and the CiA 402 state
// machine follows the controlword through the process data.
//
// Expected data: `expect` compared under `mask` (empty mask: every octet of `expect`); rows with
// `sii_word` expect the drive's own SII octets from that word on (the SII the drive carries;
// the master cannot know them beforehand). `poll`: the row is repeated (10 µs of simulated time
// apart) until it matches, at most that many times, as a master polls busy bits and states.
#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "protocol/ethercat/datagram.hpp"
#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "reference_drive/ethercat/ethercat_drive.hpp"
#include "reference_drive/ethercat/sii_image.hpp"

namespace drivecheck::reference_drive::ethercat {
namespace {

namespace ecat = drivecheck::ethercat;
using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;
using ecat::Command;

constexpr std::uint16_t kStation = 0x1001;  // SOEM: slave 1 + its node offset 1000h

struct Row {
  const char* what;
  Command command;
  std::uint16_t adp;  // position (0 = first), station, or 0 for broadcasts
  std::uint32_t ado;  // register address, or the logical address for Lxx
  Bytes data;         // sent; for reads its length is the length read
  Bytes expect;       // answer (compared under mask); empty: data not checked
  Bytes mask;         // empty: every octet of expect
  std::uint16_t wkc;
  int poll = 0;                        // repeat until it matches, at most this often
  std::optional<unsigned> sii_word{};  // expect = the drive's SII from this word on
  const char* source = "";
};

Bytes zeros(std::size_t n) {
  return Bytes(n, 0);
}

// A mailbox request: 6-octet header (length, address 0, channel/priority 0, type CoE with
// counter `cnt`), CoE header (SDO request, service 2), SDO initiate upload (command 40h; 50h
// with complete access) of index:sub, padded to the SM0 length (ETG.1000.4 mailbox header;
// ETG.1000.6 CoE; CiA 301 SDO).
Bytes sdo_upload_request(std::uint16_t index, std::uint8_t sub, std::uint8_t cnt,
                         std::uint8_t command = 0x40) {
  Bytes b = {0x0A,
             0x00,
             0x00,
             0x00,
             0x00,
             static_cast<std::uint8_t>(0x03 | (cnt << 4)),
             0x00,
             0x20,
             command,
             static_cast<std::uint8_t>(index),
             static_cast<std::uint8_t>(index >> 8),
             sub,
             0,
             0,
             0,
             0};
  b.resize(kMailboxSize, 0);
  return b;
}
// The expected expedited upload response: header (length 10, type CoE, counter any), CoE SDO
// response (service 3), command `cs` (4Fh: 1 octet, 4Bh: 2, 43h: 4), index:sub, value.
Bytes sdo_upload_response(std::uint16_t index, std::uint8_t sub, std::uint8_t cs, Bytes value) {
  Bytes b = {0x0A,
             0x00,
             0x00,
             0x00,
             0x00,
             0x03,
             0x00,
             0x30,
             cs,
             static_cast<std::uint8_t>(index),
             static_cast<std::uint8_t>(index >> 8),
             sub};
  value.resize(4, 0);
  b.insert(b.end(), value.begin(), value.end());
  return b;
}
const Bytes kSdoResponseMask = {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x0F, 0xFF, 0xF0,
                                0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF};

Bytes sm_block(std::uint16_t start, std::uint16_t length, std::uint8_t control) {
  return ecat::sync_manager_block(start, length, control, true);
}
Bytes two_sms() {
  Bytes b = sm_block(kMailboxOutStart, kMailboxSize, kSm0Control);
  const Bytes sm1 = sm_block(kMailboxInStart, kMailboxSize, kSm1Control);
  b.insert(b.end(), sm1.begin(), sm1.end());
  return b;
}
// The LRW of the cycle: 6 octets out (controlword, 607Ah), 6 in (statusword, 6064h).
Bytes lrw(std::uint16_t controlword) {
  Bytes b = zeros(12);
  b[0] = static_cast<std::uint8_t>(controlword);
  b[1] = static_cast<std::uint8_t>(controlword >> 8);
  return b;
}
// Statusword (inputs octets 6..7) under the CiA 402 state mask 006Fh.
Bytes statusword(std::uint8_t state) {
  Bytes b = zeros(8);
  b[6] = state;
  return b;
}
const Bytes kStatuswordMask = {0, 0, 0, 0, 0, 0, 0x6F, 0x00};

// Section II: "ESC Section II" (Register Description); Section I: "Technology".
// ethercrab's reset_subdevices (MainDevice, as published): BWR INIT + acknowledge, then zeros
// to every FMMU (0..15, 16 octets each) and SyncManager (0..15, 8 each) one at a time (registers
// of FMMUs/SMs the ESC does not have are reserved: addressed, +1), the DC registers including
// the read-only 092Ch, and the control loop parameters 0934h = 0C00h, then 0930h = 1000h.
std::vector<Row> ethercrab_reset_rows() {
  std::vector<Row> rows;
  rows.push_back({"ethercrab: INIT + acknowledge",
                  Command::bwr,
                  0,
                  0x0120,
                  {0x11, 0x00},
                  {},
                  {},
                  1,
                  0,
                  {},
                  "II AL Control"});
  for (unsigned n = 0; n < 16; ++n) {
    rows.push_back({"ethercrab: FMMU n blanked",
                    Command::bwr,
                    0,
                    ecat::reg::fmmu(n),
                    zeros(16),
                    {},
                    {},
                    1,
                    0,
                    {},
                    "II FMMU 0600h + 16n (8 exist; 0680h.. reserved)"});
  }
  for (unsigned n = 0; n < 16; ++n) {
    rows.push_back({"ethercrab: SM n blanked",
                    Command::bwr,
                    0,
                    ecat::reg::sync_manager(n),
                    zeros(8),
                    {},
                    {},
                    1,
                    0,
                    {},
                    "II SyncManager 0800h + 8n (8 exist)"});
  }
  const std::pair<std::uint16_t, std::size_t> dc[] = {{0x0980, 1}, {0x0910, 8}, {0x0920, 8},
                                                      {0x0928, 4}, {0x092C, 4}, {0x0981, 1},
                                                      {0x0990, 4}, {0x09A0, 4}, {0x09A4, 4}};
  for (const auto& [address, size] : dc) {
    rows.push_back({"ethercrab: DC register blanked",
                    Command::bwr,
                    0,
                    address,
                    zeros(size),
                    {},
                    {},
                    1,
                    0,
                    {},
                    "II 0900h+ (092Ch read-only: ignored, addressed)"});
  }
  rows.push_back(
      {"ethercrab: control loop parameter 3", Command::bwr, 0, 0x0934, {0x00, 0x0C}, {}, {}, 1});
  rows.push_back(
      {"ethercrab: control loop parameter 1", Command::bwr, 0, 0x0930, {0x00, 0x10}, {}, {}, 1});
  rows.push_back({"ethercrab: count by BRD of 0000h (1 octet)",
                  Command::brd,
                  0,
                  0x0000,
                  zeros(1),
                  {0xD0},
                  {},
                  1,
                  0,
                  {},
                  "II Type 0000h"});
  return rows;
}

std::vector<Row> soem_rows() {
  const Bytes mbx_words = {0x00, 0x10, 0x80, 0x00, 0x80, 0x10, 0x80, 0x00};
  return {
      // ---- ecx_detect_slaves ----
      {"DL control byte 3: alias off",
       Command::bwr,
       0,
       0x0103,
       {0},
       {},
       {},
       1,
       0,
       {},
       "II DL Control 0100h bit 24; I 2.4 Table 5 (write +1)"},
      {"AL control INIT + acknowledge",
       Command::bwr,
       0,
       0x0120,
       {0x11, 0},
       {},
       {},
       1,
       0,
       {},
       "II AL Control 0120h bits 3:0, bit 4"},
      {"AL control INIT + acknowledge again", Command::bwr, 0, 0x0120, {0x11, 0}, {}, {}, 1},
      {"count slaves: type and revision",
       Command::brd,
       0,
       0x0000,
       zeros(2),
       {0xD0, 0x01},
       {},
       1,
       0,
       {},
       "II Type 0000h, Revision 0001h; I 2.5 (BRD ORs the data)"},
      // ---- ecx_set_slaves_to_default ----
      {"DL control byte 1: loop auto",
       Command::bwr,
       0,
       0x0101,
       {0},
       {},
       {},
       1,
       0,
       {},
       "II DL Control bits 15:8"},
      {"ECAT event mask",
       Command::bwr,
       0,
       0x0200,
       {0x04, 0},
       {},
       {},
       1,
       0,
       {},
       "II ECAT Event Mask 0200h"},
      {"RX error counters cleared",
       Command::bwr,
       0,
       0x0300,
       zeros(8),
       {},
       {},
       1,
       0,
       {},
       "II RX Error Counter 0300h (write clears)"},
      {"FMMU 0..2 cleared", Command::bwr, 0, 0x0600, zeros(48), {}, {}, 1, 0, {}, "II FMMU 0600h+"},
      {"SM 0..3 cleared",
       Command::bwr,
       0,
       0x0800,
       zeros(32),
       {},
       {},
       1,
       0,
       {},
       "II SyncManager 0800h+"},
      {"DC sync activation off",
       Command::bwr,
       0,
       0x0981,
       {0},
       {},
       {},
       1,
       0,
       {},
       "II DC Activation 0981h"},
      {"DC system time (low 32 bits)",
       Command::bwr,
       0,
       0x0910,
       zeros(4),
       {},
       {},
       1,
       0,
       {},
       "II DC System Time 0910h (write: compared with the local copy)"},
      {"DC speed counter start",
       Command::bwr,
       0,
       0x0930,
       {0x00, 0x10},
       {},
       {},
       1,
       0,
       {},
       "II Speed Counter Start 0930h"},
      {"DC filter depths",
       Command::bwr,
       0,
       0x0934,
       {0x00, 0x0C},
       {},
       {},
       1,
       0,
       {},
       "II System Time Difference Filter Depth 0934h, Speed Counter Filter Depth 0935h"},
      {"alias off again", Command::bwr, 0, 0x0103, {0}, {}, {}, 1},
      {"INIT + acknowledge", Command::bwr, 0, 0x0120, {0x11, 0}, {}, {}, 1},
      {"EEPROM: force ECAT access",
       Command::bwr,
       0,
       0x0500,
       {0x02},
       {},
       {},
       1,
       0,
       {},
       "II EEPROM Configuration 0500h bit 1 (resets 0501h bit 0)"},
      {"EEPROM: assigned to ECAT",
       Command::bwr,
       0,
       0x0500,
       {0x00},
       {},
       {},
       1,
       0,
       {},
       "II EEPROM Configuration 0500h bit 0"},
      // ---- ecx_config_init, per slave ----
      {"PDI control and ESC configuration (SII word 0)",
       Command::aprd,
       0,
       0x0140,
       zeros(2),
       {},
       {},
       1,
       0,
       0u,
       "I 11.1 Table 37 (word 0 -> 0140h:0141h)"},
      {"station address",
       Command::apwr,
       0,
       0x0010,
       {0x01, 0x10},
       {},
       {},
       1,
       0,
       {},
       "II Configured Station Address 0010h"},
      {"DL control: forwarding rule",
       Command::apwr,
       0,
       0x0100,
       {0x01, 0x00},
       {},
       {},
       1,
       0,
       {},
       "II DL Control bit 0"},
      {"station address read back", Command::aprd, 0, 0x0010, zeros(2), {0x01, 0x10}, {}, 1},
      {"station alias (SII word 4)",
       Command::fprd,
       kStation,
       0x0012,
       zeros(2),
       {},
       {},
       1,
       0,
       4u,
       "I 11.1 Table 37 (word 4 -> 0012h)"},
      {"EEPROM status: 8-octet reads, idle, no error",
       Command::fprd,
       kStation,
       0x0502,
       zeros(2),
       {0x40, 0x00},
       {0x7F, 0xFF},
       1,
       0,
       {},
       "II EEPROM Control/Status 0502h bits 6, 15, 14..11"},
      {"EEPROM read word 8 (vendor)",
       Command::fpwr,
       kStation,
       0x0502,
       {0x00, 0x01, 0x08, 0x00, 0x00, 0x00},
       {},
       {},
       1,
       0,
       {},
       "II 0502h bits 10:8 = 001 read; 0504h address"},
      {"EEPROM idle again",
       Command::fprd,
       kStation,
       0x0502,
       zeros(2),
       {0x40, 0x00},
       {0xFF, 0xFF},
       1,
       20,
       {},
       "II 0502h bit 15 busy, bits 10:8 the running command"},
      {"EEPROM data: words 8..11",
       Command::fprd,
       kStation,
       0x0508,
       zeros(8),
       {},
       {},
       1,
       0,
       8u,
       "II EEPROM Data 0508h (8 octets when 0502h bit 6)"},
      {"EEPROM read word 18h (standard mailboxes)",
       Command::fpwr,
       kStation,
       0x0502,
       {0x00, 0x01, 0x18, 0x00, 0x00, 0x00},
       {},
       {},
       1},
      {"EEPROM idle", Command::fprd, kStation, 0x0502, zeros(2), {0x40, 0x00}, {0xFF, 0xFF}, 1, 20},
      {"EEPROM data: mailbox offsets and sizes",
       Command::fprd,
       kStation,
       0x0508,
       zeros(8),
       mbx_words,
       {},
       1,
       0,
       {},
       "I 11.1 Table 38 words 18h..1Bh"},
      {"EEPROM read word 1Ch (mailbox protocols)",
       Command::fpwr,
       kStation,
       0x0502,
       {0x00, 0x01, 0x1C, 0x00, 0x00, 0x00},
       {},
       {},
       1},
      {"EEPROM idle", Command::fprd, kStation, 0x0502, zeros(2), {0x40, 0x00}, {0xFF, 0xFF}, 1, 20},
      {"EEPROM data: CoE",
       Command::fprd,
       kStation,
       0x0508,
       zeros(2),
       {0x04, 0x00},
       {},
       1,
       0,
       {},
       "I 11.1 Table 38 word 1Ch"},
      // ---- the same read as IgH's SII state machine does it ----
      {"IgH: 0502h = 80h (two address octets), 01h (read), word 8",
       Command::fpwr,
       kStation,
       0x0502,
       {0x80, 0x01, 0x08, 0x00},
       {},
       {},
       1,
       0,
       {},
       "II 0502h (bit 7 read-only from ECAT), 0504h"},
      {"IgH: 10-octet check/fetch until 0502h bits 15 and 8 clear, no error bit 13",
       Command::fprd,
       kStation,
       0x0502,
       zeros(10),
       {0x00, 0x00, 0x08, 0x00, 0x00, 0x00},
       {0x00, 0xA1, 0xFF, 0xFF, 0xFF, 0xFF},
       1,
       20,
       {},
       "II 0502h bits 15, 13, 10:8; 0504h address kept"},
      {"IgH: data of word 8 at 0508h",
       Command::fprd,
       kStation,
       0x0508,
       zeros(4),
       {},
       {},
       1,
       0,
       8u,
       "II 0508h"},
      {"ESC features",
       Command::fprd,
       kStation,
       0x0008,
       zeros(2),
       {0x00, 0x00},
       {},
       1,
       0,
       {},
       "II ESC Features Supported 0008h (no DC advertised)"},
      {"DL status: port 0 open + communication, 1..3 closed",
       Command::fprd,
       kStation,
       0x0110,
       zeros(2),
       {0x13, 0x56},
       {},
       1,
       0,
       {},
       "II DL Status 0110h: bits 0,1,4 and loop/communication bits 15..8"},
      {"port descriptor",
       Command::fprd,
       kStation,
       0x0007,
       zeros(2),
       {0x0F, 0x00},
       {},
       1,
       0,
       {},
       "II Port Descriptor 0007h"},
      {"IgH base information (12 octets, 000Ah..000Bh reserved)",
       Command::fprd,
       kStation,
       0x0000,
       zeros(12),
       {0xD0, 0x01, 0x01, 0x00, 0x08, 0x08, 0x08, 0x0F, 0x00, 0x00, 0x00, 0x00},
       {},
       1,
       0,
       {},
       "II 0000h..0008h; reserved octets read 0"},
      {"AL status INIT",
       Command::fprd,
       kStation,
       0x0130,
       zeros(2),
       {0x01, 0x00},
       {},
       1,
       0,
       {},
       "II AL Status 0130h"},
      {"SM0 + SM1 in one datagram",
       Command::fpwr,
       kStation,
       0x0800,
       two_sms(),
       {},
       {},
       1,
       0,
       {},
       "II SyncManager 0800h/0808h"},
      {"EEPROM to the PDI",
       Command::fpwr,
       kStation,
       0x0500,
       {0x01},
       {},
       {},
       1,
       0,
       {},
       "II 0500h bit 0"},
      {"EEPROM command (word 18h) while the PDI has it",
       Command::fpwr,
       kStation,
       0x0502,
       {0x00, 0x01, 0x18, 0x00, 0x00, 0x00},
       {},
       {},
       1,
       0,
       {},
       "II 0500h: ECAT controls only when 0500h.0 = 0 and 0501h.0 = 0"},
      {"EEPROM not busy, data unchanged (word 8): the command was ignored",
       Command::fprd,
       kStation,
       0x0508,
       zeros(4),
       {},
       {},
       1,
       0,
       8u},
      {"PREOP + acknowledge", Command::fpwr, kStation, 0x0120, {0x12, 0x00}, {}, {}, 1},
      {"AL status PREOP",
       Command::fprd,
       kStation,
       0x0130,
       zeros(2),
       {0x02, 0x00},
       {},
       1,
       50,
       {},
       "II AL Status 0130h"},
      {"AL status code 0",
       Command::fprd,
       kStation,
       0x0134,
       zeros(2),
       {0x00, 0x00},
       {},
       1,
       0,
       {},
       "II AL Status Code 0134h"},
      // ---- CoE: PDO assignment read as ecx_readPDOmap does (SDO upload 1C12h, 1C13h) ----
      {"SM0 status: mailbox empty",
       Command::fprd,
       kStation,
       0x0805,
       zeros(1),
       {0x00},
       {0x08},
       1,
       0,
       {},
       "II SyncManager Status bit 3"},
      {"SDO upload 1C12h:00",
       Command::fpwr,
       kStation,
       kMailboxOutStart,
       sdo_upload_request(0x1C12, 0, 1),
       {},
       {},
       1,
       0,
       {},
       "I 8 mailbox: ECAT writes while empty"},
      {"SM1 status: mailbox full, written",
       Command::fprd,
       kStation,
       0x080D,
       zeros(1),
       {0x09},
       {0x0B},
       1,
       50,
       {},
       "II SyncManager Status bits 0, 1, 3"},
      {"SM1: 1C12h:00 = 1",
       Command::fprd,
       kStation,
       kMailboxInStart,
       zeros(kMailboxSize),
       sdo_upload_response(0x1C12, 0, 0x4F, {0x01}),
       kSdoResponseMask,
       1,
       0,
       {},
       "ETG.1000.6 CoE SDO response; CiA 301 expedited upload"},
      {"SM1 status: empty, read completely",
       Command::fprd,
       kStation,
       0x080D,
       zeros(1),
       {0x02},
       {0x0B},
       1,
       0,
       {},
       "II SyncManager Status bits 0, 1, 3"},
      {"SM1 empty: read refused",
       Command::fprd,
       kStation,
       kMailboxInStart,
       zeros(kMailboxSize),
       {},
       {},
       0,
       0,
       {},
       "I 8 mailbox: ECAT reads only while full (no count)"},
      {"SDO upload 1C12h:01",
       Command::fpwr,
       kStation,
       kMailboxOutStart,
       sdo_upload_request(0x1C12, 1, 2),
       {},
       {},
       1},
      {"SM1 full", Command::fprd, kStation, 0x080D, zeros(1), {0x08}, {0x08}, 1, 50},
      {"SM1: 1C12h:01 = 1600h", Command::fprd, kStation, kMailboxInStart, zeros(kMailboxSize),
       sdo_upload_response(0x1C12, 1, 0x4B, {0x00, 0x16}), kSdoResponseMask, 1},
      {"SDO upload 1C13h:01",
       Command::fpwr,
       kStation,
       kMailboxOutStart,
       sdo_upload_request(0x1C13, 1, 3),
       {},
       {},
       1},
      {"SM1 full", Command::fprd, kStation, 0x080D, zeros(1), {0x08}, {0x08}, 1, 50},
      {"SM1: 1C13h:01 = 1A00h", Command::fprd, kStation, kMailboxInStart, zeros(kMailboxSize),
       sdo_upload_response(0x1C13, 1, 0x4B, {0x00, 0x1A}), kSdoResponseMask, 1},
      // ---- ecx_mbxreceive's recovery of a lost read: the repeat request ----
      {"SM1 status and activate: empty, enabled, no repeat",
       Command::fprd,
       kStation,
       0x080D,
       zeros(2),
       {0x00, 0x01},
       {0x08, 0x03},
       1,
       0,
       {},
       "II SyncManager Status / Activate"},
      {"toggle the repeat request (0806h+8 bit 1), status byte written as read",
       Command::fpwr,
       kStation,
       0x080D,
       {0x02, 0x03},
       {},
       {},
       1,
       0,
       {},
       "II SyncManager Activate bit 1; status read-only from ECAT"},
      {"repeat acknowledge (0807h+8 bit 1) follows",
       Command::fprd,
       kStation,
       0x080F,
       zeros(1),
       {0x02},
       {0x02},
       1,
       50,
       {},
       "II SyncManager PDI Control bit 1 (written by the PDI)"},
      {"SM1 full again", Command::fprd, kStation, 0x080D, zeros(1), {0x08}, {0x08}, 1, 50},
      {"SM1: the last reply again (1C13h:01 = 1A00h)",
       Command::fprd,
       kStation,
       kMailboxInStart,
       zeros(kMailboxSize),
       sdo_upload_response(0x1C13, 1, 0x4B, {0x00, 0x1A}),
       kSdoResponseMask,
       1,
       0,
       {},
       "ETG.1000.4 mailbox repeat"},
      // ---- ecx_readPDOmapCA (the SII's General category says complete access): 1C12h whole ----
      {"SDO upload 1C12h complete access from sub 0 (command 50h)",
       Command::fpwr,
       kStation,
       kMailboxOutStart,
       sdo_upload_request(0x1C12, 0, 4, 0x50),
       {},
       {},
       1,
       0,
       {},
       "ETG.1000.6 CoE SDO, complete access bit 4 of the command"},
      {"SM1 full", Command::fprd, kStation, 0x080D, zeros(1), {0x08}, {0x08}, 1, 50},
      {"SM1: expedited response (43h, CA bit not checked): SI0 = 1 in 16 bit, then 1600h",
       Command::fprd,
       kStation,
       kMailboxInStart,
       zeros(kMailboxSize),
       {0x0A, 0x00, 0x00, 0x00, 0x00, 0x03, 0x00, 0x30, 0x43, 0x12, 0x1C, 0x00, 0x01, 0x00, 0x00,
        0x16},
       {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x0F, 0xFF, 0xF0, 0xEF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF,
        0xFF},
       1,
       0,
       {},
       "ETG.1000.6 complete access: SI0 as 16 bit, then the entries"},
      // ---- IgH writes the watchdog registers (here with their reset values) ----
      {"watchdog divider",
       Command::fpwr,
       kStation,
       0x0400,
       {0xC2, 0x09},
       {},
       {},
       1,
       0,
       {},
       "II Watchdog Divider 0400h"},
      {"process data watchdog 100 ms",
       Command::fpwr,
       kStation,
       0x0420,
       {0xE8, 0x03},
       {},
       {},
       1,
       0,
       {},
       "II Watchdog Time Process Data 0420h"},
      // ---- ecx_map_sm, FMMUs, SAFEOP ----
      {"SM2 outputs 6 octets",
       Command::fpwr,
       kStation,
       0x0810,
       sm_block(kOutputsStart, 6, 0x64),
       {},
       {},
       1,
       0,
       {},
       "II SyncManager 0810h; control 64h"},
      {"SM3 inputs 6 octets",
       Command::fpwr,
       kStation,
       0x0818,
       sm_block(kInputsStart, 6, 0x20),
       {},
       {},
       1,
       0,
       {},
       "II SyncManager 0818h; control 20h"},
      {"SM2 status: buffered, nothing written yet",
       Command::fprd,
       kStation,
       0x0815,
       zeros(1),
       {0x30},
       {0x30},
       1,
       0,
       {},
       "II SyncManager Status bits 5:4 = 11b"},
      {"FMMU 0: logical 0, 6 octets, write",
       Command::fpwr,
       kStation,
       0x0600,
       ecat::fmmu_block(0, 6, kOutputsStart, 2),
       {},
       {},
       1,
       0,
       {},
       "II FMMU 0600h"},
      {"FMMU 1: logical 6, 6 octets, read",
       Command::fpwr,
       kStation,
       0x0610,
       ecat::fmmu_block(6, 6, kInputsStart, 1),
       {},
       {},
       1,
       0,
       {},
       "II FMMU 0610h"},
      {"EEPROM to the PDI", Command::fpwr, kStation, 0x0500, {0x01}, {}, {}, 1},
      {"SAFEOP", Command::fpwr, kStation, 0x0120, {0x04, 0x00}, {}, {}, 1},
      {"AL status SAFEOP", Command::fprd, kStation, 0x0130, zeros(2), {0x04, 0x00}, {}, 1, 50},
      {"watchdog divider at reset",
       Command::fprd,
       kStation,
       0x0400,
       zeros(2),
       {0xC2, 0x09},
       {},
       1,
       0,
       {},
       "II Watchdog Divider 0400h reset 09C2h"},
      {"process data watchdog at reset",
       Command::fprd,
       kStation,
       0x0420,
       zeros(2),
       {0xE8, 0x03},
       {},
       1,
       0,
       {},
       "II Watchdog Time Process Data 0420h reset 03E8h"},
      // ---- ecx_configdc (DC as registers) ----
      {"latch receive times",
       Command::bwr,
       0,
       0x0900,
       zeros(4),
       {},
       {},
       1,
       0,
       {},
       "II Receive Time Port 0 0900h (write latches)"},
      {"receive time ECAT processing unit",
       Command::fprd,
       kStation,
       0x0918,
       zeros(8),
       {},
       {},
       1,
       0,
       {},
       "II 0918h"},
      {"system time offset",
       Command::fpwr,
       kStation,
       0x0920,
       zeros(8),
       {},
       {},
       1,
       0,
       {},
       "II System Time Offset 0920h"},
      {"port receive times", Command::fprd, kStation, 0x0900, zeros(16), {}, {}, 1},
      {"system time delay",
       Command::fpwr,
       kStation,
       0x0928,
       zeros(4),
       {},
       {},
       1,
       0,
       {},
       "II System Time Delay 0928h"},
      {"cyclic unit control",
       Command::fpwr,
       kStation,
       0x0980,
       {0x00},
       {},
       {},
       1,
       0,
       {},
       "II Cyclic Unit Control 0980h"},
      {"local system time", Command::fprd, kStation, 0x0910, zeros(8), {}, {}, 1},
      {"SYNC0 start time",
       Command::fpwr,
       kStation,
       0x0990,
       zeros(8),
       {},
       {},
       1,
       0,
       {},
       "II Start Time Cyclic Operation 0990h"},
      {"SYNC0 cycle time 1 ms",
       Command::fpwr,
       kStation,
       0x09A0,
       {0x40, 0x42, 0x0F, 0x00},
       {},
       {},
       1,
       0,
       {},
       "II SYNC0 Cycle Time 09A0h"},
      {"activate SYNC0", Command::fpwr, kStation, 0x0981, {0x03}, {}, {}, 1},
      {"activation reads back", Command::fprd, kStation, 0x0981, zeros(1), {0x03}, {}, 1},
      {"reference clock FRMW: the addressed slave reads",
       Command::frmw,
       kStation,
       0x0910,
       zeros(8),
       {},
       {},
       1,
       0,
       {},
       "I 2.4 (ARMW/FRMW count as a read when addressed)"},
      // ---- cyclic: LRW, then OP ----
      {"LRW: outputs written, inputs read",
       Command::lrw,
       0,
       0,
       lrw(0x0000),
       {},
       {},
       3,
       0,
       {},
       "I 2.4 Table 5 (LRW: +1 read, +2 write)"},
      {"OP for all (ec_writestate)", Command::bwr, 0, 0x0120, {0x08, 0x00}, {}, {}, 1},
      {"AL status OP", Command::brd, 0, 0x0130, zeros(2), {0x08, 0x00}, {}, 1, 50},
      {"shutdown -> ready to switch on",
       Command::lrw,
       0,
       0,
       lrw(0x0006),
       statusword(0x21),
       kStatuswordMask,
       3,
       2000,
       {},
       "CiA 402-2 statusword 0021h"},
      {"switch on -> switched on",
       Command::lrw,
       0,
       0,
       lrw(0x0007),
       statusword(0x23),
       kStatuswordMask,
       3,
       2000,
       {},
       "CiA 402-2 statusword 0023h"},
      {"enable operation -> operation enabled",
       Command::lrw,
       0,
       0,
       lrw(0x000F),
       statusword(0x27),
       kStatuswordMask,
       3,
       2000,
       {},
       "CiA 402-2 statusword 0027h"},
      {"a reserved register is addressed (value unspecified; the model reads 0)",
       Command::fprd,
       kStation,
       0x0A00,
       zeros(4),
       {},
       {},
       1,
       0,
       {},
       "I 2.4 (addressed and accessible: +1); II address space overview"},
      // ---- a refused transition, its code, and the error acknowledge ----
      {"INIT", Command::fpwr, kStation, 0x0120, {0x01, 0x00}, {}, {}, 1},
      {"AL status INIT", Command::fprd, kStation, 0x0130, zeros(2), {0x01, 0x00}, {}, 1, 50},
      {"INIT -> SAFEOP requested", Command::fpwr, kStation, 0x0120, {0x04, 0x00}, {}, {}, 1},
      {"AL status event pending",
       Command::fprd,
       kStation,
       0x0210,
       zeros(2),
       {0x08, 0x00},
       {0x08, 0x00},
       1,
       0,
       {},
       "II ECAT Event Request 0210h bit 3"},
      {"AL status INIT + error",
       Command::fprd,
       kStation,
       0x0130,
       zeros(2),
       {0x11, 0x00},
       {},
       1,
       50,
       {},
       "II AL Status bit 4 (error indication)"},
      {"AL status event cleared by the read",
       Command::fprd,
       kStation,
       0x0210,
       zeros(2),
       {0x00, 0x00},
       {0x08, 0x00},
       1,
       0,
       {},
       "II 0210h bit 3 cleared by reading 0130h"},
      {"AL status code 0011h",
       Command::fprd,
       kStation,
       0x0134,
       zeros(2),
       {0x11, 0x00},
       {},
       1,
       0,
       {},
       "ETG.1000.6 AL status code 0011h invalid requested state change"},
      {"INIT + acknowledge",
       Command::fpwr,
       kStation,
       0x0120,
       {0x11, 0x00},
       {},
       {},
       1,
       0,
       {},
       "II AL Control bit 4"},
      {"AL status INIT, error cleared",
       Command::fprd,
       kStation,
       0x0130,
       zeros(2),
       {0x01, 0x00},
       {},
       1,
       50},
  };
}

// ethercrab's reset first (a master that went before), then SOEM's whole bring-up.
std::vector<Row> bring_up_rows() {
  std::vector<Row> rows = ethercrab_reset_rows();
  const std::vector<Row> soem = soem_rows();
  rows.insert(rows.end(), soem.begin(), soem.end());
  return rows;
}

std::string hex(const Bytes& b) {
  std::string out;
  for (std::uint8_t v : b) {
    static constexpr char kDigits[] = "0123456789ABCDEF";
    out += kDigits[v >> 4];
    out += kDigits[v & 0x0F];
    out += ' ';
  }
  return out;
}

class ForeignMaster {
 public:
  ForeignMaster() {
    auto created = EthercatDrive::create(segment_);
    EXPECT_TRUE(created) << (created ? "" : created.error());
    drive_ = std::move(*created);
    segment_.attach(*drive_);
    drive_->power_on();
  }

  ecat::Datagram exchange(const Row& row) {
    ecat::Datagram d =
        row.command == Command::lrw || row.command == Command::lrd || row.command == Command::lwr
            ? ecat::Datagram::logical(row.command, 0, row.ado, row.data)
            : ecat::Datagram::physical(row.command, 0, row.adp, static_cast<std::uint16_t>(row.ado),
                                       row.data);
    ecat::Frame frame;
    frame.datagrams = {std::move(d)};
    EXPECT_FALSE(segment_.send(*ecat::encode_frame(frame)));
    const auto back = segment_.receive(segment_.now() + 1ms);
    if (!back) return {};
    auto decoded = ecat::decode_frame(back->bytes);
    if (!decoded || decoded->datagrams.empty()) return {};
    return decoded->datagrams.front();
  }

  // Whether the answer matches the row; `why` says how it does not.
  bool matches(const Row& row, const ecat::Datagram& got, std::string& why) const {
    Bytes expect = row.expect;
    if (row.sii_word) {
      const Bytes& sii = drive_->sii();
      const std::size_t at = *row.sii_word * 2;
      expect.assign(sii.begin() + static_cast<std::ptrdiff_t>(at),
                    sii.begin() + static_cast<std::ptrdiff_t>(at + row.data.size()));
    }
    if (got.working_counter != row.wkc) {
      why = "working counter " + std::to_string(got.working_counter) + ", expected " +
            std::to_string(row.wkc);
      return false;
    }
    for (std::size_t i = 0; i < expect.size(); ++i) {
      const std::uint8_t mask = i < row.mask.size() ? row.mask[i] : (row.mask.empty() ? 0xFF : 0);
      if (i >= got.data.size() || ((got.data[i] ^ expect[i]) & mask) != 0) {
        why =
            "data " +
            hex(got.data.size() > 32 ? Bytes(got.data.begin(), got.data.begin() + 32) : got.data) +
            "expected " + hex(expect) + "under mask " + hex(row.mask);
        return false;
      }
    }
    return true;
  }

  ecat::SimSegment segment_;
  std::unique_ptr<EthercatDrive> drive_;
};

TEST(ForeignMasterReplay, BringUpReachesOpWithEveryAnswerAsARealEsc) {
  // Given the reference drive as an emulated slave, alone on the simulated segment
  // When a foreign master's bring-up is replayed datagram by datagram (table above)
  // Then every answer and working counter is a real ESC's, OP is reached, process data flows
  ForeignMaster master;
  for (const Row& row : bring_up_rows()) {
    std::string why;
    bool ok = false;
    for (int attempt = 0; attempt <= row.poll && !ok; ++attempt) {
      if (attempt > 0) master.segment_.run_for(10us);
      ok = master.matches(row, master.exchange(row), why);
    }
    ASSERT_TRUE(ok) << row.what << " [" << row.source << "]: " << why;
  }
}

TEST(ForeignMasterReplay, ReplayFailsOnAWrongWorkingCounter) {
  // Given the same bring-up table with one row expecting a wrong working counter
  // When the row is replayed
  // Then the comparison reports it (the replay can fail)
  ForeignMaster master;
  Row row = soem_rows()[3];  // BRD 0000h: one slave
  row.wkc = 2;
  std::string why;
  EXPECT_FALSE(master.matches(row, master.exchange(row), why));
  EXPECT_NE(why.find("working counter 1, expected 2"), std::string::npos) << why;
}

}  // namespace
}  // namespace drivecheck::reference_drive::ethercat
