// Several reference drives on one simulated bus: boot-ups, interleaved heartbeats, SDO to each
// node, NMT broadcast, and one drive consuming another's heartbeat.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "reference_drive/device.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;

struct Network {
  can::SimBus bus{can::SimBusConfig{.bitrate = 500'000}};
  std::vector<std::unique_ptr<can::SimPort>> ports;
  std::vector<std::unique_ptr<ReferenceDrive>> drives;
  std::unique_ptr<can::SimPort> master = bus.attach("master");
  std::vector<can::TimedFrame> seen;
  can::MonitorId monitor =
      bus.add_monitor([this](const can::TimedFrame& frame) { seen.push_back(frame); });

  // Drives at `nodes`, heartbeat period (1017h default) `heartbeat_ms[i]`, serial = node.
  Network(const std::vector<std::uint8_t>& nodes, const std::vector<std::uint16_t>& heartbeat_ms) {
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      ports.push_back(bus.attach(fmt::format("drive{}", nodes[i])));
      DriveConfig config;
      config.dictionary.node_id = nodes[i];
      config.dictionary.identity.serial = nodes[i];
      config.dictionary.producer_heartbeat_ms = heartbeat_ms[i];
      auto drive = ReferenceDrive::create(*ports.back(), config);
      EXPECT_TRUE(drive) << drive.error();
      drives.push_back(std::move(*drive));
    }
    for (auto& drive : drives)
      drive->power_on();
  }
  ~Network() {
    bus.remove_monitor(monitor);
    drives.clear();
  }

  void nmt(std::uint8_t command, std::uint8_t node) {
    EXPECT_FALSE(master->send(can::Frame::standard(0x000, {command, node})));
  }
};

TEST(DriveNetwork, ThreeDrivesBootAndInterleaveHeartbeats) {
  // Given drives at nodes 1, 2, 3 with heartbeats of 100, 150 and 200 ms on one 500 kbit/s bus
  // When the bus runs for 1.25 s
  // Then each boots once and sends heartbeats at its own period, exactly, interleaved
  Network net({1, 2, 3}, {100, 150, 200});
  net.bus.run_for(1250ms);
  std::map<std::uint32_t, std::vector<can::TimePoint>> heartbeats;
  std::map<std::uint32_t, int> boot_ups;
  for (const auto& timed : net.seen) {
    ASSERT_GE(timed.frame.id, 0x701u);
    ASSERT_LE(timed.frame.id, 0x703u);
    if (timed.frame.data[0] == 0x00) {
      ++boot_ups[timed.frame.id];
    } else {
      EXPECT_EQ(timed.frame.data[0], 0x7F) << "pre-operational";
      heartbeats[timed.frame.id].push_back(timed.timestamp);
    }
  }
  EXPECT_EQ(boot_ups, (std::map<std::uint32_t, int>{{0x701, 1}, {0x702, 1}, {0x703, 1}}));
  EXPECT_EQ(heartbeats[0x701].size(), 12u);
  EXPECT_EQ(heartbeats[0x702].size(), 8u);
  EXPECT_EQ(heartbeats[0x703].size(), 6u);
  const std::map<std::uint32_t, can::Duration> periods = {
      {0x701, 100ms}, {0x702, 150ms}, {0x703, 200ms}};
  for (const auto& [id, times] : heartbeats) {
    for (std::size_t i = 1; i < times.size(); ++i) {
      // Arbitration may delay one by a frame time (about 0.1 ms at 500 kbit/s).
      using Micros = std::chrono::duration<double, std::micro>;
      const double period = Micros(times[i] - times[i - 1]).count();
      const double expected = Micros(periods.at(id)).count();
      EXPECT_NEAR(period, expected, 300.0) << fmt::format("{:03X}h heartbeat {}", id, i);
    }
  }
}

TEST(DriveNetwork, SdoToEachNode) {
  // Given three drives on one bus
  // When a master uploads each one's serial number (expedited) and device name (segmented,
  //      block) and downloads a heartbeat time to each
  // Then every node answers for itself
  Network net({10, 11, 12}, {0, 0, 0});
  net.bus.run_for(10ms);
  for (const std::uint8_t node : {10, 11, 12}) {
    cia301::SdoClient client(*net.master, node);
    const auto serial = client.upload_value<std::uint32_t>({0x1018, 4});
    ASSERT_TRUE(serial) << serial.error().message();
    EXPECT_EQ(*serial, node);
    const auto name = client.upload({0x1008, 0}, cia301::SdoTransferMode::block);
    ASSERT_TRUE(name) << name.error().message();
    EXPECT_EQ(std::string(name->begin(), name->end()), Identity{}.device_name);
    EXPECT_TRUE(
        client.download_value<std::uint16_t>({0x1017, 0}, static_cast<std::uint16_t>(100 + node)));
  }
  for (auto& drive : net.drives) {
    EXPECT_EQ(drive->dictionary().find(0x1017, 0)->as_unsigned(), 100u + drive->node_id());
  }
}

TEST(DriveNetwork, NmtBroadcastAndHeartbeatConsumerAcrossDrives) {
  // Given drives 1, 2, 3 with 50 ms heartbeats; drive 1 consumes drive 2's heartbeat (150 ms)
  // When all are started by a broadcast, then drive 2's heartbeat is switched off
  // Then all report Operational, and drive 1 sends EMCY 8130h and falls back to Pre-operational
  //      (1029h default) about 150 ms after drive 2's last heartbeat
  Network net({1, 2, 3}, {50, 50, 50});
  net.bus.run_for(10ms);
  cia301::SdoClient client(*net.master, 1);
  // 1016h:01 = node 2, 150 ms
  ASSERT_TRUE(client.download_value<std::uint32_t>({0x1016, 1}, 0x00020096));
  net.nmt(0x01, 0);  // start remote node, all nodes
  net.bus.run_for(100ms);
  for (auto& drive : net.drives)
    EXPECT_EQ(drive->state(), cia301::NmtState::operational);

  cia301::SdoClient client2(*net.master, 2);
  ASSERT_TRUE(client2.download_value<std::uint16_t>({0x1017, 0}, 0));
  net.seen.clear();
  net.bus.run_for(300ms);
  bool emcy = false;
  for (const auto& timed : net.seen) {
    if (timed.frame.id == 0x081) {
      EXPECT_EQ(can::to_candump(timed.frame), "081#3081110000000000");  // 8130h, reg 11h
      emcy = true;
    }
    EXPECT_NE(timed.frame.id, 0x702u) << "drive 2 stopped its heartbeat";
  }
  EXPECT_TRUE(emcy);
  EXPECT_EQ(net.drives[0]->state(), cia301::NmtState::pre_operational);
  EXPECT_EQ(net.drives[2]->state(), cia301::NmtState::operational);
}

}  // namespace
}  // namespace drivecheck::reference_drive
