// The HTML report: self-contained, the hooks the browser test and readers use, escaping, the
// timing diagram. (The page's script is exercised in a real browser by tests/browser.)
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <regex>
#include <string>

#include "reports/report_writers.hpp"
#include "tests/reports/synthetic_run.hpp"

namespace drivecheck::reports {
namespace {

using test_support::synthetic_run;

std::size_t count_of(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (auto at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1))
    ++n;
  return n;
}

// The <details> element of a vector, up to its end.
std::string vector_html(const std::string& html, const std::string& id) {
  const auto start = html.find("id=\"v:" + id + "\"");
  if (start == std::string::npos) return {};
  return html.substr(start, html.find("</details>", start) - start);
}

TEST(HtmlReport, IsSelfContained) {
  // Given the synthetic run
  // When written as HTML
  // Then the page loads nothing: no src=, no external stylesheet, no http(s) URL but the SVG
  //      namespace, no @import or url(
  const std::string html = render_html(synthetic_run());
  EXPECT_EQ(html.find("src="), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  EXPECT_EQ(html.find("@import"), std::string::npos);
  EXPECT_EQ(html.find("url("), std::string::npos);
  EXPECT_EQ(count_of(html, "http"), count_of(html, "http://www.w3.org/2000/svg"));
  EXPECT_EQ(count_of(html, "<script>"), 1u);
  EXPECT_EQ(count_of(html, "</script>"), 1u);
}

TEST(HtmlReport, CommissioningIsShownUnderTheProfile) {
  // Given a run whose profile commissions the drive, one line hostile
  // When written as HTML / Then each line is an item after the profile row, escaped
  auto run = synthetic_run();
  run.info.commissioning = {"applies to cia402/*", "6094h sub 1 := 15 (4 bytes): <b>why</b>"};
  const std::string html = render_html(run);
  const auto profile = html.find("<dt>Profile</dt>");
  const auto commissioning = html.find("<dt>Commissioning</dt>");
  ASSERT_NE(profile, std::string::npos);
  ASSERT_NE(commissioning, std::string::npos);
  EXPECT_LT(profile, commissioning);
  EXPECT_NE(html.find("<li>applies to cia402/*</li>"), std::string::npos);
  EXPECT_NE(html.find("&lt;b&gt;why&lt;/b&gt;"), std::string::npos);
  EXPECT_EQ(render_html(synthetic_run()).find("<dt>Commissioning</dt>"), std::string::npos);
}

TEST(HtmlReport, ProfileChoiceAndCapabilitiesAreShown) {
  // Given a run with a chosen profile and probed capabilities, one line hostile
  auto run = synthetic_run();
  run.info.profile_choice = "no --profile; 1000h = 00000191h: device profile 401";
  run.info.capabilities = {"pdo.rtr: absent (<b>bit 30</b>)"};
  // When written as HTML; Then both are shown, escaped
  const std::string html = render_html(run);
  EXPECT_NE(html.find("<dt>Profile chosen by</dt>"), std::string::npos);
  EXPECT_NE(html.find("<dt>Capabilities</dt>"), std::string::npos);
  EXPECT_NE(html.find("pdo.rtr: absent (&lt;b&gt;bit 30&lt;/b&gt;)"), std::string::npos);
}

TEST(HtmlReport, EdsFindingsAreShownUnderTheEdsLine) {
  // Given a run whose EDS had two lint findings, one hostile
  const auto run = synthetic_run();
  // When written as HTML
  const std::string html = render_html(run);
  // Then they are items right after the EDS row, escaped; a run without findings has none
  const auto eds = html.find("<dt>EDS</dt>");
  const auto findings = html.find("<dt>EDS findings</dt>");
  ASSERT_NE(eds, std::string::npos);
  ASSERT_NE(findings, std::string::npos);
  EXPECT_LT(eds, findings);
  EXPECT_EQ(html.find("<dt>", eds + 1), findings);
  EXPECT_NE(html.find("<li>eds/festo.eds:12: warning: VendorNumber is empty [identity-empty]</li>"),
            std::string::npos);
  EXPECT_NE(html.find("&lt;b&gt;no&lt;/b&gt; error control"), std::string::npos);
  auto clean = synthetic_run();
  clean.info.eds_findings.clear();
  EXPECT_EQ(render_html(clean).find("<dt>EDS findings</dt>"), std::string::npos);
}

TEST(HtmlReport, EsiFileDigestAndDeviceAreShownAfterTheEds) {
  // Given a run with --esi (its device's name hostile)
  auto run = synthetic_run();
  test_support::with_esi(run);
  // When written as HTML
  const std::string html = render_html(run);
  // Then the ESI row gives the file and its sha256, the ESI device row its identity, escaped
  const auto esi = html.find("<dt>ESI</dt>");
  const auto device = html.find("<dt>ESI device</dt>");
  ASSERT_NE(esi, std::string::npos);
  ASSERT_NE(device, std::string::npos);
  EXPECT_LT(html.find("<dt>EDS</dt>"), esi);
  EXPECT_EQ(html.find("<dt>", esi + 1), device);
  EXPECT_NE(html.find("esi/reference_drive.xml  sha256 " + run.info.esi_sha256), std::string::npos);
  EXPECT_NE(html.find("vendor ID 0000009Ah, product code 00000402h, revision 00010000h"),
            std::string::npos);
  EXPECT_EQ(html.find("<script>alert(1)"), std::string::npos);
  // And a run without --esi shows neither
  const std::string plain = render_html(synthetic_run());
  EXPECT_EQ(plain.find("<dt>ESI"), std::string::npos);
}

TEST(HtmlReport, ShowsCountsMatrixAndEveryVector) {
  // Given the synthetic run (pass 2, fail 2 of which 1 warning, deviation 1, n/a 1, error 1)
  // When written as HTML
  // Then the counts carry data-count-* hooks, the matrix has a row per family with cells
  //      linking to the filter, and each vector is a <details> with its verdict
  const std::string html = render_html(synthetic_run());
  EXPECT_NE(html.find("<b data-count-total>7</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-pass>2</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-fail>1</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-deviation>1</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-not-applicable>1</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-error>1</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-warning>1</b>"), std::string::npos);
  EXPECT_EQ(count_of(html, "<details class=\"vector\""), 7u);
  EXPECT_EQ(count_of(html, "<tr data-family="), 6u);
  EXPECT_NE(html.find("href=\"#filter=fail&amp;family=cia301%2Fsdo\""), std::string::npos);
  EXPECT_NE(html.find("data-verdict=\"deviation\""), std::string::npos);
  for (const char* filter :
       {"all", "pass", "fail", "deviation", "not-applicable", "error", "warning"}) {
    EXPECT_NE(html.find(std::string("data-filter=\"") + filter + "\""), std::string::npos)
        << filter;
  }
}

TEST(HtmlReport, VectorShowsRequirementChecksTimingsAndTranscript) {
  // Given the failing SDO abort vector and the warned heartbeat vector
  // When written as HTML
  // Then the failing vector shows its title, level, source, message, checks table and the
  //      transcript; the heartbeat vector shows its timing row as FAILED
  const std::string html = render_html(synthetic_run());
  const std::string fail = vector_html(html, "cia301/sdo/abort/write-read-only");
  ASSERT_FALSE(fail.empty());
  EXPECT_NE(fail.find("level <b>must</b>"), std::string::npos);
  EXPECT_NE(fail.find("000_33c1d912b8b6010a.txt §3.2.2 L764-771"), std::string::npos);
  EXPECT_NE(fail.find("<table class=\"checks\">"), std::string::npos);
  EXPECT_NE(fail.find("<pre class=\"transcript\">(   0.001000) tx 605#2341600000000000 → "),
            std::string::npos);
  const std::string warning = vector_html(html, "cia301/heartbeat/producer-period");
  EXPECT_NE(warning.find("<td>heartbeat period</td><td>112.000 ms</td><td>90.000 ms</td>"
                         "<td>110.000 ms</td><td class=\"bad\">FAILED</td>"),
            std::string::npos)
      << warning;
  EXPECT_NE(warning.find("data-warning=\"true\""), std::string::npos);
}

TEST(HtmlReport, HostileStringsAreEscaped) {
  // Given a device name and a message with </script>, markup, ESC and invalid UTF-8
  // When written as HTML
  // Then none of it is markup: the only <script> is ours, no raw ESC, and the text is escaped
  const std::string html = render_html(synthetic_run());
  EXPECT_EQ(html.find("<script>alert"), std::string::npos);
  EXPECT_EQ(html.find("<b>x</b>"), std::string::npos);
  EXPECT_EQ(html.find('\x1b'), std::string::npos);
  EXPECT_EQ(html.find("\xff"), std::string::npos);
  EXPECT_NE(html.find("Evil&lt;/script&gt;&lt;script&gt;alert(1)&lt;/script&gt;]]&gt;\\x1B[31m"),
            std::string::npos);
  EXPECT_NE(html.find("06020000h &lt;/pre&gt;&lt;b&gt;x&lt;/b&gt;"), std::string::npos);
}

TEST(HtmlReport, VectorsWithSamplesGetATimingDiagram) {
  // Given the pp vector with controlword, statusword, position and velocity samples, and
  //       the SDO vectors without samples
  // When written as HTML
  // Then the pp vector has an SVG with a trace per set bit (CW bit 4, SW bit 12 and target
  //      reached among them) and a line each for position and velocity; SDO vectors have none
  const std::string html = render_html(synthetic_run());
  const std::string pp = vector_html(html, "cia402/pp/single-set-point");
  ASSERT_NE(pp.find("<svg class=\"timing\""), std::string::npos);
  EXPECT_NE(pp.find(">CW bit 4 (new set-point/start)</text>"), std::string::npos);
  EXPECT_NE(pp.find(">SW bit 12 (ack/attained)</text>"), std::string::npos);
  EXPECT_NE(pp.find(">SW target reached</text>"), std::string::npos);
  EXPECT_EQ(pp.find(">SW fault</text>"), std::string::npos);  // never set
  EXPECT_NE(pp.find(">position</text>"), std::string::npos);
  EXPECT_NE(pp.find(">0 … 10000</text>"), std::string::npos);
  EXPECT_NE(pp.find(">velocity</text>"), std::string::npos);
  EXPECT_EQ(vector_html(html, "cia301/sdo/expedited-upload").find("<svg"), std::string::npos);
}

TEST(HtmlReport, SamplesAreMarkedByOriginAndThousandsStaySmall) {
  // Given the pp vector with 2 SDO controlword samples and 20,000 TPDO samples over 20 s
  //       (statusword toggling bit 10 every second, position a ramp), 500 said thinned out
  auto run = synthetic_run();
  auto& pp = run.vectors.front();
  pp.id = "cia402/pp/tpdo";
  pp.samples.clear();
  const auto at_ms = [](int ms) { return can::TimePoint{} + std::chrono::milliseconds(ms); };
  pp.samples.push_back({at_ms(0), "controlword", 0x000F, conformance::SampleOrigin::sdo});
  pp.samples.push_back({at_ms(10), "controlword", 0x001F, conformance::SampleOrigin::rpdo});
  for (int i = 0; i < 10'000; ++i) {
    pp.samples.push_back({at_ms(2 * i), "statusword", (i / 500) % 2 == 0 ? 0x0237 : 0x0637,
                          conformance::SampleOrigin::tpdo});
    pp.samples.push_back({at_ms(2 * i), "position", i * 7, conformance::SampleOrigin::tpdo});
  }
  pp.samples_elided = 500;
  // When written as HTML
  const std::string html = render_html(run);
  const std::string svg = vector_html(html, "cia402/pp/tpdo");
  // Then the legend counts the samples by origin and says how many were thinned out
  EXPECT_NE(svg.find(">SDO (1)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">TPDO (20000)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">RPDO (1)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">500 more thinned out (every bit edge kept)</text>"), std::string::npos);
  // And each origin has one path of marks per row it is sampled in (legend; "CW sampled";
  // "SW sampled" and position for TPDO), with at most one mark per 3-pixel column and height
  EXPECT_EQ(count_of(svg, "class=\"sample-sdo\""), 2U);
  EXPECT_EQ(count_of(svg, "class=\"sample-rpdo\""), 2U);
  EXPECT_EQ(count_of(svg, "class=\"sample-tpdo\""), 3U);
  EXPECT_NE(svg.find(">CW sampled</text>"), std::string::npos);
  EXPECT_NE(svg.find(">SW sampled</text>"), std::string::npos);
  EXPECT_GT(count_of(svg, "h0"), 300U);
  EXPECT_LT(count_of(svg, "h0"), 2000U);
  // And the statusword bit 10 trace keeps its 19 edges: 20 levels, 2 points per step + end
  const auto label = svg.find(">SW target reached</text>");
  ASSERT_NE(label, std::string::npos);
  const auto line = svg.find("points=\"", label);
  const auto line_end = svg.find('"', line + 8);
  const std::string points = svg.substr(line + 8, line_end - line - 8);
  EXPECT_EQ(static_cast<std::size_t>(std::count(points.begin(), points.end(), ' ')) + 1, 20U * 2);
  // And the vector stays small
  EXPECT_LT(svg.size(), 60'000U);
}

TEST(HtmlReport, ThousandVectorsStayOneFileOfReasonableSize) {
  // Given 1000 vectors each with 20 frames
  // When written as HTML
  // Then every vector is in the page and it stays under 20 MB (about 10 kB per vector)
  auto run = synthetic_run();
  const auto base = run.vectors[1];
  run.vectors.clear();
  for (int i = 0; i < 1000; ++i) {
    auto vector = base;
    vector.id = "cia301/sdo/generated-" + std::to_string(i);
    for (int f = 0; f < 10; ++f)
      vector.frames.insert(vector.frames.end(), base.frames.begin(), base.frames.end());
    run.vectors.push_back(std::move(vector));
  }
  const std::string html = render_html(run);
  EXPECT_EQ(count_of(html, "<details class=\"vector\""), 1000u);
  EXPECT_LT(html.size(), 20u * 1024 * 1024);
  EXPECT_NE(html.find("<b data-count-fail>1000</b>"), std::string::npos);
}

}  // namespace
}  // namespace drivecheck::reports

namespace drivecheck::reports {
namespace {

TEST(HtmlReport, SearchClauseMatrixAndPrintExpansion) {
  // Given a run with every tally, two cited documents and citations of CiA 301 and a manual
  const std::string html = render_html(test_support::synthetic_run_every_tally());
  // When written as HTML
  // Then there is a search box, a clause matrix beside the family matrix with a row per cited
  //      clause linking to its vectors, and failures, errors and warnings are marked to expand
  //      in print (with the print CSS that opens them)
  EXPECT_NE(html.find("<input type=\"search\" id=\"search\""), std::string::npos);
  EXPECT_NE(html.find("<div class=\"matrices\">"), std::string::npos);
  EXPECT_NE(html.find("<table id=\"clause-matrix\">"), std::string::npos);
  EXPECT_NE(html.find("<tr data-clause=\"CiA 301 §7.2.4.3.17\">"), std::string::npos);
  EXPECT_NE(html.find("<tr data-clause=\"000_33c1d912b8b6010a.txt §3.2.2\">"), std::string::npos);
  EXPECT_NE(html.find("href=\"#open=cia402%2Fpp%2Fchange-set-immediately\""), std::string::npos);
  EXPECT_NE(html.find("data-clauses=\"CiA 301 §7.2.4.3.17\n000_33c1d912b8b6010a.txt §3.2.2\""),
            std::string::npos);
  EXPECT_EQ(count_of(html, " data-print=\"expand\""), 3u);  // fail, warning, error
  EXPECT_NE(html.find("@media print"), std::string::npos);
  EXPECT_NE(html.find("data-print=expand]::details-content"), std::string::npos);
  EXPECT_NE(html.find("addEventListener('beforeprint'"), std::string::npos);
}

TEST(HtmlReport, ProvenanceCitationsBetweenVectorsAndFailureMarks) {
  // Given a run with its revision, vector digest, cited documents, a vector with a frame from
  //       between vectors, and a failed check at 150 ms on a vector with a timing diagram
  const std::string html = render_html(test_support::synthetic_run_every_tally());
  // Then the run info shows the revision, the digest and every document once with its edition
  EXPECT_NE(html.find("0.1.0 (revision v0.1.0-42-gabcdef0)"), std::string::npos);
  EXPECT_NE(html.find("sha256 " + std::string(64, 'a')), std::string::npos);
  EXPECT_EQ(count_of(html, "<li data-document="), 2u);
  EXPECT_NE(html.find("CANopen application layer and communication profile, edition v4.2.0"),
            std::string::npos);
  // And a citation shows its manual's title and edition
  const std::string pass = vector_html(html, "cia301/sdo/expedited-upload");
  EXPECT_NE(pass.find("L764-771</span> <span class=\"doc\">(Festo CMMP-AS-...-M3/-M0 "
                      "Description, 8046795 1510b)</span>"),
            std::string::npos)
      << pass;
  // And the late frame is shown as between vectors, outside the vector's transcript
  const std::string late = vector_html(html, "cia301/sdo/abort/write-read-only");
  EXPECT_NE(late.find("data-between-vectors=\"1\""), std::string::npos);
  const auto transcript = late.find("<pre class=\"transcript\">");
  ASSERT_NE(transcript, std::string::npos);
  EXPECT_EQ(late.find("585#8040600000000508", transcript), std::string::npos);
  // And the failed check is marked on the timing diagram and in the transcript, with its step
  const std::string pp = vector_html(html, "cia402/pp/single-set-point");
  EXPECT_NE(pp.find("<g class=\"failure-mark\" data-step=\"3\">"), std::string::npos) << pp;
  EXPECT_NE(pp.find("step 3 failed (expect_statusword)"), std::string::npos);
  EXPECT_NE(pp.find("data-failure-step=\"3\""), std::string::npos);
  // And the check table numbers steps as the message does
  EXPECT_NE(pp.find("<tr><td>3</td><td>expect_statusword</td>"), std::string::npos);
}

}  // namespace
}  // namespace drivecheck::reports
