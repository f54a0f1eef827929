// EDS and DCF files (CiA 306 v1.3): the model, the reader, the writer, and the bridge to the
// CiA 301 object dictionary.
//
// An EDS is an INI file. The sections drivecheck interprets:
//
//   [FileInfo]            FileName, FileVersion, FileRevision, EDSVersion, Description,
//                         CreationTime/Date, CreatedBy, ModificationTime/Date, ModifiedBy
//   [DeviceInfo]          VendorName/Number, ProductName/Number, RevisionNumber, OrderCode,
//                         BaudRate_10 ... BaudRate_1000, SimpleBootUpMaster/Slave,
//                         Granularity, DynamicChannelsSupported, GroupMessaging,
//                         NrOfRXPDO, NrOfTXPDO, LSS_Supported, CompactPDO
//   [DummyUsage]          Dummy0001 ... Dummy0007 = 0|1
//   [Comments]            Lines=n, Line1 ... Linen
//   [DeviceComissioning]  (DCF only; CiA 306 spells it with one 'm') NodeID, NodeName,
//                         Baudrate, NetNumber, NetworkName, CANopenManager, LSS_SerialNumber
//   [MandatoryObjects] [OptionalObjects] [ManufacturerObjects]
//                         SupportedObjects=n, then 1=0x1000 ... n=0x....
//   [1018]                one per object: ParameterName, ObjectType, DataType, AccessType,
//                         DefaultValue, LowLimit, HighLimit, PDOMapping, ObjFlags, SubNumber,
//                         CompactSubObj, ParameterValue and Denotation (DCF)
//   [1018sub1]            one per sub-object of an ARRAY/RECORD (sub-index in hex)
//   [1003Name] [1003Value] [1003Denotation]
//                         CompactSubObj arrays: NrOfEntries=k, then <sub-index>=text
//                         (sub-index in decimal); Value/Denotation carry DCF values
// Every other section ([Tools], [SupportedModules], ...) is kept verbatim and written back.
//
// Tolerated, as CiA 306 tools tolerate it (no diagnostic): case of section names and keys,
// whitespace around '=', ';' comment lines and " ;" trailing comments, CRLF/LF/CR line
// ends, a UTF-8 BOM, hex digits in either case, missing optional keys (ObjectType = VAR,
// PDOMapping = 0). Tolerated with a warning: hex without 0x in values ("1A"), TRUE/FALSE,
// [DeviceCommissioning] spelt correctly. Errors (the file is ambiguous or wrong): duplicate
// sections and keys, SubNumber inconsistent with the sub-object sections, unknown DataType,
// a DefaultValue that does not parse for its type, an object listed without a section, a
// section not listed, and the others `eds_test.cpp` shows.
//
// Numbers without 0x where the reading matters: a SupportedObjects entry ("1=1017") is read
// as CiA 306 says (decimal, leading-0 octal) unless only its hex reading names an object
// section (then hex, with a warning); if both readings name sections it is an error. A
// DataType whose CiA 306 and hex readings differ ("0010") is an error.
//
// Diagnostics are `file:line: severity: message [id]`; the id is stable (tests and scripts
// rely on it).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "protocol/cia301/data_type.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia306 {

enum class Severity : std::uint8_t { warning, error };

struct Diagnostic {
  Severity severity = Severity::error;
  std::string id;   // stable, kebab-case: "duplicate-section"
  TextError where;  // file, line, message

  // "file:12: error: message [id]"
  std::string to_string() const;
};

bool has_errors(const std::vector<Diagnostic>& diagnostics);

// Where something came from. Line numbers are provenance, not content: two models compare
// equal whatever lines they were read from (so a read -> write -> read round trip compares
// equal).
struct SourceLines {
  int section = 0;                                // the [section] line
  std::vector<std::pair<std::string, int>> keys;  // lower-case key -> line, in file order
  // The line of a key (lower-case), or the section's line when the key is absent.
  int at(std::string_view key) const;
  bool has(std::string_view key) const;
  void add(std::string lower_key, int line) { keys.emplace_back(std::move(lower_key), line); }
  friend bool operator==(const SourceLines&, const SourceLines&) { return true; }
};

// A key the model has no field for, kept as written.
struct ExtraKey {
  std::string name;
  std::string value;
  friend bool operator==(const ExtraKey&, const ExtraKey&) = default;
};

struct FileInfo {
  std::optional<std::string> file_name, file_version, file_revision, eds_version, description,
      creation_time, creation_date, created_by, modification_time, modification_date, modified_by,
      last_eds;
  std::vector<ExtraKey> extra;
  SourceLines lines;
  friend bool operator==(const FileInfo&, const FileInfo&) = default;
};

struct DeviceInfo {
  std::optional<std::string> vendor_name, product_name, order_code;
  std::optional<std::uint32_t> vendor_number, product_number, revision_number;
  std::optional<bool> baud_rate_10, baud_rate_20, baud_rate_50, baud_rate_125, baud_rate_250,
      baud_rate_500, baud_rate_800, baud_rate_1000;
  std::optional<bool> simple_boot_up_master, simple_boot_up_slave, group_messaging, lss_supported;
  std::optional<std::uint32_t> granularity, dynamic_channels_supported, nr_of_rxpdo, nr_of_txpdo,
      compact_pdo;
  std::vector<ExtraKey> extra;
  SourceLines lines;
  friend bool operator==(const DeviceInfo&, const DeviceInfo&) = default;
};

struct DeviceCommissioning {
  std::optional<std::uint32_t> node_id, baudrate, net_number, lss_serial_number;
  std::optional<std::string> node_name, network_name;
  std::optional<bool> canopen_manager;
  std::vector<ExtraKey> extra;
  SourceLines lines;
  friend bool operator==(const DeviceCommissioning&, const DeviceCommissioning&) = default;
};

// The keys of an object or sub-object section. Values stay text as written (trimmed), so
// "$NODEID+0x180" survives a round trip; cia301::parse_value_text reads them.
struct EntryKeys {
  std::string parameter_name;
  cia301::ObjectCode object_type = cia301::ObjectCode::var;
  std::optional<std::uint16_t> data_type;  // the index of a data type (checked by the reader)
  std::optional<cia301::AccessType> access_type;
  std::optional<std::string> default_value, low_limit, high_limit;
  bool pdo_mapping = false;
  std::optional<std::uint32_t> obj_flags;
  std::optional<std::string> parameter_value, denotation;  // DCF
  std::vector<ExtraKey> extra;
  SourceLines lines;
  friend bool operator==(const EntryKeys&, const EntryKeys&) = default;

  // The basic data type, when data_type names one.
  std::optional<cia301::DataType> basic_type() const;
};

struct SubObject {
  std::uint8_t sub_index = 0;
  EntryKeys keys;
  friend bool operator==(const SubObject&, const SubObject&) = default;
};

// One line of a [xxxxName] / [xxxxValue] / [xxxxDenotation] section.
struct CompactItem {
  std::uint8_t sub_index = 0;
  std::string text;
  int line = 0;
  friend bool operator==(const CompactItem& a, const CompactItem& b) {
    return a.sub_index == b.sub_index && a.text == b.text;
  }
};

enum class ObjectList : std::uint8_t { mandatory, optional, manufacturer };
std::string_view section_name(ObjectList list);  // "MandatoryObjects", ...

struct EdsObject {
  std::uint16_t index = 0;
  ObjectList list = ObjectList::optional;
  int list_line = 0;  // the SupportedObjects entry naming it (provenance)
  EntryKeys keys;     // the [xxxx] section (for VAR/DOMAIN/DEFTYPE: also sub-index 0)
  std::optional<std::uint16_t> sub_number;
  std::optional<std::uint8_t> compact_sub_obj;
  std::vector<SubObject> subs;  // [xxxxsubN] sections, ascending
  std::vector<CompactItem> names, values, denotations;
  int names_line = 0, values_line = 0, denotations_line = 0;

  friend bool operator==(const EdsObject& a, const EdsObject& b) {
    return a.index == b.index && a.list == b.list && a.keys == b.keys &&
           a.sub_number == b.sub_number && a.compact_sub_obj == b.compact_sub_obj &&
           a.subs == b.subs && a.names == b.names && a.values == b.values &&
           a.denotations == b.denotations;
  }
  const SubObject* find(std::uint8_t sub_index) const;
};

struct RawSection {
  std::string name;
  std::vector<ExtraKey> keys;
  int line = 0;
  friend bool operator==(const RawSection& a, const RawSection& b) {
    return a.name == b.name && a.keys == b.keys;
  }
};

struct Eds {
  FileInfo file_info;
  DeviceInfo device_info;
  std::array<std::optional<bool>, 8> dummy_usage{};  // [1..7]: Dummy0001 ... Dummy0007
  SourceLines dummy_usage_lines;  // [DummyUsage]: its line, "dummy0005" -> the key's line
  std::vector<std::string> comments;
  std::optional<DeviceCommissioning> commissioning;  // present: the file is a DCF
  std::vector<EdsObject> objects;                    // ascending index
  std::vector<RawSection> other_sections;            // in file order

  bool is_dcf() const { return commissioning.has_value(); }
  const EdsObject* find(std::uint16_t index) const;
  EdsObject* find(std::uint16_t index);
  friend bool operator==(const Eds&, const Eds&) = default;
};

struct ReadResult {
  Eds eds;
  std::vector<Diagnostic> diagnostics;
  bool has_errors() const { return cia306::has_errors(diagnostics); }
};

// Reads EDS/DCF text. Never fails as a whole: what cannot be understood is a diagnostic and
// is left out of the model. `file` only names the input in diagnostics.
ReadResult read_eds(std::string_view text, const std::string& file = "");
// Reads a file; the error is for a file that cannot be read at all (missing, a directory,
// unreadable, larger than 64 MiB, binary with NUL bytes).
Expected<ReadResult, TextError> read_eds_file(const std::string& path);

struct WriteOptions {
  bool crlf = true;  // CiA 306 files are DOS text; false writes LF line ends
};
// The canonical text of a model: fixed section and key order, canonical spelling of keys and
// numbers, value text as in the model. read_eds(write_eds(m)).eds == m for any m read
// without errors.
std::string write_eds(const Eds& eds, const WriteOptions& options = {});

// The object dictionary an EDS/DCF describes, for a node-ID ($NODEID values resolved). DCF
// ParameterValues become current values. Node-ID 0: the DCF's NodeID (error when absent).
// CompactSubObj arrays are expanded: sub 0 "NrOfObjects" UNSIGNED8 ro = n, sub k named by
// [xxxxName] or "<ParameterName><k>".
Expected<cia301::ObjectDictionary, std::vector<Diagnostic>> to_object_dictionary(
    const Eds& eds, std::uint8_t node_id = 0, const std::string& file = "");

// The EDS of an object dictionary (the reference drive's EDS): objects listed by CiA 306
// rules (1000h/1001h/1018h mandatory, 2000h-5FFFh manufacturer, the rest optional),
// NrOfRXPDO/NrOfTXPDO counted from 1400h-15FFh / 1800h-19FFh, defaults in canonical text
// ($NODEID+x where the definition says so).
Eds from_object_dictionary(const cia301::ObjectDictionary& od, FileInfo file_info,
                           DeviceInfo device_info);

// The default list of an index under CiA 306 rules.
ObjectList default_list(std::uint16_t index);

}  // namespace drivecheck::cia306
