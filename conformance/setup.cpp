// Before and after each vector (FORMAT.md `setup:`, `nmt:`, `drive_state:`, "Teardown").
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <optional>
#include <span>

#include "conformance/ethercat_port.hpp"
#include "conformance/vector_run.hpp"
#include "protocol/cia301/data_type.hpp"
#include "protocol/cia301/error_control.hpp"
#include "protocol/cia301/nmt_master.hpp"
#include "protocol/cia402/controlword.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {

StepStatus VectorRun::await_bootup(std::string action) {
  const auto within = resolve({{}, "bootup"});
  const auto from = received_.size();
  const auto start = now();
  const auto hit = watch(from, start + within, [&](const can::Frame& f) {
    return !f.is_extended() && !f.is_remote() && f.id == 0x700U + node() && f.length() == 1 &&
           f.data[0] == 0;
  });
  const auto expected =
      fmt::format("boot-up {:03X}#00 within {}", 0x700 + node(), profile::format_duration(within));
  if (!hit)
    return fail(std::move(action), expected, fmt::format("no boot-up; {}", recent_frames(from)));
  return StepStatus::ok;
}

StepStatus VectorRun::reach_drive_state(cia402::State target) {
  const std::string action = "setup drive_state";
  const auto state_change = resolve({{}, "state_change"});
  if (target == cia402::State::not_ready_to_switch_on || target == cia402::State::fault ||
      target == cia402::State::fault_reaction_active) {
    return harness_error(action, fmt::format("state {} cannot be reached by controlword",
                                             cia402::to_string(target)));
  }
  // Each transition of the walk: the controlword accepted, then the new state confirmed in
  // 6041h within $timing.state_change. The DUT not following is an error, not a failure: the
  // vector never ran (its own subject is elsewhere; the cia402/fsa vectors judge transitions).
  const auto transition = [&](const char* number, cia402::Command command,
                              cia402::State state) -> StepStatus {
    const auto word = cia402::controlword_of(command);
    const auto& pattern = cia402::pattern_of(state);
    const auto what = fmt::format("transition {} ({:04X}h {}) to {}", number, word,
                                  cia402::describe_controlword(word), pattern.name);
    if (auto s = write_controlword(word, action); s != StepStatus::ok)
      return harness_error(action, fmt::format("{} did not happen: controlword refused: {}", what,
                                               result_.checks.back().actual));
    if (auto s = poll_statusword(
            action, pattern.mask, pattern.value,
            fmt::format("state {} within {}", pattern.name, profile::format_duration(state_change)),
            now() + state_change);
        s != StepStatus::ok) {
      return harness_error(action, fmt::format("{} did not happen within {}: {}", what,
                                               profile::format_duration(state_change),
                                               result_.checks.back().actual));
    }
    return StepStatus::ok;
  };
  // From wherever the drive is: fault reset if in FAULT (15), then disable voltage to SWITCH ON
  // DISABLED (7, 9, 10 or 12), then the standard path 2, 3, 4 (and 11 for QUICK STOP ACTIVE).
  const auto statusword = [&]() -> std::optional<std::uint16_t> {
    const auto read = sdo_upload({0x6041, 0});
    if (!read.ok || read.data.size() != 2) return std::nullopt;
    return static_cast<std::uint16_t>(read.data[0] | read.data[1] << 8);
  };
  const auto is_fault = [](std::uint16_t sw) {
    const auto state = cia402::decode_statusword(sw);
    return state == cia402::State::fault || state == cia402::State::fault_reaction_active;
  };
  // FAULT (or a fault reaction, which ends by itself in FAULT: transition 14; a fault reset
  // counts only in FAULT, an edge during the reaction is lost) to SWITCH ON DISABLED.
  const auto clear_fault = [&](std::uint16_t sw) -> StepStatus {
    if (cia402::decode_statusword(sw) == cia402::State::fault_reaction_active) {
      const auto& fault = cia402::pattern_of(cia402::State::fault);
      if (auto s = poll_statusword(action, fault.mask, fault.value,
                                   fmt::format("fault reaction ended (transition 14: {}) within {}",
                                               fault.name, profile::format_duration(state_change)),
                                   now() + state_change);
          s != StepStatus::ok)
        return harness_error(action, fmt::format("the fault reaction did not end within {}: {}",
                                                 profile::format_duration(state_change),
                                                 result_.checks.back().actual));
    }
    if (auto s = write_controlword(0x0000, action); s != StepStatus::ok)
      return harness_error(action,
                           "controlword 0000h refused in FAULT: " + result_.checks.back().actual);
    return transition("15", cia402::Command::fault_reset, cia402::State::switch_on_disabled);
  };
  const auto first = statusword();
  if (!first) return harness_error(action, "statusword 6041h unreadable");
  if (is_fault(*first)) {
    if (auto s = clear_fault(*first); s != StepStatus::ok) return s;
    if (auto s = transition("7/9/10/12", cia402::Command::disable_voltage,
                            cia402::State::switch_on_disabled);
        s != StepStatus::ok)
      return s;
  } else {
    // Disable voltage; a fault that shows meanwhile (one the drive raised before this vector,
    // e.g. its abort connection reaction 6007h when the previous vector left EtherCAT OP, and
    // takes at its next control cycle) is reset first, then disable voltage again.
    if (auto s =
            write_controlword(cia402::controlword_of(cia402::Command::disable_voltage), action);
        s != StepStatus::ok)
      return harness_error(action, fmt::format("disable voltage: controlword refused: {}",
                                               result_.checks.back().actual));
    const auto& off = cia402::pattern_of(cia402::State::switch_on_disabled);
    const auto deadline = now() + state_change;
    bool faulted = false;
    for (;;) {
      const auto sw = statusword();
      if (sw && (*sw & off.mask) == off.value) {
        check(action,
              fmt::format("state {} within {}", off.name, profile::format_duration(state_change)),
              fmt::format("statusword {:04X}h ({})", *sw, off.name), true);
        break;
      }
      if (sw && is_fault(*sw)) {
        if (auto s = clear_fault(*sw); s != StepStatus::ok) return s;
        faulted = true;
        break;
      }
      if (now() >= deadline || vector_timed_out()) {
        return harness_error(
            action, fmt::format("transition 7/9/10/12 ({:04X}h {}) to {} did not happen within "
                                "{}: statusword {} at the deadline",
                                cia402::controlword_of(cia402::Command::disable_voltage),
                                cia402::describe_controlword(
                                    cia402::controlword_of(cia402::Command::disable_voltage)),
                                off.name, profile::format_duration(state_change),
                                sw ? fmt::format("{:04X}h", *sw) : std::string("unreadable")));
      }
      wait_until(std::min(deadline, now() + resolve({{}, "poll"})));
    }
    if (faulted) {
      if (auto s = transition("7/9/10/12", cia402::Command::disable_voltage,
                              cia402::State::switch_on_disabled);
          s != StepStatus::ok)
        return s;
    }
  }
  if (target == cia402::State::switch_on_disabled) return StepStatus::ok;
  if (auto s = transition("2", cia402::Command::shutdown, cia402::State::ready_to_switch_on);
      s != StepStatus::ok)
    return s;
  if (target == cia402::State::ready_to_switch_on) return StepStatus::ok;
  if (auto s = transition("3", cia402::Command::switch_on, cia402::State::switched_on);
      s != StepStatus::ok)
    return s;
  if (target == cia402::State::switched_on) return StepStatus::ok;
  if (auto s = transition("4", cia402::Command::enable_operation, cia402::State::operation_enabled);
      s != StepStatus::ok)
    return s;
  if (target == cia402::State::operation_enabled) return StepStatus::ok;
  return transition("11", cia402::Command::quick_stop, cia402::State::quick_stop_active);
}

void VectorRun::note(std::string text) {
  context_.notes.push_back(std::move(text));
}

StepStatus VectorRun::reach_nmt_state(cia301::NmtState target) {
  const std::string action = "setup nmt";
  cia301::NmtMaster master;
  const cia301::NmtCommand command =
      target == cia301::NmtState::operational ? cia301::NmtCommand::start
      : target == cia301::NmtState::stopped   ? cia301::NmtCommand::stop
                                              : cia301::NmtCommand::enter_pre_operational;
  const auto frame = master.command(command, node());
  const std::string name(cia301::to_string(target));
  // Whether the DUT produces a heartbeat: 1017h as read or written in this vector (the
  // commissioning may write it), else read now while SDO is served for sure (before a stop).
  const auto read_heartbeat_time = [&]() -> SdoOutcome {
    const SdoOutcome outcome = sdo_upload({0x1017, 0});  // sets heartbeat_time_ when ok
    if (outcome.ok && outcome.data.size() != 2) heartbeat_time_.reset();
    return outcome;
  };
  if (target == cia301::NmtState::stopped && !heartbeat_time_) (void)read_heartbeat_time();
  const auto from = received_.size();
  if (auto ec = send_nmt(frame))
    return harness_error(action, fmt::format("cannot send {}: {}", frame, ec.message()));
  // NMT is not acknowledged: give the frame its time on the wire, and the DUT a moment.
  wait_until(now() + std::chrono::milliseconds(1));
  const auto heartbeat_on = [&] { return heartbeat_time_ && *heartbeat_time_ > can::Duration{}; };
  if (target != cia301::NmtState::stopped && !heartbeat_on()) {
    // Behaviour: an SDO answer (any, an abort included) shows the DUT is not stopped.
    const SdoOutcome outcome = read_heartbeat_time();
    if (!outcome.ok && !outcome.abort) {
      return harness_error(
          action, fmt::format("{} ({}) not confirmed: the DUT does not answer SDO (upload of "
                              "1017h: {}), as in Stopped",
                              name, can::to_candump(frame), outcome.describe()));
    }
  }
  if (heartbeat_on()) {
    // The heartbeat's state byte (CiA 301 §7.2.8.3.2.2): one with the target state after the
    // command, within 1.5 periods and the response time.
    const auto within = *heartbeat_time_ * 3 / 2 + resolve({{}, "response"});
    const auto hit = watch(from, now() + within, [&](const can::Frame& f) {
      const auto heartbeat = cia301::decode_heartbeat(f);
      return heartbeat && heartbeat->node == node() && heartbeat->state == target;
    });
    if (!hit) {
      return harness_error(
          action,
          fmt::format("{} ({}) not confirmed: no heartbeat {:03X}#{:02X} within "
                      "{}; {}",
                      name, can::to_candump(frame), 0x700 + node(), static_cast<unsigned>(target),
                      profile::format_duration(within), recent_frames(from)));
    }
    check(action, fmt::format("NMT state {} shown by the heartbeat", name), "seen", true);
    return StepStatus::ok;
  }
  if (target == cia301::NmtState::stopped) {
    // Behaviour: in Stopped the SDO server is silent (CiA 301 §7.3.2.2). Node guarding would
    // show the state too, but its request toggles the DUT's guarding bit for the vector.
    const SdoOutcome outcome = sdo_upload({0x1000, 0});
    if (outcome.ok || outcome.abort) {
      return harness_error(
          action, fmt::format("{} ({}) not confirmed: the DUT answers SDO (upload of 1000h: {}), "
                              "which it does not in Stopped (CiA 301 §7.3.2.2)",
                              name, can::to_candump(frame), outcome.describe()));
    }
    check(action, "NMT state stopped: SDO not served", "no answer to an upload of 1000h", true);
    return StepStatus::ok;
  }
  check(action, fmt::format("NMT state {}: SDO served", name), "1017h upload answered", true);
  return StepStatus::ok;
}

StepStatus VectorRun::commission() {
  const profile::Commissioning& commissioning = context_.profile.commissioning;
  if (!commissioning.applies_to(vector_.id)) return StepStatus::ok;
  for (const profile::CommissioningWrite& w : commissioning.writes) {
    std::array<std::uint8_t, 4> bytes{};
    const auto raw = static_cast<std::uint64_t>(w.value);
    for (std::size_t i = 0; i < w.size; ++i)
      bytes[i] = static_cast<std::uint8_t>(raw >> (8 * i));
    const auto outcome = sdo_download({w.index, w.sub}, std::span(bytes.data(), w.size));
    if (!outcome.ok) {
      return fail("setup commissioning",
                  fmt::format("{:04X}h sub {} := {} ({} bytes) accepted ({})", w.index, w.sub,
                              w.value, w.size, w.why),
                  outcome.describe());
    }
  }
  return StepStatus::ok;
}

StepStatus VectorRun::consume_harness_heartbeat() {
  const std::vector<std::uint8_t>& entry = *context_.harness_consumer;
  const SdoOutcome now_value = sdo_upload({0x1016, 1});
  if (now_value.ok && now_value.data == entry) return StepStatus::ok;
  const SdoOutcome outcome = sdo_download({0x1016, 1}, entry);
  const auto value = static_cast<std::uint32_t>(cia301::load_unsigned(entry));
  if (!outcome.ok) {
    return harness_error(
        "setup", fmt::format("1016h sub 1 := {:08X}h (consume the harness heartbeat, so that a "
                             "dead harness stops the drive) was refused after the reset: {}; no "
                             "motion without it",
                             value, outcome.describe()));
  }
  check("setup",
        fmt::format("1016h sub 1 := {:08X}h (consume the harness heartbeat again after "
                    "the reset)",
                    value),
        outcome.describe(), true);
  return StepStatus::ok;
}

StepStatus VectorRun::setup() {
  // The simulated world back to its power-on condition (enable present, no forced switches,
  // no fault causes): a vector that removed an input must not leak into the next one.
  if (context_.options.simulation != nullptr) {
    if (const auto error = context_.options.simulation->reset_inputs(); !error.empty())
      return harness_error("setup", fmt::format("cannot reset the simulated inputs: {}", error));
  }
  // A reset of the DUT's communication (`node`: of the whole node) and the DUT back: on CAN an
  // NMT command and the boot-up awaited; a link without NMT frames (EtherCAT) resets through
  // its port (AL INIT, then PREOP).
  const bool can_link = context_.port.link() == LinkKind::can;
  const auto reset = [&](const char* action, bool node_reset) -> StepStatus {
    if (!can_link) {
      if (auto error = context_.port.reset(node_reset); !error.empty()) {
        return harness_error(action, fmt::format("reset by the {} link: {}",
                                                 to_string(context_.port.link()), error));
      }
      return StepStatus::ok;
    }
    cia301::NmtMaster master;
    const auto frame = master.command(
        node_reset ? cia301::NmtCommand::reset_node : cia301::NmtCommand::reset_communication,
        node());
    if (auto ec = send_nmt(frame))
      return harness_error("setup", fmt::format("cannot send {}: {}", frame, ec.message()));
    return await_bootup(action);
  };
  switch (vector_.setup) {
    case Setup::none:
      break;
    case Setup::restore_defaults: {
      // The SDO server in a known state first, whatever the vector before left (NMT Stopped,
      // where SDO is not served; a transfer it did not finish; SDO COB-IDs it changed), and the
      // drive's power stage off (a drive may refuse 1011h while it is on: Festo, a vector left
      // it SWITCHED ON): reset node, the DUT back.
      if (auto s = reset("setup restore-defaults", true); s != StepStatus::ok) return s;
      // 1011h sub 1 := "load" (6C 6F 61 64), then reset node (CiA 301 §7.5.2.14).
      const std::array<std::uint8_t, 4> load{0x6C, 0x6F, 0x61, 0x64};
      const auto outcome = sdo_download({0x1011, 1}, load);
      restored_defaults_ = true;
      if (!outcome.ok)
        return fail("setup restore-defaults", "1011h sub 1 := \"load\" accepted",
                    outcome.describe());
      [[fallthrough]];
    }
    case Setup::reset_node:
      if (auto s = reset("setup reset-node", true); s != StepStatus::ok) return s;
      break;
    case Setup::reset_communication:
      if (auto s = reset("setup reset-communication", false); s != StepStatus::ok) return s;
      break;
  }
  // The profile's commissioning (FORMAT.md "Commissioning"): after a reset, before the NMT
  // state (SDO is served in Pre-operational) and the CiA 402 state.
  if (vector_.setup != Setup::none) {
    if (auto s = commission(); s != StepStatus::ok) return s;
  }
  // The dead-harness guarantee (DESIGN.md "Safety on real drives"): the DUT consumes the
  // harness heartbeat whenever a motion vector runs. Any reset (this vector's, or an earlier
  // vector's) put 1016h back to its stored value, so it is written again before the drive may
  // move; a motion vector without it is not run.
  if (vector_.motion && context_.harness_consumer) {
    if (auto s = consume_harness_heartbeat(); s != StepStatus::ok) return s;
  }
  // Isolation (isolation.hpp): leaks of earlier vectors, then the snapshot, while the DUT is
  // in the state its reset left (SDO served), before the NMT state of the vector.
  check_leaks();
  take_snapshot();
  // The NMT state, always commanded (also Pre-operational after a boot-up: a DUT may start
  // itself) and confirmed; on a link without NMT, the state that stands for it.
  if (vector_.nmt && *vector_.nmt != cia301::NmtState::boot_up) {
    if (can_link) {
      if (auto s = reach_nmt_state(*vector_.nmt); s != StepStatus::ok) return s;
    } else {
      // The cyclic set-points into the process data outputs, in PREOP before the AL state
      // (FORMAT.md "Cyclic set-points").
      if (auto* port = dynamic_cast<EthercatPort*>(&context_.port)) {
        if (vector_.has_cyclic_step()) {
          can::Duration period = std::chrono::milliseconds(1);
          for (const Step& step : vector_.steps) {
            if (const auto* cyclic = std::get_if<CyclicStep>(&step.action)) {
              period = resolve(cyclic->period);
              break;
            }
          }
          const auto mapped = port->prepare_cyclic(vector_.cyclic_set_points(), period);
          if (!mapped.error.empty()) return harness_error("setup cyclic set-points", mapped.error);
          if (!mapped.not_applicable.empty()) {
            message_ = mapped.not_applicable;
            return StepStatus::not_applicable;
          }
          if (!mapped.done.empty())
            check("setup cyclic set-points",
                  "the set-points in the process data outputs, SM-synchronous where supported, "
                  "the vector's cycle",
                  mapped.done, true);
        }
      }
      const std::string name(cia301::to_string(*vector_.nmt));
      if (auto error = context_.port.enter_state(*vector_.nmt); !error.empty())
        return harness_error("setup nmt", fmt::format("{} not reached: {}", name, error));
      check("setup nmt",
            fmt::format("{} (its {} counterpart) entered", name, to_string(context_.port.link())),
            "ok", true);
    }
  }
  if (vector_.drive_state) {
    if (auto s = reach_drive_state(*vector_.drive_state); s != StepStatus::ok) return s;
  }
  if (can_link) drain();
  return StepStatus::ok;
}

void VectorRun::teardown() {
  if (!context_.profile.supports("cia402") || context_.stalled.load()) return;
  const bool enabled = last_statusword_ && cia402::decode_statusword(*last_statusword_) ==
                                               cia402::State::operation_enabled;
  if (!vector_.motion && !enabled && !context_.interrupted.load()) return;
  // Whatever the verdict, and even past the vector's timeout: the drive must end safe. Quick
  // stop first, and let it finish: disabling the voltage at once would let a moving motor coast
  // (on a real machine, and into the next vector on the simulated one). The quick stop is over
  // when the drive has left OPERATION ENABLED / QUICK STOP ACTIVE / FAULT REACTION ACTIVE
  // (605Ah 0..4: transition 12), or sits in QUICK STOP ACTIVE at standstill (605Ah 5..8: 606Ch
  // reads 0); at most kQuickStopLimit. Then disable voltage.
  constexpr can::Duration kQuickStopLimit = std::chrono::seconds(10);
  const auto write_controlword = [this](std::uint16_t value) {
    deadline_ = now() + resolve({{}, "sdo_response"}) * 3;
    const std::array<std::uint8_t, 2> bytes{static_cast<std::uint8_t>(value),
                                            static_cast<std::uint8_t>(value >> 8)};
    return sdo_download({0x6040, 0}, bytes).ok;
  };
  if (write_controlword(0x0002)) {
    const can::TimePoint limit = now() + kQuickStopLimit;
    while (now() < limit && !context_.stalled.load()) {
      deadline_ = now() + resolve({{}, "sdo_response"}) * 3;
      const SdoOutcome status = sdo_upload({0x6041, 0});
      if (!status.ok || status.data.size() < 2) break;
      const auto word = static_cast<std::uint16_t>(status.data[0] | (status.data[1] << 8));
      const auto decoded = cia402::decode_statusword(word);
      if (!decoded) break;
      const cia402::State state = *decoded;
      if (state != cia402::State::operation_enabled && state != cia402::State::quick_stop_active &&
          state != cia402::State::fault_reaction_active) {
        break;
      }
      if (state == cia402::State::quick_stop_active) {
        const SdoOutcome velocity = sdo_upload({0x606C, 0});
        if (!velocity.ok) break;  // no velocity to watch: nothing more to wait for
        if (std::all_of(velocity.data.begin(), velocity.data.end(),
                        [](std::uint8_t byte) { return byte == 0; })) {
          break;
        }
      }
      wait_until(now() + resolve({{}, "poll"}) * 4);
    }
  }
  (void)write_controlword(0x0000);
}

// ---- isolation (isolation.hpp) ----

namespace {

std::string hex_bytes(const Bytes& bytes) {
  return bytes.empty() ? std::string("(empty)") : fmt::format("{:02X}", fmt::join(bytes, " "));
}

constexpr std::array<std::uint8_t, 4> kSave{0x73, 0x61, 0x76, 0x65};  // "save", CiA 301 §7.5.2.13

}  // namespace

std::string Leak::describe() const {
  return fmt::format(
      "{} still holds {} (was {}{}) from vector {}", to_string(ref),
      actual ? hex_bytes(*actual) : std::string("an unknown value"), hex_bytes(expected),
      store ? fmt::format(", stored with 1010h sub {}", *store) : std::string(), vector_id);
}

SdoOutcome VectorRun::write_back(cia301::Multiplexer mux, Bytes& data) {
  SdoOutcome outcome = sdo_download(mux, data);
  // Refused for its length (CiA 301 §7.2.4.3.17: 06070010h, 06070012h too long) with zero
  // bytes at the end: the value was read padded (an upload answered 4 bytes for a shorter
  // object); the zero padding goes, down to the length the DUT takes.
  while (!outcome.ok && outcome.abort &&
         (*outcome.abort == 0x06070010 || *outcome.abort == 0x06070012) && data.size() > 1 &&
         data.back() == 0) {
    data.pop_back();
    outcome = sdo_download(mux, data);
  }
  return outcome;
}

void VectorRun::check_leaks() {
  standing_leaks_.clear();
  if (!context_.options.isolation) return;
  std::vector<std::string> standing;
  for (auto it = context_.leaks.begin(); it != context_.leaks.end();) {
    Leak& leak = it->second;
    const auto ref = leak.ref;
    const SdoOutcome now_value = sdo_upload({ref.index, ref.sub});
    bool back = now_value.ok && now_value.data == leak.expected;
    std::string how = "read back";
    if (!back) {
      Bytes data = leak.expected;
      const SdoOutcome put = write_back({ref.index, ref.sub}, data);
      back = put.ok;
      how = "written back";
      if (back && leak.store) {
        back =
            sdo_download({0x1010, *leak.store}, kSave, Transfer::automatic, std::chrono::seconds(5))
                .ok;
        how = "written back and stored";
      }
      if (now_value.ok) leak.actual = now_value.data;
    }
    if (back) {
      note(fmt::format("vector {}: {} is back to {} ({} before vector {})", leak.vector_id,
                       to_string(ref), hex_bytes(leak.expected), how, vector_.id));
      it = context_.leaks.erase(it);
      continue;
    }
    standing.push_back(leak.describe());
    ++it;
  }
  if (!standing.empty()) standing_leaks_ = fmt::format("{}", fmt::join(standing, "; "));
}

void VectorRun::take_snapshot() {
  snapshot_.clear();
  written_.clear();
  request_sizes_.clear();
  stored_.clear();
  tracking_writes_ = false;
  if (!context_.options.isolation) return;
  std::vector<std::string> values;
  for (const ObjectRef& ref : snapshot_objects(vector_, node())) {
    const SdoOutcome outcome = sdo_upload({ref.index, ref.sub});
    if (outcome.ok) {
      snapshot_[ref] = outcome.data;
      values.push_back(fmt::format("{} = {}", to_string(ref), hex_bytes(outcome.data)));
    } else {
      values.push_back(fmt::format("{}: {} (not restored)", to_string(ref), outcome.describe()));
    }
  }
  if (!values.empty()) {
    check("snapshot", "the objects the vector may change, read before its steps",
          fmt::format("{}", fmt::join(values, "; ")), true);
  }
  tracking_writes_ = true;
}

void VectorRun::run_finally() {
  if (vector_.finally_steps.empty() || context_.stalled.load()) return;
  const std::string message = message_;
  const auto budget = resolve(vector_.timeout);
  deadline_ = now() + budget;
  const std::size_t first = vector_.steps.size();
  for (std::size_t i = 0; i < vector_.finally_steps.size(); ++i) {
    const Step& step = vector_.finally_steps[i];
    step_index_ = first + i;
    action_ = std::string(action_name(step.action));
    drain();
    StepStatus status = run_stimulus(step);
    if (status == StepStatus::ok) status = run_expectation(step);
    if (status != StepStatus::ok) {
      note(fmt::format("vector {}: finally {} ({}, line {}) did not succeed: {}", vector_.id,
                       step_place(vector_.finally_steps, i), action_, step.line, message_));
    }
    if (vector_timed_out()) {
      note(fmt::format("vector {}: finally: its time budget ({}) ran out at {}", vector_.id,
                       profile::format_duration(budget), step_place(vector_.finally_steps, i)));
      break;
    }
    if (context_.stalled.load()) break;
  }
  drain();
  message_ = message;
}

void VectorRun::restore() {
  tracking_writes_ = false;
  // The PDO mapping and sync mode the setup gave the cyclic steps (FORMAT.md "Cyclic
  // set-points") go back in PREOP (the next reset would too; a run's last vector has none).
  if (auto* port = dynamic_cast<EthercatPort*>(&context_.port);
      port != nullptr && port->cyclic_configured() && !context_.stalled.load()) {
    const bool was_op = port->master().held_state() == ethercat::AlState::op;
    std::string error = context_.port.enter_state(cia301::NmtState::pre_operational);
    // Leaving OP is a loss of the master's connection to the drive (its 6007h reaction, e.g. a
    // fault): let the drive take it now, not in the next vector's setup or steps.
    if (error.empty() && was_op) {
      const auto settle = resolve({{}, "state_change"});
      deadline_ = std::max(deadline_, now() + settle);  // the vector's own may have passed
      wait_until(now() + settle);
    }
    if (error.empty()) error = port->restore_cyclic();
    if (!error.empty())
      note(fmt::format("vector {}: putting the cyclic configuration back: {}", vector_.id, error));
  }
  if (!context_.options.isolation || context_.stalled.load()) return;
  if (restored_defaults_ && context_.options.real_bus) {
    note(
        fmt::format("vector {}: restored the factory defaults (1011h): the stored parameters "
                    "it did not write itself are not put back",
                    vector_.id));
  }
  std::set<ObjectRef> written;
  for (const ObjectRef& ref : written_) {
    if (snapshot_.count(ref) != 0) written.insert(ref);
  }
  if (written.empty() && stored_.empty()) return;
  // A generous budget of its own: the vector's deadline may have passed.
  deadline_ = now() + resolve({{}, "sdo_response"}) * (8 * (snapshot_.size() + 2)) +
              std::chrono::seconds(5) * stored_.size();
  // SDO is served in Pre-operational whatever NMT state the vector left (the next vector's
  // setup commands its own state); on a link without NMT frames, in its counterpart (EtherCAT:
  // PREOP, where the mailbox is served and no process data overwrites what is put back).
  if (context_.port.link() == LinkKind::can) {
    cia301::NmtMaster master;
    if (auto ec = send_nmt(master.command(cia301::NmtCommand::enter_pre_operational, node())); !ec)
      wait_until(now() + std::chrono::milliseconds(1));
  } else if (auto error = context_.port.enter_state(cia301::NmtState::pre_operational);
             !error.empty()) {
    note(fmt::format("vector {}: restore: {} not reached by the {} link: {}", vector_.id,
                     cia301::to_string(cia301::NmtState::pre_operational),
                     to_string(context_.port.link()), error));
  }
  RestoreInput input;
  input.before = snapshot_;
  input.written = written;
  for (const auto& [ref, value] : snapshot_) {
    const SdoOutcome outcome = sdo_upload({ref.index, ref.sub});
    if (outcome.ok) input.after[ref] = outcome.data;
  }
  const auto read_only = [](cia301::AccessType access) {
    return access == cia301::AccessType::ro || access == cia301::AccessType::constant;
  };
  for (const auto& object : context_.profile.objects) {
    if (read_only(object.access)) input.read_only.insert(ObjectRef{object.index, object.sub});
  }
  if (context_.options.eds != nullptr) {
    for (const ObjectRef& ref : written) {
      const auto* entry = context_.options.eds->find(ref.index, ref.sub);
      if (entry != nullptr && read_only(entry->access())) input.read_only.insert(ref);
    }
  }
  // A value read longer than the vector wrote it, with zeros past that length (a DUT that
  // pads 1- and 2-byte values to 4 in its upload response), goes back as long as it was written.
  for (const auto& [ref, size] : request_sizes_) {
    const auto trim = [size = size](Bytes& value) {
      if (value.size() > size &&
          std::all_of(value.begin() + static_cast<std::ptrdiff_t>(size), value.end(),
                      [](std::uint8_t byte) { return byte == 0; }))
        value.resize(size);
    };
    if (const auto it = input.before.find(ref); it != input.before.end()) trim(it->second);
    if (const auto it = input.after.find(ref); it != input.after.end()) trim(it->second);
  }
  const RestorePlan plan = plan_restore(input);
  std::vector<std::string> done;
  std::set<ObjectRef> failed;
  for (const RestoreWrite& write : plan.writes) {
    Bytes data = write.data;
    const SdoOutcome outcome = write_back({write.ref.index, write.ref.sub}, data);
    done.push_back(fmt::format("{} := {} ({}): {}", to_string(write.ref), hex_bytes(data),
                               write.why, outcome.describe()));
    if (!outcome.ok) failed.insert(write.ref);
  }
  // What the vector stored goes back into non-volatile memory: the values before the vector
  // (now current again) stored with the same sub-index.
  std::optional<std::uint8_t> store_failed;
  for (const std::uint8_t sub : stored_) {
    const SdoOutcome outcome =
        sdo_download({0x1010, sub}, kSave, Transfer::automatic, std::chrono::seconds(5));
    done.push_back(
        fmt::format("1010h sub {} := \"save\" (store them again): {}", sub, outcome.describe()));
    if (!outcome.ok) store_failed = sub;
  }
  for (const std::string& skipped : plan.skipped)
    done.push_back("skipped " + skipped);
  const bool ok = failed.empty() && !store_failed;
  if (!done.empty()) {
    check("restore", "every object the vector changed back to its value before the vector",
          fmt::format("{}", fmt::join(done, "; ")), ok);
  }
  // What could not be put back is a leak: a note now, and later failures become errors.
  std::set<ObjectRef> leaked = failed;
  if (store_failed) leaked.insert(written.begin(), written.end());
  for (const ObjectRef& ref : leaked) {
    Leak leak;
    leak.ref = ref;
    leak.expected = input.before.at(ref);
    if (const auto after = input.after.find(ref); after != input.after.end())
      leak.actual = after->second;
    if (store_failed || !stored_.empty())
      leak.store = store_failed ? *store_failed : *stored_.begin();
    leak.vector_id = vector_.id;
    note(fmt::format("vector {}: could not undo its change: {}", vector_.id, leak.describe()));
    context_.leaks[ref] = std::move(leak);
  }
}

}  // namespace drivecheck::conformance
