// The DUT port on EtherCAT: CoE SDO through an ethercat::Master (protocol/ethercat/master.hpp),
// slave 0 of the segment. NMT states map to AL states by the Festo CMMP-AS table (000 §4.7.1,
// Tab. 4.11): Stopped = INIT, Pre-operational = PREOP, Operational = OP (SAFEOP has no NMT
// counterpart); a reset is AL INIT then PREOP (after the power cycle hook, when there is one,
// a new bring-up).
//
// EthercatClock is the engine's can::Bus on EtherCAT: the link's clock and timers, no CAN frames
// (send refuses, receive only lets time pass). While the master holds SAFEOP/OP it runs the
// process data cycle (one LRW, checked) every `cycle` so the slave's SM watchdog stays fed, as a
// master in cyclic operation does; in OP an SDO download of an object the outputs carry is also
// put into the outputs (else the next cycle would write the old value over it).
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "conformance/datagram_evidence.hpp"
#include "conformance/dut_port.hpp"
#include "protocol/can/bus.hpp"
#include "protocol/cia301/nmt.hpp"
#include "protocol/ethercat/master.hpp"

namespace drivecheck::conformance {

class EthercatPort;

class EthercatClock final : public can::Bus {
 public:
  EthercatClock(ethercat::Link& link, EthercatPort& port) : link_(link), port_(port) {}
  can::TimePoint now() const override { return link_.now(); }
  can::Duration unix_offset() const override { return link_.unix_offset(); }
  std::error_code send(const can::Frame& frame) override;
  std::optional<can::TimedFrame> receive(can::TimePoint deadline) override;
  void set_frame_handler(FrameHandler handler) override { (void)handler; }
  void set_filters(std::span<const can::Filter> filters) override { (void)filters; }
  void set_loopback(bool enabled) override { (void)enabled; }
  can::TimerId start_timer(can::TimePoint at, TimerCallback callback) override {
    return link_.start_timer(at, std::move(callback));
  }
  void cancel_timer(can::TimerId id) override { link_.cancel_timer(id); }
  void run_until(can::TimePoint deadline) override { receive(deadline); }
  void stop() override {
    stopped_ = true;
    link_.stop();
  }

 private:
  ethercat::Link& link_;
  EthercatPort& port_;
  bool stopped_ = false;
};

class EthercatPort final : public DutPort {
 public:
  EthercatPort(ethercat::Master& master, can::Duration cycle = std::chrono::milliseconds(1))
      : master_(master), cycle_(cycle) {}
  LinkKind link() const override { return LinkKind::ethercat; }
  SdoOutcome upload(VectorRun& run, const SdoRequest& request) override;
  SdoOutcome download(VectorRun& run, const SdoRequest& request,
                      std::span<const std::uint8_t> data) override;

  // The AL state for an NMT state (Tab. 4.11); nullopt: none (boot-up).
  static std::optional<ethercat::AlState> al_state_of(cia301::NmtState state);
  // Every slave to `state` ("" or why not).
  std::string request_state(ethercat::AlState state);
  // A reset: AL INIT then PREOP (the slave's communication); with `node` also the power cycle
  // hook first when there is one (EtherCAT has no NMT reset node: on the simulated segment the
  // harness power-cycles the emulated slave, as an operator would a real one).
  std::string reset(bool node) override;
  void set_power_cycle(std::function<void()> power_cycle) { power_cycle_ = std::move(power_cycle); }
  bool can_power_cycle() const { return static_cast<bool>(power_cycle_); }
  // The AL state of Tab. 4.11 for `state`.
  std::string enter_state(cia301::NmtState state) override;
  // Runs the cycles that are due up to `deadline` and lets time pass (EthercatClock::receive).
  void pass_time(can::TimePoint deadline);
  // The last cycle error ("" none); cleared when read.
  std::string take_cycle_error();
  ethercat::Master& master() { return master_; }
  // The vector's datagrams: feed it every frame of the link (datagram_evidence.hpp).
  DatagramEvidence& evidence() { return evidence_; }
  VectorResult* set_evidence_sink(VectorResult* sink) override { return evidence_.set_sink(sink); }

  // ---- raw access for the EtherCAT-only steps (conformance/ethercat_steps.cpp) ----
  // AL status (0130h) and code (0134h) of slave 0 now; "" or why not in `error`.
  std::optional<ethercat::AlReading> al_status(std::string& error);
  // 0120h := `state` as it is (with the acknowledge bit when an error is pending), then the AL
  // status polled until that state, the error indication or `deadline`, time passing as usual.
  std::optional<ethercat::AlReading> raw_al_request(ethercat::AlState state,
                                                    can::TimePoint deadline, std::string& error);
  // After a raw request or a slave that fell: every slave back in the state the master holds
  // them in, errors acknowledged ("" or why not).
  std::string settle();
  // One process data cycle when it is due (time passes until then); the LRW's result (also
  // when the master found it wrong) and the master's error ("" none).
  struct CycleOutcome {
    std::optional<ethercat::CycleResult> result;  // nullopt: no answer
    std::string error;
  };
  CycleOutcome checked_cycle();
  // No process data cycle before `until` (the SM watchdog is not fed meanwhile).
  void pause_cycles(can::TimePoint until) { paused_until_ = until; }
  // The process data watchdog time of slave 0's ESC (0400h divider, 0420h time).
  std::optional<can::Duration> sm_watchdog_time(std::string& error);
  // A CoE SDO download request of `data` written into the write mailbox with the counter of the
  // master's last request (a repeat of it), then the read mailbox drained until `until`: the
  // number of replies read (repeats of an earlier reply included).
  std::optional<std::size_t> repeat_download(cia301::Multiplexer mux,
                                             std::span<const std::uint8_t> data,
                                             can::TimePoint until, std::string& error);
  // The master's counter of its last mailbox request to slave 0 (0: none yet).
  std::uint8_t last_mailbox_counter();
  // CoE emergencies of slave 0, each stamped with the time the port took it from the master:
  // those the master queued while it waited for a reply (after every SDO transfer), and with
  // `poll` those the read mailbox holds now.
  struct Emergency {
    can::TimePoint at{};
    ethercat::CoeEmergency message;
    bool matched = false;  // an expect_emcy step took it
  };
  void collect_emergencies(bool poll);
  std::vector<Emergency>& emergencies() { return emergencies_; }

  // ---- cyclic set-points (the `cyclic` step, FORMAT.md "Cyclic set-points") ----
  // Before the AL state of a vector with `cyclic` steps, in INIT or PREOP, as a master sets up
  // cyclic operation in PREOP:
  // - every one of `points` into the process data outputs. The RxPDOs 1C12h assigns and their
  //   mappings are read; the set-points none of them maps go into one more RxPDO (1600h-160Fh,
  //   not assigned): one that maps them already (a fixed mapping), else the first one there,
  //   its mapping written as ETG.1000.6 has it (sub 0 := 0, the entries, sub 0 := the count).
  //   It is assigned after the others (1C12h sub 0 := 0, the entry, sub 0 := the count), and
  //   the master plans its image from what the slave now assigns (Master::set_pdos);
  // - the outputs SM-synchronous (1C32h:01 := 1, ETG.1020 as public) when 1C32h:04 says the
  //   slave supports it: each process data frame is then the cyclic modes' SYNC. A slave
  //   without it keeps its own synchronisation (free run: it takes the outputs every cycle);
  // - the process data cycle every `period` (the vector's cycle) instead of every 1 ms, so
  //   that N cycles of a `cyclic` step are N process data frames, as on CAN N SYNCs.
  // `not_applicable`: the slave cannot carry the set-points (no 1C12h, no free RxPDO, a mapping
  // or an assignment it refuses), and why; `error`: anything else; `done`: what was
  // configured. Everything is put back at the next reset (on a power cycle the slave and the
  // SII give the defaults again).
  struct CyclicSetup {
    std::string not_applicable;
    std::string error;
    std::string done;
  };
  CyclicSetup prepare_cyclic(std::span<const CyclicSetPoint> points, can::Duration period);
  // prepare_cyclic changed the mapping or the sync mode; restore_cyclic() puts both back (in
  // INIT or PREOP): "" or why not.
  bool cyclic_configured() const { return mapping_change_ || sync_mode_before_ || cycle_before_; }
  // When the next process data cycle is due.
  can::TimePoint next_cycle() const { return next_cycle_; }
  std::string restore_cyclic();

  // ---- raw SDO (sdo_request / expect_sdo_response, conformance/raw_sdo_steps.cpp) ----
  // `sdo` (the 8 octets of a CiA 301 SDO request) as one CoE SDO request: CoE header number 0,
  // service SDO request (ETG.1000.6), then the octets, in the write mailbox with the master's
  // next counter. "" or why not.
  std::string send_raw_sdo(std::span<const std::uint8_t> sdo);
  // A message the slave put into its read mailbox after a raw request (emergencies go to
  // emergencies() instead), stamped when the master read it.
  struct RawReply {
    can::TimePoint at{};
    std::uint8_t type = 0;               // mailbox type (ethercat::MailboxType, 3: CoE)
    std::vector<std::uint8_t> data;      // the mailbox data: CoE header, then the SDO octets
    std::optional<std::uint16_t> error;  // an ERR reply: its detail
  };
  // The next such message until `deadline` (nullopt then, or on a broken read mailbox:
  // `error` says why): those already read first, then the read mailbox polled (every 20 us at
  // first, up to every 1 ms), time passing as usual (the process data cycle keeps running).
  std::optional<RawReply> receive_raw(can::TimePoint deadline, std::string& error);

 private:
  bool cyclic() const;
  // One read of the read mailbox: an emergency is queued for expect_emcy, any other message
  // for receive_raw() (and ends the wait for a raw reply). False when it was empty.
  bool poll_raw(std::string& error);
  // Before a transfer through the master: a raw request still waiting for its reply gets up to
  // `timeout` for it (kept for receive_raw()), so the master's SDO client never reads it as the
  // answer to its own request.
  void settle_raw(can::Duration timeout);
  // Before an SDO transfer: false (and `outcome` says why) when the vector's time is up;
  // otherwise runs the process data cycle that is due.
  bool before_transfer(VectorRun& run, SdoOutcome& outcome);
  void run_cycle();
  // What prepare_cyclic changed: the RxPDO it assigned after the `assigned` ones in 1C12h
  // (the 1C12h entry it overwrote, when readable), that PDO's entries before and whether it
  // wrote them, and the master's RxPDO list before.
  struct CyclicChange {
    std::uint8_t assigned = 0;
    std::optional<std::uint32_t> assignment_overwritten;
    std::uint16_t pdo = 0;
    std::vector<ethercat::SiiPdoEntry> pdo_entries;
    bool rewritten = false;
    std::vector<ethercat::SiiPdo> master_before;
  };
  // The mapping and the sync mode of before back (in PREOP): "" or why not.
  std::string restore_mapping();
  std::optional<CyclicChange> mapping_change_;
  std::optional<std::uint16_t> sync_mode_before_;  // 1C32h:01 before prepare_cyclic wrote it
  std::optional<can::Duration> cycle_before_;      // the cycle before prepare_cyclic set it
  ethercat::Master& master_;
  can::Duration cycle_;
  can::TimePoint next_cycle_{};
  std::string cycle_error_;
  std::function<void()> power_cycle_;
  can::TimePoint paused_until_{};
  std::vector<Emergency> emergencies_;
  bool raw_open_ = false;  // a raw request was sent and nothing came back yet
  std::deque<RawReply> raw_replies_;
  DatagramEvidence evidence_;
};

}  // namespace drivecheck::conformance
