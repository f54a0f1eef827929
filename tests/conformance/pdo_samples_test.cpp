// Timing-diagram samples from PDOs end to end: the engine runs a vector against the standard
// reference drive (ServoDrive) on the simulated bus that maps statusword and position into
// TPDO1 and controlword into RPDO1 and drives the state machine through the RPDO; the result
// carries TPDO and RPDO samples at the frames' times, the JSON keeps their origin and the HTML
// diagram draws them.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <string>

#include "conformance/engine.hpp"
#include "conformance/vector_file.hpp"
#include "protocol/can/sim_bus.hpp"
#include "reference_drive/servo_drive.hpp"
#include "reports/report_writers.hpp"

namespace drivecheck::conformance {
namespace {

using namespace std::chrono_literals;

// TPDO1 (181h): 6041h + 6064h, event-driven; RPDO1 (201h): 6040h, applied at once. The CiA 301
// §7.5.2.36 mapping procedure, then Operational and four controlwords by RPDO.
constexpr const char* kVector = R"(- id: t/pdo-diagram
  title: "statusword by TPDO while the controlword goes by RPDO"
  source: "CiA 301 §7.5.2.36"
  steps:
    - sdo_write: {index: 0x1800, sub: 1, value: 0x80000181, size: 4}
    - sdo_write: {index: 0x1A00, sub: 0, value: 0, size: 1}
    - sdo_write: {index: 0x1A00, sub: 1, value: 0x60410010, size: 4}
    - sdo_write: {index: 0x1A00, sub: 2, value: 0x60640020, size: 4}
    - sdo_write: {index: 0x1A00, sub: 0, value: 2, size: 1}
    - sdo_write: {index: 0x1800, sub: 2, value: 255, size: 1}
    - sdo_write: {index: 0x1800, sub: 1, value: 0x00000181, size: 4}
    - sdo_write: {index: 0x1400, sub: 1, value: 0x80000201, size: 4}
    - sdo_write: {index: 0x1600, sub: 0, value: 0, size: 1}
    - sdo_write: {index: 0x1600, sub: 1, value: 0x60400010, size: 4}
    - sdo_write: {index: 0x1600, sub: 0, value: 1, size: 1}
    - sdo_write: {index: 0x1400, sub: 2, value: 255, size: 1}
    - sdo_write: {index: 0x1400, sub: 1, value: 0x00000201, size: 4}
    - nmt: start
    - expect_frame: "181#*"
    - send: "201#0600"
    - wait: 30ms
    - send: "201#0700"
    - wait: 30ms
    - send: "201#0F00"
    - wait: 30ms
    - send: "201#0600"
    - wait: 30ms
)";

class PdoSamplesTest : public ::testing::Test {
 protected:
  PdoSamplesTest() : harness_(bus_.attach("harness")), drive_port_(bus_.attach("drive")) {
    auto parsed = profile::parse_profile(
        "name: t\ntitle: T\nfeatures: [cia402, pdo, pdo.dynamic-mapping]\n",
        {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
    EXPECT_TRUE(parsed) << parsed.error().to_string();
    if (parsed) profile_ = *parsed;
    reference_drive::ServoDriveOptions options;
    options.node = 1;
    auto created = reference_drive::ServoDrive::create(*drive_port_, options);
    EXPECT_TRUE(created) << (created ? "" : created.error());
    if (created) drive_ = std::move(*created);
    if (drive_) drive_->power_on();
    bus_.run_for(20ms);
  }

  VectorResult run_vector() {
    const auto set = parse_vectors(kVector, "t.yaml");
    EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
    if (set.vectors.empty()) return {};
    Engine engine(*harness_, profile_, EngineOptions{});
    return engine.run_vector(set.vectors.front());
  }

  can::SimBus bus_{{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> harness_;
  std::unique_ptr<can::SimPort> drive_port_;
  profile::DriveProfile profile_;
  std::unique_ptr<reference_drive::ServoDrive> drive_;
};

TEST_F(PdoSamplesTest, TpdoAndRpdoFramesBecomeSamplesAtTheirTimes) {
  ASSERT_TRUE(drive_);
  // Given the standard drive; When the vector maps the PDOs and drives 6, 7, F, 6 by RPDO1
  const VectorResult result = run_vector();
  ASSERT_EQ(result.verdict, Verdict::pass) << result.message;
  // Then the controlword samples from RPDOs are 0006h, 0007h, 000Fh, 0006h in order
  std::vector<std::int64_t> controlwords;
  std::vector<std::int64_t> statuswords;
  std::size_t positions = 0;
  for (const auto& sample : result.samples) {
    if (sample.origin == SampleOrigin::rpdo && sample.signal == "controlword")
      controlwords.push_back(sample.value);
    if (sample.origin == SampleOrigin::tpdo && sample.signal == "statusword")
      statuswords.push_back(sample.value);
    if (sample.origin == SampleOrigin::tpdo && sample.signal == "position") ++positions;
  }
  EXPECT_EQ(controlwords, (std::vector<std::int64_t>{0x0006, 0x0007, 0x000F, 0x0006}));
  // And the TPDO statuswords walk SWITCH ON DISABLED -> READY TO SWITCH ON -> SWITCHED ON ->
  //     OPERATION ENABLED -> READY TO SWITCH ON (CiA 402 statusword bits 6, 3..0, mask 004Fh)
  std::vector<std::int64_t> states;
  for (const auto value : statuswords) {
    const std::int64_t state = value & 0x004F;
    if (states.empty() || states.back() != state) states.push_back(state);
  }
  EXPECT_EQ(states, (std::vector<std::int64_t>{0x0040, 0x0001, 0x0003, 0x0007, 0x0001}))
      << fmt::format("{:04X}", fmt::join(statuswords, " "));
  EXPECT_EQ(positions, statuswords.size());
  // And each TPDO sample is at the time of a 181h frame in the evidence
  for (const auto& sample : result.samples) {
    if (sample.origin != SampleOrigin::tpdo) continue;
    const bool found = std::any_of(result.frames.begin(), result.frames.end(), [&](const auto& f) {
      return f.frame.id == 0x181U && f.at == sample.at;
    });
    EXPECT_TRUE(found) << sample.signal << " at " << sample.at.time_since_epoch().count();
  }
}

TEST_F(PdoSamplesTest, ReportDiagramDrawsPdoSamplesAndJsonKeepsTheirOrigin) {
  ASSERT_TRUE(drive_);
  // Given the run of the vector
  RunResult run;
  run.vectors.push_back(run_vector());
  ASSERT_EQ(run.vectors.front().verdict, Verdict::pass) << run.vectors.front().message;
  // When written as HTML and as JSON and read back
  const std::string html = reports::render_html(run);
  const auto read = reports::parse_json_report(reports::render_json(run));
  ASSERT_TRUE(read) << read.error().to_string();
  // Then the diagram has TPDO and RPDO sample marks and the legend counts them
  ASSERT_NE(html.find("<svg class=\"timing\""), std::string::npos);
  EXPECT_NE(html.find("class=\"sample-tpdo\""), std::string::npos);
  EXPECT_NE(html.find("class=\"sample-rpdo\""), std::string::npos);
  EXPECT_NE(html.find(">TPDO ("), std::string::npos);
  EXPECT_NE(html.find(">SW operation enabled</text>"), std::string::npos);
  // And the JSON keeps every sample's origin
  const auto& a = run.vectors.front().samples;
  const auto& b = read->vectors.front().samples;
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_EQ(a[i].origin, b[i].origin) << i;
}

}  // namespace
}  // namespace drivecheck::conformance
