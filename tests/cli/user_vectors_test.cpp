// `--vectors DIR`: a user's own vectors, drive profile and manual list beside the shipped ones,
// in run, vectors lint, vectors list, profiles, fuzz and drive; what collides with the shipped
// tree, and a manual that is not there, are file:line errors.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "conformance/sha256.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck {
namespace {

using test_support::CommandResult;
using test_support::read_file;
using test_support::run_command;
using test_support::TempDir;

CommandResult drivecheck(std::vector<std::string> args) {
  args.insert(args.begin(), DRIVECHECK_EXE);
  return run_command(args);
}

void write(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// The user's manual: 6 lines of text.
constexpr const char* kManual =
    "My Drive 3000 CANopen manual, edition 2\n"
    "1 Objects\n"
    "1000h device type reads 00020192h.\n"
    "2 Deviations\n"
    "Transition 16 is not supported.\n"
    "End.\n";

// A user directory: one vector citing the user's manual, a profile citing it, and a manual
// list with the manual's sha256; the manual beside it.
class UserVectors : public ::testing::Test {
 protected:
  void SetUp() override {
    write(mine() / "my-drive-manual.txt", kManual);
    write(mine() / "manuals.yaml",
          "- file: my-drive-manual.txt\n"
          "  device: \"My Drive 3000\"\n"
          "  title: \"My Drive 3000 CANopen manual\"\n"
          "  edition: \"edition 2 (L1)\"\n"
          "  sha256: " +
              conformance::sha256_hex(std::string_view(kManual)) +
              "\n"
              "  lines: 6\n");
    write(mine() / "my.yaml",
          "- id: mine/device-type\n"
          "  title: \"1000h reads the device type the manual gives\"\n"
          "  source: \"my-drive-manual.txt §1 L3-3\"\n"
          "  steps:\n"
          "    - sdo_read: {index: 0x1000, sub: 0}\n");
    write(mine() / "drives" / "my-drive.yaml",
          "name: my-drive\n"
          "title: \"My Drive 3000 (a user's profile)\"\n"
          "manual: my-drive-manual.txt\n"
          "features: [sdo.expedited, cia402]\n"
          "deviations:\n"
          "  - id: no-transition-16\n"
          "    vectors: [{id: \"mine/device-type\", observed: {value: 131474}}]\n"
          "    source: \"my-drive-manual.txt §2 L5-5\"\n"
          "    description: \"Transition 16 is not supported.\"\n");
  }
  std::filesystem::path mine() const { return dir_ / "mine"; }
  TempDir dir_;
};

// The first vector id of a shipped file and its line.
std::pair<std::string, int> first_shipped_id(const std::string& relative) {
  std::ifstream in(std::string(DRIVECHECK_SOURCE_DIR) + "/vectors/" + relative);
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.rfind("- id: ", 0) == 0) return {line.substr(6), number};
  }
  return {"", 0};
}

TEST_F(UserVectors, LintAcceptsTheUsersVectorProfileAndManual) {
  // Given the user directory
  // When the shipped tree is linted with it
  const auto lint = drivecheck({"vectors", "lint", "--vectors", mine().string()});
  // Then it lints clean and says that the user's manual was checked
  EXPECT_EQ(lint.exit_code, 0) << lint.out << lint.err;
  EXPECT_NE(lint.out.find("1 manual(s) of --vectors checked"), std::string::npos) << lint.out;
  EXPECT_NE(lint.out.find("0 error(s)"), std::string::npos) << lint.out;
}

TEST_F(UserVectors, ListShowsTheUsersVectorBesideTheShippedOnes) {
  // Given the user directory
  // When the vectors are listed with it
  const auto list = drivecheck({"vectors", "list", "--vectors", mine().string()});
  // Then the user's vector and the shipped ones are listed
  EXPECT_EQ(list.exit_code, 0) << list.err;
  EXPECT_NE(list.out.find("mine/device-type"), std::string::npos);
  EXPECT_NE(list.out.find("cia301/"), std::string::npos);
  const auto profiles = drivecheck({"profiles", "--vectors", mine().string()});
  EXPECT_EQ(profiles.exit_code, 0) << profiles.err;
  EXPECT_NE(profiles.out.find("my-drive "), std::string::npos) << profiles.out;
  EXPECT_NE(profiles.out.find("festo-cmmp "), std::string::npos) << profiles.out;
}

TEST_F(UserVectors, RunTakesTheUsersProfileAndVector) {
  // Given the user directory
  const auto json = (dir_ / "r.json").string();
  // When run with the user's profile on the user's vector (and one shipped family)
  const auto run = drivecheck({"run", "--vectors", mine().string(), "--profile", "my-drive",
                               "--filter", "mine/*", "--filter", "cia301/sdo", "--json", json});
  // Then it runs both, the user's vector passes, and the report names the user's manual
  EXPECT_EQ(run.exit_code, 0) << run.out << run.err;
  const std::string report = read_file(json);
  EXPECT_NE(report.find("\"mine/device-type\""), std::string::npos);
  EXPECT_NE(report.find("\"cia301/sdo\""), std::string::npos);
  EXPECT_NE(report.find("My Drive 3000 CANopen manual"), std::string::npos);
  EXPECT_NE(report.find("my-drive.yaml"), std::string::npos);
}

TEST_F(UserVectors, FuzzAndDriveTakeTheUsersProfile) {
  // Given the user directory
  // When the fuzzer runs briefly on the simulated bus with the user's profile
  const auto fuzz = drivecheck({"fuzz", "--bus", "sim", "--vectors", mine().string(), "--profile",
                                "my-drive", "--duration", "1s", "--out", (dir_ / "fuzz").string()});
  // Then it runs (exit 0: nothing found)
  EXPECT_EQ(fuzz.exit_code, 0) << fuzz.out << fuzz.err;
  // When drive starts with it on an interface this machine cannot open
  const auto drive = drivecheck({"drive", "--bus", "socketcan:nosuchcan9", "--node", "5",
                                 "--vectors", mine().string(), "--profile", "my-drive"});
  // Then the profile is accepted: the only complaint is the interface
  EXPECT_EQ(drive.exit_code, 2);
  EXPECT_EQ(drive.err.find("profile"), std::string::npos) << drive.err;
  EXPECT_NE(drive.err.find("nosuchcan9"), std::string::npos) << drive.err;
}

TEST_F(UserVectors, AVectorIdOfTheShippedTreeIsAnErrorNamingBoth) {
  // Given a user vector with the id of the first vector of vectors/cia301/bus_off.yaml
  const auto [id, line] = first_shipped_id("cia301/bus_off.yaml");
  ASSERT_FALSE(id.empty());
  write(mine() / "dup.yaml", "# a copy\n- id: " + id +
                                 "\n  title: t\n  source: \"CiA 301 §1\"\n  steps: [{wait: "
                                 "1ms}]\n");
  // When linted, run, listed and fuzzed with it
  const auto lint = drivecheck({"vectors", "lint", "--vectors", mine().string()});
  const auto run = drivecheck({"run", "--vectors", mine().string()});
  const auto list = drivecheck({"vectors", "list", "--vectors", mine().string()});
  const auto fuzz = drivecheck({"fuzz", "--bus", "sim", "--vectors", mine().string(), "--duration",
                                "1s", "--out", (dir_ / "fuzz").string()});
  // Then each exits 2 with the user's file:line and the shipped file:line
  const std::string user_at = (mine() / "dup.yaml").string() + ":2";
  const std::string shipped_at = "vectors/cia301/bus_off.yaml:" + std::to_string(line);
  for (const auto* result : {&lint, &run, &list, &fuzz}) {
    EXPECT_EQ(result->exit_code, 2) << result->err;
    EXPECT_NE(result->err.find(user_at), std::string::npos) << result->err;
    EXPECT_NE(result->err.find("'" + id + "' is already defined at " + shipped_at),
              std::string::npos)
        << result->err;
  }
}

TEST_F(UserVectors, AProfileNameOfTheShippedTreeIsAnErrorNamingBoth) {
  // Given a user profile named like a shipped one (cia402-reference, `name:` on line 2)
  write(mine() / "drives" / "cia402-reference.yaml",
        "# mine\nname: cia402-reference\ntitle: \"mine\"\nfeatures: [sdo.expedited]\n");
  // When linted, run, and used by fuzz and drive
  const auto lint = drivecheck({"vectors", "lint", "--vectors", mine().string()});
  const auto run = drivecheck({"run", "--vectors", mine().string()});
  const auto fuzz = drivecheck({"fuzz", "--bus", "sim", "--vectors", mine().string(), "--duration",
                                "1s", "--out", (dir_ / "fuzz").string()});
  const auto drive = drivecheck({"drive", "--bus", "socketcan:nosuchcan9", "--node", "5",
                                 "--vectors", mine().string(), "--profile", "cia402-reference"});
  // Then each exits 2 naming the user's file:2 and the shipped profile's file:line of its name
  const std::string user_at = (mine() / "drives" / "cia402-reference.yaml").string() + ":2";
  for (const auto* result : {&lint, &run, &fuzz, &drive}) {
    EXPECT_EQ(result->exit_code, 2) << result->err;
    EXPECT_NE(result->err.find(user_at), std::string::npos) << result->err;
    EXPECT_NE(result->err.find("profile 'cia402-reference' is already defined at "),
              std::string::npos)
        << result->err;
    EXPECT_NE(result->err.find("drives/cia402-reference.yaml:6"), std::string::npos) << result->err;
  }
}

TEST_F(UserVectors, AMissingOrChangedManualIsAnErrorAtItsListLine) {
  // Given a manual list naming a second manual that is not there (line 7), and the first
  // manual changed after its sha256 was taken
  std::ofstream(mine() / "manuals.yaml", std::ios::app)
      << "- file: other-manual.txt\n  device: \"other\"\n  sha256: " << std::string(64, 'a')
      << "\n  lines: 3\n";
  std::ofstream(mine() / "my-drive-manual.txt", std::ios::app) << "Appendix.\n";
  // When linted and run
  const auto lint = drivecheck({"vectors", "lint", "--vectors", mine().string()});
  const auto run = drivecheck({"run", "--vectors", mine().string()});
  // Then both exit 2 with manuals.yaml:7 (missing) and manuals.yaml:1 (changed)
  const std::string list = (mine() / "manuals.yaml").string();
  for (const auto* result : {&lint, &run}) {
    EXPECT_EQ(result->exit_code, 2) << result->err;
    EXPECT_NE(result->err.find(list + ":7: "), std::string::npos) << result->err;
    EXPECT_NE(result->err.find("manual 'other-manual.txt' is not in"), std::string::npos)
        << result->err;
    EXPECT_NE(result->err.find(list + ":1: "), std::string::npos) << result->err;
    EXPECT_NE(result->err.find("the text changed"), std::string::npos) << result->err;
  }
}

TEST_F(UserVectors, ACitationOfAnUnlistedManualIsAnErrorAtTheVectorLine) {
  // Given a user vector citing a manual no list names (source on line 3)
  write(mine() / "unlisted.yaml",
        "- id: mine/unlisted\n  title: t\n  source: \"nowhere.txt §1 L1-2\"\n"
        "  steps: [{wait: 1ms}]\n");
  // When linted
  const auto lint = drivecheck({"vectors", "lint", "--vectors", mine().string()});
  // Then it exits 2 naming the vector's file:3
  EXPECT_EQ(lint.exit_code, 2);
  EXPECT_NE(lint.err.find((mine() / "unlisted.yaml").string() +
                          ":3: error: source 'nowhere.txt §1 L1-2': manual 'nowhere.txt' is not "
                          "listed"),
            std::string::npos)
      << lint.err;
}

}  // namespace
}  // namespace drivecheck
