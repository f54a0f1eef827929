// An emulated drive for the master's tests and benchmark: EscSlave + CoeSlave over the CoE test
// dictionary, with the CoE front end wired as protocol/ethercat/README.md describes. No gtest
// here (the benchmark includes it too).
#pragma once

#include <cstdint>
#include <cstdlib>
#include <functional>
#include <memory>
#include <vector>

#include "protocol/ethercat/coe_sdo_server.hpp"
#include "protocol/ethercat/esc_slave.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "tests/ethercat/coe_test_dictionary.hpp"

namespace drivecheck::ethercat::test {

using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

constexpr std::uint16_t kSm0 = 0x1000;
constexpr std::uint16_t kSm1 = 0x1080;
constexpr std::uint16_t kOutputs = 0x1100;
constexpr std::uint16_t kInputs = 0x1180;

// A drive-like SII: mailboxes 1000h/1080h (128 octets), SM2 outputs at 1100h with the RxPDO
// 1600h (6040h, 16 bit), SM3 inputs at 1180h with the TxPDO 1A00h (6041h, 16 bit).
inline SiiImage drive_sii_image(std::uint16_t alias) {
  SiiImage image;
  image.header.station_alias = alias;
  image.header.vendor_id = 0x1D;
  image.header.standard_receive = {kSm0, 128};
  image.header.standard_send = {kSm1, 128};
  image.header.mailbox_protocols = kSiiMailboxCoe;
  image.sync_managers = {
      {kSm0, 128, 0x26, 0, 1, SiiSyncManagerType::mailbox_out},
      {kSm1, 128, 0x22, 0, 1, SiiSyncManagerType::mailbox_in},
      {kOutputs, 2, 0x64, 0, 1, SiiSyncManagerType::outputs},
      {kInputs, 2, 0x20, 0, 1, SiiSyncManagerType::inputs},
  };
  image.rx_pdos = {{0x1600, 2, 0, 0, 0, {{0x6040, 0, 0, 6, 16, 0}}}};
  image.tx_pdos = {{0x1A00, 3, 0, 0, 0, {{0x6041, 0, 0, 6, 16, 0}}}};
  return image;
}

inline Bytes drive_sii(std::uint16_t alias = 0) {
  return *build_sii(drive_sii_image(alias));
}

struct SlaveOptions {
  std::uint16_t alias = 0;
  Bytes sii;  // empty: drive_sii(alias)
  Duration sii_busy_time = 20us;
  std::function<AlStatusCode(const AlTransition&)> check;
  // Variants of a foreign slave:
  std::uint8_t sii_read_bytes = 8;    // octets per EEPROM read (0502h bit 6)
  std::uint16_t write_mailbox = 128;  // SM0 length the CoE front end expects (the SII's)
  std::uint16_t read_mailbox = 128;   // SM1 length
  // Frames that pass after a request before its reply goes into SM1 (a slow application).
  int reply_after_frames = 0;
  // Objects added to the dictionary at every power-on (1C13h, mappings, ...).
  std::function<void(cia301::ObjectDictionary&)> dictionary;
};

// An emulated drive: the ESC and its state machine, with the CoE front end wired the way
// protocol/ethercat/README.md describes (SM0 written -> CoeSlave, SM1 free -> next reply,
// SM1 repeat request -> last reply again and the acknowledge toggled).
class TestSlave final : public SegmentDevice {
 public:
  explicit TestSlave(SlaveOptions options = {}) : options_(std::move(options)) { power_on(); }

  void on_frame(std::span<std::uint8_t> frame, TimePoint arrival,
                std::optional<TimePoint> return_arrival) override {
    slave_->on_frame(frame, arrival, return_arrival);
    if (frames_to_wait_ > 0 && --frames_to_wait_ == 0) flush(*slave_);
  }

  // A power cycle: registers, station address, state machine, mailbox all back to power-on.
  void power_on() {
    od_ = test::make_test_dictionary();
    if (options_.dictionary) options_.dictionary(od_);
    coe_ = std::make_unique<CoeSlave>(od_,
                                      MailboxSlaveConfig{.write_size = options_.write_mailbox,
                                                         .read_size = options_.read_mailbox},
                                      CoeSdoServerOptions{.read_size = options_.read_mailbox});
    EscSlaveConfig config;
    config.esc.sii = options_.sii.empty() ? drive_sii(options_.alias) : options_.sii;
    config.esc.sii_busy_time = options_.sii_busy_time;
    config.esc.sii_read_bytes = options_.sii_read_bytes;
    config.check = options_.check;
    config.on_state_change = [this](AlState, AlState to) {
      if (to == AlState::init) coe_->reset();
    };
    config.on_events = [this](EscSlave& slave, const EscEvents& events) { handle(slave, events); };
    slave_ = std::make_unique<EscSlave>(std::move(config));
  }

  void post_emergency(std::uint16_t code) {
    cia301::Emcy emcy;
    emcy.error_code = code;
    emcy.error_register = 0x01;
    if (!coe_->post_emergency(emcy)) std::abort();
    flush(*slave_);
  }
  void set_inputs(Bytes bytes) {
    for (std::size_t i = 0; i < bytes.size(); ++i) {
      if (!slave_->esc().pdi_write8(static_cast<std::uint16_t>(kInputs + i), bytes[i])) {
        std::abort();
      }
    }
  }
  Bytes outputs() {
    return {slave_->esc().pdi_read8(kOutputs), slave_->esc().pdi_read8(kOutputs + 1)};
  }
  EscSlave& esc_slave() { return *slave_; }
  cia301::ObjectDictionary& od() { return od_; }

 private:
  void flush(EscSlave& slave) {
    if (frames_to_wait_ > 0 || slave.esc().mailbox_full(1)) return;
    if (auto reply = coe_->take_reply()) slave.esc().pdi_put_mailbox(1, *reply);
  }
  void handle(EscSlave& slave, const EscEvents& events) {
    if ((events.sm_written & 0x01) != 0) {
      if (auto request = slave.esc().pdi_take_mailbox(0)) {
        coe_->on_write_mailbox(*request);
        frames_to_wait_ = options_.reply_after_frames;
      }
    }
    if ((events.sm_repeat & 0x02) != 0) {
      const bool repeat = (slave.esc().sync_manager(1).activate & sm::kActivateRepeat) != 0;
      if (!slave.esc().mailbox_full(1)) {
        if (auto last = coe_->repeat_last()) slave.esc().pdi_put_mailbox(1, *last);
      }
      const std::uint16_t pdi = reg::sync_manager(1) + 7;
      const std::uint8_t value = slave.esc().pdi_read8(pdi);
      slave.esc().pdi_write8(pdi, static_cast<std::uint8_t>(repeat ? (value | sm::kPdiRepeatAck)
                                                                   : (value & ~sm::kPdiRepeatAck)));
    }
    flush(slave);
  }

  SlaveOptions options_;
  int frames_to_wait_ = 0;
  cia301::ObjectDictionary od_;
  std::unique_ptr<CoeSlave> coe_;
  std::unique_ptr<EscSlave> slave_;
};

}  // namespace drivecheck::ethercat::test
