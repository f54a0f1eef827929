// The master facade: what drivecheck (the engine, the CLI, tests) calls to talk to EtherCAT
// slaves over a Link (SimSegment or RawLink). It runs the services of master_scan, master_sii,
// master_config, master_al, master_mailbox and master_process_data in the order a bring-up
// needs them and keeps what they found.
//
//   ethercat::SimSegment segment;                 // or ethercat_raw::RawLink
//   segment.attach(slave);                        // an EscSlave (+ CoE front end)
//   ethercat::Master master(segment, {.scan = {.expected_slaves = 1}});
//   if (auto up = master.bring_up(AlState::op); !up) fail(up.error().message());
//   auto value = master.sdo_upload(0, {0x6041, 0});        // slave 0 = position 0
//   master.outputs(0)[0] = 0x0F;                            // RxPDO bytes of slave 0
//   auto cycle = master.cycle();                            // LRW + AL status, checked
//   master.inputs(0);                                       // TxPDO bytes after the cycle
//
// bring_up(target): scan (count, station addresses, alias), SII read and parse per slave, the
// SM/FMMU plan and logical addresses, every slave to INIT (acknowledging errors), then step by
// step upwards: mailbox SMs before IP, process data SMs and FMMUs before PS, one cycle before
// SO and the cycle kept running while waiting for OP. request_state() moves every slave (in
// position order) the same way later, downwards directly. A slave taken to INIT (or found there
// on the way up) gets a fresh mailbox sequence: its requests count from 1 again and its first
// reply is new whatever counter the one before INIT had.
//
// cycle(): one process data cycle; an error when the LRW working counter is wrong
// (process_data_wkc, naming the expected and actual counts and which slaves are not in the
// held state) or when a slave left the state the master holds it in (al_state_lost with the
// slave's AL status code, e.g. 001Bh after an SM watchdog expiry). The cycle must run more
// often than the slaves' SM watchdog (100 ms by default) in SAFEOP/OP; the master has no
// thread: the caller (engine, test) calls cycle() on its clock.
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "protocol/ethercat/master_al.hpp"
#include "protocol/ethercat/master_config.hpp"
#include "protocol/ethercat/master_link.hpp"
#include "protocol/ethercat/master_mailbox.hpp"
#include "protocol/ethercat/master_process_data.hpp"
#include "protocol/ethercat/master_scan.hpp"
#include "protocol/ethercat/master_sii.hpp"

namespace drivecheck::ethercat {

struct MasterConfig {
  MasterPortConfig port;
  ScanOptions scan;
  SiiReadOptions sii;
  AlOptions al;  // between_polls is set by the master itself
  MailboxPollOptions mailbox;
  std::uint32_t logical_base = 0x00010000;
};

struct MasterSlave {
  SlaveInfo info;
  SiiRead sii;
  SlaveLayout layout;
  AlReading al;  // as last read
  std::unique_ptr<MasterMailbox> mailbox;
};

class Master {
 public:
  explicit Master(Link& link, MasterConfig config = {});
  // The mailboxes hold the port by reference: a Master stays where it was made.
  Master(const Master&) = delete;
  Master& operator=(const Master&) = delete;

  // Scan, SII, plan (no state change). Called by bring_up; again: a fresh scan.
  Expected<void, MasterError> scan();
  // scan() then every slave to `target` (INIT first).
  Expected<void, MasterError> bring_up(AlState target = AlState::op);
  // Every slave to `target`, configuring on the way up.
  Expected<void, MasterError> request_state(AlState target);
  // One slave (by position) to `target`.
  Expected<void, MasterError> request_state(std::size_t slave, AlState target);
  // The state the master holds the slaves in (the last one request_state reached for all).
  AlState held_state() const { return held_; }

  Expected<std::vector<std::uint8_t>, MasterError> sdo_upload(std::size_t slave, Multiplexer mux,
                                                              bool complete_access = false);
  Expected<void, MasterError> sdo_download(
      std::size_t slave, Multiplexer mux, std::span<const std::uint8_t> data,
      bool complete_access = false,
      CoeDownloadTransfer transfer = CoeDownloadTransfer::expedited_if_it_fits);
  // CoE emergencies read from the slave's mailbox so far (taken out).
  std::vector<CoeEmergency> take_emergencies(std::size_t slave);
  // Reads the slave's read mailbox until it is empty, queueing emergencies (other unsolicited
  // messages are dropped). The engine calls it between steps to see an EMCY.
  Expected<void, MasterError> poll_mailbox(std::size_t slave);

  // One cycle, checked (see above). The CycleResult of the last cycle stays in last_cycle().
  Expected<CycleResult, MasterError> cycle();
  const CycleResult& last_cycle() const { return last_cycle_; }
  std::span<std::uint8_t> outputs(std::size_t slave) { return image_.outputs(slave); }
  std::span<const std::uint8_t> inputs(std::size_t slave) const { return image_.inputs(slave); }

  // A mapped object in the process image by the SII's PDO list (locate_pdo_entry): where it
  // lies, its value among the slave's inputs (or outputs), and setting it among the outputs.
  // nullopt / false: not mapped (or, for set_output, mapped as an input).
  std::optional<PdoEntryPlace> locate(std::size_t slave, Multiplexer mux) const;
  std::optional<std::uint64_t> input(std::size_t slave, Multiplexer mux) const;
  bool set_output(std::size_t slave, Multiplexer mux, std::uint64_t value);

  // A PDO configuration the slave was given over CoE in PREOP (ETG.1000.6: 1600h+/1A00h+
  // mapping, 1C12h/1C13h assignment): `pdos` (each with its SM and entries, in assignment
  // order) replace the RxPDOs (`outputs`) or TxPDOs the SII lists for the slave, and the SMs,
  // FMMUs and process image are planned again (they are written on the way to SAFEOP). Only
  // while every slave is in INIT or PREOP. Errors: not_configured (no such slave, or past
  // PREOP), sii_unsupported (no SM room), frame_too_long.
  Expected<void, MasterError> set_pdos(std::size_t slave, bool outputs, std::vector<SiiPdo> pdos);

  // AL status and code of every slave now.
  Expected<std::vector<AlReading>, MasterError> read_states();

  const std::vector<MasterSlave>& slaves() const { return slaves_; }
  MasterPort& port() { return port_; }
  MasterMailbox* mailbox(std::size_t slave);

 private:
  Expected<void, MasterError> check_slave(std::size_t slave) const;
  Expected<void, MasterError> step(std::size_t slave, AlState from, AlState to);
  MasterError explain_cycle(const CycleResult& result);
  // The slave's mailbox handler stops in INIT and starts again on INIT->PREOP with its counters
  // at 0 (ETG.1000.4: Cnt 1..7, 0 reserved; the Beckhoff SSC's stop/start mailbox handler
  // clears both counters and the repeat acknowledge). The master's counters, the expected
  // reply counter and its repeat request bit restart with it.
  void restart_mailbox(std::size_t slave);
  // Before PS: a process data SM the SII lists (SyncM type 3/4) without any PDO of its own gets
  // its PDOs from the slave's CoE PDO assignment (1C10h + n for SM n: 1C12h for SM2, 1C13h for
  // SM3; each assigned PDO's mapping 1600h+/1A00h+: count, then index:sub:bits per entry;
  // ETG.1000.6), read by SDO upload, and the plan follows (set_pdos). Only for a slave with a
  // CoE mailbox; an SDO abort (no such object) leaves the SII's plan as it is.
  Expected<void, MasterError> pdos_from_coe(std::size_t slave);

  MasterConfig config_;
  MasterPort port_;
  std::vector<MasterSlave> slaves_;
  ProcessImage image_;
  CycleResult last_cycle_;
  AlState held_ = AlState::init;
  bool cycling_ = false;  // process data configured for every slave (PS done)
};

}  // namespace drivecheck::ethercat
