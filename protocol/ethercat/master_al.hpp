// AL state transitions as the master drives them (ETG.1000.6 §6.4; ESC datasheet Section II
// 0120h AL control, 0130h AL status, 0134h AL status code; al_state_machine.hpp has the
// register layouts). One transition of one slave:
//  1. read AL status; when its error indication is already set, the request carries the
//     acknowledge bit (a slave ignores higher states until the master acknowledges);
//  2. FPWR 0120h = requested state (| 10h);
//  3. poll FPRD 0130h..0135h (status and status code in one datagram), running
//     AlOptions::between_polls between the polls (the process data cycle in SAFEOP/OP, which
//     keeps the SM watchdog fed and gives the slave valid outputs before OP):
//     - the requested state without error indication: done;
//     - the error indication set: the transition was refused (or the slave fell back); the
//       error the slave showed before the request counts only when it is still unchanged at
//       the timeout (a slave may take a while to handle the acknowledge); the
//       code in 0134h is read, the error acknowledged (FPWR 0120h = current state | 10h), and
//       the result is al_refused with the code named from al_status_codes.inc;
//     - neither before AlOptions::timeout: al_timeout, naming the state the slave is in.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "protocol/ethercat/al_state_machine.hpp"
#include "protocol/ethercat/master_link.hpp"

namespace drivecheck::ethercat {

struct AlReading {
  std::uint16_t station = 0;
  std::uint16_t status = 0;  // 0130h
  std::uint16_t code = 0;    // 0134h
  std::uint8_t state_bits() const { return static_cast<std::uint8_t>(status & 0x0F); }
  bool error() const { return (status & kAlStatusError) != 0; }
  bool in(AlState state) const { return state_bits() == static_cast<std::uint8_t>(state); }
  // "SAFEOP + error, 001Bh sync_manager_watchdog: Sync manager watchdog"
  std::string describe() const;
};

struct AlOptions {
  Duration timeout = std::chrono::seconds(5);
  Duration poll_interval = std::chrono::microseconds(100);
  bool acknowledge = true;  // acknowledge a refusal after reading its code
  std::function<void()> between_polls;
};

Expected<AlReading, MasterError> read_al_status(MasterPort& port, std::uint16_t station);

// Requests `target` from the slave at `station` and waits for it (see above).
Expected<AlReading, MasterError> request_al_state(MasterPort& port, std::uint16_t station,
                                                  AlState target, const AlOptions& options = {});

// Acknowledges a pending error indication: FPWR 0120h = current state | 10h.
Expected<void, MasterError> acknowledge_al_error(MasterPort& port, const AlReading& reading);

}  // namespace drivecheck::ethercat
