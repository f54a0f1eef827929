// The PDO service of a device (CiA 301 §7.2.2 PDO, §7.5.2.35-38 PDO parameter objects): the
// RPDO and TPDO communication and mapping records in the object dictionary with their write
// rules (add_pdo_objects), and PdoService, a pure state machine over the object dictionary fed
// frames, SYNC events, the NMT state and time, returning the frames to send and the EMCYs to
// raise or clear. Codecs and frame layouts of the parameters: pdo.hpp.
//
// Objects (n = 1..count; the reference drive has 4 + 4):
//   1400h+n-1  RPDO communication, RECORD: 00h highest sub = 05h (ro), 01h COB-ID (rw,
//              default $NODEID+200h/300h/400h/500h for RPDO1..4, bit 31 per PdoDefaults),
//              02h transmission type (rw), 05h event timer = deadline monitoring, ms (rw).
//              03h (inhibit time), 04h (reserved) and 06h (SYNC start) do not apply to an RPDO
//              and do not exist: access aborts 06090011h.
//   1600h+n-1  RPDO mapping, RECORD: 00h number of mapped objects (rw), 01h..N entries (rw).
//   1800h+n-1  TPDO communication, RECORD: 00h = 06h (ro), 01h COB-ID (rw, default $NODEID+
//              180h/280h/380h/480h), 02h transmission type, 03h inhibit time (100 µs),
//              05h event timer (ms), 06h SYNC start value. 04h is reserved: aborts 06090011h.
//   1A00h+n-1  TPDO mapping, RECORD as 1600h.
// PDOs above 4 have no pre-defined CAN-ID: their COB-ID default is 80000000h (not valid).
//
// Write rules (write validators; every abort is a value the SDO server answers with):
//   COB-ID, bits 28..11 set for an 11-bit CAN-ID                          -> 06090030h
//   COB-ID, bits 0..29 changed while the PDO is valid (bit 31 = 0 before and after; CiA 301
//     §7.5.2.35: "it is not allowed to change bit 0 to 29 while the PDO exists")  -> 06090030h
//   COB-ID made valid on a restricted 11-bit CAN-ID (cob_id.hpp)           -> 06090030h
//   transmission type reserved (241..251), or 252/253 for an RPDO          -> 06090030h
//   inhibit time or SYNC start value changed while the TPDO is valid (CiA 301 §7.5.2.37:
//     "shall not be changed while the PDO exists")                         -> 06090030h
//   SYNC start value above 240                                             -> 06090030h
//   mapping sub 00h..N written while the PDO is valid (unless mapping_while_valid), or sub
//     01h..N while sub 00h is not 0
//     (the CiA 301 §7.5.2.36/38 procedure: 1. COB-ID bit 31 := 1, 2. sub 00h := 0, 3. write
//     the entries, 4. sub 00h := count, 5. bit 31 := 0)                    -> 06010000h
//     CiA 301 prescribes the procedure but names no abort code for breaking it. 06010000h
//     "unsupported access to an object" is what we answer; other devices answer 06090030h,
//     06040043h or 08000022h, and a conformance verdict should accept that set.
//   mapping entry (step 3; and every entry again at step 4, sub 00h := count):
//     00000000h                                         accepted (an empty entry)
//     index of no object                                -> 06020000h
//     sub-index of no entry                             -> 06090011h
//     object not PDO-mappable, or of variable length    -> 06040041h
//     wrong direction: a read-only (ro/const) object in an RPDO, a write-only one in a TPDO
//                                                       -> 06040041h (Festo 000 L782 "e.g.
//                                                          ro-object in RPDO")
//     length other than the object's size in bits       -> 06040041h (CiA 301 names no code)
//     dummy entry (0002h..0007h, sub 0, its size) in a TPDO, or dummy mapping off
//                                                       -> 06040041h
//   mapping sub 00h above the number of entries, or the entries 01h..count longer than 64 bits
//                                                       -> 06040042h
// Dummy entries (0002h INTEGER8 .. 0007h UNSIGNED32) reserve bits in an RPDO that no object
// receives.
//
// What PdoService does (only while the NMT state allows PDOs, i.e. in Operational; CiA 301
// §7.3.2.2; entering Operational starts every PDO afresh, leaving it stops them):
//   TPDO payload: the mapped objects' current values (no read hooks: the application keeps
//     mapped objects current, e.g. in its control cycle), packed LSB first (pdo.hpp).
//   TPDO transmission types:
//     0        acyclic synchronous: sent at a SYNC if an event happened since the last
//              transmission: trigger(), or the payload differs from the one last sent (or
//              none was sent since entering Operational)
//     1..240   sent at every n-th SYNC. Without SYNC start value (or SYNC without counter,
//              1019h = 0) the first transmission is at the n-th SYNC after entering
//              Operational. With a start value s and a SYNC counter: sent at the first SYNC
//              whose counter equals s, then at every n-th SYNC after it (CiA 301: that SYNC "is
//              regarded as the first SYNC" of the PDO).
//     252      the payload is sampled at each SYNC and sent on an RTR (before the first SYNC:
//              the current values)
//     253      sent on an RTR, current values
//     254/255  event-driven: sent when an event happens: trigger(), the payload differs from
//              the one last sent (checked whenever on_time runs: the owner calls it each
//              control cycle), the event timer (sub 05h, ms, 0 = off) expired since the last
//              transmission, or Operational was entered. The inhibit time (sub 03h, 100 µs)
//              is the least time between two transmissions: an event inside it is sent when
//              it ends, with the values then current.
//     An RTR on a TPDO whose COB-ID has bit 30 = 0 (RTR allowed) is answered for every
//     transmission type (252: with the sample); with bit 30 = 1 it is ignored. An RTR answer
//     does not restart the inhibit or event timers.
//   RPDO transmission types 0..240: the received data is applied at the next SYNC (the last
//     one received before it wins); 254/255: applied at once. Applying writes each mapped
//     object through ObjectDictionary::write (access, limits, validators and write observers
//     apply; an entry refused there is skipped and counted, the others are written).
//   RPDO length (CiA 301 §7.2.2.2, Table 21): fewer bytes than mapped -> not processed, EMCY
//     8210h "PDO not processed due to length error"; more bytes -> processed (the first bytes)
//     and EMCY 8220h "PDO length exceeded". A PDO of the right length clears both (for that
//     RPDO; an EMCY code stays active while any RPDO still has the error).
//   RPDO deadline monitoring (event timer, sub 05h): armed by each reception; no RPDO within
//     it -> EMCY 8250h "RPDO timeout", cleared by the next reception.
//   A valid PDO with no mapped objects (sub 00h = 0) is neither sent nor received.
//   Transmit masks (change_mask_index, Festo): "the payload differs from the one last sent"
//     (types 0, 254, 255) compares only the payload bits set in the TPDO's mask; the other
//     bits still go out with the next transmission. Without masks: every bit.
//   Synchronous window 1007h (µs, 0 = none; read from the dictionary at each use, the value
//     SyncConsumer has too). CiA 301 v4.2.0 §7.5.2, object 1007h: "If the synchronous window
//     length expires all synchronous TPDOs shall be discarded and an EMCY message may be
//     transmitted; all synchronous RPDOs may be discarded until the next SYNC message is
//     received. Synchronous RPDO processing is resumed with the next SYNC message." (quoted
//     from the standard as we know it; no copy is in shared/manuals to check it against).
//     What PdoService does, the window being [SYNC, SYNC + 1007h), as SyncConsumer::in_window:
//     - 1007h = 0: nothing changes; the synchronous TPDOs due at a SYNC all come out of
//       on_sync at once.
//     - 1007h ≠ 0, TPDOs of types 0..240: on_sync hands out the first TPDO due and holds the
//       others; each following one is handed out by on_sent() (the owner reports the end of
//       its previous synchronous TPDO on the wire, e.g. the loopback echo) while the window is
//       still open. Those still held when the window closes (on_sent or on_time at or after
//       SYNC + 1007h) are discarded, not sent late (statistics: sync_tpdos_discarded). A frame
//       already handed to the controller is not recalled (a can::Bus has no abort): the last
//       one handed out inside the window may end on the wire after it. No EMCY (a "may").
//     - 1007h ≠ 0, RPDOs of types 0..240: data received at or after SYNC + 1007h (and before
//       the next SYNC) is discarded: it does not take effect at the next SYNC (statistics:
//       sync_rpdos_discarded); the length checks and deadline monitoring still see the frame.
//       Before the first SYNC in Operational no window has expired: the data is kept.
//     An owner that does not call on_sent gets only the first synchronous TPDO of each SYNC
//     out while 1007h ≠ 0.
//
// Configuration is read from the object dictionary when PdoService is built, by reload(), and
// for one PDO whenever one of its entries is written (write observers). The entries mapped
// are resolved then: objects must not be added to the dictionary after that without reload().
// A PDO whose stored configuration is broken (e.g. a mapping that no longer resolves after
// ObjectDictionary::load) is inactive; configuration_problem() says why.
//
// Hot path: on_frame, on_sync and on_time do not allocate.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "protocol/can/bus.hpp"
#include "protocol/can/frame.hpp"
#include "protocol/cia301/nmt_slave.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/pdo.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

// The value a PDO's objects start with (their EDS defaults).
struct PdoDefaults {
  bool valid = false;                     // COB-ID bit 31 = 0
  bool rtr_allowed = true;                // COB-ID bit 30 = 0 (TPDO: answered on RTR)
  std::uint8_t transmission_type = 0xFF;  // event-driven (device profile)
  std::uint16_t inhibit_time = 0;         // TPDO, 100 µs
  std::uint16_t event_timer = 0;          // ms
  std::vector<PdoMappingEntry> mapping;   // checked when the PDO is configured, not here
};

struct PdoObjectOptions {
  std::uint16_t rpdo_count = 4;      // 0..512
  std::uint16_t tpdo_count = 4;      // 0..512
  std::uint8_t mapping_entries = 8;  // sub-entries of each mapping record, 1..64
  bool dummy_mapping = true;         // RPDOs accept the dummy entries 0002h..0007h
  // The mapping (sub 00h..N) may be written while the PDO is valid (Kollmorgen S300/S700,
  // 002 §6.3.5 L7199-7244); sub 01h..N still only while sub 00h is 0. CiA 301: false.
  bool mapping_while_valid = false;
  // The COB-IDs (sub 01h) support only enabling and disabling the PDO (bit 31): a write that
  // changes bits 0..30 is refused with 06090030h (CiA 301 §7.5.2.37 allows such a TPDO, answering
  // 06090030h or 08000000h; the same taken for RPDOs, §7.5.2.35). CiA 301's usual case: false.
  bool cob_id_enable_only = false;
  // Manufacturer transmit masks (Festo 2014h-2017h, 000 §3.3 L903-909, L1141-1166): 0 none;
  // else TPDO n (1..tpdo_count) gets a RECORD at change_mask_index + n - 1: sub 00h = 2 (ro),
  // sub 01h mask low (payload bits 0-31), sub 02h mask high (bits 32-63), UNSIGNED32 rw,
  // default FFFFFFFFh. Give the same index to PdoService.
  std::uint16_t change_mask_index = 0;
  std::vector<PdoDefaults> rpdo_defaults;  // [0] RPDO1, ...; missing ones: PdoDefaults{}
  std::vector<PdoDefaults> tpdo_defaults;
};

// Adds the RPDO and TPDO records with the rules above. Errors: an index is taken, a count or
// mapping_entries out of range, a valid default for a PDO above 4 (no pre-defined CAN-ID),
// more default mapping entries than mapping_entries.
Expected<void, std::string> add_pdo_objects(ObjectDictionary& od,
                                            const PdoObjectOptions& options = {});

// The CiA 301 mapping check of one entry (step 3 of the procedure) for a PDO of `direction`:
// the bits it takes, or the abort code of the table above.
Expected<unsigned, SdoAbort> check_pdo_mapping_entry(const ObjectDictionary& od,
                                                     PdoDirection direction, std::uint32_t entry,
                                                     bool dummy_mapping);

// An EMCY the PDO service asks its owner to raise (active) or clear.
struct PdoErrorChange {
  std::uint16_t code = 0;  // 8210h, 8220h or 8250h
  bool active = false;
  friend bool operator==(const PdoErrorChange&, const PdoErrorChange&) = default;
};

// What one call produced: frames to send now, in order, and EMCY changes. Spans into the
// service, valid until its next call.
struct PdoOutput {
  bool taken = false;  // on_frame: the frame was on an active PDO's CAN-ID
  std::span<const can::Frame> frames;
  std::span<const PdoErrorChange> errors;
};

struct PdoStatistics {
  std::uint64_t tpdos_sent = 0;
  std::uint64_t rtr_answered = 0;
  std::uint64_t rpdos_received = 0;  // frames on an active RPDO's CAN-ID
  std::uint64_t rpdos_applied = 0;   // ... written to the dictionary
  std::uint64_t length_errors = 0;   // too short (not processed) or too long
  std::uint64_t rpdo_timeouts = 0;
  std::uint64_t write_refusals = 0;        // mapped entries ObjectDictionary::write refused
  std::uint64_t sync_tpdos_discarded = 0;  // synchronous TPDOs not sent: window 1007h closed
  std::uint64_t sync_rpdos_discarded = 0;  // synchronous RPDOs received after window 1007h
};

class PdoService {
 public:
  // Reads every PDO of the dictionary (1400h-15FFh, 1800h-19FFh with their mapping records)
  // and observes their entries (an SDO write takes effect at once, at clock.now()). Starts
  // outside Operational. The dictionary and the clock must outlive the service;
  // `dummy_mapping` and `change_mask_index` as given to add_pdo_objects.
  PdoService(ObjectDictionary& od, const can::Clock& clock, bool dummy_mapping = true,
             std::uint16_t change_mask_index = 0);
  ~PdoService();
  PdoService(const PdoService&) = delete;
  PdoService& operator=(const PdoService&) = delete;

  // Which SYNC starts the count of a TPDO of type n (2..240) without a SYNC start value: false
  // (default) the n-th SYNC after entering Operational is its first transmission; true the
  // first SYNC is (then every n-th). CiA 301 §7.5.2.37 leaves this to the device. Takes effect
  // when the TPDOs next start (entering Operational, a reconfiguration).
  void set_first_sync_phase(bool first_sync) { first_sync_phase_ = first_sync; }
  // Re-reads every PDO's configuration (after ObjectDictionary::load/restore_defaults).
  void reload(can::TimePoint now);

  // The NMT state: PDOs run only where nmt_allows(state, NmtService::pdo).
  void set_nmt_state(NmtState state, can::TimePoint now);
  bool running() const { return running_; }
  // Fault injection (the reference drive's pdo-rtr-outside-operational; false in a conformant
  // device): remote frames for a TPDO are answered whatever the NMT state.
  void set_rtr_in_any_state(bool on) { rtr_in_any_state_ = on; }
  // Fault injection (the reference drive's sync-tpdo-acyclic-in-stopped; false in a conformant
  // device): in Stopped a SYNC still sends the acyclic synchronous TPDOs (type 0) that are due
  // and the cyclic ones waiting for their SYNC start value (1800h sub 06h) once it comes.
  void set_sync_acyclic_in_stopped(bool on) { sync_acyclic_in_stopped_ = on; }
  // Fault injection (the reference drive's sync-tpdo-acyclic-in-pre-operational; false in a
  // conformant device): in Pre-operational a SYNC still sends the acyclic synchronous TPDOs
  // (type 0) that are due.
  void set_sync_acyclic_in_pre_operational(bool on) { sync_acyclic_in_pre_operational_ = on; }

  // Fault injection (the reference drive's sync-window-tpdo-sent-late; false in a conformant
  // device): with 1007h ≠ 0 the synchronous TPDOs held when the window closes are sent then,
  // late, instead of being discarded.
  void set_sync_window_tpdos_sent_late(bool on) { sync_window_tpdos_sent_late_ = on; }
  // Fault injection (the reference drive's sync-tpdo-only-first; false in a conformant device):
  // of the synchronous TPDOs due at one SYNC only the first (lowest number) is sent, the
  // others are dropped, whatever 1007h holds.
  void set_sync_tpdo_only_first(bool on) { sync_tpdo_only_first_ = on; }
  // Fault injection (the reference drive's sync-window-rpdo-not-resumed; false in a conformant
  // device): once a synchronous RPDO has been discarded for arriving after the window, every
  // later synchronous RPDO is discarded too, until the PDOs start again (leaving and entering
  // Operational), instead of processing being resumed with the next SYNC.
  void set_sync_window_rpdo_not_resumed(bool on) { sync_window_rpdo_not_resumed_ = on; }
  // Fault injection (the reference drive's rpdo-deadline-not-restarted; false in a conformant
  // device): an RPDO's deadline (event timer) is started by the first RPDO after it was
  // stopped or timed out, not restarted by each RPDO.
  void set_rpdo_deadline_not_restarted(bool on) { rpdo_deadline_not_restarted_ = on; }

  // A frame from the bus: an RPDO, or an RTR for a TPDO.
  PdoOutput on_frame(const can::Frame& frame, can::TimePoint now);
  // A SYNC (counter: when 1019h ≠ 0).
  PdoOutput on_sync(std::optional<std::uint8_t> counter, can::TimePoint now);
  // One of the owner's own frames has left the wire at `now` (its loopback echo, timestamp =
  // end of frame): with a synchronous window (1007h ≠ 0), the end of a synchronous TPDO hands
  // out the next one held, or discards those held once the window has closed. Other frames
  // are ignored.
  PdoOutput on_sent(const can::Frame& frame, can::TimePoint now);
  // Time has passed: event timers, inhibit times, RPDO deadlines, the change-of-state check of
  // event-driven TPDOs, and the end of the synchronous window.
  PdoOutput on_time(can::TimePoint now);
  // When on_time() must be called next at the latest (change-of-state needs the owner's
  // control cycle besides).
  can::TimePoint next_deadline() const;

  // An application event for TPDO `number` (types 0, 254, 255): sent at the next SYNC (0) or
  // at the next on_time() the inhibit time allows. False for a TPDO that is not active.
  bool trigger(std::uint16_t number);

  // Forgets every PDO error and returns the EMCY clears for the codes that were active
  // (reset communication).
  PdoOutput clear_errors();

  std::size_t rpdo_count() const { return rpdos_.size(); }
  std::size_t tpdo_count() const { return tpdos_.size(); }
  // Whether PDO `number` (1-based) is valid, has mapped objects and a usable configuration.
  bool is_active(PdoDirection direction, std::uint16_t number) const;
  // Why a valid PDO is inactive ("mapping entry 2: 06020000h ..."); nullopt when it is
  // active, not valid, or has no mapped objects.
  std::optional<std::string> configuration_problem(PdoDirection direction,
                                                   std::uint16_t number) const;
  const PdoStatistics& statistics() const { return stats_; }

 private:
  struct Slot {
    const Entry* entry = nullptr;  // nullptr: dummy entry
    std::uint16_t index = 0;
    std::uint8_t sub_index = 0;
    std::uint8_t bits = 0;
    std::uint8_t bytes = 0;  // size of the object's type
    std::uint8_t offset = 0;
  };
  struct Common {
    std::uint16_t number = 0;
    bool valid = false;
    bool active = false;
    std::optional<std::string> problem;
    can::IdFormat format = can::IdFormat::standard;
    std::uint32_t can_id = 0;
    std::uint8_t type = 0xFF;
    can::Duration event_timer{0};
    std::vector<Slot> slots;  // capacity reserved: reconfiguring does not allocate
    std::uint8_t length = 0;  // bytes of the payload
  };
  struct Rpdo : Common {
    bool pending = false;
    std::array<std::uint8_t, 8> pending_data{};
    can::TimePoint deadline = can::kForever;
    bool short_error = false;
    bool long_error = false;
    bool timeout_error = false;
  };
  struct Tpdo : Common {
    bool rtr_allowed = true;
    can::Duration inhibit{0};
    std::uint8_t sync_start = 0;
    // Runtime.
    unsigned sync_count = 0;
    bool started = false;  // the SYNC start value has been seen
    bool event = false;
    bool sent_once = false;
    std::array<std::uint8_t, 8> last_sent{};
    std::uint64_t change_mask = ~std::uint64_t{0};  // transmit mask (bits of the payload)
    bool sampled = false;
    std::array<std::uint8_t, 8> sample{};
    can::TimePoint inhibit_until{};
    can::TimePoint event_due = can::kForever;
  };

  void configure(Rpdo& pdo);
  void configure(Tpdo& pdo);
  bool configure_common(Common& pdo, PdoDirection direction);
  void start(Rpdo& pdo, can::TimePoint now);
  void start(Tpdo& pdo, can::TimePoint now);
  void stop(Rpdo& pdo);

  void begin_output();
  PdoOutput output(bool taken = false);
  std::array<std::uint8_t, 8> pack(const Tpdo& pdo) const;
  void transmit(Tpdo& pdo, const std::array<std::uint8_t, 8>& payload, can::TimePoint now,
                bool event_driven);
  void emit(const Common& pdo, const std::array<std::uint8_t, 8>& payload);
  void apply(Rpdo& pdo, const std::array<std::uint8_t, 8>& data);
  void receive(Rpdo& pdo, const can::Frame& frame, can::TimePoint now);
  void set_error(bool& flag, bool active, std::uint16_t code);

  void bind();
  void unbind();

  // 1007h in the dictionary (0 when it does not exist).
  can::Duration sync_window() const;
  // Whether the window of the last SYNC (if 1007h ≠ 0) has closed at `now`.
  bool window_closed(can::TimePoint now) const;
  // Hands out the next held synchronous TPDO, or discards the held ones when the window has
  // closed.
  void release_held(can::TimePoint now);
  void send_all_held();  // every held TPDO goes out now
  void sync_outside_operational(std::optional<std::uint8_t> counter, bool start_values,
                                can::TimePoint now);

  ObjectDictionary& od_;
  const can::Clock& clock_;
  bool dummy_mapping_;
  std::uint16_t change_mask_index_ = 0;
  bool changed(const Tpdo& pdo, const std::array<std::uint8_t, 8>& payload) const;
  bool running_ = false;
  bool rtr_in_any_state_ = false;                 // set_rtr_in_any_state
  bool sync_acyclic_in_stopped_ = false;          // set_sync_acyclic_in_stopped
  bool sync_acyclic_in_pre_operational_ = false;  // set_sync_acyclic_in_pre_operational
  NmtState state_ = NmtState::boot_up;            // set_nmt_state
  bool first_sync_phase_ = false;                 // set_first_sync_phase
  bool sync_window_tpdos_sent_late_ = false;      // set_sync_window_tpdos_sent_late
  bool sync_tpdo_only_first_ = false;             // set_sync_tpdo_only_first
  bool sync_window_rpdo_not_resumed_ = false;     // set_sync_window_rpdo_not_resumed
  bool rpdo_deadline_not_restarted_ = false;      // set_rpdo_deadline_not_restarted
  bool sync_rpdos_stopped_ = false;               // (that fault) an RPDO was discarded
  std::vector<Rpdo> rpdos_;
  std::vector<Tpdo> tpdos_;
  std::vector<std::pair<std::uint16_t, std::uint8_t>> bound_;
  std::vector<can::Frame> frames_;      // capacity: one per TPDO (+1)
  std::vector<PdoErrorChange> errors_;  // capacity reserved
  bool errors_delivered_ = false;       // errors_ went out: the next call starts afresh (changes
                                        // made by write observers between calls wait for it)
  std::array<unsigned, 3> error_counts_{};   // 8210h, 8220h, 8250h: RPDOs with the error
  const Entry* window_entry_ = nullptr;      // 1007h sub 00h
  std::optional<can::TimePoint> last_sync_;  // the last SYNC in Operational
  std::vector<can::Frame> held_;             // synchronous TPDOs waiting (1007h ≠ 0), in order
  std::size_t held_next_ = 0;                // next of held_ to hand out
  std::optional<can::Frame> in_flight_;      // the synchronous TPDO handed out last
  PdoStatistics stats_;
};

}  // namespace drivecheck::cia301
