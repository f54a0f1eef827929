// The EtherCAT state machine (ESM) of a slave: INIT, PRE-OPERATIONAL, SAFE-OPERATIONAL,
// OPERATIONAL and BOOTSTRAP, requested by the master through AL control (0120h) and shown in
// AL status (0130h) and AL status code (0134h). Sources: ETG.1000.6 §6.4 (state machine and
// AL status codes, Table 11, as publicly documented); ESC datasheet Section I §10.1 and
// Section II §3.20-3.22 (register layouts); Festo CMMP-AS manual 000 §4.7 Tab. 4.10 (the
// transitions IP, PI, PS, SP, SO, OS, OP, SI, OI; BOOT not implemented there).
//
// Registers:
//   AL control 0120h  bits 3..0 requested state (1 INIT, 2 PREOP, 3 BOOT, 4 SAFEOP, 8 OP),
//                     bit 4 error indication acknowledge, bit 5 device identification
//   AL status  0130h  bits 3..0 current state, bit 4 error indication (the device has not
//                     entered the requested state or changed state by a local action),
//                     bit 5 device identification loaded
//   AL status code 0134h  why (al_status_codes.inc), 0 = no error
//
// Behaviour (a pure state machine; the ESC model and the slave front end feed it):
//  - a request for the current state changes nothing (a pending error stays);
//  - a transition in the table below is checked first: the injected `AlConfig::check` may
//    refuse it with an AL status code; a refused transition keeps the state and sets the
//    error indication and the code;
//  - a requested state not in the table from the current one: 0011h, state kept, error set;
//  - a value in bits 3..0 that is no state: 0012h, state kept, error set;
//  - BOOT when AlConfig::bootstrap is false: 0013h;
//  - while the error indication is set, a request without the acknowledge bit for a state
//    above the current one is ignored (ETG.1000.6 leaves the slave in its error state until
//    the master acknowledges; lower states are always reachable); with the acknowledge bit
//    the indication and the code are cleared first, then the request is handled;
//  - a local error (AlStateMachine::local_error) drops the state to the given lower one with
//    the error indication and the code, e.g. the SM watchdog: OP -> SAFEOP + error, 001Bh.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>

namespace drivecheck::ethercat {

enum class AlState : std::uint8_t { init = 1, preop = 2, boot = 3, safeop = 4, op = 8 };

// "INIT", "PREOP", "BOOT", "SAFEOP", "OP"; "state 5" for others.
std::string al_state_name(std::uint8_t value);
inline std::string al_state_name(AlState state) {
  return al_state_name(static_cast<std::uint8_t>(state));
}
// Order of the states for "above" and "below": INIT 0 < PREOP = BOOT 1 < SAFEOP 2 < OP 3.
int al_state_rank(AlState state);
// The state for a 4-bit value, nullopt for the values that name no state.
std::optional<AlState> al_state_from(std::uint8_t value);

enum class AlStatusCode : std::uint16_t {
#define DRIVECHECK_AL_STATUS_CODE(name, value, text, source) name = value,
#include "protocol/ethercat/al_status_codes.inc"
#undef DRIVECHECK_AL_STATUS_CODE
};

struct AlStatusCodeInfo {
  AlStatusCode code;
  std::string_view name;
  std::string_view text;
  std::string_view source;
};
std::span<const AlStatusCodeInfo> al_status_code_table();
std::optional<AlStatusCodeInfo> find_al_status_code(std::uint16_t value);
// "001Bh sync_manager_watchdog: Sync manager watchdog", or "…h (unknown AL status code)".
std::string describe_al_status_code(std::uint16_t value);
const std::error_category& al_status_category();
std::error_code make_error_code(AlStatusCode code);

// What a transition needs before it may be taken, for the injected check to test.
enum class AlRequirement : std::uint8_t {
  none,          // downward transitions: always allowed
  mailbox,       // IP: the mailbox SyncManagers (SM0/SM1) are configured validly
  bootstrap,     // IB: bootstrap mailbox configured (and BOOT supported)
  process_data,  // PS: the process data SyncManagers, FMMUs, PDO assignment and watchdog valid
  outputs,       // SO: valid outputs received (the slave may demand them before OP)
};

// One row of the transition table. `name` is the ETG / Festo abbreviation ("IP", "SO").
struct AlTransition {
  AlState from;
  AlState to;
  std::string_view name;
  AlRequirement requirement;
};

// The transitions a master may request (ETG.1000.6 §6.4.1; 000 Tab. 4.10 and Fig. 4.3);
// any other pair of distinct states is refused with 0011h.
inline constexpr std::array<AlTransition, 11> kAlTransitions = {{
    {AlState::init, AlState::preop, "IP", AlRequirement::mailbox},
    {AlState::init, AlState::boot, "IB", AlRequirement::bootstrap},
    {AlState::preop, AlState::init, "PI", AlRequirement::none},
    {AlState::preop, AlState::safeop, "PS", AlRequirement::process_data},
    {AlState::safeop, AlState::preop, "SP", AlRequirement::none},
    {AlState::safeop, AlState::op, "SO", AlRequirement::outputs},
    {AlState::safeop, AlState::init, "SI", AlRequirement::none},
    {AlState::op, AlState::safeop, "OS", AlRequirement::none},
    {AlState::op, AlState::preop, "OP", AlRequirement::none},
    {AlState::op, AlState::init, "OI", AlRequirement::none},
    {AlState::boot, AlState::init, "BI", AlRequirement::none},
}};

// The row for from -> to, or nullptr when the master may not request it.
const AlTransition* find_al_transition(AlState from, AlState to);

struct AlConfig {
  // Whether BOOT exists (000 §4.7: not on the CMMP-AS).
  bool bootstrap = false;
  // Checks a transition before it is taken: AlStatusCode::no_error allows it, any other code
  // refuses it with that code. Empty: every table transition is allowed. The CoE layer adds
  // its own checks here (PDO assignment valid, SM lengths match the mapping, ...).
  std::function<AlStatusCode(const AlTransition&)> check;
  // Called after a transition was taken (also after a local error dropped the state).
  std::function<void(AlState from, AlState to)> on_state_change;
};

struct AlStatus {
  AlState state = AlState::init;
  bool error = false;
  AlStatusCode code = AlStatusCode::no_error;

  // The AL status register 0130h: bits 3..0 state, bit 4 error indication.
  std::uint16_t register_value() const {
    return static_cast<std::uint16_t>(static_cast<unsigned>(state) | (error ? 0x10 : 0));
  }
  friend bool operator==(const AlStatus&, const AlStatus&) = default;
};

inline constexpr std::uint16_t kAlControlStateMask = 0x000F;
inline constexpr std::uint16_t kAlControlAcknowledge = 0x0010;
inline constexpr std::uint16_t kAlStatusError = 0x0010;

class AlStateMachine {
 public:
  explicit AlStateMachine(AlConfig config = {});

  // The master wrote `al_control` to 0120h. Returns the status afterwards.
  const AlStatus& request(std::uint16_t al_control);

  // A local event forces a lower state with the error indication (`to` must be below the
  // current state; otherwise only the indication and the code are set).
  const AlStatus& local_error(AlState to, AlStatusCode code);
  // The SM watchdog expired: in OP, OP -> SAFEOP + error, 001Bh; elsewhere nothing.
  const AlStatus& sm_watchdog_expired();

  const AlStatus& status() const { return status_; }
  // Power-on: INIT, no error.
  void reset() { status_ = {}; }

 private:
  void enter(AlState to);

  AlConfig config_;
  AlStatus status_;
};

}  // namespace drivecheck::ethercat

template <>
struct std::is_error_code_enum<drivecheck::ethercat::AlStatusCode> : std::true_type {};
