// What the engine records for the reports (conformance/result.hpp), against scripted peers on
// the simulated bus: Ctrl-C gives the running vector the verdict `interrupted` (not a failure);
// frames that arrive between vectors are kept apart from the next vector's evidence; steps are
// numbered from 1 in the checks and the message; the message's first line says it all.
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <regex>
#include <string>

#include "conformance/engine.hpp"
#include "conformance/provenance.hpp"
#include "conformance/sha256.hpp"
#include "conformance/vector_file.hpp"
#include "protocol/can/sim_bus.hpp"
#include "tests/support/scripted_peer.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::conformance {
namespace {

// Scripted peers answer exactly the frames of their script: no isolation snapshot/restore.
EngineOptions scripted() {
  EngineOptions options;
  options.isolation = false;
  return options;
}

using namespace std::chrono_literals;

profile::DriveProfile make_profile() {
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [sdo.segmented]\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return *parsed;
}

// A vector without setup (scripted peers do not boot), with `steps` (YAML, indented 4).
Vector make_vector(const std::string& steps) {
  const auto set = parse_vectors(
      "- id: t/x/y\n  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n  steps:\n" +
          steps,
      "t.yaml");
  EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
  return set.vectors.empty() ? Vector{} : set.vectors.front();
}

class RunResultTest : public ::testing::Test {
 protected:
  RunResultTest()
      : harness_(bus_.attach("harness")),
        peer_port_(bus_.attach("peer")),
        profile_(make_profile()) {}

  can::SimBus bus_{{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> harness_;
  std::unique_ptr<can::SimPort> peer_port_;
  profile::DriveProfile profile_;
};

TEST_F(RunResultTest, CtrlCDuringAVectorIsInterruptedNotAFailure) {
  // Given a peer that does not answer a read, and Ctrl-C 1 ms into the vector
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#4041600000000000");  // ccs=2 initiate upload, 6041h sub 0; no answer
  Engine engine(*harness_, profile_, scripted());
  peer_port_->start_timer_after(1ms, [&engine] { engine.interrupt(); });
  // When the vector runs
  const auto result =
      engine.run_vector(make_vector("    - send: \"600+N#4041600000000000\"\n    - expect_frame: "
                                    "\"580+N#4B416000....0000\"\n      within: 10ms\n"));
  // Then its verdict is interrupted, in step 2 (the wait), and it counts neither as passed
  // nor failed
  EXPECT_EQ(result.verdict, Verdict::interrupted) << result.message;
  EXPECT_NE(result.message.find("interrupted by the user in step 2"), std::string::npos)
      << result.message;
  RunResult run;
  run.vectors.push_back(result);
  const auto counts = run.counts();
  EXPECT_EQ(counts[Tally::interrupted], 1U);
  EXPECT_EQ(counts[Tally::fail] + counts[Tally::error] + counts[Tally::pass], 0U);
}

TEST_F(RunResultTest, CtrlCDuringTheObjectScanIsInterruptedNotAPass) {
  // Given no device answering (every upload times out, which the scan takes as absent), and
  //       Ctrl-C 1 ms into the scan of undocumented objects
  Engine engine(*harness_, profile_, scripted());
  harness_->start_timer_after(1ms, [&engine] { engine.interrupt(); });
  // When the scan runs
  const auto result =
      engine.probe_undocumented_objects([](std::uint16_t) { return false; }, "EDS test.eds");
  // Then the partial scan is no verdict
  EXPECT_EQ(result.verdict, Verdict::interrupted) << result.message;
}

TEST_F(RunResultTest, LateFrameOfTheVectorBeforeIsBetweenVectors) {
  // Given a peer that aborts a write at once and again 5 ms later (a late duplicate), then
  // answers a read
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#2B41600000000000")             // ccs=1 n=2 e=1 s=1, 6041h sub 0, data 0000h
      .reply("581#8041600002000106")              // abort 6041h sub 0, 06010002h
      .reply_after(5ms, "581#8041600002000106");  // the same abort, late
  peer.expect("601#4041600000000000")             // ccs=2 initiate upload, 6041h sub 0
      .reply("581#4B41600040020000");             // scs=2 n=2 e=1 s=1, data 0240h
  Engine engine(*harness_, profile_, scripted());
  const auto first = engine.run_vector(
      make_vector("    - sdo_write: {index: 0x6041, sub: 0, value: 0, size: 2}\n      expect: "
                  "{abort: [0x06010002]}\n"));
  // When time passes between the vectors (the late abort arrives) and the next vector runs
  bus_.run_for(10ms);
  const auto second = engine.run_vector(
      make_vector("    - sdo_read: {index: 0x6041, sub: 0}\n      expect: {value: 0x240}\n"));
  // Then the late abort is shown between the vectors, and the second vector's evidence begins
  // with its own request
  EXPECT_EQ(first.verdict, Verdict::pass) << first.message;
  EXPECT_EQ(second.verdict, Verdict::pass) << second.message;
  ASSERT_EQ(second.between_vectors.size(), 1U);
  EXPECT_EQ(can::to_candump(second.between_vectors[0].frame), "581#8041600002000106");
  ASSERT_EQ(second.frames.size(), 2U);
  EXPECT_TRUE(second.frames[0].from_harness);
  EXPECT_EQ(can::to_candump(second.frames[1].frame), "581#4B41600040020000");
  EXPECT_TRUE(peer.finished());
}

TEST_F(RunResultTest, StepsAreNumberedFromOneAndTheMessageIsOneLine) {
  // Given a peer that accepts two writes, the second of which the vector expects refused
  test_support::ScriptedPeer peer(*peer_port_);
  for (int i = 0; i < 2; ++i) {
    peer.expect("601#2B40600000000000")  // ccs=1 n=2 e=1 s=1, 6040h sub 0, data 0000h
        .reply("581#6040600000000000");  // scs=3 download response, 6040h sub 0
  }
  Engine engine(*harness_, profile_, scripted());
  const auto vector = make_vector(
      "    - sdo_write: {index: 0x6040, sub: 0, value: 0, size: 2}\n"
      "    - sdo_write: {index: 0x6040, sub: 0, value: 0, size: 2}\n"
      "      expect: {abort: [0x06010002]}\n");
  // When the vector runs
  const auto result = engine.run_vector(vector);
  // Then the checks are steps 1 and 2, and the message's first line names the file and line
  // of step 2 with Expected and Actual
  ASSERT_EQ(result.verdict, Verdict::fail);
  ASSERT_EQ(result.checks.size(), 2U);
  EXPECT_EQ(result.checks[0].step, 1U);
  EXPECT_EQ(result.checks[1].step, 2U);
  EXPECT_TRUE(result.checks[1].at.has_value());
  const std::string first_line = result.message.substr(0, result.message.find('\n'));
  const std::regex one_line("^t\\.yaml:" + std::to_string(vector.steps[1].line) +
                            ": step 2 sdo_write: Expected .+; Actual .+$");
  EXPECT_TRUE(std::regex_match(first_line, one_line)) << first_line;
  EXPECT_NE(result.message.find("\n  Expected: "), std::string::npos) << result.message;
}

TEST(VectorSetDigest, DependsOnPathsAndBytesNotOnOrderOrLocation) {
  // Given two directories with the same vector files, written in opposite orders, and a
  //       non-YAML file in one of them
  test_support::TempDir a;
  test_support::TempDir b;
  for (const auto* dir : {&a, &b}) {
    std::filesystem::create_directories(dir->path() / "cia301");
    std::filesystem::create_directories(dir->path() / "drives");
  }
  a.write("cia301/sdo.yaml", "- id: x\n");
  a.write("drives/p.yaml", "name: p\n");
  a.write("README.md", "not part of the set\n");
  b.write("drives/p.yaml", "name: p\n");
  b.write("cia301/sdo.yaml", "- id: x\n");
  // When their digests are taken
  const auto digest_a = vector_set_digest(a.path());
  const auto digest_b = vector_set_digest(b.path());
  ASSERT_TRUE(digest_a) << digest_a.error();
  ASSERT_TRUE(digest_b) << digest_b.error();
  // Then they are equal, cover the two YAML files, and are the sha256 of the sorted
  //      sha256sum lines (the shell recipe in provenance.hpp)
  EXPECT_EQ(digest_a->sha256, digest_b->sha256);
  EXPECT_EQ(digest_a->files, 2U);
  const std::string listing = sha256_hex(std::string_view("- id: x\n")) + "  cia301/sdo.yaml\n" +
                              sha256_hex(std::string_view("name: p\n")) + "  drives/p.yaml\n";
  EXPECT_EQ(digest_a->sha256, sha256_hex(listing));
  // And a changed byte changes it
  b.write("drives/p.yaml", "name: q\n");
  EXPECT_NE(vector_set_digest(b.path())->sha256, digest_a->sha256);
}

TEST(CitedDocuments, StandardsThenManualsWithTitleAndEdition) {
  // Given a manual list with a titled manual and one with only its device
  test_support::TempDir dir;
  const auto sha = std::string(64, 'a');
  const auto path = dir.write("manuals.yaml",
                              "- file: m.txt\n  device: D\n  title: \"T\"\n  edition: \"E 1\"\n"
                              "  sha256: " +
                                  sha +
                                  "\n  lines: 3\n"
                                  "- file: n.txt\n  device: N\n  sha256: " +
                                  sha + "\n  lines: 3\n");
  // When the cited documents are listed
  const auto documents = cited_documents(path);
  // Then the standards come first with their editions, then each manual
  ASSERT_EQ(documents.size(), kCitedStandards.size() + 2);
  EXPECT_EQ(documents[0].key, "CiA 301");
  EXPECT_EQ(documents[0].edition, "v4.2.0 (2011-02-21)");
  EXPECT_EQ(documents[kCitedStandards.size()].title, "T");
  EXPECT_EQ(documents[kCitedStandards.size()].edition, "E 1");
  EXPECT_EQ(documents[kCitedStandards.size() + 1].title, "N");
}

}  // namespace
}  // namespace drivecheck::conformance
