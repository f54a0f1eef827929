// The SDO information service (CoE service 8, ETG.1000.6): the slave describes its object
// dictionary. The server answers a request with one or more fragments, each fitting the read
// mailbox; the master reassembles them. Pure functions and a small reassembler.
//
// After the CoE header, every message carries the SDO information header (public layout:
// Wireshark packet-ecatmb.h TETHERCAT_SDO_INFO_HEADER):
//   byte 0    bits 0..6 opcode (coe_sdo_info_codes.inc), bit 7 incomplete (more fragments)
//   byte 1    reserved (0)
//   byte 2-3  fragments left (UNSIGNED16): the fragments still to come after this one
// then the service data (fragmented as one octet stream):
//   get OD list request            list type (UNSIGNED16)
//   get OD list response           list type, then the indices (UNSIGNED16 each); list type 0
//                                  gives the five list lengths instead
//   get object description request  index
//   get object description response index, data type (UNSIGNED16), max sub-index (UNSIGNED8),
//                                  object code (UNSIGNED8), name (the rest, no terminator)
//   get entry description request  index, sub-index, value info (UNSIGNED8: bit 3 unit type,
//                                  bit 4 default value, bit 5 minimum, bit 6 maximum wanted)
//   get entry description response index, sub-index, value info (what follows), data type
//                                  (UNSIGNED16), bit length (UNSIGNED16), object access
//                                  (UNSIGNED16), [default][minimum][maximum] in the entry's
//                                  type, name (the rest)
//   SDO information error          abort code (UNSIGNED32)
// Object access bits (ETG.1000.6; Wireshark's ECAT_COE_INFO_OBJACCESS_RO 07h / _RW 3Fh agree):
//   0..2 read in PREOP/SAFEOP/OP, 3..5 write in PREOP/SAFEOP/OP, 6 RxPDO mappable, 7 TxPDO
//   mappable, 8 backup, 9 setting.
// Our dictionary knows no access per state: readable → 07h, writable → 38h; a mappable entry
// is RxPDO-mappable when writable (rww, rw), TxPDO-mappable when readable (rwr, ro, rw).
// Object data type: a VAR's entry type, an ARRAY's element type (sub-index 1), 0 for a RECORD
// (we hold no DEFSTRUCT). Unit type is never given (value info bit 3 answered as absent).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/ethercat/coe.hpp"

namespace drivecheck::ethercat {

inline constexpr std::size_t kSdoInfoHeaderSize = 4;

enum class SdoInfoOpcode : std::uint8_t {
#define DRIVECHECK_SDO_INFO_OPCODE(name, value, text) name = value,
#include "protocol/ethercat/coe_sdo_info_codes.inc"
#undef DRIVECHECK_SDO_INFO_OPCODE
};
enum class OdListType : std::uint16_t {
#define DRIVECHECK_SDO_INFO_LIST(name, value, text) name = value,
#include "protocol/ethercat/coe_sdo_info_codes.inc"
#undef DRIVECHECK_SDO_INFO_LIST
};

struct SdoInfoHeader {
  std::uint8_t opcode = 0;
  bool incomplete = false;
  std::uint16_t fragments_left = 0;
};

// The mailbox data (CoE header, information header, service data) of each fragment of the
// answer to one request, in order; each fits a read mailbox of `read_size` octets (at least
// 16). Errors are SDO information error messages: a request too short or of an unknown opcode
// 05040001h, a list type other than 0..5 06010000h, a missing object 06020000h, a missing
// sub-index 06090011h. Lists 4 and 5 (device replacement, startup parameters) both name the
// objects with an entry in a store group (1010h/1011h, object_dictionary.hpp): our choice.
// `hidden` (may be empty): objects the device does not have over CoE although the dictionary
// holds them (a drive's CoE rules, e.g. Festo's 1008h-100Ah, 000 §4.6.2 L1826): no list names
// them and their descriptions are answered 06020000h, as the SDO server aborts them.
using SdoInfoHidden = std::function<bool(std::uint16_t index)>;
std::vector<std::vector<std::uint8_t>> answer_sdo_information(cia301::ObjectDictionary& od,
                                                              std::span<const std::uint8_t> data,
                                                              std::size_t read_size,
                                                              const SdoInfoHidden& hidden = {});

// Requests (mailbox data).
std::vector<std::uint8_t> sdo_info_od_list_request(OdListType list);
std::vector<std::uint8_t> sdo_info_object_request(std::uint16_t index);
std::vector<std::uint8_t> sdo_info_entry_request(std::uint16_t index, std::uint8_t sub_index,
                                                 std::uint8_t value_info = 0);

// Master side: collects fragments until the last one.
struct SdoInfoMessage {
  std::uint8_t opcode = 0;
  std::vector<std::uint8_t> data;  // the service data of all fragments, in order
};
class SdoInfoAssembler {
 public:
  // One received message (mailbox data). Returns the whole message after its last fragment,
  // nullopt while fragments are missing. Errors: not SDO information, shorter than its header,
  // a fragment whose opcode or fragments-left count does not continue the previous one.
  Expected<std::optional<SdoInfoMessage>, std::string> add(std::span<const std::uint8_t> data);
  void reset();

 private:
  std::optional<SdoInfoMessage> partial_;
  std::uint16_t expected_left_ = 0;
};

struct ObjectDescription {
  std::uint16_t index = 0;
  std::uint16_t data_type = 0;
  std::uint8_t max_sub_index = 0;
  std::uint8_t object_code = 0;
  std::string name;
};
struct EntryDescription {
  std::uint16_t index = 0;
  std::uint8_t sub_index = 0;
  std::uint8_t value_info = 0;
  std::uint16_t data_type = 0;
  std::uint16_t bit_length = 0;
  std::uint16_t object_access = 0;
  std::vector<std::uint8_t> values_and_name;  // [default][min][max] then the name
};
// Decoders of reassembled messages. Errors: the wrong opcode, too short.
Expected<std::vector<std::uint16_t>, std::string> parse_od_list(const SdoInfoMessage& message);
Expected<ObjectDescription, std::string> parse_object_description(const SdoInfoMessage& message);
Expected<EntryDescription, std::string> parse_entry_description(const SdoInfoMessage& message);
// An SDO information error's abort code.
Expected<std::uint32_t, std::string> parse_sdo_info_error(const SdoInfoMessage& message);

// The object access word of an entry (see the file comment).
std::uint16_t object_access_bits(const cia301::Entry& entry);

}  // namespace drivecheck::ethercat
