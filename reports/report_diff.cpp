// diff_reports and `drivecheck report diff`: what changed between two runs, regressions first.
#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "reports/report_writers.hpp"

namespace drivecheck::reports {
namespace {

using conformance::RunResult;
using conformance::VectorResult;
using conformance::Verdict;

// Fails as every output counts it (conformance::VerdictCounts, and the exit code): a required
// failure or a harness error.
bool fails(const VectorResult& vector) {
  const auto tally = conformance::tally_of(vector.verdict, vector.warning);
  return tally == conformance::Tally::fail || tally == conformance::Tally::error;
}

std::string verdict_text(const std::optional<Verdict>& verdict, bool warning) {
  if (!verdict) return "(absent)";
  return std::string(to_string(*verdict)) + (warning ? "+warning" : "");
}

}  // namespace

std::string_view to_string(ChangeKind kind) {
  switch (kind) {
    case ChangeKind::new_failure:
      return "new failure";
    case ChangeKind::fixed:
      return "fixed";
    case ChangeKind::verdict_changed:
      return "changed";
    case ChangeKind::added:
      return "added";
    case ChangeKind::removed:
      return "removed";
  }
  return "?";
}

std::vector<ReportChange> diff_reports(const RunResult& before, const RunResult& after) {
  // A repeated id (a broken report) compares its last occurrence.
  std::map<std::string_view, const VectorResult*> old_vectors;
  for (const auto& vector : before.vectors)
    old_vectors[vector.id] = &vector;
  std::map<std::string_view, const VectorResult*> new_vectors;
  for (const auto& vector : after.vectors)
    new_vectors[vector.id] = &vector;

  std::vector<ReportChange> changes;
  for (const auto& [id, now] : new_vectors) {
    ReportChange change;
    change.id = std::string(id);
    change.after = now->verdict;
    change.warning_after = now->warning;
    change.message = now->message;
    const auto it = old_vectors.find(id);
    if (it == old_vectors.end()) {
      change.kind = fails(*now) ? ChangeKind::new_failure : ChangeKind::added;
      changes.push_back(std::move(change));
      continue;
    }
    const VectorResult& was = *it->second;
    change.before = was.verdict;
    change.warning_before = was.warning;
    if (fails(*now) && !fails(was)) {
      change.kind = ChangeKind::new_failure;
    } else if (fails(was) && !fails(*now) && now->verdict != Verdict::interrupted) {
      // An interrupted vector has no verdict: it did not get fixed (a verdict change).
      change.kind = ChangeKind::fixed;
    } else if (was.verdict != now->verdict || was.warning != now->warning) {
      change.kind = ChangeKind::verdict_changed;
    } else {
      continue;
    }
    changes.push_back(std::move(change));
  }
  for (const auto& [id, was] : old_vectors) {
    if (new_vectors.count(id) != 0) continue;
    ReportChange change;
    change.kind = ChangeKind::removed;
    change.id = std::string(id);
    change.before = was->verdict;
    change.warning_before = was->warning;
    change.message = was->message;
    changes.push_back(std::move(change));
  }
  // Kinds in enum order (new failures first); the maps already gave id order within a kind.
  std::stable_sort(changes.begin(), changes.end(),
                   [](const ReportChange& a, const ReportChange& b) { return a.kind < b.kind; });
  return changes;
}

std::string format_diff(const std::vector<ReportChange>& changes) {
  std::string out;
  std::array<std::size_t, 5> per_kind{};
  for (const auto& change : changes) {
    ++per_kind[static_cast<std::size_t>(change.kind)];
    out += fmt::format("{:<12} {}  {} -> {}", to_string(change.kind), printable_text(change.id),
                       verdict_text(change.before, change.warning_before),
                       verdict_text(change.after, change.warning_after));
    const std::string_view line = first_line(change.message);
    if (!line.empty() &&
        (change.kind == ChangeKind::new_failure || change.kind == ChangeKind::verdict_changed)) {
      out += ": " + printable_text(line);
    }
    out += '\n';
  }
  out += fmt::format("{} new failures, {} fixed, {} changed, {} added, {} removed\n", per_kind[0],
                     per_kind[1], per_kind[2], per_kind[3], per_kind[4]);
  return out;
}

int report_diff_command(const std::filesystem::path& before, const std::filesystem::path& after,
                        std::FILE* out, std::FILE* err) {
  const auto a = read_json_report(before);
  if (!a) {
    fmt::print(err, "{}\n", printable_text(a.error().to_string()));
    return 2;
  }
  const auto b = read_json_report(after);
  if (!b) {
    fmt::print(err, "{}\n", printable_text(b.error().to_string()));
    return 2;
  }
  const auto changes = diff_reports(*a, *b);
  std::fputs(format_diff(changes).c_str(), out);
  std::fflush(out);
  const bool regressions = std::any_of(changes.begin(), changes.end(), [](const auto& change) {
    return change.kind == ChangeKind::new_failure;
  });
  return regressions ? 1 : 0;
}

}  // namespace drivecheck::reports
