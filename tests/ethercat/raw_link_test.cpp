// The AF_PACKET link for real: a veth pair in a network namespace this test creates (we run as
// root in CI). Every wait is bounded by a deadline; the namespace (and with it the pair) is
// removed when the test ends, also on failure. When the namespace or the pair cannot be
// created the test is skipped with the reason, never passed.
#include "protocol/ethercat/raw_link.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <string>

#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"
#include "tests/ethercat/veth_pair.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

using test::VethPair;

Bytes frame_of(std::vector<Datagram> datagrams) {
  Frame frame;
  frame.source = {0x02, 0, 0, 0, 0, 1};
  frame.datagrams = std::move(datagrams);
  return *encode_frame(frame);
}

TEST_F(VethPair, OwnFramesAreNotReadBack) {
  // Given links on both ends of a veth pair
  // When end a sends one EtherCAT frame
  // Then end b receives it (padded to 60 bytes) and end a does not see its own frame
  auto master = RawLink::open(a_);
  auto peer = RawLink::open(b_);
  ASSERT_TRUE(master) << describe_open_error(a_, master.error());
  ASSERT_TRUE(peer) << describe_open_error(b_, peer.error());
  const Bytes sent = frame_of({Datagram::physical(Command::brd, 5, 0, 0x0130, {0, 0})});
  ASSERT_FALSE((*master)->send(sent));
  const auto got = (*peer)->receive((*peer)->now() + 2s);
  ASSERT_TRUE(got) << "the frame did not arrive at the other end within 2 s";
  EXPECT_EQ(got->bytes, sent);
  EXPECT_FALSE((*master)->receive((*master)->now() + 200ms));
  EXPECT_EQ((*master)->stats().frames_received, 0u);
}

TEST_F(VethPair, RoundTripThroughAnEscOnTheOtherEnd) {
  // Given an ESC behind end b (a minimal emulated slave: receive, process, send back)
  // When the master on end a sends 100 frames, each an APWR of the station address and an
  // FPRD of AL status
  // Then every frame comes back processed: WKC 1 and 1, AL status 0001h; the peer never
  // reads its own replies
  auto master = RawLink::open(a_);
  auto peer = RawLink::open(b_);
  ASSERT_TRUE(master && peer);
  Esc esc;
  for (int i = 0; i < 100; ++i) {
    ASSERT_FALSE((*master)->send(
        frame_of({Datagram::physical(Command::apwr, static_cast<std::uint8_t>(i), 0,
                                     reg::kStationAddress, {0x01, 0x10}),
                  Datagram::physical(Command::fprd, 0, 0x1001, reg::kAlStatus, {0, 0})})));
    auto request = (*peer)->receive((*peer)->now() + 2s);
    ASSERT_TRUE(request) << "frame " << i << " did not reach the peer";
    esc.process_frame(request->bytes, (*peer)->now());
    ASSERT_FALSE((*peer)->send(request->bytes));
    const auto reply = (*master)->receive((*master)->now() + 2s);
    ASSERT_TRUE(reply) << "frame " << i << " did not come back";
    const auto decoded = decode_frame(reply->bytes);
    ASSERT_TRUE(decoded) << decoded.error().message();
    EXPECT_EQ(decoded->datagrams[0].index, i);
    EXPECT_EQ(decoded->datagrams[0].working_counter, 1);
    EXPECT_EQ(decoded->datagrams[1].working_counter, 1);
    EXPECT_EQ(decoded->datagrams[1].data, (Bytes{0x01, 0x00}));
    EXPECT_EQ(reply->bytes[6] & 0x02, 0x02);  // processed by an ESC
  }
  EXPECT_EQ((*peer)->stats().frames_received, 100u);
}

TEST_F(VethPair, TimersAndHandlerRunInRunUntil) {
  // Given a handler on end b and a timer on end b that fires after 20 ms
  // When end a sends a frame and b runs for 200 ms
  // Then the handler got the frame and the timer fired, within the run
  auto master = RawLink::open(a_);
  auto peer = RawLink::open(b_);
  ASSERT_TRUE(master && peer);
  int frames = 0;
  bool fired = false;
  (*peer)->set_frame_handler([&](const TimedFrame&) { ++frames; });
  (*peer)->start_timer_after(20ms, [&] { fired = true; });
  const TimerId cancelled = (*peer)->start_timer_after(10ms, [&] { ADD_FAILURE(); });
  (*peer)->cancel_timer(cancelled);
  ASSERT_FALSE((*master)->send(frame_of({Datagram::physical(Command::brd, 0, 0, 0, {0})})));
  const TimePoint start = (*peer)->now();
  (*peer)->run_for(200ms);
  EXPECT_GE((*peer)->now() - start, 200ms);
  EXPECT_EQ(frames, 1);
  EXPECT_TRUE(fired);
}

TEST_F(VethPair, OpenSaysWhyItFails) {
  // Given no interface "dcenone0", an interface that is down, and an unprivileged process
  // When each is opened
  // Then the errors are no_such_interface, interface_down and permission_denied, and the
  // permission message names CAP_NET_RAW
  const auto none = RawLink::open("dcenone0");
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error(), LinkError::no_such_interface);
  const auto down = RawLink::open(c_);
  ASSERT_FALSE(down);
  EXPECT_EQ(down.error(), LinkError::interface_down);
  EXPECT_NE(describe_open_error(c_, down.error()).find("ip link set"), std::string::npos);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    // nobody: no CAP_NET_RAW left after setuid from root.
    if (::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(3);
    const auto denied = RawLink::open(a_);
    if (denied) ::_exit(4);
    if (denied.error() != LinkError::permission_denied) ::_exit(5);
    if (describe_open_error(a_, denied.error()).find("CAP_NET_RAW") == std::string::npos) {
      ::_exit(6);
    }
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "3: setuid failed, 4: opened without privileges, "
                                       "5: other error, 6: message lacks CAP_NET_RAW";
}

}  // namespace
}  // namespace drivecheck::ethercat
