// EDS-driven object dictionary checks (family `eds/od`), generated at run time from the DUT's
// EDS (--eds) or the profile's `objects:` list (the manual's object table). Per object entry:
//   <idx>-<sub>/read           readable: an SDO read succeeds with the type's size
//   <idx>-<sub>/write-ro       ro/const: a write of the same size aborts 06010002h
//   <idx>-<sub>/read-wo        wo: a read aborts 06010001h
//   <idx>-<sub>/default        profile objects with `default:` and EDS const entries: the value
//   <idx>-<sub>/below-min      rw with a lower limit: writing min-1 aborts 0609003xh
//   <idx>-<sub>/above-max      rw with an upper limit: writing max+1 aborts 0609003xh
// (0609003xh = 06090030h value range exceeded, 06090031h too high, 06090032h too low; for sub
// 00h of a PDO mapping record also the mapping procedure's 06040042h, 06010000h, 06040043h,
// 08000022h: CiA 301 §7.5.2.36/38, see protocol/cia301/pdo_service.hpp.)
// 1003h sub 1..254 (present only while errors are recorded) get no read check.
// Only fixed-size integer types get the size/limit/default checks. Every vector resets the node
// and runs in Pre-operational, so its verdict does not depend on the vectors run before it
// (`drivecheck run --order`); `default` is the value after a reset node.
//
// Not built yet: probing for objects the device has but the EDS lacks (1000h-1FFFh,
// 6000h-67FFh).
#pragma once

#include <string>
#include <vector>

#include "conformance/result.hpp"
#include "conformance/vector.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::cia301 {
class ObjectDictionary;
}  // namespace drivecheck::cia301

namespace drivecheck::conformance {

// `eds` may be null; `eds_file` names it in the sources.
std::vector<Vector> generate_od_vectors(const cia301::ObjectDictionary* eds,
                                        const std::string& eds_file,
                                        const profile::DriveProfile& profile);

}  // namespace drivecheck::conformance
