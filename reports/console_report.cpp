// The console writer: one line per vector as results come in, a progress line on a TTY, a
// summary at the end (formats in report_writers.hpp).
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "reports/report_writers.hpp"

namespace drivecheck::reports {
namespace {

using conformance::RunResult;
using conformance::VectorResult;
using conformance::Verdict;

bool names_utf8(const char* value) {
  if (value == nullptr) return false;
  std::string text(value);
  for (char& c : text)
    if (c >= 'a' && c <= 'z') c = static_cast<char>(c - 'a' + 'A');
  return text.find("UTF-8") != std::string::npos || text.find("UTF8") != std::string::npos;
}

// The locale's character set by POSIX precedence: the first of LC_ALL, LC_CTYPE, LANG that
// is set and not empty decides.
bool locale_is_utf8() {
  for (const char* name : {"LC_ALL", "LC_CTYPE", "LANG"}) {
    const char* value = std::getenv(name);
    if (value != nullptr && *value != '\0') return names_utf8(value);
  }
  return false;
}

std::string duration_text(double seconds) {
  if (seconds < 0) seconds = 0;
  const auto total = static_cast<long long>(seconds + 0.5);
  if (total < 60) return fmt::format("{}s", total);
  if (total < 3600) return fmt::format("{}m{:02}s", total / 60, total % 60);
  return fmt::format("{}h{:02}m", total / 3600, total % 3600 / 60);
}

// The console must not obey escape sequences a device put in a string: printable_text, and
// in ASCII mode every non-ASCII byte as \xNN.
std::string console_text(std::string_view text, bool unicode) {
  const std::string printable = printable_text(text);
  if (unicode) return printable;
  std::string out;
  for (const char c : printable) {
    const auto byte = static_cast<std::uint8_t>(c);
    out += byte >= 0x80 ? fmt::format("\\x{:02X}", byte) : std::string(1, c);
  }
  return out;
}

}  // namespace

ConsoleOptions ConsoleOptions::detect(std::FILE* stream, std::size_t total, ColorMode color) {
  ConsoleOptions options;
  options.tty = stream != nullptr && ::isatty(::fileno(stream)) == 1;
  options.unicode = locale_is_utf8();
  options.total = total;
  const char* term = std::getenv("TERM");
  options.color =
      color == ColorMode::always ||
      (color == ColorMode::automatic && options.tty && std::getenv("NO_COLOR") == nullptr &&
       !(term != nullptr && std::string_view(term) == "dumb"));
  return options;
}

ConsoleReporter::ConsoleReporter(std::FILE* out, ConsoleOptions options)
    : out_(out), options_(options) {}

static std::string plain_result_line(const VectorResult& vector, bool unicode);

std::string ConsoleReporter::result_line(const VectorResult& vector, bool unicode, bool color) {
  std::string line = plain_result_line(vector, unicode);
  if (!color) return line;
  // The mark is the line's first word ("✔", "ok", "×", "!", "~", "-", "E", "?").
  const char* sgr = "";
  switch (vector.verdict) {
    case Verdict::pass:
      sgr = "32";
      break;
    case Verdict::fail:
      sgr = vector.warning ? "33" : "31";
      break;
    case Verdict::deviation:
      sgr = "36";
      break;
    case Verdict::not_applicable:
      sgr = "2";
      break;
    case Verdict::error:
      sgr = "35";
      break;
    case Verdict::interrupted:
      sgr = "33";
      break;
  }
  const auto mark_end = line.find(' ');
  return fmt::format("\x1b[{}m{}\x1b[0m{}", sgr, line.substr(0, mark_end),
                     mark_end == std::string::npos ? std::string() : line.substr(mark_end));
}

static std::string plain_result_line(const VectorResult& vector, bool unicode) {
  const std::string id = console_text(vector.id, unicode);
  const std::string message = console_text(first_line(vector.message), unicode);
  const std::string dash = unicode ? " — " : " - ";
  switch (vector.verdict) {
    case Verdict::pass:
      return (unicode ? "✔ " : "ok ") + id;
    case Verdict::fail:
      if (vector.warning) {
        return "! " + id + dash + "warning (" + std::string(to_string(vector.level)) +
               "): " + message;
      }
      return (unicode ? "× " : "x ") + id + dash + message;
    case Verdict::deviation:
      return "~ " + id + " (deviation " + console_text(vector.deviation_id, unicode) + ")";
    case Verdict::not_applicable:
      return "- " + id + " (n/a" + (message.empty() ? "" : ": " + message) + ")";
    case Verdict::error:
      return "E " + id + dash + "harness error: " + message;
    case Verdict::interrupted:
      return "? " + id + dash + message;
  }
  return id;
}

std::string ConsoleReporter::summary_line(const RunResult& result) {
  // The counts every output shows (conformance::VerdictCounts): a warning is not a failure,
  // an interrupted vector is neither passed nor failed.
  const auto counts = result.counts();
  using conformance::Tally;
  std::string line = fmt::format(
      "{} vectors: {} passed, {} failed, {} warnings, {} deviations, {} not applicable, {} "
      "errors",
      counts.total(), counts[Tally::pass], counts[Tally::fail], counts[Tally::warning],
      counts[Tally::deviation], counts[Tally::not_applicable], counts[Tally::error]);
  if (counts[Tally::interrupted] != 0)
    line += fmt::format(", {} interrupted", counts[Tally::interrupted]);
  if (result.interrupted) line += " (interrupted)";
  if (result.dut_lost) line += " (the DUT stopped answering)";
  return line + fmt::format(" (exit {})", conformance::exit_code(result));
}

void ConsoleReporter::clear_progress() {
  if (!progress_shown_) return;
  std::fputs("\r\x1b[K", out_);
  progress_shown_ = false;
}

void ConsoleReporter::draw_progress(std::string_view current) {
  if (!options_.tty) return;
  std::string line;
  if (options_.total > 0) {
    const std::size_t total = std::max(options_.total, done_);
    line = fmt::format("[{:>{}}/{}] {:3}%", done_, fmt::formatted_size("{}", total), total,
                       done_ * 100 / total);
    if (done_ > 0 && done_ < total) {
      const double eta =
          wall_sum_ / static_cast<double>(done_) * static_cast<double>(total - done_);
      line += " ETA " + duration_text(eta);
    }
  } else {
    line = fmt::format("[{}]", done_);
  }
  if (!current.empty()) line += " " + console_text(current, options_.unicode);
  // Keep to one terminal line (80 columns is a safe guess without ioctl).
  if (line.size() > 79) {
    std::size_t n = 79;  // not inside a UTF-8 sequence
    while (n > 0 && (static_cast<std::uint8_t>(line[n]) & 0xC0) == 0x80)
      --n;
    line.resize(n);
  }
  std::fputs("\r\x1b[K", out_);
  std::fputs(line.c_str(), out_);
  std::fflush(out_);
  progress_shown_ = true;
}

void ConsoleReporter::vector_started(std::string_view id) {
  draw_progress(id);
}

void ConsoleReporter::vector_finished(const VectorResult& vector) {
  ++done_;
  wall_sum_ += vector.wall_seconds;
  clear_progress();
  std::fputs(result_line(vector, options_.unicode, options_.color).c_str(), out_);
  std::fputc('\n', out_);
  draw_progress({});
  std::fflush(out_);
}

void ConsoleReporter::finish(const RunResult& result) {
  clear_progress();
  std::fputs(summary_line(result).c_str(), out_);
  std::fputc('\n', out_);
  std::fflush(out_);
}

}  // namespace drivecheck::reports
