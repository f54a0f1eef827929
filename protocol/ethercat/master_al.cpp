#include "protocol/ethercat/master_al.hpp"

#include <fmt/format.h>

#include "protocol/ethercat/esc.hpp"

namespace drivecheck::ethercat {

std::string AlReading::describe() const {
  std::string out = al_state_name(state_bits());
  if (error()) out += " + error";
  if (code != 0 || error()) out += ", " + describe_al_status_code(code);
  return out;
}

Expected<AlReading, MasterError> read_al_status(MasterPort& port, std::uint16_t station) {
  auto bytes = port.read(Command::fprd, station, reg::kAlStatus, 6);
  if (!bytes) return Unexpected(bytes.error());
  AlReading reading;
  reading.station = station;
  reading.status = get_le16(*bytes, 0);
  reading.code = get_le16(*bytes, 4);
  return reading;
}

Expected<void, MasterError> acknowledge_al_error(MasterPort& port, const AlReading& reading) {
  return port.write(Command::fpwr, reading.station, reg::kAlControl,
                    le16(static_cast<std::uint16_t>(reading.state_bits() | kAlControlAcknowledge)));
}

Expected<AlReading, MasterError> request_al_state(MasterPort& port, std::uint16_t station,
                                                  AlState target, const AlOptions& options) {
  auto before = read_al_status(port, station);
  if (!before) return before;
  auto control = static_cast<std::uint16_t>(target);
  if (before->error()) control |= kAlControlAcknowledge;
  if (auto written = port.write(Command::fpwr, station, reg::kAlControl, le16(control)); !written) {
    return Unexpected(written.error());
  }
  const TimePoint deadline = port.now() + options.timeout;
  for (;;) {
    auto now = read_al_status(port, station);
    if (!now) return now;
    // A slave that has not yet handled the request (a real one takes its time) still shows the
    // error it had before: that is no refusal until the timeout says so.
    const bool unchanged = before->error() && now->status == before->status &&
                           now->code == before->code && port.now() < deadline;
    if (now->error() && !unchanged) {
      if (options.acknowledge) {
        if (auto ack = acknowledge_al_error(port, *now); !ack) return Unexpected(ack.error());
      }
      auto error = master_error(
          MasterErrc::al_refused,
          fmt::format("station {:04X}h refused {} (from {}): AL status {}", station,
                      al_state_name(target), al_state_name(before->state_bits()), now->describe()),
          station);
      MasterError e = error.error();
      e.al_status_code = now->code;
      return Unexpected(std::move(e));
    }
    if (now->in(target)) return now;
    if (port.now() >= deadline) {
      return master_error(
          MasterErrc::al_timeout,
          fmt::format(
              "station {:04X}h did not reach {} within {} ms: AL status {}", station,
              al_state_name(target),
              std::chrono::duration_cast<std::chrono::milliseconds>(options.timeout).count(),
              now->describe()),
          station);
    }
    if (options.between_polls) options.between_polls();
    port.wait(options.poll_interval);
  }
}

}  // namespace drivecheck::ethercat
