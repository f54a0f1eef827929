// NMT master (CiA 301 §7.2.8.2.1): sends node-control commands and tracks the NMT state of
// every node from what the nodes say on 700h + node (boot-up, heartbeat, guarding responses).
//
// Frames it sends: NMT node control, see nmt.hpp (000h, DLC 2: CS, node).
// Frames it reads: NMT error control, see error_control.hpp (700h + node, DLC 1):
//   00h boot-up; bits 6..0 = 04h stopped, 05h operational, 7Fh pre-operational (bit 7 is the
//   guarding toggle and is ignored here).
//
// NMT commands are not acknowledged (Festo 000_33c1d912b8b6010a.txt L1348: "The controllers do
// not acknowledge the NMT commands. Successful completion can only be determined indirectly"):
// the master records the state it commanded and the state the node last reported, and
// in_commanded_state() compares them. Festo also asks for a gap of at least 2 position-
// controller cycles between NMT frames (L1403): spacing commands is the caller's business.
//
// NmtMaster is pure: fed frames and times. NmtMasterPort is the thin adapter over a can::Bus.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <system_error>

#include "protocol/can/bus.hpp"
#include "protocol/cia301/nmt.hpp"

namespace drivecheck::cia301 {

enum class NmtEventKind : std::uint8_t {
  boot_up,        // the node sent its boot-up message (state is boot_up; pre-operational next)
  state_changed,  // the node reports another state than before (or its first state)
  invalid_frame,  // a frame on 700h + node that is not valid error control (reason given)
};

struct NmtEvent {
  NmtEventKind kind = NmtEventKind::state_changed;
  std::uint8_t node = 0;
  can::TimePoint time{};
  std::optional<NmtState> state;     // reported state (boot_up for a boot-up)
  std::optional<NmtState> previous;  // what the node reported before, if anything
  std::string reason;                // invalid_frame only
};

class NmtMaster {
 public:
  struct NodeInfo {
    std::optional<NmtState> reported;   // last state the node reported (boot_up after a boot-up)
    std::optional<NmtState> commanded;  // state the last command addressed to it leads to
    std::optional<can::TimePoint> last_seen;
    unsigned boot_ups = 0;
  };

  // The frame of a command, and the bookkeeping: node (0 = all) now has a commanded state.
  // Precondition: node <= 127.
  can::Frame command(NmtCommand command, std::uint8_t node);

  // Feeds a received frame: error-control frames of nodes 1..127 update the table; any other
  // frame is ignored (nullopt). Remote requests (guarding polls of some master) are ignored.
  std::optional<NmtEvent> on_frame(const can::Frame& frame, can::TimePoint time);

  // Precondition for the node accessors: node 1..127.
  const NodeInfo& node(std::uint8_t node) const;
  std::optional<NmtState> state(std::uint8_t node) const { return this->node(node).reported; }
  // Whether the node's last report is the state its last command leads to (false when either
  // is unknown; a boot-up after a reset command counts as not yet there).
  bool in_commanded_state(std::uint8_t node) const;
  // Forget everything about a node (e.g. when it is removed from the network).
  void forget(std::uint8_t node);

 private:
  std::array<NodeInfo, 128> nodes_{};
};

// NmtMaster on a bus port. Frames reach it through handle(): call it from the port's frame
// handler (together with the other services sharing the port), or use wait_for_state(), which
// pulls frames with receive() and so must not be used while a frame handler is set.
class NmtMasterPort {
 public:
  using EventHandler = std::function<void(const NmtEvent&)>;

  explicit NmtMasterPort(can::Bus& bus, EventHandler on_event = {});

  // Sends the command; fails with the bus's error (or BusError::invalid_frame for node > 127).
  std::error_code send(NmtCommand command, std::uint8_t node);
  void handle(const can::TimedFrame& frame);
  // Receives frames until the node reports `state` or `deadline` passes; true when it did.
  // Frames of other kinds are consumed (and still fed to the master).
  bool wait_for_state(std::uint8_t node, NmtState state, can::TimePoint deadline);

  NmtMaster& master() { return master_; }
  const NmtMaster& master() const { return master_; }

 private:
  can::Bus& bus_;
  EventHandler on_event_;
  NmtMaster master_;
};

}  // namespace drivecheck::cia301
