// SYNC producer (CiA 301 §7.2.5): sends SYNC every communication cycle period (1006h), with the
// optional counter of 1019h.
//
// SYNC frame, CAN-ID 080h (1005h), see sync.hpp:
//   1019h = 0:      DLC 0
//   1019h = 2..240: DLC 1, byte 0 counter: 1 in the first SYNC after start, +1 per SYNC, and
//                   1 again after the SYNC that carried the overflow value
//
// Timing: SYNC k is due at start + k × period exactly (no drift from late calls: a SYNC sent
// late does not move the next one). When on_time() is called more than a period late, the
// missed SYNCs are skipped, not sent in a burst, and counted in missed(); the counter counts
// SYNCs on the bus, so it continues from the last SYNC sent.
//
// SyncProducer is pure; SyncProducerPort sends its frames on a can::Bus from a bus timer.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <system_error>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/sync.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

struct SyncProducerConfig {
  can::Duration period{0};            // 1006h, > 0
  std::uint8_t counter_overflow = 0;  // 1019h: 0 or 2..240
  std::uint32_t cob_id = kSyncCobId;  // 1005h CAN-ID (29-bit when above 7FFh)
};

class SyncProducer {
 public:
  // Errors: period not positive, 1019h value reserved (1, 241..255), CAN-ID above 29 bits.
  static Expected<SyncProducer, std::string> create(const SyncProducerConfig& config);

  // The first SYNC is due at `first`; the counter restarts at 1.
  void start(can::TimePoint first);
  void stop();
  bool running() const { return next_ != can::kForever; }

  // The SYNC due at or before `now`, if any (at most one per call).
  std::optional<can::Frame> on_time(can::TimePoint now);
  // Drops the SYNC due at or before `now` (and any missed before it) without sending it: its
  // predecessor is still waiting for the bus. Counted in missed(); the counter does not move,
  // since it counts SYNCs on the bus. Returns whether one was due.
  bool skip_due(can::TimePoint now);
  can::TimePoint next_deadline() const { return next_; }

  // Next SYNC carries counter 1 (CiA 301 asks for this when the producer's NMT state changes
  // to operational or pre-operational).
  void reset_counter() { counter_ = 1; }
  const SyncProducerConfig& config() const { return config_; }
  std::uint64_t sent() const { return sent_; }
  std::uint64_t missed() const { return missed_; }

 private:
  explicit SyncProducer(const SyncProducerConfig& config) : config_(config) {}

  SyncProducerConfig config_;
  can::TimePoint start_ = can::kForever;
  can::TimePoint next_ = can::kForever;
  std::uint64_t slot_ = 0;  // index of the next SYNC on the grid start + k × period
  std::uint8_t counter_ = 1;
  std::uint64_t sent_ = 0;
  std::uint64_t missed_ = 0;
};

class SyncProducerPort {
 public:
  SyncProducerPort(can::Bus& bus, SyncProducer producer);
  ~SyncProducerPort();
  SyncProducerPort(const SyncProducerPort&) = delete;
  SyncProducerPort& operator=(const SyncProducerPort&) = delete;

  // First SYNC at `first` (default: now).
  void start(std::optional<can::TimePoint> first = std::nullopt);
  void stop();

  const SyncProducer& producer() const { return producer_; }
  SyncProducer& producer() { return producer_; }
  std::error_code last_send_error() const { return last_send_error_; }

 private:
  void arm();

  can::Bus& bus_;
  SyncProducer producer_;
  can::TimerId timer_ = can::kNoTimer;
  std::error_code last_send_error_;
};

}  // namespace drivecheck::cia301
