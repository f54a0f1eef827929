// A network namespace with a veth pair for the AF_PACKET tests (raw_link_test.cpp,
// master_raw_link_test.cpp). Every wait is bounded; the namespace (and with it the pair) is
// removed when the test ends, also on failure. When the namespace or the pair cannot be created
// the test is skipped with the reason, never passed.
#pragma once

#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <net/if.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

namespace drivecheck::ethercat::test {

inline int run(const std::string& command) {
  return std::system((command + " >/dev/null 2>&1").c_str());
}

inline bool running(const std::string& interface) {
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
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    while (!(running(a_) && running(b_)) && std::chrono::steady_clock::now() < give_up) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
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

}  // namespace drivecheck::ethercat::test
