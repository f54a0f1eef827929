// A synthetic conformance::RunResult for the report tests and the browser test: every
// verdict (pass, fail, deviation, not applicable, error, and a should-level warning), checks,
// timings, a decoded transcript, samples for the timing diagram, and hostile strings
// (markup, CDATA end, control characters, invalid UTF-8) where a DUT or a vector could put them.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "conformance/result.hpp"
#include "protocol/can/frame.hpp"

namespace drivecheck::test_support {

inline constexpr std::string_view kHostileName =
    "Evil</script><script>alert(1)</script>]]>\x1b[31m\x01\xff\xfe\xc3(drive";

inline can::TimePoint at_ms(std::int64_t ms) {
  return can::TimePoint(std::chrono::duration_cast<can::Duration>(std::chrono::milliseconds(ms)));
}

inline conformance::EvidenceFrame evidence(std::int64_t ms, std::string_view candump,
                                           bool from_harness, std::string decoded) {
  conformance::EvidenceFrame frame;
  frame.at = at_ms(ms);
  frame.frame = *can::parse_candump(candump);
  frame.from_harness = from_harness;
  frame.decoded = std::move(decoded);
  return frame;
}

inline conformance::VectorResult vector(std::string id, conformance::Verdict verdict,
                                        std::int64_t start_ms) {
  conformance::VectorResult result;
  result.family = id.substr(0, id.find('/', id.find('/') + 1));
  result.id = std::move(id);
  result.title = "The device MUST answer " + result.id;
  result.sources = {"000_33c1d912b8b6010a.txt §3.2.2 L764-771"};
  result.level = conformance::Level::must;
  result.file = "vectors/cia301/sdo.yaml";
  result.line = 12;
  result.verdict = verdict;
  result.started = at_ms(start_ms);
  result.finished = at_ms(start_ms + 20);
  result.wall_seconds = 0.001;
  return result;
}

// Seven vectors over four families; counts: pass 2, fail 2 (one a should-level warning),
// deviation 1, not-applicable 1, error 1; exit code 1.
inline conformance::RunResult synthetic_run() {
  using conformance::Verdict;
  conformance::RunResult run;
  auto& info = run.info;
  info.tool_version = "0.1.0";
  info.started_utc = "2026-11-21T08:30:00Z";
  info.bus = "sim";
  info.node = 5;
  info.profile_name = "festo-cmmp";
  info.profile_title = "Festo CMMP-AS-...-M3/-M0";
  info.profile_file = "vectors/drives/festo-cmmp.yaml";
  info.eds_file = "eds/festo.eds";
  info.eds_sha256 = "9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08";
  info.eds_findings = {"eds/festo.eds:12: warning: VendorNumber is empty [identity-empty]",
                       "eds/festo.eds:40: warning: <b>no</b> error control [no-error-control]"};
  info.personality = "festo-cmmp";
  info.deviations = {"no-transition-16"};
  info.seed = 42;
  info.dut.device_type = 0x00020192;
  info.dut.device_name = std::string(kHostileName);
  info.dut.software_version = "1.2.3";
  info.dut.vendor_id = 0x0000001D;
  info.dut.product_code = 0x00001234;
  info.dut.revision = 0x00010002;
  info.dut.serial = 0xCAFE0001;
  run.simulated = std::chrono::milliseconds(700);
  run.wall_seconds = 0.01;

  // pass: an expedited upload of 6041h
  auto pass = vector("cia301/sdo/expedited-upload", Verdict::pass, 0);
  // ccs=2 (initiate upload), 6041h sub 0 / scs=2 e=1 s=1 n=2, 6041h sub 0, data 0250h
  pass.frames = {
      evidence(1, "605#4041600000000000", true, "SDO rx  node 5  initiate upload 6041:00"),
      evidence(2, "585#4B41600050020000", false, "SDO tx  node 5  upload 6041:00 = 0x0250")};
  pass.checks = {{1, "expect_frame", "585#4B416000....0000", "585#4B41600050020000", true, {}, {}}};
  pass.timings = {{"sdo response", std::chrono::microseconds(950), std::nullopt,
                   std::chrono::milliseconds(100), true}};
  run.vectors.push_back(pass);

  // fail: the abort code is wrong; hostile text in the message and the decoded frame
  auto fail = vector("cia301/sdo/abort/write-read-only", Verdict::fail, 20);
  fail.message =
      "vectors/cia301/sdo.yaml:14: step 1 expect_frame: Expected 585#80416000020001 06 (abort "
      "06010002h); Actual 585#80416000000002 06 (abort 06020000h)\n"
      "  Expected: 585#80416000020001 06 (abort 06010002h)\n  Actual:   585#80416000000002 06 "
      "(abort 06020000h) </script> ]]> \x1b[2J";
  // ccs=1 e=1 s=1 n=0, 6041h sub 0, data 0 / abort 6041h sub 0, 06020000h
  fail.frames = {evidence(21, "605#2341600000000000", true, "SDO rx  node 5  download 6041:00"),
                 evidence(22, "585#8041600000000206", false,
                          "SDO tx  node 5  abort 6041:00 06020000h </pre><b>x</b>")};
  fail.checks = {
      {1, "expect_frame", "585#8041600002000106", "585#8041600000000206", false, at_ms(22), {}}};
  fail.checks[0].observed.abort = 0x06020000;  // what the DUT answered, typed
  // a late answer to the vector before, which arrived before this vector's setup
  fail.between_vectors = {
      evidence(20, "585#8040600000000508", false, "SDO tx  node 5  abort 6040:00 08000005h")};
  run.vectors.push_back(fail);

  // deviation: Festo never takes transition 16
  auto deviation = vector("cia402/fsa/transition-16", Verdict::deviation, 40);
  deviation.family = "cia402/fsa";
  deviation.message = "Quick stop active always ends in switch on disabled (605Ah fixed 2)";
  deviation.deviation_id = "no-transition-16";
  deviation.deviation_source = "000_33c1d912b8b6010a.txt §6.1 L5426-5444";
  // controlword 000Fh (enable operation) via SDO: ccs=1 e=1 s=1 n=2, 6040h sub 0
  deviation.frames = {
      evidence(41, "605#2B4060000F000000", true, "SDO rx  node 5  6040:00 = 000Fh")};
  deviation.samples = {{at_ms(40), "controlword", 0x0006},
                       {at_ms(45), "controlword", 0x000F},
                       {at_ms(42), "statusword", 0x0231},
                       {at_ms(47), "statusword", 0x0237},
                       {at_ms(52), "statusword", 0x0217}};
  run.vectors.push_back(deviation);

  // not applicable: the profile lacks homing method 35
  auto na = vector("cia402/homing/method-35", Verdict::not_applicable, 60);
  na.family = "cia402/homing";
  na.message = "the profile does not support homing.method.35";
  na.finished = na.started;
  run.vectors.push_back(na);

  // should-level failure without --strict: a warning
  auto warning = vector("cia301/heartbeat/producer-period", Verdict::fail, 60);
  warning.family = "cia301/heartbeat";
  warning.level = conformance::Level::should;
  warning.warning = true;
  warning.message = "Expected: period 100 ms ± 10 ms\nActual:   112.000 ms";
  warning.timings = {{"heartbeat period", std::chrono::milliseconds(112),
                      std::chrono::milliseconds(90), std::chrono::milliseconds(110), false}};
  run.vectors.push_back(warning);

  // harness error
  auto error = vector("cia301/nmt/reset-communication", Verdict::error, 80);
  error.family = "cia301/nmt";
  error.message = "harness error: the bus went bus-off";
  run.vectors.push_back(error);

  // pass with samples: a profile position move
  auto pp = vector("cia402/pp/single-set-point", Verdict::pass, 100);
  pp.family = "cia402/pp";
  for (int i = 0; i <= 20; ++i) {
    pp.samples.push_back({at_ms(100 + 5 * i), "controlword", i >= 2 && i < 6 ? 0x001F : 0x000F});
    pp.samples.push_back({at_ms(101 + 5 * i), "statusword",
                          0x0237 | (i >= 3 && i < 7 ? 0x1000 : 0) | (i >= 18 ? 0x0400 : 0)});
    pp.samples.push_back({at_ms(102 + 5 * i), "position", i <= 2 ? 0 : std::min(i - 2, 16) * 625});
    pp.samples.push_back({at_ms(102 + 5 * i), "velocity", i > 2 && i < 18 ? 12500 : 0});
  }
  pp.frames = {evidence(100, "605#2B4060001F000000", true, "SDO rx  node 5  6040:00 = 001Fh")};
  pp.finished = at_ms(205);
  run.vectors.push_back(pp);
  return run;
}

// synthetic_run() and what a run interrupted by Ctrl-C adds, with its provenance: every tally
// (pass 2, fail 1, warning 1, deviation 1, not-applicable 1, error 1, interrupted 1; total 8),
// a failed check marked on the timing diagram, the cited documents; exit code 130.
// The ESI of a run with --esi: its file, digest and the device the slave was matched to.
inline void with_esi(conformance::RunResult& run) {
  run.info.esi_file = "esi/reference_drive.xml";
  run.info.esi_sha256 = "2c26b46b68ffc68ff99b453c1d30413413422d706483bfa0f98a5e886266e7ae";
  run.info.esi_device = conformance::EsiDeviceIdentity{0x0000009A, 0x00000402, 0x00010000,
                                                       std::string(kHostileName), 19};
}

inline conformance::RunResult synthetic_run_every_tally() {
  auto run = synthetic_run();
  run.info.revision = "v0.1.0-42-gabcdef0";
  run.info.vector_digest = std::string(64, 'a');
  run.info.vector_files = 12;
  run.info.profile_choice = "--profile festo-cmmp";
  run.info.capabilities = {"heartbeat.producer: present (1017h read 0 ms, written back)"};
  // As a run with --esi gives them (the schema's optional run.esi with its device).
  with_esi(run);
  run.info.documents = {
      {"CiA 301", "CANopen application layer and communication profile", "v4.2.0 (2011-02-21)"},
      {"000_33c1d912b8b6010a.txt", "Festo CMMP-AS-...-M3/-M0 Description", "8046795 1510b"}};
  auto stopped = vector("cia402/pp/change-set-immediately", conformance::Verdict::interrupted, 210);
  stopped.family = "cia402/pp";
  stopped.sources = {"CiA 301 §7.2.4.3.17", "000_33c1d912b8b6010a.txt §3.2.2 L764-771"};
  stopped.message = "interrupted by the user in step 2: no verdict";
  stopped.checks = {{1, "sdo_write", "write 6040h", "ok", true, at_ms(211), {}}};
  run.vectors.push_back(stopped);
  // the pp vector's statusword check failed at 150 ms (marked on its timing diagram)
  for (auto& vector : run.vectors) {
    if (vector.id == "cia402/pp/single-set-point") {
      vector.verdict = conformance::Verdict::fail;
      vector.message =
          "vectors/cia402/pp.yaml:40: step 3 expect_statusword: Expected bit 10 set; Actual 0237h";
      vector.checks = {{3, "expect_statusword", "bit 10 set", "0237h", false, at_ms(150), {}}};
    }
    if (vector.id == "cia301/sdo/abort/write-read-only") {
      vector.verdict = conformance::Verdict::pass;
      vector.message.clear();
      vector.checks[0].ok = true;
    }
  }
  run.interrupted = true;
  return run;
}

}  // namespace drivecheck::test_support
