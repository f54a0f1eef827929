// Isolation on EtherCAT (FORMAT.md "Isolation"): the engine learns what a vector wrote from the
// DUT port (CoE downloads: there are no SDO frames to read), so the restore works as on CAN.
// The reference drive as an emulated EtherCAT slave on the simulated segment, with no power
// cycle at reset node (as over veth, where the drive is another process): AL INIT then PREOP
// keeps the dictionary, so only the restore can put a written object back.
// Also the complete access vector (vectors/ethercat/coe.yaml) against the same slave and against
// a port that drops the complete access bit (a slave that ignores it).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "conformance/engine.hpp"
#include "conformance/ethercat_port.hpp"
#include "conformance/vector_file.hpp"
#include "protocol/cia301/data_type.hpp"
#include "tests/support/ethercat_rig.hpp"

namespace drivecheck::conformance {
namespace {

profile::DriveProfile make_profile() {
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [sdo.segmented, coe.complete-access]\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return *parsed;
}

std::vector<Vector> parse(const std::string& text) {
  const auto set = parse_vectors(text, "t.yaml");
  EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
  return set.vectors;
}

// The emulated slave, a master brought up to PREOP, the engine's port and clock: no power cycle.
class EthercatIsolationTest : public ::testing::Test {
 protected:
  void SetUp() override { ASSERT_TRUE(rig_.ready()); }

  // 6065h (following error window) as the master reads it now.
  std::uint32_t window() {
    auto value = rig_.master().sdo_upload(0, {0x6065, 0});
    EXPECT_TRUE(value);
    if (!value) return 0;
    return static_cast<std::uint32_t>(cia301::load_unsigned(*value));
  }

  // A vector that writes 6065h := 1234 and then fails, and one (reset node first) that reads it.
  std::string two_vectors(std::uint32_t before) {
    return fmt::format(
        "- id: t/writes\n  title: t\n  source: \"CiA 301 §1\"\n  transports: [ethercat]\n"
        "  setup: reset-node\n  steps:\n"
        "    - sdo_write: {{index: 0x6065, sub: 0, value: 1234, size: 4}}\n"
        "    - sdo_read: {{index: 0x6065, sub: 0}}\n      expect: {{value: 1}}\n"
        "- id: t/reads\n  title: t\n  source: \"CiA 301 §1\"\n  transports: [ethercat]\n"
        "  setup: reset-node\n  steps:\n"
        "    - sdo_read: {{index: 0x6065, sub: 0}}\n      expect: {{value: {}}}\n",
        before);
  }

  test_support::EthercatRig rig_;
  profile::DriveProfile profile_ = make_profile();
};

TEST_F(EthercatIsolationTest, WrittenObjectIsPutBackOverCoe) {
  // Given the drive's 6065h before, and a vector that writes it over CoE and then fails
  const std::uint32_t before = window();
  ASSERT_NE(before, 1234U);
  const auto vectors = parse(two_vectors(before));
  // When both run on EtherCAT, where a reset node cannot power-cycle the drive
  Engine engine(rig_.clock(), rig_.port(), profile_, {});
  const RunResult result = engine.run(vectors);
  // Then the first fails at its read, the engine put 6065h back (a passing restore check that
  // names it), the second reads the value before, and the drive holds it after the run
  ASSERT_EQ(result.vectors.size(), 2U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::fail) << result.vectors[0].message;
  bool restored = false;
  for (const auto& check : result.vectors[0].checks) {
    restored |= check.ok && check.action == "restore" &&
                check.actual.find("6065h sub 0 := ") != std::string::npos;
  }
  EXPECT_TRUE(restored);
  EXPECT_EQ(result.vectors[1].verdict, Verdict::pass) << result.vectors[1].message;
  EXPECT_EQ(window(), before);
  EXPECT_TRUE(result.harness_notes.empty());
}

TEST_F(EthercatIsolationTest, WithoutIsolationTheWrittenObjectLeaks) {
  // Given the same two vectors (the check that the test above can fail)
  const std::uint32_t before = window();
  const auto vectors = parse(two_vectors(before));
  // When both run without isolation
  EngineOptions options;
  options.isolation = false;
  Engine engine(rig_.clock(), rig_.port(), profile_, options);
  const RunResult result = engine.run(vectors);
  // Then the second vector reads the first one's value: the reset did not bring 6065h back
  ASSERT_EQ(result.vectors.size(), 2U);
  EXPECT_EQ(result.vectors[1].verdict, Verdict::fail);
  EXPECT_EQ(window(), 1234U);
}

// A slave that ignores the complete access bit: every transfer as if the bit were clear.
class IgnoresCompleteAccess final : public DutPort {
 public:
  explicit IgnoresCompleteAccess(EthercatPort& inner) : inner_(inner) {}
  LinkKind link() const override { return inner_.link(); }
  SdoOutcome upload(VectorRun& run, const SdoRequest& request) override {
    return inner_.upload(run, plain(request));
  }
  SdoOutcome download(VectorRun& run, const SdoRequest& request,
                      std::span<const std::uint8_t> data) override {
    return inner_.download(run, plain(request), data);
  }
  std::string reset(bool node) override { return inner_.reset(node); }
  std::string enter_state(cia301::NmtState state) override { return inner_.enter_state(state); }
  VectorResult* set_evidence_sink(VectorResult* sink) override {
    return inner_.set_evidence_sink(sink);
  }

 private:
  static SdoRequest plain(SdoRequest request) {
    if (request.transfer == Transfer::complete_access) request.transfer = Transfer::automatic;
    return request;
  }
  EthercatPort& inner_;
};

// The vector of vectors/ethercat/coe.yaml with this id.
std::vector<Vector> coe_vector(const std::string& id) {
  std::ifstream in(std::string(DRIVECHECK_VECTORS_DIR) + "/ethercat/coe.yaml");
  std::stringstream text;
  text << in.rdbuf();
  std::vector<Vector> out;
  for (auto& vector : parse(text.str())) {
    if (vector.id == id) out.push_back(std::move(vector));
  }
  EXPECT_EQ(out.size(), 1U) << id;
  return out;
}

TEST_F(EthercatIsolationTest, CompleteAccessVectorPassesOnTheEmulatedSlave) {
  // Given the complete access vector and the emulated slave, which implements it
  const auto vectors = coe_vector("ethercat/coe/complete-access/upload-1c12");
  // When it runs on EtherCAT
  Engine engine(rig_.clock(), rig_.port(), profile_, {});
  const RunResult result = engine.run(vectors);
  // Then it passes
  ASSERT_EQ(result.vectors.size(), 1U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << result.vectors[0].message;
}

TEST_F(EthercatIsolationTest, CompleteAccessVectorFailsWhenTheBitIsIgnored) {
  // Given the complete access vector and a slave that answers it as a plain SDO upload
  const auto vectors = coe_vector("ethercat/coe/complete-access/upload-1c12");
  IgnoresCompleteAccess broken(rig_.port());
  // When it runs on EtherCAT
  Engine engine(rig_.clock(), broken, profile_, {});
  const RunResult result = engine.run(vectors);
  // Then it fails (a should-level vector: a warning) at step 4, where sub-index 0 came alone
  ASSERT_EQ(result.vectors.size(), 1U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::fail) << result.vectors[0].message;
  EXPECT_TRUE(result.vectors[0].warning);
  EXPECT_NE(result.vectors[0].message.find("step 4"), std::string::npos)
      << result.vectors[0].message;
}

// ---- cyclic set-points (FORMAT.md "Cyclic set-points") ----

// A vector whose `cyclic` step gives 60B0h (not in the default RxPDO 1600h) only through the
// process data, then reads it back by SDO.
constexpr const char* kCyclicOffset = R"(- id: t/cyclic
  title: t
  source: "CiA 402-2 §1"
  transports: [ethercat]
  setup: reset-node
  nmt: operational
  steps:
    - cyclic: {cycles: 3, period: 10ms}
      set: {index: 0x60B0, sub: 0, value: 77, size: 4}
    - sdo_read: {index: 0x60B0, sub: 0}
      expect: {value: 77}
)";

std::uint64_t read_value(ethercat::Master& master, std::uint16_t index, std::uint8_t sub) {
  auto value = master.sdo_upload(0, {index, sub});
  EXPECT_TRUE(value) << fmt::format("{:04X}h sub {}", index, sub);
  return value ? cia301::load_unsigned(*value) : 0xDEADBEEF;
}

TEST_F(EthercatIsolationTest, CyclicSetPointTravelsInTheOutputsAndTheMappingGoesBack) {
  // Given a vector that gives the position offset 60B0h only in the cyclic outputs, and the
  // slave's RxPDO 1600h (2 entries), 1C32h:01 (free run) and 60B0h before
  ASSERT_EQ(read_value(rig_.master(), 0x1C12, 0), 1U);
  ASSERT_EQ(read_value(rig_.master(), 0x1601, 1), 0x60FF0020U);
  ASSERT_EQ(read_value(rig_.master(), 0x1C32, 1), 0U);
  const auto offset_before = read_value(rig_.master(), 0x60B0, 0);
  ASSERT_NE(offset_before, 77U);
  // When it runs on EtherCAT (no power cycle: only the engine can put things back)
  Engine engine(rig_.clock(), rig_.port(), profile_, {});
  const RunResult result = engine.run(parse(kCyclicOffset));
  // Then the setup mapped 60B0h into 1601h (assigned after 1600h) and made the outputs
  // SM-synchronous, the drive took 77 from the process data, and afterwards assignment,
  // mapping, sync mode and 60B0h are as before
  ASSERT_EQ(result.vectors.size(), 1U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << result.vectors[0].message;
  bool mapped = false;
  for (const auto& check : result.vectors[0].checks) {
    mapped |= check.ok && check.action == "setup cyclic set-points" &&
              check.actual.find("60B0h sub 0 (32 bits) mapped into the RxPDO 1601h") !=
                  std::string::npos &&
              check.actual.find("1C32h:01 := 1") != std::string::npos;
  }
  EXPECT_TRUE(mapped);
  EXPECT_EQ(read_value(rig_.master(), 0x1C12, 0), 1U);
  EXPECT_EQ(read_value(rig_.master(), 0x1601, 0), 1U);
  EXPECT_EQ(read_value(rig_.master(), 0x1601, 1), 0x60FF0020U);
  EXPECT_EQ(read_value(rig_.master(), 0x1C32, 1), 0U);
  EXPECT_EQ(read_value(rig_.master(), 0x60B0, 0), offset_before);
  EXPECT_FALSE(rig_.master().locate(0, {0x60B0, 0}));
  EXPECT_TRUE(result.harness_notes.empty());
}

TEST_F(EthercatIsolationTest, CyclicSetPointWithoutAMappableRxPdoIsNotApplicable) {
  // Given a slave whose RxPDO assignment 1C12h does not exist over CoE (no PDO configuration)
  reference_drive::ethercat::EthercatDriveOptions options;
  profile::CoeRules rules;
  rules.absent_objects = {{0x1C12, 0x1C12}};
  rules.sources = {"t"};
  options.coe = rules;
  test_support::EthercatRig rig(options);
  ASSERT_TRUE(rig.ready());
  // When the vector runs on it
  Engine engine(rig.clock(), rig.port(), profile_, {});
  const RunResult result = engine.run(parse(kCyclicOffset));
  // Then it is not applicable, naming the assignment and the abort
  ASSERT_EQ(result.vectors.size(), 1U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::not_applicable) << result.vectors[0].message;
  EXPECT_NE(result.vectors[0].message.find("1C12h"), std::string::npos)
      << result.vectors[0].message;
  EXPECT_NE(result.vectors[0].message.find("06020000h"), std::string::npos)
      << result.vectors[0].message;
}

// The vectors of vectors/cia402/<file> whose id starts with `prefix`.
std::vector<Vector> tree_vectors(const std::string& file, const std::string& prefix) {
  std::ifstream in(std::string(DRIVECHECK_VECTORS_DIR) + "/cia402/" + file);
  std::stringstream text;
  text << in.rdbuf();
  std::vector<Vector> out;
  for (auto& vector : parse(text.str())) {
    if (vector.id.rfind(prefix, 0) == 0) out.push_back(std::move(vector));
  }
  return out;
}

TEST_F(EthercatIsolationTest, CyclicModeVectorsRunBackToBackWithoutPowerCycle) {
  // Given the csp/csv/cst and ip vectors and the reference profile, on a slave that is not
  // power-cycled between them (as over veth)
  auto reference = profile::find_profile("cia402-reference",
                                         std::filesystem::path(DRIVECHECK_VECTORS_DIR) / "drives");
  ASSERT_TRUE(reference) << reference.error().to_string();
  auto vectors = tree_vectors("cyclic.yaml", "cia402/c");
  auto ip = tree_vectors("ip.yaml", "cia402/ip/");
  vectors.insert(vectors.end(), ip.begin(), ip.end());
  ASSERT_GT(vectors.size(), 20U);
  // When they run one after the other
  Engine engine(rig_.clock(), rig_.port(), *reference, {});
  const RunResult result = engine.run(vectors);
  // Then none fails or errors (each one's cyclic configuration went back before the next)
  for (const auto& v : result.vectors) {
    EXPECT_TRUE(v.verdict == Verdict::pass || v.verdict == Verdict::not_applicable)
        << v.id << ": " << v.message;
  }
  EXPECT_TRUE(result.harness_notes.empty());
}

}  // namespace
}  // namespace drivecheck::conformance
