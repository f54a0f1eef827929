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
#include <utility>
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

// ---- JSON (schema_version 4) -------------------------------------------------------------
//
// The schema, versioned, is reports/report.schema.json (JSON Schema 2020-12); every field is
// described there. In short:
//   { "schema_version": 4, "generator": "drivecheck <version>",
//     "run": { tool_version, revision, vector_set: {sha256, files}, documents: [{key, title,
//              edition}], started_utc, bus, node, profile: {name,title,file,commissioning?},
//              eds: {file,sha256}, esi?: {file, sha256, device?: {vendor_id,
//              product_code, revision, name}} (--esi only), personality, deviations: [..], seed,
//              order, strict, allow_motion, allow_factory_restore, filter, dut: {...} (absent = not
//              readable), interrupted, dut_lost, harness_notes, simulated_ns, simulated_s, wall_s
//              },
//     "counts": { pass, fail, warning, deviation, not-applicable, error, interrupted, total }
//               (conformance::VerdictCounts: each vector in exactly one),
//     "exit_code": 0|1|3|130,
//     "vectors": [ { id, family, title, sources: [..], level, file, line, verdict, message,
//                    deviation_id, deviation_source, warning,
//                    checks: [{step (from 1 as in the vector file; 0 = setup), action,
//                              expected, actual, ok, t_ns?, observed?: {abort?, value?,
//                              statusword?, nothing?, accepted?} (a failed check's typed
//                              observation, conformance::Observation)}],
//                    frames: [{t_ns, t_s, frame: "605#..", from_harness, decoded,
//                              repeat?: {length, times, until_ns}}] (repeat: this frame and
//                              the length - 1 after it came `times` more times until until_ns,
//                              left out, then once more: that last repetition follows them;
//                              conformance::EvidenceRepeat),
//                    frames_elided, frames_elided_at,
//                    between_vectors: [frames that arrived before this vector's setup],
//                    EtherCAT only: datagrams: [{t_ns, t_s, last_ns, count, decoded,
//                                                repeat?}],
//                    datagrams_elided, datagrams_elided_at,
//                    timings: [{name, measured_ns, measured_s, min_ns?, max_ns?, ok}],
//                    samples: [{t_ns, signal, value, origin}], samples_elided,
//                    started_ns, finished_ns, duration_s, wall_s } ] }
//
// Times on the bus clock are integers in ns ("*_ns") and, for people, seconds ("*_s").
// Verdicts and levels are the strings of conformance::to_string. Invalid UTF-8 in a string is
// written as U+FFFD (the only lossy step: write → read gives back every valid-UTF-8 result).
// The reader also reads schema 1 (steps counted from 0 there; no revision, digest, documents
// or between_vectors), 2 (no observed) and 3 (no repeat: no pattern summarised).
inline constexpr int kJsonSchemaVersion = 4;
inline constexpr int kOldestJsonSchemaVersion = 1;

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
// appearance). The first testsuite's <properties> carry the run once per file (tool version,
// revision, vector-set digest, bus, DUT identity, EDS, profile, cited documents with their
// editions, bus and wall time); each suite has suite.bus_time_s. <testcase name="<vector id>"
// classname="drivecheck.cia301.sdo" time="<wall s>"> (no properties, no file attribute: the
// Jenkins/xunit schema and GitLab reject them) with:
//   fail           <failure message="<file>:<line>: step N action: Expected ...; Actual ..."
//                  type="fail">requirement, sources, Expected/Actual block</failure>
//   error          <error message="first line" type="harness-error">...</error>
//   not applicable <skipped message="not applicable: reason"/>
//   interrupted    <skipped message="interrupted by the user ..."/>
//   deviation      passes (a deviation the drive's manual documents is the drive's specified
//                  behaviour, not a failure); said in system-out
//   should/may failure without --strict: passes; "Warning: ..." in system-out
// <system-out>: requirement, sources with their documents, level, verdict, vector file:line,
// bus time, every check and timing, frames between vectors (marked), then the transcript.
// Counts are conformance::VerdictCounts: failures = fail, errors = error, skipped =
// not-applicable + interrupted. The schema it satisfies: tests/reports/junit.xsd.
std::string render_junit(const conformance::RunResult& result);
Expected<void, std::string> write_junit_report(const std::filesystem::path& path,
                                               const conformance::RunResult& result);

// ---- HTML --------------------------------------------------------------------------------
//
// One self-contained page (inline CSS and JS, no network). Hooks for scripts and tests:
//   <body data-js="ready">                   set by the page's script once it ran
//   [data-count-<tally>] / [data-count-total] the counts shown (conformance::VerdictCounts;
//                                             tallies pass fail warning deviation
//                                             not-applicable error interrupted)
//   <table id="matrix">                       by family; <table id="clause-matrix"> (inside
//                                             <details id="clause-box">) by cited clause or
//                                             manual section, with the vectors citing it
//   <ul id="documents">                       the cited documents with their editions (once)
//   <input id="search">                       text search over id, title, sources, message
//   <details class="vector" id="v:<vector id>" data-verdict="fail" data-tally="fail"
//            data-family="cia301/sdo" data-warning="true|false" data-clauses="<clause>\n..."
//            data-print="expand" (fail, error, warning: opened when printed)>  one per vector
//   <div data-between-vectors="N">            frames that arrived before the vector's setup
//   <pre class="transcript">                  the decoded frames, with a
//                                             <span data-failure-step="N"> where a check failed
//   <svg class="timing">                      the timing diagram (vectors with samples), with a
//                                             <g class="failure-mark" data-step="N"> per failed
//                                             check
//   URL fragment: #open=<vector id> opens (and scrolls to) that vector;
//                 #filter=<tally|all>[&family=<family>][&clause=<clause>][&search=<text>]
//                 filters the list.
// Printing (or saving as PDF) hides the controls and expands every failure, error and warning
// with its evidence (print CSS ::details-content, and the script's beforeprint handler).
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
// "(   0.012000) LRW logical 00010000h len 14 wkc 3  ×120 (to 0.131000)": one EtherCAT datagram
// entry (conformance::EvidenceDatagram), its count and last time when it stands for a run.
std::string transcript_line(const conformance::EvidenceDatagram& datagram, can::TimePoint start);
// The HTML/JUnit transcript of an EtherCAT vector's datagrams, elided entries marked.
std::string datagram_transcript(const conformance::VectorResult& vector);
// The line after a summarised pattern's first occurrence (conformance::EvidenceRepeat):
//   "   ↻ the 2 frame(s) above came 40 more time(s) in a row until (0.412345), left out; the
//   last time follows". `entries` names them ("frame(s)", "datagram entries").
std::string repeat_line(const conformance::EvidenceRepeat& repeat, can::TimePoint start,
                        std::string_view entries);
// Where a transcript loop puts repeat_line: after(i, entry i's repeat), then before(i) gives
// the repeat whose line goes before entry i (nullptr: none).
class RepeatLines {
 public:
  void after(std::size_t i, const conformance::EvidenceRepeat& repeat) {
    if (repeat.times != 0) {
      pending_ = &repeat;
      at_ = i + repeat.length;
    }
  }
  const conformance::EvidenceRepeat* before(std::size_t i) {
    if (pending_ == nullptr || i != at_) return nullptr;
    return std::exchange(pending_, nullptr);
  }

 private:
  const conformance::EvidenceRepeat* pending_ = nullptr;
  std::size_t at_ = 0;
};

// ---- console -----------------------------------------------------------------------------

// --color: auto colours a TTY only, and not when NO_COLOR is set (any value, also empty;
// https://no-color.org) or TERM is "dumb"; always and never decide alone.
enum class ColorMode : std::uint8_t { automatic, always, never };

struct ConsoleOptions {
  bool tty = false;       // progress line overwritten in place ("\r\x1b[K")
  bool unicode = true;    // ✔ × — ; false: plain ASCII ("ok", "x", "-")
  std::size_t total = 0;  // vectors expected (for the progress line; 0 = unknown)
  bool color = false;     // the verdict mark of each line in ANSI colour (SGR)

  // From the stream (isatty), the locale environment (LC_ALL, LC_CTYPE, LANG naming
  // UTF-8: unicode; anything else, e.g. C/POSIX: ASCII) and, for colour, `color` with
  // NO_COLOR and TERM.
  static ConsoleOptions detect(std::FILE* stream, std::size_t total,
                               ColorMode color = ColorMode::automatic);
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

  // The line vector_finished prints for `vector` (without newline). With `color` the verdict
  // mark is coloured: pass green, fail red, warning and interrupted yellow, deviation cyan,
  // not applicable dim, error magenta; the rest of the line is not.
  static std::string result_line(const conformance::VectorResult& vector, bool unicode,
                                 bool color = false);
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

// ---- build ------------------------------------------------------------------------------

// The drivecheck revision this binary was built from: `git describe --always --dirty` of the
// source tree at build time, or the project version when it was not built from a git checkout.
std::string_view build_revision();

// ---- citations ---------------------------------------------------------------------------

// The document a citation ("000_33c1d912b8b6010a.txt §3.2.2 L764-780", "CiA 301 §7.2.4.3.17")
// refers to, from RunInfo::documents (vectors/manuals.yaml): the longest key the citation
// starts with, ending at a word boundary; nullptr when none is listed.
const conformance::CitedDocument* cited_document(const conformance::RunInfo& info,
                                                 std::string_view source);
// The citation followed by its document's title and edition, "<source> (<title>, <edition>)";
// the citation alone when its document is not listed.
std::string citation_text(const conformance::RunInfo& info, std::string_view source);
// The clause a citation names, for the HTML clause matrix: "<document> §<section>" without the
// line range or the free text after it ("CiA 301 §7.2.4.3.17", "000_...txt §3.2.2"); a
// citation without "§" up to its line range.
std::string clause_of(std::string_view source);

}  // namespace drivecheck::reports
