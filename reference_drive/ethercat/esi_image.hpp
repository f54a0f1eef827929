// The ESI (ETG.2000 EtherCAT Slave Information, XML) of the reference drive as an EtherCAT
// slave, generated from its object dictionary and SII as generate_eds.cpp generates the EDS for
// CAN: one source, never written by hand. reference_drive/ethercat/reference_drive.xml is the
// output of reference_drive_esi (generate_esi.cpp) for the standard drive, checked byte for byte
// by ethercat_drive_tests.
//
//   Vendor/Id, Type@ProductCode/@RevisionNo   1018h:01..03 (= the SII header, sii_image.hpp)
//   Type, Name, GroupType                     the SII's strings
//   Profile/Dictionary                        every object of the dictionary, in index order:
//     a VAR as Object (Type, BitSize, Flags/Access, DefaultData); an ARRAY or RECORD as a
//     DataType DT<index> with one SubItem per sub-index (SubIdx, Type, BitSize, BitOffs,
//     Flags/Access) and Object/Info/SubItem (Name, DefaultData). DefaultData (hexBinary, little
//     endian) only for what a reset gives back: integer entries of 1..8 octets that are const,
//     writable (rw/rwr/rww) or sub 0 of an ARRAY/RECORD; read-only process values (6041h, 1001h,
//     1018h:04 the serial number) get none. Access: ro (ro, const), rw (rw, rwr, rww), wo.
//   Sm                                        SM0..3 as the SII has them
//   RxPdo/TxPdo                               every mapping object 1600h+/1A00h+ with its
//     default entries; @Sm on those 1C12h/1C13h assign by default
//   Mailbox/CoE                               SdoInfo, PdoAssign, PdoConfig, CompleteAccess as
//     the SII's CoE details
#pragma once

#include <string>

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"
#include "protocol/ethercat/sii.hpp"

namespace drivecheck::reference_drive::ethercat {

// The ESI text of a drive with dictionary `od` (as after create: power-on values) and SII
// image `sii`.
Expected<std::string, std::string> drive_esi_text(const cia301::ObjectDictionary& od,
                                                  const drivecheck::ethercat::SiiImage& sii);

// The standard EthercatDrive's ESI (no personality, no deviation): reference_drive.xml.
Expected<std::string, std::string> standard_drive_esi_text();

}  // namespace drivecheck::reference_drive::ethercat
