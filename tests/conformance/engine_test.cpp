// The engine (conformance/engine.hpp) against scripted peers and the reference drive on the
// simulated bus: each step kind passing and failing, timeouts, dut_lost, evidence.
#include "conformance/engine.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <string>

#include "conformance/capabilities.hpp"
#include "conformance/od_checks.hpp"
#include "conformance/vector_file.hpp"
#include "protocol/can/sim_bus.hpp"
#include "reference_drive/device.hpp"
#include "tests/support/scripted_peer.hpp"

namespace drivecheck::conformance {
namespace {

using namespace std::chrono_literals;

profile::DriveProfile make_profile() {
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [sdo.segmented, heartbeat.producer]\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return *parsed;
}

// A vector without setup (scripted peers do not boot), with `steps` (YAML, indented 4).
Vector make_vector(const std::string& steps, const std::string& extra = "") {
  const auto set = parse_vectors(
      "- id: t/x\n  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n" + extra +
          "  steps:\n" + steps,
      "t.yaml");
  EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
  return set.vectors.empty() ? Vector{} : set.vectors.front();
}

class EngineTest : public ::testing::Test {
 protected:
  EngineTest()
      : harness_(bus_.attach("harness")),
        peer_port_(bus_.attach("peer")),
        profile_(make_profile()) {}

  // Scripted peers answer exactly the frames of their script: no isolation snapshot/restore.
  static EngineOptions scripted() {
    EngineOptions options;
    options.isolation = false;
    return options;
  }
  VectorResult run(const Vector& vector, EngineOptions options = scripted()) {
    Engine engine(*harness_, profile_, std::move(options));
    return engine.run_vector(vector);
  }
  std::string failure(const VectorResult& result) {
    return result.checks.empty()
               ? result.message
               : result.checks.back().expected + " / " + result.checks.back().actual;
  }

  can::SimBus bus_{{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> harness_;
  std::unique_ptr<can::SimPort> peer_port_;
  profile::DriveProfile profile_;
};

TEST_F(EngineTest, SdoWriteExpectedAbortPasses) {
  // Given a peer that aborts a write of 6041h with 06010002h
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#2B41600000000000")  // ccs=1 n=2 e=1 s=1, 6041h sub 0, data 0000h
      .reply("581#8041600002000106");  // abort 6041h sub 0, 06010002h
  // When the vector expects that abort
  const auto result =
      run(make_vector("    - sdo_write: {index: 0x6041, sub: 0, value: 0, size: 2}\n      expect: "
                      "{abort: write-read-only}\n"),
          scripted());
  // Then it passes, with the check and both frames as evidence
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  ASSERT_EQ(result.checks.size(), 1U);
  EXPECT_TRUE(result.checks[0].ok);
  ASSERT_EQ(result.frames.size(), 2U);
  EXPECT_TRUE(result.frames[0].from_harness);
  EXPECT_FALSE(result.frames[1].from_harness);
  EXPECT_FALSE(result.frames[1].decoded.empty());
  EXPECT_TRUE(peer.finished());
}

// A server that aborts every request at once: whatever the transfer, the vector sees the abort
// (never "did not answer in time").
struct AbortCase {
  const char* name;
  const char* step;                   // the vector step (YAML, indented 4)
  std::vector<const char*> exchange;  // expected frame, then its reply, alternating
};

TEST_F(EngineTest, EveryAbortAnswerIsSeenAsAnAbort) {
  const std::vector<AbortCase> cases = {
      {"segmented download initiate",
       "    - sdo_write: {index: 0x2000, sub: 1, data: \"01 02 03 04 05 06 07 08\"}\n",
       {"601#2100200108000000",    // ccs=1 s=1: initiate segmented, 8 bytes
        "581#8000200102000106"}},  // abort 2000h sub 1, 06010002h
      {"segmented download segment",
       "    - sdo_write: {index: 0x2000, sub: 1, data: \"01 02 03 04 05 06 07 08\"}\n",
       {"601#2100200108000000", "581#6000200100000000",  // initiate, response
        "601#0001020304050607",                          // segment toggle 0
        "581#8000200102000106"}},                        // abort 06010002h
      {"block download initiate",
       "    - sdo_write: {index: 0x2000, sub: 1, data: \"01 02 03 04 05 06 07 08\"}\n"
       "      transfer: block\n",
       {"601#C600200108000000",    // ccs=6 cc=1 s=1 cs=0: block download initiate, 8 bytes
        "581#8000200102000106"}},  // abort 06010002h
      {"block upload initiate",
       "    - sdo_read: {index: 0x2000, sub: 1}\n      transfer: block\n",
       {"601#A40020017F000000",    // ccs=5 cc=1 cs=0: block upload initiate, blksize 127
        "581#8000200102000106"}},  // abort 06010002h
      {"block upload sub-block",
       "    - sdo_read: {index: 0x2000, sub: 1}\n      transfer: block\n",
       {"601#A40020017F000000", "581#C600200109000000",  // initiate, response: 9 bytes
        "601#A300000000000000",                          // start
        "581#8000200102000106"}},                        // abort instead of a segment
      {"segmented upload segment",
       "    - sdo_read: {index: 0x2000, sub: 1}\n",
       {"601#4000200100000000", "581#4100200109000000",  // initiate, response: 9 bytes
        "601#6000000000000000",                          // segment request toggle 0
        "581#8000200102000106"}},                        // abort 06010002h
      {"abort naming another object",
       "    - sdo_read: {index: 0x2000, sub: 1}\n",
       {"601#4000200100000000",    // ccs=2 upload 2000h sub 1
        "581#8000000002000106"}},  // abort 0000h sub 0, 06010002h
  };
  for (const auto& c : cases) {
    // Given a peer that answers the request with an abort (06010002h)
    can::SimBus bus({.bitrate = 1'000'000});
    auto harness = bus.attach("harness");
    auto peer_port = bus.attach("peer");
    test_support::ScriptedPeer peer(*peer_port, {0x601});
    peer.set_mismatch_handler([](const std::string&) {});  // block segments after the abort
    for (std::size_t i = 0; i + 1 < c.exchange.size(); i += 2)
      peer.expect(c.exchange[i]).reply(c.exchange[i + 1]);
    // When the vector expects that abort
    Engine engine(*harness, profile_, scripted());
    const auto result = engine.run_vector(
        make_vector(std::string(c.step) + "      expect: {abort: [0x06010002]}\n"));
    // Then it passes: the abort is the answer
    EXPECT_EQ(result.verdict, Verdict::pass) << c.name << "\n" << result.message;
  }
}

TEST_F(EngineTest, EveryCodeOfTheNamedSetPasses) {
  // Given peers that answer a write to read-only 6041h with each code of write-read-only
  for (const char* reply : {"581#8041600000000106",     // abort 6041h sub 0, 06010000h
                            "581#8041600002000106",     // abort 6041h sub 0, 06010002h
                            "581#8041600000000008"}) {  // abort 6041h sub 0, 08000000h
    test_support::ScriptedPeer peer(*peer_port_);
    peer.expect("601#2B41600000000000")  // ccs=1 n=2 e=1 s=1, 6041h sub 0, data 0000h
        .reply(reply);
    // When the vector expects the set
    const auto result =
        run(make_vector("    - sdo_write: {index: 0x6041, sub: 0, value: 0, size: 2}\n"
                        "      expect: {abort: write-read-only}\n"));
    // Then each passes
    EXPECT_EQ(result.verdict, Verdict::pass) << reply << ": " << result.message;
  }
}

TEST_F(EngineTest, RawAbortFrameJudgedByTheSet) {
  // Given peers that answer an upload of missing 1FFFh with 08000000h (in the set) and with
  // 06090011h (not in object-does-not-exist)
  const std::string steps =
      "    - send: \"601#40FF1F0000000000\"\n"          // ccs=2, upload 1FFFh sub 0
      "    - expect_frame: \"581#80FF1F00........\"\n"  // abort 1FFFh sub 0, code: the set
      "      abort: object-does-not-exist\n";
  {
    test_support::ScriptedPeer peer(*peer_port_);
    peer.expect("601#40FF1F0000000000").reply("581#80FF1F0000000008");  // 08000000h
    const auto result = run(make_vector(steps));
    // Then the code inside the set passes
    EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  }
  {
    test_support::ScriptedPeer peer(*peer_port_);
    peer.expect("601#40FF1F0000000000").reply("581#80FF1F0011000906");  // 06090011h
    const auto result = run(make_vector(steps));
    // And the code outside it fails, naming the set, with the code as the observation
    EXPECT_EQ(result.verdict, Verdict::fail);
    EXPECT_NE(result.message.find("abort in object-does-not-exist {06020000h, 08000000h} "
                                  "(CTT 2.6; CiA 301 §7.2.4.3.17)"),
              std::string::npos)
        << result.message;
    EXPECT_EQ(result.checks.back().observed.abort, 0x06090011U);
  }
}

TEST_F(EngineTest, DeviationOnlyForTheDocumentedAbort) {
  // Given a profile documenting that a write to 6041h is aborted with 06090030h
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [sdo.segmented]\ndeviations:\n  - id: d\n    vectors: "
      "[t/x]\n    observed: {abort: 0x06090030}\n    source: \"CiA 301 §1\"\n    description: "
      "documented\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  const auto vector = make_vector(
      "    - sdo_write: {index: 0x6041, sub: 0, value: 0, size: 2}\n"
      "      expect: {abort: write-read-only}\n");
  const auto judge = [&](const char* reply) {
    test_support::ScriptedPeer peer(*peer_port_);
    peer.expect("601#2B41600000000000").reply(reply);
    Engine engine(*harness_, *parsed, scripted());
    return engine.run_vector(vector);
  };
  // When the DUT answers the documented code / another code outside the set
  const auto documented = judge("581#8041600030000906");  // abort 06090030h
  const auto other = judge("581#8041600031000906");       // abort 06090031h
  // Then the first is the deviation, the second a failure naming the deviation it missed
  EXPECT_EQ(documented.verdict, Verdict::deviation) << documented.message;
  EXPECT_EQ(other.verdict, Verdict::fail);
  EXPECT_NE(other.message.find("not the documented deviation d"), std::string::npos)
      << other.message;
  EXPECT_NE(other.message.find("it documents abort 06090030h, the DUT showed abort 06090031h"),
            std::string::npos)
      << other.message;
}

TEST_F(EngineTest, WrongAbortCodeFailsWithExpectedActual) {
  // Given a peer that answers a write to a read-only object with 06090030h instead
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#2B41600000000000")  // ccs=1 n=2 e=1 s=1, 6041h sub 0, data 0000h
      .reply("581#8041600030000906");  // abort 6041h sub 0, 06090030h (value range)
  // When the vector expects 06010002h
  const auto result =
      run(make_vector("    - sdo_write: {index: 0x6041, sub: 0, value: 0, size: 2}\n      expect: "
                      "{abort: write-read-only}\n"),
          scripted());
  // Then it fails, and the message shows both codes
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_NE(result.message.find("Expected: write 6041h sub 0 := 00 00: abort in write-read-only "
                                "{06010000h, 06010002h, 08000000h} (CTT 2.3, 4.3; CiA 301 "
                                "§7.2.4.3.17)"),
            std::string::npos)
      << result.message;
  // And the failing check carries the code as data
  EXPECT_EQ(result.checks.back().observed.abort, 0x06090030U);
  EXPECT_NE(result.message.find("Actual:   abort 06090030h"), std::string::npos) << result.message;
  ASSERT_FALSE(result.checks.empty());
  EXPECT_FALSE(result.checks.back().ok);
}

// An optional value (6088h = 1, the sin² ramp) that the device may refuse.
const std::string kOptionalValue =
    "    - sdo_write: {index: 0x6088, sub: 0, value: 1, size: 2}\n"
    "      refused_means_not_applicable: value-range\n"
    "      clause: \"CiA 402-2 §6088h torque profile type\"\n"
    "    - sdo_read: {index: 0x6088, sub: 0}\n"
    "      expect: {value: 1}\n";

TEST_F(EngineTest, RefusedOptionalValueMakesTheVectorNotApplicable) {
  // Given a drive that refuses 6088h = 1 with 06090030h (value range exceeded)
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#2B88600001000000")  // ccs=1 n=2 e=1 s=1, 6088h sub 0, data 0001h
      .reply("581#8088600030000906");  // abort 6088h sub 0, 06090030h
  // When the vector writes it with refused_means_not_applicable: value-range
  const auto result = run(make_vector(kOptionalValue));
  // Then it is not applicable, naming the refusal, and the read after it never ran
  EXPECT_EQ(result.verdict, Verdict::not_applicable) << result.message;
  EXPECT_NE(result.message.find("device refused 6088h = 1 (06090030h), a value it may refuse "
                                "(CiA 402-2 §6088h torque profile type): step 1, t.yaml:"),
            std::string::npos)
      << result.message;
  EXPECT_TRUE(peer.finished());
}

TEST_F(EngineTest, RefusedValueIsNamedInHexAsTheManualsWriteIt) {
  // Given a drive that refuses 6083h = 10000 (2710h) with 06090031h (value too high)
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#2383600010270000")  // ccs=1 n=0 e=1 s=1, 6083h sub 0, data 00002710h
      .reply("581#8083600031000906");  // abort 6083h sub 0, 06090031h
  // When the vector writes it with refused_means_not_applicable: value-range
  const auto result =
      run(make_vector("    - sdo_write: {index: 0x6083, sub: 0, value: 10000, size: 4}\n"
                      "      refused_means_not_applicable: value-range\n"
                      "      clause: \"CiA 402-2 §6083h\"\n"));
  // Then the not-applicable message names the value in hex, not in decimal
  EXPECT_EQ(result.verdict, Verdict::not_applicable) << result.message;
  EXPECT_NE(result.message.find("device refused 6083h = 2710h (06090031h)"), std::string::npos)
      << result.message;
}

TEST_F(EngineTest, RefusalOutsideTheSetStillFails) {
  // Given a drive that refuses 6088h = 1 with 06010002h (read only): not "value not supported"
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#2B88600001000000")  // ccs=1 n=2 e=1 s=1, 6088h sub 0, data 0001h
      .reply("581#8088600002000106");  // abort 6088h sub 0, 06010002h
  // When the vector writes it with refused_means_not_applicable: value-range
  const auto result = run(make_vector(kOptionalValue));
  // Then it fails, Expected naming the set and Actual the code
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  EXPECT_NE(result.message.find("ok, or (not applicable) abort in value-range"), std::string::npos)
      << result.message;
  EXPECT_NE(result.message.find("06010002"), std::string::npos) << result.message;
}

TEST_F(EngineTest, AcceptedOptionalValueIsJudged) {
  // Given a drive that takes 6088h = 1 but reads back 0
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#2B88600001000000")  // ccs=1 n=2 e=1 s=1, 6088h sub 0, data 0001h
      .reply("581#6088600000000000");  // download confirmed
  peer.expect("601#4088600000000000")  // ccs=2 upload, 6088h sub 0
      .reply("581#4B88600000000000");  // scs=2 n=2 e=1 s=1, 0000h
  // When the vector writes it and reads it back
  const auto result = run(make_vector(kOptionalValue));
  // Then the later step judges it: a failure, not N/A
  EXPECT_EQ(result.verdict, Verdict::fail) << result.message;
  EXPECT_NE(result.message.find("read 6088h sub 0"), std::string::npos) << result.message;
}

TEST_F(EngineTest, SdoReadValueWithMask) {
  // Given a peer answering 6041h reads with 0240h twice
  test_support::ScriptedPeer peer(*peer_port_);
  for (int i = 0; i < 2; ++i) {
    peer.expect("601#4041600000000000")  // ccs=2 upload, 6041h sub 0
        .reply("581#4B41600040020000");  // scs=2 n=2 e=1 s=1, data 0240h
  }
  // When one read expects state bits 0040h and one expects 0027h
  const auto pass = run(make_vector(
      "    - sdo_read: {index: 0x6041, sub: 0}\n      expect: {value: 0x40, mask: 0x4F}\n"));
  const auto fail = run(make_vector(
      "    - sdo_read: {index: 0x6041, sub: 0}\n      expect: {value: 0x27, mask: 0x6F}\n"));
  // Then the first passes, the second fails naming the value read; both recorded a sample
  EXPECT_EQ(pass.verdict, Verdict::pass) << pass.message;
  EXPECT_EQ(fail.verdict, Verdict::fail);
  EXPECT_NE(fail.message.find("576 (240h)"), std::string::npos) << fail.message;
  ASSERT_EQ(pass.samples.size(), 1U);
  EXPECT_EQ(pass.samples[0].signal, "statusword");
  EXPECT_EQ(pass.samples[0].value, 0x240);
}

TEST_F(EngineTest, FailureInsideARepeatNamesTheStepAndItsIteration) {
  // Given a peer answering 6041h reads with 0040h three times, then with 0027h
  test_support::ScriptedPeer peer(*peer_port_);
  for (int i = 0; i < 3; ++i)
    peer.expect("601#4041600000000000").reply("581#4B41600040000000");
  peer.expect("601#4041600000000000").reply("581#4B41600027000000");
  // When a repeat of four reads expects state bits 0040h
  const auto result =
      run(make_vector("    - wait: 1ms\n"
                      "    - repeat:\n"
                      "        times: 4\n"
                      "        steps:\n"
                      "          - sdo_read: {index: 0x6041, sub: 0}\n"
                      "            expect: {value: 0x40, mask: 0x4F}\n"));
  // Then it fails in step 3 (the read; the repeat is step 2), iteration 4 of 4, at the read's
  // line, and the failed check carries the same place
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_NE(result.message.find("t.yaml:11: step 3 (iteration 4 of 4) sdo_read: Expected"),
            std::string::npos)
      << result.message;
  ASSERT_FALSE(result.checks.empty());
  EXPECT_EQ(result.checks.back().step, 3U);
  EXPECT_EQ(result.checks.back().iterations, (std::vector<Iteration>{{4, 4}}));
  EXPECT_EQ(step_label(result.checks.back().step, result.checks.back().iterations),
            "step 3 (iteration 4 of 4)");
  EXPECT_EQ(result.checks.front().iterations, (std::vector<Iteration>{{1, 4}}));
}

TEST_F(EngineTest, ExpectFrameTimesOut) {
  // Given a peer that never answers
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#4041600000000000");  // ccs=2 upload, 6041h sub 0; no reply
  const auto start = bus_.now();
  // When the vector waits 10 ms for the answer
  const auto result =
      run(make_vector("    - send: \"600+N#4041600000000000\"\n    - expect_frame: "
                      "\"580+N#4B416000....0000\"\n      within: 10ms\n"));
  // Then it fails after 10 ms of bus time with "nothing matching"
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_NE(result.message.find("nothing matching within 10ms"), std::string::npos)
      << result.message;
  EXPECT_GE(bus_.now() - start, 10ms);
  EXPECT_LT(bus_.now() - start, 12ms);
}

TEST_F(EngineTest, ExpectFrameMatchesAndMeasuresMarks) {
  // Given a peer answering 123h after 3 ms and 124h after 7 ms
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("123#01").reply_after(3ms, "181#00");  // stimulus → TPDO-like answer
  peer.expect("124#01").reply_after(7ms, "182#00");
  // When the vector marks both answers and measures between them
  const auto result =
      run(make_vector("    - send: \"123#01\"\n    - expect_frame: \"180+N#*\"\n      mark: a\n"
                      "    - send: \"124#01\"\n    - expect_frame: \"182#00\"\n      mark: b\n"
                      "    - measure: {from: a, to: b, min: 5ms, max: 20ms}\n"));
  // Then it passes with one timing of about 7 ms
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  ASSERT_EQ(result.timings.size(), 1U);
  EXPECT_GE(result.timings[0].measured, 7ms);
  EXPECT_LT(result.timings[0].measured, 8ms);
  // And a tighter bound fails
  peer.expect("123#01").reply_after(3ms, "181#00");
  peer.expect("124#01").reply_after(7ms, "182#00");
  const auto tight =
      run(make_vector("    - send: \"123#01\"\n    - expect_frame: \"180+N#*\"\n      mark: a\n"
                      "    - send: \"124#01\"\n    - expect_frame: \"182#00\"\n      mark: b\n"
                      "    - measure: {from: a, to: b, max: 5ms}\n"));
  EXPECT_EQ(tight.verdict, Verdict::fail);
  EXPECT_FALSE(tight.timings.at(0).ok);
}

TEST_F(EngineTest, ExpectSilence) {
  // Given a peer that sends 181h 5 ms after a stimulus
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("123#01").reply_after(5ms, "181#00");
  peer.expect("123#01").reply_after(5ms, "181#00");
  // When one vector wants silence on 180+N and another on 280+N
  const auto loud = run(
      make_vector("    - send: \"123#01\"\n    - expect_silence: [\"180+N\"]\n      for: 20ms\n"));
  const auto quiet = run(
      make_vector("    - send: \"123#01\"\n    - expect_silence: [\"280+N\"]\n      for: 20ms\n"));
  // Then the first fails naming the frame, the second passes
  EXPECT_EQ(loud.verdict, Verdict::fail);
  EXPECT_NE(loud.message.find("181#00"), std::string::npos) << loud.message;
  EXPECT_EQ(quiet.verdict, Verdict::pass) << quiet.message;
}

TEST_F(EngineTest, ExpectEmcy) {
  // Given a peer that sends EMCY 2310h, register 01h
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("123#01").reply("081#1023010000000000");  // EMCY code 2310h, register 01h
  peer.expect("123#01").reply("081#1023010000000000");
  // When one vector expects that code and another expects 8611h
  const auto right =
      run(make_vector("    - send: \"123#01\"\n    - expect_emcy: {code: [0x2310, 0x2320], "
                      "register: {mask: 0x01, value: 0x01}}\n"));
  const auto wrong = run(make_vector(
      "    - send: \"123#01\"\n    - expect_emcy: {code: 0x8611}\n      within: 20ms\n"));
  // Then pass and fail
  EXPECT_EQ(right.verdict, Verdict::pass) << right.message;
  EXPECT_EQ(wrong.verdict, Verdict::fail);
  EXPECT_NE(wrong.message.find("081#1023010000000000"), std::string::npos) << wrong.message;
}

TEST_F(EngineTest, ControlwordIsAnSdoWriteOf6040) {
  // Given a peer that accepts the first controlword write and refuses the second
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#2B40600006000000")  // ccs=1 n=2 e=1 s=1, 6040h sub 0, data 0006h
      .reply("581#6040600000000000");  // scs=3 download confirmed
  peer.expect("601#2B4060000F000000")  // 6040h := 000Fh
      .reply("581#8040600022000008");  // abort 08000022h (device state)
  // When a vector writes shutdown then enable operation
  const auto result = run(make_vector("    - controlword: 0x0006\n    - controlword: 0x000F\n"));
  // Then the first check passes, the second fails naming the abort; samples are recorded
  EXPECT_EQ(result.verdict, Verdict::fail);
  ASSERT_EQ(result.checks.size(), 2U);
  EXPECT_TRUE(result.checks[0].ok);
  EXPECT_NE(result.checks[1].actual.find("08000022h"), std::string::npos)
      << result.checks[1].actual;
  ASSERT_EQ(result.samples.size(), 2U);
  EXPECT_EQ(result.samples[0].signal, "controlword");
  EXPECT_EQ(result.samples[1].value, 0x000F);
}

TEST_F(EngineTest, TeardownQuickStopsThenDisablesAfterMotion) {
  // Given a CiA 402 profile and a motion vector whose step fails
  auto parsed = profile::parse_profile(
      "name: m\ntitle: M\nfeatures: [cia402]\n",
      {.file_name = "m.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#2B40600002000000")  // 6040h := 0002h quick stop
      .reply("581#6040600000000000");  // confirmed
  peer.expect("601#4041600000000000")  // upload 6041h
      .reply("581#4B41600007020000");  // 0207h: QUICK STOP ACTIVE
  peer.expect("601#406C600000000000")  // upload 606Ch velocity actual value
      .reply("581#436C600010000000");  // 16 units/s: still moving
  peer.expect("601#4041600000000000")  // upload 6041h again, a moment later
      .reply("581#4B41600040020000");  // 0240h: SWITCH ON DISABLED (quick stop complete)
  peer.expect("601#2B40600000000000")  // 6040h := 0000h disable voltage
      .reply("581#6040600000000000");  // confirmed
  // When it runs (the expectation times out)
  Engine engine(*harness_, *parsed, {});
  const auto result = engine.run_vector(
      make_vector("    - expect_frame: \"181#*\"\n      within: 5ms\n", "  motion: true\n"));
  // Then it fails, and afterwards the drive got quick stop, was watched until the quick stop
  // was complete (not disabled while still moving), then got disable voltage
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_TRUE(peer.finished());
}

TEST_F(EngineTest, DriveStateWalksTheStandardPath) {
  // Given a CiA 402 profile and a peer playing a drive in SWITCH ON DISABLED
  auto parsed = profile::parse_profile(
      "name: m\ntitle: M\nfeatures: [cia402]\n",
      {.file_name = "m.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#4041600000000000").reply("581#4B41600040020000");  // 6041h = 0240h (SOD)
  peer.expect("601#2B40600000000000").reply("581#6040600000000000");  // 6040h := 0000h, ok
  peer.expect("601#4041600000000000").reply("581#4B41600040020000");  // 6041h = 0240h (SOD)
  peer.expect("601#2B40600006000000").reply("581#6040600000000000");  // 6040h := 0006h, ok
  peer.expect("601#4041600000000000").reply("581#4B41600021020000");  // 6041h = 0221h (RTSO)
  // When a vector asks for ready-to-switch-on (then does nothing)
  Engine engine(*harness_, *parsed, {});
  const auto result =
      engine.run_vector(make_vector("    - wait: 1ms\n", "  drive_state: ready-to-switch-on\n"));
  // Then the setup walked 7 (disable voltage) and 2 (shutdown), and the vector passes
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  EXPECT_TRUE(peer.finished());
}

TEST_F(EngineTest, DriveStateWalkNamesTheTransitionThatDidNotHappen) {
  // Given a CiA 402 profile and a peer playing a drive that stays in SWITCH ON DISABLED after
  // shutdown (transition 2 does not happen)
  auto parsed = profile::parse_profile(
      "name: m\ntitle: M\nfeatures: [cia402]\n",
      {.file_name = "m.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  test_support::ScriptedPeer peer(*peer_port_);
  peer.set_mismatch_handler([](const std::string&) {});
  peer.expect("601#4041600000000000").reply("581#4B41600040020000");  // 6041h = 0240h (SOD)
  peer.expect("601#2B40600000000000").reply("581#6040600000000000");  // 6040h := 0000h, ok
  peer.expect("601#4041600000000000").reply("581#4B41600040020000");  // 6041h = 0240h (SOD)
  peer.expect("601#2B40600006000000").reply("581#6040600000000000");  // 6040h := 0006h, ok
  for (int i = 0; i < 100; ++i)
    peer.expect("601#4041600000000000").reply("581#4B41600040020000");  // still 0240h
  // When a vector asks for ready-to-switch-on
  Engine engine(*harness_, *parsed, {});
  const auto result =
      engine.run_vector(make_vector("    - wait: 1ms\n", "  drive_state: ready-to-switch-on\n"));
  // Then it is an error (the vector never ran) that names transition 2 and what was seen
  EXPECT_EQ(result.verdict, Verdict::error);
  EXPECT_NE(result.message.find("transition 2 (0006h"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("did not happen within 200ms: statusword 0240h"), std::string::npos)
      << result.message;
}

TEST_F(EngineTest, ExpectStatePollsUntilReached) {
  // Given a drive that shows NOT READY first, then SWITCH ON DISABLED
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#4041600000000000").reply("581#4B41600000000000");  // 6041h = 0000h
  peer.expect("601#4041600000000000").reply("581#4B41600040020000");  // 6041h = 0240h
  // When the vector expects switch-on-disabled
  const auto result = run(make_vector("    - expect_state: switch-on-disabled\n"));
  // Then it passes after two reads, each a statusword sample
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  EXPECT_EQ(result.samples.size(), 2U);
  EXPECT_TRUE(peer.finished());
}

TEST_F(EngineTest, ExpectStatuswordFailsAtDeadline) {
  // Given a drive stuck in NOT READY (a peer answering every read with 0000h)
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#4041600000000000").reply("581#4B41600000000000");  // 6041h = 0000h
  peer.set_repeat(true);
  // When the vector expects bit 6 within 20 ms
  const auto result = run(
      make_vector("    - expect_statusword: {mask: 0x0040, value: 0x0040}\n      within: 20ms\n"));
  // Then it fails with the last statusword
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_NE(result.message.find("statusword 0000h"), std::string::npos) << result.message;
}

TEST_F(EngineTest, PollingADeviceThatAbortsEndsWithItsAbortNotATimeout) {
  // Given a device without 6041h: every read is aborted at once with 06020000h
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("601#4041600000000000")  // ccs=2 upload 6041h sub 0
      .reply("581#8041600000000206");  // abort 06020000h (object does not exist)
  peer.set_repeat(true);
  // When a vector limited to 50 ms polls the statusword for up to 1 s
  const auto result =
      run(make_vector("    - expect_statusword: {mask: 0x0040, value: 0x0040}\n      within: 1s\n",
                      "  timeout: 50ms\n"));
  // Then it fails with the device's answer, the abort; no request went unanswered
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_NE(result.message.find("06020000"), std::string::npos) << result.message;
  EXPECT_EQ(result.message.find("did not answer in time"), std::string::npos) << result.message;
}

TEST_F(EngineTest, VectorTimeoutEndsAWait) {
  // Given a vector limited to 50 ms that waits 1 s
  const auto start = bus_.now();
  const auto result = run(make_vector("    - wait: 1s\n", "  timeout: 50ms\n"));
  // Then it fails at 50 ms with "vector timeout"
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_NE(result.message.find("vector timeout"), std::string::npos) << result.message;
  EXPECT_EQ(bus_.now() - start, 50ms);
}

class FakeSimulation final : public SimulationControl {
 public:
  std::string set_input(std::string_view input, std::int64_t value) override {
    if (input != "hardware-enable") return "unknown input (known: hardware-enable)";
    last = value;
    return {};
  }
  std::string reset_inputs() override {
    ++resets;
    last = -1;
    return {};
  }
  std::int64_t last = -1;
  int resets = 0;
};

TEST_F(EngineTest, SimulateGoesThroughTheControl) {
  // Given a simulation control knowing hardware-enable
  FakeSimulation simulation;
  EngineOptions options;
  options.simulation = &simulation;
  // When a vector sets it, and another sets an unknown input
  const auto ok = run(make_vector("    - simulate: {input: hardware-enable, value: 1}\n"), options);
  const auto unknown = run(make_vector("    - simulate: {input: limit-up, value: 1}\n"), options);
  // Then the first passes (value delivered), the second is a harness error naming the input,
  // and the inputs were reset before each vector (the second one found last = -1 again)
  EXPECT_EQ(ok.verdict, Verdict::pass) << ok.message;
  EXPECT_EQ(simulation.resets, 2);
  EXPECT_EQ(simulation.last, -1);
  EXPECT_EQ(unknown.verdict, Verdict::error);
  EXPECT_NE(unknown.message.find("limit-up"), std::string::npos) << unknown.message;
}

TEST_F(EngineTest, UnknownMarkAtRunTimeIsAHarnessError) {
  // Given a vector built in code whose measure names marks nobody set (the loader would refuse)
  Vector vector;
  vector.id = "t/marks";
  vector.setup = Setup::none;
  vector.nmt.reset();
  MeasureStep measure;
  measure.from = "a";
  measure.to = "b";
  measure.max = DurationSpec{1ms, {}};
  vector.steps.push_back(Step{measure, {}, 1, {}});
  // When run; Then a harness error, not a DUT failure
  const auto result = run(vector);
  EXPECT_EQ(result.verdict, Verdict::error);
  EXPECT_NE(result.message.find("unknown mark 'a'"), std::string::npos) << result.message;
}

class EngineDriveTest : public EngineTest {
 protected:
  EngineDriveTest() {
    reference_drive::DriveConfig config;
    config.dictionary.node_id = 1;
    auto drive = reference_drive::ReferenceDrive::create(*peer_port_, std::move(config));
    EXPECT_TRUE(drive) << drive.error();
    drive_ = std::move(*drive);
    drive_->power_on();
    bus_.run_for(10ms);
  }
  std::unique_ptr<reference_drive::ReferenceDrive> drive_;
};

// The embedded drive's bus-off control, reduced to the reference drive on the peer port.
class DriveBusOff final : public SimulationControl {
 public:
  DriveBusOff(can::SimPort& port, reference_drive::ReferenceDrive& drive)
      : port_(port), drive_(drive) {}
  std::string set_input(std::string_view, std::int64_t) override { return "no inputs"; }
  std::string reset_inputs() override { return {}; }
  bool can_bus_off() const override { return true; }
  std::string set_bus_off(bool bus_off) override {
    port_.set_bus_off(bus_off);
    drive_.set_bus_off(bus_off);
    ++calls;
    return {};
  }
  int calls = 0;

 private:
  can::SimPort& port_;
  reference_drive::ReferenceDrive& drive_;
};

TEST_F(EngineDriveTest, BusOffStepThenRecoveryEmcy) {
  // Given the reference drive and a control that can put its controller bus-off
  DriveBusOff control(*peer_port_, *drive_);
  EngineOptions options;
  options.simulation = &control;
  const auto set = parse_vectors(
      "- id: t/bus-off\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n    - bus_off: 50ms\n"
      "    - expect_emcy: {code: 0x8140, register: {mask: 0x10, value: 0x10}}\n",
      "t.yaml");
  ASSERT_TRUE(set.ok());
  // When the vector runs
  const auto start = bus_.now();
  const auto result = run(set.vectors.front(), options);
  // Then the step went bus-off and back (two calls, at least 50 ms), and the drive's EMCY
  // 8140h after the recovery passes the expectation
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  EXPECT_EQ(control.calls, 2);
  EXPECT_GE(bus_.now() - start, 50ms);
  EXPECT_FALSE(peer_port_->bus_off());
}

TEST_F(EngineDriveTest, BusOffStepOnARealBusIsNotApplicable) {
  // Given the same vector, run as on a real bus (no simulation control)
  const auto set = parse_vectors(
      "- id: t/bus-off\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n    - bus_off: 50ms\n",
      "t.yaml");
  ASSERT_TRUE(set.ok());
  EngineOptions options;
  options.real_bus = true;
  // When it runs; Then it is not applicable, and the reason names the bus_off step
  const auto result = run(set.vectors.front(), options);
  EXPECT_EQ(result.verdict, Verdict::not_applicable);
  EXPECT_NE(result.message.find("bus_off step"), std::string::npos) << result.message;
}

TEST_F(EngineDriveTest, FactoryRestoreOnARealBusNeedsTheOptIn) {
  // Given a profile with restore and a vector with setup restore-defaults (1011h "load")
  auto parsed = profile::parse_profile(
      "name: r\ntitle: R\nfeatures: [sdo.segmented, store, restore]\n",
      {.file_name = "r.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  profile_ = *parsed;
  const auto set = parse_vectors(
      "- id: t/defaults\n  title: t\n  source: \"CiA 301 §1\"\n  setup: restore-defaults\n"
      "  steps:\n    - sdo_read: {index: 0x1018, sub: 0}\n",
      "t.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  EngineOptions real_bus;
  real_bus.real_bus = true;
  EngineOptions allowed = real_bus;
  allowed.allow_factory_restore = true;
  // When it runs on a real bus without and with --allow-factory-restore, and on the simulated
  // bus
  const auto refused = run(set.vectors.front(), real_bus);
  const auto opted_in = run(set.vectors.front(), allowed);
  const auto simulated = run(set.vectors.front(), EngineOptions{});
  // Then without the opt-in it is not applicable, with the reason, and sends no 1011h download;
  // with it, and on the simulated bus, it runs
  EXPECT_EQ(refused.verdict, Verdict::not_applicable);
  EXPECT_EQ(refused.message,
            "would restore factory defaults and wipe the device's stored parameters; pass "
            "--allow-factory-restore");
  EXPECT_TRUE(refused.frames.empty());
  EXPECT_EQ(opted_in.verdict, Verdict::pass) << opted_in.message;
  EXPECT_EQ(simulated.verdict, Verdict::pass) << simulated.message;
  const auto loads = [](const VectorResult& result) {
    return std::count_if(result.frames.begin(), result.frames.end(), [](const auto& frame) {
      return frame.frame.id == 0x601 && frame.frame.data[1] == 0x11 && frame.frame.data[2] == 0x10;
    });
  };
  EXPECT_EQ(loads(opted_in), 1);
}

TEST_F(EngineDriveTest, DetectedFeaturesAndObjectNeedsAreProbedOnceAndDecideApplicability) {
  // Given a reference drive built without its TIME consumer (no 1012h), a generic profile that
  // detects time and heartbeat.producer, and vectors needing time, heartbeat.producer, object
  // 1029h and object 2FFFh
  drive_.reset();
  reference_drive::DriveConfig config;
  config.dictionary.node_id = 1;
  config.dictionary.time_consumer = false;
  auto drive = reference_drive::ReferenceDrive::create(*peer_port_, std::move(config));
  ASSERT_TRUE(drive) << drive.error();
  drive_ = std::move(*drive);
  drive_->power_on();
  bus_.run_for(10ms);
  auto parsed = profile::parse_profile(
      "name: g\ntitle: G\nfeatures: [sdo.expedited]\ndetect: [time, heartbeat.producer]\n",
      {.file_name = "g.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  profile_ = *parsed;
  const auto set = parse_vectors(
      "- id: t/time\n  title: t\n  source: \"CiA 301 §1\"\n  requires: [time]\n  steps:\n"
      "    - wait: 1ms\n"
      "- id: t/heartbeat\n  title: t\n  source: \"CiA 301 §1\"\n"
      "  requires: [heartbeat.producer]\n  steps:\n    - sdo_read: {index: 0x1017, sub: 0}\n"
      "- id: t/error-behavior\n  title: t\n  source: \"CiA 301 §1\"\n"
      "  requires: [object.1029]\n  steps:\n    - sdo_read: {index: 0x1029, sub: 1}\n"
      "- id: t/manufacturer\n  title: t\n  source: \"CiA 301 §1\"\n"
      "  requires: [object.2FFF]\n  steps:\n    - sdo_read: {index: 0x2FFF, sub: 0}\n",
      "t.yaml");
  ASSERT_TRUE(set.ok()) << set.errors.front().to_string();
  // When the run probes the drive and runs them
  Engine engine(*harness_, profile_, {});
  const RunResult result = engine.run(set.vectors);
  // Then what the drive lacks is not applicable with the probe's answer, the rest passes, and
  // the report info lists what was probed
  ASSERT_EQ(result.vectors.size(), 4U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::not_applicable);
  EXPECT_EQ(result.vectors[0].message,
            "requires time (probed: absent, 1012h: upload answered 06020000h)");
  EXPECT_EQ(result.vectors[1].verdict, Verdict::pass) << result.vectors[1].message;
  EXPECT_EQ(result.vectors[2].verdict, Verdict::pass) << result.vectors[2].message;
  EXPECT_EQ(result.vectors[3].verdict, Verdict::not_applicable);
  EXPECT_EQ(result.vectors[3].message, "needs object 2FFFh: absent (upload answered 06020000h)");
  EXPECT_FALSE(result.info.capabilities.empty());
  EXPECT_TRUE(result.harness_notes.empty());
}

TEST_F(EngineDriveTest, DeviceTypeChoosesTheGenericProfile) {
  // Given the reference drive (1000h: a CiA 402 drive)
  Engine engine(*harness_, profile_, {});
  // When 1000h is read and a generic profile chosen from it
  const auto device_type = engine.read_device_type();
  // Then the drive's profile number is 402 and cia402-device is chosen
  ASSERT_TRUE(device_type);
  EXPECT_EQ(*device_type & 0xFFFF, 402U);
  EXPECT_EQ(choose_generic_profile(device_type).name, "cia402-device");
}

TEST_F(EngineDriveTest, ResetNodeSetupAndBootup) {
  // Given the reference drive; When a vector with the default setup resets it and resets it
  // again by an nmt step
  const auto set = parse_vectors(
      "- id: t/boot\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n    - nmt: reset-node\n    - "
      "expect_bootup: {}\n      mark: up\n",
      "t.yaml");
  ASSERT_TRUE(set.ok());
  const auto result = run(set.vectors.front());
  // Then both boot-ups are seen
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
}

TEST_F(EngineDriveTest, CommissioningWritesAfterTheResetOfTheVectorsItAppliesTo) {
  // Given a profile commissioning 1017h := 50 (heartbeat) for t/* except t/skip/*
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [sdo.segmented, heartbeat.producer]\n"
      "commissioning:\n  vectors: [\"t/*\"]\n  except: [\"t/skip/*\"]\n  writes:\n"
      "    - {index: 0x1017, value: 50, size: 2, source: \"CiA 301 §7.5.2.28\", why: hb}\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  profile_ = *parsed;
  const auto set = parse_vectors(
      "- id: t/commissioned\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1017, sub: 0}\n      expect: {value: 50}\n"
      "- id: t/skip/delivered\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1017, sub: 0}\n      expect: {value: 0}\n",
      "t.yaml");
  ASSERT_TRUE(set.ok());
  // When both run (each resets the node first)
  Engine engine(*harness_, profile_, {});
  const RunResult result = engine.run(set.vectors);
  // Then the first sees the written value after its reset, the excepted one the default
  ASSERT_EQ(result.vectors.size(), 2U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << result.vectors[0].message;
  EXPECT_EQ(result.vectors[1].verdict, Verdict::pass) << result.vectors[1].message;
  // And the report info lists the globs and the write
  ASSERT_EQ(result.info.commissioning.size(), 2U);
  EXPECT_EQ(result.info.commissioning[0], "applies to t/* except t/skip/*");
  EXPECT_NE(result.info.commissioning[1].find("1017h sub 0 := 50 (2 bytes): hb"),
            std::string::npos);
}

TEST_F(EngineDriveTest, RefusedCommissioningWriteFailsTheVector) {
  // Given a profile commissioning 1000h (read-only device type)
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [sdo.segmented]\ncommissioning:\n  vectors: [\"t/*\"]\n"
      "  writes:\n    - {index: 0x1000, value: 1, size: 4, source: \"CiA 301 §1\", why: w}\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  profile_ = *parsed;
  const auto set = parse_vectors(
      "- id: t/x\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n    - wait: 1ms\n", "t.yaml");
  ASSERT_TRUE(set.ok());
  // When the vector runs / Then it fails in setup with the abort as Actual
  const auto result = run(set.vectors.front());
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_NE(result.message.find("setup commissioning"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("06010002"), std::string::npos) << result.message;
}

TEST_F(EngineDriveTest, HeartbeatAndPeriodic) {
  // Given the drive producing a heartbeat every 50 ms (1017h written by the vector)
  const auto result =
      run(make_vector("    - sdo_write: {index: 0x1017, sub: 0, value: 50, size: 2}\n"
                      "    - expect_heartbeat: pre-operational\n"
                      "    - expect_periodic: \"700+N\"\n      period: 50ms\n      tolerance: "
                      "2ms\n      count: 3\n"));
  // Then the heartbeat is seen within 75 ms and its period is within tolerance
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  EXPECT_EQ(result.timings.size(), 2U);
  // And a wrong period fails with the measured interval
  const auto wrong =
      run(make_vector("    - sdo_write: {index: 0x1017, sub: 0, value: 50, size: 2}\n"
                      "    - expect_periodic: \"700+N\"\n      period: 40ms\n      tolerance: "
                      "2ms\n      count: 3\n"));
  EXPECT_EQ(wrong.verdict, Verdict::fail);
}

TEST_F(EngineDriveTest, PollAndSave) {
  // Given the drive's device type 1000h; When read, saved and polled for the same value
  const auto result =
      run(make_vector("    - sdo_read: {index: 0x1000, sub: 0}\n      save: type\n"
                      "    - sdo_read: {index: 0x1000, sub: 0}\n      expect: {value: $type}\n"
                      "    - poll: {index: 0x1018, sub: 0, value: 4}\n      within: 20ms\n"));
  // Then it passes
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
}

TEST_F(EngineDriveTest, PollIntoARangeSignedOrNot) {
  // Given 1017h (UNSIGNED16) holding FFF6h
  const std::string write = "    - sdo_write: {index: 0x1017, sub: 0, value: 0xFFF6, size: 2}\n";
  // When polled into [-10, -1] read as signed, and into [65520, 65530] read as unsigned
  const auto pass =
      run(make_vector(
          write + "    - poll: {index: 0x1017, sub: 0, range: [-10, -1]}\n      signed: true\n"
                  "      within: 20ms\n    - poll: {index: 0x1017, sub: 0, range: [65520, 65530]}\n"
                  "      within: 20ms\n"));
  // Then both pass
  EXPECT_EQ(pass.verdict, Verdict::pass) << pass.message;
  // And [-10, -1] unsigned never holds FFF6h: it fails at the deadline with the value last read
  const auto fail = run(make_vector(
      write + "    - poll: {index: 0x1017, sub: 0, range: [-10, -1]}\n      within: 20ms\n"));
  EXPECT_EQ(fail.verdict, Verdict::fail);
  EXPECT_NE(fail.message.find("1017h sub 0 in [-10, -1] within 20ms"), std::string::npos)
      << fail.message;
  EXPECT_NE(fail.message.find("last read: 65526 (FFF6h)"), std::string::npos) << fail.message;
}

TEST_F(EngineDriveTest, PollRangeBoundsFromASavedValue) {
  // Given 1018h sub 0 saved as n; When polled into [$n, $n+1], then into [$n+1, $n+2]
  const std::string save = "    - sdo_read: {index: 0x1018, sub: 0}\n      save: n\n";
  const auto pass = run(make_vector(
      save +
      "    - poll: {index: 0x1018, sub: 0, range: [\"$n\", \"$n+1\"]}\n      within: 20ms\n"));
  const auto fail = run(make_vector(save + "    - poll: {index: 0x1018, sub: 0, range: [\"$n+1\", "
                                           "\"$n+2\"]}\n      within: 20ms\n"));
  // Then the first passes, the second fails showing the computed bounds
  EXPECT_EQ(pass.verdict, Verdict::pass) << pass.message;
  EXPECT_EQ(fail.verdict, Verdict::fail);
  EXPECT_NE(fail.message.find("in [$n+1 = "), std::string::npos) << fail.message;
}

TEST_F(EngineDriveTest, RangeAroundASavedValue) {
  // Given the drive's device type 1000h saved, then read again against bounds computed from it
  const auto pass =
      run(make_vector("    - sdo_read: {index: 0x1000, sub: 0}\n      save: type\n"
                      "    - sdo_read: {index: 0x1000, sub: 0}\n"
                      "      expect: {range: [\"$type-1\", \"$type+1\"]}\n"));
  // Then bounds around the saved value pass
  EXPECT_EQ(pass.verdict, Verdict::pass) << pass.message;
  // And bounds that leave it out fail, showing the computed bounds
  const auto fail =
      run(make_vector("    - sdo_read: {index: 0x1000, sub: 0}\n      save: type\n"
                      "    - sdo_read: {index: 0x1000, sub: 0}\n"
                      "      expect: {range: [\"$type+1\", \"$type+2\"]}\n"));
  EXPECT_EQ(fail.verdict, Verdict::fail);
  EXPECT_NE(fail.message.find("value in [$type+1 = "), std::string::npos) << fail.message;
}

TEST_F(EngineDriveTest, RangeOfAScaledSavedValue) {
  // Given the drive's device type 1000h saved, then read again against scaled bounds
  const auto pass =
      run(make_vector("    - sdo_read: {index: 0x1000, sub: 0}\n      save: type\n"
                      "    - sdo_read: {index: 0x1000, sub: 0}\n"
                      "      expect: {range: [\"$type*3/4\", \"$type*5/4\"]}\n"));
  // Then bounds that hold the value pass
  EXPECT_EQ(pass.verdict, Verdict::pass) << pass.message;
  // And bounds of twice to three times the value fail, showing how they were computed
  const auto fail =
      run(make_vector("    - sdo_read: {index: 0x1000, sub: 0}\n      save: type\n"
                      "    - sdo_read: {index: 0x1000, sub: 0}\n"
                      "      expect: {range: [\"$type*2\", \"$type*3-1\"]}\n"));
  EXPECT_EQ(fail.verdict, Verdict::fail);
  EXPECT_NE(fail.message.find("value in [$type*2 = "), std::string::npos) << fail.message;
  EXPECT_NE(fail.message.find(", $type*3-1 = "), std::string::npos) << fail.message;
}

TEST_F(EngineDriveTest, ReadRelativeToASavedValue) {
  // Given 1017h written 100, read and saved, then written 250
  const std::string head =
      "    - sdo_write: {index: 0x1017, sub: 0, value: 100, size: 2}\n"
      "    - sdo_read: {index: 0x1017, sub: 0}\n      signed: true\n      save: before\n"
      "    - sdo_write: {index: 0x1017, sub: 0, value: 250, size: 2}\n";
  // When read again relative to the saved value, the difference saved and used as a bound
  const auto pass =
      run(make_vector(head + "    - sdo_read: {index: 0x1017, sub: 0}\n"
                             "      signed: true\n      relative_to: before\n"
                             "      expect: {value: 150}\n      save: change\n"
                             "    - sdo_read: {index: 0x1017, sub: 0}\n"
                             "      signed: true\n"
                             "      expect: {range: [\"$change+100\", \"$change+100\"]}\n"));
  // Then the difference (150) is what is judged and what is saved
  EXPECT_EQ(pass.verdict, Verdict::pass) << pass.message;
  // And the value read itself does not pass as the difference; the failure shows both
  const auto fail = run(make_vector(head + "    - sdo_read: {index: 0x1017, sub: 0}\n"
                                           "      signed: true\n      relative_to: before\n"
                                           "      expect: {range: [200, 300]}\n"));
  EXPECT_EQ(fail.verdict, Verdict::fail);
  EXPECT_NE(fail.message.find("read 1017h sub 0 - $before: value in [200, 300]"), std::string::npos)
      << fail.message;
  EXPECT_NE(fail.message.find("= 250 (FAh), minus $before (100) = 150"), std::string::npos)
      << fail.message;
}

TEST_F(EngineDriveTest, DutLostAfterSilentVectors) {
  // Given one vector where the drive answers, then four where it says nothing
  std::vector<Vector> vectors;
  vectors.push_back(make_vector("    - sdo_read: {index: 0x1000, sub: 0}\n"));
  for (int i = 0; i < 4; ++i) {
    auto v = make_vector("    - wait: 10ms\n");
    v.id = "t/silent-" + std::to_string(i);
    vectors.push_back(v);
  }
  EngineOptions options;
  options.max_silent_vectors = 3;
  Engine engine(*harness_, profile_, options);
  // When the run goes on
  const auto result = engine.run(vectors);
  // Then it stops after the third silent vector with dut_lost (exit 3)
  EXPECT_TRUE(result.dut_lost);
  EXPECT_EQ(result.vectors.size(), 4U);
  EXPECT_EQ(exit_code(result), 3);
  EXPECT_EQ(result.info.dut.device_type.has_value(), true);
}

TEST_F(EngineDriveTest, RealBusRunRestoresHeartbeatConsumerAndStopsItsHeartbeat) {
  // Given a real-bus run with motion allowed and one motion vector: the engine makes the DUT
  // consume the harness heartbeat (node 127) through 1016h sub 1, which holds 0 before
  auto motion = make_vector("    - wait: 20ms\n");
  motion.motion = true;
  EngineOptions options;
  options.real_bus = true;
  options.allow_motion = true;
  std::vector<can::TimedFrame> seen;
  bus_.add_monitor([&](const can::TimedFrame& frame) { seen.push_back(frame); });
  Engine engine(*harness_, profile_, options);
  // When the run ends
  const auto result = engine.run({motion});
  // Then 1016h sub 1 was taken over during the run, is back to 0 afterwards, and says so
  ASSERT_EQ(result.vectors.size(), 1U);
  bool taken_over = false;
  for (const auto& check : result.vectors.front().checks)
    taken_over |= check.expected.find("1016h sub 1 := 007F012Ch") != std::string::npos;
  EXPECT_TRUE(taken_over);
  ASSERT_EQ(result.harness_notes.size(), 1U);
  EXPECT_EQ(result.harness_notes.front(), "1016h sub 1 restored to 00000000h after the run");
  const auto after =
      run(make_vector("    - sdo_read: {index: 0x1016, sub: 1}\n"
                      "      expect: {value: 0}\n"));
  EXPECT_EQ(after.verdict, Verdict::pass) << failure(after);
  // And the harness heartbeat (77Fh) stops with the run
  seen.clear();
  bus_.run_for(500ms);
  for (const auto& frame : seen)
    EXPECT_NE(frame.frame.id, 0x77FU) << "harness heartbeat";
}

TEST_F(EngineDriveTest, MotionVectorsConsumeTheHarnessHeartbeatAfterEveryReset) {
  // Given a real-bus run with motion allowed: a motion vector whose setup resets the node, a
  // vector without motion that resets it, and a motion vector without a reset of its own (a
  // reset puts 1016h back to its stored value, 0)
  const std::string read_consumer =
      "    - sdo_read: {index: 0x1016, sub: 1}\n      expect: {value: 0x007F012C}\n";
  auto first = make_vector(read_consumer);
  first.id = "t/first";
  first.motion = true;
  first.setup = Setup::reset_node;
  auto between = make_vector("    - wait: 10ms\n");
  between.id = "t/between";
  between.setup = Setup::reset_node;
  auto last = make_vector(read_consumer);
  last.id = "t/last";
  last.motion = true;
  EngineOptions options;
  options.real_bus = true;
  options.allow_motion = true;
  Engine engine(*harness_, profile_, options);
  // When the run goes through them
  const auto result = engine.run({first, between, last});
  // Then both motion vectors find the DUT consuming the harness heartbeat (node 127, 300 ms)
  ASSERT_EQ(result.vectors.size(), 3U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << failure(result.vectors[0]);
  EXPECT_EQ(result.vectors[2].verdict, Verdict::pass) << failure(result.vectors[2]);
  bool again = false;
  for (const auto& check : result.vectors[2].checks)
    again |= check.expected.find("consume the harness heartbeat again") != std::string::npos;
  EXPECT_TRUE(again);
}

TEST_F(EngineDriveTest, FailureWhileTheHarnessStalledIsNoVerdictAndRunsAgain) {
  // Given a vector that fails against the drive (1000h is not 0), and a harness whose machine
  // stalled for the whole run (the stall log of a real bus)
  const auto wrong = make_vector(
      "    - sdo_read: {index: 0x1000, sub: 0}\n"
      "      expect: {value: 0}\n");
  StallLog stalls(1ms, 2ms);
  stalls.tick(can::TimePoint(-1s));
  stalls.tick(can::TimePoint(10h));
  EngineOptions options;
  options.stalls = &stalls;
  Engine engine(*harness_, profile_, options);
  // When the run goes
  const auto result = engine.run({wrong});
  // Then the failure is not charged to the drive: error: harness late, after three attempts,
  // each earlier attempt listed in the evidence and the run's notes
  ASSERT_EQ(result.vectors.size(), 1U);
  const auto& vector = result.vectors.front();
  EXPECT_EQ(vector.verdict, Verdict::error);
  EXPECT_EQ(vector.message.rfind("error: harness late", 0), 0U) << vector.message;
  EXPECT_NE(vector.message.find("no thread of the harness ran"), std::string::npos);
  ASSERT_GE(vector.checks.size(), 2U);
  EXPECT_EQ(vector.checks[0].expected.rfind("attempt 1 of 3", 0), 0U) << vector.checks[0].expected;
  EXPECT_EQ(vector.checks[1].expected.rfind("attempt 2 of 3", 0), 0U) << vector.checks[1].expected;
  ASSERT_FALSE(result.harness_notes.empty());
  EXPECT_NE(result.harness_notes.front().find("t/x: run 3 times"), std::string::npos)
      << result.harness_notes.front();
}

TEST_F(EngineDriveTest, StallBeforeTheVectorChangesNothing) {
  // Given the same failing vector, and a stall that ended before the run
  const auto wrong = make_vector(
      "    - sdo_read: {index: 0x1000, sub: 0}\n"
      "      expect: {value: 0}\n");
  StallLog stalls(1ms, 2ms);
  stalls.tick(can::TimePoint(-2s));
  stalls.tick(can::TimePoint(-1s));
  EngineOptions options;
  options.stalls = &stalls;
  Engine engine(*harness_, profile_, options);
  // When the run goes; Then the failure is the drive's, judged once
  const auto result = engine.run({wrong});
  ASSERT_EQ(result.vectors.size(), 1U);
  EXPECT_EQ(result.vectors.front().verdict, Verdict::fail) << result.vectors.front().message;
  for (const auto& check : result.vectors.front().checks)
    EXPECT_EQ(check.expected.find("attempt"), std::string::npos);
}

TEST_F(EngineTest, NoDutAtAllIsLostAtOnce) {
  // Given nothing on the bus but the harness
  Engine engine(*harness_, profile_, {});
  // When a run starts; Then the identity reads go unanswered and the run is lost
  const auto result = engine.run({make_vector("    - wait: 1ms\n")});
  EXPECT_TRUE(result.dut_lost);
  EXPECT_TRUE(result.vectors.empty());
}

TEST_F(EngineDriveTest, FilterAndNotApplicable) {
  // Given two vectors, one needing sdo.block (not in the profile)
  auto a = make_vector("    - sdo_read: {index: 0x1000, sub: 0}\n");
  a.id = "x/a";
  auto b = make_vector("    - sdo_read: {index: 0x1000, sub: 0}\n      transfer: block\n",
                       "  requires: [sdo.block]\n");
  b.id = "y/b";
  EngineOptions options;
  options.filter = "y/*";
  Engine engine(*harness_, profile_, options);
  // When run with filter y/*; Then only b runs, and is not applicable naming sdo.block
  const auto result = engine.run({a, b});
  ASSERT_EQ(result.vectors.size(), 1U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::not_applicable);
  EXPECT_NE(result.vectors[0].message.find("sdo.block"), std::string::npos);
}

TEST_F(EngineDriveTest, ProbeFindsObjectsTheDescriptionLacks) {
  // Given a description that lists every object of the drive but 1018h
  Engine engine(*harness_, profile_, {});
  const auto documented = [this](std::uint16_t index) {
    return index != 0x1018 && drive_->dictionary().find(index) != nullptr;
  };
  // When the probe runs
  const auto result = engine.probe_undocumented_objects(documented, "test EDS");
  // Then 1018h is the one undescribed object, and its frames are the evidence
  EXPECT_EQ(result.verdict, Verdict::fail);
  ASSERT_EQ(result.checks.size(), 1U);
  EXPECT_EQ(result.checks[0].actual.rfind("1 undescribed: 1018h", 0), 0U)
      << result.checks[0].actual;
  EXPECT_EQ(result.frames.size(), 2U);
}

TEST_F(EngineTest, OdChecksCatchAWrongAccessType) {
  // Given a profile whose manual lists 6041h as ro, and a DUT that accepts a write to it
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [cia402]\nobjects:\n  - {index: 0x6041, sub: 0, type: "
      "UNSIGNED16, access: ro, source: \"CiA 402-2 §1\"}\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  const auto vectors = generate_od_vectors(nullptr, "", *parsed);
  // When the generated checks are listed; Then a read (2 bytes) and a write-ro check exist
  ASSERT_EQ(vectors.size(), 2U);
  EXPECT_EQ(vectors[0].id, "eds/od/6041-00/read");
  EXPECT_EQ(vectors[1].id, "eds/od/6041-00/write-ro");
  // Then each check resets the node and runs in Pre-operational: none relies on the vector
  // before it (FORMAT.md "Isolation")
  for (const auto& vector : vectors) {
    EXPECT_EQ(vector.setup, Setup::reset_node) << vector.id;
    EXPECT_EQ(vector.nmt, cia301::NmtState::pre_operational) << vector.id;
  }
  test_support::ScriptedPeer peer(*peer_port_);
  peer.expect("000#8101")              // NMT reset node, node 1
      .reply("701#00")                 // boot-up
      .expect("000#8001")              // NMT enter pre-operational, commanded after the boot-up
      .expect("601#4017100000000000")  // upload 1017h: the heartbeat, or SDO served
      .reply("581#8017100000000206")   // abort 06020000h: no 1017h (SDO served: not stopped)
      .expect("601#2B41600000000000")  // ccs=1 n=2 e=1 s=1, 6041h sub 0, data 0000h
      .reply("581#6041600000000000");  // scs=3: download confirmed (wrong: 6041h is ro)
  // When the write-ro check runs against that DUT (no isolation: the script has every frame)
  Engine engine(*harness_, *parsed, scripted());
  const auto result = engine.run_vector(vectors[1]);
  // Then it fails with Expected abort 06010002h / Actual ok
  EXPECT_EQ(result.verdict, Verdict::fail);
  EXPECT_NE(result.message.find("abort in write-read-only {06010000h, 06010002h, 08000000h}"),
            std::string::npos)
      << result.message;
  EXPECT_TRUE(result.checks.back().observed.accepted);
  EXPECT_NE(result.message.find("Actual:   ok"), std::string::npos) << result.message;
}

TEST_F(EngineTest, OdChecksAcceptMappingProcedureAbortsForMappingCount) {
  // Given a profile listing 1A00h sub 0 (rw, max 8) and 6065h (rw, max 100)
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [pdo]\nobjects:\n  - {index: 0x1A00, sub: 0, type: "
      "UNSIGNED8, access: rw, max: 8, source: \"CiA 301 §1\"}\n  - {index: 0x6065, sub: 0, "
      "type: UNSIGNED32, access: rw, max: 100, source: \"CiA 402-2 §1\"}\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  ASSERT_TRUE(parsed) << parsed.error().to_string();
  // When the checks are generated
  const auto vectors = generate_od_vectors(nullptr, "", *parsed);
  // Then the mapping count's above-max also accepts 06040042h and 06010000h, 6065h's does not
  const auto aborts_of = [&](const std::string& id) {
    for (const auto& v : vectors) {
      if (v.id == id) return std::get<SdoWriteStep>(v.steps.at(0).action).expect.abort.codes;
    }
    ADD_FAILURE() << id << " not generated";
    return std::vector<std::uint32_t>{};
  };
  const auto mapping = aborts_of("eds/od/1a00-00/above-max");
  const auto window = aborts_of("eds/od/6065-00/above-max");
  EXPECT_NE(std::find(mapping.begin(), mapping.end(), 0x06040042U), mapping.end());
  EXPECT_NE(std::find(mapping.begin(), mapping.end(), 0x06010000U), mapping.end());
  EXPECT_NE(std::find(mapping.begin(), mapping.end(), 0x06090031U), mapping.end());
  EXPECT_EQ(std::find(window.begin(), window.end(), 0x06040042U), window.end());
}

}  // namespace
}  // namespace drivecheck::conformance
