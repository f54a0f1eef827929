// The test rig of the personality tests: one ServoDrive (node 5, the standard drive or a
// profile's personality) and a tester port on a 1 Mbit/s simulated bus, driven by scripted
// expedited SDO exchanges.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/servo_drive.hpp"

namespace drivecheck::reference_drive::testing {

inline constexpr std::uint8_t kNode = 5;
inline constexpr std::uint32_t kNoAnswer = 0xFFFFFFFF;

inline const std::filesystem::path kDrives =
    std::filesystem::path(DRIVECHECK_SOURCE_DIR) / "vectors/drives";

class ServoRig {
 public:
  enum class PowerOn { now, later };

  // `profile_name` empty: the standard drive. With PowerOn::later the test calls power_on().
  explicit ServoRig(const std::string& profile_name = "", PowerOn power = PowerOn::now) {
    if (!profile_name.empty()) {
      auto loaded = profile::find_profile(profile_name, kDrives);
      if (!loaded) {
        ADD_FAILURE() << loaded.error().to_string();
        return;
      }
      profile_ = std::move(*loaded);
    }
    start(power);
  }
  // A drive with a profile the test made (e.g. parsed from text).
  explicit ServoRig(profile::DriveProfile profile, PowerOn power = PowerOn::now) {
    profile_ = std::move(profile);
    start(power);
  }

 private:
  void start(PowerOn power) {
    tester_ = bus_.attach("tester");
    port_ = bus_.attach("drive");
    tester_->set_frame_handler([this](const can::TimedFrame& f) { seen_.push_back(f.frame); });
    ServoDriveOptions options;
    options.node = kNode;
    options.profile = profile_ ? &*profile_ : nullptr;
    auto created = ServoDrive::create(*port_, options);
    if (!created) {
      ADD_FAILURE() << "ServoDrive::create: " << created.error();
      return;
    }
    drive_ = std::move(*created);
    if (power == PowerOn::now) power_on();
  }

 public:
  bool ok() const { return drive_ != nullptr; }
  ServoDrive& drive() { return *drive_; }
  void power_on() {
    drive_->power_on();
    run(std::chrono::milliseconds(20));
  }

  // The frames the tester saw in `window` of bus time.
  std::vector<can::Frame> run(can::Duration window) {
    seen_.clear();
    bus_.run_for(window);
    return std::exchange(seen_, {});
  }
  void send(const can::Frame& frame) { ASSERT_FALSE(tester_->send(frame)); }

  // Expedited download of `size` bytes: 0, the abort code, or kNoAnswer.
  std::uint32_t write(std::uint16_t index, std::uint8_t sub, std::uint64_t value, unsigned size) {
    // ccs=1 e=1 s=1 n=4-size, index LE, sub, data LE
    const std::uint8_t bytes[8] = {static_cast<std::uint8_t>(0x23 | ((4 - size) << 2)),
                                   static_cast<std::uint8_t>(index & 0xFF),
                                   static_cast<std::uint8_t>(index >> 8),
                                   sub,
                                   static_cast<std::uint8_t>(value & 0xFF),
                                   static_cast<std::uint8_t>(size > 1 ? (value >> 8) & 0xFF : 0),
                                   static_cast<std::uint8_t>(size > 2 ? (value >> 16) & 0xFF : 0),
                                   static_cast<std::uint8_t>(size > 3 ? (value >> 24) & 0xFF : 0)};
    send(can::Frame::standard(0x600 + kNode, bytes));
    for (const auto& f : run(std::chrono::milliseconds(5))) {
      if (f.id != 0x580U + kNode) continue;
      if (f.data[0] == 0x60) return 0;
      if (f.data[0] == 0x80) return data32(f);
    }
    return kNoAnswer;
  }
  // Expedited upload: the response frame (nullopt: none).
  std::optional<can::Frame> upload(std::uint16_t index, std::uint8_t sub) {
    // ccs=2 initiate upload, index LE, sub
    const std::uint8_t bytes[8] = {0x40,
                                   static_cast<std::uint8_t>(index & 0xFF),
                                   static_cast<std::uint8_t>(index >> 8),
                                   sub,
                                   0,
                                   0,
                                   0,
                                   0};
    send(can::Frame::standard(0x600 + kNode, bytes));
    for (const auto& f : run(std::chrono::milliseconds(5)))
      if (f.id == 0x580U + kNode) return f;
    return std::nullopt;
  }
  // Expedited upload: the value, or kNoAnswer (no answer, not expedited, or an abort, whose
  // code goes to `abort` when given).
  std::uint32_t read(std::uint16_t index, std::uint8_t sub = 0, std::uint32_t* abort = nullptr) {
    const auto f = upload(index, sub);
    if (!f) return kNoAnswer;
    if (f->data[0] == 0x80) {
      if (abort != nullptr) *abort = data32(*f);
      return kNoAnswer;
    }
    if ((f->data[0] & 0xE3) != 0x43) return kNoAnswer;
    const unsigned size = 4 - ((f->data[0] >> 2) & 3);
    const std::uint32_t data = data32(*f);
    return size == 4 ? data : data & ((1U << (8 * size)) - 1);
  }
  std::uint16_t statusword() { return static_cast<std::uint16_t>(read(0x6041)); }
  // 6040h := value, confirmed, then 20 ms.
  void controlword(std::uint16_t value) {
    EXPECT_EQ(write(0x6040, 0, value, 2), 0U);
    run(std::chrono::milliseconds(20));
  }
  // 6040h := value without waiting for the confirmation (the drive may not answer, e.g.
  // bus-off), then 20 ms.
  void send_controlword(std::uint16_t value) {
    // ccs=1 e=1 s=1 n=2, 6040h sub 0, data LE
    send(can::Frame::standard(
        0x600 + kNode,
        std::array<std::uint8_t, 8>{0x2B, 0x40, 0x60, 0x00, static_cast<std::uint8_t>(value),
                                    static_cast<std::uint8_t>(value >> 8), 0, 0}));
    run(std::chrono::milliseconds(20));
  }
  // Shutdown, switch on, enable operation (unconfirmed, like a master that does not wait).
  void enable() {
    for (std::uint16_t cw : {0x0006, 0x0007, 0x000F})
      send_controlword(cw);
  }
  cia402::State state() const { return drive_->application().pds().state(); }
  // The dictionary's current value.
  std::uint64_t value(std::uint16_t index, std::uint8_t sub) {
    const cia301::Entry* entry = drive_->device().dictionary().find(index, sub);
    EXPECT_NE(entry, nullptr);
    return entry != nullptr ? entry->as_unsigned() : ~std::uint64_t{0};
  }
  // The drive's CAN controller bus-off or recovered, as the embedded drive's simulation
  // control does it: the port first, then the drive's controller report.
  void bus_off(bool off) {
    port_->set_bus_off(off);
    drive_->device().set_bus_off(off);
  }

  static std::uint32_t data32(const can::Frame& f) {
    return static_cast<std::uint32_t>(f.data[4] | f.data[5] << 8 | f.data[6] << 16 |
                                      static_cast<std::uint32_t>(f.data[7]) << 24);
  }

 private:
  std::optional<profile::DriveProfile> profile_;
  can::SimBus bus_{can::SimBusConfig{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> tester_;
  std::unique_ptr<can::SimPort> port_;
  std::unique_ptr<ServoDrive> drive_;
  std::vector<can::Frame> seen_;
};

}  // namespace drivecheck::reference_drive::testing
