// A scripted-exchange fixture for the device-side CiA 301 services: a simulated bus (500 kbit/s,
// exact bit stuffing) with a "master" port that the test drives in pull mode, and a "device"
// port running DeviceServices over its own object dictionary (node 5 unless told otherwise).
//
//   DeviceHarness h;                        // objects added, device attached, not powered
//   h.power_on();                           // boot-up queued at 0
//   auto boot = h.next(1ms);                // 705#00
//   h.send("000#0105");                     // start node 5; returns at its delivery time
//   h.write(0x1017, 0, 100, 2);             // an SDO write's effect, at the current time
//
// Times: a frame the device queues at t while the wire is idle starts (SOF) at t and is
// delivered at t + its wire time; start_of_frame() recovers t from the delivery timestamp, so
// tests assert the device's own timing exactly.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/frame.hpp"
#include "protocol/can/frame_timing.hpp"
#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/device_services.hpp"
#include "protocol/cia301/object_dictionary.hpp"

namespace drivecheck::test_support {

using namespace std::chrono_literals;

inline can::TimePoint at(can::Duration d) {
  return can::TimePoint{} + d;
}

inline can::Frame frame_of(std::string_view text) {
  auto frame = can::parse_candump(text);
  EXPECT_TRUE(frame) << text;
  return frame ? *frame : can::Frame{};
}

class DeviceHarness {
 public:
  explicit DeviceHarness(std::uint8_t node = 5, cia301::DeviceObjectsOptions objects = {},
                         cia301::DeviceServicesConfig config = {},
                         cia301::DeviceServicesHandlers handlers = {})
      : od(node) {
    master = bus.attach("master");
    device_port = bus.attach("device");
    bus.add_monitor([this](const can::TimedFrame& frame) {
      trace.push_back(frame);
      if (waiting_for_ && frame.frame == *waiting_for_) {
        waiting_for_.reset();
        bus.stop();
      }
    });
    auto added = cia301::DeviceServices::add_objects(od, objects);
    EXPECT_TRUE(added) << (added ? "" : added.error());
    // An application object, to tell reset application from reset communication.
    EXPECT_TRUE(od.add_var(0x6060, "Modes of operation", cia301::DataType::integer8,
                           cia301::AccessType::rw, cia301::Value::of_signed(1)));
    device =
        std::make_unique<cia301::DeviceServices>(*device_port, od, config, std::move(handlers));
    device->attach();
  }

  // Powers the device on and returns its boot-up frame (within 1 s).
  std::optional<can::TimedFrame> power_on() {
    device->power_on();
    return next(1s);
  }

  // The master sends `text`; returns when the frame has reached the other nodes.
  void send(std::string_view text) { send(frame_of(text)); }
  void send(const can::Frame& frame) {
    EXPECT_FALSE(master->send(frame));
    waiting_for_ = frame;
    bus.run_until(bus.now() + 100ms);  // the monitor stops the bus at the frame's delivery
    if (waiting_for_) ADD_FAILURE() << "frame never went on the wire: " << can::to_candump(frame);
    waiting_for_.reset();
  }

  // Runs the network up to `t` without taking frames from the master's queue.
  void run_to(can::TimePoint t) { bus.run_until(t); }

  // The next frame the master receives within `within`, or nullopt (time is then now + within).
  std::optional<can::TimedFrame> next(can::Duration within) {
    return master->receive(bus.now() + within);
  }
  // The next frame within `within`, which must be `text`.
  can::TimedFrame expect(std::string_view text, can::Duration within) {
    auto frame = next(within);
    if (!frame) {
      ADD_FAILURE() << "expected " << text << " within " << within.count() << " ns, got nothing";
      return {};
    }
    EXPECT_EQ(can::to_candump(frame->frame), text);
    return *frame;
  }
  // Nothing reaches the master for `span`.
  void expect_silence(can::Duration span) {
    if (auto frame = next(span)) {
      ADD_FAILURE() << "expected silence, got " << can::to_candump(frame->frame) << " at "
                    << frame->timestamp.time_since_epoch().count() << " ns";
    }
  }
  // Lets simulated time pass, dropping whatever the master receives meanwhile.
  void drain(can::Duration span) {
    const can::TimePoint until = bus.now() + span;
    while (master->receive(until)) {
    }
  }

  // When the device started sending a frame that reached the master at frame.timestamp (the
  // wire was idle: SOF = queue time).
  can::TimePoint start_of_frame(const can::TimedFrame& frame) const {
    const auto bits = can::frame_bits(frame.frame, bus.config().stuffing);
    return frame.timestamp - can::bit_duration(bits - 3, bus.config().bitrate);
  }

  // The 3-bit intermission after a frame: a frame queued at a delivery time starts this much
  // later (the wire is busy until then).
  can::Duration intermission() const { return can::bit_duration(3, bus.config().bitrate); }

  // The effect of an SDO download of `size` bytes at the current simulated time.
  Expected<void, cia301::SdoAbort> write(std::uint16_t index, std::uint8_t sub, std::uint64_t value,
                                         std::size_t size) {
    std::vector<std::uint8_t> bytes(size);
    cia301::store_unsigned(value, bytes);
    return od.write(index, sub, bytes);
  }
  // An SDO upload of an integer entry.
  Expected<std::uint64_t, cia301::SdoAbort> read(std::uint16_t index, std::uint8_t sub) {
    auto bytes = od.read(index, sub);
    if (!bytes) return Unexpected(bytes.error());
    return cia301::load_unsigned(*bytes);
  }

  can::SimBus bus;
  std::unique_ptr<can::SimPort> master;
  std::unique_ptr<can::SimPort> device_port;
  std::vector<can::TimedFrame> trace;  // every frame on the wire, in order
  cia301::ObjectDictionary od;
  std::unique_ptr<cia301::DeviceServices> device;

 private:
  std::optional<can::Frame> waiting_for_;
};

}  // namespace drivecheck::test_support
