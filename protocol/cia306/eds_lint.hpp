// The EDS/DCF linter: the semantic checks CiA's EDS checker makes, on top of what the reader
// already reports. Each finding is a Diagnostic with file:line, severity and a stable id:
//
//   mandatory-object-missing     E  1000h, 1001h or 1018h absent (CiA 301 §7.5.2)
//   mandatory-list               W  1000h/1001h/1018h not in [MandatoryObjects], or another
//                                   object in it
//   wrong-object-list            W  2000h-5FFFh outside [ManufacturerObjects], or the reverse
//   error-control-missing        E  neither 1017h (heartbeat) nor 100Ch+100Dh (guarding)
//   guarding-incomplete          E  only one of 100Ch/100Dh
//   identity-vendor-id-missing   E  1018h without sub-index 1
//   identity-mismatch            W  DeviceInfo Vendor/Product/RevisionNumber != 1018h sub 1/2/3
//   sub0-data-type               E  sub-index 0 of an ARRAY/RECORD is not UNSIGNED8
//   sub0-inconsistent            E  sub 0 default != highest sub-index (ro/const sub 0),
//                                   or > highest sub-index (writable sub 0)
//   array-mixed-types            E  ARRAY sub-objects 1..n of different DataType
//   limits-inverted              E  LowLimit > HighLimit
//   limits-on-non-numeric        W  limits on a string/domain
//   default-out-of-range         E  DefaultValue outside LowLimit..HighLimit (for $NODEID:
//                                   with node-ID 1 and 127)
//   value-out-of-range           E  DCF ParameterValue outside the limits
//   mappable-variable-length     W  PDOMapping=1 on a string/domain
//   data-type-mismatch           E  a CiA 301 communication object with another DataType
//   access-type-mismatch         E  1000h/1001h/1018h writable
//   pdo-mapping-entry-missing    E  mapping sub 0 counts an entry that has no sub-object
//   pdo-mapping-target-missing   E  a mapping entry names no existing object (or is 0)
//   pdo-mapping-not-mappable     E  ... an object with PDOMapping=0
//   pdo-mapping-length           E  ... with a length other than the object's size in bits
//   pdo-mapping-direction        E  RPDO -> ro/const, TPDO -> wo
//   pdo-mapping-direction-hint   W  RPDO -> rwr, TPDO -> rww
//   pdo-mapping-dummy-disabled   E  dummy object mapped but [DummyUsage] does not enable it
//   dummy-usage-granularity      E  [DummyUsage] enables a dummy whose length the Granularity
//                                   cannot place (1-bit 0001h, Granularity 8)
//   dummy-usage-unusable         W  [DummyUsage] enables a dummy no RPDO can map (no RPDO, or
//                                   Granularity 0 and no default RPDO mapping holds it)
//   pdo-mapping-too-long         E  more than 64 bits mapped
//   pdo-without-communication    E  1600h+n without 1400h+n, 1A00h+n without 1800h+n, and
//                                   the reverse
//   pdo-count-mismatch           E  NrOfRXPDO/NrOfTXPDO != number of 1400h-15FFh/1800h-19FFh
//   device-info-range            E  Granularity > 64
//   device-info-missing-key      W  VendorName, ProductName, a BaudRate_ or NrOf*PDO missing
//   no-baud-rate                 W  no BaudRate_x=1
//   file-info-format             W  EDSVersion, FileVersion, CreationDate/Time ... malformed
//   dcf-node-id                  E  DCF NodeID absent or outside 1..127
//   dcf-baudrate                 E  DCF Baudrate not a CiA bit rate or not in DeviceInfo
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/cia306/eds.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia306 {

// One rule of the linter (protocol/cia306/eds_lint_rules.inc, the one table).
struct LintRule {
  std::string_view id;
  Severity severity;
  std::string_view clause;  // what makes it a finding (CiA 301 clause, CiA 306 section/key)
  std::string_view what;    // what a clean file has, one line
};
// Every rule, in table order.
std::span<const LintRule> lint_rules();
// The reader's own warnings (file syntax it tolerates) as one rule: id "reader".
const LintRule& reader_rule();

// Semantic findings for a model (read from `file`, for the diagnostics' file name).
std::vector<Diagnostic> lint_eds(const Eds& eds, const std::string& file = "");

// Reader diagnostics plus lint findings, ordered by line; the error is an unreadable file.
Expected<std::vector<Diagnostic>, TextError> lint_eds_file(const std::string& path);
std::vector<Diagnostic> lint_eds_text(std::string_view text, const std::string& file = "");

}  // namespace drivecheck::cia306
