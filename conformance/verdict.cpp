#include "conformance/verdict.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivecheck::conformance {

std::string not_applicable_reason(const Vector& vector, const profile::DriveProfile& profile,
                                  const ApplicabilityContext& context) {
  if (!vector.profiles.empty() && std::find(vector.profiles.begin(), vector.profiles.end(),
                                            profile.name) == vector.profiles.end()) {
    return fmt::format("only for profile {} (selected: {})", fmt::join(vector.profiles, ", "),
                       profile.name);
  }
  for (const auto& feature : vector.requires_features) {
    if (feature == "simulation") {
      if (!context.simulation) return "requires simulation (only the embedded drive has it)";
    } else if (feature == "motion") {
      if (!context.motion_allowed) return "moves the motor: needs --allow-motion on a real bus";
    } else if (!profile.supports(feature)) {
      return fmt::format("requires {} (profile {} lacks it)", feature, profile.name);
    }
  }
  if (vector.has_bus_off_step() && !context.bus_off)
    return "the bus_off step needs the DUT's CAN controller on the simulated bus (embedded drive)";
  if (vector.drive_state && !profile.supports("cia402"))
    return fmt::format("drive_state needs cia402 (profile {} lacks it)", profile.name);
  if (vector.setup == Setup::restore_defaults && !profile.supports("restore"))
    return fmt::format("setup restore-defaults needs restore (profile {} lacks it)", profile.name);
  return {};
}

void decide_verdict(VectorResult& result, const Vector& vector,
                    const profile::DriveProfile& profile, Outcome outcome,
                    const std::string& message, bool strict) {
  result.warning = false;
  result.deviation_id.clear();
  result.deviation_source.clear();
  switch (outcome) {
    case Outcome::pass:
      result.verdict = Verdict::pass;
      result.message.clear();
      return;
    case Outcome::harness_error:
      result.verdict = Verdict::error;
      result.message = message;
      return;
    case Outcome::fail:
      break;
  }
  if (const auto* deviation = profile.deviation_for(vector.id)) {
    result.verdict = Verdict::deviation;
    result.deviation_id = deviation->id;
    result.deviation_source = fmt::format("{}", fmt::join(deviation->sources, "; "));
    result.message = fmt::format("{}\n{}", deviation->description, message);
    return;
  }
  result.verdict = Verdict::fail;
  result.message = message;
  result.warning = vector.level != Level::must && !strict;
}

}  // namespace drivecheck::conformance
