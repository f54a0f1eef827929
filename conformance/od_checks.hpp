// EDS-driven object dictionary checks, generated at run time from the DUT's EDS/DCF (--eds) or
// the profile's `objects:` list (the manual's object table). The CTT counterparts (shared/notes/
// ctt-catalogue.md) are named per check.
//
// Family `eds/od`, per object entry (EDS or profile):
//   <idx>-<sub>/read        readable: an SDO read succeeds with the type's size (CTT 4.1, 4.7)
//   <idx>-<sub>/write-ro    ro/const: a write of the same size aborts (CTT 4.3)
//   <idx>-<sub>/read-wo     wo: a read aborts (CTT 4.4)
//   <idx>-<sub>/below-min   rw with a lower limit: writing min-1 aborts 0609003xh (CTT 4.6)
//   <idx>-<sub>/above-max   rw with an upper limit: writing max+1 aborts 0609003xh (CTT 4.6)
//   <idx>-<sub>/default     the value after a reset node (CTT 4.2, 4.8): a profile object with
//                           `default:`; an EDS entry with a DefaultValue that is const, writable
//                           (rw/rwr/rww), or sub 00h of an ARRAY/RECORD ("highest sub-index
//                           supported", fixed by the structure, CiA 301 §7.4.3). The expected
//                           value is the EDS's, $NODEID resolved for --node; a DCF's
//                           ParameterValue where it gives one (a commissioned drive's stored
//                           value); strings and domains (1008h, 1009h, 100Ah: they may name
//                           another firmware of the family the EDS describes) at should
//                           level. ro entries other than sub 00h are process values (6041h,
//                           1001h, the serial number 1018h sub 4): their DefaultValue is no reset
//                           value, they get no default check. A writable EDS entry is read
//                           after a factory restore (setup restore-defaults: 1011h, then reset
//                           node; on a real bus N/A without --allow-factory-restore), since a
//                           reset gives the stored configuration, not the EDS default; with a
//                           DCF (*.dcf) after a reset node, against its ParameterValue.
// EDS entries only (with --eds):
//   <idx>-<sub>/write-back  rw/rwr/rww of a fixed size (1..8 bytes): the value read is written
//                           back and read again unchanged (CTT 4.9). Where CiA 301 lets the
//                           device refuse any write in the present state (a valid PDO's COB-ID,
//                           inhibit time and mapping, the COB-IDs of 1005h/1012h/1014h, 1019h
//                           while SYNC is produced), a refusal from that clause's set passes too;
//                           the value read again must be unchanged either way.
//   <idx>-ff/object-type    per object: sub-index FFh (CiA 301 §7.4.3) read; it is optional, so
//                           abort 06090011h/08000000h (sub-index-does-not-exist) passes; a value
//                           must hold the EDS's object code in bits 0-7 and, for VAR and ARRAY,
//                           the data type index in bits 8-23 (CTT 4.5). A RECORD's data type (its
//                           structure index) is not in the EDS model: only its object code is
//                           judged.
//   <idx>-<sub>/mapped-object  a default PDO mapping entry (1600h-17FFh/1A00h-1BFFh sub 1..40h,
//                           EDS DefaultValue not 0, no dummy): the object it names exists,
//                           read live: a TPDO's with the mapped length, an RPDO's read or
//                           refused read-write-only (CTT 3.21; the mapping itself is
//                           <idx>-<sub>/default).
//   reset-communication     one check (`eds/od/reset-communication`, CTT 9.1): every readable,
//                           writable integer entry of 1000h-1FFFh read after the reset node (its
//                           power-on value: stored, else default), the parameters CiA 301 lets
//                           take any value (100Ch, 100Dh, 1017h, 18xxh sub 5) written another,
//                           NMT reset communication, each entry must read its power-on value
//                           again (CiA 301 §7.3.2.1). One reset for all; the write-back
//                           exclusions apply, and 1013h (a running time stamp).
// EDS entries and the profile's objects:
//   <idx>-<sub>/tpdo-map    a PDO-mappable (EDS PDOMapping=1, profile `pdo: true`) wo or rww
//                           entry of a fixed size, mapped into a TPDO with the CiA 301 §7.5.2.38
//                           procedure (PDO destroyed, mapping disabled, entry written): the
//                           entry write is refused, set not-mappable (CTT 3.31). wo at must
//                           level (a wo entry cannot be read, so no TPDO can carry it); rww at
//                           should level (CiA 301 §7.4.5 makes its direction a hint; the CTT
//                           refuses it). With an EDS that declares none, `eds/od/tpdo-map` is
//                           one not-applicable result that says so. The TPDO: the EDS's first,
//                           else the profile's first default TPDO, else TPDO1 at 180h + node.
// Checks that would misjudge are not applicable with the rule as reason, never left out
// silently: the default of an entry with ObjFlags bit 1 ("refuse read on scan", CiA 306), the
// write-back of an entry with ObjFlags bit 0 ("refuse write on download"), of 1010h/1011h (a
// read gives the capability, a write needs the signature: CiA 301 §7.5.2.13, §7.5.2.14), 1003h
// sub 0 (only 0 may be written: §7.5.2.4), 1F51h (program control: a write is a command,
// CiA 302-3) and 6040h (controlword: a write is a command to the CiA 402 state machine).
// 1003h sub 1..254 (present only while errors are recorded) get no read or default check.
//
// Family `eds/identity` (with --eds): 1018h sub 1 (vendor-ID), sub 2 (product code) and sub 3
// (revision number) read live against [DeviceInfo] VendorNumber, ProductNumber, RevisionNumber
// where the EDS gives them (CiA 306: the numbers 1018h holds; CiA 301 §7.5.2.21). The revision:
// its major part (bits 16-31, the CANopen behaviour the EDS describes) at must level, the whole
// number (minor revision: same behaviour, other firmware) at should level.
//
// Family `eds/lint` (with --eds): the EDS itself (CTT 1.0): one result per linter rule
// (protocol/cia306/eds_lint_rules.inc, `eds/lint/<rule>`) and one for the reader's tolerated
// syntax (`eds/lint/reader`): pass when the file has no such finding; an error rule is must
// level (fail), a warning rule should level (a warning, a failure under --strict). They read the
// file, not the bus.
//
// Every bus check resets the node and runs in Pre-operational, so its verdict does not depend
// on the vectors run before it (`drivecheck run --order`); only fixed-size integer types get the
// size/limit checks. The probe for objects the device has but the EDS lacks is
// Engine::probe_undocumented_objects (`eds/od/undocumented-objects`).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "conformance/result.hpp"
#include "conformance/vector.hpp"
#include "protocol/cia306/eds.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::cia301 {
class ObjectDictionary;
}  // namespace drivecheck::cia301

namespace drivecheck::conformance {

// What the EDS's [DeviceInfo] says 1018h holds (absent: not given).
struct EdsIdentity {
  std::optional<std::uint32_t> vendor_id;
  std::optional<std::uint32_t> product_code;
  std::optional<std::uint32_t> revision_number;
};

// `eds` may be null; `eds_file` names it in the sources. `identity` (with an EDS) adds the
// `eds/identity` vectors. `node`: the DUT's node-ID (a profile's "+N" COB-IDs).
std::vector<Vector> generate_od_vectors(const cia301::ObjectDictionary* eds,
                                        const std::string& eds_file,
                                        const profile::DriveProfile& profile,
                                        const std::optional<EdsIdentity>& identity = std::nullopt,
                                        std::uint8_t node = 1);

// The `eds/lint/*` results of an EDS: `findings` are the reader's and the linter's diagnostics
// of `eds_file`. Verdicts go through decide_verdict (a profile deviation may name them;
// should-level failures are warnings unless `strict`).
std::vector<VectorResult> eds_lint_results(const std::vector<cia306::Diagnostic>& findings,
                                           const std::string& eds_file,
                                           const profile::DriveProfile& profile, bool strict);

}  // namespace drivecheck::conformance
