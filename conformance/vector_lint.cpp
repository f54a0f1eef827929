#include "conformance/vector_lint.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <set>

#include "conformance/isolation.hpp"
#include "conformance/sha256.hpp"
#include "conformance/vector_file.hpp"
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

}  // namespace

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
      if (key != "file" && key != "device" && key != "sha256" && key != "lines") {
        errors.push_back(
            {file, line_of(kv.first),
             fmt::format("unknown key '{}' (allowed: file, device, sha256, lines)", key)});
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
  auto set = load_vector_tree(options.dir);
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
  for (const auto& vector : set.vectors) {
    for (const auto& source : vector.sources) {
      if (auto message = check_citation(source, manuals); !message.empty() && loaded)
        report.errors.push_back({vector.file, static_cast<int>(source.line), message});
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
    lint_isolation(vector, report);
  }

  // Drive profiles.
  std::set<std::string> profile_names;
  const auto drives = options.dir / "drives";
  std::error_code ec;
  if (std::filesystem::is_directory(drives, ec)) {
    for (const auto& name : profile::list_profiles(drives)) {
      ++report.profiles;
      const auto path = drives / (name + ".yaml");
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
        for (const auto& glob : deviation.vectors) {
          const bool used =
              std::any_of(set.vectors.begin(), set.vectors.end(),
                          [&](const Vector& v) { return profile::glob_match(glob, v.id); }) ||
              matches_od_check(glob, drive->objects);
          if (!used)
            report.warnings.push_back(
                {where, 0,
                 fmt::format("deviation {}: glob '{}' matches no vector", deviation.id, glob)});
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
                                             vector.id, name, drives.string())});
    }
  }
  report.vectors = std::move(set.vectors);
  return report;
}

}  // namespace drivecheck::conformance
