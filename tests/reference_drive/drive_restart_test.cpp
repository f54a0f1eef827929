// ReferenceDrive::restart: a drive restarted on a new bus behaves exactly as a drive created on
// it, whatever it did before (the fuzz targets run thousands of inputs on one drive this way).
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "protocol/can/frame.hpp"
#include "protocol/can/sim_bus.hpp"
#include "reference_drive/device.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;

constexpr std::uint8_t kNode = 5;

struct Step {
  can::Frame frame;  // sent by the tester (when send is true)
  bool send = true;
  can::Duration run{0};  // then the bus runs this long
};

Step send(const can::Frame& frame, can::Duration run = 2ms) {
  return {frame, true, run};
}
Step wait(can::Duration run) {
  return {can::Frame{}, false, run};
}

// One input: what a fuzz target or a test case does to a drive after power on.
using Script = std::vector<Step>;

// A: start, heartbeat 10 ms, TPDO1 disabled.
Script script_a() {
  return {
      // NMT start remote node, node 5
      send(can::Frame::standard(0x000, {0x01, kNode})),
      // SDO download expedited 2 bytes (2Bh), 1017h sub 0 = 000Ah (10 ms)
      send(can::Frame::standard(0x605, {0x2B, 0x17, 0x10, 0x00, 0x0A, 0x00, 0x00, 0x00}), 35ms),
      // SDO download expedited 4 bytes (23h), 1800h sub 1 = 80000185h (TPDO1 not valid)
      send(can::Frame::standard(0x605, {0x23, 0x00, 0x18, 0x01, 0x85, 0x01, 0x00, 0x80}), 20ms),
  };
}

// B: heartbeat 20 ms stored (1010h), then reset node: the stored value comes back.
Script script_b() {
  return {
      // SDO download 2 bytes, 1017h sub 0 = 0014h (20 ms)
      send(can::Frame::standard(0x605, {0x2B, 0x17, 0x10, 0x00, 0x14, 0x00, 0x00, 0x00})),
      // SDO download 4 bytes, 1010h sub 1 = "save" (65766173h): store all parameters
      send(can::Frame::standard(0x605, {0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65})),
      // NMT reset node, node 5
      send(can::Frame::standard(0x000, {0x81, kNode}), 70ms),
      // SDO download 4 bytes, 1016h sub 1 = 00060064h (node 6 every 100 ms)
      send(can::Frame::standard(0x605, {0x23, 0x16, 0x10, 0x01, 0x64, 0x00, 0x06, 0x00}), 250ms),
  };
}

// C: reset node to all, read 1017h, a SYNC and a guarding request.
Script script_c() {
  return {
      // NMT reset node, all nodes
      send(can::Frame::standard(0x000, {0x81, 0x00}), 100ms),
      // SDO initiate upload (40h), 1017h sub 0
      send(can::Frame::standard(0x605, {0x40, 0x17, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00})),
      // SYNC without counter
      send(can::Frame::standard(0x080, {})),
      // node guarding RTR, 705h, DLC 1
      send(can::Frame::remote(0x705, 1)),
      wait(50ms),
  };
}

// D: started, a SYNC producer every 1 ms, guarding, a segmented SDO upload left open, TPDO1 on
// every SYNC: the input ends with frames queued, timers pending and a transfer open.
Script script_d() {
  return {
      // NMT start remote node, node 5
      send(can::Frame::standard(0x000, {0x01, kNode})),
      // SDO download 1 byte (2Fh), 1800h sub 2 = 01h (TPDO1 at every SYNC)
      send(can::Frame::standard(0x605, {0x2F, 0x00, 0x18, 0x02, 0x01, 0x00, 0x00, 0x00})),
      // SDO download 4 bytes, 1006h sub 0 = 000003E8h (communication cycle period 1000 us)
      send(can::Frame::standard(0x605, {0x23, 0x06, 0x10, 0x00, 0xE8, 0x03, 0x00, 0x00})),
      // SDO download 4 bytes, 1005h sub 0 = 40000080h (this device produces SYNC on 080h)
      send(can::Frame::standard(0x605, {0x23, 0x05, 0x10, 0x00, 0x80, 0x00, 0x00, 0x40})),
      // node guarding RTR, 705h, DLC 1 (guarding answers)
      send(can::Frame::remote(0x705, 1), std::chrono::microseconds{345'678}),
      // SDO initiate upload (40h), 1008h sub 0 (device name: segmented), never continued
      send(can::Frame::standard(0x605, {0x40, 0x08, 0x10, 0x00, 0x00, 0x00, 0x00, 0x00}),
           std::chrono::microseconds{1'234}),
  };
}

// What a script did: every frame on the bus with its time since the bus started, and every
// entry's value at the end.
struct Outcome {
  std::vector<std::string> frames;
  std::vector<std::string> values;
  friend bool operator==(const Outcome&, const Outcome&) = default;
};

class Rig {
 public:
  Rig() : drive_port_(bus_.attach("drive")), tester_(bus_.attach("tester")) {
    bus_.add_monitor([this](const can::TimedFrame& seen) {
      outcome_.frames.push_back(
          fmt::format("{} {}", seen.timestamp.time_since_epoch().count(), seen.frame));
    });
  }

  can::SimPort& drive_port() { return *drive_port_; }
  // The bus as new (SimBus::reset), the outcome forgotten.
  bool reset() {
    outcome_ = {};
    return bus_.reset();
  }

  Outcome run(ReferenceDrive& drive, const Script& script) {
    drive.power_on();
    bus_.run_for(1ms);
    for (const Step& step : script) {
      if (step.send) {
        EXPECT_FALSE(tester_->send(step.frame));
      }
      bus_.run_for(step.run);
    }
    for (const cia301::Object& object : drive.dictionary().objects()) {
      for (const cia301::Entry& entry : object.entries()) {
        outcome_.values.push_back(fmt::format("{:04X}h.{} {:02X}", object.index(),
                                              entry.sub_index(), fmt::join(entry.bytes(), "")));
      }
    }
    return outcome_;
  }

 private:
  can::SimBus bus_{can::SimBusConfig{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> drive_port_;
  std::unique_ptr<can::SimPort> tester_;
  Outcome outcome_;
};

DriveConfig config() {
  DriveConfig out;
  out.dictionary.node_id = kNode;
  return out;
}

Outcome on_new_drive(const Script& script) {
  Rig rig;
  auto drive = ReferenceDrive::create(rig.drive_port(), config());
  EXPECT_TRUE(drive.has_value());
  return rig.run(**drive, script);
}

// The scripts in `order` on one drive, restarted on a new bus before each; with `release`, the
// drive leaves each bus (release_bus) before that bus is destroyed, else it leaves it in
// restart().
std::vector<Outcome> on_restarted_drive(const std::vector<const Script*>& order, bool release) {
  std::vector<Outcome> outcomes;
  std::unique_ptr<Rig> rig = std::make_unique<Rig>();
  auto created = ReferenceDrive::create(rig->drive_port(), config());
  EXPECT_TRUE(created.has_value());
  std::unique_ptr<ReferenceDrive> drive = std::move(*created);
  for (const Script* script : order) {
    if (release) {
      drive->release_bus();
      rig = std::make_unique<Rig>();
      EXPECT_TRUE(drive->restart(rig->drive_port()).has_value());
    } else {
      auto next = std::make_unique<Rig>();
      EXPECT_TRUE(drive->restart(next->drive_port()).has_value());
      rig = std::move(next);  // the old bus goes once the drive left it
    }
    outcomes.push_back(rig->run(*drive, *script));
  }
  drive.reset();
  return outcomes;
}

TEST(DriveRestart, BehavesAsANewDriveInEitherOrder) {
  // Given three scripts that change the NMT state, the heartbeat, a PDO, stored parameters and
  // the consumer heartbeat, each run once on a newly created drive
  const Script a = script_a();
  const Script b = script_b();
  const Script c = script_c();
  const Outcome fresh_a = on_new_drive(a);
  const Outcome fresh_b = on_new_drive(b);
  const Outcome fresh_c = on_new_drive(c);
  ASSERT_NE(fresh_a, fresh_b);  // the scripts do differ
  ASSERT_NE(fresh_b, fresh_c);
  // When they run on one drive restarted before each, in the order A B C and in C B A
  const std::vector<Outcome> forward = on_restarted_drive({&a, &b, &c}, false);
  const std::vector<Outcome> backward = on_restarted_drive({&c, &b, &a}, true);
  // Then every script gives the same frames at the same times and the same dictionary
  ASSERT_EQ(forward.size(), 3u);
  ASSERT_EQ(backward.size(), 3u);
  EXPECT_EQ(forward[0], fresh_a);
  EXPECT_EQ(forward[1], fresh_b);
  EXPECT_EQ(forward[2], fresh_c);
  EXPECT_EQ(backward[0], fresh_c);
  EXPECT_EQ(backward[1], fresh_b);
  EXPECT_EQ(backward[2], fresh_a);
}

// The scripts in `order` on one drive and one bus: before each, the drive leaves the bus, the
// bus is reset (SimBus::reset) and the drive restarts on it.
std::vector<Outcome> on_reset_bus(const std::vector<const Script*>& order) {
  std::vector<Outcome> outcomes;
  Rig rig;
  auto created = ReferenceDrive::create(rig.drive_port(), config());
  EXPECT_TRUE(created.has_value());
  std::unique_ptr<ReferenceDrive> drive = std::move(*created);
  for (const Script* script : order) {
    drive->release_bus();
    EXPECT_TRUE(rig.reset());
    EXPECT_TRUE(drive->restart(rig.drive_port()).has_value());
    outcomes.push_back(rig.run(*drive, *script));
  }
  return outcomes;
}

TEST(DriveRestart, OnAResetBusBehavesAsANewDriveOnANewBusInEitherOrder) {
  // Given four scripts, one of which (D) ends with SYNC produced every 1 ms, TPDOs, guarding,
  // an open SDO transfer, frames queued and timers pending, each run on a new drive and bus
  const std::vector<Script> scripts{script_a(), script_b(), script_c(), script_d()};
  std::vector<Outcome> fresh;
  for (const Script& script : scripts)
    fresh.push_back(on_new_drive(script));
  ASSERT_GT(fresh[3].frames.size(), 300u);  // D's SYNCs did run
  // When they run on one drive and one bus, reset before each, in the order A B C D and D C B A
  const std::vector<Outcome> forward =
      on_reset_bus({&scripts[0], &scripts[1], &scripts[2], &scripts[3]});
  const std::vector<Outcome> backward =
      on_reset_bus({&scripts[3], &scripts[2], &scripts[1], &scripts[0]});
  // Then every script gives the same frames at the same times and the same dictionary
  ASSERT_EQ(forward.size(), 4u);
  ASSERT_EQ(backward.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(forward[i], fresh[i]) << "forward, script " << i;
    EXPECT_EQ(backward[3 - i], fresh[i]) << "backward, script " << i;
  }
}

TEST(DriveRestart, ForgetsWhatItsOwnStorageHeld) {
  // Given a drive that stored a 20 ms heartbeat (script B)
  std::unique_ptr<Rig> rig = std::make_unique<Rig>();
  auto created = ReferenceDrive::create(rig->drive_port(), config());
  ASSERT_TRUE(created.has_value());
  std::unique_ptr<ReferenceDrive> drive = std::move(*created);
  auto next = std::make_unique<Rig>();
  ASSERT_TRUE(drive->restart(next->drive_port()).has_value());
  rig = std::move(next);
  rig->run(*drive, script_b());
  ASSERT_EQ(drive->dictionary().find(0x1017, 0)->as_unsigned(), 20u);
  ASSERT_GT(drive->statistics().cycles, 0u);
  // When it restarts
  next = std::make_unique<Rig>();
  ASSERT_TRUE(drive->restart(next->drive_port()).has_value());
  rig = std::move(next);
  // Then its statistics start again, and after power on 1017h is its default again (a new
  // drive's storage is empty)
  EXPECT_EQ(drive->statistics().cycles, 0u);
  rig->run(*drive, {});
  EXPECT_EQ(drive->dictionary().find(0x1017, 0)->as_unsigned(), 0u);
}

TEST(DriveRestart, RefusesADriveWithDeviations) {
  // Given a drive with a deviation
  Rig rig;
  DriveConfig with_deviation = config();
  with_deviation.deviations.add(Deviation::sdo_no_timeout);
  auto drive = ReferenceDrive::create(rig.drive_port(), with_deviation);
  ASSERT_TRUE(drive.has_value());
  // When it is restarted, Then it says it cannot be
  Rig other;
  EXPECT_FALSE((*drive)->restart(other.drive_port()).has_value());
}

}  // namespace
}  // namespace drivecheck::reference_drive
