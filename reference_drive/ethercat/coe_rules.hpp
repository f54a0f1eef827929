// The drive's own CoE rules (the profile's `coe:` section, profile::CoeRules) on the CoE SDO
// server: a CoeSdoHook in front of the SDO service deviations (coe_deviations.hpp), so a named
// deviation still acts on what the personality's server answers.
//
//   absent_objects   an initiate (upload or download, complete access too) of such an index is
//                    aborted 06020000h "object does not exist in the object dictionary" (CiA 301
//                    §7.2.4.3.17; Festo 000 L781), e.g. Festo's 1008h-100Ah (000 §4.6.3
//                    L2029-2036, L1826); the same objects stay on CAN
//   max_sdo_size     a download initiate announcing more octets is aborted 06070012h "length of
//                    service parameter too high" (CiA 301; Festo 000 L787); an upload whose
//                    value (complete access: whose layout) is longer is aborted 06010000h
//                    "unsupported access to an object" (CiA 301; Festo 000 L778): Festo's CoE
//                    carries only transfers of up to 4 octets (000 §4.8 L2133-2135, L2150-2157)
//                    and its manual names no abort for more, so these are CiA 301's codes for
//                    "too long to write" and "this access is not supported", both in Festo's
//                    own abort table (000 §3.2.2 L773-798)
// The server is reset whenever the hook aborts a transfer it did not see (the request replaces
// a transfer in progress, as a new initiate does) or one it began (an upload too long).
// 1C12h/1C13h and the PDO configuration states are the dictionary's rules
// (coe_objects.hpp install_coe_object_rules), not this hook's.
#pragma once

#include <functional>
#include <optional>

#include "protocol/ethercat/coe_sdo_server.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::reference_drive::ethercat {

class CoeRulesHook final : public drivecheck::ethercat::CoeSdoHook {
 public:
  // `inner` (may be nullptr) sees each request after this hook lets it through and each
  // response after this hook; it must outlive the hook. `reset_server` forgets the server's
  // transfer in progress.
  CoeRulesHook(profile::CoeRules rules, drivecheck::ethercat::CoeSdoHook* inner,
               std::function<void()> reset_server)
      : rules_(std::move(rules)), inner_(inner), reset_server_(std::move(reset_server)) {}

  // Whether the rules change anything (else the hook need not be installed).
  bool active() const { return rules_.max_sdo_size.has_value() || !rules_.absent_objects.empty(); }

  std::optional<drivecheck::ethercat::CoeSdoResponse> before(
      drivecheck::ethercat::CoeSdoRequest* request) override;
  std::optional<drivecheck::ethercat::CoeSdoResponse> after(
      const drivecheck::ethercat::CoeSdoRequest* request,
      drivecheck::ethercat::CoeSdoResponse response) override;

 private:
  profile::CoeRules rules_;
  drivecheck::ethercat::CoeSdoHook* inner_;
  std::function<void()> reset_server_;
};

}  // namespace drivecheck::reference_drive::ethercat
