// An emulated slave without application: an ESC (esc.hpp) and its EtherCAT state machine
// (al_state_machine.hpp), tied together the way a slave's firmware ties them, as a device on
// the simulated segment (sim_segment.hpp). The mailbox and CoE layer and the drive attach to
// it through EscSlaveConfig (check, on_events); the full slave front end comes later.
//
// What it does on every frame (before the ESC processes it, so the master reads the state as
// of the frame's arrival):
//  - lets the ESC's time pass; a process data watchdog expiry in OP drops the state to
//    SAFEOP + error, AL status code 001Bh (ETG.1000.6; AlStateMachine::sm_watchdog_expired);
// and after it:
//  - a write to AL control is read from the PDI side and handed to the state machine; AL
//    status (0130h) and AL status code (0134h) are written from its result;
//  - on_events gets every other event (mailbox written, repeat request, ...).
//
// The checks of the state machine's transitions (AlRequirement), against the SII image the
// ESC carries (the emulated slave's choices; a device may check less or more):
//  - mailbox (IP): SM0 enabled in mailbox mode, ECAT writes, at the SII's standard receive
//    mailbox offset and size; SM1 the same for ECAT reads and the standard send mailbox;
//    else 0016h (invalid mailbox configuration). A SII without mailbox (size 0) needs none.
//  - bootstrap (IB, when EscSlaveConfig::bootstrap): the same against the SII's bootstrap
//    mailbox words (14h..17h); else 0015h.
//  - process_data (PS): every SII SyncM entry of type outputs (3) / inputs (4) with a length
//    has its SM enabled in buffered mode with the right direction, start and length; else
//    001Dh (invalid output configuration) / 001Eh (invalid input configuration).
//  - then EscSlaveConfig::check (the CoE layer's PDO assignment checks, a personality's
//    rules), whose code refuses the transition when it is not no_error.
#pragma once

#include <functional>
#include <optional>

#include "protocol/ethercat/al_state_machine.hpp"
#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/sii.hpp"
#include "protocol/ethercat/sim_segment.hpp"

namespace drivecheck::ethercat {

class EscSlave;

struct EscSlaveConfig {
  EscConfig esc;  // esc.sii: the SII image (build_sii); the checks read it
  bool bootstrap = false;
  // false: the built-in process data check (PS) is left out and `check` does it (a slave whose
  // PDO assignment is configurable: SM2/SM3 lengths follow 1C12h/1C13h, not the SII).
  bool check_process_data = true;
  // false is a fault for named deviations ("SM watchdog ignored"): an expired process data
  // watchdog leaves the state alone (no OP -> SAFEOP, no 001Bh).
  bool sm_watchdog_drops_op = true;
  std::function<AlStatusCode(const AlTransition&)> check;
  std::function<void(AlState from, AlState to)> on_state_change;
  std::function<void(EscSlave&, const EscEvents&)> on_events;
};

class EscSlave final : public SegmentDevice {
 public:
  explicit EscSlave(EscSlaveConfig config);

  void on_frame(std::span<std::uint8_t> frame, TimePoint arrival,
                std::optional<TimePoint> return_arrival) override;
  // Lets time pass without a frame (the watchdog); a scheduler may call it at next_deadline().
  void advance(TimePoint now);
  std::optional<TimePoint> next_deadline() const { return esc_.next_deadline(); }

  Esc& esc() { return esc_; }
  const Esc& esc() const { return esc_; }
  const AlStatus& al_status() const { return state_machine_.status(); }
  // The SII as parsed at construction (nullopt when it did not parse: no checks then).
  const std::optional<SiiImage>& sii() const { return sii_; }

  // The built-in check of one transition (without EscSlaveConfig::check), for tests and for a
  // CoE layer that wants to run it first.
  AlStatusCode builtin_check(const AlTransition& transition) const;

 private:
  void handle(const EscEvents& events);
  void publish();

  EscSlaveConfig config_;
  Esc esc_;
  AlStateMachine state_machine_;
  std::optional<SiiImage> sii_;
};

}  // namespace drivecheck::ethercat
