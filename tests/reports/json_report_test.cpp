// The JSON report: its stable keys, the write → read round trip, and clear errors on bad files.
#include <gtest/gtest.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>

#include "reports/report_writers.hpp"
#include "tests/reports/synthetic_run.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::reports {
namespace {

using conformance::Verdict;
using nlohmann::json;
using test_support::synthetic_run;
using test_support::TempDir;

conformance::RunResult valid_utf8_run() {
  auto run = synthetic_run();
  run.info.dut.device_name = "CMMP-AS \x1b[31m</script>]]> §";  // hostile but valid UTF-8
  return run;
}

TEST(JsonReport, HasSchemaVersionCountsAndTimesInNanosecondsAndSeconds) {
  // Given the synthetic run with every verdict
  // When written as JSON
  // Then the document has schema_version 4, counts per tally (a warning is not a fail), the
  //      exit code, and each frame's time both as t_ns and t_s
  const json document = json::parse(render_json(valid_utf8_run()));
  EXPECT_EQ(document["schema_version"], 4);
  EXPECT_EQ(document["counts"]["pass"], 2);
  EXPECT_EQ(document["counts"]["fail"], 1);
  EXPECT_EQ(document["counts"]["warning"], 1);
  EXPECT_EQ(document["counts"]["deviation"], 1);
  EXPECT_EQ(document["counts"]["not-applicable"], 1);
  EXPECT_EQ(document["counts"]["error"], 1);
  EXPECT_EQ(document["counts"]["interrupted"], 0);
  EXPECT_EQ(document["counts"]["total"], 7);
  EXPECT_EQ(document["exit_code"], 1);
  const json& frame = document["vectors"][0]["frames"][1];
  EXPECT_EQ(frame["t_ns"], 2'000'000);
  EXPECT_DOUBLE_EQ(frame["t_s"].get<double>(), 0.002);
  EXPECT_EQ(frame["frame"], "585#4B41600050020000");
  EXPECT_EQ(document["run"]["dut"]["vendor_id"], 0x1D);
  EXPECT_FALSE(document["run"]["dut"].contains("hardware_version"));  // not readable
  EXPECT_EQ(document["vectors"][2]["deviation_source"], "000_33c1d912b8b6010a.txt §6.1 L5426-5444");
}

TEST(JsonReport, FailedCheckCarriesItsTypedObservation) {
  // Given the synthetic run, whose failed expect_frame observed abort 06020000h
  // When written as JSON
  // Then that check has observed.abort as an integer and nothing else; passed checks have none
  const json document = json::parse(render_json(valid_utf8_run()));
  const json& failed = document["vectors"][1]["checks"][0];
  ASSERT_FALSE(failed["ok"].get<bool>());
  EXPECT_EQ(failed["observed"], json({{"abort", 0x06020000}}));
  EXPECT_FALSE(document["vectors"][0]["checks"][0].contains("observed"));
}

TEST(JsonReport, WriteThenReadGivesTheSameRun) {
  // Given the synthetic run (hostile but valid UTF-8 strings)
  // When written to a file and read back
  // Then the run read renders to the identical document and its fields are the originals
  TempDir dir;
  const auto original = valid_utf8_run();
  ASSERT_TRUE(write_json_report(dir / "run.json", original));
  const auto read = read_json_report(dir / "run.json");
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_EQ(render_json(*read), render_json(original));
  EXPECT_EQ(read->info.dut.device_name, original.info.dut.device_name);
  EXPECT_EQ(read->info.dut.serial, 0xCAFE0001u);
  EXPECT_FALSE(read->info.dut.hardware_version.has_value());
  ASSERT_EQ(read->vectors.size(), original.vectors.size());
  for (std::size_t i = 0; i < original.vectors.size(); ++i) {
    const auto& a = original.vectors[i];
    const auto& b = read->vectors[i];
    EXPECT_EQ(b.id, a.id);
    EXPECT_EQ(b.verdict, a.verdict);
    EXPECT_EQ(b.level, a.level);
    EXPECT_EQ(b.warning, a.warning);
    EXPECT_EQ(b.message, a.message);
    EXPECT_EQ(b.started, a.started);
    EXPECT_EQ(b.finished, a.finished);
    ASSERT_EQ(b.frames.size(), a.frames.size());
    for (std::size_t f = 0; f < a.frames.size(); ++f) {
      EXPECT_EQ(b.frames[f].frame, a.frames[f].frame);
      EXPECT_EQ(b.frames[f].at, a.frames[f].at);
      EXPECT_EQ(b.frames[f].decoded, a.frames[f].decoded);
    }
    ASSERT_EQ(b.timings.size(), a.timings.size());
    for (std::size_t t = 0; t < a.timings.size(); ++t) {
      EXPECT_EQ(b.timings[t].min, a.timings[t].min);
      EXPECT_EQ(b.timings[t].max, a.timings[t].max);
    }
    EXPECT_EQ(b.samples.size(), a.samples.size());
    ASSERT_EQ(b.checks.size(), a.checks.size());
    for (std::size_t c = 0; c < a.checks.size(); ++c)
      EXPECT_EQ(b.checks[c].observed, a.checks[c].observed);
  }
}

TEST(JsonReport, RepeatedPatternsAreWrittenAndReadBack) {
  // Given a vector whose frame 0 starts a pattern (frame 1 its last time) left out 40 times, and
  // an EtherCAT vector whose first datagram starts one of length 1
  auto run = valid_utf8_run();
  auto& frames = run.vectors.at(0).frames;
  ASSERT_GE(frames.size(), 2U);
  frames[0].repeat = {1, 40, frames[0].at + std::chrono::milliseconds(400)};
  auto& ecat = run.vectors.at(1);
  ecat.datagrams = {{ecat.started, ecat.started, 1, "FPRD station 1001h 080Dh SM1 status", {}},
                    {ecat.started, ecat.started, 1, "FPRD station 1001h 080Dh SM1 status", {}}};
  ecat.datagrams[0].repeat = {1, 7, ecat.started + std::chrono::milliseconds(7)};
  // When written and read back
  const json document = json::parse(render_json(run));
  const auto read = parse_json_report(document.dump());
  // Then each is an object {length, times, until_ns} on its entry and comes back the same
  EXPECT_EQ(document["vectors"][0]["frames"][0]["repeat"]["length"], 1);
  EXPECT_EQ(document["vectors"][0]["frames"][0]["repeat"]["times"], 40);
  EXPECT_FALSE(document["vectors"][0]["frames"][1].contains("repeat"));
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_EQ(read->vectors.at(0).frames[0].repeat, frames[0].repeat);
  EXPECT_EQ(read->vectors.at(1).datagrams, ecat.datagrams);
  // And a pattern that runs past the list, and schema 3 (no patterns), are told apart
  json past = document;
  past["vectors"][1]["datagrams"][0]["repeat"]["length"] = 2;
  EXPECT_EQ(parse_json_report(past.dump()).error().message,
            "vectors[1].datagrams[0].repeat.length: the pattern and its last repetition run past "
            "the list");
  json older = json::parse(render_json(valid_utf8_run()));
  older["schema_version"] = 3;
  EXPECT_TRUE(parse_json_report(older.dump()));
}

TEST(JsonReport, IterationOfARepeatedStepIsWrittenAndReadBack) {
  // Given a failed check in iteration 117 of 254 of a repeat inside pass 2 of 3 of another
  auto run = valid_utf8_run();
  auto& check = run.vectors.at(1).checks.at(0);
  check.iterations = {{2, 3}, {117, 254}};
  // When written and read back
  const json document = json::parse(render_json(run));
  const auto read = parse_json_report(document.dump());
  // Then the check has iterations outermost first, checks outside a repeat have none, and the
  // pass comes back the same; a pass beyond its count is an error naming its place
  EXPECT_EQ(document["vectors"][1]["checks"][0]["iterations"],
            json::parse(R"([{"iteration": 2, "of": 3}, {"iteration": 117, "of": 254}])"));
  EXPECT_FALSE(document["vectors"][0]["checks"][0].contains("iterations"));
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_EQ(read->vectors.at(1).checks.at(0).iterations, check.iterations);
  EXPECT_EQ(conformance::step_label(check.step, check.iterations),
            "step " + std::to_string(check.step) + " (iteration 117 of 254 in iteration 2 of 3)");
  json bad = document;
  bad["vectors"][1]["checks"][0]["iterations"][1]["iteration"] = 255;
  EXPECT_EQ(parse_json_report(bad.dump()).error().message,
            "vectors[1].checks[0].iterations[1].iteration: not within 1..of");
}

TEST(JsonReport, CommissioningIsListedUnderTheProfileAndReadBack) {
  // Given a run whose profile commissions the drive (festo-cmmp.yaml `commissioning:`)
  // When written as JSON and read back
  // Then run.profile.commissioning holds its lines in order, and a run without one has no key
  TempDir dir;
  auto run = valid_utf8_run();
  run.info.commissioning = {"applies to cia402/* except cia402/factor/festo/*",
                            "6094h sub 1 := 15 (4 bytes): numerator [000 §5.3 L2707-2755]"};
  const json document = json::parse(render_json(run));
  EXPECT_EQ(document["run"]["profile"]["commissioning"][1],
            "6094h sub 1 := 15 (4 bytes): numerator [000 §5.3 L2707-2755]");
  ASSERT_TRUE(write_json_report(dir / "run.json", run));
  const auto read = read_json_report(dir / "run.json");
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_EQ(read->info.commissioning, run.info.commissioning);
  EXPECT_FALSE(
      json::parse(render_json(valid_utf8_run()))["run"]["profile"].contains("commissioning"));
}

TEST(JsonReport, ProfileChoiceAndCapabilitiesAreWrittenAndReadBack) {
  // Given a run whose profile was chosen from 1000h and whose DUT was probed
  TempDir dir;
  auto run = valid_utf8_run();
  run.info.profile_choice = "no --profile; 1000h = 00020192h: device profile 402, a CiA 402 drive";
  run.info.capabilities = {"heartbeat.producer: present (1017h read 0 ms, written back)",
                           "object 1029h: absent (upload answered 06020000h)"};
  // When written as JSON and read back
  const json document = json::parse(render_json(run));
  ASSERT_TRUE(write_json_report(dir / "run.json", run));
  const auto read = read_json_report(dir / "run.json");
  // Then run.profile.choice and run.capabilities hold them; a run without them has no keys
  EXPECT_EQ(document["run"]["capabilities"][1], "object 1029h: absent (upload answered 06020000h)");
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_EQ(read->info.profile_choice, run.info.profile_choice);
  EXPECT_EQ(read->info.capabilities, run.info.capabilities);
  EXPECT_FALSE(json::parse(render_json(valid_utf8_run()))["run"].contains("capabilities"));
}

TEST(JsonReport, EdsFindingsAreWrittenAndReadBack) {
  // Given a run whose EDS had two lint findings
  TempDir dir;
  const auto run = valid_utf8_run();
  // When written as JSON and read back
  const json document = json::parse(render_json(run));
  ASSERT_TRUE(write_json_report(dir / "run.json", run));
  const auto read = read_json_report(dir / "run.json");
  // Then run.eds.findings lists them in order; a run without findings has no key
  ASSERT_EQ(document["run"]["eds"]["findings"].size(), 2u);
  EXPECT_EQ(document["run"]["eds"]["findings"][0],
            "eds/festo.eds:12: warning: VendorNumber is empty [identity-empty]");
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_EQ(read->info.eds_findings, run.info.eds_findings);
  auto clean = valid_utf8_run();
  clean.info.eds_findings.clear();
  EXPECT_FALSE(json::parse(render_json(clean))["run"]["eds"].contains("findings"));
}

TEST(JsonReport, EsiFileDigestAndDeviceAreWrittenAndReadBack) {
  // Given a run with --esi: the ESI's file, its sha256 and the ESI device the slave matched
  TempDir dir;
  auto run = valid_utf8_run();
  test_support::with_esi(run);
  run.info.esi_device->name = "drivecheck reference drive";
  // When written as JSON and read back
  const json document = json::parse(render_json(run));
  ASSERT_TRUE(write_json_report(dir / "run.json", run));
  const auto read = read_json_report(dir / "run.json");
  // Then run.esi holds them as the EDS's are held (file, sha256), with the device's identity
  EXPECT_EQ(document["run"]["esi"]["file"], "esi/reference_drive.xml");
  EXPECT_EQ(document["run"]["esi"]["sha256"], run.info.esi_sha256);
  EXPECT_EQ(document["run"]["esi"]["device"]["vendor_id"], 0x9A);
  EXPECT_EQ(document["run"]["esi"]["device"]["product_code"], 0x402);
  EXPECT_EQ(document["run"]["esi"]["device"]["revision"], 0x10000);
  EXPECT_EQ(document["run"]["esi"]["device"]["name"], "drivecheck reference drive");
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_EQ(read->info.esi_file, run.info.esi_file);
  EXPECT_EQ(read->info.esi_sha256, run.info.esi_sha256);
  ASSERT_TRUE(read->info.esi_device.has_value());
  EXPECT_EQ(read->info.esi_device->vendor_id, 0x9Au);
  EXPECT_EQ(read->info.esi_device->product_code, 0x402u);
  EXPECT_EQ(read->info.esi_device->revision, 0x10000u);
  EXPECT_EQ(read->info.esi_device->name, "drivecheck reference drive");
  // And a run without --esi has no run.esi at all (reports of schema 4 before it stay valid)
  const auto plain = valid_utf8_run();
  EXPECT_FALSE(json::parse(render_json(plain))["run"].contains("esi"));
  ASSERT_TRUE(write_json_report(dir / "plain.json", plain));
  const auto plain_read = read_json_report(dir / "plain.json");
  ASSERT_TRUE(plain_read) << plain_read.error().to_string();
  EXPECT_TRUE(plain_read->info.esi_file.empty());
  EXPECT_FALSE(plain_read->info.esi_device.has_value());
}

TEST(JsonReport, EsiDeviceWithoutAKeyIsAnError) {
  // Given a report whose run.esi.device lacks product_code
  auto run = valid_utf8_run();
  test_support::with_esi(run);
  json document = json::parse(render_json(run));
  document["run"]["esi"]["device"].erase("product_code");
  // When read; Then the error names the key
  const auto read = parse_json_report(document.dump());
  ASSERT_FALSE(read);
  EXPECT_NE(read.error().to_string().find("run.esi.device.product_code"), std::string::npos)
      << read.error().to_string();
}

TEST(JsonReport, RunOrderIsWrittenAndReadBackAndDefaultsToFile) {
  // Given a run made with --order shuffle:7
  TempDir dir;
  auto run = valid_utf8_run();
  run.info.order = "shuffle:7";
  // When written as JSON and read back
  ASSERT_TRUE(write_json_report(dir / "run.json", run));
  const auto read = read_json_report(dir / "run.json");
  ASSERT_TRUE(read) << read.error().to_string();
  // Then run.order holds it; a report without the key (older drivecheck) reads as file order
  EXPECT_EQ(json::parse(render_json(run))["run"]["order"], "shuffle:7");
  EXPECT_EQ(read->info.order, "shuffle:7");
  json older = json::parse(render_json(run));
  older["run"].erase("order");
  ASSERT_TRUE(write_file_atomically(dir / "older.json", older.dump()));
  const auto read_older = read_json_report(dir / "older.json");
  ASSERT_TRUE(read_older) << read_older.error().to_string();
  EXPECT_EQ(read_older->info.order, "file");
}

TEST(JsonReport, FactoryRestoreChoiceIsWrittenAndReadBackAndDefaultsToNotAllowed) {
  // Given a run made with --allow-factory-restore
  TempDir dir;
  auto run = valid_utf8_run();
  run.info.allow_factory_restore = true;
  // When written as JSON and read back
  ASSERT_TRUE(write_json_report(dir / "run.json", run));
  const auto read = read_json_report(dir / "run.json");
  ASSERT_TRUE(read) << read.error().to_string();
  // Then run.allow_factory_restore holds it; a report without the key (older drivecheck) reads
  // as not allowed
  EXPECT_EQ(json::parse(render_json(run))["run"]["allow_factory_restore"], true);
  EXPECT_TRUE(read->info.allow_factory_restore);
  json older = json::parse(render_json(run));
  older["run"].erase("allow_factory_restore");
  ASSERT_TRUE(write_file_atomically(dir / "older.json", older.dump()));
  const auto read_older = read_json_report(dir / "older.json");
  ASSERT_TRUE(read_older) << read_older.error().to_string();
  EXPECT_FALSE(read_older->info.allow_factory_restore);
}

TEST(JsonReport, InvalidUtf8IsWrittenAsReplacementCharacter) {
  // Given a device name with invalid UTF-8 bytes
  // When written as JSON
  // Then the document is valid JSON whose name has U+FFFD in place of each bad byte
  const auto text = render_json(synthetic_run());
  const json document = json::parse(text);
  const std::string name = document["run"]["dut"]["device_name"];
  EXPECT_NE(name.find("\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD("), std::string::npos) << name;
  EXPECT_NE(name.find("</script>"), std::string::npos);
}

TEST(JsonReportRead, SyntaxErrorNamesFileAndLine) {
  // Given a file whose third line breaks the JSON syntax
  // When read
  // Then the error is "<file>:3: not valid JSON: ..."
  TempDir dir;
  const auto path = dir.write("bad.json", "{\n  \"schema_version\": 2,\n  \"run\": ]\n}\n");
  const auto read = read_json_report(path);
  ASSERT_FALSE(read);
  EXPECT_EQ(read.error().file, path.string());
  EXPECT_EQ(read.error().line, 3);
  EXPECT_NE(read.error().message.find("not valid JSON"), std::string::npos);
}

TEST(JsonReportRead, StructuralErrorsNameTheKey) {
  // Given reports with a wrong schema version, a misspelt verdict, a missing key and a bad frame
  // When parsed
  // Then each error names the JSON path and what is wrong
  json document = json::parse(render_json(valid_utf8_run()));
  json wrong_version = document;
  wrong_version["schema_version"] = 5;
  EXPECT_NE(parse_json_report(wrong_version.dump()).error().message.find("schema_version: 5"),
            std::string::npos);
  json bad_verdict = document;
  bad_verdict["vectors"][3]["verdict"] = "pased";
  EXPECT_EQ(parse_json_report(bad_verdict.dump()).error().message,
            "vectors[3].verdict: unknown verdict \"pased\"");
  json missing = document;
  missing["vectors"][0]["checks"][0].erase("actual");
  EXPECT_EQ(parse_json_report(missing.dump()).error().message,
            "vectors[0].checks[0].actual: missing");
  json bad_frame = document;
  bad_frame["vectors"][1]["frames"][0]["frame"] = "605#ZZ";
  EXPECT_NE(
      parse_json_report(bad_frame.dump()).error().message.find("vectors[1].frames[0].frame: "),
      std::string::npos);
  json not_object = json::array();
  EXPECT_FALSE(parse_json_report(not_object.dump()));
  EXPECT_NE(parse_json_report("{}").error().message.find("not a drivecheck JSON report"),
            std::string::npos);
}

TEST(JsonReportRead, ExtremeTimesAreRejectedAndExtremeSamplesRender) {
  // Given a report whose frame time is INT64_MAX ns, and one whose samples are INT64_MIN and
  //       INT64_MAX
  // When read (and the second rendered as HTML)
  // Then the time is "out of range" (differences of times could overflow), the samples are
  //      read and drawn
  json document = json::parse(render_json(valid_utf8_run()));
  json far = document;
  far["vectors"][0]["frames"][0]["t_ns"] = INT64_MAX;
  EXPECT_EQ(parse_json_report(far.dump()).error().message,
            "vectors[0].frames[0].t_ns: out of range");
  json extreme = document;
  extreme["vectors"][6]["samples"][2]["value"] = INT64_MIN;
  extreme["vectors"][6]["samples"][6]["value"] = INT64_MAX;
  const auto read = parse_json_report(extreme.dump());
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_NE(render_html(*read).find("<svg class=\"timing\""), std::string::npos);
}

TEST(JsonReportRead, SampleOriginsRoundTripAndDefaultToSdo) {
  // Given a vector with SDO, TPDO and RPDO samples and 7 samples thinned out
  auto run = valid_utf8_run();
  auto& vector = run.vectors[6];
  ASSERT_GE(vector.samples.size(), 3U);
  vector.samples[0].origin = conformance::SampleOrigin::tpdo;
  vector.samples[1].origin = conformance::SampleOrigin::rpdo;
  vector.samples_elided = 7;
  // When written and read back
  json document = json::parse(render_json(run));
  const auto read = parse_json_report(document.dump());
  ASSERT_TRUE(read) << read.error().to_string();
  // Then the origins and the count are kept
  EXPECT_EQ(read->vectors[6].samples[0].origin, conformance::SampleOrigin::tpdo);
  EXPECT_EQ(read->vectors[6].samples[1].origin, conformance::SampleOrigin::rpdo);
  EXPECT_EQ(read->vectors[6].samples[2].origin, conformance::SampleOrigin::sdo);
  EXPECT_EQ(read->vectors[6].samples_elided, 7U);
  EXPECT_EQ(document["vectors"][6]["samples"][0]["origin"], "tpdo");
  // And a report without them (older writers) reads as SDO samples, none thinned out
  json old = document;
  for (auto& sample : old["vectors"][6]["samples"])
    sample.erase("origin");
  old["vectors"][6].erase("samples_elided");
  const auto read_old = parse_json_report(old.dump());
  ASSERT_TRUE(read_old) << read_old.error().to_string();
  EXPECT_EQ(read_old->vectors[6].samples[0].origin, conformance::SampleOrigin::sdo);
  EXPECT_EQ(read_old->vectors[6].samples_elided, 0U);
  // And an unknown origin is an error that names it
  json wrong = document;
  wrong["vectors"][6]["samples"][1]["origin"] = "mpdo";
  EXPECT_EQ(parse_json_report(wrong.dump()).error().message,
            "vectors[6].samples[1].origin: unknown origin \"mpdo\"");
}

TEST(JsonReportRead, MissingFileIsAnError) {
  // Given a path with no file
  // When read
  // Then the error names the file
  TempDir dir;
  const auto read = read_json_report(dir / "absent.json");
  ASSERT_FALSE(read);
  EXPECT_NE(read.error().to_string().find("absent.json"), std::string::npos);
}

}  // namespace
}  // namespace drivecheck::reports

namespace drivecheck::reports {
namespace {

TEST(JsonReportRead, SchemaOneStepsAreRenumberedFromOne) {
  // Given a schema 1 report (steps counted from 0, no between_vectors, no provenance)
  json older = json::parse(render_json(test_support::synthetic_run()));
  older["schema_version"] = 1;
  older["vectors"][0]["checks"][0]["step"] = 0;
  older["vectors"][0].erase("between_vectors");
  older["run"].erase("revision");
  older["run"].erase("vector_set");
  older["run"].erase("documents");
  // When read
  const auto read = parse_json_report(older.dump());
  // Then it reads, with its first step numbered 1 as schema 2 numbers it
  ASSERT_TRUE(read) << read.error().to_string();
  EXPECT_EQ(read->vectors[0].checks[0].step, 1U);
}

TEST(JsonReport, ProvenanceBetweenVectorsAndCheckTimesRoundTrip) {
  // Given a run with the revision, the vector digest, cited documents, frames between vectors
  //       and a failed check's time
  const auto run = test_support::synthetic_run_every_tally();
  // When written and read back
  const auto read = parse_json_report(render_json(run));
  ASSERT_TRUE(read) << read.error().to_string();
  // Then all of it is there
  EXPECT_EQ(read->info.revision, "v0.1.0-42-gabcdef0");
  EXPECT_EQ(read->info.vector_digest, std::string(64, 'a'));
  EXPECT_EQ(read->info.vector_files, 12U);
  ASSERT_EQ(read->info.documents.size(), 2U);
  EXPECT_EQ(read->info.documents[0].edition, "v4.2.0 (2011-02-21)");
  ASSERT_EQ(read->vectors[1].between_vectors.size(), 1U);
  EXPECT_EQ(can::to_candump(read->vectors[1].between_vectors[0].frame), "585#8040600000000508");
  EXPECT_EQ(read->vectors[1].checks[0].at, test_support::at_ms(22));
  EXPECT_EQ(read->vectors.back().verdict, conformance::Verdict::interrupted);
}

}  // namespace
}  // namespace drivecheck::reports
