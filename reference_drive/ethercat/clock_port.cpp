#include "reference_drive/ethercat/clock_port.hpp"

#include "protocol/cia301/object_dictionary.hpp"

namespace drivecheck::reference_drive::ethercat {

namespace {
constexpr std::uint16_t kEmcyCobIdIndex = 0x1014;
constexpr std::uint32_t kEmcyBase = 0x80;
}  // namespace

std::uint32_t LinkClockPort::emcy_cob_id() const {
  if (od_ == nullptr) return kEmcyBase + 1;
  if (const cia301::Entry* entry = od_->find(kEmcyCobIdIndex, 0)) {
    auto decoded =
        cia301::decode_emcy_cob_id_entry(static_cast<std::uint32_t>(entry->as_unsigned()));
    if (decoded && decoded->valid && !decoded->extended) return decoded->can_id;
    return 0xFFFFFFFFu;  // not valid: the drive sends no EMCY
  }
  return kEmcyBase + od_->node_id();
}

std::error_code LinkClockPort::send(const can::Frame& frame) {
  if (emcy_ && frame.kind == can::FrameKind::data && !frame.is_extended() &&
      frame.id == emcy_cob_id()) {
    if (auto emcy = cia301::decode_emcy(frame)) {
      emcy_(*emcy);
      return {};
    }
  }
  ++dropped_;
  return {};
}

std::optional<can::TimedFrame> LinkClockPort::receive(can::TimePoint deadline) {
  (void)deadline;
  return std::nullopt;
}

}  // namespace drivecheck::reference_drive::ethercat
