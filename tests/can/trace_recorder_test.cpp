#include "protocol/can/trace_recorder.hpp"

#include <gtest/gtest.h>

#include "protocol/can/sim_bus.hpp"
#include "tests/can/manual_bus.hpp"
#include "tests/support/temp_dir.hpp"

namespace drivecheck::can {
namespace {

using namespace std::chrono_literals;
using std::chrono::nanoseconds;
using test_support::ManualBus;
using test_support::TempDir;

constexpr Duration kOffset = 1'700'000'000s;

Frame frame_of(const char* text) {
  auto frame = parse_candump(text);
  EXPECT_TRUE(frame) << text;
  return frame ? *frame : Frame{};
}

// The candump log keeps microseconds: what a bus time becomes in it.
nanoseconds log_time(TimePoint at, Duration offset = kOffset) {
  return nanoseconds(to_unix_time(at, offset).count() / 1000 * 1000);
}

std::unique_ptr<TraceRecorder> open_both(const TempDir& dir, Duration offset = kOffset) {
  auto recorder = TraceRecorder::open({dir / "run.log", dir / "run.pcap"},
                                      {.interface = "sim", .unix_offset = offset});
  EXPECT_TRUE(recorder) << recorder.error();
  return recorder ? std::move(*recorder) : nullptr;
}

TEST(TraceRecorder, WritesBothFilesInUnixTime) {
  // Given a recorder on a candump log and a pcap, for a bus whose zero is Unix 1700000000 s
  // When three frames are recorded at bus times with nanoseconds
  // Then the log has them in µs Unix time with their direction flags, the pcap in ns
  TempDir dir;
  auto recorder = open_both(dir);
  ASSERT_TRUE(recorder);
  // NMT start node 5; SDO rx node 5 read 6041h sub 0; SDO tx node 5: 6041h = 0237h
  const Frame frames[] = {frame_of("000#0105"), frame_of("605#4041600000000000"),
                          frame_of("585#4B41600037020000")};
  const TimePoint times[] = {TimePoint(1500ns), TimePoint(250'123'456ns), TimePoint(250'355'999ns)};
  const std::optional<TraceDirection> directions[] = {std::nullopt, TraceDirection::transmit,
                                                      TraceDirection::receive};
  for (int i = 0; i < 3; ++i)
    ASSERT_TRUE(recorder->record(frames[i], times[i], directions[i]));
  EXPECT_EQ(recorder->frames_recorded(), 3u);

  EXPECT_EQ(test_support::read_file(dir / "run.log"),
            "(1700000000.000001) sim 000#0105\n"
            "(1700000000.250123) sim 605#4041600000000000 T\n"
            "(1700000000.250355) sim 585#4B41600037020000 R\n");
  const auto pcap = read_pcap_file(dir / "run.pcap");
  ASSERT_TRUE(pcap) << pcap.error().to_string();
  ASSERT_EQ(pcap->size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ((*pcap)[i].frame, frames[i]);
    EXPECT_EQ((*pcap)[i].timestamp, to_unix_time(times[i], kOffset));
  }
}

TEST(TraceRecorder, FilesAreValidAfterEveryFrame) {
  // Given a recording in progress (files never closed, as when a run is interrupted)
  // When both files are read after each frame
  // Then each holds every frame recorded so far
  TempDir dir;
  auto recorder = open_both(dir);
  ASSERT_TRUE(recorder);
  for (int i = 0; i < 10; ++i) {
    // SYNC with counter i + 1
    const Frame sync = Frame::standard(0x080, {static_cast<std::uint8_t>(i + 1)});
    ASSERT_TRUE(recorder->record(sync, TimePoint(i * 1ms)));
    const auto log = read_candump_log_file(dir / "run.log");
    const auto pcap = read_pcap_file(dir / "run.pcap");
    ASSERT_TRUE(log) << log.error().to_string();
    ASSERT_TRUE(pcap) << pcap.error().to_string();
    ASSERT_EQ(log->size(), static_cast<std::size_t>(i + 1));
    ASSERT_EQ(pcap->size(), static_cast<std::size_t>(i + 1));
    EXPECT_EQ(log->back().frame, sync);
    EXPECT_EQ(pcap->back().frame, sync);
  }
}

TEST(TraceRecorder, OnlyTheRequestedFileIsWritten) {
  TempDir dir;
  auto recorder = TraceRecorder::open({.pcap = dir / "only.pcap"}, {});
  ASSERT_TRUE(recorder) << recorder.error();
  ASSERT_TRUE((*recorder)->record(frame_of("080#"), TimePoint(1s)));
  EXPECT_EQ(read_pcap_file(dir / "only.pcap")->size(), 1u);
  EXPECT_FALSE(std::filesystem::exists(dir / "only.log"));
}

TEST(TraceRecorder, OpenRejectsBadSettings) {
  // Given bad interface names, no file at all, and an uncreatable path
  // When a recorder is opened
  // Then each fails with a message naming the problem
  TempDir dir;
  const std::pair<std::string, const char*> names[] = {
      {"", "1..15 characters"},           {"sixteen-chars-xx", "1..15 characters"},
      {"has space", "printable ASCII"},   {"can#0", "printable ASCII"},
      {"caf\xC3\xA9", "printable ASCII"},
  };
  for (const auto& [name, expected] : names) {
    const auto recorder = TraceRecorder::open({dir / "x.log"}, {.interface = name});
    ASSERT_FALSE(recorder) << name;
    EXPECT_NE(recorder.error().find(expected), std::string::npos) << recorder.error();
  }
  const auto none = TraceRecorder::open({}, {});
  ASSERT_FALSE(none);
  EXPECT_NE(none.error().find("no trace file"), std::string::npos);
  const auto uncreatable = TraceRecorder::open({.candump_log = dir / "no" / "x.log"}, {});
  ASSERT_FALSE(uncreatable);
  EXPECT_NE(uncreatable.error().find("cannot create"), std::string::npos);
}

TEST(TraceRecorder, WriteErrorStopsRecordingAndStays) {
  // Given a recorder whose candump log is /dev/full (every write fails with ENOSPC)
  // When frames are recorded
  // Then the first record fails naming the reason, error() keeps it, and later records fail too
  auto recorder = TraceRecorder::open({.candump_log = "/dev/full"}, {});
  ASSERT_TRUE(recorder) << recorder.error();
  const auto first = (*recorder)->record(frame_of("080#"), TimePoint(1ms));
  ASSERT_FALSE(first);
  EXPECT_NE(first.error().find("No space left on device"), std::string::npos) << first.error();
  ASSERT_TRUE((*recorder)->error().has_value());
  EXPECT_FALSE((*recorder)->record(frame_of("080#"), TimePoint(2ms)));
  EXPECT_EQ((*recorder)->frames_recorded(), 0u);
}

TEST(TraceRecorder, TimeBefore1970StopsRecording) {
  // Given a bus time that maps to a negative Unix time, and one that overflows
  // When recorded
  // Then recording stops with an error instead of writing a wrong time
  TempDir dir;
  auto recorder = open_both(dir, -1s);
  ASSERT_TRUE(recorder);
  ASSERT_TRUE(recorder->record(frame_of("080#"), TimePoint(2s)));
  const auto negative = recorder->record(frame_of("080#"), TimePoint(500ms));
  ASSERT_FALSE(negative);
  EXPECT_NE(negative.error().find("not a Unix time"), std::string::npos) << negative.error();
  EXPECT_EQ(read_candump_log_file(dir / "run.log")->size(), 1u);

  TempDir dir2;
  auto overflow = open_both(dir2, kOffset);
  ASSERT_TRUE(overflow);
  EXPECT_FALSE(overflow->record(frame_of("080#"), kForever));
}

TEST(RecordingBus, RecordsSentAtSendTimeAndReceivedWithTheirTimestamp) {
  // Given a RecordingBus over a port, a frame arriving at 3 ms and one at 7 ms
  // When the port sends at 1 ms, receives the first by receive() and the second by handler
  // Then the trace has T at 1 ms, R at 3 ms, R at 7 ms, in that order
  TempDir dir;
  auto recorder = open_both(dir);
  ASSERT_TRUE(recorder);
  ManualBus inner(kOffset);
  RecordingBus bus(inner, *recorder);
  EXPECT_EQ(bus.unix_offset(), kOffset);
  const Frame request = frame_of("605#4041600000000000");   // SDO upload 6041h sub 0
  const Frame response = frame_of("585#4B41600037020000");  // 6041h = 0237h
  const Frame heartbeat = frame_of("705#05");               // node 5 operational
  inner.inject(response, TimePoint(3ms));
  inner.inject(heartbeat, TimePoint(7ms));

  bus.run_until(TimePoint(1ms));
  ASSERT_FALSE(bus.send(request));
  const auto got = bus.receive(TimePoint(5ms));
  ASSERT_TRUE(got);
  EXPECT_EQ(got->frame, response);
  std::vector<Frame> handled;
  bus.set_frame_handler([&](const TimedFrame& frame) { handled.push_back(frame.frame); });
  bus.run_until(TimePoint(10ms));
  ASSERT_EQ(handled.size(), 1u);

  const auto log = read_candump_log_file(dir / "run.log");
  ASSERT_TRUE(log) << log.error().to_string();
  ASSERT_EQ(log->size(), 3u);
  EXPECT_EQ((*log)[0],
            (LogRecord{log_time(TimePoint(1ms)), "sim", request, TraceDirection::transmit}));
  EXPECT_EQ((*log)[1],
            (LogRecord{log_time(TimePoint(3ms)), "sim", response, TraceDirection::receive}));
  EXPECT_EQ((*log)[2],
            (LogRecord{log_time(TimePoint(7ms)), "sim", heartbeat, TraceDirection::receive}));
}

TEST(RecordingBus, FailedSendsAndLoopbackEchoesAreNotRecorded) {
  // Given a RecordingBus over a port with loopback on, whose first send fails (queue full)
  // When it sends twice and receives its own echo
  // Then only the accepted frame is in the trace, once, marked T; the error reaches the caller
  TempDir dir;
  auto recorder = open_both(dir);
  ASSERT_TRUE(recorder);
  ManualBus inner(kOffset);
  RecordingBus bus(inner, *recorder);
  bus.set_loopback(true);
  inner.fail_sends(1, BusError::queue_full);
  const Frame sync = frame_of("080#");
  EXPECT_EQ(bus.send(sync), make_error_code(BusError::queue_full));
  EXPECT_FALSE(bus.send(sync));
  const auto echo = bus.receive(TimePoint(1ms));
  ASSERT_TRUE(echo);
  EXPECT_TRUE(echo->own);
  const auto log = read_candump_log_file(dir / "run.log");
  ASSERT_TRUE(log);
  ASSERT_EQ(log->size(), 1u);
  EXPECT_EQ((*log)[0].direction, TraceDirection::transmit);
}

TEST(RecordingBus, ForwardsTimersFiltersAndStop) {
  // Given a RecordingBus over a port
  // When timers are started and cancelled, filters set, and stop() called through it
  // Then the inner port does all of it
  TempDir dir;
  auto recorder = open_both(dir);
  ASSERT_TRUE(recorder);
  ManualBus inner(kOffset);
  RecordingBus bus(inner, *recorder);
  int fired = 0;
  bus.start_timer(TimePoint(2ms), [&] { ++fired; });
  const TimerId cancelled = bus.start_timer(TimePoint(3ms), [&] { fired += 100; });
  bus.cancel_timer(cancelled);
  const Filter only_705[] = {Filter::standard(0x705)};
  bus.set_filters(only_705);
  inner.inject(frame_of("185#01"), TimePoint(4ms));  // TPDO1 node 5: filtered out
  inner.inject(frame_of("705#05"), TimePoint(5ms));
  bus.run_until(TimePoint(10ms));
  EXPECT_EQ(fired, 1);
  EXPECT_EQ(bus.now(), TimePoint(10ms));
  const auto got = bus.receive(TimePoint(10ms));
  ASSERT_TRUE(got);
  EXPECT_EQ(to_candump(got->frame), "705#05");
  EXPECT_FALSE(bus.receive(TimePoint(10ms)));
  bus.stop();
  inner.inject(frame_of("705#05"), TimePoint(11ms));
  bus.run_until(TimePoint(20ms));
  EXPECT_EQ(bus.now(), TimePoint(10ms));  // the stop made run_until return at once
}

TEST(TraceRecorderOnSimBus, MonitorRecordsTheWireAndReadsBack) {
  // Given a simulated bus at 500 kbit/s whose clock zero is Unix 1700000000 s, a master and
  // a drive that answers an SDO upload, and a recorder plugged in as a bus monitor
  // When the master sends the request and waits for the answer
  // Then the trace has both frames, at the end-of-frame times the ports saw, in both files
  TempDir dir;
  SimBus bus({.bitrate = 500'000, .unix_offset = kOffset});
  auto recorder = open_both(dir, bus.unix_offset());
  ASSERT_TRUE(recorder);
  bus.add_monitor(recorder->monitor());
  auto master = bus.attach("master");
  auto drive = bus.attach("drive");
  const Frame request = frame_of("605#4041600000000000");   // SDO upload 6041h sub 0
  const Frame response = frame_of("585#4B41600037020000");  // 6041h = 0237h
  TimePoint request_seen{};
  drive->set_frame_handler([&](const TimedFrame& frame) {
    request_seen = frame.timestamp;
    EXPECT_FALSE(drive->send(response));
  });
  ASSERT_FALSE(master->send(request));
  const auto reply = master->receive(TimePoint(10ms));
  ASSERT_TRUE(reply);
  EXPECT_GT(reply->timestamp, request_seen);
  EXPECT_FALSE(recorder->error());

  const auto log = read_candump_log_file(dir / "run.log");
  ASSERT_TRUE(log) << log.error().to_string();
  ASSERT_EQ(log->size(), 2u);
  EXPECT_EQ((*log)[0], (LogRecord{log_time(request_seen), "sim", request, std::nullopt}));
  EXPECT_EQ((*log)[1], (LogRecord{log_time(reply->timestamp), "sim", response, std::nullopt}));
  const auto pcap = read_pcap_file(dir / "run.pcap");
  ASSERT_TRUE(pcap) << pcap.error().to_string();
  const std::vector<PcapRecord> expected = {{to_unix_time(request_seen, kOffset), request},
                                            {to_unix_time(reply->timestamp, kOffset), response}};
  EXPECT_EQ(*pcap, expected);
}

TEST(TraceRecorderOnSimBus, RecordingPortMarksDirections) {
  // Given the same exchange, with the master's port wrapped in a RecordingBus
  // When the master sends and receives
  // Then its trace has the request as T at send time (before the wire) and the reply as R
  TempDir dir;
  SimBus bus({.bitrate = 500'000, .unix_offset = kOffset});
  auto recorder = open_both(dir, bus.unix_offset());
  ASSERT_TRUE(recorder);
  auto port = bus.attach("master");
  auto drive = bus.attach("drive");
  RecordingBus master(*port, *recorder);
  const Frame request = frame_of("605#4041600000000000");
  const Frame response = frame_of("585#4B41600037020000");
  drive->set_frame_handler([&](const TimedFrame&) { EXPECT_FALSE(drive->send(response)); });
  master.run_until(TimePoint(1ms));
  ASSERT_FALSE(master.send(request));
  const auto reply = master.receive(TimePoint(10ms));
  ASSERT_TRUE(reply);
  const auto log = read_candump_log_file(dir / "run.log");
  ASSERT_TRUE(log);
  ASSERT_EQ(log->size(), 2u);
  EXPECT_EQ((*log)[0],
            (LogRecord{log_time(TimePoint(1ms)), "sim", request, TraceDirection::transmit}));
  EXPECT_EQ((*log)[1],
            (LogRecord{log_time(reply->timestamp), "sim", response, TraceDirection::receive}));
}

}  // namespace
}  // namespace drivecheck::can
