#include "protocol/ethercat/al_state_machine.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <iterator>

namespace drivecheck::ethercat {
namespace {

constexpr AlStatusCodeInfo kCodes[] = {
#define DRIVECHECK_AL_STATUS_CODE(name, value, text, source) \
  {AlStatusCode::name, #name, text, source},
#include "protocol/ethercat/al_status_codes.inc"
#undef DRIVECHECK_AL_STATUS_CODE
};

constexpr bool codes_sorted() {
  for (std::size_t i = 1; i < std::size(kCodes); ++i) {
    if (static_cast<unsigned>(kCodes[i - 1].code) >= static_cast<unsigned>(kCodes[i].code)) {
      return false;
    }
  }
  return true;
}
static_assert(codes_sorted(), "al_status_codes.inc must list codes in ascending order, once each");

constexpr bool transitions_unique() {
  for (std::size_t i = 0; i < kAlTransitions.size(); ++i) {
    if (kAlTransitions[i].from == kAlTransitions[i].to) return false;
    for (std::size_t j = i + 1; j < kAlTransitions.size(); ++j) {
      if (kAlTransitions[i].from == kAlTransitions[j].from &&
          kAlTransitions[i].to == kAlTransitions[j].to) {
        return false;
      }
    }
  }
  return true;
}
static_assert(transitions_unique(), "kAlTransitions lists each pair of distinct states once");

class AlStatusCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "al-status"; }
  std::string message(int value) const override {
    return describe_al_status_code(static_cast<std::uint16_t>(value));
  }
};

}  // namespace

int al_state_rank(AlState state) {
  switch (state) {
    case AlState::init:
      return 0;
    case AlState::preop:
    case AlState::boot:
      return 1;
    case AlState::safeop:
      return 2;
    case AlState::op:
      return 3;
  }
  return 0;
}

std::string al_state_name(std::uint8_t value) {
  switch (value) {
    case 1:
      return "INIT";
    case 2:
      return "PREOP";
    case 3:
      return "BOOT";
    case 4:
      return "SAFEOP";
    case 8:
      return "OP";
    default:
      return fmt::format("state {}", value);
  }
}

std::optional<AlState> al_state_from(std::uint8_t value) {
  switch (value) {
    case 1:
    case 2:
    case 3:
    case 4:
    case 8:
      return static_cast<AlState>(value);
    default:
      return std::nullopt;
  }
}

std::span<const AlStatusCodeInfo> al_status_code_table() {
  return kCodes;
}

std::optional<AlStatusCodeInfo> find_al_status_code(std::uint16_t value) {
  const auto* it = std::lower_bound(std::begin(kCodes), std::end(kCodes), value,
                                    [](const AlStatusCodeInfo& row, std::uint16_t v) {
                                      return static_cast<std::uint16_t>(row.code) < v;
                                    });
  if (it == std::end(kCodes) || static_cast<std::uint16_t>(it->code) != value) {
    return std::nullopt;
  }
  return *it;
}

std::string describe_al_status_code(std::uint16_t value) {
  if (const auto info = find_al_status_code(value)) {
    return fmt::format("{:04X}h {}: {}", value, info->name, info->text);
  }
  return fmt::format("{:04X}h (unknown AL status code)", value);
}

const std::error_category& al_status_category() {
  static const AlStatusCategory category;
  return category;
}

std::error_code make_error_code(AlStatusCode code) {
  return {static_cast<int>(code), al_status_category()};
}

const AlTransition* find_al_transition(AlState from, AlState to) {
  for (const AlTransition& row : kAlTransitions) {
    if (row.from == from && row.to == to) return &row;
  }
  return nullptr;
}

AlStateMachine::AlStateMachine(AlConfig config) : config_(std::move(config)) {}

void AlStateMachine::enter(AlState to) {
  const AlState from = status_.state;
  status_.state = to;
  if (config_.on_state_change && from != to) config_.on_state_change(from, to);
}

const AlStatus& AlStateMachine::request(std::uint16_t al_control) {
  const auto requested_value = static_cast<std::uint8_t>(al_control & kAlControlStateMask);
  const bool acknowledge = (al_control & kAlControlAcknowledge) != 0;
  if (status_.error && acknowledge) {
    status_.error = false;
    status_.code = AlStatusCode::no_error;
  }
  const auto requested = al_state_from(requested_value);
  if (!requested) {
    status_.error = true;
    status_.code = AlStatusCode::unknown_requested_state;
    return status_;
  }
  if (*requested == status_.state) return status_;
  // An unacknowledged error holds the device below: only lower states are reachable.
  if (status_.error && al_state_rank(*requested) > al_state_rank(status_.state)) return status_;
  const AlTransition* transition = find_al_transition(status_.state, *requested);
  if (transition == nullptr) {
    status_.error = true;
    status_.code = AlStatusCode::invalid_requested_state_change;
    return status_;
  }
  if (transition->requirement == AlRequirement::bootstrap && !config_.bootstrap) {
    status_.error = true;
    status_.code = AlStatusCode::bootstrap_not_supported;
    return status_;
  }
  if (config_.check) {
    const AlStatusCode refusal = config_.check(*transition);
    if (refusal != AlStatusCode::no_error) {
      status_.error = true;
      status_.code = refusal;
      return status_;
    }
  }
  enter(*requested);
  return status_;
}

const AlStatus& AlStateMachine::local_error(AlState to, AlStatusCode code) {
  status_.error = true;
  status_.code = code;
  if (al_state_rank(to) < al_state_rank(status_.state)) enter(to);
  return status_;
}

const AlStatus& AlStateMachine::sm_watchdog_expired() {
  if (status_.state != AlState::op) return status_;
  return local_error(AlState::safeop, AlStatusCode::sync_manager_watchdog);
}

}  // namespace drivecheck::ethercat
