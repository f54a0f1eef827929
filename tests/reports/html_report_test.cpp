// The HTML report: self-contained, the hooks the browser test and readers use, escaping, the
// timing diagram. (The page's script is exercised in a real browser by tests/browser.)
#include <gtest/gtest.h>

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

TEST(HtmlReport, ShowsCountsMatrixAndEveryVector) {
  // Given the synthetic run (pass 2, fail 2 of which 1 warning, deviation 1, n/a 1, error 1)
  // When written as HTML
  // Then the counts carry data-count-* hooks, the matrix has a row per family with cells
  //      linking to the filter, and each vector is a <details> with its verdict
  const std::string html = render_html(synthetic_run());
  EXPECT_NE(html.find("<b data-count-total>7</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-pass>2</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-fail>2</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-deviation>1</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-not-applicable>1</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-error>1</b>"), std::string::npos);
  EXPECT_NE(html.find("<b data-count-warnings>1</b>"), std::string::npos);
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
