// The DUT port on CAN: CiA 301 SDO (SdoClientTransfer) driven by the vector's own receive loop
// (VectorRun::pump/send), so that every frame of a transfer is evidence with its wire time.
#pragma once

#include "conformance/dut_port.hpp"

namespace drivecheck::conformance {

class CanPort final : public DutPort {
 public:
  LinkKind link() const override { return LinkKind::can; }
  SdoOutcome upload(VectorRun& run, const SdoRequest& request) override;
  SdoOutcome download(VectorRun& run, const SdoRequest& request,
                      std::span<const std::uint8_t> data) override;
};

}  // namespace drivecheck::conformance
