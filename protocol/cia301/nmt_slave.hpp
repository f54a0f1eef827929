// NMT slave (CiA 301 §7.3.2): the NMT state machine of a device, the services each NMT state
// allows, and the error behaviour object 1029h.
//
// NMT node control frame the slave obeys (see nmt.hpp), CAN-ID 000h, DLC 2:
//   byte 0  CS    01h start, 02h stop, 80h enter pre-operational, 81h reset node,
//                 82h reset communication
//   byte 1  node  this slave's node-ID, or 0 = all nodes (broadcast)
// Ignored, without any answer (NMT is never acknowledged): frames on other identifiers, remote
// and 29-bit frames, a DLC other than 2, an unknown CS, a node-ID above 127, another node's
// node-ID, and every command while the slave is initialising.
//
// Boot-up frame the slave sends when initialisation ends (see error_control.hpp),
// CAN-ID 700h + node, DLC 1:
//   byte 0  00h
//
// The state machine (CiA 301 §7.3.2.1, NMT state diagram; transition numbers as printed there,
// where one number group covers the same command from different states):
//
//   power on ──(1)──> Initialisation ──(2) boot-up message──> Pre-operational
//   start remote node            (3),(6)           -> Operational
//   enter pre-operational        (4),(7)           -> Pre-operational
//   stop remote node             (5),(8)           -> Stopped
//   reset node                   (9),(10),(11)     -> Initialisation: reset application, then
//                                                     reset communication, then (2)
//   reset communication          (12),(13),(14)    -> Initialisation: reset communication,
//                                                     then (2)
// A command that leads to the state the slave is already in changes nothing.
//
// Initialisation is represented by NmtState::boot_up. The slave does not reset anything itself:
// a reset command returns NmtSlaveAction::reset_node / reset_communication and leaves the slave
// in Initialisation; its owner reloads the object dictionary (reset node: application and
// communication parameters back to their stored values; reset communication: communication
// parameters 1000h-1FFFh only) and then calls finish_initialisation(), which returns the boot-up
// frame and enters Pre-operational. DeviceServices (device_services.hpp) does exactly this and
// tells its owner through its on_reset handler.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

// The communication services whose availability the NMT state decides.
enum class NmtService : std::uint8_t {
  pdo,            // PDO reception and transmission
  sdo,            // SDO server
  sync,           // SYNC consumption and production
  time,           // TIME consumption and production
  emcy,           // EMCY production
  boot_up,        // the boot-up message
  node_control,   // NMT node control commands (obeying them)
  error_control,  // heartbeat production/consumption, node guarding
};
std::string_view to_string(NmtService service);

// One row of the CiA 301 §7.3.2.2 table "NMT states and communication objects": where a
// service runs. Initialisation only sends the boot-up message.
struct NmtServiceRow {
  NmtService service;
  bool initialisation;
  bool pre_operational;
  bool operational;
  bool stopped;
};

inline constexpr std::array<NmtServiceRow, 8> kNmtServiceTable{{
    // service                   init   pre-op  op     stopped
    {NmtService::pdo, false, false, true, false},
    {NmtService::sdo, false, true, true, false},
    {NmtService::sync, false, true, true, false},
    {NmtService::time, false, true, true, false},
    {NmtService::emcy, false, true, true, false},
    {NmtService::boot_up, true, false, false, false},
    {NmtService::node_control, false, true, true, true},
    {NmtService::error_control, false, true, true, true},
}};

// Whether `service` may run in `state` (NmtState::boot_up = Initialisation).
constexpr bool nmt_allows(NmtState state, NmtService service) {
  for (const auto& row : kNmtServiceTable) {
    if (row.service != service) continue;
    switch (state) {
      case NmtState::boot_up:
        return row.initialisation;
      case NmtState::pre_operational:
        return row.pre_operational;
      case NmtState::operational:
        return row.operational;
      case NmtState::stopped:
        return row.stopped;
    }
  }
  return false;
}

// What a frame or a local command did to the slave.
enum class NmtSlaveAction : std::uint8_t {
  ignored,              // not for this slave, or malformed (see NmtSlaveResult::ignored_because)
  unchanged,            // a valid command for this slave that leads to its current state
  state_changed,        // start / stop / enter pre-operational changed the state
  reset_node,           // now initialising: reset application + communication, then
                        // finish_initialisation()
  reset_communication,  // now initialising: reset communication, then finish_initialisation()
};
std::string_view to_string(NmtSlaveAction action);

enum class NmtIgnoreReason : std::uint8_t {
  none,
  not_nmt,       // another identifier, 29-bit, remote or error frame
  malformed,     // CAN-ID 000h but DLC ≠ 2, unknown CS or node-ID above 127
  other_node,    // addressed to another node
  initialising,  // the slave is in Initialisation and obeys no command
};

struct NmtSlaveResult {
  NmtSlaveAction action = NmtSlaveAction::ignored;
  NmtState before = NmtState::boot_up;
  NmtState after = NmtState::boot_up;
  std::optional<NmtCommand> command;
  bool broadcast = false;  // the command addressed node 0
  NmtIgnoreReason ignored_because = NmtIgnoreReason::none;

  bool changed() const { return before != after; }
};

class NmtSlave {
 public:
  // Power on, transition (1): the slave is in Initialisation until finish_initialisation().
  // Precondition: node_id 1..127.
  explicit NmtSlave(std::uint8_t node_id) : node_id_(node_id) {}

  NmtState state() const { return state_; }
  bool initialising() const { return state_ == NmtState::boot_up; }
  std::uint8_t node_id() const { return node_id_; }
  bool allows(NmtService service) const { return nmt_allows(state_, service); }

  // Transition (2): ends Initialisation with the boot-up message of `node_id` (which may differ
  // from before: reset communication applies a new node-ID) and enters Pre-operational.
  // nullopt, and no change, when the slave is not initialising. Precondition: node_id 1..127.
  std::optional<can::Frame> finish_initialisation(std::uint8_t node_id);

  // Power cycle: back to Initialisation (transition (1)), whatever the state was.
  void restart() { state_ = NmtState::boot_up; }

  // A frame from the bus: NMT node control for this node or for all nodes is obeyed, anything
  // else is ignored (see the file comment).
  NmtSlaveResult on_frame(const can::Frame& frame);

  // A command from local control (the application, or the error behaviour of 1029h): obeyed as
  // if the master had sent it to this node; ignored while initialising.
  NmtSlaveResult apply(NmtCommand command);

 private:
  NmtSlaveResult obey(NmtCommand command, bool broadcast);

  std::uint8_t node_id_;
  NmtState state_ = NmtState::boot_up;
};

// ---------------------------------------------------------------------------------------------
// 1029h error behaviour (CiA 301 §7.5.2, object 1029h), ARRAY of UNSIGNED8:
//   sub 00h  highest sub-index supported, ro, 01h
//   sub 01h  communication error (heartbeat consumer timeout, life guarding event, bus-off), rw:
//              00h  change to Pre-operational, only if currently Operational (default)
//              01h  no change of the NMT state
//              02h  change to Stopped
//              03h..7Fh  reserved: refused with 06090030h (invalid value)
//              80h..FFh  manufacturer-specific: accepted, and handled here as "no change"
inline constexpr std::uint16_t kErrorBehaviourIndex = 0x1029;

enum class CommunicationErrorBehaviour : std::uint8_t {
  pre_operational = 0x00,
  no_change = 0x01,
  stopped = 0x02,
};

// The local NMT command a communication error leads to in `state` under the 1029h sub 01h value
// `behaviour`; nullopt when the state does not change.
std::optional<NmtCommand> communication_error_command(NmtState state, std::uint8_t behaviour);

// Adds 1029h (sub 00h and sub 01h) with the rules above. Errors: the index is taken.
Expected<void, std::string> add_error_behaviour_objects(ObjectDictionary& od);

}  // namespace drivecheck::cia301
