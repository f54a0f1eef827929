// The console writer: result lines per verdict, the TTY progress line, the summary, ASCII.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <stdlib.h>
#include <unistd.h>

#include <cstdio>
#include <string>

#include "reports/report_writers.hpp"
#include "tests/reports/synthetic_run.hpp"

namespace drivecheck::reports {
namespace {

using test_support::synthetic_run;

// Captures what a reporter writes (open_memstream).
class Capture {
 public:
  Capture() : file_(::open_memstream(&buffer_, &size_)) {}
  ~Capture() {
    std::fclose(file_);
    std::free(buffer_);
  }
  Capture(const Capture&) = delete;
  Capture& operator=(const Capture&) = delete;
  std::FILE* file() { return file_; }
  std::string text() {
    std::fflush(file_);
    return std::string(buffer_, size_);
  }

 private:
  char* buffer_ = nullptr;
  std::size_t size_ = 0;
  std::FILE* file_;
};

TEST(ConsoleReport, OneLinePerVerdict) {
  // Given the synthetic run's vectors
  // When each is formatted for a UTF-8 console
  // Then pass ✔, fail × with the first message line, warning !, deviation ~, n/a -, error E
  const auto run = synthetic_run();
  const auto line = [&](std::size_t i) {
    return ConsoleReporter::result_line(run.vectors[i], true);
  };
  EXPECT_EQ(line(0), "✔ cia301/sdo/expedited-upload");
  EXPECT_EQ(line(1),
            "× cia301/sdo/abort/write-read-only — vectors/cia301/sdo.yaml:14: step 1 "
            "expect_frame: Expected 585#80416000020001 06 (abort 06010002h); Actual "
            "585#80416000000002 06 (abort 06020000h)");
  EXPECT_EQ(line(2), "~ cia402/fsa/transition-16 (deviation no-transition-16)");
  EXPECT_EQ(line(3),
            "- cia402/homing/method-35 (n/a: the profile does not support homing.method.35)");
  EXPECT_EQ(line(4),
            "! cia301/heartbeat/producer-period — warning (should): Expected: period 100 ms ± 10 "
            "ms");
  EXPECT_EQ(line(5),
            "E cia301/nmt/reset-communication — harness error: harness error: the bus "
            "went bus-off");
}

TEST(ConsoleReport, AsciiFallbackHasNoNonAsciiBytes) {
  // Given every vector of the synthetic run (with a hostile, non-ASCII message)
  // When formatted for a non-UTF-8 console
  // Then the lines are pure printable ASCII ("ok", "x", " - ") with \xNN for anything else
  const auto run = synthetic_run();
  EXPECT_EQ(ConsoleReporter::result_line(run.vectors[0], false), "ok cia301/sdo/expedited-upload");
  EXPECT_EQ(ConsoleReporter::result_line(run.vectors[1], false).substr(0, 37),
            "x cia301/sdo/abort/write-read-only - ");
  for (const auto& vector : run.vectors) {
    for (const char c : ConsoleReporter::result_line(vector, false)) {
      const auto byte = static_cast<unsigned char>(c);
      EXPECT_TRUE(byte >= 0x20 && byte < 0x7F) << vector.id << " byte " << int{byte};
    }
  }
}

TEST(ConsoleReport, EscapeSequencesFromTheDeviceAreNotSentToTheTerminal) {
  // Given a failure message with ESC [2J (clear screen) on its first line
  // When printed
  // Then the ESC byte appears as the text \x1B
  auto vector = synthetic_run().vectors[1];
  vector.message = "Actual: \x1b[2J cleared";
  EXPECT_EQ(ConsoleReporter::result_line(vector, true),
            "× cia301/sdo/abort/write-read-only — Actual: \\x1B[2J cleared");
}

TEST(ConsoleReport, PlainStreamGetsResultLinesAndSummaryOnly) {
  // Given a reporter on a non-TTY stream
  // When the run's vectors are fed and the run finishes
  // Then the output is the result lines and the summary, no carriage returns or escapes
  const auto run = synthetic_run();
  Capture capture;
  ConsoleReporter reporter(capture.file(), {.tty = false, .unicode = true, .total = 7});
  for (const auto& vector : run.vectors) {
    reporter.vector_started(vector.id);
    reporter.vector_finished(vector);
  }
  reporter.finish(run);
  const std::string text = capture.text();
  EXPECT_EQ(text.find('\r'), std::string::npos);
  EXPECT_EQ(text.find('\x1b'), std::string::npos);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 8);
  EXPECT_NE(text.find("\n7 vectors: 2 passed, 1 failed, 1 warnings, 1 deviations, 1 not "
                      "applicable, 1 errors (exit 1)\n"),
            std::string::npos)
      << text;
}

TEST(ConsoleReport, TtyProgressLineIsOverwrittenInPlaceWithEta) {
  // Given a reporter on a TTY, 4 vectors expected, each taking 2 s of wall time
  // When the first vector finishes and the second starts
  // Then the progress line shows "[1/4]  25% ETA 6s" and then the next id, each drawn after
  //      "\r\x1b[K" so it replaces the previous one; finish() clears it before the summary
  Capture capture;
  ConsoleReporter reporter(capture.file(), {.tty = true, .unicode = true, .total = 4});
  auto vector = synthetic_run().vectors[0];
  vector.wall_seconds = 2.0;
  reporter.vector_started(vector.id);
  reporter.vector_finished(vector);
  reporter.vector_started("cia301/sdo/next");
  const std::string text = capture.text();
  EXPECT_EQ(text,
            "\r\x1b[K[0/4]   0% cia301/sdo/expedited-upload"
            "\r\x1b[K✔ cia301/sdo/expedited-upload\n"
            "\r\x1b[K[1/4]  25% ETA 6s"
            "\r\x1b[K[1/4]  25% ETA 6s cia301/sdo/next");
  reporter.finish(synthetic_run());
  EXPECT_EQ(capture.text().substr(text.size(), 4), "\r\x1b[K");
}

TEST(ConsoleOptionsDetect, LocaleDecidesUnicode) {
  // Given LC_ALL set to a UTF-8 locale, then to C
  // When options are detected for a file that is not a TTY
  // Then unicode follows the locale and tty is false
  ::setenv("LC_ALL", "en_US.UTF-8", 1);
  Capture capture;
  EXPECT_TRUE(ConsoleOptions::detect(capture.file(), 3).unicode);
  EXPECT_FALSE(ConsoleOptions::detect(capture.file(), 3).tty);
  ::setenv("LC_ALL", "C", 1);
  EXPECT_FALSE(ConsoleOptions::detect(capture.file(), 3).unicode);
  ::unsetenv("LC_ALL");
}

// A pseudo-terminal's slave side as a FILE*: a stream isatty() says is a TTY.
class PseudoTerminal {
 public:
  PseudoTerminal() {
    master_ = ::posix_openpt(O_RDWR | O_NOCTTY);
    if (master_ < 0 || ::grantpt(master_) != 0 || ::unlockpt(master_) != 0) return;
    const char* name = ::ptsname(master_);
    if (name != nullptr) file_ = std::fopen(name, "w");
  }
  ~PseudoTerminal() {
    if (file_ != nullptr) std::fclose(file_);
    if (master_ >= 0) ::close(master_);
  }
  PseudoTerminal(const PseudoTerminal&) = delete;
  PseudoTerminal& operator=(const PseudoTerminal&) = delete;
  std::FILE* file() { return file_; }

 private:
  int master_ = -1;
  std::FILE* file_ = nullptr;
};

TEST(ConsoleReport, ColourMarksOnlyTheVerdict) {
  // Given the synthetic run's vectors
  // When their lines are made with colour
  // Then the mark alone is wrapped in an SGR colour and reset; without colour no escape at all
  const auto run = synthetic_run();
  for (const auto& vector : run.vectors) {
    const std::string plain = ConsoleReporter::result_line(vector, true);
    const std::string coloured = ConsoleReporter::result_line(vector, true, true);
    EXPECT_EQ(plain.find('\x1b'), std::string::npos) << plain;
    ASSERT_EQ(coloured.substr(0, 2), "\x1b[") << coloured;
    const auto reset = coloured.find("\x1b[0m");
    ASSERT_NE(reset, std::string::npos) << coloured;
    const auto mark_start = coloured.find('m') + 1;
    EXPECT_EQ(coloured.substr(mark_start, reset - mark_start) + coloured.substr(reset + 4), plain);
  }
  auto pass = run.vectors[0];
  pass.verdict = conformance::Verdict::pass;
  EXPECT_EQ(ConsoleReporter::result_line(pass, true, true),
            "\x1b[32m✔\x1b[0m " + ConsoleReporter::result_line(pass, true).substr(4));
  auto fail = pass;
  fail.verdict = conformance::Verdict::fail;
  EXPECT_EQ(ConsoleReporter::result_line(fail, false, true).substr(0, 11), "\x1b[31mx\x1b[0m ");
}

TEST(ConsoleOptionsDetect, ColourOnATerminalOnlyAndNotUnderNoColor) {
  // Given a pseudo-terminal and a file that is not a TTY, NO_COLOR and TERM unset
  PseudoTerminal terminal;
  if (terminal.file() == nullptr) GTEST_SKIP() << "no pseudo-terminal available";
  Capture pipe;
  ::unsetenv("NO_COLOR");
  ::setenv("TERM", "xterm", 1);
  // When options are detected / Then auto colours the terminal only
  EXPECT_TRUE(ConsoleOptions::detect(terminal.file(), 3).tty);
  EXPECT_TRUE(ConsoleOptions::detect(terminal.file(), 3).color);
  EXPECT_FALSE(ConsoleOptions::detect(pipe.file(), 3).color);
  // And NO_COLOR with any value, even empty, or TERM=dumb turns auto off
  ::setenv("NO_COLOR", "", 1);
  EXPECT_FALSE(ConsoleOptions::detect(terminal.file(), 3, ColorMode::automatic).color);
  ::setenv("NO_COLOR", "1", 1);
  EXPECT_FALSE(ConsoleOptions::detect(terminal.file(), 3, ColorMode::automatic).color);
  ::unsetenv("NO_COLOR");
  ::setenv("TERM", "dumb", 1);
  EXPECT_FALSE(ConsoleOptions::detect(terminal.file(), 3).color);
  ::setenv("TERM", "xterm", 1);
  // And always and never decide alone (always even into a pipe and under NO_COLOR)
  ::setenv("NO_COLOR", "1", 1);
  EXPECT_TRUE(ConsoleOptions::detect(pipe.file(), 3, ColorMode::always).color);
  ::unsetenv("NO_COLOR");
  EXPECT_FALSE(ConsoleOptions::detect(terminal.file(), 3, ColorMode::never).color);
  // And the reporter writes coloured lines only when told to
  ConsoleReporter reporter(pipe.file(), {.tty = false, .unicode = true, .total = 1, .color = true});
  reporter.vector_finished(synthetic_run().vectors[0]);
  EXPECT_EQ(pipe.text().substr(0, 2), "\x1b[");
}

}  // namespace
}  // namespace drivecheck::reports
