#include "conformance/vector_lint.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <tuple>
#include <type_traits>
#include <variant>

#include "conformance/isolation.hpp"
#include "conformance/sha256.hpp"
#include "conformance/vector_file.hpp"
#include "protocol/cia301/object_requirements.hpp"
#include "protocol/cia402/object_requirements.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {
namespace {

int line_of(const YAML::Node& node) {
  return node.Mark().line < 0 ? 0 : node.Mark().line + 1;
}

// A deviation glob that names an OD check generated at run time from the profile's objects
// list (conformance/od_checks.hpp: eds/od/<index>-<sub>/<check>): it matches the id of a
// check some listed entry can get.
bool matches_od_check(const std::string& glob, const std::vector<profile::ObjectSpec>& objects) {
  static constexpr const char* kChecks[] = {"read",    "default",   "write-ro",
                                            "read-wo", "below-min", "above-max"};
  return std::any_of(objects.begin(), objects.end(), [&](const profile::ObjectSpec& o) {
    return std::any_of(std::begin(kChecks), std::end(kChecks), [&](const char* check) {
      return profile::glob_match(glob,
                                 fmt::format("eds/od/{:04x}-{:02x}/{}", o.index, o.sub, check));
    });
  });
}

// An object a step touches.
struct Touch {
  std::uint16_t index = 0;
  std::uint8_t sub = 0;
  std::size_t line = 0;
  std::string_view how;
};

bool expects_absence(const SdoExpect& expect) {
  if (expect.kind != SdoExpect::Kind::abort) return false;
  return std::any_of(expect.abort.codes.begin(), expect.abort.codes.end(),
                     [](std::uint32_t code) { return code == 0x06020000 || code == 0x06090011; });
}

std::vector<Touch> touches(const Vector& vector) {
  std::vector<Touch> found;
  for (const auto& step : vector.steps) {
    if (const auto* write = std::get_if<SdoWriteStep>(&step.action)) {
      // `expect: ok-or-abort` takes a refusal as an answer, "object does not exist" included:
      // the write needs no object (1029h set to its default where the device has one).
      if (!expects_absence(write->expect) && write->expect.kind != SdoExpect::Kind::ok_or_abort)
        found.push_back({write->index, write->sub, step.line, "sdo_write"});
    } else if (const auto* read = std::get_if<SdoReadStep>(&step.action)) {
      if (!expects_absence(read->expect))
        found.push_back({read->index, read->sub, step.line, "sdo_read"});
    } else if (const auto* poll = std::get_if<PollStep>(&step.action)) {
      found.push_back({poll->index, poll->sub, step.line, "poll"});
    } else if (const auto* cyclic = std::get_if<CyclicStep>(&step.action)) {
      for (const CyclicSetPoint& point : cyclic->set)
        found.push_back({point.index, point.sub, step.line, "cyclic set"});
    } else if (std::holds_alternative<ControlwordStep>(step.action)) {
      found.push_back({0x6040, 0, step.line, "controlword"});
    } else if (std::holds_alternative<ExpectStateStep>(step.action) ||
               std::holds_alternative<ExpectStatuswordStep>(step.action)) {
      found.push_back({0x6041, 0, step.line, "statusword poll"});
    } else if (const auto* send = frame_sent(step)) {
      // An SDO request to the DUT's default server (CiA 301 §7.2.4.3): initiate download
      // (ccs 1), initiate upload (ccs 2), block upload (ccs 5, cs 0), block download (ccs 6,
      // cs 0) carry the multiplexer in bytes 1..3.
      const auto& frame = send->frame;
      if (frame.remote || !frame.cob.plus_node || frame.cob.base != 0x600 || frame.bytes.size() < 4)
        continue;
      if (!frame.bytes[0] || !frame.bytes[1] || !frame.bytes[2] || !frame.bytes[3]) continue;
      const unsigned b0 = *frame.bytes[0];
      const unsigned ccs = b0 >> 5;
      const bool initiate =
          ccs == 1 || ccs == 2 || (ccs == 5 && (b0 & 0x03) == 0) || (ccs == 6 && (b0 & 0x01) == 0);
      if (!initiate) continue;
      found.push_back({static_cast<std::uint16_t>(*frame.bytes[1] | *frame.bytes[2] << 8),
                       *frame.bytes[3], step.line, "SDO request in send"});
    }
  }
  return found;
}

// An option.<object>.<value> feature claims that the option-code object takes the value, so the
// object is there (605Ah for option.quick-stop.6).
bool implied_by_option_feature(std::uint16_t index, const Vector& vector) {
  for (const auto& row : profile::option_code_table()) {
    if (row.index != index) continue;
    const std::string prefix = fmt::format("option.{}.", row.name);
    for (const auto& r : vector.requires_features)
      if (r.starts_with(prefix)) return true;
  }
  return false;
}

// Whether `requires` (with the vector's drive_state) satisfies one of the '|' alternatives.
bool condition_met(std::string_view condition, const Vector& vector) {
  const auto& required = vector.requires_features;
  const auto met = [&](std::string_view feature) {
    for (const auto& r : required) {
      if (r == feature) return true;
      // A sub-feature implies its family: pdo.dynamic-mapping -> pdo, emcy.history -> emcy.
      if (r.size() > feature.size() && std::string_view(r).starts_with(feature) &&
          r[feature.size()] == '.')
        return true;
      if (feature == "cia402" && (r.starts_with("mode.") || r.starts_with("homing.method.")))
        return true;
      if (feature == "mode.hm" && r.starts_with("homing.method.")) return true;
    }
    return feature == "cia402" && vector.drive_state.has_value();
  };
  while (!condition.empty()) {
    const auto bar = condition.find('|');
    if (met(condition.substr(0, bar))) return true;
    if (bar == std::string_view::npos) break;
    condition.remove_prefix(bar + 1);
  }
  return false;
}

bool is_sdo_response_cob(const CobIdSpec& cob) {
  if (cob.extended) return false;
  if (cob.plus_node) return cob.base == 0x580;
  return cob.base > 0x580 && cob.base <= 0x5FF;
}

// FORMAT.md "Isolation": a factory restore wipes a real drive's commissioning, so
// `setup: restore-defaults` is only for vectors about restore (they write 1011h themselves) or
// about the default values (the id says "default"); and clean-up belongs in `finally:`, which
// runs after a failed step too.
void lint_isolation(const Vector& vector, LintReport& report) {
  if (vector.setup == Setup::restore_defaults && !writes_restore_defaults(vector, 1) &&
      vector.id.find("default") == std::string::npos) {
    report.errors.push_back(
        {vector.file, static_cast<int>(vector.line),
         fmt::format("vector {}: setup: restore-defaults wipes a real drive's stored parameters; "
                     "the engine puts back what a vector writes (FORMAT.md \"Isolation\"): keep "
                     "it for vectors about restore (1011h) or default values only",
                     vector.id)});
  }
  for (const Step& step : vector.steps) {
    if (step.note.rfind("clean up", 0) == 0 || step.note.rfind("clean-up", 0) == 0) {
      report.warnings.push_back(
          {vector.file, static_cast<int>(step.line),
           fmt::format("vector {}: a clean-up step in steps: does not run after a failed step; "
                       "move it to finally:",
                       vector.id)});
    }
  }
}

// FORMAT.md "Repeated steps": a repeat of one pass says nothing a plain step list would not.
void lint_repeats(const Vector& vector, LintReport& report) {
  for (const auto* steps : {&vector.steps, &vector.finally_steps}) {
    for (const Step& step : *steps) {
      for (const StepRepeat& repeat : step.repeats) {
        if (repeat.times == 1 && repeat.iteration == 1) {
          report.warnings.push_back(
              {vector.file, static_cast<int>(repeat.line),
               fmt::format("vector {}: repeat: times: 1 repeats nothing; write its steps out",
                           vector.id)});
        }
      }
    }
  }
}

// The same finding at the same line once: a step in a `repeat:` is unrolled into one copy per
// pass, and each copy is checked like any step.
void drop_repeated_findings(std::vector<TextError>& findings) {
  std::set<std::tuple<std::string, int, std::string>> seen;
  std::erase_if(findings, [&](const TextError& finding) {
    return !seen.insert({finding.file, finding.line, finding.message}).second;
  });
}

// DESIGN.md "Safety on real drives": while a motion vector runs, the DUT consumes the harness
// heartbeat (1016h sub 1, written in the setup), so that a dead harness stops the drive. A
// reset inside the steps puts 1016h back to its stored value while the drive may still be
// enabled (reset communication leaves the application running), and nothing writes it again
// before the vector ends: a motion vector resets only in its setup.
void lint_dead_harness(const Vector& vector, LintReport& report) {
  if (!vector.motion) return;
  const auto is_reset = [](std::uint8_t command) {
    return command == static_cast<std::uint8_t>(cia301::NmtCommand::reset_node) ||
           command == static_cast<std::uint8_t>(cia301::NmtCommand::reset_communication);
  };
  for (const auto* steps : {&vector.steps, &vector.finally_steps}) {
    for (const Step& step : *steps) {
      bool reset = false;
      if (const auto* nmt = std::get_if<NmtStep>(&step.action)) {
        reset = is_reset(static_cast<std::uint8_t>(nmt->command));
      } else if (const auto* send = std::get_if<SendStep>(&step.action)) {
        const FrameSpec& frame = send->frame;
        reset = !frame.cob.extended && !frame.cob.plus_node && frame.cob.base == 0 &&
                !frame.bytes.empty() && frame.bytes[0] && is_reset(*frame.bytes[0]);
      }
      if (reset) {
        report.errors.push_back(
            {vector.file, static_cast<int>(step.line),
             fmt::format("vector {}: a motion vector must not reset the DUT in its steps: the "
                         "reset drops the harness heartbeat consumer (1016h) that stops the "
                         "drive when the harness dies (DESIGN.md \"Safety on real drives\"); "
                         "reset in the setup, or leave motion out of this vector",
                         vector.id)});
      }
    }
  }
}

// Each user directory's manual list (DIR/manuals.yaml, optional): loaded, its manuals read
// beside it with their sha256 checked, a file name the shipped list or an earlier user list
// has refused; the manuals are added to `manuals` for the citations.
void lint_user_manuals(const std::vector<std::filesystem::path>& user_dirs,
                       const std::filesystem::path& shipped_list, std::vector<ManualEntry>& manuals,
                       LintReport& report) {
  std::map<std::string, std::string> where;  // file -> list:line
  for (const auto& manual : manuals)
    where.emplace(manual.file, fmt::format("{}:{}", shipped_list.string(), manual.line));
  for (const auto& dir : user_dirs) {
    const auto list = dir / "manuals.yaml";
    std::error_code ec;
    if (!std::filesystem::exists(list, ec)) continue;
    auto loaded = load_manuals(list);
    if (!loaded) {
      for (auto& e : loaded.error())
        report.errors.push_back(std::move(e));
      continue;
    }
    for (auto& manual : *loaded) {
      const int line = static_cast<int>(manual.line);
      const auto [first, inserted] =
          where.emplace(manual.file, fmt::format("{}:{}", list.string(), line));
      if (!inserted) {
        report.errors.push_back(
            {list.string(), line,
             fmt::format("manual '{}' is already listed at {} (manual file names are unique "
                         "across the shipped list and every --vectors DIR)",
                         manual.file, first->second)});
        continue;
      }
      ++report.user_manuals;
      const auto digest = sha256_file(dir / manual.file);
      if (!digest) {
        report.errors.push_back(
            {list.string(), line,
             fmt::format("manual '{}' is not in {} (a user's manuals are kept beside their "
                         "manuals.yaml)",
                         manual.file, dir.string())});
      } else if (*digest != manual.sha256) {
        report.errors.push_back(
            {list.string(), line,
             fmt::format("manual '{}' has sha256 {}, {} says {}: the text changed, so line "
                         "citations may point elsewhere",
                         manual.file, *digest, list.string(), manual.sha256)});
      }
      manuals.push_back(std::move(manual));
    }
  }
}

}  // namespace

// The 1-based line of a profile's top-level `name:` key (1 when there is none).
int profile_name_line(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    if (text.rfind("name:", 0) == 0) return line;
  }
  return 1;
}

std::vector<TextError> check_object_needs(const Vector& vector) {
  std::vector<TextError> errors;
  std::set<std::pair<std::uint16_t, std::uint8_t>> reported;
  const auto needs = [&] {
    std::vector<profile::ObjectNeed> list;
    for (const auto& r : vector.requires_features)
      if (auto need = profile::parse_object_need(r)) list.push_back(*need);
    return list;
  }();
  for (const auto& touch : touches(vector)) {
    const auto row = touch.index >= 0x6000 && touch.index <= 0x67FF
                         ? cia402::find_object_requirement(touch.index, touch.sub)
                         : cia301::find_object_requirement(touch.index, touch.sub);
    if (!row || row->kind == cia301::ObjectClass::mandatory) continue;
    const bool declared = std::any_of(needs.begin(), needs.end(),
                                      [&](const auto& need) {
                                        if (need.index != touch.index) return false;
                                        if (need.sub) return *need.sub == touch.sub;
                                        return row->whole_object();
                                      }) ||
                          implied_by_option_feature(touch.index, vector);
    if (declared) continue;
    if (row->kind == cia301::ObjectClass::conditional && condition_met(row->condition, vector))
      continue;
    if (!reported.insert({touch.index, touch.sub}).second) continue;
    const std::string token = profile::object_need_feature(
        row->whole_object() ? profile::ObjectNeed{touch.index, std::nullopt}
                            : profile::ObjectNeed{touch.index, touch.sub});
    const std::string what =
        row->kind == cia301::ObjectClass::optional
            ? fmt::format("optional ({})", row->clause)
            : fmt::format("conditional on {} ({})", row->condition, row->clause);
    const std::string fix = row->kind == cia301::ObjectClass::optional
                                ? fmt::format("declare {} in requires", token)
                                : fmt::format("require {} or declare {}", row->condition, token);
    errors.push_back(
        {vector.file, static_cast<int>(touch.line),
         fmt::format("vector {}: {} touches {:04X}h sub {} ({}), which is {}: {}", vector.id,
                     touch.how, touch.index, touch.sub, row->name, what, fix)});
  }
  return errors;
}

std::string check_abort_expectation(const Step& step) {
  const auto literal = [](const AbortExpect& abort) {
    return abort.set.empty() && abort.clause.empty();
  };
  if (const auto* write = std::get_if<SdoWriteStep>(&step.action)) {
    if (write->expect.kind == SdoExpect::Kind::abort && literal(write->expect.abort))
      return "sdo_write expect: a literal list of abort codes needs clause: (the clause that "
             "gives exactly these codes); or name a set of sdo_abort_sets.inc";
  }
  if (const auto* read = std::get_if<SdoReadStep>(&step.action)) {
    if (read->expect.kind == SdoExpect::Kind::abort && literal(read->expect.abort))
      return "sdo_read expect: a literal list of abort codes needs clause: (the clause that "
             "gives exactly these codes); or name a set of sdo_abort_sets.inc";
  }
  if (const auto* frame = frame_expected(step)) {
    const std::string what(action_name(step.action));
    const auto fixed_code = [](const FrameSpec& pattern) {
      const auto& bytes = pattern.bytes;
      const bool abort_frame = is_sdo_response_cob(pattern.cob) && !pattern.remote &&
                               bytes.size() == 8 && bytes[0] && *bytes[0] == 0x80;
      return abort_frame && std::any_of(bytes.begin() + 4, bytes.end(),
                                        [](const auto& b) { return b.has_value(); });
    };
    if (!frame->abort && frame->clause.empty() && fixed_code(frame->pattern))
      return fmt::format(
          "{} '{}' is an SDO abort with a fixed code: give abort: <set> (with the "
          "code bytes as ..) or clause: naming the clause that gives exactly this code",
          what, frame->pattern.text);
    for (const auto& alternative : frame->alternatives) {
      if (frame->clause.empty() && fixed_code(alternative))
        return fmt::format(
            "{} or: '{}' is an SDO abort with a fixed code: make it "
            "the main pattern with abort: <set>, or give clause:",
            what, alternative.text);
    }
  }
  return {};
}

namespace {
std::string describe_duration(can::Duration d) {
  const auto us = std::chrono::duration_cast<std::chrono::microseconds>(d).count();
  if (us % 1000 != 0) return fmt::format("{}us", us);
  if (us % 1000000 != 0) return fmt::format("{}ms", us / 1000);
  return fmt::format("{}s", us / 1000000);
}
}  // namespace

std::vector<std::string> check_timing_bounds(const Vector& vector, const Step& step,
                                             const std::vector<ManualEntry>& manuals) {
  std::vector<std::string> messages;
  if (vector.level != Level::must) return messages;
  // The literal bounds of the step, by the key they are written under.
  std::vector<std::pair<std::string_view, const DurationSpec*>> bounds;
  const auto add = [&](std::string_view key, const DurationSpec& d) {
    if (!d.is_timing()) bounds.emplace_back(key, &d);
  };
  std::visit(
      [&](const auto& a) {
        using T = std::decay_t<decltype(a)>;
        if constexpr (std::is_same_v<T, ExpectFrameStep> || std::is_same_v<T, ExpectBootupStep> ||
                      std::is_same_v<T, ExpectEmcyStep> || std::is_same_v<T, ExpectStateStep> ||
                      std::is_same_v<T, ExpectStatuswordStep> || std::is_same_v<T, PollStep> ||
                      std::is_same_v<T, AlRequestStep> || std::is_same_v<T, ExpectAlStep>) {
          add("within", a.within);
        } else if constexpr (std::is_same_v<T, ExpectSdoResponseStep>) {
          add("within", a.expect.within);
        } else if constexpr (std::is_same_v<T, ExpectHeartbeatStep>) {
          if (a.within) add("within", *a.within);
        } else if constexpr (std::is_same_v<T, ExpectSilenceStep>) {
          add("for", a.duration);
        } else if constexpr (std::is_same_v<T, ExpectPeriodicStep>) {
          add("tolerance", a.tolerance);
        } else if constexpr (std::is_same_v<T, MeasureStep>) {
          if (a.min) add("min", *a.min);
          if (a.max) add("max", *a.max);
        }
      },
      step.action);
  if (bounds.empty()) return messages;
  const std::string action(action_name(step.action));
  if (step.clause.empty()) {
    for (const auto& [key, d] : bounds)
      messages.push_back(fmt::format(
          "{} {}: {} is a literal time bound in a must-level vector: give clause: (the CiA "
          "clause or manual line that gives it), or use a $timing key, or make the vector "
          "should (FORMAT.md \"Timing\")",
          action, key, describe_duration(d->value)));
    return messages;
  }
  if (auto problem = check_clause_citation(step.clause, manuals); !problem.empty())
    messages.push_back(fmt::format("{} clause: {}", action, problem));
  return messages;
}

std::string check_clause_citation(const std::string& clause,
                                  const std::vector<ManualEntry>& manuals) {
  // The clause begins with a citation: up to the first " (", ";" or ",".
  std::string head = clause;
  for (const char* stop : {" (", ";", ","}) {
    if (const auto at = head.find(stop); at != std::string::npos) head.resize(at);
  }
  auto citation = parse_source(head);
  if (!citation)
    return fmt::format("'{}' does not begin with a citation: {}", clause, citation.error());
  return check_citation(*citation, manuals);
}

// True when `citation` names `clause` ("CiA 301 §7.5.2.37") as a whole clause number: the
// next character is not a digit or a dot followed by one (§7.5.2.3 is not §7.5.2.37).
static bool cites_clause(std::string_view citation, std::string_view clause) {
  if (clause.empty()) return false;
  for (auto at = citation.find(clause); at != std::string_view::npos;
       at = citation.find(clause, at + 1)) {
    const auto end = at + clause.size();
    const bool digit_next =
        end < citation.size() && std::isdigit(static_cast<unsigned char>(citation[end]));
    const bool subclause_next = end + 1 < citation.size() && citation[end] == '.' &&
                                std::isdigit(static_cast<unsigned char>(citation[end + 1]));
    if (!digit_next && !subclause_next) return true;
  }
  return false;
}

std::vector<std::string> check_refusal_not_applicable(const Vector& vector, const Step& step,
                                                      bool in_finally,
                                                      const std::vector<ManualEntry>& manuals) {
  std::vector<std::string> messages;
  const auto* write = std::get_if<SdoWriteStep>(&step.action);
  if (write == nullptr || !write->refused_means_not_applicable) return messages;
  if (in_finally) {
    messages.push_back(
        "sdo_write refused_means_not_applicable: not in finally: (the verdict is decided by "
        "then; a clean-up write the DUT refuses is a harness note)");
    return messages;
  }
  if (step.clause.empty()) {
    messages.push_back(
        "sdo_write refused_means_not_applicable: give clause: citing where CiA (or the "
        "manual) lets the device refuse this value (an optional value, a reserved range)");
  } else if (auto problem = check_clause_citation(step.clause, manuals); !problem.empty()) {
    messages.push_back(fmt::format("sdo_write clause: {}", problem));
  }
  // A must-level vector that writes an object every device it applies to has: a refusal of it
  // would turn what may be a failure into not applicable. The value may still be optional
  // (a mode, an option code), but then a feature says so (mode.*, option.*), not a refusal.
  // Except where the object's own clause lets the device refuse the value with the codes of a
  // named set, and the set's citation names that clause (pdo-cob-id-fixed: CiA 301 §7.5.2.37
  // lets a TPDO's COB-ID support enabling and disabling only).
  if (vector.level == Level::must) {
    const auto row = write->index >= 0x6000 && write->index <= 0x67FF
                         ? cia402::find_object_requirement(write->index, write->sub)
                         : cia301::find_object_requirement(write->index, write->sub);
    const bool mandatory =
        row &&
        (row->kind == cia301::ObjectClass::mandatory ||
         (row->kind == cia301::ObjectClass::conditional && condition_met(row->condition, vector)));
    const auto& refusal = *write->refused_means_not_applicable;
    if (mandatory && !(!refusal.set.empty() && cites_clause(refusal.citation, row->clause)))
      messages.push_back(fmt::format(
          "sdo_write refused_means_not_applicable: {:04X}h sub {} ({}) is mandatory here ({}): "
          "in a must-level vector a refusal of it must not make the vector not applicable; "
          "require the feature that makes the value optional (mode.*, option.*), or make the "
          "vector should",
          write->index, write->sub, row->name,
          row->kind == cia301::ObjectClass::mandatory
              ? row->clause
              : fmt::format("{}, {}", row->condition, row->clause)));
  }
  return messages;
}

Expected<std::vector<ManualEntry>, std::vector<TextError>> load_manuals(
    const std::filesystem::path& path) {
  const std::string file = path.string();
  std::vector<TextError> errors;
  std::vector<ManualEntry> manuals;
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    return Unexpected(std::vector<TextError>{{file, 0, "cannot read the manual list"}});
  } catch (const YAML::Exception& e) {
    return Unexpected(std::vector<TextError>{{file, e.mark.line + 1, e.msg}});
  }
  if (!root.IsSequence()) {
    return Unexpected(std::vector<TextError>{
        {file, line_of(root), "expected a list of {file, device, sha256, lines}"}});
  }
  std::set<std::string> seen;
  for (const auto& node : root) {
    ManualEntry entry;
    entry.line = static_cast<std::size_t>(line_of(node));
    if (!node.IsMap()) {
      errors.push_back(
          {file, line_of(node), "a manual entry is a map {file, device, sha256, lines}"});
      continue;
    }
    bool ok = true;
    for (const auto& kv : node) {
      const auto key = kv.first.Scalar();
      if (key != "file" && key != "device" && key != "sha256" && key != "lines" && key != "title" &&
          key != "edition") {
        errors.push_back({file, line_of(kv.first),
                          fmt::format("unknown key '{}' (allowed: file, device, sha256, lines, "
                                      "title, edition)",
                                      key)});
        ok = false;
      } else if (!kv.second.IsScalar()) {
        errors.push_back(
            {file, line_of(kv.second), fmt::format("{}: expected a single value", key)});
        ok = false;
      }
    }
    for (const char* key : {"file", "device", "sha256", "lines"}) {
      if (!node[key]) {
        errors.push_back({file, line_of(node), fmt::format("manual entry: '{}' is missing", key)});
        ok = false;
      }
    }
    if (!ok) continue;
    entry.file = node["file"].Scalar();
    entry.device = node["device"].Scalar();
    if (node["title"]) entry.title = node["title"].Scalar();
    if (node["edition"]) entry.edition = node["edition"].Scalar();
    entry.sha256 = node["sha256"].Scalar();
    const auto& lines = node["lines"].Scalar();
    if (entry.sha256.size() != 64 ||
        !std::all_of(entry.sha256.begin(), entry.sha256.end(),
                     [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); })) {
      errors.push_back(
          {file, line_of(node["sha256"]), "sha256: expected 64 lower-case hex digits"});
      continue;
    }
    try {
      std::size_t used = 0;
      entry.lines = std::stoul(lines, &used);
      if (used != lines.size() || entry.lines == 0) throw std::invalid_argument(lines);
    } catch (const std::exception&) {
      errors.push_back({file, line_of(node["lines"]),
                        fmt::format("lines: '{}' is not a positive integer", lines)});
      continue;
    }
    if (!seen.insert(entry.file).second) {
      errors.push_back(
          {file, line_of(node), fmt::format("manual '{}' is listed twice", entry.file)});
      continue;
    }
    manuals.push_back(std::move(entry));
  }
  if (!errors.empty()) return Unexpected(std::move(errors));
  return manuals;
}

std::string check_citation(const Source& source, const std::vector<ManualEntry>& manuals) {
  if (source.manual.empty()) return {};
  const auto it = std::find_if(manuals.begin(), manuals.end(),
                               [&](const ManualEntry& m) { return m.file == source.manual; });
  if (it == manuals.end())
    return fmt::format("source '{}': manual '{}' is not listed in manuals.yaml", source.text,
                       source.manual);
  if (source.last > it->lines)
    return fmt::format("source '{}': line {} is past the end of {} ({} lines)", source.text,
                       source.last, source.manual, it->lines);
  return {};
}

LintReport lint_vector_tree(const LintOptions& options) {
  LintReport report;
  std::vector<std::filesystem::path> roots{options.dir};
  roots.insert(roots.end(), options.user_dirs.begin(), options.user_dirs.end());
  auto set = load_vector_trees(roots);
  report.files = set.files.size();
  report.errors = std::move(set.errors);

  // Manuals.
  const auto manuals_path = options.dir / "manuals.yaml";
  std::vector<ManualEntry> manuals;
  auto loaded = load_manuals(manuals_path);
  if (!loaded) {
    for (auto& e : loaded.error())
      report.errors.push_back(std::move(e));
  } else {
    manuals = std::move(*loaded);
    if (options.manuals_dir) {
      report.manuals_checked = true;
      for (const auto& manual : manuals) {
        const auto digest = sha256_file(*options.manuals_dir / manual.file);
        if (!digest) {
          report.errors.push_back({manuals_path.string(), static_cast<int>(manual.line),
                                   fmt::format("manual '{}' is not in {}", manual.file,
                                               options.manuals_dir->string())});
        } else if (*digest != manual.sha256) {
          report.errors.push_back(
              {manuals_path.string(), static_cast<int>(manual.line),
               fmt::format("manual '{}' has sha256 {}, manuals.yaml says {}: the text changed, "
                           "so line citations may point elsewhere",
                           manual.file, *digest, manual.sha256)});
        }
      }
    }
  }
  lint_user_manuals(options.user_dirs, manuals_path, manuals, report);
  for (const auto& vector : set.vectors) {
    for (auto& error : check_object_needs(vector))
      report.errors.push_back(std::move(error));
    for (const auto& source : vector.sources) {
      if (auto message = check_citation(source, manuals); !message.empty() && loaded)
        report.errors.push_back({vector.file, static_cast<int>(source.line), message});
    }
    // Accepted abort codes: a named set, or a literal list with the clause that gives exactly
    // those codes; a raw SDO abort frame with a fixed code likewise.
    for (const auto& step : vector.steps) {
      if (auto message = check_abort_expectation(step); !message.empty())
        report.errors.push_back({vector.file, static_cast<int>(step.line),
                                 fmt::format("vector {}: {}", vector.id, message)});
      // Every must-level literal time bound carries its clause (FORMAT.md "Timing").
      for (auto& message : check_timing_bounds(vector, step, manuals))
        report.errors.push_back({vector.file, static_cast<int>(step.line),
                                 fmt::format("vector {}: {}", vector.id, message)});
    }
    // A refusal that means not applicable: cited, not in finally:, not of a mandatory object
    // at must level (FORMAT.md "Values the device may refuse").
    for (const auto* steps : {&vector.steps, &vector.finally_steps}) {
      for (const auto& step : *steps) {
        for (auto& message :
             check_refusal_not_applicable(vector, step, steps == &vector.finally_steps, manuals))
          report.errors.push_back({vector.file, static_cast<int>(step.line),
                                   fmt::format("vector {}: {}", vector.id, message)});
      }
    }
    // A bus_off step as long as the whole vector leaves no time to see the drive's reaction.
    for (const auto* steps : {&vector.steps, &vector.finally_steps}) {
      for (const auto& step : *steps) {
        const auto* bus_off = std::get_if<BusOffStep>(&step.action);
        if (bus_off != nullptr && !bus_off->duration.is_timing() && !vector.timeout.is_timing() &&
            bus_off->duration.value >= vector.timeout.value) {
          report.errors.push_back(
              {vector.file, static_cast<int>(step.line),
               "bus_off: the duration is not shorter than the vector's timeout"});
        }
      }
    }
    // An EtherCAT-only step (FORMAT.md "EtherCAT steps") in a vector limited to other links.
    if (auto step = vector.ethercat_only_step();
        !step.empty() && !vector.transports.empty() &&
        std::find(vector.transports.begin(), vector.transports.end(), "ethercat") ==
            vector.transports.end()) {
      report.errors.push_back(
          {vector.file, static_cast<int>(vector.line),
           fmt::format("vector {}: {} needs EtherCAT, but transports: lists only {}", vector.id,
                       step, fmt::join(vector.transports, ", "))});
    }
    lint_isolation(vector, report);
    lint_dead_harness(vector, report);
    lint_repeats(vector, report);
  }

  // Drive profiles: the tree's, then each user directory's.
  std::set<std::string> profile_names;
  std::map<std::string, std::string> profile_where;  // name -> file:line of its name
  std::vector<std::string> drives_dirs;
  for (const auto& root : roots) {
    const auto drives = root / "drives";
    drives_dirs.push_back(drives.string());
    std::error_code ec;
    if (!std::filesystem::is_directory(drives, ec)) continue;
    for (const auto& name : profile::list_profiles(drives)) {
      ++report.profiles;
      const auto path = drives / (name + ".yaml");
      const int line = profile_name_line(path);
      const auto [first, inserted] =
          profile_where.emplace(name, fmt::format("{}:{}", path.string(), line));
      if (!inserted) {
        report.errors.push_back(
            {path.string(), line,
             fmt::format("profile '{}' is already defined at {} (profile names are unique across "
                         "the shipped profiles and every --vectors DIR)",
                         name, first->second)});
        continue;
      }
      auto drive = profile::load_profile(path);
      if (!drive) {
        report.errors.push_back(drive.error());
        continue;
      }
      profile_names.insert(drive->name);
      const auto where = path.string();
      for (const auto& deviation : drive->deviations) {
        for (const auto& text : deviation.sources) {
          auto source = parse_source(text);
          if (!source) {
            report.errors.push_back(
                {where, 0, fmt::format("deviation {}: {}", deviation.id, source.error())});
          } else if (auto message = check_citation(*source, manuals); !message.empty() && loaded) {
            report.errors.push_back(
                {where, 0, fmt::format("deviation {}: {}", deviation.id, message)});
          }
        }
        if (deviation.vectors.empty())
          report.warnings.push_back(
              {where, deviation.line,
               fmt::format("deviation {}: covers no vector (documentation only: no failure "
                           "is ever judged a deviation by it)",
                           deviation.id)});
        // Exact ids (the loader refuses globs): each must be a vector of the tree or a
        // generated object check of the profile's objects.
        for (const auto& entry : deviation.vectors) {
          const bool known = std::any_of(set.vectors.begin(), set.vectors.end(),
                                         [&](const Vector& v) { return v.id == entry.id; }) ||
                             matches_od_check(entry.id, drive->objects);
          if (!known)
            report.errors.push_back(
                {where, deviation.line,
                 fmt::format("deviation {}: no vector '{}' (a deviation names exact vector ids)",
                             deviation.id, entry.id)});
        }
      }
      // Commissioning: sources cite listed manuals, globs match vectors, and a write to an
      // object the profile lists read-only can never succeed.
      const profile::Commissioning& commissioning = drive->commissioning;
      for (const auto& w : commissioning.writes) {
        const std::string what = fmt::format("commissioning {:04X}h sub {}", w.index, w.sub);
        for (const auto& text : w.sources) {
          auto source = parse_source(text);
          if (!source) {
            report.errors.push_back({where, 0, fmt::format("{}: {}", what, source.error())});
          } else if (auto message = check_citation(*source, manuals); !message.empty() && loaded) {
            report.errors.push_back({where, 0, fmt::format("{}: {}", what, message)});
          }
        }
        const auto listed =
            std::find_if(drive->objects.begin(), drive->objects.end(),
                         [&](const auto& o) { return o.index == w.index && o.sub == w.sub; });
        if (listed != drive->objects.end() && (listed->access == cia301::AccessType::ro ||
                                               listed->access == cia301::AccessType::constant)) {
          report.errors.push_back(
              {where, 0, fmt::format("{}: the profile's objects list it read-only", what)});
        }
      }
      for (const auto* globs : {&commissioning.vectors, &commissioning.except}) {
        for (const auto& glob : *globs) {
          const bool used =
              std::any_of(set.vectors.begin(), set.vectors.end(),
                          [&](const Vector& v) { return profile::glob_match(glob, v.id); });
          if (!used)
            report.warnings.push_back(
                {where, 0, fmt::format("commissioning: glob '{}' matches no vector", glob)});
        }
      }
    }
  }
  for (const auto& vector : set.vectors) {
    for (const auto& name : vector.profiles) {
      if (profile_names.count(name) == 0)
        report.errors.push_back({vector.file, static_cast<int>(vector.line),
                                 fmt::format("vector {}: profiles: no drive profile '{}' in {}",
                                             vector.id, name, fmt::join(drives_dirs, ", "))});
    }
  }
  drop_repeated_findings(report.errors);
  drop_repeated_findings(report.warnings);
  report.vectors = std::move(set.vectors);
  return report;
}

}  // namespace drivecheck::conformance
