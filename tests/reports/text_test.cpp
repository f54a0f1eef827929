// The writers' shared text helpers and write_file_atomically.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "reports/report_writers.hpp"
#include "tests/reports/synthetic_run.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::reports {
namespace {

using test_support::read_file;
using test_support::TempDir;

std::vector<std::string> names_in(const std::filesystem::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(ReportText, InvalidUtf8BecomesReplacementCharacter) {
  // Given bytes that are not UTF-8 (lone continuation, bad lead, truncated sequence, overlong,
  //       surrogate) around valid multi-byte characters
  // When made valid
  // Then each invalid byte is one U+FFFD and the valid characters are kept
  EXPECT_EQ(to_valid_utf8("a\x80z"), "a\xEF\xBF\xBDz");
  EXPECT_EQ(to_valid_utf8("\xff\xfe"), "\xEF\xBF\xBD\xEF\xBF\xBD");
  EXPECT_EQ(to_valid_utf8("\xc3("), "\xEF\xBF\xBD(");
  EXPECT_EQ(to_valid_utf8("\xc0\xaf"), "\xEF\xBF\xBD\xEF\xBF\xBD");
  EXPECT_EQ(to_valid_utf8("\xed\xa0\x80"), "\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD");
  EXPECT_EQ(to_valid_utf8("§ → ✔ \xF0\x9F\x98\x80"), "§ → ✔ \xF0\x9F\x98\x80");
  EXPECT_EQ(to_valid_utf8("\xE2\x86"), "\xEF\xBF\xBD\xEF\xBF\xBD");
}

TEST(ReportText, ControlCharactersBecomeVisibleEscapes) {
  // Given text with ESC, NUL, BEL, DEL, a tab and newlines
  // When made printable
  // Then the controls are "\xNN" text and tab/newline stay
  EXPECT_EQ(printable_text(std::string_view("a\x1b[2J\0b\x07\x7f\tc\nd", 13)),
            "a\\x1B[2J\\x00b\\x07\\x7F\tc\nd");
}

TEST(ReportText, FirstLineStopsAtNewlineAndDropsCarriageReturn) {
  // Given one-line, multi-line and CRLF texts
  // When their first line is taken
  // Then it ends before the newline, without '\r'
  EXPECT_EQ(first_line("Expected: x"), "Expected: x");
  EXPECT_EQ(first_line("Expected: x\nActual: y"), "Expected: x");
  EXPECT_EQ(first_line("Expected: x\r\nActual: y"), "Expected: x");
  EXPECT_EQ(first_line(""), "");
}

TEST(ReportText, TranscriptLineHasTimeDirectionFrameAndDecoding) {
  // Given a frame sent by the harness 12.345 ms after the vector started
  // When written as a transcript line
  // Then it reads "(   0.012345) tx 605#... → <decoded>"
  const auto frame = test_support::evidence(112, "605#4041600000000000", true, "SDO rx  node 5");
  conformance::EvidenceFrame later = frame;
  later.at += std::chrono::microseconds(345);
  EXPECT_EQ(transcript_line(later, test_support::at_ms(100)),
            "(   0.012345) tx 605#4041600000000000 → SDO rx  node 5");
  const auto reply = test_support::evidence(100, "585#4B41600050020000", false, "");
  EXPECT_EQ(transcript_line(reply, test_support::at_ms(100)),
            "(   0.000000) rx 585#4B41600050020000");
}

TEST(AtomicWrite, CreatesParentDirectoriesAndWritesEverything) {
  // Given a path two directories below a fresh temp dir
  // When a report is written there
  // Then the file holds exactly the contents and no temporary file is left
  TempDir dir;
  const auto path = dir / "out/nested/report.json";
  std::string contents(100000, 'x');
  contents += "end";
  ASSERT_TRUE(write_file_atomically(path, contents));
  EXPECT_EQ(read_file(path), contents);
  EXPECT_EQ(names_in(dir / "out/nested"), std::vector<std::string>{"report.json"});
}

TEST(AtomicWrite, ReplacesAnExistingFile) {
  // Given an existing report
  // When a new one is written over it
  // Then the file holds the new contents only
  TempDir dir;
  const auto path = dir.write("report.html", "old old old old old old");
  ASSERT_TRUE(write_file_atomically(path, "new"));
  EXPECT_EQ(read_file(path), "new");
  EXPECT_EQ(names_in(dir.path()), std::vector<std::string>{"report.html"});
}

TEST(AtomicWrite, UnwritableDirectoryLeavesNoPartialFile) {
  // Given a directory without write permission holding an old report
  // When an unprivileged process writes the report and a report in a new subdirectory
  // Then both fail with a message naming the directory, the old report is unchanged and no
  //      file appears (root ignores permissions: the writer then runs as user nobody)
  TempDir dir;
  const auto locked = dir / "locked";
  std::filesystem::create_directory(locked);
  {
    std::ofstream old(locked / "report.json");
    old << "old report";
  }
  ASSERT_EQ(::chmod(dir.path().c_str(), 0755), 0);
  ASSERT_EQ(::chmod(locked.c_str(), 0555), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    if (::geteuid() == 0 && (::setgid(65534) != 0 || ::setuid(65534) != 0)) ::_exit(10);
    const auto replace = write_file_atomically(locked / "report.json", "new report");
    if (replace || replace.error().find(locked.string()) == std::string::npos) ::_exit(11);
    const auto nested = write_file_atomically(locked / "sub" / "report.json", "new report");
    if (nested || nested.error().find("sub") == std::string::npos) ::_exit(12);
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ::chmod(locked.c_str(), 0755);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "10: cannot drop root, 11: replace, 12: nested";
  EXPECT_EQ(read_file(locked / "report.json"), "old report");
  EXPECT_EQ(names_in(locked), std::vector<std::string>{"report.json"});
}

TEST(AtomicWrite, FailureHalfwayKeepsTheOldFileAndRemovesTheTempFile) {
  // Given an old report and a file size limit (RLIMIT_FSIZE) smaller than the new report
  // When the new report is written (write(2) fails with EFBIG halfway)
  // Then the write fails, the old report is intact and no temporary file is left
  TempDir dir;
  const auto path = dir.write("report.json", "old report");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::signal(SIGXFSZ, SIG_IGN);
    const rlimit limit{4096, 4096};
    if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) ::_exit(10);
    const auto written = write_file_atomically(path, std::string(100000, 'n'));
    ::_exit(written ? 11 : 0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "10: setrlimit failed, 11: the write succeeded";
  EXPECT_EQ(read_file(path), "old report");
  EXPECT_EQ(names_in(dir.path()), std::vector<std::string>{"report.json"});
}

TEST(AtomicWrite, PathThatIsADirectoryIsAnError) {
  // Given a path naming an existing directory
  // When a report is written to it
  // Then the write fails and the directory is still there
  TempDir dir;
  std::filesystem::create_directory(dir / "report.json");
  EXPECT_FALSE(write_file_atomically(dir / "report.json", "x"));
  EXPECT_TRUE(std::filesystem::is_directory(dir / "report.json"));
  EXPECT_EQ(names_in(dir.path()), std::vector<std::string>{"report.json"});
}

}  // namespace
}  // namespace drivecheck::reports
