#include "conformance/verdict.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivecheck::conformance {

namespace {

// "" when the profile claims the feature or detected it (or could not tell); else why not.
std::string missing_feature(std::string_view feature, const profile::DriveProfile& profile,
                            const ApplicabilityContext& context) {
  if (profile.supports(feature)) return {};
  if (profile.detects(feature)) {
    if (context.capabilities == nullptr) return {};
    const Finding finding = context.capabilities->feature(feature);
    if (finding.presence != Presence::absent) return {};
    return fmt::format("requires {} (probed: absent, {})", feature, finding.how);
  }
  return fmt::format("requires {} (profile {} lacks it)", feature, profile.name);
}

}  // namespace

std::vector<profile::ObjectNeed> object_needs(const Vector& vector) {
  std::vector<profile::ObjectNeed> needs;
  for (const auto& feature : vector.requires_features)
    if (auto need = profile::parse_object_need(feature)) needs.push_back(*need);
  return needs;
}

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
    } else if (const auto need = profile::parse_object_need(feature)) {
      if (context.capabilities == nullptr) continue;
      const Finding finding = context.capabilities->object(*need);
      if (finding.presence == Presence::absent)
        return fmt::format("needs object {}: absent ({})", profile::describe(*need), finding.how);
    } else if (auto missing = missing_feature(feature, profile, context); !missing.empty()) {
      return missing;
    }
  }
  if (vector.has_bus_off_step() && !context.bus_off)
    return "the bus_off step needs the DUT's CAN controller on the simulated bus (embedded drive)";
  if (vector.drive_state) {
    if (auto missing = missing_feature("cia402", profile, context); !missing.empty())
      return "drive_state: " + missing;
  }
  if (vector.setup == Setup::restore_defaults) {
    if (auto missing = missing_feature("restore", profile, context); !missing.empty())
      return "setup restore-defaults: " + missing;
  }
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
