// The JUnit XML report: schema-valid (xmllint against tests/reports/junit.xsd), one suite per
// family, each verdict mapped as report_writers.hpp says, hostile strings escaped.
#include <gtest/gtest.h>

#include <pugixml.hpp>
#include <string>

#include "reports/report_writers.hpp"
#include "tests/reports/synthetic_run.hpp"
#include "tests/support/run_command.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::reports {
namespace {

using test_support::synthetic_run;
using test_support::TempDir;

const std::string kXsd = DRIVECHECK_JUNIT_XSD;

pugi::xml_node testcase(const pugi::xml_document& document, std::string_view id) {
  return document.select_node(("//testcase[@name='" + std::string(id) + "']").c_str()).node();
}

std::string property(pugi::xml_node suite, std::string_view name) {
  return suite.select_node(("properties/property[@name='" + std::string(name) + "']").c_str())
      .node()
      .attribute("value")
      .value();
}

TEST(JunitReport, ValidatesAgainstTheJunitSchema) {
  // Given the synthetic run with every verdict and hostile strings (markup, "]]>", control
  //       characters, invalid UTF-8 in the device name)
  // When written as JUnit XML
  // Then xmllint validates it against junit.xsd
  TempDir dir;
  ASSERT_TRUE(write_junit_report(dir / "junit.xml", synthetic_run()));
  const auto result = test_support::run_command(
      {"xmllint", "--noout", "--schema", kXsd, (dir / "junit.xml").string()});
  if (result.exit_code == 127) GTEST_SKIP() << "xmllint is not installed (libxml2-utils)";
  EXPECT_EQ(result.exit_code, 0) << result.err;
}

TEST(JunitReport, SchemaRejectsAReportWithoutTestcaseNames) {
  // Given a JUnit file whose testcase lacks a name (so the schema check can fail)
  // When validated with xmllint against junit.xsd
  // Then validation fails
  TempDir dir;
  const auto path = dir.write("bad.xml",
                              "<testsuites><testsuite name=\"a\" tests=\"1\" failures=\"0\" "
                              "errors=\"0\"><testcase classname=\"c\" time=\"0\"/></testsuite>"
                              "</testsuites>");
  const auto result =
      test_support::run_command({"xmllint", "--noout", "--schema", kXsd, path.string()});
  if (result.exit_code == 127) GTEST_SKIP() << "xmllint is not installed (libxml2-utils)";
  EXPECT_NE(result.exit_code, 0);
  EXPECT_NE(result.err.find("fails to validate"), std::string::npos) << result.err;
  EXPECT_NE(result.err.find("'name' is required"), std::string::npos) << result.err;
}

TEST(JunitReport, OneSuitePerFamilyWithUniqueClassnamesAndCounts) {
  // Given the synthetic run (families cia301/sdo, cia402/fsa, cia402/homing, cia301/heartbeat,
  //       cia301/nmt, cia402/pp)
  // When written as JUnit XML
  // Then there is one testsuite per family in run order, classnames drivecheck.<family
  //      with dots>, and the counts say 1 failure (the warning passes), 1 error, 1 skipped
  pugi::xml_document document;
  ASSERT_TRUE(document.load_string(render_junit(synthetic_run()).c_str()));
  std::vector<std::string> suites;
  for (const auto& suite : document.child("testsuites").children("testsuite"))
    suites.push_back(suite.attribute("name").value());
  EXPECT_EQ(suites, (std::vector<std::string>{"cia301/sdo", "cia402/fsa", "cia402/homing",
                                              "cia301/heartbeat", "cia301/nmt", "cia402/pp"}));
  const auto root = document.child("testsuites");
  EXPECT_STREQ(root.attribute("tests").value(), "7");
  EXPECT_STREQ(root.attribute("failures").value(), "1");
  EXPECT_STREQ(root.attribute("errors").value(), "1");
  // testsuites has no skipped attribute (the Jenkins/xunit schema rejects it); suites have it
  EXPECT_FALSE(root.attribute("skipped"));
  EXPECT_STREQ(root.find_child_by_attribute("testsuite", "name", "cia402/homing")
                   .attribute("skipped")
                   .value(),
               "1");
  EXPECT_STREQ(
      testcase(document, "cia301/sdo/abort/write-read-only").attribute("classname").value(),
      "drivecheck.cia301.sdo");
}

TEST(JunitReport, EachVerdictMapsToItsElement) {
  // Given the synthetic run
  // When written as JUnit XML
  // Then fail → <failure message=first line: file:line, step, Expected; Actual> with the block,
  //      error → <error>, n/a → <skipped message=reason>, deviation and warning → no failure,
  //      said in system-out; no testcase has properties or a file attribute
  pugi::xml_document document;
  ASSERT_TRUE(document.load_string(render_junit(synthetic_run()).c_str()));

  const auto fail = testcase(document, "cia301/sdo/abort/write-read-only");
  const auto failure = fail.child("failure");
  ASSERT_TRUE(failure);
  EXPECT_STREQ(failure.attribute("message").value(),
               "vectors/cia301/sdo.yaml:14: step 1 expect_frame: Expected 585#80416000020001 06 "
               "(abort 06010002h); Actual 585#80416000000002 06 (abort 06020000h)");
  const std::string body = failure.text().get();
  EXPECT_NE(body.find("Actual:   585#80416000000002 06"), std::string::npos) << body;
  EXPECT_NE(body.find("Expected: 585#8041600002000106"), std::string::npos) << body;
  EXPECT_NE(body.find("Source: 000_33c1d912b8b6010a.txt §3.2.2 L764-771"), std::string::npos);
  const std::string fail_out = fail.child("system-out").text().get();
  EXPECT_NE(fail_out.find("Verdict: fail\n"), std::string::npos) << fail_out;
  EXPECT_NE(fail_out.find("Level: must\n"), std::string::npos) << fail_out;
  EXPECT_NE(fail_out.find("Vector: vectors/cia301/sdo.yaml:12\n"), std::string::npos);
  for (const auto& node : document.select_nodes("//testcase")) {
    EXPECT_FALSE(node.node().child("properties")) << node.node().attribute("name").value();
    EXPECT_FALSE(node.node().attribute("file")) << node.node().attribute("name").value();
  }

  const auto error = testcase(document, "cia301/nmt/reset-communication");
  EXPECT_TRUE(error.child("error"));
  EXPECT_FALSE(error.child("failure"));

  const auto na = testcase(document, "cia402/homing/method-35");
  EXPECT_STREQ(na.child("skipped").attribute("message").value(),
               "not applicable: the profile does not support homing.method.35");

  const auto deviation = testcase(document, "cia402/fsa/transition-16");
  EXPECT_FALSE(deviation.child("failure"));
  EXPECT_FALSE(deviation.child("skipped"));
  const std::string deviation_out = deviation.child("system-out").text().get();
  EXPECT_NE(deviation_out.find("Documented deviation: no-transition-16 "
                               "(000_33c1d912b8b6010a.txt §6.1 L5426-5444)"),
            std::string::npos)
      << deviation_out;

  const auto warning = testcase(document, "cia301/heartbeat/producer-period");
  EXPECT_FALSE(warning.child("failure"));
  EXPECT_NE(
      std::string(warning.child("system-out").text().get()).find("Verdict: warning (a should"),
      std::string::npos);

  const auto pass = testcase(document, "cia301/sdo/expedited-upload");
  EXPECT_FALSE(pass.child("failure"));
  // time is wall time (the synthetic vectors took 1 ms of wall time, 20 ms of bus time)
  EXPECT_STREQ(pass.attribute("time").value(), "0.001000");
}

TEST(JunitReport, RunPropertiesOncePerFile) {
  // Given the synthetic run
  // When written as JUnit XML
  // Then the DUT identity, EDS and profile are properties of the first testsuite only, and each
  //      suite has its bus time
  pugi::xml_document document;
  ASSERT_TRUE(document.load_string(render_junit(synthetic_run()).c_str()));
  EXPECT_EQ(document.select_nodes("//property[@name='dut.vendor_id']").size(), 1U);
  EXPECT_EQ(document.select_nodes("//property[@name='profile']").size(), 1U);
  const auto first = document.child("testsuites").child("testsuite");
  EXPECT_EQ(property(first, "dut.vendor_id"), "0x0000001D");
  EXPECT_EQ(property(first, "eds.sha256").size(), 64u);
  EXPECT_EQ(property(first, "profile"), "festo-cmmp");
  EXPECT_EQ(document.select_nodes("//property[@name='suite.bus_time_s']").size(), 6U);
}

TEST(JunitReport, EdsFindingsAreRunProperties) {
  // Given a run whose EDS had two lint findings
  // When written as JUnit XML
  pugi::xml_document document;
  ASSERT_TRUE(document.load_string(render_junit(synthetic_run()).c_str()));
  // Then they are the run-wide properties eds.finding.1 and eds.finding.2, once per file
  const auto first = document.child("testsuites").child("testsuite");
  EXPECT_EQ(property(first, "eds.finding.1"),
            "eds/festo.eds:12: warning: VendorNumber is empty [identity-empty]");
  EXPECT_EQ(property(first, "eds.finding.2"),
            "eds/festo.eds:40: warning: <b>no</b> error control [no-error-control]");
  EXPECT_EQ(document.select_nodes("//property[starts-with(@name,'eds.finding.')]").size(), 2U);
}

TEST(JunitReport, EsiFileDigestAndDeviceAreRunProperties) {
  // Given a run with --esi
  auto run = test_support::synthetic_run();
  test_support::with_esi(run);
  // When written as JUnit XML
  pugi::xml_document document;
  ASSERT_TRUE(document.load_string(render_junit(run).c_str()));
  // Then esi.file, esi.sha256 and the ESI device's identity are run-wide properties, once
  const auto first = document.child("testsuites").child("testsuite");
  EXPECT_EQ(property(first, "esi.file"), "esi/reference_drive.xml");
  EXPECT_EQ(property(first, "esi.sha256"), run.info.esi_sha256);
  EXPECT_EQ(property(first, "esi.vendor_id"), "0x0000009A");
  EXPECT_EQ(property(first, "esi.product_code"), "0x00000402");
  EXPECT_EQ(property(first, "esi.revision"), "0x00010000");
  EXPECT_EQ(document.select_nodes("//property[@name='esi.sha256']").size(), 1U);
  EXPECT_EQ(document.select_nodes("//property[@name='esi.name']").size(), 1U);
  // And a run without --esi has no esi.* property
  pugi::xml_document plain;
  ASSERT_TRUE(plain.load_string(render_junit(test_support::synthetic_run()).c_str()));
  EXPECT_EQ(plain.select_nodes("//property[starts-with(@name,'esi.')]").size(), 0U);
}

TEST(JunitReport, SystemOutIsTheDecodedTranscript) {
  // Given the passing SDO upload vector with two frames
  // When written as JUnit XML
  // Then system-out ends with one transcript line per frame, after the requirement and checks
  pugi::xml_document document;
  ASSERT_TRUE(document.load_string(render_junit(synthetic_run()).c_str()));
  const std::string out =
      testcase(document, "cia301/sdo/expedited-upload").child("system-out").text().get();
  const std::string transcript =
      "\n(   0.001000) tx 605#4041600000000000 → SDO rx  node 5  initiate upload 6041:00\n"
      "(   0.002000) rx 585#4B41600050020000 → SDO tx  node 5  upload 6041:00 = 0x0250\n";
  ASSERT_GE(out.size(), transcript.size());
  EXPECT_EQ(out.substr(out.size() - transcript.size()), transcript) << out;
  EXPECT_NE(out.find("ok     step 1 (expect_frame)"), std::string::npos) << out;
}

TEST(JunitReport, HostileStringsAreEscapedNotInterpreted) {
  // Given a device name with markup, "]]>", ESC, SOH and invalid UTF-8
  // When written as JUnit XML and parsed back
  // Then the name reads back as text with the controls as \xNN and U+FFFD for the bad bytes
  const std::string xml = render_junit(synthetic_run());
  EXPECT_EQ(xml.find("<script>"), std::string::npos);
  EXPECT_EQ(xml.find('\x1b'), std::string::npos);
  pugi::xml_document document;
  ASSERT_TRUE(document.load_string(xml.c_str()));
  EXPECT_EQ(property(document.child("testsuites").child("testsuite"), "dut.device_name"),
            "Evil</script><script>alert(1)</script>]]>\\x1B[31m\\x01\xEF\xBF\xBD\xEF\xBF\xBD"
            "\xEF\xBF\xBD(drive");
}

}  // namespace
}  // namespace drivecheck::reports
