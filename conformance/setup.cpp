// Before and after each vector (FORMAT.md `setup:`, `nmt:`, `drive_state:`, "Teardown").
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <span>

#include "conformance/vector_run.hpp"
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
  const auto await = [&](cia402::State state) {
    const auto& pattern = cia402::pattern_of(state);
    return poll_statusword(
        action, pattern.mask, pattern.value,
        fmt::format("state {} within {}", pattern.name, profile::format_duration(state_change)),
        now() + state_change);
  };
  // From wherever the drive is: fault reset if in FAULT, then disable voltage to SWITCH ON
  // DISABLED, then the standard path 2, 3, 4 (and 11 for QUICK STOP ACTIVE).
  const auto read = sdo_upload({0x6041, 0});
  if (!read.ok) return fail(action, "statusword 6041h readable", read.describe());
  if (read.data.size() == 2) {
    const auto sw = static_cast<std::uint16_t>(read.data[0] | read.data[1] << 8);
    const auto state = cia402::decode_statusword(sw);
    if (state == cia402::State::fault || state == cia402::State::fault_reaction_active) {
      if (auto s = write_controlword(0x0000, action); s != StepStatus::ok) return s;
      if (auto s = write_controlword(cia402::controlword_of(cia402::Command::fault_reset), action);
          s != StepStatus::ok)
        return s;
    }
  }
  if (auto s = write_controlword(cia402::controlword_of(cia402::Command::disable_voltage), action);
      s != StepStatus::ok)
    return s;
  if (auto s = await(cia402::State::switch_on_disabled); s != StepStatus::ok) return s;
  if (target == cia402::State::switch_on_disabled) return StepStatus::ok;
  if (auto s = write_controlword(cia402::controlword_of(cia402::Command::shutdown), action);
      s != StepStatus::ok)
    return s;
  if (auto s = await(cia402::State::ready_to_switch_on); s != StepStatus::ok) return s;
  if (target == cia402::State::ready_to_switch_on) return StepStatus::ok;
  if (auto s = write_controlword(cia402::controlword_of(cia402::Command::switch_on), action);
      s != StepStatus::ok)
    return s;
  if (auto s = await(cia402::State::switched_on); s != StepStatus::ok) return s;
  if (target == cia402::State::switched_on) return StepStatus::ok;
  if (auto s = write_controlword(cia402::controlword_of(cia402::Command::enable_operation), action);
      s != StepStatus::ok)
    return s;
  if (auto s = await(cia402::State::operation_enabled); s != StepStatus::ok) return s;
  if (target == cia402::State::operation_enabled) return StepStatus::ok;
  if (auto s = write_controlword(cia402::controlword_of(cia402::Command::quick_stop), action);
      s != StepStatus::ok)
    return s;
  return await(cia402::State::quick_stop_active);
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

StepStatus VectorRun::setup() {
  cia301::NmtMaster master;
  const auto command = [&](cia301::NmtCommand cmd) -> StepStatus {
    const auto frame = master.command(cmd, node());
    if (auto ec = send_nmt(frame))
      return harness_error("setup", fmt::format("cannot send {}: {}", frame, ec.message()));
    return StepStatus::ok;
  };
  // The simulated world back to its power-on condition (enable present, no forced switches,
  // no fault causes): a vector that removed an input must not leak into the next one.
  if (context_.options.simulation != nullptr) {
    if (const auto error = context_.options.simulation->reset_inputs(); !error.empty())
      return harness_error("setup", fmt::format("cannot reset the simulated inputs: {}", error));
  }
  bool booted = false;
  switch (vector_.setup) {
    case Setup::none:
      break;
    case Setup::restore_defaults: {
      // The SDO server in a known state first, whatever the vector before left (NMT Stopped,
      // where SDO is not served; a transfer it did not finish; SDO COB-IDs it changed): reset
      // communication, boot-up awaited.
      if (auto s = command(cia301::NmtCommand::reset_communication); s != StepStatus::ok) return s;
      if (auto s = await_bootup("setup restore-defaults"); s != StepStatus::ok) return s;
      // 1011h sub 1 := "load" (6C 6F 61 64), then reset node (CiA 301 §7.5.2.14).
      const std::array<std::uint8_t, 4> load{0x6C, 0x6F, 0x61, 0x64};
      const auto outcome = sdo_download({0x1011, 1}, load);
      if (!outcome.ok)
        return fail("setup restore-defaults", "1011h sub 1 := \"load\" accepted",
                    outcome.describe());
      [[fallthrough]];
    }
    case Setup::reset_node:
      if (auto s = command(cia301::NmtCommand::reset_node); s != StepStatus::ok) return s;
      if (auto s = await_bootup("setup reset-node"); s != StepStatus::ok) return s;
      booted = true;
      break;
    case Setup::reset_communication:
      if (auto s = command(cia301::NmtCommand::reset_communication); s != StepStatus::ok) return s;
      if (auto s = await_bootup("setup reset-communication"); s != StepStatus::ok) return s;
      booted = true;
      break;
  }
  // The profile's commissioning (FORMAT.md "Commissioning"): after a reset, before the NMT
  // state (SDO is served in Pre-operational) and the CiA 402 state.
  if (vector_.setup != Setup::none) {
    if (auto s = commission(); s != StepStatus::ok) return s;
  }
  if (vector_.nmt) {
    switch (*vector_.nmt) {
      case cia301::NmtState::pre_operational:
        if (!booted) {
          if (auto s = command(cia301::NmtCommand::enter_pre_operational); s != StepStatus::ok)
            return s;
        }
        break;
      case cia301::NmtState::operational:
        if (auto s = command(cia301::NmtCommand::start); s != StepStatus::ok) return s;
        break;
      case cia301::NmtState::stopped:
        if (auto s = command(cia301::NmtCommand::stop); s != StepStatus::ok) return s;
        break;
      case cia301::NmtState::boot_up:
        break;
    }
    // NMT is not acknowledged: give the frame its time on the wire, and the DUT a moment.
    wait_until(now() + std::chrono::milliseconds(1));
  }
  if (vector_.drive_state) {
    if (auto s = reach_drive_state(*vector_.drive_state); s != StepStatus::ok) return s;
  }
  drain();
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

}  // namespace drivecheck::conformance
