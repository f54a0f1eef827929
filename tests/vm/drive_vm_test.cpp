// `drivecheck drive` as its own process on vcan0, exercised by this test process through its own
// socket, as a master and a drive meet on a real bus: SDO (expedited, segmented, block, both
// directions), NMT states in the heartbeat, a PDO, store/restore across a reset and a restart,
// and a clean stop on SIGTERM/SIGINT. Runs inside the test VM (tests/vm/run-in-vm, with
// --extra <drivecheck>); outside it, pass --drivecheck=PATH and have vcan0.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "protocol/can/socketcan_bus.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "tests/vm/drive_process.hpp"

namespace drivecheck::vm {
namespace {

using namespace std::chrono_literals;

constexpr const char* kInterface = "vcan0";
constexpr std::uint8_t kNode = 5;

std::string g_drivecheck = "drivecheck";
int g_run = 0;

std::string text(const can::Frame& frame) {
  return can::to_candump(frame);
}

class DriveVm : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = fmt::format("/tmp/drive-vm-{}-{}.txt", ::getpid(), ++g_run);
    std::remove(store_.c_str());
    auto opened = can::SocketCanBus::open(kInterface);
    ASSERT_TRUE(opened) << can::describe_open_error(kInterface, opened.error());
    bus_ = std::move(*opened);
    start_drive();
  }

  void TearDown() override {
    if (drive_) {
      EXPECT_EQ(drive_->stop(SIGTERM, 3000ms), 0) << "drivecheck drive did not stop cleanly";
    }
    std::remove(store_.c_str());
  }

  void start_drive() {
    std::string error;
    drive_ = DriveProcess::start(g_drivecheck,
                                 {"drive", "--bus", fmt::format("socketcan:{}", kInterface),
                                  "--node", std::to_string(kNode), "--store", store_},
                                 error);
    ASSERT_TRUE(drive_) << error;
    const auto boot = wait_for([](const can::Frame& f) { return text(f) == "705#00"; }, 5s);
    ASSERT_TRUE(boot) << "no boot-up message from drivecheck drive";
  }

  // The first frame that satisfies `match` within `timeout`.
  std::optional<can::TimedFrame> wait_for(const std::function<bool(const can::Frame&)>& match,
                                          can::Duration timeout) {
    const can::TimePoint deadline = bus_->now() + timeout;
    while (auto timed = bus_->receive(deadline)) {
      if (match(timed->frame)) return timed;
    }
    return std::nullopt;
  }

  // Every frame with identifier `id` during `duration`.
  std::vector<can::TimedFrame> collect(std::uint32_t id, can::Duration duration) {
    std::vector<can::TimedFrame> frames;
    const can::TimePoint deadline = bus_->now() + duration;
    while (auto timed = bus_->receive(deadline)) {
      if (timed->frame.id == id && !timed->frame.is_extended()) frames.push_back(*timed);
    }
    return frames;
  }

  void nmt(std::uint8_t command) {
    ASSERT_FALSE(bus_->send(can::Frame::standard(0x000, {command, kNode})));
  }

  cia301::SdoClient client(can::Duration timeout = 1s) {
    cia301::SdoClientOptions options;
    options.timeout = timeout;
    return cia301::SdoClient(*bus_, kNode, options);
  }

  std::unique_ptr<can::SocketCanBus> bus_;
  std::unique_ptr<DriveProcess> drive_;
  std::string store_;
};

TEST_F(DriveVm, SdoExpeditedSegmentedAndBlock) {
  // Given drivecheck drive at node 5 on vcan0
  // When this process uploads 1000h (expedited) and 1008h (segmented, block), and downloads
  //      1017h segmented and as a block
  // Then every transfer succeeds with the drive's values and the kind asked for
  auto sdo = client();
  const auto device_type = sdo.upload_value<std::uint32_t>({0x1000, 0});
  ASSERT_TRUE(device_type) << device_type.error().message();
  EXPECT_EQ(*device_type, 0x00020192u);
  EXPECT_EQ(sdo.last_transfer().kind(), cia301::SdoTransferKind::expedited);

  std::string name;
  for (const auto mode : {cia301::SdoTransferMode::segmented, cia301::SdoTransferMode::block}) {
    const auto bytes = sdo.upload({0x1008, 0}, mode);
    ASSERT_TRUE(bytes) << bytes.error().message();
    const std::string got(bytes->begin(), bytes->end());
    EXPECT_GT(got.size(), 7u);
    if (name.empty()) name = got;
    EXPECT_EQ(got, name);
  }
  EXPECT_EQ(sdo.last_transfer().kind(), cia301::SdoTransferKind::block);
  EXPECT_NE(name.find("drivecheck reference drive"), std::string::npos) << name;

  const std::uint8_t period[] = {0x2C, 0x01};  // 300 ms
  ASSERT_TRUE(sdo.download({0x1017, 0}, period, cia301::SdoTransferMode::segmented));
  EXPECT_EQ(sdo.last_transfer().kind(), cia301::SdoTransferKind::segmented);
  EXPECT_EQ(sdo.upload_value<std::uint16_t>({0x1017, 0}).value_or(0), 300);
  const std::uint8_t off[] = {0x00, 0x00};
  ASSERT_TRUE(sdo.download({0x1017, 0}, off, cia301::SdoTransferMode::block));
  EXPECT_EQ(sdo.last_transfer().kind(), cia301::SdoTransferKind::block);
  EXPECT_EQ(sdo.upload_value<std::uint16_t>({0x1017, 0}).value_or(1), 0);

  const auto missing = sdo.upload({0x5FFF, 0});  // no such object (manufacturer range)
  ASSERT_FALSE(missing);
  EXPECT_EQ(cia301::server_abort_code(missing.error()), 0x06020000u);
}

TEST_F(DriveVm, NmtStatesShowInTheHeartbeat) {
  // Given drivecheck drive with 1017h = 50 ms
  // When it is started, stopped, put in pre-operational and its communication reset
  // Then heartbeats come every ~50 ms carrying 7Fh, 05h, 04h, 7Fh; SDO is silent in Stopped;
  //      the reset sends a boot-up and restores 1017h's default (no more heartbeats)
  auto sdo = client();
  ASSERT_TRUE(sdo.download_value<std::uint16_t>({0x1017, 0}, 50));
  const auto pre = collect(0x705, 400ms);
  ASSERT_GE(pre.size(), 5u);
  for (const auto& hb : pre)
    EXPECT_EQ(text(hb.frame), "705#7F");
  for (std::size_t i = 1; i < pre.size(); ++i) {
    const auto gap = pre[i].timestamp - pre[i - 1].timestamp;
    EXPECT_GT(gap, 35ms);
    EXPECT_LT(gap, 80ms);
  }

  const std::pair<std::uint8_t, const char*> transitions[] = {
      {0x01, "705#05"}, {0x02, "705#04"}, {0x80, "705#7F"}};
  for (const auto& [command, heartbeat] : transitions) {
    nmt(command);
    collect(0x705, 60ms);  // a heartbeat that may still carry the old state
    const auto next = wait_for([](const can::Frame& f) { return f.id == 0x705; }, 200ms);
    ASSERT_TRUE(next);
    EXPECT_EQ(text(next->frame), heartbeat);
    if (command == 0x02) {
      auto quick = client(100ms);
      const auto silent = quick.upload({0x1000, 0});
      EXPECT_FALSE(silent) << "SDO must not be served in Stopped";
    }
  }

  nmt(0x82);  // reset communication
  ASSERT_TRUE(wait_for([](const can::Frame& f) { return text(f) == "705#00"; }, 1s));
  EXPECT_EQ(collect(0x705, 200ms).size(), 0u) << "1017h is back to its default 0";
}

TEST_F(DriveVm, TpdoOnSync) {
  // Given TPDO1 mapped to 1001h (error register), synchronous every SYNC, valid on 185h
  // When the drive is started and this process sends SYNCs
  // Then TPDO1 185#00 answers each SYNC
  auto sdo = client();
  ASSERT_TRUE(sdo.download_value<std::uint8_t>({0x1A00, 0}, 0));
  ASSERT_TRUE(sdo.download_value<std::uint32_t>({0x1A00, 1}, 0x10010008));
  ASSERT_TRUE(sdo.download_value<std::uint8_t>({0x1A00, 0}, 1));
  ASSERT_TRUE(sdo.download_value<std::uint8_t>({0x1800, 2}, 1));
  ASSERT_TRUE(sdo.download_value<std::uint32_t>({0x1800, 1}, 0x185));
  nmt(0x01);
  for (int i = 0; i < 3; ++i) {
    ASSERT_FALSE(bus_->send(can::Frame::standard(0x080, {})));
    const auto tpdo = wait_for([](const can::Frame& f) { return f.id == 0x185; }, 200ms);
    ASSERT_TRUE(tpdo) << "no TPDO after SYNC " << i;
    EXPECT_EQ(text(tpdo->frame), "185#00");
  }
}

TEST_F(DriveVm, StoredParametersSurviveResetAndRestart) {
  // Given 1017h = 70 saved with 1010h:01 ("save") into the --store file
  // When the node is reset, and then the process is restarted on the same file
  // Then 1017h reads 70 both times, and the file holds the entry
  auto sdo = client();
  ASSERT_TRUE(sdo.download_value<std::uint16_t>({0x1017, 0}, 70));
  ASSERT_TRUE(sdo.download_value<std::uint32_t>({0x1010, 1}, 0x65766173));
  ASSERT_TRUE(sdo.download_value<std::uint16_t>({0x1017, 0}, 0));
  nmt(0x81);  // reset node
  ASSERT_TRUE(wait_for([](const can::Frame& f) { return text(f) == "705#00"; }, 1s));
  EXPECT_EQ(client().upload_value<std::uint16_t>({0x1017, 0}).value_or(0), 70);

  std::ifstream file(store_);
  std::stringstream content;
  content << file.rdbuf();
  EXPECT_NE(content.str().find("1017:00 4600"), std::string::npos) << content.str();

  EXPECT_EQ(drive_->stop(SIGTERM, 3000ms), 0);
  start_drive();
  EXPECT_EQ(client().upload_value<std::uint16_t>({0x1017, 0}).value_or(0), 70);
}

TEST_F(DriveVm, SigintStopsTheDriveCleanly) {
  // Given drivecheck drive serving vcan0
  // When it gets SIGINT (Ctrl-C)
  // Then it exits 0 at once and sends nothing more
  EXPECT_EQ(drive_->stop(SIGINT, 2000ms), 0);
  drive_.reset();
  EXPECT_FALSE(client(100ms).upload({0x1000, 0})) << "nobody answers any more";
}

}  // namespace
}  // namespace drivecheck::vm

int main(int argc, char** argv) {
  drivecheck::vm::g_drivecheck = drivecheck::vm::take_drivecheck_path(argc, argv);
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
