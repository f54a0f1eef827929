// DeviceServices with the real SDO server (sdo_server.hpp) behind it and the real SDO client
// (sdo_client.hpp) on the master's port: SDO writes to the communication objects take effect at
// once, their aborts reach the master, and SDO is served only where the NMT state allows it.
#include "protocol/cia301/device_services.hpp"

#include <gtest/gtest.h>

#include <optional>

#include "protocol/cia301/sdo_client.hpp"
#include "protocol/cia301/sdo_server.hpp"
#include "tests/cia301/device_harness.hpp"

namespace drivecheck::cia301 {
namespace {

using namespace std::chrono_literals;
using test_support::at;
using test_support::DeviceHarness;
using test_support::frame_of;

// A device of node 5 as the reference drive composes one: DeviceServices takes the NMT, error
// control and SYNC frames, the SDO server gets the rest while the NMT state allows SDO, and a
// reset or Stopped drops an open SDO transfer.
class SdoDevice {
 public:
  SdoDevice()
      : h_(5, {}, {}, handlers()),
        server_(h_.od, SdoServerConfig::for_node(5)),
        runner_(*h_.device_port, server_) {
    h_.power_on();
  }

  DeviceHarness& harness() { return h_; }
  SdoClient client() {
    SdoClientOptions options;
    options.timeout = 50ms;
    return SdoClient(*h_.master, 5, options);
  }
  // When the request with this first byte and multiplexer reached the device.
  std::optional<can::TimePoint> delivered(const can::Frame& request) const {
    for (const auto& frame : h_.trace) {
      if (frame.frame == request) return frame.timestamp;
    }
    return std::nullopt;
  }

 private:
  DeviceServicesHandlers handlers() {
    DeviceServicesHandlers handlers;
    handlers.other_frames = [this](const can::TimedFrame& frame) {
      if (h_.device->allows(NmtService::sdo)) runner_.handle(frame);
    };
    handlers.on_state_changed = [this](NmtState, NmtState to) {
      if (!nmt_allows(to, NmtService::sdo)) {
        server_.reset();
        runner_.transmit({});
      }
    };
    return handlers;
  }

  DeviceHarness h_;
  SdoServer server_;
  SdoServerRunner runner_;
};

TEST(DeviceServicesWithSdo, HeartbeatTimeWrittenBySdoTakesEffectAtOnce) {
  // Given a device with 1017h = 0 and an SDO client on the master's port
  SdoDevice device;
  auto client = device.client();
  // When the master writes 1017h = 100 ms by expedited SDO
  ASSERT_TRUE(client.download_value<std::uint16_t>({0x1017, 0}, 100));
  // Then the first heartbeat starts exactly 100 ms after the request reached the device
  const auto written = device.delivered(frame_of("605#2B17100064000000"));  // 2Bh: 2 bytes
  ASSERT_TRUE(written);
  auto& h = device.harness();
  const auto beat = h.expect("705#7F", 150ms);  // heartbeat, pre-operational
  EXPECT_EQ(h.start_of_frame(beat), *written + 100ms);
}

TEST(DeviceServicesWithSdo, ObjectRulesAnswerWithCia301AbortCodes) {
  // Given a pre-operational device and an SDO client
  SdoDevice device;
  auto client = device.client();
  // When the master configures node 9 twice in 1016h
  ASSERT_TRUE(client.download_value<std::uint32_t>({0x1016, 1}, 0x00090096));
  const auto duplicate = client.download_value<std::uint32_t>({0x1016, 2}, 0x000900C8);
  // Then the second write is aborted with 06040043h
  ASSERT_FALSE(duplicate);
  EXPECT_EQ(duplicate.error(), SdoAbort::general_parameter_incompatibility);
  // And 1003h:00 = 1 is aborted with 06090030h, 1003h:01 without errors with 08000024h
  const auto clear = client.download_value<std::uint8_t>({0x1003, 0}, 1);
  ASSERT_FALSE(clear);
  EXPECT_EQ(clear.error(), SdoAbort::invalid_value);
  const auto empty = client.upload_value<std::uint32_t>({0x1003, 1});
  ASSERT_FALSE(empty);
  EXPECT_EQ(empty.error(), SdoAbort::no_data_available);
  // And a new CAN-ID in a valid 1014h is aborted with 06090030h
  const auto cob = client.download_value<std::uint32_t>({0x1014, 0}, 0x00000090);
  ASSERT_FALSE(cob);
  EXPECT_EQ(cob.error(), SdoAbort::invalid_value);
  // And 1019h while 1006h ≠ 0 is aborted with 08000022h
  ASSERT_TRUE(client.download_value<std::uint32_t>({0x1006, 0}, 10000));
  const auto overflow = client.download_value<std::uint8_t>({0x1019, 0}, 5);
  ASSERT_FALSE(overflow);
  EXPECT_EQ(overflow.error(), SdoAbort::cannot_transfer_device_state);
}

TEST(DeviceServicesWithSdo, NoSdoInStopped) {
  // Given a device the master stopped
  SdoDevice device;
  auto client = device.client();
  device.harness().send("000#0205");  // stop node 5
  // When the master reads 1017h
  const auto stopped = client.upload_value<std::uint16_t>({0x1017, 0});
  // Then no answer comes (CiA 301 §7.3.2.2: SDO not in Stopped): the client times out
  ASSERT_FALSE(stopped);
  EXPECT_EQ(stopped.error(), SdoClientError::timeout);
  // When the node is put back into Pre-operational
  device.harness().send("000#8005");  // enter pre-operational node 5
  // Then the read is answered
  const auto value = client.upload_value<std::uint16_t>({0x1017, 0});
  ASSERT_TRUE(value);
  EXPECT_EQ(*value, 0);
}

TEST(DeviceServicesWithSdo, ConsumerConfiguredBySdoTimesOutOnTheWire) {
  // Given a device made operational and told by SDO to consume node 9 with 100 ms
  SdoDevice device;
  auto client = device.client();
  ASSERT_TRUE(client.download_value<std::uint32_t>({0x1016, 1}, 0x00090064));  // node 9, 100 ms
  auto& h = device.harness();
  h.send("000#0105");  // start node 5
  // When node 9 sends one heartbeat
  h.send("709#05");  // heartbeat of node 9, operational
  const can::TimePoint last = h.bus.now();
  // Then EMCY 8130h comes 100 ms later and the device is pre-operational (1029h default 0)
  const auto emcy = h.expect("085#3081110000000000", 200ms);  // 8130h, register 11h
  EXPECT_EQ(h.start_of_frame(emcy), last + 100ms);
  EXPECT_EQ(h.device->state(), NmtState::pre_operational);
  // And the master can read the error from 1001h and 1003h
  EXPECT_EQ(client.upload_value<std::uint8_t>({0x1001, 0}).value_or(0), 0x11);
  EXPECT_EQ(client.upload_value<std::uint32_t>({0x1003, 1}).value_or(0), 0x8130u);
}

}  // namespace
}  // namespace drivecheck::cia301
