// The bad_*.eds files (one kind of mistake each) and the linter's findings, asserted as the
// exact "file:line: severity: message [id]" lines a user sees.
#include "protocol/cia306/eds_lint.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace drivecheck::cia306 {
namespace {

using Lines = std::vector<std::string>;

std::string load(const std::string& name) {
  std::ifstream in(std::string(DRIVECHECK_EDS_TEST_DATA) + "/" + name, std::ios::binary);
  EXPECT_TRUE(in) << name;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

Lines lines(const std::vector<Diagnostic>& diagnostics, Severity severity) {
  Lines out;
  for (const auto& d : diagnostics) {
    if (d.severity == severity) out.push_back(d.to_string());
  }
  return out;
}

Lines read_errors(const std::string& name) {
  return lines(read_eds(load(name), name).diagnostics, Severity::error);
}

Lines read_eds_errors_text(const std::string& text, const std::string& name) {
  return lines(read_eds(text, name).diagnostics, Severity::error);
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) text.replace(pos, from.size(), to);
  return text;
}

TEST(EdsErrors, EmptyVendorAndProductNumberAreWarnings) {
  // Given an otherwise valid EDS whose VendorNumber and ProductNumber are empty, as real vendor
  // files have them
  std::string text = load("minimal.eds");
  text = replaced(text, "VendorNumber=0x000001A2", "VendorNumber=");
  text = replaced(text, "ProductNumber=0x00000001", "ProductNumber=");
  // When read
  const auto result = read_eds(text, "vendor.eds");
  // Then it has no error, and a warning names each empty key
  EXPECT_EQ(lines(result.diagnostics, Severity::error), Lines{});
  const auto warnings = lines(result.diagnostics, Severity::warning);
  const auto count = std::count_if(warnings.begin(), warnings.end(), [](const std::string& w) {
    return w.find("[identity-empty]") != std::string::npos;
  });
  EXPECT_EQ(count, 2) << ::testing::PrintToString(warnings);
}

TEST(EdsErrors, DuplicateSection) {
  // Given [1001] twice
  // When read
  // Then the repeat is an error at its line, naming the first
  EXPECT_EQ(
      read_errors("bad_duplicate_section.eds"),
      Lines{"bad_duplicate_section.eds:58: error: section [1001] repeats the one at line 29; the "
            "repeat is ignored [duplicate-section]"});
}

TEST(EdsErrors, DuplicateKeyWithAnotherValue) {
  // Given DefaultValue=0 and DefaultValue=1000 in one section
  // When read
  // Then the second is an error and the first value is kept
  EXPECT_EQ(
      read_errors("bad_duplicate_key.eds"),
      Lines{"bad_duplicate_key.eds:40: error: key 'DefaultValue' of [1017] repeats line 39 with "
            "another value ('0' vs '1000'); the first is used [duplicate-key]"});
  EXPECT_EQ(read_eds(load("bad_duplicate_key.eds")).eds.find(0x1017)->keys.default_value, "0");
}

TEST(EdsErrors, DuplicateKeyWithTheSameValueIsAWarning) {
  // Given a key repeated with the same value
  // When read
  // Then it is a warning only
  const auto text =
      replaced(load("minimal.eds"), "DefaultValue=4\n", "DefaultValue=4\ndefaultvalue = 4\n");
  const auto result = read_eds(text, "minimal.eds");
  EXPECT_FALSE(result.has_errors());
  EXPECT_EQ(
      lines(result.diagnostics, Severity::warning),
      Lines{"minimal.eds:69: warning: key 'defaultvalue' of [1018sub0] repeats line 68 with the "
            "same value [duplicate-key]"});
}

TEST(EdsErrors, SubNumberInconsistentWithSubSections) {
  // Given SubNumber=3 and two sub-object sections
  // When read
  // Then an error at the SubNumber line
  EXPECT_EQ(
      read_errors("bad_subnumber.eds"),
      Lines{"bad_subnumber.eds:44: error: [1018] SubNumber=3 but 2 sub-object sections follow "
            "[subnumber-mismatch]"});
}

TEST(EdsErrors, UnknownOrAmbiguousDataType) {
  // Given DataType=0x0017 (reserved) and DataType=0010 (octal 8, hex 16)
  // When read
  // Then both are errors
  EXPECT_EQ(
      read_errors("bad_data_type.eds"),
      (Lines{
          "bad_data_type.eds:25: error: DataType '0010' reads 0008h as CiA 306 says (leading 0 = "
          "octal, else decimal) but 0010h as hex; write it with 0x [ambiguous-data-type]",
          "bad_data_type.eds:37: error: DataType 0x0017 of [1017] is not a CiA 301 basic data "
          "type [unknown-data-type]"}));
}

TEST(EdsErrors, DefaultValueNotParseableForItsType) {
  // Given 0x1FF for UNSIGNED8, 089 (bad octal) and $NODEID-1
  // When read
  // Then each is an error that says why
  EXPECT_EQ(
      read_errors("bad_default_value.eds"),
      (Lines{"bad_default_value.eds:33: error: DefaultValue '0x1FF' is not valid for UNSIGNED8: "
             "0x1FF does not fit UNSIGNED8 [bad-value]",
             "bad_default_value.eds:39: error: DefaultValue '089' is not valid for UNSIGNED16: "
             "'089' is not an octal number (CiA 306 reads a leading 0 as octal) [bad-value]",
             "bad_default_value.eds:56: error: DefaultValue '$NODEID-1' is not valid for "
             "UNSIGNED32: '$NODEID-1' is not a $NODEID expression ($NODEID, $NODEID+n or "
             "n+$NODEID) [bad-value]"}));
}

TEST(EdsErrors, ListedObjectWithoutSection) {
  // Given 0x1005 in [OptionalObjects] and no [1005]
  // When read
  // Then an error at the list entry
  EXPECT_EQ(
      read_errors("bad_listed_without_section.eds"),
      Lines{"bad_listed_without_section.eds:22: error: object 1005h is listed in [OptionalObjects] "
            "but has no section [1005] [missing-object-section]"});
}

TEST(EdsErrors, MissingListEntriesAreReportedAsRuns) {
  // Given [MandatoryObjects] SupportedObjects=65535 with entries 1, 3 and 6 (the objects of
  // minimal.eds renumbered)
  // When read
  // Then one error per run of missing entry numbers (2, 4..5, 7..65535), at the section line:
  //      not one per number (65533 errors for one wrong count)
  const std::string text =
      replaced(load("minimal.eds"), "SupportedObjects=3\n1=0x1000\n2=0x1001\n3=0x1018\n",
               "SupportedObjects=65535\n1=0x1000\n3=0x1001\n6=0x1018\n");
  EXPECT_EQ(lines(read_eds(text, "runs.eds").diagnostics, Severity::error),
            (Lines{"runs.eds:36: error: [MandatoryObjects] SupportedObjects=65535 but entry 2 is "
                   "missing [list-count-mismatch]",
                   "runs.eds:36: error: [MandatoryObjects] SupportedObjects=65535 but entries "
                   "4..5 are missing [list-count-mismatch]",
                   "runs.eds:36: error: [MandatoryObjects] SupportedObjects=65535 but entries "
                   "7..65535 are missing [list-count-mismatch]"}));
}

TEST(EdsErrors, SectionNotListedAndOrphanSubSection) {
  // Given [2000] that no list names and [2001sub1] without [2001]
  // When read
  // Then both are errors at their section lines
  EXPECT_EQ(read_errors("bad_unlisted_section.eds"),
            (Lines{"bad_unlisted_section.eds:58: error: section [2000] is not listed in "
                   "[MandatoryObjects], [OptionalObjects] or [ManufacturerObjects] "
                   "[unlisted-object-section]",
                   "bad_unlisted_section.eds:64: error: [2001sub1] has no object section [2001] "
                   "[orphan-sub-section]"}));
}

TEST(EdsErrors, SyntaxAccessTypeAndObjectType) {
  // Given a key before any section, a line without '=', ObjectType=0x4, AccessType=readwrite
  // When read
  // Then four errors, each at its line
  EXPECT_EQ(
      read_errors("bad_syntax.eds"),
      (Lines{
          "bad_syntax.eds:2: error: key 'Orphan' before the first section [syntax]",
          "bad_syntax.eds:9: error: 'this line has no equals sign' is neither 'key=value', "
          "'[section]' nor a ';' comment [syntax]",
          "bad_syntax.eds:33: error: ObjectType '0x4' is not 0x0, 0x2, 0x5, 0x6, 0x7, 0x8 or "
          "0x9 [bad-object-type]",
          "bad_syntax.eds:41: error: AccessType 'readwrite' is not ro, wo, rw, rwr, rww or const "
          "[bad-access-type]"}));
}

TEST(EdsErrors, CompactSubObjMisuse) {
  // Given CompactSubObj on a RECORD, [1016Name] with NrOfEntries=3 and a name for sub 3 of 2
  // When read
  // Then three errors
  EXPECT_EQ(
      read_errors("bad_compact.eds"),
      (Lines{"bad_compact.eds:65: error: CompactSubObj on [1016], a RECORD (CiA 306 allows it on "
             "ARRAY only) [compact-not-array]",
             "bad_compact.eds:68: error: [1016Name] NrOfEntries=3 but 1 usable entry follows "
             "[count-mismatch]",
             "bad_compact.eds:70: error: key '3' in [1016Name] is not a sub-index 1..2 (decimal) "
             "[bad-compact-entry]"}));
}

TEST(EdsErrors, AmbiguousListIndex) {
  // Given a list entry "1017" without 0x, where decimal 1017 (03F9h) has no section but 1017h does
  // When read
  // Then it is read as hex with a warning; with sections for both readings it is an error
  const auto text = replaced(load("minimal.eds"), "1=0x1017", "1=1017");
  const auto result = read_eds(text, "minimal.eds");
  EXPECT_FALSE(result.has_errors());
  EXPECT_EQ(
      lines(result.diagnostics, Severity::warning),
      Lines{"minimal.eds:105: warning: '1017' read as 1017h (hex without 0x: that object has a "
            "section) [hex-without-prefix]"});
  const auto both = replaced(text, "[1017]\n",
                             "[03F9]\nParameterName=x\nDataType=0x0005\nAccessType=ro\n\n[1017]\n");
  EXPECT_EQ(
      lines(read_eds(both, "minimal.eds").diagnostics, Severity::error)[0],
      "minimal.eds:105: error: '1017' names object 03F9h read as CiA 306 says, or 1017h read as "
      "hex; both have a section: write 0x1017 [ambiguous-index]");
}

TEST(EdsErrors, GarbageNeverCrashes) {
  // Given truncations and byte mutations of a large valid file
  // When read, linted and turned into a dictionary
  // Then every call returns (errors are values), whatever the input
  const std::string text = load("servo_drive.eds");
  std::uint32_t seed = 12345;
  auto next = [&seed] {
    seed = seed * 1664525u + 1013904223u;
    return seed >> 8;
  };
  const char alphabet[] = "[]=;\r\n 0x$NODEIDsub+-09AFaf\t\xEF\xBB\xBF\xFF";
  for (int round = 0; round < 300; ++round) {
    std::string mutated = text.substr(0, next() % text.size());
    for (int k = 0; k < 20; ++k) {
      if (mutated.empty()) break;
      mutated[next() % mutated.size()] = alphabet[next() % (sizeof alphabet - 1)];
    }
    const auto result = read_eds(mutated, "fuzz");
    (void)lint_eds(result.eds);
    (void)to_object_dictionary(result.eds, 1);
    (void)write_eds(result.eds);
  }
  SUCCEED();
}

TEST(EdsFile, UnreadableFileIsAnError) {
  // Given a path that does not exist, and a directory
  // When linted
  // Then the error names the file and no diagnostic list is produced
  const auto missing = lint_eds_file("/nonexistent/drivecheck.eds");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().to_string(), "/nonexistent/drivecheck.eds: No such file or directory");
  const auto directory = lint_eds_file(DRIVECHECK_EDS_TEST_DATA);
  ASSERT_FALSE(directory);
  EXPECT_EQ(directory.error().message, "is a directory");
  const auto ok = lint_eds_file(std::string(DRIVECHECK_EDS_TEST_DATA) + "/minimal.eds");
  ASSERT_TRUE(ok);
  EXPECT_EQ(ok->size(), 0u);
}

TEST(EdsLint, CleanFilesHaveNoErrors) {
  // Given the well-formed test files
  // When linted
  // Then no finding has error severity
  for (const char* name :
       {"minimal.eds", "crlf_bom.eds", "lowercase_keys.eds", "compact_subobj.eds",
        "nodeid_forms.eds", "octal_and_hex.eds", "missing_optional.eds", "device.dcf",
        "comments_tools.eds", "value_types.eds", "servo_drive.eds"}) {
    EXPECT_EQ(lines(lint_eds_text(load(name), name), Severity::error), Lines{}) << name;
  }
}

TEST(EdsLint, FindsCiA301RuleViolations) {
  // Given a file that reads cleanly but breaks CiA 301 rules
  // When linted
  // Then every violation is found at its line with its id
  const auto findings = lint_eds_text(load("bad_lint.eds"), "bad_lint.eds");
  EXPECT_EQ(
      lines(findings, Severity::error),
      (Lines{
          "bad_lint.eds: error: mandatory object 1001h is missing (CiA 301 §7.5.2) "
          "[mandatory-object-missing]",
          "bad_lint.eds: error: no error control: neither 1017h (producer heartbeat time) nor "
          "100Ch/100Dh (node guarding) [error-control-missing]",
          "bad_lint.eds:11: error: [DeviceInfo] NrOfRXPDO=2 but 1 PDO communication objects "
          "(1400h-15FFh) exist [pdo-count-mismatch]",
          "bad_lint.eds:41: error: 100Ch without 100Dh: node guarding needs guard time and life "
          "time factor [guarding-incomplete]",
          "bad_lint.eds:43: error: 100Ch sub 0 is UNSIGNED32, CiA 301 defines it as UNSIGNED16 "
          "[data-type-mismatch]",
          "bad_lint.eds:56: error: 1018h sub 0 (highest sub-index supported) defaults to 3 but "
          "the highest sub-index is 1 [sub0-inconsistent]",
          "bad_lint.eds:96: error: RPDO mapping 1600h sub 1 (0x20020010) names 2002h sub 0, "
          "which is ro: an RPDO cannot write it [pdo-mapping-direction]",
          "bad_lint.eds:102: error: RPDO mapping 1600h sub 2 (0x20030008) names 2003h sub 0, "
          "which has PDOMapping=0 [pdo-mapping-not-mappable]",
          "bad_lint.eds:108: error: RPDO mapping 1600h sub 3 (0x20040020) gives 32 bits, 2004h "
          "sub 0 is UNSIGNED16 (16 bits) [pdo-mapping-length]",
          "bad_lint.eds:110: error: PDO mapping 1A00h has no communication object 1800h "
          "[pdo-without-communication]",
          "bad_lint.eds:119: error: TPDO mapping 1A00h maps 80 bits, more than the 64 of a CAN "
          "frame [pdo-mapping-too-long]",
          "bad_lint.eds:137: error: 2000h sub 0 DefaultValue '200' is above HighLimit '100' "
          "[default-out-of-range]",
          "bad_lint.eds:146: error: 2001h sub 0 LowLimit 10 is above HighLimit -10 "
          "[limits-inverted]",
      }));
  EXPECT_EQ(
      lines(findings, Severity::warning),
      Lines{"bad_lint.eds:8: warning: [DeviceInfo] VendorNumber=0x10 but 1018h sub 1 defaults to "
            "0x1 [identity-mismatch]"});
}

TEST(EdsLint, DummyMappingNeedsDummyUsage) {
  // Given an RPDO mapping dummy 0005h while [DummyUsage] says Dummy0005=0
  // When linted
  // Then the mapping entry is an error
  const auto text = replaced(load("compact_subobj.eds"), "Dummy0005=1", "Dummy0005=0");
  EXPECT_EQ(
      lines(lint_eds_text(text, "compact_subobj.eds"), Severity::error),
      Lines{"compact_subobj.eds:156: error: RPDO mapping 1600h sub 1 (0x00050008) maps dummy 0005h "
            "(UNSIGNED8) but [DummyUsage] Dummy0005 is not 1 [pdo-mapping-dummy-disabled]"});
}

TEST(EdsLint, DummyUsageBelowTheGranularity) {
  // Given [DummyUsage] Dummy0001=1 (the 1-bit BOOLEAN dummy) with [DeviceInfo] Granularity=8
  // When linted
  // Then the key is an error: a byte-wise mapping cannot place one bit
  const auto text = replaced(load("compact_subobj.eds"), "Dummy0001=0", "Dummy0001=1");
  EXPECT_EQ(lines(lint_eds_text(text, "compact_subobj.eds"), Severity::error),
            Lines{"compact_subobj.eds:26: error: [DummyUsage] Dummy0001=1 declares the 1-bit dummy "
                  "0001h (BOOLEAN) but [DeviceInfo] Granularity=8 maps in steps of 8 bits: it "
                  "cannot be mapped [dummy-usage-granularity]"});
}

TEST(EdsLint, DummyUsageWithAFixedMapping) {
  // Given Granularity=0 (the mapping cannot be changed) and Dummy0002..0007=1, while the one
  // default RPDO mapping holds the dummies 0005h and 0006h
  // When linted
  // Then each dummy no RPDO can ever map is a warning, 0005h and 0006h are not
  const auto text = replaced(load("compact_subobj.eds"), "Granularity=8", "Granularity=0");
  Lines unusable;
  for (const auto& line : lines(lint_eds_text(text, "compact_subobj.eds"), Severity::warning)) {
    if (line.find("[dummy-usage-unusable]") != std::string::npos) unusable.push_back(line);
  }
  EXPECT_EQ(unusable.size(), 4U) << ::testing::PrintToString(unusable);
  EXPECT_EQ(unusable.at(0),
            "compact_subobj.eds:27: warning: [DummyUsage] Dummy0002=1 but [DeviceInfo] "
            "Granularity=0 (the mapping cannot be changed) and no default RPDO mapping holds "
            "0002h: no RPDO can map it [dummy-usage-unusable]");
  for (const auto& line : unusable) {
    EXPECT_EQ(line.find("Dummy0005"), std::string::npos) << line;
    EXPECT_EQ(line.find("Dummy0006"), std::string::npos) << line;
  }
}

TEST(EdsLint, DummyUsageWithoutAnyRpdo) {
  // Given a file without RPDOs that declares Dummy0005=1
  // When linted
  // Then the declaration is a warning: a dummy is an RPDO mapping entry
  const auto text = load("minimal.eds") + "\n[DummyUsage]\nDummy0005=1\n";
  Lines unusable;
  for (const auto& line : lines(lint_eds_text(text, "minimal.eds"), Severity::warning)) {
    if (line.find("[dummy-usage-unusable]") != std::string::npos) unusable.push_back(line);
  }
  EXPECT_EQ(unusable, Lines{"minimal.eds:116: warning: [DummyUsage] Dummy0005=1 but the file "
                            "describes no RPDO mapping (1600h-17FFh): a dummy is an RPDO mapping "
                            "entry [dummy-usage-unusable]"});
}

TEST(EdsErrors, DummyUsageMalformedLines) {
  // Given [DummyUsage] with a key outside Dummy0001..Dummy0007 and a value neither 0 nor 1
  auto text = replaced(load("compact_subobj.eds"), "Dummy0007=1", "Dummy0008=1");
  text = replaced(text, "Dummy0006=1", "Dummy0006=yes");
  // When read
  // Then each is an error at its own line
  EXPECT_EQ(read_eds_errors_text(text, "compact_subobj.eds"),
            (Lines{"compact_subobj.eds:31: error: Dummy0006 'yes' is neither 0 nor 1 [bad-value]",
                   "compact_subobj.eds:32: error: 'Dummy0008' in [DummyUsage] is not one of "
                   "Dummy0001..Dummy0007 (CiA 306: the dummy data types 0001h-0007h) [bad-key]"}));
}

TEST(EdsLint, NodeIdDefaultsAreCheckedForNodes1And127) {
  // Given HighLimit 0x1FF on a COB-ID defaulting to $NODEID+0x180
  // When linted
  // Then node 127 (0x1FF) is within the limit, but a limit of 0x1FE is not
  const std::string base = replaced(load("nodeid_forms.eds"), "DefaultValue=$nodeid + 0x80",
                                    "DefaultValue=$NODEID+0x180\nHighLimit=0x1FF");
  EXPECT_EQ(lines(lint_eds_text(base, "n.eds"), Severity::error), Lines{});
  const std::string low = replaced(base, "HighLimit=0x1FF", "HighLimit=0x1FE");
  EXPECT_EQ(lines(lint_eds_text(low, "n.eds"), Severity::error),
            Lines{"n.eds:73: error: 1014h sub 0 DefaultValue '$NODEID+0x180' is above HighLimit "
                  "'0x1FE' [default-out-of-range]"});
}

TEST(EdsLint, DcfCommissioningIsChecked) {
  // Given the DCF with NodeID 0 and a bit rate the device does not support
  // When linted
  // Then both are errors
  std::string text = replaced(load("device.dcf"), "NodeID=5", "NodeID=0");
  text = replaced(text, "Baudrate=500", "Baudrate=125");
  EXPECT_EQ(
      lines(lint_eds_text(text, "device.dcf"), Severity::error),
      (Lines{
          "device.dcf:33: error: [DeviceComissioning] NodeID=0 is outside 1..127 [dcf-node-id]",
          "device.dcf:35: error: [DeviceComissioning] Baudrate=125 but [DeviceInfo] BaudRate_125 "
          "is not 1 [dcf-baudrate]"}));
}

TEST(EdsLintRules, EveryFindingIdIsARuleOfTheTable) {
  // Given every test file (the clean ones and those made to break the rules)
  std::vector<std::string> ids;
  for (const std::string name :
       {"minimal.eds", "crlf_bom.eds", "lowercase_keys.eds", "compact_subobj.eds",
        "nodeid_forms.eds", "octal_and_hex.eds", "missing_optional.eds", "device.dcf",
        "comments_tools.eds", "value_types.eds", "servo_drive.eds", "bad_lint.eds"}) {
    for (const auto& finding : lint_eds(read_eds(load(name), name).eds, name))
      ids.push_back(finding.id);
  }
  // When the linter's findings are looked up in protocol/cia306/eds_lint_rules.inc
  // Then each id is a row whose severity is the finding's, and the rows are unique, kebab-case
  //      and cite a clause
  ASSERT_FALSE(ids.empty());
  const auto rules = lint_rules();
  for (const auto& id : ids) {
    EXPECT_NE(std::find_if(rules.begin(), rules.end(),
                           [&](const LintRule& rule) { return rule.id == id; }),
              rules.end())
        << id;
  }
  std::vector<std::string_view> seen;
  for (const auto& rule : rules) {
    EXPECT_EQ(std::find(seen.begin(), seen.end(), rule.id), seen.end()) << rule.id;
    seen.push_back(rule.id);
    EXPECT_TRUE(std::all_of(rule.id.begin(), rule.id.end(), [](char c) {
      return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
    })) << rule.id;
    EXPECT_TRUE(rule.clause.starts_with("CiA 30")) << rule.id;
    EXPECT_FALSE(rule.what.empty()) << rule.id;
  }
  EXPECT_EQ(reader_rule().id, "reader");
}

TEST(EdsLintRules, SeverityOfEachFindingIsItsRules) {
  // Given the findings of the broken file and of the rwr/rww mapping hint
  auto findings = lint_eds_text(load("bad_lint.eds"), "bad_lint.eds");
  // When each finding's severity is compared with its rule's
  // Then they agree (a rule is either an error or a warning, never both)
  for (const auto& finding : findings) {
    const auto rules = lint_rules();
    const auto rule = std::find_if(rules.begin(), rules.end(),
                                   [&](const LintRule& r) { return r.id == finding.id; });
    if (rule == rules.end()) continue;  // a reader finding
    EXPECT_EQ(rule->severity, finding.severity) << finding.to_string();
  }
}

}  // namespace
}  // namespace drivecheck::cia306
