#include "protocol/ethercat/esc_slave.hpp"

namespace drivecheck::ethercat {
namespace {

std::optional<SiiImage> parse(const std::vector<std::uint8_t>& bytes) {
  if (bytes.empty()) return std::nullopt;
  auto image = parse_sii(bytes);
  if (!image) return std::nullopt;
  return std::move(*image);
}

}  // namespace

EscSlave::EscSlave(EscSlaveConfig config)
    : config_(std::move(config)),
      esc_(config_.esc),
      state_machine_([this] {
        AlConfig al;
        al.bootstrap = config_.bootstrap;
        al.check = [this](const AlTransition& t) {
          const AlStatusCode own = builtin_check(t);
          if (own != AlStatusCode::no_error || !config_.check) return own;
          return config_.check(t);
        };
        al.on_state_change = [this](AlState from, AlState to) {
          if (config_.on_state_change) config_.on_state_change(from, to);
        };
        return al;
      }()),
      sii_(parse(config_.esc.sii)) {
  publish();
}

AlStatusCode EscSlave::builtin_check(const AlTransition& transition) const {
  if (!sii_) return AlStatusCode::no_error;
  const SiiHeader& h = sii_->header;
  switch (transition.requirement) {
    case AlRequirement::mailbox:
    case AlRequirement::bootstrap: {
      const bool boot = transition.requirement == AlRequirement::bootstrap;
      const SiiMailbox& receive = boot ? h.bootstrap_receive : h.standard_receive;
      const SiiMailbox& send = boot ? h.bootstrap_send : h.standard_send;
      if (receive.size == 0 && send.size == 0) break;
      const SyncManagerRegisters out = esc_.sync_manager(0);
      const SyncManagerRegisters in = esc_.sync_manager(1);
      const bool out_ok = out.enabled() && out.mailbox() && out.ecat_writes() &&
                          out.start == receive.offset && out.length == receive.size;
      const bool in_ok = in.enabled() && in.mailbox() && !in.ecat_writes() &&
                         in.start == send.offset && in.length == send.size;
      if (!out_ok || !in_ok) {
        return boot ? AlStatusCode::invalid_mailbox_configuration_boot
                    : AlStatusCode::invalid_mailbox_configuration;
      }
      break;
    }
    case AlRequirement::process_data: {
      if (!config_.check_process_data) break;
      for (std::size_t n = 0; n < sii_->sync_managers.size() && n < 16; ++n) {
        const SiiSyncManager& wanted = sii_->sync_managers[n];
        const bool outputs = wanted.type == SiiSyncManagerType::outputs;
        const bool inputs = wanted.type == SiiSyncManagerType::inputs;
        if ((!outputs && !inputs) || wanted.length == 0) continue;
        const SyncManagerRegisters r = esc_.sync_manager(static_cast<unsigned>(n));
        const bool ok = r.enabled() && !r.mailbox() && r.ecat_writes() == outputs &&
                        r.start == wanted.start && r.length == wanted.length;
        if (!ok) {
          return outputs ? AlStatusCode::invalid_output_configuration
                         : AlStatusCode::invalid_input_configuration;
        }
      }
      break;
    }
    case AlRequirement::none:
    case AlRequirement::outputs:
      break;
  }
  return AlStatusCode::no_error;
}

void EscSlave::publish() {
  const AlStatus& status = state_machine_.status();
  esc_.pdi_set_al_status(status.register_value(), static_cast<std::uint16_t>(status.code));
}

void EscSlave::handle(const EscEvents& events) {
  if (events.watchdog_expired && config_.sm_watchdog_drops_op) {
    state_machine_.sm_watchdog_expired();
    publish();
  }
  if (events.al_control) {
    state_machine_.request(esc_.pdi_read16(reg::kAlControl));
    publish();
  }
  if (config_.on_events && events.any()) config_.on_events(*this, events);
}

void EscSlave::advance(TimePoint now) {
  handle(esc_.advance(now));
}

void EscSlave::on_frame(std::span<std::uint8_t> frame, TimePoint arrival,
                        std::optional<TimePoint> return_arrival) {
  advance(arrival);
  handle(esc_.process_frame(frame, arrival, return_arrival));
}

}  // namespace drivecheck::ethercat
