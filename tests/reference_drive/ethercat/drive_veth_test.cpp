// `drivecheck drive --bus ethercat:IF` for real: a veth pair in a network namespace this test
// creates (we run as root in CI); the drive serves one end, the test is the master on the other
// with raw datagrams and CoE SDO. Every wait is bounded; the drive process is stopped by its
// pid (SIGTERM: exit 0 expected) and the namespace removed, also on failure. When the namespace
// or the pair cannot be created the test is skipped with the reason, never passed.
#include <fcntl.h>
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <net/if.h>
#include <sched.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "protocol/ethercat/coe_sdo_client.hpp"
#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/mailbox.hpp"
#include "protocol/ethercat/raw_link.hpp"
#include "reference_drive/ethercat/sii_image.hpp"
#include "tests/ethercat/veth_pair.hpp"

namespace drivecheck::reference_drive::ethercat {
namespace {

namespace ecat = drivecheck::ethercat;
using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

// The namespace with its veth pair (a <-> b) is tests/ethercat/veth_pair.hpp's.
class DriveOnVeth : public drivecheck::ethercat::test::VethPair {
 protected:
  void TearDown() override {
    stop_drive();
    VethPair::TearDown();
  }

  // Starts `drivecheck drive --bus ethercat:<b> --node 1` (in this namespace: fork inherits it).
  void start_drive() {
    drive_pid_ = ::fork();
    ASSERT_GE(drive_pid_, 0);
    if (drive_pid_ == 0) {
      const std::string bus = "ethercat:" + b_;
      ::execl(DRIVECHECK_BINARY, DRIVECHECK_BINARY, "drive", "--bus", bus.c_str(), "--node", "1",
              static_cast<char*>(nullptr));
      ::_exit(127);
    }
  }
  // SIGTERM to the drive's pid; its exit status (nullopt: it had to be killed).
  std::optional<int> stop_drive() {
    if (drive_pid_ <= 0) return std::nullopt;
    ::kill(drive_pid_, SIGTERM);
    int status = 0;
    for (int i = 0; i < 300; ++i) {
      if (::waitpid(drive_pid_, &status, WNOHANG) == drive_pid_) {
        drive_pid_ = -1;
        return WIFEXITED(status) ? std::optional<int>(WEXITSTATUS(status)) : std::nullopt;
      }
      std::this_thread::sleep_for(10ms);
    }
    ::kill(drive_pid_, SIGKILL);
    ::waitpid(drive_pid_, &status, 0);
    drive_pid_ = -1;
    return std::nullopt;
  }

  pid_t drive_pid_ = -1;
};

// One datagram per frame; nullopt when nothing comes back within 500 ms.
std::optional<ecat::Datagram> exchange(ecat::Link& link, ecat::Datagram datagram) {
  ecat::Frame frame;
  frame.source = {0x02, 0, 0, 0, 0, 1};
  frame.datagrams = {std::move(datagram)};
  if (link.send(*ecat::encode_frame(frame))) return std::nullopt;
  const auto back = link.receive(link.now() + 500ms);
  if (!back) return std::nullopt;
  auto decoded = ecat::decode_frame(back->bytes);
  if (!decoded || decoded->datagrams.empty()) return std::nullopt;
  return decoded->datagrams.front();
}

TEST_F(DriveOnVeth, PreopAndSdoUploadOfDeviceType) {
  // Given `drivecheck drive --bus ethercat:<b>` serving one end of a veth pair
  // When the master on the other end reads AL status, configures the mailboxes, requests
  //      PREOP and uploads 1000h over CoE
  // Then INIT, PREOP without error code, 1000h = 00020192h; SIGTERM ends the drive with exit 0
  start_drive();
  auto link = ecat::RawLink::open(a_);
  ASSERT_TRUE(link) << ecat::describe_open_error(a_, link.error());
  std::optional<ecat::Datagram> status;
  for (int i = 0; i < 100 && !status; ++i) {  // the drive needs a moment to open its end
    status = exchange(**link, ecat::Datagram::physical(ecat::Command::aprd, 0, 0,
                                                       ecat::reg::kAlStatus, Bytes(2)));
  }
  ASSERT_TRUE(status) << "the drive did not answer within 50 s";
  EXPECT_EQ(status->working_counter, 1);
  EXPECT_EQ(status->data.at(0), 0x01) << "INIT";

  Bytes sms = ecat::sync_manager_block(kMailboxOutStart, kMailboxSize, kSm0Control);
  const Bytes sm1 = ecat::sync_manager_block(kMailboxInStart, kMailboxSize, kSm1Control);
  sms.insert(sms.end(), sm1.begin(), sm1.end());
  ASSERT_TRUE(exchange(
      **link, ecat::Datagram::physical(ecat::Command::apwr, 0, 0, ecat::reg::kSyncManager, sms)));
  ASSERT_TRUE(exchange(**link, ecat::Datagram::physical(ecat::Command::apwr, 0, 0,
                                                        ecat::reg::kAlControl, {0x02, 0x00})));
  const auto al = exchange(
      **link, ecat::Datagram::physical(ecat::Command::aprd, 0, 0, ecat::reg::kAlStatus, Bytes(6)));
  ASSERT_TRUE(al);
  EXPECT_EQ(al->data.at(0), 0x02) << "PREOP";
  EXPECT_EQ(al->data.at(4), 0x00) << "AL status code";

  ecat::MailboxMaster mailbox({.write_size = kMailboxSize, .address = 0, .reply_timeout = 1s});
  ecat::CoeSdoClient client({.write_size = kMailboxSize, .expedited = true});
  const Bytes request = mailbox.request(ecat::MailboxType::coe, client.start_upload({0x1000, 0}),
                                        (*link)->now().time_since_epoch());
  ASSERT_TRUE(exchange(
      **link, ecat::Datagram::physical(ecat::Command::apwr, 0, 0, kMailboxOutStart, request)));
  std::optional<Bytes> reply;
  for (int i = 0; i < 100 && !reply; ++i) {
    const auto sm =
        exchange(**link, ecat::Datagram::physical(ecat::Command::aprd, 0, 0,
                                                  ecat::reg::sync_manager(1) + 5, Bytes(1)));
    if (sm && (sm->data.at(0) & ecat::sm::kStatusMailboxFull) != 0) {
      const auto buffer =
          exchange(**link, ecat::Datagram::physical(ecat::Command::aprd, 0, 0, kMailboxInStart,
                                                    Bytes(kMailboxSize)));
      if (buffer) reply = buffer->data;
    }
  }
  ASSERT_TRUE(reply) << "no CoE reply in SM1";
  auto accepted = mailbox.accept(*reply);
  ASSERT_TRUE(accepted);
  const auto step = client.on_response(accepted->message.data);
  ASSERT_TRUE(step.done);
  ASSERT_FALSE(step.error) << step.error->code;
  const Bytes& value = client.value();
  ASSERT_EQ(value.size(), 4u);
  EXPECT_EQ(value, (Bytes{0x92, 0x01, 0x02, 0x00}));
  EXPECT_EQ(stop_drive(), std::optional<int>(0));
}

}  // namespace
}  // namespace drivecheck::reference_drive::ethercat
