// The console writer: result lines per verdict, the TTY progress line, the summary, ASCII.
#include <gtest/gtest.h>
#include <stdlib.h>

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

}  // namespace
}  // namespace drivecheck::reports
