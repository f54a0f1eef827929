// The `cyclic` step (FORMAT.md "Cyclic set-points"): the set-points of the cyclic modes (csp,
// csv, cst, ip) delivered the way each link delivers them, so that one vector judges a drive on
// both. On CAN: each set-point an SDO download before the first cycle, each cycle a SYNC (080h)
// and a wait of the period, the same frames and timing the vectors had as `sdo_write`, `send:
// "080#"`, `wait`. On EtherCAT: the set-points in the process data outputs (mapped by the setup,
// EthercatPort::prepare_cyclic), carried by the process data cycle for cycles x period; the
// drive in SM-synchronous mode takes each LRW as its SYNC (ETG.1020 as public), in free run
// it takes them every drive cycle.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <string>
#include <vector>

#include "conformance/ethercat_port.hpp"
#include "conformance/vector_run.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {

StepStatus VectorRun::run_cyclic(const Step& step, const CyclicStep& cyclic) {
  const std::string name = "cyclic";
  const auto period = resolve(cyclic.period);
  if (context_.port.link() == LinkKind::can) {
    for (const CyclicSetPoint& point : cyclic.set) {
      SdoWriteStep write;
      write.index = point.index;
      write.sub = point.sub;
      write.value = point.value;
      write.size = point.size;
      const Step as_write{write, step.note, step.line, {}};
      if (const auto status = run_stimulus(as_write); status != StepStatus::ok) return status;
    }
    // The SYNC of the default COB-ID 1005h = 80h (CiA 301 §7.5.2.5), as the vectors sent it.
    const auto sync = can::Frame::standard(0x080, std::initializer_list<std::uint8_t>{});
    for (std::size_t i = 0; i < cyclic.cycles; ++i) {
      send_asked_ = now();
      const auto ec = send(sync);
      send_asked_.reset();
      if (ec) return harness_error(name, fmt::format("cannot send {}: {}", sync, ec.message()));
      wait_until(now() + period);
    }
    return StepStatus::ok;
  }
  auto* port = dynamic_cast<EthercatPort*>(&context_.port);
  if (port == nullptr) return harness_error(name, "no EtherCAT port on this link");
  auto& master = port->master();
  if (master.held_state() != ethercat::AlState::op)
    return harness_error(name, fmt::format("the set-points are taken in OP (the master holds the "
                                           "slave in {}): nmt: operational",
                                           ethercat::al_state_name(master.held_state())));
  std::vector<std::string> values;
  for (const CyclicSetPoint& point : cyclic.set) {
    std::string error;
    const auto value = value_of(point.value, error);
    if (!value) return harness_error(name, error);
    const auto bits = 8 * point.size;
    const auto raw = bits >= 64 ? static_cast<std::uint64_t>(*value)
                                : static_cast<std::uint64_t>(*value) & ((1ULL << bits) - 1);
    if (!master.set_output(0, {point.index, point.sub}, raw))
      return harness_error(name, fmt::format("{:04X}h sub {} is not in the process data outputs "
                                             "(the setup maps it)",
                                             point.index, point.sub));
    // Isolation puts it back after the vector, as a download of it on CAN.
    note_download_request({point.index, point.sub}, point.size);
    note_confirmed_download({point.index, point.sub});
    values.push_back(fmt::format("{:04X}h sub {} = {}", point.index, point.sub, *value));
  }
  // N process data frames, one per cycle (prepare_cyclic set the cycle to the vector's period),
  // each checked; the step ends when the next one is due, as on CAN a period after the SYNC.
  const auto expected = fmt::format(
      "{} process data cycle(s), {} apart: {} in the outputs of each (LRW), working counter "
      "and OP held",
      cyclic.cycles, profile::format_duration(period),
      values.empty() ? std::string("the set-points as they are")
                     : fmt::format("{}", fmt::join(values, ", ")));
  const auto first = now();
  for (std::size_t i = 0; i < cyclic.cycles; ++i) {
    if (vector_timed_out()) break;
    const auto outcome = port->checked_cycle();
    if (!outcome.result || !outcome.error.empty())
      return harness_error(
          name, fmt::format("{}: cycle {} failed, the set-points did not arrive: {}", expected,
                            i + 1, outcome.error));
  }
  wait_until(port->next_cycle());
  const auto duration = now() - first;
  note_dut_answer();
  check(name, expected, fmt::format("{} of process data", profile::format_duration(duration)),
        true);
  return StepStatus::ok;
}

}  // namespace drivecheck::conformance
