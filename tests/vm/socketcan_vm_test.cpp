// SocketCanBus against the kernel's vcan, from two processes: runs inside the test VM
// (tests/vm/run-in-vm sets up vcan0..vcan3, see there). Each peer is this program started
// again with --peer (vm_peer.hpp). Frame data in these tests are marker bytes that tell
// frames apart, not CANopen payloads, unless a comment names the fields.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/time.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "protocol/can/error_frame.hpp"
#include "protocol/can/socketcan_bus.hpp"
#include "tests/vm/vm_peer.hpp"

namespace drivecheck::can {
namespace {

using namespace std::chrono_literals;
using vm::PeerProcess;

// vcan0: plain; vcan1: tbf 1000 frames/s with 10 frames of queue; vcan2: down;
// vcan3: tbf 10 frames/s with 10 frames of queue.
constexpr const char* kPlain = "vcan0";
constexpr const char* kThrottled = "vcan1";
constexpr const char* kDown = "vcan2";
constexpr const char* kSlow = "vcan3";

std::unique_ptr<SocketCanBus> open_bus(const char* interface, SocketCanOptions options = {}) {
  auto bus = SocketCanBus::open(interface, std::move(options));
  EXPECT_TRUE(bus) << (bus ? "" : describe_open_error(interface, bus.error()));
  return bus ? std::move(*bus) : nullptr;
}

std::unique_ptr<PeerProcess> start_peer(const std::string& role,
                                        const std::vector<std::string>& args) {
  std::string error;
  auto peer = PeerProcess::start(role, args, error);
  EXPECT_TRUE(peer) << error;
  return peer;
}

Frame frame_of(std::string_view text) {
  const auto frame = parse_candump(text);
  EXPECT_TRUE(frame) << text;
  return frame ? *frame : Frame{};
}

// Every frame until `silence` passes without one.
std::vector<TimedFrame> receive_all(SocketCanBus& bus, Duration silence = 200ms) {
  std::vector<TimedFrame> frames;
  while (auto timed = bus.receive(bus.now() + silence))
    frames.push_back(*timed);
  return frames;
}

std::vector<std::string> texts(const std::vector<TimedFrame>& frames) {
  std::vector<std::string> out;
  for (const auto& timed : frames)
    out.push_back(to_candump(timed.frame));
  return out;
}

void quit(SocketCanBus& bus, PeerProcess& peer) {
  EXPECT_FALSE(bus.send(vm::quit_frame()));
  EXPECT_EQ(peer.wait(3s), 0) << "the echo peer failed or did not quit";
}

// ---- both directions ----

TEST(SocketCanVm, EchoPeerAnswersEveryFrameShape) {
  // Given an echo peer process on vcan0 (answers each frame with id + 1)
  // When this process sends a frame of each shape
  // Then each answer comes back exactly, not marked as own
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  auto peer = start_peer("echo", {kPlain});
  ASSERT_TRUE(peer);
  const std::pair<const char*, const char*> exchanges[] = {
      // ccs=2 upload request, index 1000h sub 0
      {"601#4000100000000000", "602#4000100000000000"},     {"7FE#", "7FF#"},
      {"00000123#DEADBEEF", "00000124#DEADBEEF"},           {"704#R3", "705#R3"},
      {"123#1122334455667788_C", "124#1122334455667788_C"},
  };
  for (const auto& [request, answer] : exchanges) {
    ASSERT_FALSE(bus->send(frame_of(request))) << request;
    const auto reply = bus->receive(bus->now() + 1s);
    ASSERT_TRUE(reply) << "no answer to " << request;
    EXPECT_EQ(to_candump(reply->frame), answer);
    EXPECT_FALSE(reply->own);
  }
  quit(*bus, *peer);
  EXPECT_EQ(bus->stats().frames_sent, std::size(exchanges) + 1);
}

TEST(SocketCanVm, FramesFromPeerArriveInOrderThroughFilters) {
  // Given a port on vcan0 filtering 181h, 700h..77Fh and extended 18FF0001h
  // When a peer process sends nine frames
  // Then exactly the five matching ones arrive, in the order sent
  SocketCanOptions options;
  options.filters = {Filter::standard(0x181), Filter{0x700, Filter::kEffFlag | 0x780, false},
                     Filter::extended(0x18FF0001)};
  auto bus = open_bus(kPlain, options);
  ASSERT_TRUE(bus);
  // Only the ids matter here; the data bytes are markers that tell the frames apart.
  auto peer = start_peer("send", {kPlain, "180#", "181#01", "182#", "701#05", "77F#", "780#",
                                  "00000181#", "18FF0001#AA", "181#02"});
  ASSERT_TRUE(peer);
  EXPECT_EQ(peer->wait(3s), 0);
  EXPECT_EQ(texts(receive_all(*bus)),
            (std::vector<std::string>{"181#01", "701#05", "77F#", "18FF0001#AA", "181#02"}));
}

TEST(SocketCanVm, InvertedFilterPassesEverythingElse) {
  // Given a port with one inverted filter on 11-bit 180h (mask 7FFh)
  // When the peer sends 180h, 181h, extended 180h and 181h, and 280h
  // Then all but the frames whose low 11 bits are 180h arrive
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  const Filter inverted[] = {Filter{0x180, 0x7FF, true}};
  bus->set_filters(inverted);
  auto peer = start_peer("send", {kPlain, "180#", "181#", "00000180#", "00000181#", "280#"});
  ASSERT_TRUE(peer);
  EXPECT_EQ(peer->wait(3s), 0);
  EXPECT_EQ(texts(receive_all(*bus)), (std::vector<std::string>{"181#", "00000181#", "280#"}));
}

TEST(SocketCanVm, NewFiltersApplyToFramesAlreadyRead) {
  // Given three frames already read from the socket by run_for (no handler: kept for receive)
  // When the filters are changed to 200h only
  // Then receive() returns only the 200h frame
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  // ids 100h/200h, data: one marker byte each
  auto peer = start_peer("send", {kPlain, "100#01", "200#02", "100#03"});
  ASSERT_TRUE(peer);
  EXPECT_EQ(peer->wait(3s), 0);
  bus->run_for(100ms);
  const Filter only[] = {Filter::standard(0x200)};
  bus->set_filters(only);
  EXPECT_EQ(texts(receive_all(*bus)), (std::vector<std::string>{"200#02"}));
  EXPECT_EQ(bus->stats().frames_received, 3u);
}

// ---- loopback ----

TEST(SocketCanVm, OwnFramesComeBackMarkedOnlyWithLoopback) {
  // Given port A with loopback on, port B (plain) and an echo peer, all on vcan0
  // When A sends 321h, then turns loopback off and sends 323h
  // Then A sees its 321h marked own and the answer 322h unmarked; B sees both unmarked; after
  //      loopback off A sees only the answer 324h
  auto a = open_bus(kPlain);
  auto b = open_bus(kPlain);
  ASSERT_TRUE(a && b);
  a->set_loopback(true);
  auto peer = start_peer("echo", {kPlain});
  ASSERT_TRUE(peer);

  // id 321h, data: marker byte 01 (the echo answers 322#01)
  ASSERT_FALSE(a->send(frame_of("321#01")));
  std::vector<std::pair<std::string, bool>> seen_by_a;
  for (int i = 0; i < 2; ++i) {
    const auto timed = a->receive(a->now() + 1s);
    ASSERT_TRUE(timed) << "A received only " << i << " frames";
    seen_by_a.emplace_back(to_candump(timed->frame), timed->own);
  }
  std::sort(seen_by_a.begin(), seen_by_a.end());
  EXPECT_EQ(seen_by_a,
            (std::vector<std::pair<std::string, bool>>{{"321#01", true}, {"322#01", false}}));
  const auto seen_by_b = receive_all(*b, 100ms);
  ASSERT_EQ(texts(seen_by_b), (std::vector<std::string>{"321#01", "322#01"}));
  EXPECT_FALSE(seen_by_b[0].own);
  EXPECT_FALSE(seen_by_b[1].own);

  a->set_loopback(false);
  ASSERT_FALSE(a->send(frame_of("323#02")));
  const auto after = receive_all(*a, 200ms);
  ASSERT_EQ(texts(after), (std::vector<std::string>{"324#02"}));
  EXPECT_FALSE(after[0].own);
  quit(*a, *peer);
}

// ---- timestamps ----

class SocketCanVmTimestamps : public testing::TestWithParam<TimestampSource> {};

TEST_P(SocketCanVmTimestamps, AreMonotonicAndOnTheMonotonicClock) {
  // Given a port using the kernel timestamp source under test and an echo peer on vcan0
  // When 50 round trips run, then a peer sends a burst of 200 frames
  // Then every answer's timestamp lies between the send and the receive, timestamps never go
  //      back, every burst frame is stamped inside the burst's window, and unix_offset() is
  //      realtime - monotonic
  SocketCanOptions options;
  options.timestamps = GetParam();
  auto bus = open_bus(kPlain, options);
  ASSERT_TRUE(bus);
  EXPECT_EQ(bus->timestamp_source(), GetParam());
  // Measurement error of the realtime -> monotonic conversion, and SO_TIMESTAMP's 1 us steps.
  const Duration slack = 20us;

  auto echo = start_peer("echo", {kPlain});
  ASSERT_TRUE(echo);
  TimePoint previous{};
  for (int i = 0; i < 50; ++i) {
    const TimePoint before = bus->now();
    ASSERT_FALSE(bus->send(Frame::standard(0x601, {static_cast<std::uint8_t>(i)})));
    const auto reply = bus->receive(before + 1s);
    const TimePoint after = bus->now();
    ASSERT_TRUE(reply) << "round trip " << i;
    EXPECT_GE(reply->timestamp + slack, before) << "round trip " << i;
    EXPECT_LE(reply->timestamp, after) << "round trip " << i;
    EXPECT_GT(reply->timestamp, previous) << "round trip " << i;
    previous = reply->timestamp;
  }
  quit(*bus, *echo);

  std::vector<std::string> args = {kPlain};
  for (int i = 0; i < 200; ++i)
    args.push_back(fmt::format("100#{:08X}", i));
  const TimePoint burst_start = bus->now();
  auto sender = start_peer("send", args);
  ASSERT_TRUE(sender);
  EXPECT_EQ(sender->wait(5s), 0);
  const auto burst = receive_all(*bus);
  const TimePoint burst_end = bus->now();
  ASSERT_EQ(burst.size(), 200u);
  for (std::size_t i = 0; i < burst.size(); ++i) {
    EXPECT_GE(burst[i].timestamp + slack, burst_start) << i;
    EXPECT_LE(burst[i].timestamp, burst_end) << i;
    if (i > 0) {
      EXPECT_GE(burst[i].timestamp, burst[i - 1].timestamp) << i;
    }
  }
  EXPECT_EQ(bus->stats().missing_timestamps, 0u);

  timespec real{};
  timespec mono{};
  ::clock_gettime(CLOCK_REALTIME, &real);
  ::clock_gettime(CLOCK_MONOTONIC, &mono);
  const Duration offset =
      std::chrono::seconds(real.tv_sec - mono.tv_sec) + Duration(real.tv_nsec - mono.tv_nsec);
  EXPECT_LT(std::chrono::abs(offset - bus->unix_offset()), 10ms);
}

INSTANTIATE_TEST_SUITE_P(Sources, SocketCanVmTimestamps,
                         testing::Values(TimestampSource::so_timestamping,
                                         TimestampSource::so_timestamp),
                         [](const testing::TestParamInfo<TimestampSource>& param_info) {
                           return param_info.param == TimestampSource::so_timestamping
                                      ? "SoTimestamping"
                                      : "SoTimestamp";
                         });

TEST(SocketCanVm, AutomaticTimestampsUseSoTimestamping) {
  // Given a port opened with the default options
  // When asked for its timestamp source
  // Then it is SO_TIMESTAMPING (Debian's kernel has it)
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  EXPECT_EQ(bus->timestamp_source(), TimestampSource::so_timestamping);
}

// ---- errors on open and send ----

TEST(SocketCanVm, OpenNamesMissingNonCanAndDownInterfaces) {
  // Given no vcan9, the loopback interface lo (not CAN) and vcan2 (down)
  // When ports are opened on them
  // Then the errors are no_such_interface, no_such_interface and interface_down, and the
  //      explanations name the interface
  const auto missing = SocketCanBus::open("vcan9");
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error(), BusError::no_such_interface);
  EXPECT_NE(describe_open_error("vcan9", missing.error()).find("vcan9: no CAN interface"),
            std::string::npos);
  const auto not_can = SocketCanBus::open("lo");
  ASSERT_FALSE(not_can);
  EXPECT_EQ(not_can.error(), BusError::no_such_interface);
  const auto down = SocketCanBus::open(kDown);
  ASSERT_FALSE(down);
  EXPECT_EQ(down.error(), BusError::interface_down);
  EXPECT_NE(describe_open_error(kDown, down.error()).find("ip link set vcan2 up"),
            std::string::npos);
}

TEST(SocketCanVm, InterfaceGoingDownIsReported) {
  // Given a port on vcan2 while it is up
  // When vcan2 is set down
  // Then a wait reports it through last_error(), and send() returns interface_down
  ASSERT_EQ(std::system("/sbin/ip link set dev vcan2 up"), 0);
  auto bus = open_bus(kDown);
  ASSERT_TRUE(bus);
  EXPECT_FALSE(bus->send(frame_of("123#01")));
  EXPECT_FALSE(bus->last_error());
  ASSERT_EQ(std::system("/sbin/ip link set dev vcan2 down"), 0);
  EXPECT_FALSE(bus->receive(bus->now() + 50ms));
  EXPECT_EQ(bus->last_error(), BusError::interface_down);
  EXPECT_EQ(bus->send(frame_of("123#02")), BusError::interface_down);
}

TEST(SocketCanVm, InvalidFramesAreRefusedBeforeTheKernel) {
  // Given an error frame and an 11-bit frame with id 800h
  // When sent
  // Then both are invalid_frame and nothing was sent
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  Frame too_big = Frame::standard(0x7FF, {});
  too_big.id = 0x800;
  EXPECT_EQ(bus->send(frame_of("20000040#0000000000000000")), BusError::invalid_frame);
  EXPECT_EQ(bus->send(too_big), BusError::invalid_frame);
  EXPECT_EQ(bus->stats().frames_sent, 0u);
}

// ---- full transmit queue (ENOBUFS) ----

std::vector<Frame> numbered_frames(int count) {
  std::vector<Frame> frames;
  for (int i = 0; i < count; ++i) {
    const auto n = static_cast<std::uint32_t>(i);
    // data: 32-bit sequence number, big-endian
    frames.push_back(Frame::standard(
        0x300, {static_cast<std::uint8_t>(n >> 24), static_cast<std::uint8_t>(n >> 16),
                static_cast<std::uint8_t>(n >> 8), static_cast<std::uint8_t>(n)}));
  }
  return frames;
}

TEST(SocketCanVm, FloodThroughAFullQueueArrivesCompleteAndInOrder) {
  // Given vcan1, whose queue (10 frames, drained at 1000 frames/s) fills like a controller's,
  //       and a counting peer
  // When 300 frames are sent as fast as send() returns
  // Then every send succeeds (retrying on ENOBUFS within the 100 ms send timeout), retries
  //      did happen, and the peer receives all 300 in order
  auto bus = open_bus(kThrottled);
  ASSERT_TRUE(bus);
  auto counter = start_peer("count", {kThrottled, "300", "1000"});
  ASSERT_TRUE(counter);
  for (const Frame& frame : numbered_frames(300)) {
    const auto error = bus->send(frame);
    ASSERT_FALSE(error) << to_candump(frame) << ": " << error.message();
  }
  EXPECT_GT(bus->stats().send_retries, 0u) << "the queue never filled: no ENOBUFS to handle";
  EXPECT_EQ(counter->wait(10s), 0);
  fmt::print("vcan1 flood: 300 frames, {} send retries\n", bus->stats().send_retries);
}

TEST(SocketCanVm, FloodOnPlainVcanArrivesComplete) {
  // Given vcan0 (txqueuelen 10) and a counting peer
  // When 200 frames are sent back to back
  // Then every send succeeds and the peer receives all 200 in order
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  auto counter = start_peer("count", {kPlain, "200", "1000"});
  ASSERT_TRUE(counter);
  for (const Frame& frame : numbered_frames(200)) {
    const auto error = bus->send(frame);
    ASSERT_FALSE(error) << to_candump(frame) << ": " << error.message();
  }
  EXPECT_EQ(counter->wait(10s), 0);
  fmt::print("vcan0 flood: 200 frames, {} send retries\n", bus->stats().send_retries);
}

TEST(SocketCanVm, QueueStillFullAfterTheSendTimeoutIsQueueFull) {
  // Given vcan3, whose 10-frame queue drains at 10 frames/s, and a send timeout of 20 ms
  // When frames are sent until one fails
  // Then at least 10 frames are accepted, the failure is queue_full, and it came after
  //      waiting the send timeout, not much longer
  SocketCanOptions options;
  options.send_timeout = 20ms;
  auto bus = open_bus(kSlow, options);
  ASSERT_TRUE(bus);
  int accepted = 0;
  std::error_code error;
  Duration failing_send{};
  for (const Frame& frame : numbered_frames(100)) {
    const TimePoint before = bus->now();
    error = bus->send(frame);
    if (error) {
      failing_send = bus->now() - before;
      break;
    }
    ++accepted;
  }
  EXPECT_EQ(error, BusError::queue_full) << error.message();
  EXPECT_GE(accepted, 10);
  EXPECT_GE(failing_send, 20ms);
  EXPECT_LT(failing_send, 200ms);
  fmt::print("vcan3: {} frames accepted, then queue_full after {} us\n", accepted,
             std::chrono::duration_cast<std::chrono::microseconds>(failing_send).count());
}

// ---- error frames ----

TEST(SocketCanVm, ErrorFramesAreDecodedAndBusOffBlocksSending) {
  // Given a port on vcan0 and a peer that injects a bus-off error frame
  // When it arrives
  // Then it is an error frame described as bus-off, and send() returns bus_off until a
  //      "restarted" error frame arrives
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  // class 0x040 bus-off, 8 zero bytes
  auto injector = start_peer("raw-send", {kPlain, "20000040#0000000000000000"});
  ASSERT_TRUE(injector);
  EXPECT_EQ(injector->wait(3s), 0);
  const auto bus_off = bus->receive(bus->now() + 1s);
  ASSERT_TRUE(bus_off);
  EXPECT_TRUE(bus_off->frame.is_error());
  EXPECT_EQ(describe_error_frame(bus_off->frame), "bus-off");
  EXPECT_TRUE(bus->bus_off());
  EXPECT_EQ(bus->send(frame_of("601#01")), BusError::bus_off);

  // class 0x100 restarted; then class 0x204 controller + counters: tx passive, tx 128, rx 5
  injector =
      start_peer("raw-send", {kPlain, "20000100#0000000000000000", "20000204#0020000000008005"});
  ASSERT_TRUE(injector);
  EXPECT_EQ(injector->wait(3s), 0);
  EXPECT_FALSE(bus->send(frame_of("601#02")));  // send() reads the restart first
  EXPECT_FALSE(bus->bus_off());
  const auto rest = receive_all(*bus);
  ASSERT_EQ(rest.size(), 2u);
  EXPECT_EQ(describe_error_frame(rest[0].frame), "controller restarted");
  EXPECT_EQ(describe_error_frame(rest[1].frame),
            "controller problem: transmit error passive; error counters: tx 128, rx 5");
  EXPECT_EQ(bus->stats().error_frames, 3u);
}

TEST(SocketCanVm, ErrorFramesFollowFiltersButBusOffIsAlwaysTracked) {
  // Given a port filtering 181h only, and one with error frames turned off
  // When a peer injects bus-off and sends 181h
  // Then neither port delivers the error frame, and both know they are bus-off
  SocketCanOptions filtered;
  filtered.filters = {Filter::standard(0x181)};
  auto a = open_bus(kPlain, filtered);
  SocketCanOptions quiet;
  quiet.error_frames = false;
  auto b = open_bus(kPlain, quiet);
  ASSERT_TRUE(a && b);
  auto injector = start_peer("raw-send", {kPlain, "20000040#0000000000000000", "181#01"});
  ASSERT_TRUE(injector);
  EXPECT_EQ(injector->wait(3s), 0);
  EXPECT_EQ(texts(receive_all(*a)), (std::vector<std::string>{"181#01"}));
  EXPECT_EQ(texts(receive_all(*b)), (std::vector<std::string>{"181#01"}));
  EXPECT_TRUE(a->bus_off());
  EXPECT_TRUE(b->bus_off());
}

// ---- event loop: timers, handlers, stop ----

TEST(SocketCanVm, TimersFireInOrderAndCancelledOnesDoNot) {
  // Given timers at +30, +10, +20 ms, one at +15 ms that is cancelled, and one in the past
  // When run_until(+50 ms)
  // Then the past one fires first, then 10, 20, 30, never before their time, and run_until
  //      returns no earlier than its deadline
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  const TimePoint t0 = bus->now();
  std::vector<int> order;
  bool early = false;
  const auto at = [&](Duration d, int tag) {
    return bus->start_timer(t0 + d, [&, d, tag] {
      early = early || bus->now() < t0 + d;
      order.push_back(tag);
    });
  };
  at(30ms, 30);
  at(10ms, 10);
  at(20ms, 20);
  const TimerId cancelled = at(15ms, 15);
  at(-5ms, 0);
  bus->cancel_timer(cancelled);
  bus->cancel_timer(9999);  // unknown: ignored
  bus->run_until(t0 + 50ms);
  EXPECT_GE(bus->now(), t0 + 50ms);
  EXPECT_EQ(order, (std::vector<int>{0, 10, 20, 30}));
  EXPECT_FALSE(early);
}

TEST(SocketCanVm, TimersRunWhileReceiving) {
  // Given an echo peer and a timer that sends a request after 20 ms
  // When receive() waits
  // Then the timer fires during the wait and receive() returns the answer
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  auto peer = start_peer("echo", {kPlain});
  ASSERT_TRUE(peer);
  const TimePoint t0 = bus->now();
  bus->start_timer_after(20ms, [&] { EXPECT_FALSE(bus->send(frame_of("601#AA"))); });
  const auto reply = bus->receive(t0 + 2s);
  ASSERT_TRUE(reply);
  EXPECT_EQ(to_candump(reply->frame), "602#AA");
  EXPECT_GE(bus->now(), t0 + 20ms);
  quit(*bus, *peer);
}

TEST(SocketCanVm, HandlerTakesFramesFromReceive) {
  // Given an echo peer and a frame handler that stops the loop after three answers
  // When three requests are sent and run_until waits (at most 2 s)
  // Then the handler gets the three answers, receive() gets nothing while the handler is set,
  //      and frames go to receive() again once the handler is cleared
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  auto peer = start_peer("echo", {kPlain});
  ASSERT_TRUE(peer);
  std::vector<std::string> handled;
  bus->set_frame_handler([&](const TimedFrame& timed) {
    handled.push_back(to_candump(timed.frame));
    if (handled.size() == 3) bus->stop();
  });
  for (const char* text : {"601#01", "601#02", "601#03"})
    ASSERT_FALSE(bus->send(frame_of(text)));
  const TimePoint t0 = bus->now();
  bus->run_until(t0 + 2s);
  EXPECT_LT(bus->now() - t0, 1s);
  EXPECT_EQ(handled, (std::vector<std::string>{"602#01", "602#02", "602#03"}));

  ASSERT_FALSE(bus->send(frame_of("601#04")));
  EXPECT_FALSE(bus->receive(bus->now() + 100ms));
  EXPECT_EQ(handled.size(), 4u);
  bus->set_frame_handler({});
  ASSERT_FALSE(bus->send(frame_of("601#05")));
  const auto reply = bus->receive(bus->now() + 1s);
  ASSERT_TRUE(reply);
  EXPECT_EQ(to_candump(reply->frame), "602#05");
  quit(*bus, *peer);
}

std::atomic<SocketCanBus*> g_stop_target{nullptr};

extern "C" void stop_on_signal(int) {
  if (SocketCanBus* bus = g_stop_target.load()) bus->stop();
}

// Arms SIGALRM (no SA_RESTART) to call stop() after `delay`.
void stop_after(SocketCanBus& bus, Duration delay) {
  g_stop_target = &bus;
  struct sigaction action {};
  action.sa_handler = stop_on_signal;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGALRM, &action, nullptr);
  itimerval timer{};
  timer.it_value.tv_usec = static_cast<suseconds_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(delay).count());
  ::setitimer(ITIMER_REAL, &timer, nullptr);
}

TEST(SocketCanVm, StopFromASignalHandlerEndsTheWait) {
  // Given a SIGALRM handler that calls stop() 50 ms from now
  // When run_until(+5 s), and then receive(forever), wait
  // Then each returns shortly after the signal; a stop() before run_until makes that call
  //      return at once and only that one
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);

  stop_after(*bus, 50ms);
  TimePoint t0 = bus->now();
  bus->run_until(t0 + 5s);
  EXPECT_GE(bus->now() - t0, 40ms);
  EXPECT_LT(bus->now() - t0, 1s);

  stop_after(*bus, 50ms);
  t0 = bus->now();
  EXPECT_FALSE(bus->receive(kForever));
  EXPECT_GE(bus->now() - t0, 40ms);
  EXPECT_LT(bus->now() - t0, 1s);
  g_stop_target = nullptr;

  bus->stop();
  t0 = bus->now();
  bus->run_until(t0 + 1s);
  EXPECT_LT(bus->now() - t0, 50ms);
  t0 = bus->now();
  bus->run_until(t0 + 100ms);
  EXPECT_GE(bus->now() - t0, 100ms);
}

TEST(SocketCanVm, StopFromAnotherThreadEndsABlockingWait) {
  // Given a port waiting with nothing due for 5 s (the blocking recvmsg() path)
  // When another thread calls stop() 100 ms later
  // Then receive() returns nothing within one receive slice (20 ms) of the stop, far before 5 s
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  const TimePoint t0 = bus->now();
  std::jthread stopper([&bus] {
    std::this_thread::sleep_for(100ms);
    bus->stop();
  });
  EXPECT_FALSE(bus->receive(t0 + 5s));
  EXPECT_GE(bus->now() - t0, 90ms);
  EXPECT_LT(bus->now() - t0, 500ms);
}

TEST(SocketCanVm, FrameEndsABlockingWaitAtOnce) {
  // Given a port waiting with nothing due for 5 s (the blocking recvmsg() path)
  // When the echo peer answers a frame
  // Then receive() returns the answer at once: the median round trip is far below one receive
  //      slice (20 ms), which every answer would take if the frame did not end the wait
  auto bus = open_bus(kPlain);
  ASSERT_TRUE(bus);
  auto peer = start_peer("echo", {kPlain});
  ASSERT_TRUE(peer);
  std::vector<Duration> round_trips;
  for (int i = 0; i < 21; ++i) {
    // ccs=2 upload request, index 1000h sub 0
    ASSERT_FALSE(bus->send(frame_of("601#4000100000000000")));
    const TimePoint sent = bus->now();
    const auto answer = bus->receive(sent + 5s);
    ASSERT_TRUE(answer);
    EXPECT_EQ(to_candump(answer->frame), "602#4000100000000000");
    round_trips.push_back(bus->now() - sent);
  }
  std::nth_element(round_trips.begin(), round_trips.begin() + 10, round_trips.end());
  EXPECT_LT(round_trips[10], 5ms);
  quit(*bus, *peer);
}

}  // namespace
}  // namespace drivecheck::can

int main(int argc, char** argv) {
  if (const int status = drivecheck::vm::run_peer_if_asked(argc, argv); status >= 0) return status;
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
