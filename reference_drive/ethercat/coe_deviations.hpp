// The SDO service deviations of the reference drive (reference_drive/sdo_deviations.hpp, the
// same ones DeviationPort applies to CAN SDO frames) on the CoE SDO server: a CoeSdoHook that
// turns the server's decoded CoE messages into the transport-neutral view and back.
//   CoE request                           view
//   initiate download (not complete access) download (expedited: its 4 - n octets, or 4)
//   initiate upload (not complete access)   upload
//   download segment / upload segment req.  download_segment / upload_segment
//   abort                                   abort
//   not decodable (reserved command, ...)   invalid
//   complete access                         other (left alone)
//   CoE response                          view
//   abort                                   abort
//   initiate download response              download_confirmed
//   initiate upload response, e = 1, s = 1  expedited_upload
//   upload segment                          upload_segment (toggle)
// A replaced expedited download (the store signatures) becomes 4 octets, size indicated.
#pragma once

#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/ethercat/coe_sdo_server.hpp"
#include "reference_drive/sdo_deviations.hpp"

namespace drivecheck::reference_drive::ethercat {

class CoeDeviationHook final : public drivecheck::ethercat::CoeSdoHook {
 public:
  // `od` must outlive the hook.
  CoeDeviationHook(const cia301::ObjectDictionary& od, DeviationSet deviations)
      : od_(od), deviations_(deviations) {}

  // Whether any SDO service deviation is in the set (else the hook changes nothing).
  bool active() const { return deviations_.active(); }

  std::optional<drivecheck::ethercat::CoeSdoResponse> before(
      drivecheck::ethercat::CoeSdoRequest* request) override;
  std::optional<drivecheck::ethercat::CoeSdoResponse> after(
      const drivecheck::ethercat::CoeSdoRequest* request,
      drivecheck::ethercat::CoeSdoResponse response) override;

 private:
  const cia301::ObjectDictionary& od_;
  SdoDeviations deviations_;
};

}  // namespace drivecheck::reference_drive::ethercat
