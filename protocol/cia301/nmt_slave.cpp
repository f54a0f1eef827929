#include "protocol/cia301/nmt_slave.hpp"

#include <cassert>
#include <utility>

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/error_control.hpp"

namespace drivecheck::cia301 {

std::string_view to_string(NmtService service) {
  switch (service) {
    case NmtService::pdo:
      return "PDO";
    case NmtService::sdo:
      return "SDO";
    case NmtService::sync:
      return "SYNC";
    case NmtService::time:
      return "TIME";
    case NmtService::emcy:
      return "EMCY";
    case NmtService::boot_up:
      return "boot-up";
    case NmtService::node_control:
      return "NMT node control";
    case NmtService::error_control:
      return "NMT error control";
  }
  return "?";
}

std::string_view to_string(NmtSlaveAction action) {
  switch (action) {
    case NmtSlaveAction::ignored:
      return "ignored";
    case NmtSlaveAction::unchanged:
      return "unchanged";
    case NmtSlaveAction::state_changed:
      return "state changed";
    case NmtSlaveAction::reset_node:
      return "reset node";
    case NmtSlaveAction::reset_communication:
      return "reset communication";
  }
  return "?";
}

std::optional<can::Frame> NmtSlave::finish_initialisation(std::uint8_t node_id) {
  assert(is_valid_node_id(node_id));
  if (state_ != NmtState::boot_up) return std::nullopt;
  node_id_ = node_id;
  state_ = NmtState::pre_operational;
  return encode(BootUp{node_id_});
}

NmtSlaveResult NmtSlave::on_frame(const can::Frame& frame) {
  NmtSlaveResult result;
  result.before = result.after = state_;
  if (frame.is_error() || frame.is_extended() || frame.is_remote() || frame.id != kNmtCobId) {
    result.ignored_because = NmtIgnoreReason::not_nmt;
    return result;
  }
  const auto message = decode_nmt_node_control(frame);
  if (!message) {
    result.ignored_because = NmtIgnoreReason::malformed;
    return result;
  }
  if (!message->is_broadcast() && message->node != node_id_) {
    result.command = message->command;
    result.ignored_because = NmtIgnoreReason::other_node;
    return result;
  }
  return obey(message->command, message->is_broadcast());
}

NmtSlaveResult NmtSlave::apply(NmtCommand command) {
  return obey(command, false);
}

NmtSlaveResult NmtSlave::obey(NmtCommand command, bool broadcast) {
  NmtSlaveResult result;
  result.before = result.after = state_;
  result.command = command;
  result.broadcast = broadcast;
  if (state_ == NmtState::boot_up) {
    result.ignored_because = NmtIgnoreReason::initialising;
    return result;
  }
  switch (command) {
    case NmtCommand::reset_node:
    case NmtCommand::reset_communication:
      state_ = NmtState::boot_up;
      result.after = state_;
      result.action = command == NmtCommand::reset_node ? NmtSlaveAction::reset_node
                                                        : NmtSlaveAction::reset_communication;
      return result;
    case NmtCommand::start:
    case NmtCommand::stop:
    case NmtCommand::enter_pre_operational: {
      const NmtState target = state_after(command);
      result.action = target == state_ ? NmtSlaveAction::unchanged : NmtSlaveAction::state_changed;
      state_ = target;
      result.after = state_;
      return result;
    }
  }
  return result;
}

std::optional<NmtCommand> communication_error_command(NmtState state, std::uint8_t behaviour) {
  switch (behaviour) {
    case static_cast<std::uint8_t>(CommunicationErrorBehaviour::pre_operational):
      if (state == NmtState::operational) return NmtCommand::enter_pre_operational;
      return std::nullopt;
    case static_cast<std::uint8_t>(CommunicationErrorBehaviour::stopped):
      if (state == NmtState::pre_operational || state == NmtState::operational) {
        return NmtCommand::stop;
      }
      return std::nullopt;
    default:
      return std::nullopt;  // 01h no change; 80h..FFh manufacturer: no change here
  }
}

Expected<void, std::string> add_error_behaviour_objects(ObjectDictionary& od) {
  ObjectDefinition def;
  def.index = kErrorBehaviourIndex;
  def.name = "Error behavior";
  def.code = ObjectCode::array;
  def.entries.push_back(EntryDefinition::unsigned_entry(0, "Highest sub-index supported",
                                                        DataType::unsigned8, AccessType::ro, 1));
  def.entries.push_back(EntryDefinition::unsigned_entry(1, "Communication error",
                                                        DataType::unsigned8, AccessType::rw, 0));
  auto added = od.add_object(std::move(def));
  if (!added) return Unexpected(added.error());
  (*added)->find(1)->set_write_validator(
      [](const ObjectDictionary&, const Entry&,
         std::span<const std::uint8_t> data) -> Expected<void, SdoAbort> {
        const std::uint8_t value = data[0];
        if (value >= 0x03 && value <= 0x7F) return Unexpected(SdoAbort::invalid_value);
        return {};
      });
  return {};
}

}  // namespace drivecheck::cia301
