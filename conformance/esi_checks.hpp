// The ESI cross-check (`drivecheck run --bus ethercat:... --esi FILE`): the EtherCAT slave
// against its ESI (ETG.2000 EtherCAT Slave Information, protocol/ethercat/esi.hpp), as the
// eds/* families judge a CANopen device against its EDS (od_checks.hpp). Generated vectors,
// EtherCAT only (`transports: [ethercat]`), each with the ESI as its first source.
//
// Family `esi/identity`:
//   vendor-id, product-code          1018h:01/02 read over CoE against Vendor/Id and
//                                    Type@ProductCode: MUST (CiA 301 §7.5.2.21: 1018h holds
//                                    the device's identity; ETG.2000: the ESI is matched to a
//                                    slave by these numbers, so a mismatch names another device)
//   revision-major, revision-number  1018h:03 against Type@RevisionNo: bits 16-31 MUST, the
//                                    whole number SHOULD (as eds/identity: CiA 301 §7.5.2.21,
//                                    minor revision = same behaviour, other firmware)
//   sii-vendor-id, sii-product-code, the SII header (words 08h-0Dh, as the master read it at the
//   sii-revision-number              bring-up) against the same ESI numbers: MUST, the master
//                                    finds the slave's ESI by them (ETG.2000). Judged from the
//                                    SII the master read (no bus step): results, not vectors
// Family `esi/od`, per entry of the ESI's Dictionary (VARs, and each sub-index of a structured
// object):
//   <idx>-<sub>/read       ro/rw: an upload succeeds, with BitSize/8 octets where BitSize is a
//                          multiple of 8 up to 64 (MUST: ETG.2000 Flags/Access, CiA 301 §7.4.5)
//   <idx>-<sub>/read-wo    wo: an upload aborts (read-write-only; MUST)
//   <idx>-<sub>/write-ro   ro of 1..8 octets: a download aborts (write-read-only; MUST)
//   <idx>-<sub>/default    an integer entry with DefaultData: the value after the setup
//                          (restore defaults for a writable entry, else a reset) equals it.
//                          SHOULD (a warning): the ESI's DefaultData is the value a
//                          configuration tool starts from, and neither ETG.2000 nor CiA 301
//                          binds the device to it; MUST for a read-only sub 0 of an
//                          ARRAY/RECORD, which the structure fixes (CiA 301 §7.4.3, as eds/od;
//                          a writable sub 0, e.g. 1C12h's count, is a setting: SHOULD)
// Family `esi/pdo`:
//   rx-assignment, tx-assignment   1C12h/1C13h against the RxPdo/TxPdo with @Sm (the PDOs the
//                                  ESI says are assigned by default), count and order: MUST
//                                  where the ESI's CoE has no PdoAssign (the master cannot
//                                  download an assignment, so it relies on the ESI's);
//                                  SHOULD where it has (ETG.1000.6: the master downloads the
//                                  assignment it wants in PREOP)
//   <idx>/mapping                  each RxPdo/TxPdo: <idx>:00 and its entries against the ESI's
//                                  Entry list: MUST where the PDO is Fixed or the CoE has no
//                                  PdoConfig (the mapping cannot be written), else SHOULD
// PdoMapping (Flags/PdoMapping of the Dictionary: R, T, RT, TR; lower case read alike), only
// where the ESI flags some entry (otherwise it says nothing about mappability: not applicable):
//   <idx>/mappable          each PDO mapping object the ESI knows (RxPdo/TxPdo, and its
//                           Dictionary's 1600h-17FFh/1A00h-1BFFh), read after a reset: sub 0 at
//                           most the entries the ESI describes, and each entry in use an
//                           object the ESI flags for that direction (R for 1600h+, T for
//                           1A00h+), or a gap
//   <idx>/entries-mappable  the ESI's own RxPdo/TxPdo Entry lists against its own flags,
//                           judged from the file (an ESI that contradicts itself is an ESI
//                           defect): results, not vectors
//   Both SHOULD (a warning): CiA 301 lets only mappable objects be mapped, but whether ETG.2000
//   binds a device's mappings to its ESI's flags is in ETG.2000's text, which is not public to
//   us (the vector's note says so); `--strict` makes them fail.
// 1003h sub 1..FEh (present only while errors are recorded) get no read; 1010h/1011h sub 1+
// (a read is the capability) and the 1003h history get no default check.
#pragma once

#include <string>
#include <vector>

#include "conformance/result.hpp"
#include "conformance/vector.hpp"
#include "protocol/ethercat/esi.hpp"
#include "protocol/ethercat/sii.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::conformance {

// The esi/identity (bus part), esi/od and esi/pdo vectors of `device` of `esi`.
std::vector<Vector> generate_esi_vectors(const ethercat::EsiFile& esi,
                                         const ethercat::EsiDevice& device);

// The esi/identity/sii-* results: the SII header the master read against the ESI.
std::vector<VectorResult> esi_sii_results(const ethercat::EsiFile& esi,
                                          const ethercat::EsiDevice& device,
                                          const ethercat::SiiHeader& sii,
                                          const profile::DriveProfile& profile, bool strict);

// The esi/pdo/<idx>/entries-mappable results: the ESI's RxPdo/TxPdo Entry lists against its
// own Flags/PdoMapping (no bus).
std::vector<VectorResult> esi_pdo_mapping_results(const ethercat::EsiFile& esi,
                                                  const ethercat::EsiDevice& device,
                                                  const profile::DriveProfile& profile,
                                                  bool strict);

}  // namespace drivecheck::conformance
