// EMCY producer (CiA 301 §7.2.7): a device reports errors as they occur and when they are
// repaired, keeps the error register 1001h and the pre-defined error field 1003h.
//
// EMCY frame, CAN-ID from 1014h (default 80h + node), DLC 8 (see emcy.hpp):
//   bytes 0..1  error code, UNSIGNED16 little-endian; 0000h = error reset / no error
//   byte 2      error register 1001h after the event
//   bytes 3..7  manufacturer-specific error field (as given to raise(); zero for resets)
//
// The EMCY state machine (CiA 301 §7.2.7.2, "error free" / "error occurred"):
//  - raise(code): the code becomes active, is pushed onto the history (1003h, newest first) and
//    an EMCY with that code is queued. Raising a code that is already active changes nothing.
//  - clear(code): the code is no longer active. When it was the last active error, an EMCY
//    "error reset" (0000h, error register as it now is) is queued; while other errors remain,
//    nothing is sent (CiA 301 allows, but does not require, an error reset then).
//  - 1001h: bit 0 (generic) is set whenever any error is active; the other bits are the OR of
//    the register bits given with the active errors.
//
// Inhibit time 1015h (UNSIGNED16, 100 µs units; 0 = none): after an EMCY is sent, the next one
// waits until the inhibit time has passed. EMCYs raised meanwhile are queued in order, not lost,
// and sent one per inhibit time (queue limit kEmcyQueueLimit; beyond it the oldest queued EMCY
// is dropped and counted in dropped()).
//
// When EMCY is not produced nothing is sent and queued EMCYs are dropped (counted in
// suppressed()), while 1001h and 1003h keep being maintained:
//  - 1014h bit 31 = 1 (EMCY not valid);
//  - the NMT state does not allow EMCY (Stopped, Initialisation; CiA 301 §7.3.2.2 table): the
//    owner calls set_enabled(false).
//
// 1014h COB-ID EMCY, UNSIGNED32 rw, default 80h + node-ID:
//   bit 31 = 1 not valid, bit 30 reserved (0), bit 29 = 1 29-bit CAN-ID, bits 28..0 CAN-ID.
//   SDO write rules (write validator):
//    - bits 28..11 set for an 11-bit CAN-ID, or bit 30 set               -> 06090030h
//    - a valid COB-ID on a restricted CAN-ID (CiA 301 §7.3.5, cob_id.hpp)  -> 06090030h
//    - changing bits 0..29 while the EMCY is valid (bit 31 = 0 before and after the write);
//      the COB-ID is changed by first setting bit 31 (CiA 301 §7.5.2, 1014h)    -> 06090030h
// 1015h inhibit time EMCY, UNSIGNED16 rw, 100 µs, default 0.
// 1001h error register, UNSIGNED8 ro, PDO-mappable.
// 1003h pre-defined error field, ARRAY:
//   sub 00h  number of errors recorded, UNSIGNED8 rw: writing 00h deletes the whole history;
//            writing any other value is refused with 06090030h invalid value (CiA 301 §7.5.2,
//            1003h)
//   sub 01h..N  UNSIGNED32 ro: bits 15..0 error code, bits 31..16 additional information (0
//            here); sub 01h is the newest error. Reading a sub-index above the number of
//            errors recorded is refused with 08000024h no data available (CiA 301 names no
//            code for this; 08000024h is the code for "no data available", and what the
//            object dictionary model documents for it).
//
// EmcyProducer is pure: the application raises and clears errors with the current time; on_time
// returns the EMCY frames when the inhibit time allows. DeviceServices runs it on a bus and
// mirrors 1001h/1003h into the object dictionary.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/emcy.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kErrorRegisterIndex = 0x1001;
inline constexpr std::uint16_t kPreDefinedErrorFieldIndex = 0x1003;
inline constexpr std::uint16_t kEmcyCobIdIndex = 0x1014;
inline constexpr std::uint16_t kEmcyInhibitTimeIndex = 0x1015;
inline constexpr std::size_t kEmcyQueueLimit = 64;

struct ActiveError {
  std::uint16_t code = 0;
  std::uint8_t register_bits = 0;
  std::array<std::uint8_t, 5> manufacturer{};
  friend bool operator==(const ActiveError&, const ActiveError&) = default;
};

class EmcyProducer {
 public:
  // COB-ID 80h + node, valid; no inhibit time; a history of `history_size` entries (1..254).
  // Precondition: node_id 1..127.
  explicit EmcyProducer(std::uint8_t node_id = 1, std::size_t history_size = 8);

  // 1014h. Not valid: queued EMCYs are dropped.
  void set_cob_id(const EmcyCobIdEntry& cob_id);
  const EmcyCobIdEntry& cob_id() const { return cob_id_; }
  // 1015h as a duration (100 µs × value). Applies from the next EMCY on.
  void set_inhibit_time(can::Duration inhibit) { inhibit_ = inhibit; }
  can::Duration inhibit_time() const { return inhibit_; }
  // Whether the NMT state allows EMCY. false drops queued EMCYs.
  void set_enabled(bool enabled);
  bool enabled() const { return enabled_; }

  // The application's API. raise() returns false (and does nothing) for code 0000h and for a
  // code that is already active; clear() returns false for a code that is not active.
  bool raise(std::uint16_t code, std::uint8_t register_bits,
             const std::array<std::uint8_t, 5>& manufacturer, can::TimePoint now);
  bool raise(EmcyCode code, std::uint8_t register_bits, can::TimePoint now) {
    return raise(static_cast<std::uint16_t>(code), register_bits, {}, now);
  }
  bool clear(std::uint16_t code, can::TimePoint now);
  bool clear(EmcyCode code, can::TimePoint now) {
    return clear(static_cast<std::uint16_t>(code), now);
  }

  // Reset application: no active error, empty history, nothing queued, inhibit timer off.
  void reset();
  // 1003h sub 00h := 0.
  void clear_history() { history_.clear(); }
  // Fault injection (false only for the reference drive's emcy-history-full-not-shifted): a
  // full history takes no new entries (CiA 301 §7.5.2.4: the oldest drops out).
  void set_history_shift_when_full(bool shift) { shift_when_full_ = shift; }
  // Reset communication: queued EMCYs are dropped, the inhibit timer restarts; errors stay.
  void discard_pending();

  // The next queued EMCY if the inhibit time allows it at `now` (at most one per call).
  std::optional<can::Frame> on_time(can::TimePoint now);
  // When on_time() must be called next; kForever when nothing is queued.
  can::TimePoint next_deadline() const;

  std::uint8_t error_register() const;
  bool is_active(std::uint16_t code) const;
  std::span<const ActiveError> active() const { return active_; }
  // 1003h sub 01h.. (newest first).
  std::span<const std::uint32_t> history() const { return history_; }
  std::size_t history_size() const { return history_size_; }
  std::size_t queued() const { return queue_.size(); }
  std::uint64_t sent() const { return sent_; }
  std::uint64_t dropped() const { return dropped_; }
  std::uint64_t suppressed() const { return suppressed_; }

 private:
  struct Pending {
    Emcy message;
    can::TimePoint queued_at;
  };
  bool producing() const { return enabled_ && cob_id_.valid; }
  void enqueue(const Emcy& message, can::TimePoint now);
  void drop_queue();

  EmcyCobIdEntry cob_id_;
  can::Duration inhibit_{0};
  bool enabled_ = true;
  std::size_t history_size_;
  bool shift_when_full_ = true;  // set_history_shift_when_full
  std::vector<ActiveError> active_;
  std::vector<std::uint32_t> history_;
  std::deque<Pending> queue_;
  std::optional<can::TimePoint> last_sent_;
  std::uint64_t sent_ = 0;
  std::uint64_t dropped_ = 0;
  std::uint64_t suppressed_ = 0;
};

struct EmcyObjectOptions {
  std::uint8_t history_size = 8;  // 1003h sub-entries, 1..254
};

// Adds 1001h, 1003h, 1014h and 1015h with the rules above (1014h default $NODEID+80h).
// Errors: an index is taken, history_size out of range.
Expected<void, std::string> add_emcy_producer_objects(ObjectDictionary& od,
                                                      const EmcyObjectOptions& options = {});

// Zeroes 1003h (sub 00h and every entry), application-side: what a write of 0 to 1003h sub 00h
// does when no EmcyProducer keeps the history (the observer add_emcy_producer_objects installs).
void clear_pre_defined_error_field(ObjectDictionary& od);

// Writes 1001h and 1003h (sub 00h and every sub-entry) from the producer, application-side (no
// hooks). Objects that do not exist are skipped.
void mirror_error_objects(const EmcyProducer& producer, ObjectDictionary& od);

// 1014h decoded, and 1015h as a duration; nullopt when the object does not exist (or 1014h holds
// a value that does not decode).
std::optional<EmcyCobIdEntry> configured_emcy_cob_id(const ObjectDictionary& od);
std::optional<can::Duration> configured_emcy_inhibit_time(const ObjectDictionary& od);

}  // namespace drivecheck::cia301
