#include "conformance/verdict.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <string>
#include <vector>

#include "conformance/isolation.hpp"

namespace drivecheck::conformance {

namespace {

// "" when the profile claims the feature or detected it (or could not tell); else why not.
std::string missing_feature(std::string_view feature, const profile::DriveProfile& profile,
                            const ApplicabilityContext& context) {
  if (profile.supports(feature)) {
    // A mode the drive has on one link only (the profile's modes_only_on).
    const auto only = profile.only_on(feature);
    const auto link =
        context.link == LinkKind::ethercat ? profile::Link::ethercat : profile::Link::can;
    if (!only || *only == link) return {};
    return fmt::format("requires {} (profile {} has it on {} only: modes_only_on)", feature,
                       profile.name, *only == profile::Link::ethercat ? "EtherCAT" : "CAN");
  }
  if (profile.detects(feature)) {
    if (context.capabilities == nullptr) return {};
    const Finding finding = context.capabilities->feature(feature);
    if (finding.presence != Presence::absent) return {};
    return fmt::format("requires {} (probed: absent, {})", feature, finding.how);
  }
  return fmt::format("requires {} (profile {} lacks it)", feature, profile.name);
}

}  // namespace

VectorResult result_for(const Vector& vector) {
  VectorResult result;
  result.id = vector.id;
  result.family = vector.family();
  result.title = vector.title;
  for (const auto& source : vector.sources)
    result.sources.push_back(source.text);
  result.level = vector.level;
  result.file = vector.file;
  result.line = vector.line;
  return result;
}

bool restores_factory_defaults(const Vector& vector, std::uint8_t node) {
  return vector.setup == Setup::restore_defaults || writes_restore_defaults(vector, node);
}

std::vector<profile::ObjectNeed> object_needs(const Vector& vector) {
  std::vector<profile::ObjectNeed> needs;
  for (const auto& feature : vector.requires_features)
    if (auto need = profile::parse_object_need(feature)) needs.push_back(*need);
  return needs;
}

std::string can_only_step(const Vector& vector) {
  const auto check = [](const std::vector<Step>& steps, const char* where) -> std::string {
    for (std::size_t i = 0; i < steps.size(); ++i) {
      const auto& action = steps[i].action;
      bool can = std::holds_alternative<SendStep>(action) ||
                 std::holds_alternative<NmtStep>(action) ||
                 std::holds_alternative<ExpectFrameStep>(action) ||
                 std::holds_alternative<ExpectSilenceStep>(action) ||
                 std::holds_alternative<ExpectBootupStep>(action) ||
                 std::holds_alternative<ExpectHeartbeatStep>(action) ||
                 std::holds_alternative<ExpectPeriodicStep>(action) ||
                 std::holds_alternative<BusOffStep>(action);
      if (const auto* m = std::get_if<MeasureStep>(&action); m != nullptr && !m->frames.empty())
        can = true;
      if (const auto* w = std::get_if<SdoWriteStep>(&action);
          w != nullptr && w->transfer == Transfer::block)
        can = true;
      if (const auto* r = std::get_if<SdoReadStep>(&action);
          r != nullptr && r->transfer == Transfer::block)
        can = true;
      if (can) return fmt::format("{} {} ({})", where, step_place(steps, i), action_name(action));
    }
    return {};
  };
  if (auto step = check(vector.steps, "steps:"); !step.empty()) return step;
  return check(vector.finally_steps, "finally:");
}

std::string not_applicable_reason(const Vector& vector, const profile::DriveProfile& profile,
                                  const ApplicabilityContext& context) {
  if (!vector.not_applicable.empty()) return vector.not_applicable;
  const std::string link(to_string(context.link));
  if (!vector.transports.empty() && std::find(vector.transports.begin(), vector.transports.end(),
                                              link) == vector.transports.end())
    return fmt::format("only on {} (transports:; this link: {})",
                       fmt::join(vector.transports, ", "), link);
  if (context.link != LinkKind::can) {
    if (auto step = can_only_step(vector); !step.empty())
      return fmt::format("needs the CAN link ({})", step);
  }
  if (context.link != LinkKind::ethercat) {
    if (auto step = vector.ethercat_only_step(); !step.empty())
      return fmt::format("needs the EtherCAT link ({})", step);
  }
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
  for (const auto& feature : vector.unless_features) {
    // A claim, or a detection that found it (one not probed or unknown leaves the vector on).
    if (profile.supports(feature))
      return fmt::format("profile {} claims {}: the vector for such a device judges it (unless:)",
                         profile.name, feature);
    if (profile.detects(feature) && context.capabilities != nullptr &&
        context.capabilities->feature(feature).presence == Presence::present)
      return fmt::format(
          "{} probed present ({}): the vector for such a device judges it "
          "(unless:)",
          feature, context.capabilities->feature(feature).how);
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
  if (!context.factory_restore_allowed && restores_factory_defaults(vector, context.node))
    return kFactoryRestoreNotAllowed;
  return {};
}

namespace {

// A documented text may name a node-relative COB-ID, "580+N#4B616000": the manual's frame
// from the DUT at whatever node-ID the run uses (1..127). Plain text is a substring.
bool text_observed(const std::string& documented, const std::string& actual) {
  const auto plus = documented.find("+N");
  if (plus == std::string::npos || plus < 3) return actual.find(documented) != std::string::npos;
  const std::string base_text = documented.substr(plus - 3, 3);
  unsigned base = 0;
  for (const char c : base_text) {
    if (!std::isxdigit(static_cast<unsigned char>(c)))
      return actual.find(documented) != std::string::npos;
    base = base * 16 +
           static_cast<unsigned>(std::isdigit(static_cast<unsigned char>(c))
                                     ? c - '0'
                                     : std::toupper(static_cast<unsigned char>(c)) - 'A' + 10);
  }
  const std::string before = documented.substr(0, plus - 3);
  const std::string after = documented.substr(plus + 2);
  for (unsigned node = 1; node <= 127; ++node) {
    if (actual.find(fmt::format("{}{:03X}{}", before, base + node, after)) != std::string::npos)
      return true;
  }
  return false;
}

}  // namespace

bool observation_matches(const profile::DeviationObservation& documented, const Check& check) {
  using Kind = profile::DeviationObservation::Kind;
  const Observation& seen = check.observed;
  switch (documented.kind) {
    case Kind::abort:
      return seen.abort == documented.abort;
    case Kind::value:
      if (documented.value_max)
        return seen.value && *seen.value >= documented.value &&
               *seen.value <= *documented.value_max;
      return seen.value == documented.value;
    case Kind::nothing:
      return seen.nothing;
    case Kind::accepted:
      return seen.accepted;
    case Kind::state: {
      const auto& pattern = cia402::pattern_of(documented.state);
      return seen.statusword && (*seen.statusword & pattern.mask) == pattern.value;
    }
    case Kind::statusword:
      return seen.statusword && (*seen.statusword & documented.mask) == documented.statusword;
    case Kind::text:
      return text_observed(documented.text, check.actual);
  }
  return false;
}

std::string describe(const Check& check) {
  const Observation& seen = check.observed;
  std::vector<std::string> parts;
  if (seen.abort) parts.push_back(fmt::format("abort {:08X}h", *seen.abort));
  if (seen.value) parts.push_back(fmt::format("value {}", *seen.value));
  if (seen.statusword)
    parts.push_back(fmt::format("statusword {:04X}h ({})", *seen.statusword,
                                cia402::describe_statusword(*seen.statusword)));
  if (seen.nothing) parts.push_back("nothing in time");
  if (seen.accepted) parts.push_back("the transfer accepted");
  if (parts.empty()) return fmt::format("\"{}\"", check.actual);
  return fmt::format("{}", fmt::join(parts, ", "));
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
  // A documented deviation covers the failure only when it lists the vector and the failing
  // check shows the observation its manual documents; anything else stays a failure.
  const auto failing = std::find_if(result.checks.begin(), result.checks.end(),
                                    [](const Check& c) { return !c.ok; });
  std::string near;
  for (const auto* deviation : profile.deviations_for(vector.id)) {
    const auto& documented = deviation->observed_for(*deviation->find(vector.id));
    const bool matches =
        failing != result.checks.end() &&
        std::any_of(documented.begin(), documented.end(), [&](const auto& observation) {
          return observation_matches(observation, *failing);
        });
    if (matches) {
      result.verdict = Verdict::deviation;
      result.deviation_id = deviation->id;
      result.deviation_source = fmt::format("{}", fmt::join(deviation->sources, "; "));
      result.message = fmt::format("{}\n{}", deviation->description, message);
      return;
    }
    std::vector<std::string> texts;
    for (const auto& observation : documented)
      texts.push_back(observation.describe());
    near += fmt::format(
        "\nnot the documented deviation {} ({}): it documents {}, the DUT showed {}", deviation->id,
        fmt::join(deviation->sources, "; "), fmt::join(texts, " or "),
        failing == result.checks.end() ? std::string("no failing check") : describe(*failing));
  }
  result.verdict = Verdict::fail;
  result.message = message + near;
  result.warning = vector.level != Level::must && !strict;
}

}  // namespace drivecheck::conformance
