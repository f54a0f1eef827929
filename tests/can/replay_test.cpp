#include "protocol/can/replay.hpp"

#include <gtest/gtest.h>

#include "protocol/can/sim_bus.hpp"
#include "protocol/can/trace_recorder.hpp"
#include "tests/can/manual_bus.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::can {
namespace {

using namespace std::chrono_literals;
using std::chrono::nanoseconds;
using test_support::ManualBus;
using test_support::TempDir;

std::vector<LogRecord> log_of(std::string_view text) {
  auto records = read_candump_log(text);
  EXPECT_TRUE(records) << records.error().to_string();
  return records ? *records : std::vector<LogRecord>{};
}

std::vector<std::string> sent_texts(const ManualBus& bus) {
  std::vector<std::string> texts;
  for (const auto& sent : bus.sent()) {
    texts.push_back(fmt::format("{} {}", sent.at.time_since_epoch().count() / 1000, sent.frame));
  }
  return texts;  // "<µs> <frame>"
}

// NMT start node 5, SYNC, RPDO1 node 5 (controlword 000Fh), SYNC; 0, 1, 5.5, 10 ms
constexpr std::string_view kLog =
    "(1700000000.000000) can0 000#0105 T\n"
    "(1700000000.001000) can0 080# T\n"
    "(1700000000.005500) can0 205#0F00 T\n"
    "(1700000000.010000) can0 080# T\n";

TEST(Replay, OriginalTimingKeepsRelativeTimes) {
  // Given a log with frames at 0, 1, 5.5 and 10 ms, and a port whose clock is at 2 ms
  // When replayed with the original timing
  // Then the frames go out at 2, 3, 7.5 and 12 ms
  ManualBus bus;
  bus.run_until(TimePoint(2ms));
  const auto stats = replay(bus, log_of(kLog));
  ASSERT_TRUE(stats) << stats.error().to_string();
  EXPECT_EQ(stats->sent, 4u);
  EXPECT_EQ(stats->skipped, 0u);
  EXPECT_EQ(sent_texts(bus), (std::vector<std::string>{"2000 000#0105", "3000 080#",
                                                       "7500 205#0F00", "12000 080#"}));
}

TEST(Replay, AsFastAsPossibleSendsEverythingAtOnce) {
  // Given the same log
  // When replayed as fast as possible
  // Then every frame goes out at the current time, in log order
  ManualBus bus;
  bus.run_until(TimePoint(2ms));
  const auto stats = replay(bus, log_of(kLog), {.timing = ReplayTiming::as_fast_as_possible});
  ASSERT_TRUE(stats);
  EXPECT_EQ(sent_texts(bus),
            (std::vector<std::string>{"2000 000#0105", "2000 080#", "2000 205#0F00", "2000 080#"}));
}

TEST(Replay, StartPlacesTheLogsFirstRecord) {
  // Given a start time of 50 ms
  // When replayed with the original timing
  // Then the first record goes at 50 ms and the rest keep their spacing
  ManualBus bus;
  ASSERT_TRUE(replay(bus, log_of(kLog), {.start = TimePoint(50ms)}));
  EXPECT_EQ(sent_texts(bus), (std::vector<std::string>{"50000 000#0105", "51000 080#",
                                                       "55500 205#0F00", "60000 080#"}));
}

TEST(Replay, FiltersKeepTheOriginalTimeOrigin) {
  // Given a filter passing only SYNC (080h)
  // When replayed from 0 ms
  // Then only the SYNCs go, at their original 1 and 10 ms (the log's first record is time 0)
  ManualBus bus;
  const auto stats =
      replay(bus, log_of(kLog), {.filters = {Filter::standard(0x080)}, .start = TimePoint(0ms)});
  ASSERT_TRUE(stats);
  EXPECT_EQ(stats->sent, 2u);
  EXPECT_EQ(stats->skipped, 2u);
  EXPECT_EQ(sent_texts(bus), (std::vector<std::string>{"1000 080#", "10000 080#"}));
}

TEST(Replay, InvertedFilterInterfaceAndDirectionSelect) {
  // Given a log over two interfaces, with R and T flags, an error frame, and several SYNCs
  // When replayed without SYNC (inverted filter), only can0, only T
  // Then exactly the T frames of can0 other than SYNC go; the error frame never does
  constexpr std::string_view log =
      "(1.000000) can0 000#0105 T\n"                   // NMT start node 5: sent
      "(1.000100) can0 080# T\n"                       // SYNC: filtered out
      "(1.000200) can1 205#0F00 T\n"                   // other interface
      "(1.000300) can0 185#0102 R\n"                   // received, not sent
      "(1.000400) can0 20000004#0004000000000000 T\n"  // error frame (controller problem)
      "(1.000500) can0 605#4041600000000000 T\n";      // SDO upload 6041h: sent
  Filter not_sync = Filter::standard(0x080);
  not_sync.invert = true;
  ManualBus bus;
  const auto stats = replay(bus, log_of(log),
                            {.timing = ReplayTiming::as_fast_as_possible,
                             .filters = {not_sync},
                             .interface = "can0",
                             .direction = TraceDirection::transmit});
  ASSERT_TRUE(stats);
  EXPECT_EQ(stats->sent, 2u);
  EXPECT_EQ(stats->skipped, 4u);
  EXPECT_EQ(sent_texts(bus), (std::vector<std::string>{"0 000#0105", "0 605#4041600000000000"}));
}

TEST(Replay, ErrorFramesAreNeverSentEvenUnfiltered) {
  ManualBus bus;
  const auto stats = replay(bus, log_of("(1.0) can0 20000080#0000000000000000\n"));
  ASSERT_TRUE(stats);
  EXPECT_EQ(stats->sent, 0u);
  EXPECT_EQ(stats->skipped, 1u);
  EXPECT_TRUE(bus.sent().empty());
}

TEST(Replay, BackwardsTimestampsGoAtOnceInLogOrder) {
  // Given a merged log whose third record is earlier than the second
  // When replayed with the original timing
  // Then the late-stamped record goes right after the second, in log order
  ManualBus bus;
  ASSERT_TRUE(replay(bus, log_of("(10.000000) can0 080#01\n"
                                 "(10.004000) can0 080#02\n"
                                 "(10.001000) can0 080#03\n"
                                 "(10.006000) can0 080#04\n"
                                 "(9.000000) can0 080#05\n")));
  EXPECT_EQ(sent_texts(bus), (std::vector<std::string>{"0 080#01", "4000 080#02", "4000 080#03",
                                                       "6000 080#04", "6000 080#05"}));
}

TEST(Replay, FullQueueIsRetried) {
  // Given a port whose next 3 sends fail with queue_full
  // When a log is replayed with a 2 ms retry interval
  // Then the first frame goes after 3 retries (6 ms) and the rest follow with the original spacing
  // from there on where they are not late
  ManualBus bus;
  bus.fail_sends(3, BusError::queue_full);
  const auto stats = replay(bus, log_of(kLog), {.retry_interval = 2ms});
  ASSERT_TRUE(stats) << stats.error().to_string();
  EXPECT_EQ(sent_texts(bus), (std::vector<std::string>{"6000 000#0105", "6000 080#",
                                                       "6000 205#0F00", "10000 080#"}));
}

TEST(Replay, FullQueueGivesUpAfterTheLimit) {
  // Given a port that never takes the third frame (queue full)
  // When replayed with give_up_after 10 ms
  // Then the replay stops with queue_full naming record 3, after sending 2
  ManualBus bus;
  const auto records = log_of(kLog);
  Replayer replayer(bus, records, {.retry_interval = 1ms, .give_up_after = 10ms});
  bool finished = false;
  replayer.start([&] { finished = true; });
  bus.run_until(TimePoint(5ms));
  bus.fail_sends(1000, BusError::queue_full);
  bus.run_until(TimePoint(100ms));
  ASSERT_TRUE(finished);
  ASSERT_TRUE(replayer.error());
  EXPECT_EQ(replayer.error()->record_index, 2u);
  EXPECT_EQ(replayer.error()->error, make_error_code(BusError::queue_full));
  EXPECT_EQ(replayer.error()->to_string(),
            "replay stopped at record 3 (205#0F00): transmit queue full (ENOBUFS) past the send "
            "timeout");
  EXPECT_EQ(replayer.stats().sent, 2u);
  EXPECT_EQ(bus.sent().size(), 2u);
  EXPECT_EQ(bus.pending_events(), 0u);  // no timer left behind
}

TEST(Replay, BusOffStopsAtOnce) {
  // Given a port that is bus-off
  // When a log is replayed
  // Then replay() returns the bus_off error for the first record
  ManualBus bus;
  bus.fail_sends(1, BusError::bus_off);
  const auto stats = replay(bus, log_of(kLog));
  ASSERT_FALSE(stats);
  EXPECT_EQ(stats.error().record_index, 0u);
  EXPECT_EQ(stats.error().error, make_error_code(BusError::bus_off));
}

TEST(Replay, CancelAndDestructionLeaveNoTimer) {
  // Given a replay waiting for its second frame
  // When it is cancelled, and another one is destroyed while waiting
  // Then nothing more is sent and no timer is left on the port
  ManualBus bus;
  {
    Replayer replayer(bus, log_of(kLog));
    replayer.start();
    EXPECT_EQ(bus.sent().size(), 1u);
    replayer.cancel();
    EXPECT_TRUE(replayer.done());
    EXPECT_EQ(bus.pending_events(), 0u);
    Replayer destroyed(bus, log_of(kLog));
    destroyed.start();
    EXPECT_EQ(bus.pending_events(), 1u);
  }
  EXPECT_EQ(bus.pending_events(), 0u);
  bus.run_until(TimePoint(1s));
  EXPECT_EQ(bus.sent().size(), 2u);
}

TEST(Replay, EmptyLogIsDoneAtOnceAndLeavesNoStop) {
  // Given an empty log
  // When replayed
  // Then replay() returns with nothing sent, and the port's next run_until runs normally
  ManualBus bus;
  const auto stats = replay(bus, {});
  ASSERT_TRUE(stats);
  EXPECT_EQ(stats->sent, 0u);
  bus.run_until(TimePoint(5ms));
  EXPECT_EQ(bus.now(), TimePoint(5ms));
}

TEST(ReplayRoundTrip, RecordReadBackReplayGivesIdenticalTrace) {
  // Given a log recorded from a port (T flags, µs timestamps) and read back
  // When it is replayed into a recording port whose clock maps the log's first time to its start
  // Then the new trace is identical to the original: frames, timestamps, interface, flags
  TempDir dir;
  const Duration offset = 1'700'000'000s;
  {
    ManualBus original_port(offset);
    auto recorder = TraceRecorder::open({.candump_log = dir / "original.log"},
                                        {.interface = "can0", .unix_offset = offset});
    ASSERT_TRUE(recorder) << recorder.error();
    RecordingBus port(original_port, **recorder);
    // 50 frames: SYNC, RPDO1 node 5, SDO request, at irregular µs times
    for (int i = 0; i < 50; ++i) {
      original_port.run_until(TimePoint(std::chrono::microseconds(1000 * i + (i * i * 37) % 900)));
      const auto text = i % 3 == 0 ? "080#" : i % 3 == 1 ? "205#0F00" : "605#4041600000000000";
      ASSERT_FALSE(port.send(*parse_candump(text)));
    }
  }
  const auto original = read_candump_log_file(dir / "original.log");
  ASSERT_TRUE(original) << original.error().to_string();
  ASSERT_EQ(original->size(), 50u);

  ManualBus replay_port(offset);
  auto recorder = TraceRecorder::open({.candump_log = dir / "replayed.log"},
                                      {.interface = "can0", .unix_offset = offset});
  ASSERT_TRUE(recorder) << recorder.error();
  RecordingBus port(replay_port, **recorder);
  const auto stats =
      replay(port, *original, {.start = to_bus_time(original->front().timestamp, offset)});
  ASSERT_TRUE(stats) << stats.error().to_string();
  EXPECT_EQ(stats->sent, 50u);
  const auto replayed = read_candump_log_file(dir / "replayed.log");
  ASSERT_TRUE(replayed) << replayed.error().to_string();
  EXPECT_EQ(*replayed, *original);
  EXPECT_EQ(test_support::read_file(dir / "replayed.log"),
            test_support::read_file(dir / "original.log"));
}

TEST(ReplayOnSimBus, FastReplayThroughASmallQueueDeliversEverythingInOrder) {
  // Given a simulated bus at 125 kbit/s whose ports queue at most 4 frames, and a listener
  // When 100 frames are replayed as fast as possible from one port
  // Then the listener gets all 100 in order, back to back on the wire, and the replay
  //      needed the queue_full retries to get there
  SimBus bus({.bitrate = 125'000, .tx_queue_limit = 4});
  auto player = bus.attach("player");
  auto listener = bus.attach("listener");
  std::vector<TimedFrame> heard;
  listener->set_frame_handler([&](const TimedFrame& frame) { heard.push_back(frame); });
  std::vector<LogRecord> records;
  for (int i = 0; i < 100; ++i) {
    // TPDO1 node 1 carrying a counter
    records.push_back({nanoseconds(i), "can0",
                       Frame::standard(0x181, {static_cast<std::uint8_t>(i)}), std::nullopt});
  }
  const auto stats = replay(*player, records,
                            {.timing = ReplayTiming::as_fast_as_possible, .retry_interval = 100us});
  ASSERT_TRUE(stats) << stats.error().to_string();
  EXPECT_EQ(stats->sent, 100u);
  // The last send waited for the queue: 96 frames of at least 440 µs went before it.
  EXPECT_GT(player->now(), TimePoint(30ms));
  bus.run_until(bus.now() + 10ms);
  ASSERT_EQ(heard.size(), 100u);
  for (int i = 0; i < 100; ++i)
    EXPECT_EQ(heard[i].frame.data[0], i);
  // A frame of 1 byte is at least 52 bits (no stuffing) = 416 µs at 125 kbit/s.
  EXPECT_GE(heard.back().timestamp - heard.front().timestamp, 99 * 416us);
}

TEST(ReplayOnSimBus, OriginalTimingOnSimulatedClockAndMonitorTrace) {
  // Given a log spanning 2 s, a simulated bus whose zero is the log's first second, a monitor
  // recording the wire
  // When replayed with the original timing
  // Then each frame reaches the wire at its log time plus its own wire time (under 300 µs at
  //      500 kbit/s), and the whole run took 2 s of simulated time
  TempDir dir;
  const Duration offset = 1'700'000'000s;
  SimBus bus({.bitrate = 500'000, .unix_offset = offset});
  auto recorder = TraceRecorder::open({.candump_log = dir / "wire.log"},
                                      {.interface = "can0", .unix_offset = offset});
  ASSERT_TRUE(recorder);
  bus.add_monitor((*recorder)->monitor());
  auto player = bus.attach("player");
  const auto records = log_of(
      "(1700000000.000000) can0 000#0105\n"                // NMT start node 5
      "(1700000000.500000) can0 205#0F00\n"                // RPDO1 node 5: controlword 000Fh
      "(1700000002.000000) can0 605#4041600000000000\n");  // SDO upload 6041h
  const auto stats = replay(*player, records, {.start = TimePoint(0s)});
  ASSERT_TRUE(stats) << stats.error().to_string();
  bus.run_until(bus.now() + 1ms);
  const auto wire = read_candump_log_file(dir / "wire.log");
  ASSERT_TRUE(wire) << wire.error().to_string();
  ASSERT_EQ(wire->size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ((*wire)[i].frame, records[i].frame);
    const auto late = (*wire)[i].timestamp - records[i].timestamp;
    EXPECT_GT(late, 0us) << i;
    EXPECT_LT(late, 300us) << i;
  }
}

}  // namespace
}  // namespace drivecheck::can
