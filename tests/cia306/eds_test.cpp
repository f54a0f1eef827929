#include "protocol/cia306/eds.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "protocol/cia306/eds_lint.hpp"

namespace drivecheck::cia306 {
namespace {

using cia301::Value;
using Bytes = std::vector<std::uint8_t>;

std::string data_path(const std::string& name) {
  return std::string(DRIVECHECK_EDS_TEST_DATA) + "/" + name;
}

std::string load(const std::string& name) {
  std::ifstream in(data_path(name), std::ios::binary);
  EXPECT_TRUE(in) << name;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::vector<std::string> texts(const std::vector<Diagnostic>& diagnostics, Severity severity) {
  std::vector<std::string> out;
  for (const auto& d : diagnostics) {
    if (d.severity == severity) out.push_back(d.to_string());
  }
  return out;
}

// Reads a data file by its bare name (so diagnostics say "name.eds:12: ...").
ReadResult read(const std::string& name) {
  return read_eds(load(name), name);
}

// Reads a file that must have no error-severity diagnostic.
Eds read_clean(const std::string& name) {
  auto result = read(name);
  EXPECT_EQ(texts(result.diagnostics, Severity::error), std::vector<std::string>{}) << name;
  return std::move(result.eds);
}

Eds read_clean_text(const std::string& text) {
  auto result = read_eds(text, "text");
  EXPECT_EQ(texts(result.diagnostics, Severity::error), std::vector<std::string>{});
  return std::move(result.eds);
}

cia301::ObjectDictionary dictionary(const Eds& eds, std::uint8_t node_id) {
  auto od = to_object_dictionary(eds, node_id);
  if (!od) {
    for (const auto& d : od.error())
      ADD_FAILURE() << d.to_string();
    return cia301::ObjectDictionary();
  }
  return std::move(*od);
}

Value value(const cia301::ObjectDictionary& od, std::uint16_t index, std::uint8_t sub) {
  auto v = od.get(index, sub);
  EXPECT_TRUE(v) << std::hex << index << " sub " << int{sub};
  return v ? *v : Value();
}

const std::vector<std::string> kGoodFiles = {
    "minimal.eds",        "crlf_bom.eds",      "lowercase_keys.eds",   "compact_subobj.eds",
    "nodeid_forms.eds",   "octal_and_hex.eds", "missing_optional.eds", "device.dcf",
    "comments_tools.eds", "value_types.eds",   "servo_drive.eds",      "bad_lint.eds"};

TEST(EdsReader, ReadsMinimalFile) {
  // Given the smallest complete EDS
  // When read
  // Then [FileInfo], [DeviceInfo], the lists and every object are in the model
  const Eds eds = read_clean("minimal.eds");
  EXPECT_EQ(eds.file_info.file_name, "minimal.eds");
  EXPECT_EQ(eds.file_info.creation_date, "03-14-2024");
  EXPECT_EQ(eds.device_info.vendor_number, 0x1A2u);
  EXPECT_EQ(eds.device_info.baud_rate_250, true);
  EXPECT_EQ(eds.device_info.baud_rate_800, false);
  EXPECT_EQ(eds.device_info.nr_of_rxpdo, 0u);
  EXPECT_FALSE(eds.is_dcf());
  ASSERT_EQ(eds.objects.size(), 4u);
  const EdsObject* identity = eds.find(0x1018);
  ASSERT_NE(identity, nullptr);
  EXPECT_EQ(identity->list, ObjectList::mandatory);
  EXPECT_EQ(identity->keys.object_type, cia301::ObjectCode::record);
  EXPECT_EQ(identity->sub_number, 5);
  ASSERT_EQ(identity->subs.size(), 5u);
  EXPECT_EQ(identity->subs[1].keys.parameter_name, "Vendor-ID");
  EXPECT_EQ(identity->subs[1].keys.default_value, "0x000001A2");
  EXPECT_EQ(eds.find(0x1017)->list, ObjectList::optional);
  EXPECT_EQ(eds.find(0x1001)->keys.pdo_mapping, true);
}

TEST(EdsReader, AcceptsBomAndCrlf) {
  // Given a file with a UTF-8 BOM, CRLF line ends and lower-case hex section names
  // When read
  // Then nothing of the BOM or CR leaks into names or values
  const Eds eds = read_clean("crlf_bom.eds");
  EXPECT_EQ(eds.file_info.file_name, "crlf_bom.eds");
  EXPECT_EQ(eds.device_info.vendor_number, 0xABCDu);
  ASSERT_NE(eds.find(0x100C), nullptr);
  EXPECT_EQ(eds.find(0x100C)->keys.default_value, "0x0064");
  EXPECT_EQ(eds.find(0x1000)->keys.parameter_name, "Device type");
  const auto od = dictionary(eds, 1);
  EXPECT_EQ(value(od, 0x1000, 0), Value::of_unsigned(0x000F0191));
}

TEST(EdsReader, AcceptsLowerCaseKeysWhitespaceAndComments) {
  // Given a hand-edited file: lower-case sections and keys, tabs, spaces around '=',
  // trailing comments, [1018SUB1]
  // When read
  // Then keys are matched case-insensitively and comments are not part of values
  const Eds eds = read_clean("lowercase_keys.eds");
  EXPECT_EQ(eds.file_info.description, "Hand edited");
  EXPECT_EQ(eds.find(0x1000)->keys.default_value, "0x00020192");
  EXPECT_EQ(eds.find(0x1000)->keys.access_type, cia301::AccessType::ro);
  EXPECT_EQ(eds.find(0x1001)->keys.parameter_name, "Error register");
  EXPECT_FALSE(eds.find(0x1001)->keys.default_value);
  EXPECT_EQ(eds.find(0x1017)->keys.object_type, cia301::ObjectCode::var);
  const EdsObject* identity = eds.find(0x1018);
  ASSERT_EQ(identity->subs.size(), 3u);
  EXPECT_EQ(identity->subs[2].keys.default_value, "0x7");
  const auto od = dictionary(eds, 1);
  EXPECT_EQ(value(od, 0x1017, 0), Value::of_unsigned(1000));
  EXPECT_EQ(value(od, 0x1001, 0), Value::of_unsigned(0));
}

TEST(EdsReader, ExpandsCompactSubObjArrays) {
  // Given CompactSubObj arrays with partial [xxxxName] sections and a [DummyUsage]
  // When the dictionary is built
  // Then sub 0 is the count, named subs take their names, others "<ParameterName><k>"
  const Eds eds = read_clean("compact_subobj.eds");
  EXPECT_EQ(eds.find(0x1003)->compact_sub_obj, 8);
  EXPECT_EQ(eds.dummy_usage[1], false);
  EXPECT_EQ(eds.dummy_usage[5], true);
  const auto od = dictionary(eds, 3);
  const auto* history = od.find(0x1003);
  ASSERT_NE(history, nullptr);
  ASSERT_EQ(history->entries().size(), 9u);
  EXPECT_EQ(value(od, 0x1003, 0), Value::of_unsigned(8));
  EXPECT_EQ(history->find(0)->access(), cia301::AccessType::ro);
  EXPECT_EQ(history->find(1)->name(), "Newest error");
  EXPECT_EQ(history->find(2)->name(), "Pre-defined error field2");
  EXPECT_EQ(history->find(8)->name(), "Oldest error");
  EXPECT_EQ(od.find(0x1016)->entries().size(), 4u);
  EXPECT_EQ(od.find(0x1016, 3)->access(), cia301::AccessType::rw);
  EXPECT_EQ(od.find(0x1018, 4)->name(), "Serial number");
  EXPECT_EQ(value(od, 0x1400, 1), Value::of_unsigned(0x203));
}

TEST(EdsReader, ResolvesEveryNodeIdForm) {
  // Given $NODEID+n, n+$NODEID, $NODEID and lower case with spaces
  // When the dictionary is built for node 5
  // Then every COB-ID is its base plus 5, and the model keeps the text as written
  const Eds eds = read_clean("nodeid_forms.eds");
  EXPECT_EQ(eds.find(0x1200)->subs[2].keys.default_value, "0x580+$NODEID");
  const auto od = dictionary(eds, 5);
  EXPECT_EQ(value(od, 0x1014, 0), Value::of_unsigned(0x85));
  EXPECT_EQ(value(od, 0x1200, 1), Value::of_unsigned(0x605));
  EXPECT_EQ(value(od, 0x1200, 2), Value::of_unsigned(0x585));
  EXPECT_EQ(value(od, 0x1800, 1), Value::of_unsigned(0x40000185));
  EXPECT_EQ(value(od, 0x2000, 0), Value::of_unsigned(5));
  EXPECT_TRUE(od.find(0x1014, 0)->definition().default_adds_node_id);
}

TEST(EdsReader, NodeIdValuesNeedANodeId) {
  // Given an EDS with $NODEID defaults and no DCF NodeID
  // When the dictionary is built without a node-ID
  // Then it fails, naming the line of the first $NODEID value
  const auto od = to_object_dictionary(read_clean("nodeid_forms.eds"), 0, "nodeid_forms.eds");
  ASSERT_FALSE(od);
  EXPECT_EQ(
      od.error().front().to_string(),
      "nodeid_forms.eds:73: error: DefaultValue '$nodeid + 0x80' needs a node-ID (none given, no "
      "DCF NodeID) [dictionary]");
}

TEST(EdsReader, ReadsOctalAndHexSpellings) {
  // Given leading-0 octal, 0x/0X hex in both cases, signed hex bit patterns and hex without 0x
  // When read
  // Then values are those CiA 306 defines, and the hex-without-0x one is a warning
  const auto result = read("octal_and_hex.eds");
  EXPECT_FALSE(result.has_errors());
  EXPECT_EQ(
      texts(result.diagnostics, Severity::warning),
      std::vector<std::string>{
          "octal_and_hex.eds:94: warning: DefaultValue '1A' read as hex [hex-without-prefix]"});
  EXPECT_EQ(result.eds.device_info.product_number, 8u);  // "010" is octal
  EXPECT_EQ(result.eds.device_info.vendor_number, 0xFFEEu);
  const auto od = dictionary(result.eds, 1);
  EXPECT_EQ(value(od, 0x1000, 0), Value::of_unsigned(0xABCD));
  EXPECT_EQ(value(od, 0x1018, 2), Value::of_unsigned(8));
  EXPECT_EQ(value(od, 0x1017, 0), Value::of_unsigned(500));  // 0764 octal
  EXPECT_EQ(value(od, 0x2000, 0), Value::of_signed(-1));     // 0xFFFF as INTEGER16
  EXPECT_EQ(od.find(0x2000, 0)->definition().high_limit, Value::of_signed(1000));
  EXPECT_EQ(value(od, 0x2001, 0), Value::of_unsigned(0x1A));
  EXPECT_EQ(value(od, 0x2002, 0), Value::of_signed(std::numeric_limits<std::int32_t>::min()));
}

TEST(EdsReader, FillsDefaultsForMissingOptionalKeys) {
  // Given objects with only ParameterName, DataType and AccessType
  // When read and turned into a dictionary
  // Then ObjectType is VAR, PDOMapping 0, values zero or empty
  const Eds eds = read_clean("missing_optional.eds");
  const auto& device_type = eds.find(0x1000)->keys;
  EXPECT_EQ(device_type.object_type, cia301::ObjectCode::var);
  EXPECT_FALSE(device_type.pdo_mapping);
  EXPECT_FALSE(device_type.default_value);
  EXPECT_FALSE(eds.file_info.file_version);
  const auto od = dictionary(eds, 1);
  EXPECT_EQ(value(od, 0x1000, 0), Value::of_unsigned(0));
  EXPECT_EQ(value(od, 0x1008, 0), Value::of_string(""));
  EXPECT_EQ(od.find(0x1018, 1)->access(), cia301::AccessType::constant);
}

TEST(DcfReader, ReadsCommissioningAndParameterValues) {
  // Given a DCF for node 5 with ParameterValues, Denotations and a [1016Value] section
  // When read and turned into a dictionary without naming a node-ID
  // Then the DCF's NodeID is used and ParameterValues are the current values
  const Eds eds = read_clean("device.dcf");
  ASSERT_TRUE(eds.is_dcf());
  EXPECT_EQ(eds.commissioning->node_id, 5u);
  EXPECT_EQ(eds.commissioning->baudrate, 500u);
  EXPECT_EQ(eds.commissioning->node_name, "Axis X");
  EXPECT_EQ(eds.commissioning->lss_serial_number, 0x12345678u);
  EXPECT_EQ(eds.file_info.last_eds, "minimal.eds");
  EXPECT_EQ(eds.find(0x1017)->keys.denotation, "Heartbeat for the PLC");
  ASSERT_EQ(eds.find(0x1016)->denotations.size(), 1u);
  const auto od = dictionary(eds, 0);
  EXPECT_EQ(od.node_id(), 5);
  EXPECT_EQ(value(od, 0x1014, 0), Value::of_unsigned(0x85));
  EXPECT_EQ(value(od, 0x1017, 0), Value::of_unsigned(100));
  EXPECT_EQ(od.find(0x1017, 0)->default_bytes(5), (Bytes{0, 0}));
  EXPECT_EQ(value(od, 0x1016, 1), Value::of_unsigned(0x000101F4));
  EXPECT_EQ(value(od, 0x1016, 2), Value::of_unsigned(0x007F03E8));
}

TEST(EdsReader, KeepsCommentsToolSectionsAndObjFlags) {
  // Given [Comments], [Tools]/[Tool1], ObjFlags, DownloadFile and an unknown DeviceInfo key
  // When read
  // Then all of it is in the model, unknown parts verbatim, without warnings
  const auto result = read("comments_tools.eds");
  EXPECT_EQ(result.diagnostics.size(), 0u);
  const Eds& eds = result.eds;
  ASSERT_EQ(eds.comments.size(), 3u);
  EXPECT_EQ(eds.comments[1],
            "ObjFlags=1 on 1F50h: do not write it during a configuration download.");
  EXPECT_EQ(eds.comments[2], "Leading spaces are trimmed.");
  ASSERT_EQ(eds.other_sections.size(), 2u);
  EXPECT_EQ(eds.other_sections[1].name, "Tool1");
  EXPECT_EQ(eds.other_sections[1].keys[1].value, "configurator.exe %f");
  ASSERT_EQ(eds.device_info.extra.size(), 1u);
  EXPECT_EQ(eds.device_info.extra[0].name, "CANopenSafetySupported");
  const SubObject* program = eds.find(0x1F50)->find(1);
  ASSERT_NE(program, nullptr);
  EXPECT_EQ(program->keys.obj_flags, 1u);
  EXPECT_EQ(program->keys.object_type, cia301::ObjectCode::domain);
  ASSERT_EQ(program->keys.extra.size(), 1u);
  EXPECT_EQ(program->keys.extra[0].value, "firmware.bin");
  const auto od = dictionary(eds, 1);
  EXPECT_EQ(od.find(0x1F50, 1)->definition().obj_flags, 1u);
  EXPECT_EQ(od.find(0x1F50, 1)->type(), cia301::DataType::domain);
}

TEST(EdsReader, ReadsEveryValueFamily) {
  // Given defaults of strings, octet and unicode strings, reals, 24/40-bit integers,
  // BOOLEAN and TIME_OF_DAY
  // When the dictionary is built
  // Then each value has its CiA 301 encoding
  const auto od = dictionary(read_clean("value_types.eds"), 1);
  EXPECT_EQ(value(od, 0x1008, 0), Value::of_string("Servo = drive; model 7"));
  EXPECT_EQ(value(od, 0x2000, 0), Value::of_bytes(Bytes{0x01, 0xA2, 0xFF, 0x00}));
  EXPECT_EQ(value(od, 0x2001, 0),
            Value::of_bytes(Bytes{'A', 0, 'c', 0, 'h', 0, 's', 0, 'e', 0, ' ', 0, 0xDC, 0}));
  EXPECT_EQ(value(od, 0x2002, 0), Value::of_real(1.5));
  EXPECT_EQ(od.find(0x2002, 0)->definition().high_limit, Value::of_real(100.0));
  EXPECT_EQ(value(od, 0x2003, 0), Value::of_real(-0.001));
  auto encoder = od.find(0x2004, 0)->bytes();
  EXPECT_EQ(Bytes(encoder.begin(), encoder.end()), (Bytes{0x00, 0x00, 0x80}));
  EXPECT_EQ(value(od, 0x2005, 0), Value::of_unsigned(0xFFFFFFFFFF));
  EXPECT_EQ(value(od, 0x2006, 0), Value::of_unsigned(1));
  auto time = od.find(0x2007, 0)->bytes();
  EXPECT_EQ(Bytes(time.begin(), time.end()), (Bytes{0xC0, 0xA8, 0xD2, 0x04, 0x34, 0x12}));
}

TEST(EdsReader, ReadsLargeServoDriveEds) {
  // Given a realistic CiA 402 servo drive EDS (335 sections)
  // When read, linted and turned into a dictionary for node 12
  // Then there is no error, and PDO, CiA 402 and manufacturer objects are all there
  const Eds eds = read_clean("servo_drive.eds");
  EXPECT_EQ(texts(lint_eds(eds), Severity::error), std::vector<std::string>{});
  EXPECT_EQ(eds.objects.size(), 3u + 16 + 16 + 51 + 40);
  EXPECT_EQ(eds.device_info.nr_of_txpdo, 4u);
  const auto od = dictionary(eds, 12);
  EXPECT_EQ(od.objects().size(), eds.objects.size());
  EXPECT_EQ(value(od, 0x1401, 1), Value::of_unsigned(0x30C));
  EXPECT_EQ(value(od, 0x1803, 1), Value::of_unsigned(0x4000048C));
  EXPECT_EQ(value(od, 0x1600, 1), Value::of_unsigned(0x60400010));
  EXPECT_EQ(value(od, 0x607D, 1), Value::of_signed(std::numeric_limits<std::int32_t>::min()));
  EXPECT_TRUE(od.find(0x6041, 0)->pdo_mappable());
  EXPECT_EQ(od.find(0x6040, 0)->access(), cia301::AccessType::rww);
  EXPECT_EQ(od.find(0x6060, 0)->definition().low_limit, Value::of_signed(-3));
  EXPECT_EQ(od.find(0x1016, 2)->name(), "Consumer heartbeat time (safety)");
}

TEST(EdsRoundTrip, EveryGoodFileRoundTrips) {
  // Given every test file the reader accepts
  // When read, written, and read again (CRLF and LF)
  // Then the models are equal, the diagnostics the same, and writing again gives the same text
  const auto ids = [](const std::vector<Diagnostic>& diagnostics) {
    std::vector<std::string> out;
    for (const auto& d : diagnostics)
      out.push_back(d.id);
    return out;
  };
  for (const auto& name : kGoodFiles) {
    const auto original = read(name);
    const Eds& first = original.eds;
    EXPECT_FALSE(original.has_errors()) << name;
    for (const bool crlf : {true, false}) {
      const std::string text = write_eds(first, {crlf});
      const auto second = read_eds(text, name + " (written)");
      // Value text is kept as written, so a tolerated spelling is warned about again.
      EXPECT_EQ(ids(second.diagnostics), ids(original.diagnostics)) << name;
      EXPECT_TRUE(second.eds == first) << name << ":\n" << text;
      EXPECT_EQ(write_eds(second.eds, {crlf}), text) << name;
    }
  }
}

TEST(EdsRoundTrip, ModelEqualityNoticesChanges) {
  // Given a model and a copy with one changed value, one changed list, one extra comment
  // When compared
  // Then each copy differs from the original (the round trip test can fail)
  const Eds original = read_clean("minimal.eds");
  Eds changed = original;
  changed.find(0x1017)->keys.default_value = "1000";
  EXPECT_FALSE(changed == original);
  changed = original;
  changed.find(0x1017)->list = ObjectList::manufacturer;
  EXPECT_FALSE(changed == original);
  changed = original;
  changed.comments.push_back("x");
  EXPECT_FALSE(changed == original);
  EXPECT_FALSE(read_eds(write_eds(changed)).eds == original);
}

TEST(EdsWriter, WritesCanonicalText) {
  // Given the lower-case hand-edited file
  // When written
  // Then sections and keys have CiA 306 spelling and order, numbers canonical form
  const std::string text = write_eds(read_clean("lowercase_keys.eds"), {false});
  EXPECT_NE(text.find("[FileInfo]\nFileName=lowercase_keys.eds\nFileVersion=3\n"),
            std::string::npos);
  EXPECT_NE(text.find("[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n"),
            std::string::npos);
  EXPECT_NE(text.find("[1000]\nParameterName=Device type\nObjectType=0x7\nDataType=0x0007\n"
                      "AccessType=ro\nDefaultValue=0x00020192\nPDOMapping=0\n"),
            std::string::npos);
  EXPECT_NE(text.find("[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=0x3\n\n"
                      "[1018sub0]\n"),
            std::string::npos);
  EXPECT_NE(text.find("[DeviceInfo]\nVendorName=lowercase vendor\nVendorNumber=0x42\n"),
            std::string::npos);
  EXPECT_EQ(text.find('\r'), std::string::npos);
  EXPECT_NE(write_eds(read_clean("lowercase_keys.eds")).find("[FileInfo]\r\n"), std::string::npos);
}

TEST(EdsDictionary, DictionaryToEdsAndBack) {
  // Given a dictionary built in code with a $NODEID default, limits and a RECORD
  // When turned into an EDS, written, read and turned into a dictionary again
  // Then every object definition is unchanged and the EDS lints without errors
  cia301::ObjectDictionary od(9);
  ASSERT_TRUE(od.add_var(0x1000, "Device type", cia301::DataType::unsigned32,
                         cia301::AccessType::ro, Value::of_unsigned(0x00020192)));
  ASSERT_TRUE(od.add_var(0x1001, "Error register", cia301::DataType::unsigned8,
                         cia301::AccessType::ro, Value::of_unsigned(0), true));
  ASSERT_TRUE(od.add_var(0x1008, "Manufacturer device name", cia301::DataType::visible_string,
                         cia301::AccessType::constant,
                         Value::of_string("drivecheck reference drive")));
  cia301::EntryDefinition emcy;
  emcy.name = "COB-ID EMCY";
  emcy.type = cia301::DataType::unsigned32;
  emcy.default_value = Value::of_unsigned(0x80);
  emcy.default_adds_node_id = true;
  ASSERT_TRUE(od.add_object({0x1014, "COB-ID EMCY", cia301::ObjectCode::var, {emcy}}));
  ASSERT_TRUE(od.add_var(0x1017, "Producer heartbeat time", cia301::DataType::unsigned16,
                         cia301::AccessType::rw));
  cia301::EntryDefinition count;
  count.name = "Highest sub-index supported";
  count.access = cia301::AccessType::ro;
  count.default_value = Value::of_unsigned(1);
  cia301::EntryDefinition vendor;
  vendor.sub_index = 1;
  vendor.name = "Vendor-ID";
  vendor.type = cia301::DataType::unsigned32;
  vendor.access = cia301::AccessType::ro;
  vendor.default_value = Value::of_unsigned(0x1A2);
  ASSERT_TRUE(
      od.add_object({0x1018, "Identity object", cia301::ObjectCode::record, {count, vendor}}));
  cia301::EntryDefinition modes;
  modes.name = "Modes of operation";
  modes.type = cia301::DataType::integer8;
  modes.access = cia301::AccessType::rww;
  modes.pdo_mappable = true;
  modes.low_limit = Value::of_signed(-3);
  modes.high_limit = Value::of_signed(10);
  ASSERT_TRUE(od.add_object({0x6060, "Modes of operation", cia301::ObjectCode::var, {modes}}));
  FileInfo fi;
  fi.file_name = "reference.eds";
  DeviceInfo di;
  di.vendor_name = "drivecheck";
  di.product_name = "reference drive";
  di.baud_rate_500 = true;
  const Eds eds = from_object_dictionary(od, fi, di);
  EXPECT_EQ(eds.find(0x1014)->keys.default_value, "$NODEID+0x80");
  EXPECT_EQ(eds.find(0x1018)->list, ObjectList::mandatory);
  EXPECT_EQ(eds.device_info.nr_of_rxpdo, 0u);
  const auto text = write_eds(eds);
  const auto lint = lint_eds_text(text, "reference.eds");
  EXPECT_EQ(texts(lint, Severity::error), std::vector<std::string>{});
  const auto back = dictionary(read_clean_text(text), 9);
  ASSERT_EQ(back.objects().size(), od.objects().size());
  for (const auto& object : od.objects()) {
    const auto* other = back.find(object.index());
    ASSERT_NE(other, nullptr);
    EXPECT_EQ(other->definition(), object.definition()) << std::hex << object.index();
  }
}

}  // namespace
}  // namespace drivecheck::cia306
