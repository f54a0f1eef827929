// What the DUT has (conformance/capabilities.hpp) and how it decides applicability
// (conformance/verdict.hpp): object needs from the EDS or an upload, detected features, the
// generic profile chosen from 1000h. The probes talk to a scripted device (FakeDevice).
#include "conformance/capabilities.hpp"

#include <gtest/gtest.h>

#include <map>
#include <utility>

#include "conformance/verdict.hpp"
#include "protocol/cia301/object_dictionary.hpp"

namespace drivecheck::conformance {
namespace {

// A device that answers uploads from a map: (index, sub) -> data, or an abort code; anything
// else goes unanswered. Downloads are recorded and answered from `refuse` (abort) or ok.
class FakeDevice final : public DeviceProbe {
 public:
  std::map<std::pair<std::uint16_t, std::uint8_t>, std::vector<std::uint8_t>> objects;
  std::map<std::pair<std::uint16_t, std::uint8_t>, std::uint32_t> aborts;
  std::map<std::pair<std::uint16_t, std::uint8_t>, std::uint32_t> refuse;
  std::vector<std::pair<std::pair<std::uint16_t, std::uint8_t>, std::vector<std::uint8_t>>>
      downloads;
  std::optional<bool> guarding;
  bool block = false;
  int uploads = 0;

  Answer upload(std::uint16_t index, std::uint8_t sub) override {
    ++uploads;
    if (auto it = objects.find({index, sub}); it != objects.end()) return {true, it->second, {}};
    if (auto it = aborts.find({index, sub}); it != aborts.end()) return {false, {}, it->second};
    return {};
  }
  Answer block_upload(std::uint16_t index, std::uint8_t sub) override {
    if (!block) return {false, {}, 0x05040001};
    return upload(index, sub);
  }
  Answer download(std::uint16_t index, std::uint8_t sub,
                  std::span<const std::uint8_t> data) override {
    downloads.push_back({{index, sub}, {data.begin(), data.end()}});
    if (auto it = refuse.find({index, sub}); it != refuse.end()) return {false, {}, it->second};
    objects[{index, sub}] = {data.begin(), data.end()};
    return {true, {}, {}};
  }
  std::optional<bool> guarding_answered() override { return guarding; }
};

profile::DriveProfile generic_profile() {
  auto parsed = profile::parse_profile(
      "name: g\ntitle: G\nfeatures: [sdo.expedited]\n"
      "detect: [heartbeat.producer, emcy.history, pdo.dynamic-mapping, mode.pp, mode.csp, "
      "nmt.guarding, sdo.block]\n",
      {.file_name = "g.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return *parsed;
}

Vector needing(std::vector<std::string> requires_features) {
  Vector vector;
  vector.id = "t/v";
  vector.requires_features = std::move(requires_features);
  return vector;
}

constexpr profile::ObjectNeed k1029{0x1029, std::nullopt};

TEST(Unless, AClaimedFeatureMakesTheVectorNotApplicable) {
  // Given a vector with unless: [pdo.dummy-mapping] and two profiles, one claiming it
  Vector vector = needing({"pdo"});
  vector.unless_features = {"pdo.dummy-mapping"};
  auto claims = profile::parse_profile(
      "name: c\ntitle: C\nfeatures: [sdo.expedited, pdo, pdo.dummy-mapping]\n",
      {.file_name = "c.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(claims) << claims.error().to_string();
  auto lacks = profile::parse_profile(
      "name: l\ntitle: L\nfeatures: [sdo.expedited, pdo]\n",
      {.file_name = "l.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(lacks) << lacks.error().to_string();
  ApplicabilityContext context;
  // When applicability is decided
  // Then the claiming profile makes it not applicable, saying why; the other runs it
  EXPECT_EQ(not_applicable_reason(vector, *claims, context),
            "profile c claims pdo.dummy-mapping: the vector for such a device judges it (unless:)");
  EXPECT_EQ(not_applicable_reason(vector, *lacks, context), "");
}

TEST(ObjectPresence, UploadAnswered06020000IsAbsentAndTheVectorNotApplicable) {
  // Given a device that answers 1029h with "object does not exist"
  FakeDevice device;
  device.aborts[{0x1029, 0}] = 0x06020000;
  Capabilities capabilities;
  // When the need is probed and a vector needing it is checked
  capabilities.probe(device, {k1029}, {}, std::nullopt);
  ApplicabilityContext context;
  context.capabilities = &capabilities;
  // Then the vector is not applicable and the reason says how absence was known
  EXPECT_EQ(not_applicable_reason(needing({"object.1029"}), generic_profile(), context),
            "needs object 1029h: absent (upload answered 06020000h)");
}

TEST(ObjectPresence, MissingSubIndexIsAbsentOtherAbortsArePresent) {
  // Given 1018h sub 2 missing (06090011h) and 1029h write-only (06010001h)
  FakeDevice device;
  device.aborts[{0x1018, 2}] = 0x06090011;
  device.aborts[{0x1029, 0}] = 0x06010001;
  Capabilities capabilities;
  // When both are probed
  capabilities.probe(device, {{0x1018, 2}, k1029}, {}, std::nullopt);
  // Then the missing sub is absent, the object that answered another abort present
  EXPECT_EQ(capabilities.object({0x1018, 2}).presence, Presence::absent);
  EXPECT_EQ(capabilities.object(k1029).presence, Presence::present);
}

TEST(ObjectPresence, NoAnswerIsUnknownTheVectorRunsAndANoteSaysSo) {
  // Given a device that does not answer the upload of 1029h
  FakeDevice device;
  Capabilities capabilities;
  // When probed
  capabilities.probe(device, {k1029}, {}, std::nullopt);
  ApplicabilityContext context;
  context.capabilities = &capabilities;
  // Then the vector applies and the harness notes name the object
  EXPECT_EQ(not_applicable_reason(needing({"object.1029"}), generic_profile(), context), "");
  ASSERT_EQ(capabilities.notes().size(), 1U);
  EXPECT_NE(capabilities.notes()[0].find("1029h"), std::string::npos);
}

TEST(ObjectPresence, ProbedOncePerRun) {
  // Given a need already probed
  FakeDevice device;
  device.objects[{0x1029, 0}] = {0};
  Capabilities capabilities;
  capabilities.probe(device, {k1029}, {}, std::nullopt);
  const int after_first = device.uploads;
  // When probed again; Then the device is not asked again
  capabilities.probe(device, {k1029}, {}, std::nullopt);
  EXPECT_EQ(device.uploads, after_first);
  EXPECT_EQ(after_first, 1);
}

TEST(ObjectPresence, TheEdsDecidesWithoutAskingTheDevice) {
  // Given an EDS dictionary with 1008h but not 1029h
  cia301::ObjectDictionary eds;
  ASSERT_TRUE(eds.add_var(0x1008, "device name", cia301::DataType::visible_string,
                          cia301::AccessType::constant));
  FakeDevice device;
  Capabilities capabilities(&eds);
  // When the needs are probed
  capabilities.probe(device, {k1029, {0x1008, std::nullopt}}, {}, std::nullopt);
  ApplicabilityContext context;
  context.capabilities = &capabilities;
  // Then 1029h is absent "not in the EDS", 1008h present, and the device was never asked
  EXPECT_EQ(not_applicable_reason(needing({"object.1029"}), generic_profile(), context),
            "needs object 1029h: absent (not in the EDS)");
  EXPECT_EQ(not_applicable_reason(needing({"object.1008"}), generic_profile(), context), "");
  EXPECT_EQ(device.uploads, 0);
}

TEST(DetectedFeatures, HeartbeatProducerIs1017hReadAndWrittenBack) {
  // Given a device whose 1017h reads 0 and takes the value back
  FakeDevice device;
  device.objects[{0x1017, 0}] = {0, 0};
  Capabilities capabilities;
  // When heartbeat.producer is detected
  capabilities.probe(device, {}, {"heartbeat.producer"}, std::nullopt);
  // Then present, and the write put back exactly what was read
  EXPECT_EQ(capabilities.feature("heartbeat.producer").presence, Presence::present);
  ASSERT_EQ(device.downloads.size(), 1U);
  EXPECT_EQ(device.downloads[0].second, (std::vector<std::uint8_t>{0, 0}));
}

TEST(DetectedFeatures, AbsentFeatureMakesItsVectorsNotApplicable) {
  // Given a device without 1003h (no error history) and a profile that detects emcy.history
  FakeDevice device;
  device.aborts[{0x1003, 0}] = 0x06020000;
  Capabilities capabilities;
  const auto profile = generic_profile();
  // When probed and a vector requiring emcy.history is checked
  capabilities.probe(device, {}, profile.detect, std::nullopt);
  ApplicabilityContext context;
  context.capabilities = &capabilities;
  // Then not applicable with the probe's answer
  EXPECT_EQ(not_applicable_reason(needing({"emcy.history"}), profile, context),
            "requires emcy.history (probed: absent, 1003h: upload answered 06020000h)");
}

TEST(DetectedFeatures, StaticMappingRefusedAndTpdo1PutBack) {
  // Given TPDO1 valid at 181h whose mapping sub 0 refuses writes (static mapping)
  FakeDevice device;
  device.objects[{0x1800, 1}] = {0x81, 0x01, 0x00, 0x40};
  device.objects[{0x1A00, 0}] = {1};
  device.refuse[{0x1A00, 0}] = 0x06010002;
  Capabilities capabilities;
  // When pdo.dynamic-mapping is detected
  capabilities.probe(device, {}, {"pdo.dynamic-mapping"}, std::nullopt);
  // Then absent (static), and 1800h sub 1 ends as it was: invalid first, then put back
  EXPECT_EQ(capabilities.feature("pdo.dynamic-mapping").presence, Presence::absent);
  ASSERT_EQ(device.downloads.size(), 3U);
  EXPECT_EQ(device.downloads[0].second, (std::vector<std::uint8_t>{0x81, 0x01, 0x00, 0xC0}));
  EXPECT_EQ(device.downloads.back().second, (std::vector<std::uint8_t>{0x81, 0x01, 0x00, 0x40}));
  const auto& tpdo1_cob = device.objects[{0x1800, 1}];
  EXPECT_EQ(tpdo1_cob, (std::vector<std::uint8_t>{0x81, 0x01, 0x00, 0x40}));
}

TEST(DetectedFeatures, DynamicMappingAccepted) {
  // Given TPDO1 whose mapping sub 0 takes a write while the PDO is invalid
  FakeDevice device;
  device.objects[{0x1800, 1}] = {0x81, 0x01, 0x00, 0x00};
  device.objects[{0x1A00, 0}] = {2};
  Capabilities capabilities;
  // When detected; Then present
  capabilities.probe(device, {}, {"pdo.dynamic-mapping"}, std::nullopt);
  EXPECT_EQ(capabilities.feature("pdo.dynamic-mapping").presence, Presence::present);
}

TEST(DetectedFeatures, ModesFrom6502h) {
  // Given 6502h with pp (bit 0) and csv (bit 8)
  FakeDevice device;
  device.objects[{0x6502, 0}] = {0x01, 0x01, 0x00, 0x00};
  Capabilities capabilities;
  // When pp, csp and csv are detected
  capabilities.probe(device, {}, {"mode.pp", "mode.csp", "mode.csv"}, 0x00020192);
  // Then pp and csv present, csp absent; 6502h read once
  EXPECT_EQ(capabilities.feature("mode.pp").presence, Presence::present);
  EXPECT_EQ(capabilities.feature("mode.csv").presence, Presence::present);
  EXPECT_EQ(capabilities.feature("mode.csp").presence, Presence::absent);
  EXPECT_EQ(device.uploads, 1);
}

TEST(DetectedFeatures, GuardingByRemoteFrameWhen100ChIsMissing) {
  // Given a device without 100Ch that answers a guarding request
  FakeDevice device;
  device.aborts[{0x100C, 0}] = 0x06020000;
  device.guarding = true;
  Capabilities capabilities;
  // When nmt.guarding is detected; Then present, and the description says how
  capabilities.probe(device, {}, {"nmt.guarding"}, std::nullopt);
  EXPECT_EQ(capabilities.feature("nmt.guarding").presence, Presence::present);
  EXPECT_NE(capabilities.feature("nmt.guarding").how.find("700h+N"), std::string::npos);
}

TEST(DetectedFeatures, BlockTransferRefusedIsAbsent) {
  // Given a device that aborts a block upload initiate with 05040001h
  FakeDevice device;
  device.objects[{0x1000, 0}] = {0x91, 0x01, 0x00, 0x00};
  Capabilities capabilities;
  // When sdo.block is detected; Then absent
  capabilities.probe(device, {}, {"sdo.block"}, std::nullopt);
  EXPECT_EQ(capabilities.feature("sdo.block").presence, Presence::absent);
}

TEST(DetectedFeatures, EveryDetectableFeatureHasAProbe) {
  // Given a device that answers nothing
  FakeDevice device;
  Capabilities capabilities;
  std::set<std::string> all;
  for (auto name : profile::detectable_features())
    all.emplace(name);
  // When every detectable feature is probed
  capabilities.probe(device, {}, all, 0x00020192);
  // Then none falls through to "no probe for this feature"
  for (const auto& name : all)
    EXPECT_NE(capabilities.feature(name).how, "no probe for this feature") << name;
}

TEST(DetectedFeatures, NotProbedDetectedFeatureStillApplies) {
  // Given no probe at all (a single vector run)
  const auto profile = generic_profile();
  // When checked without capabilities; Then a detected feature does not make it N/A
  EXPECT_EQ(not_applicable_reason(needing({"emcy.history"}), profile, {}), "");
  // and a feature neither claimed nor detected does
  EXPECT_EQ(not_applicable_reason(needing({"store"}), profile, {}),
            "requires store (profile g lacks it)");
}

TEST(GenericProfile, ChosenFrom1000h) {
  // Given 1000h values of a CiA 402 drive, a CiA 401 I/O module and no answer
  // When chosen; Then cia402-device for 402 only, cia301-device otherwise, with the reason
  const auto drive = choose_generic_profile(0x00020192);
  EXPECT_EQ(drive.name, "cia402-device");
  EXPECT_NE(drive.why.find("00020192h"), std::string::npos);
  EXPECT_EQ(choose_generic_profile(0x000F0191).name, "cia301-device");
  EXPECT_EQ(choose_generic_profile(std::nullopt).name, "cia301-device");
  EXPECT_NE(choose_generic_profile(std::nullopt).why.find("could not be read"), std::string::npos);
}

}  // namespace
}  // namespace drivecheck::conformance
