// The vector writer (conformance/vector_file.hpp: to_yaml, same_content): what the loader
// accepts is written to text that the loader reads back to vectors of the same content.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <variant>
#include <vector>

#include "conformance/vector_file.hpp"

namespace drivecheck::conformance {
namespace {

std::string errors_of(const VectorSet& set) {
  std::string all;
  for (const auto& error : set.errors)
    all += error.to_string() + "\n";
  return all;
}

// Parses `vectors` written by to_yaml; expects no errors and the same content, in order.
void expect_round_trip(const std::vector<Vector>& vectors, const std::string& what) {
  const std::string written = to_yaml(vectors);
  const VectorSet again = parse_vectors(written, "written.yaml");
  ASSERT_TRUE(again.ok()) << what << ": the written text does not load:\n"
                          << errors_of(again) << written;
  ASSERT_EQ(again.vectors.size(), vectors.size()) << what << "\n" << written;
  for (std::size_t i = 0; i < vectors.size(); ++i) {
    EXPECT_TRUE(same_content(again.vectors[i], vectors[i]))
        << what << ": vector " << vectors[i].id << " changed in the round trip; written:\n"
        << written;
  }
  EXPECT_EQ(to_yaml(again.vectors), written) << what << ": writing is not canonical";
}

// Every action of FORMAT.md's closed vocabulary, with every modifier, and strings YAML must
// quote (colons, '#', quotes, a newline, a leading space, 'null', non-ASCII, an empty note).
constexpr const char* kEveryAction = R"(- id: "cia301/x/every-action"
  title: "t: with # a \"quote\"\nand a newline"
  source: ["CiA 301 §7.2.4", "000_33c1d912b8b6010a.txt §3.2.2 L764-771"]
  level: should
  requires: [sdo.block, motion, simulation]
  profiles: [festo-cmmp, " odd name"]
  motion: true
  setup: restore-defaults
  nmt: none
  drive_state: operation-enabled
  timeout: $timing.homing
  steps:
    - send: "600+N#2341600000000000"          # ccs=1 e=1 s=1 n=0, 6041h sub 0, data 0
      note: "null"
    - nmt: reset-communication
      node: other
    - nmt: start
      node: 42
    - nmt: stop
      node: all
    - sdo_write: {index: 0x6060, sub: 0, value: -3, size: 1}
      transfer: expedited
      expect: {abort: [0x06090030, 0x06090031]}
    - sdo_read: {index: 0x6061, sub: 0}
      transfer: segmented
      expect: {value: -9223372036854775808, mask: 0xFFFFFFFFFFFFFFFF}
      signed: true
      save: mode_seen
    - sdo_write: {index: 0x2000, sub: 1, data: "01 02 0A"}
      transfer: block
    - sdo_write: {index: 0x6060, sub: 0, value: $mode_seen}
    - sdo_write: {index: 0x6060, sub: 0, value: $mode_seen-1}
    - sdo_read: {index: 0x6061, sub: 0}
      expect: {range: ["$mode_seen-2", "$mode_seen+0x10"]}
    - sdo_read: {index: 0x1018, sub: 1}
      expect: {range: [-9223372036854775808, 9223372036854775807]}
    - sdo_read: {index: 0x1008, sub: 0}
      expect: {size: 16777216}
    - sdo_read: {index: 0x1008, sub: 0}
      expect: {data: ""}
    - wait: 90s
    - wait: 1500us
    - bus_off: 20ms
    - controlword: 0x000F
    - simulate: {input: "fault over-temperature: é", value: -9223372036854775808}
    - mark: t0
    - expect_frame: "580+N#4B416000....0000*"
      within: 1min
      mark: t1
      since: t0
    - expect_frame: "12345678#R8"
    - expect_silence: [180+N, 080, 1FFFFF00+N]
      for: 7ns
      since: t1
    - expect_silence: any
      for: 0ms
    - expect_bootup: {}
      mark: boot
      since: t0
    - expect_heartbeat: initialising
      within: 1500ms
      mark: hb
      since: boot
    - expect_heartbeat: stopped
    - expect_emcy: {code: [0x2320, 0], register: {mask: 0x01, value: 0x01}, manufacturer: "..01"}
      within: 2s
      mark: e
      since: hb
    - expect_emcy: {code: 0x8130}
    - expect_emcy: {code: error}
    - expect_state: quick-stop-active
      within: 1s
    - expect_statusword: {mask: 0x006F, value: 0x0027}
    - poll: {index: 0x6041, sub: 0, value: -1, mask: 0x400}
      within: 10s
      every: 1ms
    - poll: {index: 0x6041, sub: 0, value: 7}
      within: 10s
    - poll: {index: 0x6064, sub: 0, range: [-10, "$mode_seen+3"]}
      signed: true
      within: $timing.homing
    - poll: {index: 0x6064, sub: 0, range: [0, 0xFFFF]}
      within: 1s
    - measure: {from: t0, to: t1, max: 10ms}
    - measure: {from: t0, to: e, min: $timing.ack_latency, max: 1s}
    - expect_periodic: 700+N
      period: 100ms
      tolerance: 3ms
      count: 10000
      mark: p
    - al_request: op
    - al_request: boot
      expect: {state: init, error: true, code: [bootstrap-not-supported, invalid_requested_state_change]}
      within: 1s
    - expect_al: {state: safeop, error: true, code: sync-manager-watchdog}
      within: $timing.response
    - expect_al: {state: preop}
    - process_data: {cycles: 100000}
    - cyclic: {cycles: 3, period: 10ms}
    - cyclic: {cycles: 1, period: $timing.poll}
      set:
        - {index: 0x607A, sub: 0, value: $mode_seen+10, size: 4}
        - {index: 0x60B2, sub: 0, value: -100, size: 2}
    - pause_process_data: watchdog
    - pause_process_data: 150ms
    - mailbox_repeat: {index: 0x6083, sub: 0, size: 4, value: -1, repeat: 4294967295}
    - power_cycle: {}
    - sdo_request: "40 18 10 00 00 00 00 00"
    - expect_sdo_response: "80181000........"
      abort: any
      or: ["4F181000........"]
      mark: answered
      within: $timing.sdo_response
  finally:
    - sdo_write: {index: 0x6060, sub: 0, value: $mode_seen}
      note: "clean-up that runs after a failed step too"
    - nmt: pre-operational
  note: ""
)";

TEST(VectorWriter, RepeatsAreWrittenBackAsRepeats) {
  // Given a vector with a repeat holding a nested repeat, with notes, in steps: and finally:
  const auto set = parse_vectors(R"(- id: t/x
  title: t
  source: "CiA 301 §1"
  steps:
    - wait: 1ms
    - repeat:
        times: 3
        steps:
          - send: "080#"
          - repeat: {times: 2, steps: [{wait: 1ms}, {send: "77D#05"}]}
            note: "inner"
      note: "outer"
    - repeat: {times: 2, steps: [{wait: 2ms}]}
  finally:
    - repeat: {times: 2, steps: [{nmt: start}]}
)",
                                 "t.yaml");
  ASSERT_TRUE(set.ok()) << errors_of(set);
  // When written and read back; Then the content, the repeats and the numbering are the same
  expect_round_trip(set.vectors, "repeats");
  const std::string written = to_yaml(set.vectors);
  EXPECT_NE(written.find("times: 3"), std::string::npos) << written;
  const auto again = parse_vectors(written, "w.yaml");
  ASSERT_TRUE(again.ok()) << errors_of(again);
  ASSERT_EQ(again.vectors.front().steps.size(), set.vectors.front().steps.size());
  for (std::size_t i = 0; i < set.vectors.front().steps.size(); ++i)
    EXPECT_EQ(again.vectors.front().steps[i].number, set.vectors.front().steps[i].number) << i;
}

TEST(VectorWriter, EveryActionRoundTrips) {
  // Given a vector file with every action and modifier of the vocabulary
  const VectorSet set = parse_vectors(kEveryAction, "every.yaml");
  ASSERT_TRUE(set.ok()) << errors_of(set);
  ASSERT_EQ(set.vectors.size(), 1U);
  std::set<std::size_t> kinds;
  for (const Step& step : set.vectors.front().steps)
    kinds.insert(step.action.index());
  ASSERT_EQ(kinds.size(), std::variant_size_v<Action>) << "the test misses an action";
  // When it is written and read again
  // Then the content is the same and writing again gives the same text
  expect_round_trip(set.vectors, "every action");
}

TEST(VectorWriter, EmptyListRoundTrips) {
  // Given no vectors / When written and read again / Then there are none and no errors
  expect_round_trip({}, "empty");
}

TEST(VectorWriter, SameContentIgnoresPlacesButNotValues) {
  // Given a vector read from one text
  const VectorSet set = parse_vectors(kEveryAction, "every.yaml");
  ASSERT_TRUE(set.ok()) << errors_of(set);
  Vector moved = set.vectors.front();
  // When only the places it was read from change, Then it has the same content
  moved.file = "elsewhere.yaml";
  moved.line += 7;
  moved.steps.front().line += 7;
  moved.sources.front().line += 7;
  EXPECT_TRUE(same_content(moved, set.vectors.front()));
  // When a modifier deep in a step changes, Then it does not
  Vector changed = set.vectors.front();
  const auto poll = std::find_if(changed.steps.begin(), changed.steps.end(), [](const Step& s) {
    return std::holds_alternative<PollStep>(s.action);
  });
  ASSERT_NE(poll, changed.steps.end());
  std::get<PollStep>(poll->action).mask = 0x800;
  EXPECT_FALSE(same_content(changed, set.vectors.front()));
  Vector renoted = set.vectors.front();
  renoted.steps.front().note = "not null";
  EXPECT_FALSE(same_content(renoted, set.vectors.front()));
}

TEST(VectorWriter, LoaderRefusesTextThatIsNotUtf8) {
  // Given a title with a byte that is not UTF-8 on line 2 (the writer could not give it back)
  const std::string text =
      "- id: a/b\n  title: \"x\xFF\"\n  source: \"CiA 301 §7\"\n"
      "  steps:\n    - wait: 1ms\n";
  // When it is loaded
  const VectorSet set = parse_vectors(text, "v.yaml");
  // Then it is an error naming that line, and no vector is kept
  ASSERT_EQ(set.errors.size(), 1U) << errors_of(set);
  EXPECT_EQ(set.errors.front().to_string(), "v.yaml:2: the text is not valid UTF-8");
  EXPECT_TRUE(set.vectors.empty());
}

TEST(VectorWriter, LoaderRefusesAnEmptyEmcyCodeList) {
  // Given an expect_emcy step with `code: []` (found by the vectors fuzz target: the step was
  // dropped without an error)
  const std::string text =
      "- id: a/b\n  title: x\n  source: \"CiA 301 §7\"\n  steps:\n"
      "    - expect_emcy: {code: []}\n    - wait: 1ms\n";
  // When it is loaded
  const VectorSet set = parse_vectors(text, "v.yaml");
  // Then it is an error on that line
  ASSERT_EQ(set.errors.size(), 1U) << errors_of(set);
  EXPECT_EQ(set.errors.front().to_string(), "v.yaml:5: expect_emcy: the list of codes is empty");
}

// Every vector file of vectors/cia301, vectors/cia402 and vectors/ethercat.
std::vector<std::filesystem::path> tree_files() {
  std::vector<std::filesystem::path> files;
  for (const char* family : {"cia301", "cia402", "ethercat"}) {
    for (const auto& entry : std::filesystem::directory_iterator(
             std::filesystem::path(DRIVECHECK_VECTORS_DIR) / family)) {
      if (entry.is_regular_file() && entry.path().extension() == ".yaml")
        files.push_back(entry.path());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

TEST(VectorWriter, EveryTreeFileRoundTrips) {
  // Given every vector file of vectors/cia301 and vectors/cia402
  const auto files = tree_files();
  ASSERT_GE(files.size(), 10U);
  std::size_t vectors = 0;
  for (const auto& path : files) {
    const VectorSet set = load_vector_file(path);
    EXPECT_TRUE(set.ok()) << errors_of(set);  // vectors.lint says more; round trip the rest
    ASSERT_FALSE(set.vectors.empty()) << path;
    vectors += set.vectors.size();
    // When it is parsed, written and parsed again
    // Then every vector has the same content and writing again gives the same text
    expect_round_trip(set.vectors, path.string());
  }
  EXPECT_GE(vectors, 500U);
}

}  // namespace
}  // namespace drivecheck::conformance
