// Runs the built drivecheck program and checks its command-line contract (DESIGN.md, "The
// CLI contract"): help, version, exit codes, one-line usage errors, and `decode`.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "tests/support/run_command.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck {
namespace {

using test_support::CommandResult;

const std::string kData = DRIVECHECK_CLI_TEST_DATA;

CommandResult drivecheck(std::vector<std::string> args, std::string_view input = {}) {
  args.insert(args.begin(), DRIVECHECK_EXE);
  return test_support::run_command(args, input);
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    lines.push_back(line);
  return lines;
}

// One line on stderr, nothing on stdout, exit 2.
void expect_usage_error(const CommandResult& result, const std::string& contains) {
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_TRUE(result.out.empty()) << result.out;
  EXPECT_EQ(lines_of(result.err).size(), 1u) << result.err;
  EXPECT_NE(result.err.find(contains), std::string::npos)
      << "stderr: " << result.err << "expected: " << contains;
}

TEST(CliVersion, PrintsProjectVersion) {
  // Given the built program
  // When run with --version
  // Then it prints "drivecheck <CMake project version>" and exits 0
  const auto result = drivecheck({"--version"});
  EXPECT_EQ(result.exit_code, 0);
  EXPECT_EQ(result.out, std::string("drivecheck ") + DRIVECHECK_EXPECTED_VERSION + "\n");
}

TEST(CliHelp, EverySubcommandHasHelpExitingZero) {
  // Given every subcommand path of the CLI contract
  // When each is run with --help
  // Then each exits 0 and prints its usage line
  const std::vector<std::vector<std::string>> paths = {{},
                                                       {"run"},
                                                       {"drive"},
                                                       {"fuzz"},
                                                       {"decode"},
                                                       {"eds"},
                                                       {"eds", "lint"},
                                                       {"eds", "dump"},
                                                       {"esi"},
                                                       {"esi", "show"},
                                                       {"vectors"},
                                                       {"vectors", "lint"},
                                                       {"vectors", "list"},
                                                       {"report"},
                                                       {"report", "diff"},
                                                       {"profiles"},
                                                       {"deviations"}};
  for (const auto& path : paths) {
    auto args = path;
    args.push_back("--help");
    const auto result = drivecheck(args);
    std::string usage = "Usage: drivecheck";
    for (const auto& part : path)
      usage += " " + part;
    EXPECT_EQ(result.exit_code, 0) << usage << "\n" << result.err;
    EXPECT_NE(result.out.find(usage), std::string::npos) << result.out;
  }
}

TEST(CliHelp, RunHelpListsTheContractOptions) {
  // Given the run subcommand
  // When its help is printed
  // Then every option of the CLI contract is there
  const auto result = drivecheck({"run", "--help"});
  ASSERT_EQ(result.exit_code, 0);
  for (const char* option :
       {"--bus", "--node", "--profile", "--eds", "--filter", "--strict", "--allow-motion",
        "--allow-factory-restore", "--seed", "--junit", "--html", "--json", "--trace", "--pcap"}) {
    EXPECT_NE(result.out.find(option), std::string::npos) << option;
  }
}

TEST(CliUsage, UnknownOptionExitsTwoWithOneLine) {
  // Given unknown options at the top level and in subcommands
  // When run
  // Then each exits 2 with one line on stderr naming the option
  expect_usage_error(drivecheck({"--bogus"}), "--bogus");
  expect_usage_error(drivecheck({"run", "--bogus"}), "--bogus");
  expect_usage_error(drivecheck({"decode", "--bogus", (kData + "/small.log")}), "--bogus");
  expect_usage_error(drivecheck({"frobnicate"}), "frobnicate");
}

TEST(CliUsage, MissingSubcommandOrArgumentExitsTwo) {
  expect_usage_error(drivecheck({}), "subcommand is required");
  expect_usage_error(drivecheck({"eds"}), "subcommand is required");
  expect_usage_error(drivecheck({"decode"}), "drivecheck decode: LOG is required");
  expect_usage_error(drivecheck({"drive", "--node", "5"}), "--bus");
}

TEST(CliUsage, BadOptionValuesExitTwo) {
  // Given out-of-range node ids, a bus that is neither sim nor socketcan:IF, a duration
  // without unit and a negative seed
  // When run
  // Then each is a one-line usage error
  expect_usage_error(drivecheck({"run", "--node", "0"}), "--node");
  expect_usage_error(drivecheck({"run", "--node", "128"}), "--node");
  expect_usage_error(drivecheck({"run", "--bus", "can0"}), "neither 'sim' nor 'socketcan:IF'");
  expect_usage_error(drivecheck({"run", "--bus", "socketcan:"}), "1..15 characters");
  expect_usage_error(drivecheck({"run", "--seed", "-1"}), "not a whole number");
  expect_usage_error(drivecheck({"fuzz", "--bus", "sim", "--node", "5", "--duration", "10"}),
                     "needs a unit");
  expect_usage_error(drivecheck({"drive", "--bus", "sim", "--node", "5"}),
                     "--bus must be socketcan:IF");
  // huge numbers and bytes that are not ASCII
  expect_usage_error(drivecheck({"run", "--seed", "99999999999999999999999"}), "above 2^64-1");
  expect_usage_error(drivecheck({"run", "--node", "99999999999999999999999"}), "--node");
  expect_usage_error(
      drivecheck({"fuzz", "--bus", "sim", "--node", "5", "--duration", "9999999999999h"}),
      "duration too large");
  expect_usage_error(drivecheck({"run", "--bus", "socketcan:caf\xC3\xA9"}),
                     "is not a network interface name");
  expect_usage_error(drivecheck({"run", "--bus", "socketcan:sixteen-chars-xx"}), "1..15");
  // an EDS describes the CANopen interface: not a judge of the device over EtherCAT
  expect_usage_error(
      drivecheck({"run", "--bus", "ethercat:sim", "--eds",
                  std::string(DRIVECHECK_SOURCE_DIR) + "/reference_drive/reference_drive.eds"}),
      "over EtherCAT the description is the device's ESI");
  // an ESI describes an EtherCAT slave: refused on CAN; a file that is no ESI: file:line
  const std::string esi =
      std::string(DRIVECHECK_SOURCE_DIR) + "/reference_drive/ethercat/reference_drive.xml";
  expect_usage_error(drivecheck({"run", "--esi", esi}), "it needs --bus ethercat:sim");
  const auto not_esi =
      drivecheck({"run", "--bus", "ethercat:sim", "--esi",
                  std::string(DRIVECHECK_SOURCE_DIR) + "/reference_drive/reference_drive.eds"});
  EXPECT_EQ(not_esi.exit_code, 2) << not_esi.err;
  EXPECT_TRUE(not_esi.out.empty()) << not_esi.out;  // refused before the bus is touched
  EXPECT_NE(not_esi.err.find("reference_drive.eds:"), std::string::npos) << not_esi.err;
  EXPECT_NE(not_esi.err.find(": not well-formed XML"), std::string::npos) << not_esi.err;
}

TEST(CliEsi, ShowPrintsTheDeviceItsPdosAndPdoMappingAndRefusesAMalformedFile) {
  // Given the reference drive's ESI
  const std::string esi =
      std::string(DRIVECHECK_SOURCE_DIR) + "/reference_drive/ethercat/reference_drive.xml";
  // When shown
  const auto shown = drivecheck({"esi", "show", esi});
  // Then the device's identity, its PDOs and each entry's access and PdoMapping, with file:line
  ASSERT_EQ(shown.exit_code, 0) << shown.err;
  EXPECT_NE(shown.out.find("product code 00000402h, revision 00010000h"), std::string::npos)
      << shown.out;
  EXPECT_NE(shown.out.find("TxPdo 1A00h 'TPDO mapping parameter 1', SM3"), std::string::npos);
  EXPECT_NE(shown.out.find("6041h sub 0   UINT         16 bit(s) ro T   'statusword'"),
            std::string::npos)
      << shown.out;
  EXPECT_NE(shown.out.find("  Dc: no OpMode"), std::string::npos);
  // And a file that is no ESI is refused with file:line, exit 2
  const auto not_esi = drivecheck(
      {"esi", "show", std::string(DRIVECHECK_SOURCE_DIR) + "/reference_drive/reference_drive.eds"});
  EXPECT_EQ(not_esi.exit_code, 2) << not_esi.err;
  EXPECT_NE(not_esi.err.find("reference_drive.eds:"), std::string::npos) << not_esi.err;
  expect_usage_error(drivecheck({"esi"}), "subcommand is required");
}

TEST(CliDecode, PrintsEachRecordWithTimeInterfaceDirectionAndFrame) {
  // Given a small log with comments, blank lines, R/T flags and every kind of frame
  // When decoded
  // Then each record is one line: Unix time, interface, direction, frame (padded columns),
  //      then the function column, and the exit code is 0
  const auto result = drivecheck({"decode", kData + "/small.log"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_TRUE(result.err.empty()) << result.err;
  const std::vector<std::string> expected = {
      "1700000000.000000  vcan0  T  000#0105                   ",
      "1700000000.000210  vcan0  R  705#05                     ",
      "1700000000.001000  vcan0  T  080#                       ",
      "1700000000.001150  vcan0  R  185#37020000               ",
      "1700000000.002000  vcan0  T  605#4041600000000000       ",
      "1700000000.002400  vcan0  R  585#4B41600037020000       ",
      "1700000000.003000  vcan0  R  085#1023010000000000       ",
      "1700000000.004000  vcan0  T  705#R                      ",
      "1700000000.005000  vcan0  -  100#0000000000A4           ",
      "1700000000.006000  vcan0  -  205#0F00                   ",
      "1700000000.007000  vcan0  -  7E5#4C00000000000000       ",
      "1700000000.008000  vcan0  -  12345678#DEADBEEF          ",
      "1700000000.009000  vcan0  -  20000080#0000000000000000  ",
      "1700000000.010000  vcan0  -  180#00                     ",
  };
  const auto lines = lines_of(result.out);
  ASSERT_EQ(lines.size(), expected.size()) << result.out;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(lines[i].substr(0, expected[i].size()), expected[i]);
    EXPECT_GT(lines[i].size(), expected[i].size()) << "no function column: " << lines[i];
  }
}

// The last column is the CANopen dissector's summary (protocol/cia301/dissector.hpp).
TEST(CliDecode, DissectsEveryFrame) {
  // Given the small log
  // When decoded
  // Then the last column is function, node and the decoded content of each frame
  const auto result = drivecheck({"decode", kData + "/small.log"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::vector<std::string> functions = {
      "NMT     start node 5",
      "NMT EC  node 5  heartbeat operational",
      "SYNC    no counter",
      "TPDO1   node 5  37 02 00 00",
      "SDO rx  node 5  initiate upload 6041:00 (statusword)",
      "SDO tx  node 5  initiate upload response expedited 6041:00 (statusword) = 0x0237 = "
      "operation enabled",
      "EMCY    node 5  2310h Continuous over-current; register 01h generic",
      "NMT EC  node 5  node-guarding request",
      "TIME    2098-12-12 00:00:00.000 (day 41984, 0 ms)",
      "RPDO1   node 5  0F 00",
      "LSS rx  cs 4Ch identify non-configured remote slave data 00 00 00 00 00 00 00",
      "29-bit  DE AD BE EF: not in the CANopen pre-defined connection set",
      "CAN     error frame, error class 00000080h",
      // 180h: TPDO1 function code with node 0 is not a valid COB-ID
      "-       00 (CAN-ID 180h unassigned, restricted: reserved)",
  };
  const auto lines = lines_of(result.out);
  ASSERT_EQ(lines.size(), functions.size());
  for (std::size_t i = 0; i < functions.size(); ++i) {
    EXPECT_EQ(lines[i].substr(56), functions[i]) << lines[i];
  }
}

TEST(CliDecode, NodeOptionFlagsOtherNodes) {
  // Given the small log (node 5) and --node 3
  // When decoded
  // Then frames of node 5 are flagged as not configured; a node out of range is a usage error
  const auto result = drivecheck({"decode", "--node", "3", kData + "/small.log"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto lines = lines_of(result.out);
  ASSERT_GE(lines.size(), 2u);
  EXPECT_NE(lines[1].find("(node 5 not configured)"), std::string::npos) << lines[1];
  EXPECT_EQ(drivecheck({"decode", "--node", "128", kData + "/small.log"}).exit_code, 2);
}

TEST(CliDecode, EdsOptionNamesObjects) {
  // Given an EDS naming 6041h "Statusword (from EDS)"
  // When the small log is decoded with --eds
  // Then SDO lines use the EDS name; an unreadable EDS is a usage error with the file named
  const auto result = drivecheck({"decode", "--eds", kData + "/names.eds", kData + "/small.log"});
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const auto lines = lines_of(result.out);
  ASSERT_GE(lines.size(), 5u);
  EXPECT_NE(lines[4].find("6041:00 (Statusword (from EDS))"), std::string::npos) << lines[4];
  const auto missing = drivecheck({"decode", "--eds", kData + "/absent.eds", kData + "/small.log"});
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("absent.eds"), std::string::npos) << missing.err;
}

TEST(CliDecode, ReadsStandardInput) {
  const std::string log = test_support::read_file(kData + "/small.log");
  ASSERT_FALSE(log.empty());
  const auto from_stdin = drivecheck({"decode", "-"}, log);
  const auto from_file = drivecheck({"decode", kData + "/small.log"});
  EXPECT_EQ(from_stdin.exit_code, 0) << from_stdin.err;
  EXPECT_EQ(from_stdin.out, from_file.out);
}

TEST(CliDecode, BrokenLineIsReportedAndTheRestDecoded) {
  // Given a log whose third line has a bad data byte
  // When decoded
  // Then the first line is decoded, stderr says file:3 and why and how many were not read, and
  //      the exit code is 0 (something was read)
  const auto result = drivecheck({"decode", kData + "/broken.log"});
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_EQ(lines_of(result.out).size(), 1u) << result.out;
  EXPECT_EQ(result.err, kData + "/broken.log:3: data byte 0: 'G' is not a hex digit\n" +
                            "drivecheck decode: " + kData +
                            "/broken.log: 1 line(s) not read, 1 decoded\n");
}

TEST(CliDecode, MalformedInputsNameTheLineAndExitTwoOnlyWhenNothingIsRead) {
  // Given logs with non-ASCII bytes, a truncated line, a huge timestamp and a missing file
  // When decoded
  // Then each names file:line and why; the exit code is 2 only when no line could be read
  test_support::TempDir dir;
  const std::tuple<std::string, std::string, int> cases[] = {
      {"(1.000000) can0 080#\n(2.0) can0 080#\xFF\xFE\n", ":2: column 16: byte 0xFF", 0},
      {"(1.000000) can0 080#\n(2.000000) can0", ":2: missing frame", 0},
      {"(1.000000) can0 605#404160000000000", ":1: data byte 7: odd number", 2},
      {"(123456789012345678901234567890.0) can0 080#\n", ":1: timestamp", 2},
      {std::string("\x00\x01\x02", 3), ":1: column 1: byte 0x00", 2},
  };
  int n = 0;
  for (const auto& [content, expected, exit_code] : cases) {
    const auto path = dir.write("case" + std::to_string(n++) + ".log", content);
    const auto result = drivecheck({"decode", path.string()});
    EXPECT_EQ(result.exit_code, exit_code) << path << result.err;
    EXPECT_EQ(result.out.empty(), exit_code != 0) << result.out;
    EXPECT_NE(result.err.find(path.string() + expected), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("1 line(s) not read"), std::string::npos) << result.err;
  }
  expect_usage_error(drivecheck({"decode", (dir / "absent.log").string()}),
                     (dir / "absent.log").string() + ": cannot open");
}

TEST(CliDecode, ReadsPlainAndTimestampedCandumpOutput) {
  // Given the small log's first frames as `candump can0` and `candump -ta can0` print them
  test_support::TempDir dir;
  const auto plain = dir.write("plain.txt",
                               "  vcan0  000   [2]  01 05\n"
                               "  vcan0  605   [8]  40 41 60 00 00 00 00 00\n"
                               "  vcan0  585   [8]  4B 41 60 00 37 02 00 00\n");
  const auto timed = dir.write("timed.txt",
                               "(1700000000.000000)  vcan0  000   [2]  01 05\n"
                               "(1700000000.002000)  vcan0  605   [8]  40 41 60 00 00 00 00 00\n");
  // When decoded
  const auto from_plain = drivecheck({"decode", plain.string()});
  const auto from_timed = drivecheck({"decode", timed.string()});
  // Then each line is decoded as from the -L log: no time ('-') for plain output, the time for -ta
  ASSERT_EQ(from_plain.exit_code, 0) << from_plain.err;
  EXPECT_TRUE(from_plain.err.empty()) << from_plain.err;
  const auto lines = lines_of(from_plain.out);
  ASSERT_EQ(lines.size(), 3u) << from_plain.out;
  EXPECT_EQ(lines[0].substr(0, 22), "-  vcan0  -  000#0105 ") << lines[0];
  EXPECT_NE(lines[1].find("initiate upload 6041:00"), std::string::npos) << lines[1];
  EXPECT_NE(lines[2].find("6041:00 (statusword) = 0x0237"), std::string::npos) << lines[2];
  ASSERT_EQ(from_timed.exit_code, 0) << from_timed.err;
  const auto timed_lines = lines_of(from_timed.out);
  ASSERT_EQ(timed_lines.size(), 2u) << from_timed.out;
  EXPECT_EQ(timed_lines[1].substr(0, 17), "1700000000.002000") << timed_lines[1];
  EXPECT_NE(timed_lines[1].find("initiate upload 6041:00"), std::string::npos);
  // And a text with no readable line exits 2
  const auto junk = dir.write("junk.txt", "hello world\n");
  const auto from_junk = drivecheck({"decode", junk.string()});
  EXPECT_EQ(from_junk.exit_code, 2);
  EXPECT_NE(from_junk.err.find(junk.string() + ":1: not a candump line"), std::string::npos)
      << from_junk.err;
}

// Runs drivecheck in `dir` with SIGINT already pending and blocked, as a parent that blocked
// it and then sent Ctrl-C right at the start would leave it; the exit code (128 + signal if
// killed), stdout and stderr go to files in `dir`.
int run_with_pending_sigint(const std::filesystem::path& dir, std::vector<std::string> args) {
  args.insert(args.begin(), DRIVECHECK_EXE);
  const pid_t child = ::fork();
  if (child == 0) {
    if (::chdir(dir.c_str()) != 0) ::_exit(120);
    const int out = ::open("stdout", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err = ::open("stderr", O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(out, 1);
    ::dup2(err, 2);
    sigset_t interrupt;
    sigemptyset(&interrupt);
    sigaddset(&interrupt, SIGINT);
    ::sigprocmask(SIG_BLOCK, &interrupt, nullptr);
    ::raise(SIGINT);  // pending: kept across exec
    std::vector<char*> argv;
    for (auto& arg : args)
      argv.push_back(arg.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(121);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

TEST(CliRunInterrupt, SigintBeforeTheRunStartsExits130WithoutReports) {
  // Given a SIGINT that reaches drivecheck run while it loads the vectors
  test_support::TempDir dir;
  // When run with the default reports (reports/out/ in the working directory)
  const int code = run_with_pending_sigint(dir.path(), {"run"});
  // Then it exits 130, says so, and writes no report
  EXPECT_EQ(code, 130) << test_support::read_file(dir / "stderr");
  EXPECT_NE(test_support::read_file(dir / "stderr").find("interrupted"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir / "reports")) << "a report was written";
}

TEST(CliRunSelection, EmptySelectionExitsTwo) {
  // Given filters that match no vector id, and a level with a filter that leaves nothing
  // When run
  // Then each exits 2 saying no vector matches, and writes no report
  test_support::TempDir dir;
  const auto json = (dir / "r.json").string();
  for (const std::vector<std::string>& selection :
       {std::vector<std::string>{"--filter", "no/such/vector"},
        std::vector<std::string>{"--filter", "cia301/sdo/abort/*", "--level", "may"}}) {
    auto args = selection;
    args.insert(args.begin(), "run");
    args.insert(args.end(), {"--json", json});
    const auto result = drivecheck(args);
    EXPECT_EQ(result.exit_code, 2) << result.err;
    EXPECT_NE(result.err.find("no vector matches"), std::string::npos) << result.err;
    EXPECT_FALSE(std::filesystem::exists(json));
  }
}

// The ids of a JSON report's vectors.
std::vector<std::string> report_ids(const std::filesystem::path& json) {
  const std::string report = test_support::read_file(json);
  std::vector<std::string> ids;
  const std::string key = "\"id\": \"";
  for (auto at = report.find(key); at != std::string::npos; at = report.find(key, at + 1)) {
    const auto begin = at + key.size();
    ids.push_back(report.substr(begin, report.find('"', begin) - begin));
  }
  return ids;
}

TEST(CliRunSelection, FamilyNamesAndRepeatedFiltersSelect) {
  // Given the family names cia301/sdo and cia402/fsa as the matrix shows them
  test_support::TempDir dir;
  const auto json = (dir / "r.json").string();
  // When run with both as filters, and with --level should
  const auto both =
      drivecheck({"run", "--filter", "cia301/sdo", "--filter", "cia402/fsa", "--json", json});
  const auto ids = report_ids(json);
  const auto should = drivecheck({"run", "--level", "should", "--json", json});
  const auto should_text = test_support::read_file(json);
  // Then the run has vectors of both families and of no other, and the level selects
  EXPECT_EQ(both.exit_code, 0) << both.err;
  ASSERT_FALSE(ids.empty());
  bool sdo = false;
  bool fsa = false;
  for (const auto& id : ids) {
    sdo = sdo || id.rfind("cia301/sdo/", 0) == 0;
    fsa = fsa || id.rfind("cia402/fsa/", 0) == 0;
    EXPECT_TRUE(id.rfind("cia301/sdo/", 0) == 0 || id.rfind("cia402/fsa/", 0) == 0) << id;
  }
  EXPECT_TRUE(sdo && fsa);
  EXPECT_EQ(should.exit_code, 0) << should.err;
  EXPECT_EQ(should_text.find("\"level\": \"must\""), std::string::npos);
  EXPECT_NE(should_text.find("\"level\": \"should\""), std::string::npos);
}

TEST(CliRunSelection, RerunRunsOnlyTheFailedVectors) {
  // Given a report of a run with a deviation that fails some vectors
  test_support::TempDir dir;
  const auto first = (dir / "first.json").string();
  const auto again = (dir / "again.json").string();
  const auto failed = drivecheck(
      {"run", "--deviation", "sdo-read-only-wrong-abort", "--filter", "cia301/*", "--json", first});
  ASSERT_EQ(failed.exit_code, 1) << failed.err;
  std::size_t fails = 0;
  const std::string first_text = test_support::read_file(first);
  for (auto at = first_text.find("\"verdict\": \"fail\""); at != std::string::npos;
       at = first_text.find("\"verdict\": \"fail\"", at + 1))
    ++fails;
  // When run again with --rerun against the drive without the deviation
  const auto rerun = drivecheck({"run", "--rerun", first, "--json", again});
  // Then only the failed vectors ran, and they pass now
  EXPECT_EQ(rerun.exit_code, 0) << rerun.err;
  EXPECT_EQ(report_ids(again).size(), fails);
  EXPECT_GT(fails, 0U);
  // And a report without failures leaves nothing to run again: exit 2
  const auto nothing = drivecheck({"run", "--rerun", again, "--json", first});
  EXPECT_EQ(nothing.exit_code, 2);
  EXPECT_NE(nothing.err.find("no vector matches"), std::string::npos) << nothing.err;
}

TEST(CliListings, ProfilesAndDeviationsAreListed) {
  // Given the shipped profiles and the reference drive's deviations
  // When listed
  const auto profiles = drivecheck({"profiles"});
  const auto deviations = drivecheck({"deviations"});
  // Then each names what --profile and --deviation take, and exits 0
  EXPECT_EQ(profiles.exit_code, 0) << profiles.err;
  for (const char* name : {"cia402-reference", "festo-cmmp", "kollmorgen-s300-s700",
                           "irtsa-drive-fb", "esr-triodrive"})
    EXPECT_NE(profiles.out.find(name), std::string::npos) << name << "\n" << profiles.out;
  // (as many as the shipped vectors/drives/*.yaml: the count follows the tree)
  std::size_t shipped = 0;
  for (const auto& file :
       std::filesystem::directory_iterator(std::string(DRIVECHECK_SOURCE_DIR) + "/vectors/drives"))
    shipped += file.path().extension() == ".yaml" ? 1 : 0;
  EXPECT_NE(profiles.out.find(std::to_string(shipped) + " profiles"), std::string::npos)
      << profiles.out;
  EXPECT_EQ(deviations.exit_code, 0) << deviations.err;
  const auto row = deviations.out.find("\nsdo-read-only-wrong-abort ");
  ASSERT_NE(row, std::string::npos) << deviations.out;
  const auto row_text = deviations.out.substr(row, deviations.out.find('\n', row + 1) - row);
  EXPECT_NE(row_text.find(" cia301/sdo "), std::string::npos) << row_text;
  EXPECT_NE(row_text.find(" ordinary "), std::string::npos) << row_text;
  EXPECT_NE(deviations.out.find(" deviations (drivecheck run --deviation NAME)"),
            std::string::npos);
}

TEST(CliFuzz, SimulatedBusNeedsNoNodeAndOldPersonalityNameWarns) {
  // Given the live fuzzer on the embedded drive, without --node, with the old option name
  test_support::TempDir dir;
  const auto result = drivecheck({"fuzz", "--bus", "sim", "--duration", "2s", "--personality",
                                  "festo-cmmp", "--out", (dir / "fuzz").string()});
  // When it runs / Then it fuzzes node 1 as festo-cmmp, warns about the old name, exits 0
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("--personality is deprecated, use --profile"), std::string::npos)
      << result.err;
  EXPECT_NE(result.out.find("node 1 on sim"), std::string::npos) << result.out;
  // And a real bus still needs --node
  expect_usage_error(drivecheck({"fuzz", "--bus", "socketcan:vcan0", "--duration", "2s"}),
                     "--node is required");
}

TEST(CliRunEds, EmptyVendorNumberIsAcceptedWithAWarning) {
  // Given the reference drive's EDS with VendorNumber and ProductNumber left empty, as real
  // vendor EDS files have them
  test_support::TempDir dir;
  std::string eds = test_support::read_file(std::string(DRIVECHECK_SOURCE_DIR) +
                                            "/reference_drive/reference_drive.eds");
  for (const std::string key : {"VendorNumber=", "ProductNumber="}) {
    const auto at = eds.find("\n" + key);
    ASSERT_NE(at, std::string::npos) << key;
    eds.erase(at + 1 + key.size(), eds.find('\n', at + 1) - (at + 1 + key.size()));
  }
  const auto file = dir.write("vendor.eds", eds);
  // When run with it on the EDS checks of the identity object
  const auto result = drivecheck({"run", "--eds", file.string(), "--filter", "eds/od/1018*",
                                  "--json", (dir / "r.json").string()});
  // Then the run goes on (exit 0) and shows the lint findings first
  EXPECT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.err.find("vendor.eds:"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("VendorNumber is empty"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("[identity-empty]"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("finding(s) above; the EDS is used"), std::string::npos) << result.err;
  // And the JSON report carries them under run.eds.findings
  const std::string report = test_support::read_file((dir / "r.json").string());
  const auto findings = report.find("\"findings\"");
  ASSERT_NE(findings, std::string::npos) << report.substr(0, 2000);
  EXPECT_NE(report.find("VendorNumber is empty", findings), std::string::npos);
}

TEST(CliRun, ColourIsOffInAPipeAndOnWithAlways) {
  // Given a small selection run with stdout a pipe
  const std::vector<std::string> run = {"run", "--filter", "cia301/sdo/expedited/*"};
  // When run without --color, with --color always and with --color always under NO_COLOR
  const auto plain = drivecheck(run);
  auto always_args = run;
  always_args.insert(always_args.end(), {"--color", "always"});
  const auto always = drivecheck(always_args);
  // Then the pipe gets no escape sequence, --color always colours the marks, a bad value is a
  //      usage error
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  EXPECT_EQ(plain.out.find('\x1b'), std::string::npos) << plain.out;
  ASSERT_EQ(always.exit_code, 0) << always.err;
  EXPECT_NE(always.out.find("\x1b[32m"), std::string::npos) << always.out;
  expect_usage_error(drivecheck({"run", "--color", "sometimes"}), "--color");
}

}  // namespace
}  // namespace drivecheck
