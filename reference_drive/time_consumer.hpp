// The reference drive's TIME consumer (CiA 301 §7.2.6, object 1012h §7.5.2.15): a pure state
// machine over the object dictionary, fed frames and the NMT state.
//
// 1012h (dictionary.hpp): bit 31 = 1 the device consumes TIME, bit 30 produce, bit 29 frame,
// bits 10..0 the CAN-ID. The reference drive is a consumer only, on 11-bit CAN-IDs: a write
// with bit 30 or bit 29 set, with bits 28..11 not 0, or with a restricted CAN-ID (CiA 301
// §7.3.5, protocol/cia301/cob_id.hpp) is refused with 06090030h (invalid value). CiA 301 lets
// a device that cannot produce TIME refuse bit 30, as it names for 1005h's bit 30.
//
// Consumed: a TIME frame (protocol/cia301/time.hpp: DLC 6, reserved bits 0, ms within the day)
// on the CAN-ID of 1012h while bit 31 is 1 and the NMT state is Pre-operational or Operational
// (CiA 301 §7.3.2.2, Table 'NMT states and communication objects': TIME is no service of
// Stopped). It sets 2F01h sub 01h (ms after midnight) and 02h (days since 1984-01-01) and
// counts 2F01h sub 03h. An invalid TIME frame is dropped. A reset communication sets 2F01h
// to 0.
#pragma once

#include <cstdint>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/cia301/object_dictionary.hpp"

namespace drivecheck::reference_drive {

struct TimeConsumerOptions {
  // Named deviations (deviations.inc): checks off, or bit 31 not looked at.
  bool refuse_restricted = true;      // time-restricted-cob-id-accepted: false
  bool refuse_producer_frame = true;  // time-cob-id-bits-not-checked: false (bits 30, 29)
  bool consumer_bit_ignored = false;  // time-consumer-bit-ignored: true
};

class TimeConsumer {
 public:
  // Binds 1012h's validator; the dictionary must outlive the consumer. Without 1012h or 2F01h
  // the consumer does nothing (present() false).
  TimeConsumer(cia301::ObjectDictionary& od, TimeConsumerOptions options);

  bool present() const { return cob_id_ != nullptr && received_ != nullptr; }
  // Whether `frame` is on 1012h's CAN-ID (then no other service takes it); consumes it when
  // the state and bit 31 allow.
  bool on_frame(const can::Frame& frame, cia301::NmtState state);
  // Reset communication: 2F01h back to 0.
  void reset();

 private:
  cia301::ObjectDictionary& od_;
  TimeConsumerOptions options_;
  cia301::Entry* cob_id_ = nullptr;
  cia301::Object* received_ = nullptr;
};

}  // namespace drivecheck::reference_drive
