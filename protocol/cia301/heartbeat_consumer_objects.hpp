// The device side of heartbeat consumption (CiA 301 §7.2.8.3.2.2): object 1016h, whose entries
// configure the HeartbeatConsumer state machine of heartbeat_consumer.hpp (the same consumer a
// master uses; a device runs it through DeviceServices).
//
// 1016h consumer heartbeat time, ARRAY:
//   sub 00h       highest sub-index supported, UNSIGNED8 ro (1..127)
//   sub 01h..N    UNSIGNED32 rw, default 0:
//                   bits 31..24  reserved (0)
//                   bits 23..16  node-ID of the monitored heartbeat producer
//                   bits 15..0   consumer heartbeat time, ms
//                 node-ID 0 or time 0: the entry is not used.
//
// SDO write rules (write validator on every sub-entry):
//  - reserved bits 31..24 set, or a node-ID above 127      -> 06090030h invalid value
//  - a used entry (node-ID 1..127, time ≠ 0) naming the same node-ID as another used entry
//    -> 06040043h general parameter incompatibility (CiA 301 §7.5.2, 1016h: "an attempt to
//       configure several consumer heartbeat times unequal 0 for the same node-ID" is answered
//       with this abort)
// A successful write takes effect at once through the owner's write observer (DeviceServices:
// the node's monitoring restarts and waits for its next heartbeat).
//
// What the owner turns a timeout into (DeviceServices): EMCY 8130h "life guard error or
// heartbeat error" and the communication error behaviour of 1029h sub 01h (nmt_slave.hpp).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "protocol/cia301/heartbeat_consumer.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kConsumerHeartbeatTimeIndex = 0x1016;

// Adds 1016h with `entries` sub-entries (1..127). Errors: the index is taken, entries out of
// range.
Expected<void, std::string> add_heartbeat_consumer_objects(ObjectDictionary& od,
                                                           std::uint8_t entries = 4);

// The used entries of 1016h, in sub-index order (empty when the object does not exist). Entries
// whose value is invalid (possible only through application-side assign) are left out.
std::vector<ConsumerHeartbeatEntry> consumer_heartbeat_entries(const ObjectDictionary& od);

// Brings `consumer` in line with 1016h, given the entries applied before (`previous`, as
// returned by the last call; empty the first time): nodes no longer named are released, new or
// changed entries are monitored afresh (waiting for the node's next heartbeat), unchanged
// entries keep running. Returns the entries now applied.
std::vector<ConsumerHeartbeatEntry> configure_heartbeat_consumer(
    HeartbeatConsumer& consumer, const ObjectDictionary& od,
    std::span<const ConsumerHeartbeatEntry> previous);

}  // namespace drivecheck::cia301
