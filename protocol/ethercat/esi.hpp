// ESI (EtherCAT Slave Information, ETG.2000): the XML file a slave's vendor ships, the EtherCAT
// counterpart of a CANopen EDS. This reader takes the subset a conformance check needs:
//
//   EtherCATInfo/Vendor/Id                       the vendor ID (1018h:01, SII word 08h)
//   .../Devices/Device                           each device of the file:
//     Type@ProductCode, Type@RevisionNo          1018h:02/03 (SII words 0Ah/0Ch)
//     Name                                       the first one (any LcId)
//     Mailbox/CoE (@SdoInfo @PdoAssign           CoE supported, and its details
//       @PdoConfig @CompleteAccess)
//     Sm (@StartAddress @DefaultSize             the SyncManagers, in order (SM0, SM1, ...)
//       @ControlByte @Enable, text MBoxOut ...)
//     RxPdo / TxPdo (@Sm @Fixed @Mandatory,      the PDOs; @Sm present = assigned to that SM by
//       Index, Name, Entry: Index SubIndex         default (ETG.2000)
//       BitLen DataType)
//     Profile/Dictionary                         the object dictionary:
//       DataTypes/DataType (Name, BitSize,       structured types: SubItem (SubIdx, Name,
//         SubItem, BaseType, ArrayInfo)           Type, BitSize, Flags/Access); a SubItem
//                                                 without SubIdx of an ARRAY type (ArrayInfo
//                                                 LBound, Elements) stands for its elements
//       Objects/Object (Index, Name, Type,       a Type naming a DataType with SubItems gives
//         BitSize, Info/DefaultData,              the object's sub-indices; Info/SubItem (by
//         Info/SubItem, Flags/Access,             Name, else by position) their DefaultData
//         Flags/PdoMapping)
//     Dc/OpMode (Name, Desc, AssignActivate,     the distributed-clock operation modes a
//       CycleTimeSync0/1 @Factor,                 configuration tool offers (shown by
//       ShiftTimeSync0/1 @Factor @Input)          `drivecheck esi show`; no check reads them)
//     Slots (@MaxSlotCount @SlotPdoIncrement     a modular device's slots: which modules
//       @SlotIndexIncrement), Slot (@MinInstances (ModuleIdent, @Default; or ModuleClass)
//       @MaxInstances @SlotGroup, Name)           each slot takes
//   EtherCATInfo/Descriptions/Modules/Module     the modules: Type@ModuleIdent @ModuleClass,
//                                                 Name, RxPdo/TxPdo, DcOpModeName
//
// Numbers are ETG.2000 HexDecValue: "#x1A00" hexadecimal, else decimal (the DC times are
// xs:int: signed decimal, ns). DefaultData is hexBinary, the value's octets in transfer order
// (little endian: "92010200" is 00020192h). Access is ro/rw/wo (Flags/Access; its
// ReadRestrictions/WriteRestrictions are kept as text). PdoMapping is R, T, RT or TR, or the
// same in lower case (the enumeration of the ETG.2000 schema EtherCATBase.xsd, ObjectType and
// SubItemType Flags): R the entry may be mapped into an RxPDO (1600h+, outputs), T into a
// TxPDO (1A00h+, inputs); what distinguishes the lower case is not public to us, so both cases
// are read alike. An entry of a structured object takes its SubItem's PdoMapping, else the
// Object's. Any other value is an error.
// Not read: Profile/DictionaryFile (an external dictionary: a clear error names it), EEPROM,
// InfoReference, Dc/OpMode/Sm, a Module's Profile and Mailbox. Bad input gives a TextError
// naming file:line (the XML parser's offset turned into a line); a well-formed file with a
// missing or malformed field names the line of the element.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/common/expected.hpp"

namespace drivecheck::ethercat {

enum class EsiAccess : std::uint8_t { ro, rw, wo };
std::string_view to_string(EsiAccess access);

// Flags/PdoMapping: the directions the entry may be mapped in.
struct EsiPdoMapping {
  bool rx = false;   // R: into an RxPDO (1600h+, master to slave)
  bool tx = false;   // T: into a TxPDO (1A00h+, slave to master)
  std::string text;  // as written: R, T, RT, TR, r, t, rt, tr
  int line = 0;      // the <PdoMapping> element
};

struct EsiPdoEntry {
  std::uint16_t index = 0;  // 0: a gap (padding) of bit_length bits
  std::uint8_t sub_index = 0;
  std::uint8_t bit_length = 0;
  std::string name;
  std::string data_type;
  int line = 0;
  // The 1600h+/1A00h+ mapping entry value: index << 16 | sub << 8 | bits.
  std::uint32_t mapping_value() const {
    return std::uint32_t{index} << 16 | std::uint32_t{sub_index} << 8 | bit_length;
  }
};

struct EsiPdo {
  std::uint16_t index = 0;
  std::string name;
  std::optional<std::uint8_t> sm;  // assigned to this SyncManager by default
  bool fixed = false;
  bool mandatory = false;
  std::vector<EsiPdoEntry> entries;
  int line = 0;
};

struct EsiSubItem {
  std::uint8_t sub_index = 0;
  std::string name;
  std::string type;  // the ESI type name: USINT, UINT, UDINT, DINT, STRING(8), ...
  std::uint32_t bit_size = 0;
  std::optional<EsiAccess> access;
  std::string read_restrictions;   // Flags/Access@ReadRestrictions, e.g. "PreOp"
  std::string write_restrictions;  // Flags/Access@WriteRestrictions
  // Flags/PdoMapping (the SubItem's, else the Object's); absent: the ESI gives none.
  std::optional<EsiPdoMapping> pdo_mapping;
  std::optional<std::vector<std::uint8_t>> default_data;
  int line = 0;
};

struct EsiObject {
  std::uint16_t index = 0;
  std::string name;
  std::string type;
  std::uint32_t bit_size = 0;
  // A VAR: one entry, sub-index 0, with the object's own access and default. A structured
  // object: its sub-indices from the DataType.
  std::vector<EsiSubItem> entries;
  bool structured = false;
  int line = 0;
};

struct EsiSyncManager {
  std::string type;  // MBoxOut, MBoxIn, Outputs, Inputs (the element's text)
  std::optional<std::uint16_t> start_address;
  std::optional<std::uint16_t> default_size;
  std::optional<std::uint8_t> control_byte;
  bool enable = false;
  int line = 0;
};

// Dc/OpMode: one distributed-clock operation mode. Times in ns as written (xs:int); a Factor
// (when given) is the multiple of the master's cycle a configuration tool adds.
struct EsiDcTime {
  std::int64_t value = 0;
  std::optional<std::int64_t> factor;
  std::optional<bool> input;  // ShiftTimeSync*@Input
};
struct EsiDcOpMode {
  std::string name;
  std::string desc;
  std::uint16_t assign_activate = 0;  // the value for ESC register 0980h (ETG.2000 AssignActivate)
  std::optional<EsiDcTime> cycle_time_sync0;
  std::optional<EsiDcTime> shift_time_sync0;
  std::optional<EsiDcTime> cycle_time_sync1;
  std::optional<EsiDcTime> shift_time_sync1;
  int line = 0;
};

// Slots/Slot: a place for one or more modules of a modular device.
struct EsiSlot {
  std::string name;
  std::uint32_t min_instances = 0;
  std::uint32_t max_instances = 0;
  std::optional<std::uint32_t> slot_group;
  std::vector<std::uint32_t> module_idents;      // ModuleIdent elements, in order
  std::optional<std::uint32_t> default_ident;    // the ModuleIdent with @Default true/1
  std::vector<std::string> module_classes;       // ModuleClass/Class (the other form)
  std::optional<std::uint32_t> pdo_increment;    // @SlotPdoIncrement
  std::optional<std::uint32_t> index_increment;  // @SlotIndexIncrement
  int line = 0;
};
struct EsiSlots {
  std::optional<std::uint32_t> max_slot_count;
  std::optional<std::uint32_t> pdo_increment;    // Slots@SlotPdoIncrement
  std::optional<std::uint32_t> index_increment;  // Slots@SlotIndexIncrement
  std::vector<EsiSlot> slots;
  int line = 0;
};

// Descriptions/Modules/Module.
struct EsiModule {
  std::uint32_t ident = 0;   // Type@ModuleIdent
  std::string module_class;  // Type@ModuleClass
  std::string type;          // Type's text
  std::string name;
  std::vector<EsiPdo> rx_pdos;
  std::vector<EsiPdo> tx_pdos;
  std::string dc_op_mode_name;  // DcOpModeName: the Dc/OpMode the module needs
  int line = 0;
};

struct EsiCoe {
  bool sdo_info = false;
  bool pdo_assign = false;
  bool pdo_config = false;
  bool complete_access = false;
};

struct EsiDevice {
  std::uint32_t product_code = 0;
  std::uint32_t revision_number = 0;
  std::string type;  // Type's text
  std::string name;
  std::optional<EsiCoe> coe;  // Mailbox/CoE present
  std::vector<EsiSyncManager> sync_managers;
  std::vector<EsiPdo> rx_pdos;
  std::vector<EsiPdo> tx_pdos;
  std::vector<EsiObject> objects;        // in file order
  std::vector<EsiDcOpMode> dc_op_modes;  // Dc/OpMode, in order
  std::optional<EsiSlots> slots;         // Slots (a modular device)
  int line = 0;

  const EsiObject* find(std::uint16_t index) const;
  const EsiSubItem* find(std::uint16_t index, std::uint8_t sub) const;
  // The PDOs assigned by default to the outputs (RxPdo with @Sm) or inputs (TxPdo with @Sm).
  std::vector<const EsiPdo*> default_rx_assignment() const;
  std::vector<const EsiPdo*> default_tx_assignment() const;
};

struct EsiFile {
  std::string file;
  std::uint32_t vendor_id = 0;
  std::string vendor_name;
  std::vector<EsiDevice> devices;
  std::vector<EsiModule> modules;  // Descriptions/Modules/Module

  const EsiModule* find_module(std::uint32_t ident) const;
};

// `file` names the input in errors.
Expected<EsiFile, TextError> read_esi(std::string_view text, const std::string& file);
Expected<EsiFile, TextError> read_esi_file(const std::string& path);

// The device of `esi` that a slave with this product code and revision is: the exact one,
// else the one with the product code (ETG.2000: a file may describe several revisions), else
// nullptr. With one device in the file and `product_code` nullopt: that one.
const EsiDevice* find_esi_device(const EsiFile& esi, std::optional<std::uint32_t> product_code,
                                 std::optional<std::uint32_t> revision);

// The octets of a little-endian unsigned value of `bits` (1..64) as ESI DefaultData is written.
std::string esi_hex_binary(std::uint64_t value, unsigned bytes);

}  // namespace drivecheck::ethercat
