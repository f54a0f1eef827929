// The master over a real link: RawLink (AF_PACKET) on one end of a veth pair in a network
// namespace the test creates, the emulated CoE slave of master_test_slave.hpp behind the other
// end (a thread that receives each frame, lets the slave process it in place and sends it
// back). Real time: every wait is bounded. Skipped with the reason where no namespace or veth
// pair can be made (not root).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "protocol/ethercat/master.hpp"
#include "protocol/ethercat/raw_link.hpp"
#include "tests/ethercat/master_test_slave.hpp"
#include "tests/ethercat/veth_pair.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;
using test::VethPair;

// The slave's end: receives, processes in place, sends back, until stopped.
class SlaveEnd {
 public:
  SlaveEnd(Link& link, test::TestSlave& slave) : link_(link), slave_(slave) {
    thread_ = std::thread([this] { serve(); });
  }
  ~SlaveEnd() {
    stop_ = true;
    thread_.join();
  }
  SlaveEnd(const SlaveEnd&) = delete;
  SlaveEnd& operator=(const SlaveEnd&) = delete;

 private:
  void serve() {
    while (!stop_) {
      auto request = link_.receive(link_.now() + 20ms);
      if (!request) continue;
      slave_.on_frame(request->bytes, link_.now(), std::nullopt);
      (void)link_.send(request->bytes);
    }
  }

  Link& link_;
  test::TestSlave& slave_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TEST_F(VethPair, MasterBringsUpASlaveBehindAVethPair) {
  // Given the emulated slave behind end b and the master on end a
  auto master_link = RawLink::open(a_);
  auto slave_link = RawLink::open(b_);
  ASSERT_TRUE(master_link) << describe_open_error(a_, master_link.error());
  ASSERT_TRUE(slave_link) << describe_open_error(b_, slave_link.error());
  test::TestSlave slave;
  SlaveEnd end(**slave_link, slave);
  MasterConfig config;
  config.port.response_timeout = 200ms;
  config.scan.expected_slaves = 1;
  Master master(**master_link, config);
  // When the master brings it up to OP, reads 1018h:01 by CoE and cycles 50 times at 1 ms
  const auto up = master.bring_up(AlState::op);
  ASSERT_TRUE(up) << up.error().message();
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  slave.set_inputs({0x37, 0x02});
  master.outputs(0)[0] = 0x0F;
  for (int i = 0; i < 50; ++i) {
    const auto cycle = master.cycle();
    ASSERT_TRUE(cycle) << i << ": " << cycle.error().message();
    EXPECT_EQ(cycle->wkc, 3);
    master.port().wait(1ms);
  }
  // Then the slave is in OP with the outputs, the master has the inputs and the vendor ID
  ASSERT_TRUE(vendor) << vendor.error().message();
  EXPECT_EQ(*vendor, (Bytes{0x1D, 0, 0, 0}));
  EXPECT_EQ(Bytes(master.inputs(0).begin(), master.inputs(0).end()), (Bytes{0x37, 0x02}));
  // And when the cycle stops for 300 ms, the next one reports the SM watchdog (001Bh)
  master.port().wait(300ms);
  const auto late = master.cycle();
  ASSERT_FALSE(late);
  EXPECT_EQ(late.error().code, MasterErrc::al_state_lost) << late.error().message();
  EXPECT_EQ(late.error().al_status_code, 0x001B);
}

}  // namespace
}  // namespace drivecheck::ethercat
