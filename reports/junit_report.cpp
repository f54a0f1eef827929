// The JUnit XML report (layout in report_writers.hpp; schema tests/reports/junit.xsd, written
// from the Ant/Jenkins JUnit format: testsuites/testsuite/testcase/failure/error/skipped/
// properties/system-out).
#include <fmt/format.h>

#include <map>
#include <pugixml.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "reports/report_writers.hpp"

namespace drivecheck::reports {
namespace {

using conformance::RunResult;
using conformance::VectorResult;
using conformance::Verdict;

// XML 1.0 cannot carry most C0 controls even as character references, and pugixml would
// write them as &#N;: every text goes through printable_text first.
void set_attribute(pugi::xml_node node, const char* name, std::string_view value) {
  node.append_attribute(name).set_value(printable_text(value).c_str());
}

void add_property(pugi::xml_node properties, std::string_view name, std::string_view value) {
  pugi::xml_node property = properties.append_child("property");
  set_attribute(property, "name", name);
  set_attribute(property, "value", value);
}

std::string seconds_text(double seconds) {
  return fmt::format("{:.6f}", seconds);
}
double seconds(can::Duration duration) {
  return static_cast<double>(duration.count()) / 1e9;
}

std::string hex32(std::uint32_t value) {
  return fmt::format("0x{:08X}", value);
}

std::string duration_text(can::Duration duration) {
  return fmt::format("{:.3f} ms", static_cast<double>(duration.count()) / 1e6);
}

// The run-wide properties each testcase repeats (a CI test page shows one testcase at a time).
void add_run_properties(pugi::xml_node properties, const RunResult& result) {
  const auto& info = result.info;
  const auto& dut = info.dut;
  if (dut.vendor_id) add_property(properties, "dut.vendor_id", hex32(*dut.vendor_id));
  if (dut.product_code) add_property(properties, "dut.product_code", hex32(*dut.product_code));
  if (dut.revision) add_property(properties, "dut.revision", hex32(*dut.revision));
  if (dut.serial) add_property(properties, "dut.serial", hex32(*dut.serial));
  if (dut.device_name) add_property(properties, "dut.device_name", *dut.device_name);
  if (dut.software_version) add_property(properties, "dut.software_version", *dut.software_version);
  if (!info.eds_file.empty()) add_property(properties, "eds.file", info.eds_file);
  if (!info.eds_sha256.empty()) add_property(properties, "eds.sha256", info.eds_sha256);
  add_property(properties, "profile", info.profile_name);
  if (!info.profile_choice.empty()) add_property(properties, "profile.choice", info.profile_choice);
  for (std::size_t i = 0; i < info.capabilities.size(); ++i)
    add_property(properties, fmt::format("capability.{}", i + 1), info.capabilities[i]);
}

// The failure body: the requirement, then the message (the first failing check's
// Expected/Actual), then every failing check and timing.
std::string failure_body(const VectorResult& vector) {
  std::string body = "Requirement: " + vector.title + "\n";
  for (const auto& source : vector.sources)
    body += "Source: " + source + "\n";
  body += "\n" + vector.message + "\n";
  for (const auto& check : vector.checks) {
    if (check.ok) continue;
    body += fmt::format("\nstep {} ({})\n  Expected: {}\n  Actual:   {}\n", check.step,
                        check.action, check.expected, check.actual);
  }
  for (const auto& timing : vector.timings) {
    if (timing.ok) continue;
    body += fmt::format("\ntiming {}: measured {}", timing.name, duration_text(timing.measured));
    if (timing.min) body += ", min " + duration_text(*timing.min);
    if (timing.max) body += ", max " + duration_text(*timing.max);
    body += "\n";
  }
  return body;
}

void add_testcase(pugi::xml_node suite, const VectorResult& vector, const RunResult& result) {
  pugi::xml_node testcase = suite.append_child("testcase");
  set_attribute(testcase, "name", vector.id);
  std::string classname = "drivecheck." + vector.family;
  for (char& c : classname)
    if (c == '/') c = '.';
  set_attribute(testcase, "classname", classname);
  set_attribute(testcase, "time", seconds_text(seconds(vector.finished - vector.started)));
  if (!vector.file.empty()) set_attribute(testcase, "file", vector.file);

  pugi::xml_node properties = testcase.append_child("properties");
  add_property(properties, "title", vector.title);
  for (const auto& source : vector.sources)
    add_property(properties, "source", source);
  add_property(properties, "level", to_string(vector.level));
  add_property(properties, "verdict", to_string(vector.verdict));
  if (!vector.file.empty())
    add_property(properties, "vector", fmt::format("{}:{}", vector.file, vector.line));
  if (vector.verdict == Verdict::deviation) {
    // A deviation the drive's manual documents is the drive's specified behaviour: the report
    // shows it, but it is not a failure of the drive against its own documentation.
    add_property(properties, "deviation.id", vector.deviation_id);
    add_property(properties, "deviation.source", vector.deviation_source);
    add_property(properties, "deviation.description", vector.message);
  }
  if (vector.warning) {
    add_property(properties, "warning",
                 fmt::format("{}-level requirement not met (run with --strict to fail): {}",
                             to_string(vector.level), first_line(vector.message)));
  }
  for (std::size_t i = 0; i < vector.checks.size(); ++i) {
    const auto& check = vector.checks[i];
    const std::string prefix = fmt::format("check.{}", i + 1);
    add_property(properties, prefix + ".step", fmt::format("{} {}", check.step, check.action));
    add_property(properties, prefix + ".accepted", check.expected);
    add_property(properties, prefix + ".observed", check.actual);
    add_property(properties, prefix + ".result", check.ok ? "ok" : "FAILED");
  }
  for (const auto& timing : vector.timings) {
    std::string value = duration_text(timing.measured);
    if (timing.min) value += " min " + duration_text(*timing.min);
    if (timing.max) value += " max " + duration_text(*timing.max);
    value += timing.ok ? " ok" : " FAILED";
    add_property(properties, "timing." + timing.name, value);
  }
  add_run_properties(properties, result);

  const std::string message(first_line(vector.message));
  switch (vector.verdict) {
    case Verdict::pass:
    case Verdict::deviation:
      break;
    case Verdict::fail:
      // A should/may failure without --strict is a warning: the testcase passes (property).
      if (!vector.warning) {
        pugi::xml_node failure = testcase.append_child("failure");
        set_attribute(failure, "message", message);
        set_attribute(failure, "type", "fail");
        failure.append_child(pugi::node_pcdata)
            .set_value(printable_text(failure_body(vector)).c_str());
      }
      break;
    case Verdict::error: {
      pugi::xml_node error = testcase.append_child("error");
      set_attribute(error, "message", message);
      set_attribute(error, "type", "harness-error");
      error.append_child(pugi::node_pcdata).set_value(printable_text(failure_body(vector)).c_str());
      break;
    }
    case Verdict::not_applicable: {
      pugi::xml_node skipped = testcase.append_child("skipped");
      set_attribute(skipped, "message", message);
      break;
    }
  }
  std::string transcript;
  for (std::size_t i = 0; i < vector.frames.size(); ++i) {
    if (vector.frames_elided != 0 && i == vector.frames_elided_at)
      transcript += elided_line(vector.frames_elided) + "\n";
    transcript += transcript_line(vector.frames[i], vector.started) + "\n";
  }
  testcase.append_child("system-out")
      .append_child(pugi::node_pcdata)
      .set_value(printable_text(transcript).c_str());
}

}  // namespace

std::string render_junit(const RunResult& result) {
  // Families in the order they first appear in the run.
  std::vector<std::string> families;
  std::map<std::string, std::vector<const VectorResult*>> by_family;
  for (const auto& vector : result.vectors) {
    auto& list = by_family[vector.family];
    if (list.empty()) families.push_back(vector.family);
    list.push_back(&vector);
  }

  pugi::xml_document document;

  pugi::xml_node root = document.append_child("testsuites");
  set_attribute(root, "name", "drivecheck " + result.info.profile_name);
  std::size_t total_tests = 0;
  std::size_t total_failures = 0;
  std::size_t total_errors = 0;
  std::size_t total_skipped = 0;
  double total_time = 0.0;

  std::size_t suite_id = 0;
  for (const auto& family : families) {
    const auto& vectors = by_family[family];
    std::size_t failures = 0;
    std::size_t errors = 0;
    std::size_t skipped = 0;
    double time = 0.0;
    for (const VectorResult* vector : vectors) {
      if (vector->verdict == Verdict::fail && !vector->warning) ++failures;
      if (vector->verdict == Verdict::error) ++errors;
      if (vector->verdict == Verdict::not_applicable) ++skipped;
      time += seconds(vector->finished - vector->started);
    }
    pugi::xml_node suite = root.append_child("testsuite");
    set_attribute(suite, "name", family);
    set_attribute(suite, "id", std::to_string(suite_id++));
    set_attribute(suite, "package", "drivecheck");
    set_attribute(suite, "tests", std::to_string(vectors.size()));
    set_attribute(suite, "failures", std::to_string(failures));
    set_attribute(suite, "errors", std::to_string(errors));
    set_attribute(suite, "skipped", std::to_string(skipped));
    set_attribute(suite, "time", seconds_text(time));
    if (!result.info.started_utc.empty())
      set_attribute(suite, "timestamp", result.info.started_utc);
    set_attribute(suite, "hostname", result.info.bus.empty() ? "-" : result.info.bus);

    pugi::xml_node properties = suite.append_child("properties");
    add_property(properties, "tool_version", result.info.tool_version);
    add_property(properties, "bus", result.info.bus);
    add_property(properties, "node", std::to_string(result.info.node));
    add_property(properties, "seed", std::to_string(result.info.seed));
    add_property(properties, "order", result.info.order);
    add_property(properties, "strict", result.info.strict ? "true" : "false");
    if (result.interrupted) add_property(properties, "interrupted", "true");
    if (result.dut_lost) add_property(properties, "dut_lost", "true");
    if (!result.info.personality.empty())
      add_property(properties, "personality", result.info.personality);
    for (const auto& deviation : result.info.deviations)
      add_property(properties, "injected_deviation", deviation);
    add_run_properties(properties, result);

    for (const VectorResult* vector : vectors)
      add_testcase(suite, *vector, result);

    total_tests += vectors.size();
    total_failures += failures;
    total_errors += errors;
    total_skipped += skipped;
    total_time += time;
  }
  set_attribute(root, "tests", std::to_string(total_tests));
  set_attribute(root, "failures", std::to_string(total_failures));
  set_attribute(root, "errors", std::to_string(total_errors));
  set_attribute(root, "skipped", std::to_string(total_skipped));
  set_attribute(root, "time", seconds_text(total_time));

  std::ostringstream out;
  document.save(out, "  ", pugi::format_default | pugi::format_no_declaration, pugi::encoding_utf8);
  // The declaration by hand, naming the encoding (pugixml's default one does not).
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n" + out.str();
}

Expected<void, std::string> write_junit_report(const std::filesystem::path& path,
                                               const RunResult& result) {
  return write_file_atomically(path, render_junit(result));
}

}  // namespace drivecheck::reports
