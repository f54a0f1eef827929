// Whether a vector applies to the selected drive, and how the outcome of its steps becomes a
// verdict (vectors/FORMAT.md "Verdicts"). Pure functions: the engine calls them, tests call
// them directly.
#pragma once

#include <string>

#include "conformance/result.hpp"
#include "conformance/vector.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace drivecheck::conformance {

struct ApplicabilityContext {
  bool simulation = false;      // a SimulationControl is present (embedded drive)
  bool motion_allowed = false;  // simulated bus, or --allow-motion on a real bus
  bool bus_off = false;         // the DUT's controller can be put bus-off (simulated bus)
};

// "" when the vector applies; else the reason it is not applicable, e.g.
// "requires mode.hm (the profile lacks it)", "only for profiles festo-cmmp".
std::string not_applicable_reason(const Vector& vector, const profile::DriveProfile& profile,
                                  const ApplicabilityContext& context);

// What running the steps gave.
enum class Outcome : std::uint8_t { pass, fail, harness_error };

// Whether the failing check shows the observation a deviation documents (abort code, value,
// nothing, accepted, state or statusword from Check::observed; text from its Actual).
bool observation_matches(const profile::DeviationObservation& documented, const Check& check);
// The failing check's observation in words: "abort 06090030h", "value -1000", "nothing in
// time", or its Actual quoted when it has no typed observation.
std::string describe(const Check& check);

// Sets verdict, message, deviation and warning of `result` from the outcome:
//   pass → pass; harness_error → error (message as given);
//   fail → deviation when a profile deviation lists the vector id and the first failing check
//          of result.checks shows the observation it documents (message: its description,
//          deviation_id/source set; the failure's Expected/Actual kept after it); else fail,
//          and each deviation that listed the id but documents another observation is named in
//          the message with what it documents and what the DUT showed; a should/may fail (not
//          a deviation) is a warning unless `strict`.
void decide_verdict(VectorResult& result, const Vector& vector,
                    const profile::DriveProfile& profile, Outcome outcome,
                    const std::string& message, bool strict);

}  // namespace drivecheck::conformance
