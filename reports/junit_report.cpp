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
using conformance::Tally;
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

// The run-wide properties, once per file (in the first testsuite): who was tested, with what.
void add_run_properties(pugi::xml_node properties, const RunResult& result) {
  const auto& info = result.info;
  const auto& dut = info.dut;
  add_property(properties, "tool_version", info.tool_version);
  if (!info.revision.empty()) add_property(properties, "revision", info.revision);
  if (!info.vector_digest.empty()) {
    add_property(properties, "vector_set.sha256", info.vector_digest);
    add_property(properties, "vector_set.files", std::to_string(info.vector_files));
  }
  add_property(properties, "bus", info.bus);
  add_property(properties, "node", std::to_string(info.node));
  add_property(properties, "seed", std::to_string(info.seed));
  add_property(properties, "order", info.order);
  add_property(properties, "strict", info.strict ? "true" : "false");
  if (!info.filter.empty()) add_property(properties, "filter", info.filter);
  if (result.interrupted) add_property(properties, "interrupted", "true");
  if (result.dut_lost) add_property(properties, "dut_lost", "true");
  if (!info.personality.empty()) add_property(properties, "personality", info.personality);
  for (const auto& deviation : info.deviations)
    add_property(properties, "injected_deviation", deviation);
  if (dut.device_type) add_property(properties, "dut.device_type", hex32(*dut.device_type));
  if (dut.vendor_id) add_property(properties, "dut.vendor_id", hex32(*dut.vendor_id));
  if (dut.product_code) add_property(properties, "dut.product_code", hex32(*dut.product_code));
  if (dut.revision) add_property(properties, "dut.revision", hex32(*dut.revision));
  if (dut.serial) add_property(properties, "dut.serial", hex32(*dut.serial));
  if (dut.device_name) add_property(properties, "dut.device_name", *dut.device_name);
  if (dut.hardware_version) add_property(properties, "dut.hardware_version", *dut.hardware_version);
  if (dut.software_version) add_property(properties, "dut.software_version", *dut.software_version);
  if (!info.eds_file.empty()) add_property(properties, "eds.file", info.eds_file);
  if (!info.eds_sha256.empty()) add_property(properties, "eds.sha256", info.eds_sha256);
  for (std::size_t i = 0; i < info.eds_findings.size(); ++i)
    add_property(properties, fmt::format("eds.finding.{}", i + 1), info.eds_findings[i]);
  if (!info.esi_file.empty()) add_property(properties, "esi.file", info.esi_file);
  if (!info.esi_sha256.empty()) add_property(properties, "esi.sha256", info.esi_sha256);
  if (const auto& device = info.esi_device) {
    add_property(properties, "esi.vendor_id", hex32(device->vendor_id));
    add_property(properties, "esi.product_code", hex32(device->product_code));
    add_property(properties, "esi.revision", hex32(device->revision));
    add_property(properties, "esi.name", device->name);
  }
  add_property(properties, "profile", info.profile_name);
  if (!info.profile_choice.empty()) add_property(properties, "profile.choice", info.profile_choice);
  for (std::size_t i = 0; i < info.capabilities.size(); ++i)
    add_property(properties, fmt::format("capability.{}", i + 1), info.capabilities[i]);
  for (const auto& document : info.documents) {
    add_property(properties, "document." + document.key,
                 document.title + (document.edition.empty() ? "" : ", " + document.edition));
  }
  add_property(properties, "bus_time_s", seconds_text(seconds(result.simulated)));
  add_property(properties, "wall_time_s", seconds_text(result.wall_seconds));
}

// What a CI page shows of a testcase besides its verdict: the requirement with its cited
// documents, where the vector is, its checks and timings (steps numbered from 1, 0 = setup).
std::string vector_header(const VectorResult& vector, const RunResult& result) {
  std::string text = "Requirement: " + vector.title + "\n";
  for (const auto& source : vector.sources)
    text += "Source: " + citation_text(result.info, source) + "\n";
  text += fmt::format("Level: {}\nVerdict: {}\n", to_string(vector.level),
                      vector.warning ? "warning (a " + std::string(to_string(vector.level)) +
                                           " requirement not met; fails only with --strict)"
                                     : std::string(to_string(vector.verdict)));
  if (!vector.file.empty()) text += fmt::format("Vector: {}:{}\n", vector.file, vector.line);
  text += fmt::format("Bus time: {}\n", duration_text(vector.finished - vector.started));
  if (vector.verdict == Verdict::deviation) {
    text += fmt::format("Documented deviation: {} ({})\n", vector.deviation_id,
                        vector.deviation_source);
  }
  return text;
}

std::string checks_text(const VectorResult& vector) {
  std::string body;
  for (const auto& check : vector.checks) {
    body +=
        fmt::format("{} {} ({})\n  Expected: {}\n  Actual:   {}\n", check.ok ? "ok    " : "FAILED",
                    conformance::step_label(check.step, check.iterations), check.action,
                    check.expected, check.actual);
  }
  for (const auto& timing : vector.timings) {
    body += fmt::format("{} timing {}: measured {}", timing.ok ? "ok    " : "FAILED", timing.name,
                        duration_text(timing.measured));
    if (timing.min) body += ", min " + duration_text(*timing.min);
    if (timing.max) body += ", max " + duration_text(*timing.max);
    body += "\n";
  }
  return body;
}

// The failure body: the requirement, the message (its first line is the failure's message
// attribute), then every failing check and timing.
std::string failure_body(const VectorResult& vector, const RunResult& result) {
  std::string body = vector_header(vector, result) + "\n" + vector.message + "\n";
  for (const auto& check : vector.checks) {
    if (check.ok) continue;
    body += fmt::format("\n{} ({})\n  Expected: {}\n  Actual:   {}\n",
                        check.step == 0 ? std::string("step 0")
                                        : conformance::step_label(check.step, check.iterations),
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
  // Wall time (what a CI server sums up); the bus time is in the system-out header.
  set_attribute(testcase, "time", seconds_text(vector.wall_seconds));

  const std::string message(first_line(vector.message));
  switch (vector.verdict) {
    case Verdict::pass:
    case Verdict::deviation:
      break;
    case Verdict::fail:
      // A should/may failure without --strict is a warning: the testcase passes.
      if (!vector.warning) {
        pugi::xml_node failure = testcase.append_child("failure");
        set_attribute(failure, "message", message);
        set_attribute(failure, "type", "fail");
        failure.append_child(pugi::node_pcdata)
            .set_value(printable_text(failure_body(vector, result)).c_str());
      }
      break;
    case Verdict::error: {
      pugi::xml_node error = testcase.append_child("error");
      set_attribute(error, "message", message);
      set_attribute(error, "type", "harness-error");
      error.append_child(pugi::node_pcdata)
          .set_value(printable_text(failure_body(vector, result)).c_str());
      break;
    }
    case Verdict::not_applicable:
    case Verdict::interrupted: {
      // Neither passed nor failed: an absent feature, or a vector the user stopped.
      pugi::xml_node skipped = testcase.append_child("skipped");
      set_attribute(
          skipped, "message",
          vector.verdict == Verdict::interrupted ? message : "not applicable: " + message);
      break;
    }
  }
  std::string out = vector_header(vector, result);
  if (vector.warning) out += "Warning: " + std::string(first_line(vector.message)) + "\n";
  out += "\n" + checks_text(vector);
  if (!vector.between_vectors.empty()) {
    out += "\nBetween vectors (arrived before this vector's setup; not its evidence):\n";
    for (const auto& frame : vector.between_vectors)
      out += transcript_line(frame, vector.started) + "\n";
  }
  out += "\n";
  out += datagram_transcript(vector);  // EtherCAT; empty on CAN
  RepeatLines repeats;
  for (std::size_t i = 0; i < vector.frames.size(); ++i) {
    if (vector.frames_elided != 0 && i == vector.frames_elided_at)
      out += elided_line(vector.frames_elided) + "\n";
    if (const auto* repeat = repeats.before(i))
      out += repeat_line(*repeat, vector.started, "frame(s)") + "\n";
    out += transcript_line(vector.frames[i], vector.started) + "\n";
    repeats.after(i, vector.frames[i].repeat);
  }
  testcase.append_child("system-out")
      .append_child(pugi::node_pcdata)
      .set_value(printable_text(out).c_str());
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
  double total_time = 0.0;

  std::size_t suite_id = 0;
  for (const auto& family : families) {
    const auto& vectors = by_family[family];
    // The counts of every output (conformance::VerdictCounts): failures are the fails,
    // warnings pass, skipped are the not-applicable and the interrupted vectors.
    conformance::VerdictCounts counts;
    double time = 0.0;
    can::Duration bus_time{};
    for (const VectorResult* vector : vectors) {
      counts.add(vector->verdict, vector->warning);
      time += vector->wall_seconds;
      bus_time += vector->finished - vector->started;
    }
    pugi::xml_node suite = root.append_child("testsuite");
    set_attribute(suite, "name", family);
    set_attribute(suite, "id", std::to_string(suite_id));
    set_attribute(suite, "package", "drivecheck");
    set_attribute(suite, "tests", std::to_string(vectors.size()));
    set_attribute(suite, "failures", std::to_string(counts[Tally::fail]));
    set_attribute(suite, "errors", std::to_string(counts[Tally::error]));
    set_attribute(suite, "skipped",
                  std::to_string(counts[Tally::not_applicable] + counts[Tally::interrupted]));
    set_attribute(suite, "time", seconds_text(time));
    if (!result.info.started_utc.empty())
      set_attribute(suite, "timestamp", result.info.started_utc);
    set_attribute(suite, "hostname", result.info.bus.empty() ? "-" : result.info.bus);

    pugi::xml_node properties = suite.append_child("properties");
    if (suite_id == 0) add_run_properties(properties, result);
    add_property(properties, "suite.bus_time_s", seconds_text(seconds(bus_time)));
    ++suite_id;

    for (const VectorResult* vector : vectors)
      add_testcase(suite, *vector, result);
    total_time += time;
  }
  const auto counts = result.counts();
  set_attribute(root, "tests", std::to_string(counts.total()));
  set_attribute(root, "failures", std::to_string(counts[Tally::fail]));
  set_attribute(root, "errors", std::to_string(counts[Tally::error]));
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
