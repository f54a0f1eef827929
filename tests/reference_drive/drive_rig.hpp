// The test bench of the reference drive's tests: one ReferenceDrive on a simulated bus
// (1 Mbit/s) and a bare tester port that sends literal frames and records every frame it sees,
// as CiA's conformance tool drives a device. Plus TestApplication, whose objects give the PDO
// tests something to map.
//
// Node 5 by default: SDO 605h/585h, EMCY 085h, boot-up/heartbeat 705h, TPDO1..4 185h..485h,
// RPDO1..4 205h..505h.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/can/sim_bus.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "protocol/cia301/store_restore.hpp"
#include "reference_drive/device.hpp"

namespace drivecheck::reference_drive::testing {

using namespace std::chrono_literals;

// Manufacturer objects of the test application (2000h-5FFFh, store group 4):
//   2000h  UNSIGNED16 rw  mappable       "output word"
//   2001h  UNSIGNED32 rw  mappable       "output long"
//   2002h  UNSIGNED8  rw  mappable       "output byte"
//   2003h  UNSIGNED16 ro  mappable       "input word" (TPDO only)
//   2004h  UNSIGNED16 wo  mappable       "command word" (RPDO only)
//   2005h  UNSIGNED16 rw  not mappable
//   2006h  VISIBLE_STRING rw, marked mappable (variable length: still not mappable)
//   2007h  BOOLEAN    rw  mappable
//   2008h  UNSIGNED8  rw  mappable, HighLimit 100
//   2009h  UNSIGNED64 rw  mappable
//   200Ah  ARRAY of 2 INTEGER16 rw mappable (sub 1, sub 2)
class TestApplication final : public DriveApplication {
 public:
  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override;
  void on_reset(ReferenceDrive& drive, cia301::ResetKind kind) override;
  void on_cycle(ReferenceDrive& drive, can::TimePoint now) override;

  std::vector<cia301::ResetKind> resets;
  std::uint64_t cycles = 0;
};

struct SdoResult {
  bool answered = false;
  std::optional<std::uint32_t> abort;  // the server's abort code
  std::uint64_t value = 0;             // upload: the expedited data, little endian
};

class DriveRig {
 public:
  static constexpr std::uint32_t kNoAnswer = 0xFFFFFFFF;

  // A drive at `node` with the test application (unless config.application names another) and
  // a memory storage, powered on, boot-up seen (the tester's record is cleared after it).
  // `bitrate`: of the simulated bus (bit/s).
  explicit DriveRig(std::uint8_t node = 5, DriveConfig config = {},
                    std::uint32_t bitrate = 1'000'000);

  can::SimBus& bus() { return bus_; }
  can::SimPort& drive_port() { return *drive_port_; }
  ReferenceDrive& drive() { return *drive_; }
  TestApplication& application() { return application_; }
  cia301::MemoryParameterStorage& storage() { return storage_; }
  std::uint8_t node() const { return node_; }

  // Sends a frame from the tester (candump text) now.
  void send(std::string_view candump);
  // Runs the bus for `window` and returns the frames the tester saw meanwhile (candump text).
  std::vector<std::string> run(can::Duration window);
  // send() then run().
  std::vector<std::string> exchange(std::string_view candump, can::Duration window = 10ms);
  // Every frame the tester saw since the last run()/exchange()/take(), with times.
  std::vector<can::TimedFrame> take();

  // Expedited SDO download of `size` bytes (1..4): 0 on success, the abort code, or kNoAnswer.
  // write() and read() drop the frames recorded before them and consume those of their window.
  std::uint32_t write(std::uint16_t index, std::uint8_t sub_index, std::uint64_t value,
                      unsigned size);
  // Expedited SDO upload.
  SdoResult read(std::uint16_t index, std::uint8_t sub_index);

  // NMT node control to this node (cs 01h start, 02h stop, 80h pre-op, 81h reset node,
  // 82h reset communication), then 10 ms of bus time.
  std::vector<std::string> nmt(std::uint8_t command);
  // A SYNC (with counter when given), then 2 ms of bus time.
  std::vector<std::string> sync(std::optional<std::uint8_t> counter = std::nullopt);

  // A master port in pull mode that sees only this drive's SDO answers, for SdoClient.
  can::SimPort& master() { return *master_; }
  cia301::SdoClient client(cia301::SdoClientOptions options = {}) {
    return cia301::SdoClient(*master_, node_, std::move(options));
  }

  // "185#..." etc. for this node: base + node.
  std::string id(std::uint32_t base) const;

 private:
  std::uint8_t node_;
  can::SimBus bus_;
  std::unique_ptr<can::SimPort> tester_;
  std::unique_ptr<can::SimPort> drive_port_;
  std::unique_ptr<can::SimPort> master_;
  TestApplication application_;
  cia301::MemoryParameterStorage storage_;
  std::unique_ptr<ReferenceDrive> drive_;
  std::vector<can::TimedFrame> seen_;
};

// Frame text helpers: "585#80<index LE><sub><code LE>" etc.
std::string sdo_abort_frame(std::uint8_t node, std::uint16_t index, std::uint8_t sub_index,
                            std::uint32_t code);
std::string emcy_frame(std::uint8_t node, std::uint16_t code, std::uint8_t error_register);

}  // namespace drivecheck::reference_drive::testing
