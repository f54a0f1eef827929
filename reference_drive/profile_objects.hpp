// The profile's object list in the reference drive: when the drive takes on a personality, every
// object of the profile's `objects:` list (vectors/drives/<name>/objects.yaml, the manual's
// object table; drive_profile.hpp) that the dictionary lacks is added, so that the drive answers
// the `eds/od/*` checks (conformance/od_checks.hpp) as the manual's drive would.
//
// An added entry carries the listed data type, access, PDO mappability, default (`default:`,
// else 0 / the empty string) and limits (`min:`/`max:` as the entry's low/high limit: a write
// outside aborts 06090032h/06090031h). It is a plain stored value: the reference drive has no
// behaviour behind a manufacturer parameter (the manual's drive does something with it, ours
// only keeps it), and a ro entry keeps its default for ever. Store group: the dictionary's.
//   - one entry listed at sub 0 only: a VAR;
//   - entries at subs >= 1: a RECORD; sub 0 is the listed sub 0 when the list has an UNSIGNED8
//     one (its default, else the highest listed sub), otherwise "highest sub-index supported"
//     (UNSIGNED8 ro, = the highest listed sub).
// Objects the dictionary has already keep the drive's definition and behaviour (the CiA
// objects the drive implements, the personality's own objects, KollmorgenObjects), except:
//   - structure: an ARRAY/RECORD whose sub 0 is "highest sub-index supported" (UNSIGNED8,
//     ro) takes the listed shape (ObjectDictionary::reshape_object): a listed sub 0 default N
//     drops the drive's entries above N (Kollmorgen 1010h/1011h/1016h: sub 1 only; Festo
//     1400h: subs 1-2), listed sub-indices it lacks are added as above (Kollmorgen 1800h
//     sub 4, Festo 60C1h sub 2); PDO mapping records keep their shape (mapping_entries does
//     that, listed_mapping_entries below); other missing sub-indices are reported;
//   - limits: listed min/max of a writable integer entry are checked before the drive's own
//     checks (06090032h / 06090031h);
//   - access: a device profile entry (6000h-9FFFh) listed ro that the drive lets write
//     aborts writes with 06010002h;
//   - defaults: profile_default_overrides below.
// Where the manual's entry contradicts the drive's CiA behaviour, the objects file says so in
// a comment and the profile lists the deviation.
#pragma once

#include <string>
#include <vector>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/personality.hpp"

namespace drivecheck::reference_drive {

// Adds the objects of `objects` that `od` lacks (above). Returns one line per listed entry that
// could not be added (a sub-index of an existing object, a definition the dictionary refuses);
// the other entries are added all the same.
std::vector<std::string> add_profile_objects(cia301::ObjectDictionary& od,
                                             const std::vector<profile::ObjectSpec>& objects);

// The listed defaults of the drive profile objects the drive has (6000h-9FFFh, writable, or
// the encoder resolutions 608Fh/6090h; integer `default:`) as default overrides: the drive takes
// the manual's value at each application reset while the entry holds the dictionary's default
// (stored parameters win). The option codes 6007h, 605Ah-605Eh (the personality's option_defaults),
// the factors 6091h-6097h (the personality's commissioning) and the IP buffer 60C4h (ip_submode)
// are left to the personality; the entries an added object gets are its defaults already.
// Communication objects (1000h-1FFFh) keep their defaults: the personality's pdo_defaults,
// heartbeat_time_ms, ... set them.
std::vector<DefaultOverride> profile_default_overrides(
    const std::vector<profile::ObjectSpec>& objects);

// The number of entries a PDO mapping record has (PdoObjectOptions::mapping_entries): the
// highest sub-index the objects list gives for 1600h-17FFh / 1A00h-1BFFh; 0: none listed.
std::uint8_t listed_mapping_entries(const std::vector<profile::ObjectSpec>& objects);

}  // namespace drivecheck::reference_drive
