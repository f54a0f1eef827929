// The EDS checks (conformance/od_checks.hpp) against the reference drive's CiA 301 device on the
// simulated bus: the live object dictionary cross-check (defaults after reset, write-back, sub
// FFh, 1018h) passing against the drive's own EDS and failing against a mismatching EDS or a
// drive with a named deviation; the eds/lint results of a clean and a broken EDS.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>

#include "conformance/engine.hpp"
#include "conformance/od_checks.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/cia306/eds_lint.hpp"
#include "reference_drive/device.hpp"
#include "reference_drive/dictionary.hpp"

namespace drivecheck::conformance {
namespace {

using namespace std::chrono_literals;

profile::DriveProfile plain_profile() {
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [heartbeat.producer, store, restore, pdo, "
      "pdo.dynamic-mapping]\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return *parsed;
}

class EdsChecksTest : public ::testing::Test {
 protected:
  void start(reference_drive::DeviationSet deviations = {}) {
    reference_drive::DriveConfig config;
    config.dictionary.node_id = 1;
    config.deviations = std::move(deviations);
    auto drive = reference_drive::ReferenceDrive::create(*peer_port_, std::move(config));
    ASSERT_TRUE(drive) << drive.error();
    drive_ = std::move(*drive);
    drive_->power_on();
    bus_.run_for(10ms);
    eds_ = reference_drive::reference_eds(drive_->dictionary(), {});
  }
  // The EDS's object dictionary for node 1 (after any change the test made to eds_).
  cia301::ObjectDictionary eds_od() {
    auto od = cia306::to_object_dictionary(eds_, 1, "drive.eds");
    EXPECT_TRUE(od);
    return od ? std::move(*od) : cia301::ObjectDictionary{};
  }
  std::vector<Vector> generate(const std::optional<EdsIdentity>& identity = std::nullopt) {
    od_ = std::make_unique<cia301::ObjectDictionary>(eds_od());
    return generate_od_vectors(od_.get(), "drive.eds", profile_, identity);
  }
  static const Vector& find(const std::vector<Vector>& vectors, const std::string& id) {
    const auto it =
        std::find_if(vectors.begin(), vectors.end(), [&](const Vector& v) { return v.id == id; });
    if (it == vectors.end()) throw std::runtime_error(id + " not generated");
    return *it;
  }
  // The first readable PDO-mappable VAR of the EDS (the CiA 301 device's 1001h).
  cia306::EdsObject* mappable_var() {
    for (auto& object : eds_.objects)
      if (object.keys.pdo_mapping && object.keys.object_type == cia301::ObjectCode::var &&
          object.keys.access_type && cia301::is_readable(*object.keys.access_type))
        return &object;
    return nullptr;
  }
  static bool has(const std::vector<Vector>& vectors, const std::string& id) {
    return std::any_of(vectors.begin(), vectors.end(), [&](const Vector& v) { return v.id == id; });
  }
  VectorResult run(const Vector& vector) {
    Engine engine(*harness_, profile_, {});
    return engine.run_vector(vector);
  }

  can::SimBus bus_{{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> harness_ = bus_.attach("harness");
  std::unique_ptr<can::SimPort> peer_port_ = bus_.attach("peer");
  profile::DriveProfile profile_ = plain_profile();
  std::unique_ptr<reference_drive::ReferenceDrive> drive_;
  cia306::Eds eds_;
  std::unique_ptr<cia301::ObjectDictionary> od_;
};

TEST_F(EdsChecksTest, GeneratesTheLiveChecksEachEntryCanHave) {
  // Given the drive's own EDS
  start();
  // When the checks are generated with the identity of [DeviceInfo]
  const auto vectors = generate(EdsIdentity{0x1, 0x2, 0x00010003});
  // Then rw and const entries and ro sub 0 of a record get a default check, ro process values
  //      (1001h, 1018h sub 4) none
  EXPECT_TRUE(has(vectors, "eds/od/1017-00/default"));
  EXPECT_TRUE(has(vectors, "eds/od/1018-00/default"));
  EXPECT_FALSE(has(vectors, "eds/od/1001-00/default"));
  EXPECT_FALSE(has(vectors, "eds/od/1018-04/default"));
  // Then rw entries are written back; 1010h/1011h are not applicable with CiA 301's reason
  EXPECT_TRUE(find(vectors, "eds/od/1017-00/write-back").not_applicable.empty());
  EXPECT_NE(find(vectors, "eds/od/1010-01/write-back").not_applicable.find("§7.5.2.13"),
            std::string::npos);
  EXPECT_NE(find(vectors, "eds/od/1003-00/write-back").not_applicable.find("§7.5.2.4"),
            std::string::npos);
  // Then a valid TPDO's COB-ID may also be refused, from the cob-id-while-valid set
  const auto& cob_id = find(vectors, "eds/od/1800-01/write-back");
  const auto& write = std::get<SdoWriteStep>(cob_id.steps.at(1).action);
  ASSERT_TRUE(write.expect.or_abort);
  EXPECT_EQ(write.expect.or_abort->set, "cob-id-while-valid");
  // Then every object gets its sub FFh check, and 1018h sub 1..3 their identity checks
  EXPECT_TRUE(has(vectors, "eds/od/1018-ff/object-type"));
  EXPECT_TRUE(has(vectors, "eds/od/1017-ff/object-type"));
  EXPECT_TRUE(has(vectors, "eds/identity/vendor-id"));
  EXPECT_TRUE(has(vectors, "eds/identity/product-code"));
  EXPECT_EQ(find(vectors, "eds/identity/revision-major").level, Level::must);
  EXPECT_EQ(find(vectors, "eds/identity/revision-number").level, Level::should);
}

TEST_F(EdsChecksTest, DriveAgreesWithItsOwnEds) {
  // Given the drive and its own EDS
  start();
  const auto& ident = drive_->dictionary();
  const auto vendor = static_cast<std::uint32_t>(ident.find(0x1018, 1)->as_unsigned());
  const auto product = static_cast<std::uint32_t>(ident.find(0x1018, 2)->as_unsigned());
  const auto revision = static_cast<std::uint32_t>(ident.find(0x1018, 3)->as_unsigned());
  const auto vectors = generate(EdsIdentity{vendor, product, revision});
  // When the checks of 1017h, 1018h, 1800h sub 1 and the identity run
  // Then each passes (sub FFh is not implemented: 06090011h is the accepted "not present")
  for (const auto* id :
       {"eds/od/1017-00/default", "eds/od/1017-00/write-back", "eds/od/1018-00/default",
        "eds/od/1800-01/write-back", "eds/od/1800-01/default", "eds/od/1018-ff/object-type",
        "eds/od/1017-ff/object-type", "eds/identity/vendor-id", "eds/identity/product-code",
        "eds/identity/revision-major", "eds/identity/revision-number"}) {
    const auto result = run(find(vectors, id));
    EXPECT_EQ(result.verdict, Verdict::pass) << id << ": " << result.message;
  }
  // And a check N/A by rule says why, without touching the bus
  const auto na = run(find(vectors, "eds/od/1010-01/write-back"));
  EXPECT_EQ(na.verdict, Verdict::not_applicable);
  EXPECT_NE(na.message.find("signature"), std::string::npos) << na.message;
}

TEST_F(EdsChecksTest, DefaultThatDiffersFromTheEdsFails) {
  // Given an EDS whose 1017h DefaultValue (1000 ms) is not the drive's (0: no heartbeat)
  start();
  eds_.find(0x1017)->keys.default_value = "1000";
  const auto vectors = generate();
  // When the default check runs after a reset node
  const auto result = run(find(vectors, "eds/od/1017-00/default"));
  // Then it fails: Expected the EDS's bytes, Actual the drive's
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_NE(result.message.find("data E8 03"), std::string::npos) << result.message;
}

TEST_F(EdsChecksTest, ObjFlagsRefuseReadMakesTheDefaultNotApplicable) {
  // Given an EDS that marks 1017h "refuse read on scan" and "refuse write on download"
  start();
  eds_.find(0x1017)->keys.obj_flags = 0x3;
  const auto vectors = generate();
  // When the default and write-back checks are generated
  // Then both are not applicable, each naming its ObjFlags bit
  EXPECT_NE(find(vectors, "eds/od/1017-00/default").not_applicable.find("ObjFlags bit 1"),
            std::string::npos);
  EXPECT_NE(find(vectors, "eds/od/1017-00/write-back").not_applicable.find("ObjFlags bit 0"),
            std::string::npos);
}

TEST_F(EdsChecksTest, WrongSubFfIsCaught) {
  // Given a drive whose ARRAY/RECORD sub FFh says VAR (deviation od-sub-ff-wrong)
  start(reference_drive::DeviationSet{reference_drive::Deviation::od_sub_ff_wrong});
  const auto vectors = generate();
  // When 1018h's (RECORD) sub FFh check runs
  const auto result = run(find(vectors, "eds/od/1018-ff/object-type"));
  // Then it fails with the value read (7: VAR) as the observation
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  ASSERT_FALSE(result.checks.empty());
  EXPECT_EQ(result.checks.back().observed.value, 7);
}

TEST_F(EdsChecksTest, WrongIdentityIsCaught) {
  // Given an EDS whose ProductNumber is not what the drive's 1018h sub 2 holds
  start();
  const auto product =
      static_cast<std::uint32_t>(drive_->dictionary().find(0x1018, 2)->as_unsigned());
  const auto vectors = generate(EdsIdentity{std::nullopt, product + 1, std::nullopt});
  // When the identity checks are generated and run
  // Then only the product code is checked (the others are not given), and it fails
  EXPECT_FALSE(has(vectors, "eds/identity/vendor-id"));
  const auto result = run(find(vectors, "eds/identity/product-code"));
  EXPECT_EQ(result.verdict, Verdict::fail);
}

TEST_F(EdsChecksTest, TpdoMapIsNotApplicableWhereTheEdsHasNoWoOrRwwMappableEntry) {
  // Given the drive's own EDS (no wo or rww entry with PDOMapping=1)
  start();
  // When the checks are generated
  const auto vectors = generate();
  // Then the one tpdo-map result is not applicable and says why
  EXPECT_NE(find(vectors, "eds/od/tpdo-map").not_applicable.find("PDOMapping=1"),
            std::string::npos);
}

TEST_F(EdsChecksTest, WriteOnlyEntryMappedIntoATpdoFails) {
  // Given an EDS that declares a mappable entry (1001h) write only, while the drive reads it
  start();
  auto* object = mappable_var();
  ASSERT_NE(object, nullptr);
  object->keys.access_type = cia301::AccessType::wo;
  const auto vectors = generate();
  // When its tpdo-map check runs (TPDO1 destroyed, mapping disabled, the entry written)
  EXPECT_FALSE(has(vectors, "eds/od/tpdo-map"));
  const auto& vector = find(vectors, fmt::format("eds/od/{:04x}-00/tpdo-map", object->index));
  EXPECT_EQ(vector.level, Level::must);
  ASSERT_EQ(vector.steps.size(), 3U);
  const auto& destroy = std::get<SdoWriteStep>(vector.steps.at(0).action);
  EXPECT_EQ(destroy.index, 0x1800);
  EXPECT_EQ(destroy.value->literal, 0x80000181);
  const auto result = run(vector);
  // Then it fails: the drive maps it (a wo entry in a TPDO must be refused, not-mappable)
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  EXPECT_FALSE(result.warning);
}

TEST_F(EdsChecksTest, RwwEntryMappedIntoATpdoOnlyWarns) {
  // Given an EDS that declares a mappable entry (1001h) rww (meant for an RPDO; CiA 301 makes
  //       that a hint)
  start();
  auto* object = mappable_var();
  ASSERT_NE(object, nullptr);
  object->keys.access_type = cia301::AccessType::rww;
  const auto vectors = generate();
  // When its tpdo-map check runs on a drive that maps it
  const auto& vector = find(vectors, fmt::format("eds/od/{:04x}-00/tpdo-map", object->index));
  const auto result = run(vector);
  // Then it is a should-level failure: a warning, not a fail
  EXPECT_EQ(vector.level, Level::should);
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  EXPECT_TRUE(result.warning);
}

TEST_F(EdsChecksTest, DefaultMappingNamesAnObjectTheDriveHasOrFails) {
  // Given an EDS whose TPDO1 maps 1001h (the drive has it) and TPDO2 2FFFh (it has not)
  start();
  ASSERT_NE(eds_.find(0x1A01), nullptr);
  const auto sub_one = [&](std::uint16_t index) -> cia306::SubObject* {
    auto* object = eds_.find(index);
    if (object == nullptr) return nullptr;
    for (auto& sub : object->subs)
      if (sub.sub_index == 1) return &sub;
    return nullptr;
  };
  auto* tpdo1 = sub_one(0x1A00);
  auto* tpdo2 = sub_one(0x1A01);
  ASSERT_NE(tpdo1, nullptr);
  ASSERT_NE(tpdo2, nullptr);
  tpdo1->keys.default_value = "0x10010008";
  tpdo2->keys.default_value = "0x2FFF0010";
  const auto vectors = generate();
  // When the mapped-object checks run
  const auto present = run(find(vectors, "eds/od/1a00-01/mapped-object"));
  const auto absent = run(find(vectors, "eds/od/1a01-01/mapped-object"));
  // Then the first passes and the second fails; an empty entry (0) gets no check
  EXPECT_EQ(present.verdict, Verdict::pass) << present.message;
  EXPECT_EQ(absent.verdict, Verdict::fail) << absent.message;
  EXPECT_FALSE(has(vectors, "eds/od/1a02-01/mapped-object"));
}

TEST_F(EdsChecksTest, ResetCommunicationRestoresTheCommunicationArea) {
  // Given the drive and its own EDS
  start();
  const auto vectors = generate();
  const auto& vector = find(vectors, "eds/od/reset-communication");
  // When the reset-communication check runs (1017h among the values written before)
  EXPECT_NE(vector.note.find("1017h sub 0"), std::string::npos) << vector.note;
  const auto result = run(vector);
  // Then every writable entry of 1000h-1FFFh is back to its power-on value
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
}

TEST_F(EdsChecksTest, ResetCommunicationThatKeepsValuesFails) {
  // Given a drive whose reset communication keeps the communication objects as written
  start(reference_drive::DeviationSet{
      reference_drive::Deviation::nmt_reset_communication_keeps_values});
  const auto vectors = generate();
  // When the reset-communication check runs
  const auto result = run(find(vectors, "eds/od/reset-communication"));
  // Then it fails
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
}

TEST(EdsLintResults, CleanEdsPassesEveryRule) {
  // Given no findings
  const auto profile = plain_profile();
  // When the lint results are made
  const auto results = eds_lint_results({}, "drive.eds", profile, false);
  // Then there is one per rule plus the reader's, all passing, citing the rule's clause
  EXPECT_EQ(results.size(), cia306::lint_rules().size() + 1);
  for (const auto& result : results) {
    EXPECT_EQ(result.verdict, Verdict::pass) << result.id;
    EXPECT_EQ(result.id.rfind("eds/lint/", 0), 0U) << result.id;
    EXPECT_EQ(result.family, "eds/lint");
    EXPECT_GE(result.sources.size(), 3U) << result.id;
  }
}

TEST(EdsLintResults, ErrorsFailAndWarningsWarn) {
  // Given an EDS without 1001h and with a malformed CreationDate, read with an empty
  //       VendorNumber (a reader warning)
  const std::string text =
      "[FileInfo]\nFileName=x.eds\nEDSVersion=4.0\nCreationDate=2025-01-01\n"
      "[DeviceInfo]\nVendorName=V\nVendorNumber=\nProductName=P\nBaudRate_250=1\n"
      "NrOfRXPDO=0\nNrOfTXPDO=0\n"
      "[MandatoryObjects]\nSupportedObjects=2\n1=0x1000\n2=0x1018\n"
      "[1000]\nParameterName=Device type\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\n"
      "[1018]\nParameterName=Identity\nObjectType=0x9\nSubNumber=2\n"
      "[1018sub0]\nParameterName=n\nDataType=0x0005\nAccessType=ro\nDefaultValue=1\n"
      "[1018sub1]\nParameterName=Vendor\nDataType=0x0007\nAccessType=ro\nDefaultValue=0\n"
      "[OptionalObjects]\nSupportedObjects=1\n1=0x1017\n"
      "[1017]\nParameterName=HB\nDataType=0x0006\nAccessType=rw\nDefaultValue=0\n";
  auto read = cia306::read_eds(text, "x.eds");
  auto findings = read.diagnostics;
  for (auto& finding : cia306::lint_eds(read.eds, "x.eds"))
    findings.push_back(std::move(finding));
  const auto profile = plain_profile();
  // When the lint results are made, without and with --strict
  const auto results = eds_lint_results(findings, "x.eds", profile, false);
  const auto strict = eds_lint_results(findings, "x.eds", profile, true);
  const auto verdict_of = [](const std::vector<VectorResult>& all, const std::string& id) {
    const auto it =
        std::find_if(all.begin(), all.end(), [&](const VectorResult& r) { return r.id == id; });
    EXPECT_NE(it, all.end()) << id;
    return it == all.end() ? std::pair{Verdict::error, false} : std::pair{it->verdict, it->warning};
  };
  // Then the missing mandatory object fails (must), with the finding's file:line in the message
  EXPECT_EQ(verdict_of(results, "eds/lint/mandatory-object-missing"),
            std::pair(Verdict::fail, false));
  // Then the format warning and the reader's warning are warnings (should), failures with
  //      --strict; a rule without findings passes
  EXPECT_EQ(verdict_of(results, "eds/lint/file-info-format"), std::pair(Verdict::fail, true));
  EXPECT_EQ(verdict_of(results, "eds/lint/reader"), std::pair(Verdict::fail, true));
  EXPECT_EQ(verdict_of(strict, "eds/lint/reader"), std::pair(Verdict::fail, false));
  EXPECT_EQ(verdict_of(results, "eds/lint/pdo-mapping-too-long"), std::pair(Verdict::pass, false));
}

}  // namespace
}  // namespace drivecheck::conformance
