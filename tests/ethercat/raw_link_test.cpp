// The AF_PACKET link for real: a veth pair in a network namespace this test creates (we run as
// root in CI). Every wait is bounded by a deadline; the namespace (and with it the pair) is
// removed when the test ends, also on failure. When the namespace or the pair cannot be
// created the test is skipped with the reason, never passed.
#include "protocol/ethercat/raw_link.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <net/if.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

int run(const std::string& command) {
  return std::system((command + " >/dev/null 2>&1").c_str());
}

bool running(const std::string& interface) {
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return false;
  ifreq request{};
  std::strncpy(request.ifr_name, interface.c_str(), IFNAMSIZ - 1);
  const bool up = ::ioctl(fd, SIOCGIFFLAGS, &request) == 0 && (request.ifr_flags & IFF_RUNNING);
  ::close(fd);
  return up;
}

// A network namespace with a veth pair a <-> b (both up) and a third interface c (down); the
// test thread enters the namespace, so sockets it opens live there.
class VethPair : public ::testing::Test {
 protected:
  void SetUp() override {
    const int pid = static_cast<int>(::getpid());
    ns_ = fmt::format("dcecat{}", pid);
    a_ = fmt::format("dcea{}", pid % 100000);
    b_ = fmt::format("dceb{}", pid % 100000);
    c_ = fmt::format("dcec{}", pid % 100000);
    if (run("ip netns add " + ns_) != 0) {
      GTEST_SKIP() << "cannot create a network namespace (ip netns add " << ns_
                   << " failed: not root, or no netns support)";
    }
    created_ = true;
    if (run(fmt::format("ip -n {} link add {} type veth peer name {}", ns_, a_, b_)) != 0 ||
        run(fmt::format("ip -n {} link add {} type veth peer name {}x", ns_, c_, c_)) != 0 ||
        run(fmt::format("ip -n {} link set {} up", ns_, a_)) != 0 ||
        run(fmt::format("ip -n {} link set {} up", ns_, b_)) != 0) {
      GTEST_SKIP() << "cannot create a veth pair in namespace " << ns_ << " (no veth support?)";
    }
    original_ = ::open("/proc/self/ns/net", O_RDONLY | O_CLOEXEC);
    const int target = ::open(("/var/run/netns/" + ns_).c_str(), O_RDONLY | O_CLOEXEC);
    ASSERT_GE(original_, 0);
    ASSERT_GE(target, 0);
    ASSERT_EQ(::setns(target, CLONE_NEWNET), 0) << std::strerror(errno);
    ::close(target);
    entered_ = true;
    const auto give_up = std::chrono::steady_clock::now() + 3s;
    while (!(running(a_) && running(b_)) && std::chrono::steady_clock::now() < give_up) {
      std::this_thread::sleep_for(5ms);
    }
    ASSERT_TRUE(running(a_) && running(b_)) << "veth pair did not come up within 3 s";
  }

  void TearDown() override {
    if (entered_) {
      EXPECT_EQ(::setns(original_, CLONE_NEWNET), 0);
    }
    if (original_ >= 0) ::close(original_);
    if (created_) run("ip netns del " + ns_);
  }

  std::string ns_, a_, b_, c_;
  int original_ = -1;
  bool created_ = false;
  bool entered_ = false;
};

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
