// The report writers: everything a conformance run produced (conformance::RunResult) as a
// JSON file, a JUnit XML file, one self-contained HTML page and console lines, plus the
// difference between two JSON reports (`drivecheck report diff`).
//
// Every writer reads only RunResult. Every string in it (device names read from the DUT,
// decoded frames, messages) is untrusted: the writers make it valid UTF-8 (invalid bytes become
// U+FFFD), show control characters as visible "\xNN" escapes where the format cannot carry
// them (XML, HTML, console) and escape it for the format. Every report file is written through
// write_file_atomically(): a reader never sees half a report.
#pragma once

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "conformance/result.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::reports {

// ---- files ------------------------------------------------------------------------------

// Writes `contents` to `path` so that `path` is either absent/unchanged or complete: a temp
// file in the same directory, fsync, rename over `path`, fsync of the directory. Creates the
// parent directories. On failure nothing is left behind; the error says what and where
// ("cannot create /x/y.json.tmp-ab12: Permission denied").
Expected<void, std::string> write_file_atomically(const std::filesystem::path& path,
                                                  std::string_view contents);

// ---- JSON (schema_version 1) -------------------------------------------------------------
//
//   { "schema_version": 1, "generator": "drivecheck <version>",
//     "run": { tool_version, started_utc, bus, node, profile: {name,title,file},
//              eds: {file,sha256}, personality, deviations: [..], seed,
//              order ("file" | "reverse" | "shuffle:SEED"; absent in older reports: file),
//              strict, allow_motion, filter, dut: {device_type, device_name, hardware_version,
//              software_version, vendor_id, product_code, revision, serial} (absent = not
//              readable),
//              interrupted, dut_lost, simulated_ns, simulated_s, wall_s },
//     "counts": { pass, fail, deviation, not-applicable, error, warnings, total },
//     "exit_code": 0|1|3|130,
//     "vectors": [ { id, family, title, sources: [..], level, file, line, verdict, message,
//                    deviation_id, deviation_source, warning,
//                    checks: [{step, action, expected, actual, ok}],
//                    frames: [{t_ns, t_s, frame: "605#..", from_harness, decoded}],
//                    timings: [{name, measured_ns, measured_s, min_ns?, max_ns?, ok}],
//                    samples: [{t_ns, signal, value, origin: "sdo"|"tpdo"|"rpdo"}],
//                    samples_elided (samples thinned out of a long vector, every bit edge
//                    kept; origin and samples_elided are absent in older reports: sdo, 0),
//                    started_ns, finished_ns, duration_s, wall_s } ] }
//
// Times on the bus clock are integers in ns ("*_ns") and, for people, seconds ("*_s").
// Verdicts and levels are the strings of conformance::to_string. Invalid UTF-8 in a string is
// written as U+FFFD (the only lossy step: write → read gives back every valid-UTF-8 result).
inline constexpr int kJsonSchemaVersion = 1;

std::string render_json(const conformance::RunResult& result);
Expected<void, std::string> write_json_report(const std::filesystem::path& path,
                                              const conformance::RunResult& result);

// Reads a JSON report back. Errors are file:line (line of a syntax error; 0 for a structural
// error, whose message names the key, e.g. "vectors[3].verdict: unknown verdict \"pased\"").
// Unknown keys are ignored (a newer minor writer may add some); a missing required key or a
// schema_version other than kJsonSchemaVersion is an error.
Expected<conformance::RunResult, TextError> parse_json_report(std::string_view text,
                                                              std::string_view file = {});
Expected<conformance::RunResult, TextError> read_json_report(const std::filesystem::path& path);

// ---- JUnit XML ---------------------------------------------------------------------------
//
// <testsuites> with one <testsuite name="cia301/sdo"> per family (run order of first
// appearance); <testcase name="<vector id>" classname="drivecheck.cia301.sdo" time="s"> with
// <properties> (source, level, verdict, expected/actual per check, DUT identity, EDS hash,
// profile, deviation, warning) and:
//   fail           <failure message="first line" type="fail">Expected/Actual block</failure>
//   error          <error message="first line" type="harness-error">...</error>
//   not applicable <skipped message="reason"/>
//   deviation      passes: property verdict=deviation + deviation id/source (a deviation the
//                  drive's manual documents is the drive's specified behaviour, not a failure)
//   should/may failure without --strict: passes with property warning=...
// <system-out> carries the decoded transcript (transcript_line per frame).
// The schema it satisfies: tests/reports/junit.xsd.
std::string render_junit(const conformance::RunResult& result);
Expected<void, std::string> write_junit_report(const std::filesystem::path& path,
                                               const conformance::RunResult& result);

// ---- HTML --------------------------------------------------------------------------------
//
// One self-contained page (inline CSS and JS, no network). Hooks for scripts and tests:
//   <body data-js="ready">                   set by the page's script once it ran
//   [data-count-<verdict>] / [data-count-total] / [data-count-warnings]   the counts shown
//   <details class="vector" id="v:<vector id>" data-verdict="fail" data-family="cia301/sdo"
//            data-warning="true|false">      one per vector
//   <pre class="transcript">                  the decoded frames inside it
//   <svg class="timing">                      the timing diagram (vectors with samples)
//   URL fragment: #open=<vector id> opens (and scrolls to) that vector;
//                 #filter=<verdict|warning|all>[&family=<family>] filters the list.
std::string render_html(const conformance::RunResult& result);
Expected<void, std::string> write_html_report(const std::filesystem::path& path,
                                              const conformance::RunResult& result);

// ---- transcript --------------------------------------------------------------------------

// One line of a vector's transcript, time relative to the vector's start:
//   "(   0.012345) tx 605#4041600000000000 → SDO rx  node 5  initiate upload 6041:00 ..."
// tx = sent by the harness, rx = seen from the DUT or another node. Not sanitised (each
// writer escapes for its format).
std::string transcript_line(const conformance::EvidenceFrame& frame, can::TimePoint start);
// The line that stands for the frames a long vector left out (VectorResult::frames_elided).
std::string elided_line(std::size_t count);

// ---- console -----------------------------------------------------------------------------

struct ConsoleOptions {
  bool tty = false;       // progress line overwritten in place ("\r\x1b[K")
  bool unicode = true;    // ✔ × — ; false: plain ASCII ("ok", "x", "-")
  std::size_t total = 0;  // vectors expected (for the progress line; 0 = unknown)

  // From the stream (isatty) and the locale environment (LC_ALL, LC_CTYPE, LANG naming
  // UTF-8: unicode; anything else, e.g. C/POSIX: ASCII).
  static ConsoleOptions detect(std::FILE* stream, std::size_t total);
};

// Fed results as the engine produces them:
//   ✔ cia301/sdo/expedited-read                               (pass)
//   × cia301/sdo/abort/write-read-only — Expected abort ...    (fail; first line of message)
//   ! cia301/heartbeat/x — warning (should): ...               (should/may fail, no --strict)
//   ~ cia402/fsa/transition-16 (deviation no-transition-16)    (documented deviation)
//   - cia402/homing/method-35 (n/a: homing.method.35)          (not applicable)
//   E cia301/sdo/x — harness error: ...                        (error)
// On a TTY a progress line "[ 12/340] 3% ETA 1m20s <id>" follows the last result line and
// is overwritten in place (ETA from the mean VectorResult::wall_seconds so far). finish()
// prints the summary line: "340 vectors: 330 passed, 2 failed, ... (exit 1)".
class ConsoleReporter {
 public:
  ConsoleReporter(std::FILE* out, ConsoleOptions options);

  void vector_started(std::string_view id);
  void vector_finished(const conformance::VectorResult& vector);
  void finish(const conformance::RunResult& result);

  // The line vector_finished prints for `vector` (without newline).
  static std::string result_line(const conformance::VectorResult& vector, bool unicode);
  static std::string summary_line(const conformance::RunResult& result);

 private:
  void clear_progress();
  void draw_progress(std::string_view current);

  std::FILE* out_;
  ConsoleOptions options_;
  std::size_t done_ = 0;
  double wall_sum_ = 0.0;
  bool progress_shown_ = false;
};

// ---- report diff -------------------------------------------------------------------------

enum class ChangeKind : std::uint8_t {
  new_failure,      // fails in B (fail without warning, or error) and did not in A (or absent)
  fixed,            // failed in A, does not fail in B
  verdict_changed,  // any other verdict or warning change
  added,            // only in B (and does not fail there)
  removed,          // only in A
};
std::string_view to_string(ChangeKind kind);

struct ReportChange {
  ChangeKind kind = ChangeKind::verdict_changed;
  std::string id;
  std::optional<conformance::Verdict> before;  // absent: not in A
  std::optional<conformance::Verdict> after;   // absent: not in B
  bool warning_before = false;
  bool warning_after = false;
  std::string message;  // B's message (A's for removed/fixed)
};

// Changes ordered new failures first, then fixed, verdict changes, added, removed; by id
// within each kind. Vectors with the same verdict and warning in both runs are not listed.
std::vector<ReportChange> diff_reports(const conformance::RunResult& before,
                                       const conformance::RunResult& after);

// The text `drivecheck report diff` prints: one line per change and a summary line.
std::string format_diff(const std::vector<ReportChange>& changes);

// `drivecheck report diff A B`: prints the diff to `out`, errors ("file:line: message") to
// `err`; returns 0 no new failures, 1 new failures, 2 bad input.
int report_diff_command(const std::filesystem::path& before, const std::filesystem::path& after,
                        std::FILE* out, std::FILE* err);

// ---- text helpers (shared by the writers, exposed for tests) -----------------------------

// Valid UTF-8: each invalid byte sequence becomes U+FFFD.
std::string to_valid_utf8(std::string_view text);
// to_valid_utf8 plus every C0 control except \t and \n, and DEL, shown as "\xNN".
std::string printable_text(std::string_view text);
// The first line of `text` (up to the first '\n', without a trailing '\r').
std::string_view first_line(std::string_view text);

}  // namespace drivecheck::reports
