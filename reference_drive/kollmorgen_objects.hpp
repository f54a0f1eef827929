// Kollmorgen S300/S700 objects with behaviour of their own (personality key
// `manufacturer_objects: kollmorgen`, reference_drive/personality.hpp). Manual
// 002_953174ea6ca45cdb.txt:
//
// 1002h manufacturer status register (§5.2.1.3 L1282-1344), UNSIGNED32 ro, PDO-mappable.
//   The bits the reference drive can show, refreshed every control cycle (so a TPDO carries
//   the current value) and on each SDO read:
//     bit 10  initialisation finished (the PDS has left NOT READY TO SWITCH ON)
//     bit 14  power stage enabled (SWITCHED ON, OPERATION ENABLED, QUICK STOP ACTIVE: the
//             Kollmorgen power stage is on from SWITCHED ON, §5.4.1.1 L3039-3142)
//     bit 15  error status (FAULT REACTION ACTIVE, FAULT)
//     bit 29  hardware enable input set
//   Every other bit reads 0 (motion tasks, latches, digital inputs 1-4 are not simulated).
//
// 1026h OS prompt (§5.2.1.18 L1807-1846, table §6.1.3 L6037-6040, example §6.3.10 L7719-7754):
//   ARRAY, sub 0 = 2 (UNSIGNED8 ro), none of them mapped.
//   sub 1 StdIn  UNSIGNED8 rw: each write is one ASCII character of a command line; CR (0Dh)
//                or LF (0Ah) ends the line and executes it. A read gives the last character
//                written (0 after a reset). A character that does not fit the line buffer
//                (kLineCapacity) aborts FF030000h "OS command buffer full" (§4.4.5.6 L940).
//   sub 2 StdOut UNSIGNED8 ro: each read takes the next character of the drive's answer,
//                00h when there is none (default 0, L1845).
//   The access follows the table (L6039-6040: StdIn w, StdOut ro) and the example, not the
//   description (L1825-1845: StdIn ro, StdOut w), which has them swapped.
//   Commands (the parameters below, by name, case-insensitive):
//     "<NAME>"          answer: the value in decimal, then CR LF   ("GV\r" -> "6\r\n")
//     "<NAME> <value>"  sets a read-write parameter within its limits; no answer
//   The manual prints the command frames only (each write confirmed with 60h), no answer
//   frame: the answer format is the reference drive's choice. An unknown command, a value for
//   a read-only parameter or one outside the limits changes nothing and gives no answer.
//
// 3500h+ manufacturer object channel (§6.1.1 L5038-5212, command list §6.1.2 L5213-6004,
//   table §6.1.3 L6307-6326): one RECORD per ASCII parameter, at 3500h + its number:
//     sub 0  UNSIGNED8 ro = 8
//     sub 1  INTEGER32 (always transferred as INTEGER32, L5087): the value; ro or rw as the
//            ASCII command is
//     sub 2  INTEGER32 ro lower limit       sub 3  INTEGER32 ro upper limit
//     sub 4  INTEGER32 ro default           sub 5  UNSIGNED32 ro format (L5164-5178)
//     sub 6  UNSIGNED32 ro check data (10000h save + reset, 20000h EEPROM, 200000h read-only;
//            L5195-5199)
//     sub 7, 8  UNSIGNED32 ro reserved (0)
//   None of them can be mapped into a PDO (L5049: abort 06040041h). 3500h itself is MAXCMD:
//   sub 1 = the offset of the last object of the channel (the table: "3500h+MAXCMD: last
//   entry", L6326), read-only. The text calls it "the total number of objects" (L5046-5047;
//   its "(= # 103)" is a lost cross-reference, as at L2687 and L3011). The reference drive's
//   channel is sparse (the objects below only), so it reads the last offset; the real drive's
//   list has gaps too (350Dh, 350Eh are missing, L5237-5238).
//   Parameters (number, ASCII name, §6.1.2 line):
//     3504h ACTIVE   UNSIGNED8 ro  power stage enabled 0/1 (as 1002h bit 14)       L5224
//     3505h ADDR     UNSIGNED8 ro  station address = the node-ID                   L5226
//     3548h GV       INTEGER32 rw  speed controller P gain; stored (1010h saves it) L5312
//     35EFh SERIALNO UNSIGNED32 ro the serial number (1018h sub 4)                 L5580
//   GV's default (1) and limits (0..1000000) are not printed in this manual (the ASCII
//   reference of the setup software has them): chosen, and GV acts on nothing (the simulated
//   axis has no speed controller). The real channel has over a hundred parameters.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"
#include "reference_drive/cia402_application.hpp"

namespace drivecheck::reference_drive {

class KollmorgenObjects {
 public:
  static constexpr std::uint16_t kStatusIndex = 0x1002;
  static constexpr std::uint16_t kOsPromptIndex = 0x1026;
  static constexpr std::uint16_t kChannelBase = 0x3500;
  static constexpr std::size_t kLineCapacity = 64;  // characters of one command line

  // `application` must outlive this object.
  explicit KollmorgenObjects(const Cia402Application& application) : application_(application) {}

  // Adds 1002h, 1026h and the object channel. Errors: an index the dictionary already has.
  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od);
  // Any reset: the command line and the answer are discarded.
  void on_reset();
  // Refreshes 1002h (and the read-only channel values) from the application.
  void refresh(cia301::ObjectDictionary& od) const;

  // 1002h as the bits above give it now.
  std::uint32_t manufacturer_status() const;
  // The answer not read yet from 1026h sub 2.
  std::string_view pending_answer() const { return std::string_view(answer_).substr(read_); }

 private:
  void receive(cia301::ObjectDictionary& od, std::uint8_t character);
  void execute(cia301::ObjectDictionary& od, std::string_view line);
  std::optional<std::int64_t> parameter_value(const cia301::ObjectDictionary& od,
                                              std::size_t row) const;

  const Cia402Application& application_;
  std::string line_;
  std::string answer_;
  std::size_t read_ = 0;  // characters of answer_ already read
};

}  // namespace drivecheck::reference_drive
