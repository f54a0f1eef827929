// SYNC consumer of a device (CiA 301 §7.2.5), and the device's SYNC objects 1005h, 1006h,
// 1007h and 1019h (for consuming, and for producing with the SyncProducer of sync_producer.hpp).
//
// SYNC frame, CAN-ID from 1005h (default 080h), see sync.hpp:
//   1019h = 0:       DLC 0
//   1019h = 2..240:  DLC 1, byte 0 counter 1..1019h
// A SYNC whose length does not match 1019h (DLC 1 while 1019h = 0, DLC 0 or 2..8 while
// 1019h ≠ 0) is not taken as a SYNC: the consumer reports wrong_length, and the owner raises
// EMCY 8240h "unexpected SYNC data length" (CiA 301 Table 21; DeviceServices clears it again
// with the next SYNC of the right length). Remote frames on the SYNC CAN-ID are ignored.
//
// Synchronous window 1007h (µs, 0 = none): after each SYNC, synchronous PDOs may be sent and
// are valid only until the window closes; in_window() answers that for the PDO engine, and the
// consumer reports window_closed at SYNC + window (when synchronous PDOs not yet sent are to be
// discarded).
//
// 1005h COB-ID SYNC, UNSIGNED32 rw, default 00000080h:
//   bit 31 don't care, bit 30 gen (1 = this device produces SYNC), bit 29 29-bit CAN-ID,
//   bits 28..0 CAN-ID.
//   SDO write rules (write validator; CiA 301 §7.5.2, 1005h):
//    - bits 28..11 set for an 11-bit CAN-ID                                 -> 06090030h
//    - bit 30 set on a device that cannot produce SYNC                      -> 06090030h
//    - a restricted 11-bit CAN-ID (CiA 301 §7.3.5)                          -> 06090030h
//    - bits 0..29 changed while the device produces SYNC (bit 30 = 1 before the write)
//                                                                           -> 06090030h
// 1006h communication cycle period, UNSIGNED32 rw, µs, default 0 (0 = no SYNC produced).
// 1007h synchronous window length, UNSIGNED32 rw, µs, default 0 (0 = no window).
// 1019h synchronous counter overflow value, UNSIGNED8 rw, default 0:
//    - 1 or 241..255 (reserved)                                              -> 06090030h
//    - another value while 1006h ≠ 0 (CiA 301 §7.5.2, 1019h: the value shall only be changed
//      while the communication cycle period is 0)      -> 08000022h (present device state)
//
// SyncConsumer is pure; DeviceServices feeds it frames while the NMT state allows SYNC
// (Pre-operational, Operational) and runs the device's SyncProducer.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sync.hpp"
#include "protocol/cia301/sync_producer.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kSyncCobIdIndex = 0x1005;
inline constexpr std::uint16_t kCommunicationCyclePeriodIndex = 0x1006;
inline constexpr std::uint16_t kSyncWindowLengthIndex = 0x1007;
inline constexpr std::uint16_t kSyncCounterOverflowIndex = 0x1019;

enum class SyncConsumerEventKind : std::uint8_t {
  sync,           // a SYNC of the configured length (counter given when 1019h ≠ 0)
  wrong_length,   // a frame on the SYNC CAN-ID whose length does not match 1019h
  window_closed,  // the synchronous window of the last SYNC has ended
};
std::string_view to_string(SyncConsumerEventKind kind);

struct SyncConsumerEvent {
  SyncConsumerEventKind kind = SyncConsumerEventKind::sync;
  can::TimePoint time{};
  std::optional<std::uint8_t> counter;  // sync with 1019h ≠ 0
  std::uint8_t dlc = 0;                 // DLC of the frame (sync, wrong_length)
  friend bool operator==(const SyncConsumerEvent&, const SyncConsumerEvent&) = default;
};

struct SyncConsumerConfig {
  SyncCobIdEntry cob_id{};            // 1005h
  std::uint8_t counter_overflow = 0;  // 1019h
  can::Duration window{0};            // 1007h; 0 = none
  friend bool operator==(const SyncConsumerConfig&, const SyncConsumerConfig&) = default;
};

class SyncConsumer {
 public:
  // Applies at once; an open window keeps its start and takes the new length.
  void configure(const SyncConsumerConfig& config) { config_ = config; }
  const SyncConsumerConfig& config() const { return config_; }

  // A frame from the bus (or the device's own SYNC); nullopt for frames that are not on the
  // SYNC CAN-ID.
  std::optional<SyncConsumerEvent> on_frame(const can::Frame& frame, can::TimePoint now);
  // window_closed when the window of the last SYNC ends at or before `now`.
  std::optional<SyncConsumerEvent> on_time(can::TimePoint now);
  can::TimePoint next_deadline() const;

  // Whether synchronous PDOs may still be sent at `now`: a SYNC was received and the window
  // (if any) has not ended. Always false before the first SYNC.
  bool in_window(can::TimePoint now) const;
  std::optional<can::TimePoint> last_sync() const { return last_sync_; }
  std::optional<std::uint8_t> last_counter() const { return last_counter_; }

  // Reset communication: forget the last SYNC.
  void reset();

  std::uint64_t received() const { return received_; }
  std::uint64_t wrong_lengths() const { return wrong_lengths_; }

 private:
  SyncConsumerConfig config_;
  std::optional<can::TimePoint> last_sync_;
  std::optional<std::uint8_t> last_counter_;
  bool window_open_ = false;
  std::uint64_t received_ = 0;
  std::uint64_t wrong_lengths_ = 0;
};

struct SyncObjectOptions {
  bool producer_supported = true;  // whether 1005h bit 30 may be set
};

// Adds 1005h, 1006h, 1007h and 1019h with the rules above. Errors: an index is taken.
Expected<void, std::string> add_sync_objects(ObjectDictionary& od,
                                             const SyncObjectOptions& options = {});

// The consumer configuration from 1005h/1007h/1019h (missing objects: their defaults; a 1005h
// value that does not decode: the default COB-ID 080h).
SyncConsumerConfig sync_consumer_config(const ObjectDictionary& od);

// The producer configuration when 1005h bit 30 is set and 1006h ≠ 0; nullopt otherwise.
std::optional<SyncProducerConfig> sync_producer_config(const ObjectDictionary& od);

}  // namespace drivecheck::cia301
