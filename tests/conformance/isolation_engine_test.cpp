// Commanded states and isolation in the engine (FORMAT.md "Setup", "Isolation"): against the
// reference drive and a small fake device on the simulated bus.
#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <set>
#include <string>

#include "conformance/engine.hpp"
#include "conformance/isolation.hpp"
#include "conformance/vector_file.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/data_type.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "reference_drive/device.hpp"

namespace drivecheck::conformance {
namespace {

using namespace std::chrono_literals;

profile::DriveProfile make_profile() {
  auto parsed = profile::parse_profile(
      "name: t\ntitle: T\nfeatures: [sdo.segmented, heartbeat.producer, store, restore]\n",
      {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
  EXPECT_TRUE(parsed) << parsed.error().to_string();
  return *parsed;
}

std::vector<Vector> parse(const std::string& text) {
  const auto set = parse_vectors(text, "t.yaml");
  EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
  return set.vectors;
}

bool has_note(const RunResult& result, const std::string& part) {
  for (const auto& note : result.harness_notes) {
    if (note.find(part) != std::string::npos) return true;
  }
  return false;
}

std::string notes(const RunResult& result) {
  std::string text;
  for (const auto& note : result.harness_notes)
    text += note + "\n";
  return text;
}

// A device of 4-byte objects: answers expedited uploads and downloads on 600h+N, boot-up on
// reset. Objects in `write_once` accept one write, then refuse every further one (06010002h):
// a change that cannot be undone.
class FakeDevice {
 public:
  FakeDevice(can::Bus& port, std::uint8_t node) : port_(port), node_(node) {
    port_.set_frame_handler([this](const can::TimedFrame& frame) { on_frame(frame); });
  }
  ~FakeDevice() { port_.set_frame_handler({}); }
  FakeDevice(const FakeDevice&) = delete;
  FakeDevice& operator=(const FakeDevice&) = delete;

  std::map<ObjectRef, std::uint32_t> values;
  std::set<ObjectRef> write_once;
  std::set<ObjectRef> locked;

 private:
  void reply(std::array<std::uint8_t, 8> bytes) {
    (void)port_.send(can::Frame::standard(0x580U + node_, bytes));
  }
  void abort(cia301::Multiplexer mux, std::uint32_t code) {
    reply({0x80, static_cast<std::uint8_t>(mux.index), static_cast<std::uint8_t>(mux.index >> 8),
           mux.sub_index, static_cast<std::uint8_t>(code), static_cast<std::uint8_t>(code >> 8),
           static_cast<std::uint8_t>(code >> 16), static_cast<std::uint8_t>(code >> 24)});
  }
  void on_frame(const can::TimedFrame& timed) {
    if (timed.own) return;
    const can::Frame& frame = timed.frame;
    if (frame.id == 0 && frame.length() == 2 && (frame.data[1] == node_ || frame.data[1] == 0)) {
      if (frame.data[0] == 0x81 || frame.data[0] == 0x82)
        (void)port_.send(can::Frame::standard(0x700U + node_, std::array<std::uint8_t, 1>{0}));
      return;
    }
    if (frame.id != 0x600U + node_ || frame.length() != 8) return;
    const auto message = cia301::decode_client_message(frame);
    if (const auto* up = std::get_if<cia301::InitiateUploadRequest>(&message)) {
      const ObjectRef ref{up->mux.index, up->mux.sub_index};
      const auto it = values.find(ref);
      if (it == values.end()) return abort(up->mux, 0x06020000);
      const std::uint32_t v = it->second;
      // scs=2 n=0 e=1 s=1: 4 bytes
      reply({0x43, static_cast<std::uint8_t>(ref.index), static_cast<std::uint8_t>(ref.index >> 8),
             ref.sub, static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8),
             static_cast<std::uint8_t>(v >> 16), static_cast<std::uint8_t>(v >> 24)});
      return;
    }
    if (const auto* down = std::get_if<cia301::InitiateDownloadRequest>(&message)) {
      const ObjectRef ref{down->mux.index, down->mux.sub_index};
      if (!down->expedited || values.count(ref) == 0) return abort(down->mux, 0x06020000);
      if (locked.count(ref) != 0) return abort(down->mux, 0x06010002);
      values[ref] = static_cast<std::uint32_t>(cia301::load_unsigned(down->expedited_data()));
      if (write_once.count(ref) != 0) locked.insert(ref);
      // scs=3: download confirmed
      reply({0x60, static_cast<std::uint8_t>(ref.index), static_cast<std::uint8_t>(ref.index >> 8),
             ref.sub, 0, 0, 0, 0});
    }
  }

  can::Bus& port_;
  std::uint8_t node_;
};

class IsolationTest : public ::testing::Test {
 protected:
  IsolationTest() : harness_(bus_.attach("harness")), dut_port_(bus_.attach("dut")) {}

  void start_drive(reference_drive::DeviationSet deviations = {}) {
    reference_drive::DriveConfig config;
    config.dictionary.node_id = 1;
    config.deviations = std::move(deviations);
    auto drive = reference_drive::ReferenceDrive::create(*dut_port_, std::move(config));
    ASSERT_TRUE(drive) << drive.error();
    drive_ = std::move(*drive);
    drive_->power_on();
    bus_.run_for(10ms);
  }

  can::SimBus bus_{{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> harness_;
  std::unique_ptr<can::SimPort> dut_port_;
  profile::DriveProfile profile_ = make_profile();
  std::unique_ptr<reference_drive::ReferenceDrive> drive_;
};

TEST_F(IsolationTest, FailedVectorStillRunsFinallyAndItsObjectsAreRestored) {
  start_drive();
  // Given a vector (no reset around it) that writes 1017h, fails at its second step, and
  // writes 1016h sub 1 in finally:; then one that reads both without a reset
  const auto vectors = parse(
      "- id: t/fails-midway\n  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n"
      "  steps:\n"
      "    - sdo_write: {index: 0x1017, sub: 0, value: 300, size: 2}\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n      expect: {value: 0x12345678}\n"
      "    - sdo_write: {index: 0x100C, sub: 0, value: 9, size: 2}\n"
      "  finally:\n"
      "    - sdo_write: {index: 0x1016, sub: 1, value: 0x007D0064, size: 4}\n"
      "- id: t/after\n  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n"
      "  steps:\n"
      "    - sdo_read: {index: 0x1017, sub: 0}\n      expect: {value: 0}\n"
      "    - sdo_read: {index: 0x1016, sub: 1}\n      expect: {value: 0}\n");
  // When both run
  Engine engine(*harness_, profile_, {});
  const RunResult result = engine.run(vectors);
  // Then the first fails at step 2, its finally step ran (a passing check), the engine put both
  // objects back (a passing restore check), and the second vector sees the values before
  ASSERT_EQ(result.vectors.size(), 2U);
  const auto& failed = result.vectors[0];
  EXPECT_EQ(failed.verdict, Verdict::fail);
  EXPECT_NE(failed.message.find("step 2 sdo_read"), std::string::npos) << failed.message;
  bool finally_ran = false;
  bool restored = false;
  for (const auto& check : failed.checks) {
    finally_ran |= check.ok && check.expected.find("write 1016h sub 1") != std::string::npos;
    restored |= check.ok && check.action == "restore" &&
                check.actual.find("1017h sub 0 := 00 00") != std::string::npos &&
                check.actual.find("1016h sub 1 := 00 00 00 00") != std::string::npos;
  }
  EXPECT_TRUE(finally_ran);
  EXPECT_TRUE(restored);
  EXPECT_EQ(result.vectors[1].verdict, Verdict::pass) << result.vectors[1].message;
  EXPECT_TRUE(result.harness_notes.empty()) << notes(result);
}

TEST_F(IsolationTest, FailedFinallyStepIsANoteNotTheVerdict) {
  start_drive();
  // Given a passing vector whose finally step fails
  const auto vectors = parse(
      "- id: t/ok\n  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n"
      "  steps:\n    - sdo_read: {index: 0x1000, sub: 0}\n"
      "  finally:\n    - sdo_read: {index: 0x1000, sub: 0}\n      expect: {value: 7}\n");
  // When it runs
  Engine engine(*harness_, profile_, {});
  const RunResult result = engine.run(vectors);
  // Then it passes, and the failed finally step is a harness note with the vector id
  ASSERT_EQ(result.vectors.size(), 1U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << result.vectors[0].message;
  EXPECT_TRUE(has_note(result, "vector t/ok: finally step 1 (sdo_read, line 9) did not succeed"))
      << notes(result);
}

TEST_F(IsolationTest, StoredValueIsPutBackIntoNonVolatileMemory) {
  start_drive();
  // Given a vector that writes 1017h, stores it (1010h sub 1 "save") and then fails; and a
  // vector after it that resets the node and reads 1017h
  const std::string text =
      "- id: t/stores\n  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n"
      "  steps:\n"
      "    - sdo_write: {index: 0x1017, sub: 0, value: 200, size: 2}\n"
      "    - sdo_write: {index: 0x1010, sub: 1, value: 0x65766173, size: 4}\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n      expect: {value: 0x12345678}\n"
      "- id: t/after-reset\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1017, sub: 0}\n      expect: {value: 0}\n";
  // When both run with isolation
  Engine engine(*harness_, profile_, {});
  const RunResult result = engine.run(parse(text));
  // Then the reset brings back the value before the vector: the engine stored it again
  ASSERT_EQ(result.vectors.size(), 2U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::fail);
  EXPECT_EQ(result.vectors[1].verdict, Verdict::pass) << result.vectors[1].message;
  bool stored_again = false;
  for (const auto& check : result.vectors[0].checks)
    stored_again |=
        check.actual.find("1010h sub 1 := \"save\" (store them again): ok") != std::string::npos;
  EXPECT_TRUE(stored_again);
}

TEST_F(IsolationTest, WithoutIsolationTheStoredValueLeaks) {
  start_drive();
  // Given the same two vectors (the check that the test above can fail)
  const std::string text =
      "- id: t/stores\n  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n"
      "  steps:\n"
      "    - sdo_write: {index: 0x1017, sub: 0, value: 200, size: 2}\n"
      "    - sdo_write: {index: 0x1010, sub: 1, value: 0x65766173, size: 4}\n"
      "    - sdo_read: {index: 0x1000, sub: 0}\n      expect: {value: 0x12345678}\n"
      "- id: t/after-reset\n  title: t\n  source: \"CiA 301 §1\"\n  steps:\n"
      "    - sdo_read: {index: 0x1017, sub: 0}\n      expect: {value: 0}\n";
  // When both run without isolation
  EngineOptions options;
  options.isolation = false;
  Engine engine(*harness_, profile_, options);
  const RunResult result = engine.run(parse(text));
  // Then the second vector fails: the drive kept 200 ms in non-volatile memory
  ASSERT_EQ(result.vectors.size(), 2U);
  EXPECT_EQ(result.vectors[1].verdict, Verdict::fail);
}

TEST_F(IsolationTest, UnrestorableChangeIsANoteAndTurnsLaterFailuresIntoErrors) {
  // Given a device where 2000h accepts one write and refuses any further one
  FakeDevice device(*dut_port_, 1);
  device.values = {{{0x1000, 0}, 0x00000191}, {{0x2000, 0}, 0}, {{0x2001, 0}, 0}};
  device.write_once = {{0x2000, 0}};
  // And a vector that writes 2000h, one that fails, one that passes
  const std::string head = "  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n";
  const auto vectors =
      parse("- id: t/leaky\n" + head +
            "  steps:\n    - sdo_write: {index: 0x2000, sub: 0, value: 5, size: 4}\n"
            "- id: t/fails-later\n" +
            head +
            "  steps:\n    - sdo_read: {index: 0x2001, sub: 0}\n      expect: {value: 1}\n"
            "- id: t/passes\n" +
            head + "  steps:\n    - sdo_read: {index: 0x2001, sub: 0}\n      expect: {value: 0}\n");
  Engine engine(*harness_, profile_, {});
  // When they run
  const RunResult result = engine.run(vectors);
  // Then the change is a harness note naming the vector, object and values; the later failure
  // is an error that names the leak; the passing vector still passes
  ASSERT_EQ(result.vectors.size(), 3U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << result.vectors[0].message;
  EXPECT_TRUE(has_note(result,
                       "vector t/leaky: could not undo its change: 2000h sub 0 still holds 05 00 "
                       "00 00 (was 00 00 00 00) from vector t/leaky"))
      << notes(result);
  EXPECT_EQ(result.vectors[1].verdict, Verdict::error);
  EXPECT_NE(result.vectors[1].message.find("2000h sub 0 still holds 05 00 00 00"),
            std::string::npos)
      << result.vectors[1].message;
  EXPECT_EQ(result.vectors[2].verdict, Verdict::pass) << result.vectors[2].message;
  EXPECT_TRUE(has_note(result, "at the end of the run: 2000h sub 0 still holds")) << notes(result);
  // When the device accepts writes again and the failing vector runs once more
  device.locked.clear();
  const RunResult again = engine.run({vectors[1]});
  // Then the engine put the object back before it (a note), and the failure is a failure
  ASSERT_EQ(again.vectors.size(), 1U);
  EXPECT_EQ(again.vectors[0].verdict, Verdict::fail) << again.vectors[0].message;
  EXPECT_TRUE(has_note(again,
                       "vector t/leaky: 2000h sub 0 is back to 00 00 00 00 (written back "
                       "before vector t/fails-later)"))
      << notes(again);
}

TEST_F(IsolationTest, SelfStartingDeviceStillRunsVectorsInPreOperational) {
  // Given a drive that enters Operational by itself after its boot-up
  start_drive({reference_drive::Deviation::nmt_starts_operational});
  const std::string steps =
      "  steps:\n    - sdo_write: {index: 0x1017, sub: 0, value: 20, size: 2}\n"
      "    - expect_heartbeat: pre-operational\n      within: 40ms\n";
  const auto vectors =
      parse("- id: t/commanded\n  title: t\n  source: \"CiA 301 §1\"\n" + steps +
            "- id: t/assumed\n  title: t\n  source: \"CiA 301 §1\"\n  nmt: none\n" + steps);
  // When a vector with the default nmt: pre-operational and one with nmt: none run (both reset
  // the node first)
  Engine engine(*harness_, profile_, {});
  const RunResult result = engine.run(vectors);
  // Then the engine's explicit command puts the first in Pre-operational (pass); the second,
  // which takes the state after boot-up as it is, sees the drive Operational (fail)
  ASSERT_EQ(result.vectors.size(), 2U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::pass) << result.vectors[0].message;
  EXPECT_EQ(result.vectors[1].verdict, Verdict::fail);
}

TEST_F(IsolationTest, StoppedThatCannotBeConfirmedIsAnError) {
  // Given a drive that answers SDO in Stopped (it cannot be told apart from one that ignored
  // the stop command without a heartbeat)
  start_drive({reference_drive::Deviation::sdo_in_stopped});
  const auto vectors = parse(
      "- id: t/stopped\n  title: t\n  source: \"CiA 301 §1\"\n  nmt: stopped\n"
      "  steps:\n    - wait: 1ms\n");
  // When a vector asks for Stopped
  Engine engine(*harness_, profile_, {});
  const RunResult result = engine.run(vectors);
  // Then it is an error that says why, not a failure
  ASSERT_EQ(result.vectors.size(), 1U);
  EXPECT_EQ(result.vectors[0].verdict, Verdict::error);
  EXPECT_NE(result.vectors[0].message.find("stopped (000#0201) not confirmed: the DUT answers SDO"),
            std::string::npos)
      << result.vectors[0].message;
}

TEST_F(IsolationTest, StateConfirmedByTheHeartbeatWhenTheDeviceProducesOne) {
  // Given a drive that sends its heartbeat with a wrong state byte, producing one every 20 ms
  // (stored, so that it runs from the boot-up)
  start_drive({reference_drive::Deviation::heartbeat_wrong_state});
  const auto vectors = parse(
      "- id: t/store-heartbeat\n  title: t\n  source: \"CiA 301 §1\"\n  nmt: none\n"
      "  steps:\n    - sdo_write: {index: 0x1017, sub: 0, value: 20, size: 2}\n"
      "    - sdo_write: {index: 0x1010, sub: 1, value: 0x65766173, size: 4}\n"
      "- id: t/operational\n  title: t\n  source: \"CiA 301 §1\"\n  nmt: operational\n"
      "  steps:\n    - wait: 1ms\n");
  // When the second vector asks for Operational with isolation off (the stored heartbeat stays)
  EngineOptions options;
  options.isolation = false;
  Engine engine(*harness_, profile_, options);
  const RunResult result = engine.run(vectors);
  // Then the heartbeat's state byte (7Fh where 05h is due) makes it an error naming the frame
  ASSERT_EQ(result.vectors.size(), 2U);
  EXPECT_EQ(result.vectors[1].verdict, Verdict::error);
  EXPECT_NE(result.vectors[1].message.find("no heartbeat 701#05"), std::string::npos)
      << result.vectors[1].message;
}

}  // namespace
}  // namespace drivecheck::conformance
