// The reference drive as an emulated EtherCAT slave on the simulated segment, a master brought
// up to PREOP, and the engine's port and clock on them: what an engine test runs vectors against
// over EtherCAT. No power cycle hook: a reset node is AL INIT then PREOP and keeps the
// dictionary, as over veth where the drive is another process.
#pragma once

#include <gtest/gtest.h>

#include <memory>
#include <utility>

#include "conformance/ethercat_port.hpp"
#include "protocol/ethercat/master.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "reference_drive/ethercat/ethercat_drive.hpp"

namespace drivecheck::test_support {

class EthercatRig {
 public:
  explicit EthercatRig(reference_drive::ethercat::EthercatDriveOptions options = {}) {
    auto created = reference_drive::ethercat::EthercatDrive::create(segment_, std::move(options));
    EXPECT_TRUE(created) << created.error();
    if (!created) return;
    drive_ = std::move(*created);
    segment_.attach(*drive_);
    drive_->power_on();
    ethercat::MasterConfig config;
    config.scan.expected_slaves = 1;
    master_ = std::make_unique<ethercat::Master>(segment_, config);
    const bool up = master_->bring_up(ethercat::AlState::preop).has_value();
    EXPECT_TRUE(up) << "the master did not bring the slave to PREOP";
    if (!up) return;
    port_ = std::make_unique<conformance::EthercatPort>(*master_);
    clock_ = std::make_unique<conformance::EthercatClock>(segment_, *port_);
  }
  ~EthercatRig() { segment_.detach_all(); }
  EthercatRig(const EthercatRig&) = delete;
  EthercatRig& operator=(const EthercatRig&) = delete;

  // False when the slave could not be created or brought to PREOP (the test has failed then).
  bool ready() const { return clock_ != nullptr; }
  ethercat::SimSegment& segment() { return segment_; }
  ethercat::Master& master() { return *master_; }
  conformance::EthercatPort& port() { return *port_; }
  conformance::EthercatClock& clock() { return *clock_; }

 private:
  ethercat::SimSegment segment_;
  std::unique_ptr<reference_drive::ethercat::EthercatDrive> drive_;
  std::unique_ptr<ethercat::Master> master_;
  std::unique_ptr<conformance::EthercatPort> port_;
  std::unique_ptr<conformance::EthercatClock> clock_;
};

}  // namespace drivecheck::test_support
