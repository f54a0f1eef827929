#include "protocol/cia301/time.hpp"

#include <fmt/format.h>

#include <cassert>

namespace drivecheck::cia301 {

std::chrono::sys_time<std::chrono::milliseconds> TimeOfDay::to_sys_time() const {
  return std::chrono::sys_time<std::chrono::milliseconds>{kTimeOfDayEpoch} +
         std::chrono::days{days} + std::chrono::milliseconds{ms};
}

TimeOfDay TimeOfDay::from_sys_time(std::chrono::sys_time<std::chrono::milliseconds> time) {
  const auto day = std::chrono::floor<std::chrono::days>(time);
  const auto since_epoch = (day - kTimeOfDayEpoch).count();
  assert(since_epoch >= 0 && since_epoch <= 0xFFFF);
  return TimeOfDay{static_cast<std::uint32_t>((time - day).count()),
                   static_cast<std::uint16_t>(since_epoch)};
}

can::Frame encode(const TimeOfDay& time, std::uint32_t cob_id) {
  assert(time.ms < kMsPerDay);
  const std::uint8_t bytes[6] = {
      static_cast<std::uint8_t>(time.ms),       static_cast<std::uint8_t>(time.ms >> 8),
      static_cast<std::uint8_t>(time.ms >> 16), static_cast<std::uint8_t>(time.ms >> 24),
      static_cast<std::uint8_t>(time.days),     static_cast<std::uint8_t>(time.days >> 8)};
  return cob_id > can::kMaxStandardId ? can::Frame::extended(cob_id, bytes)
                                      : can::Frame::standard(cob_id, bytes);
}

Expected<TimeOfDay, DecodeError> decode_time(const can::Frame& frame, std::uint32_t cob_id) {
  if (frame.is_error()) return Unexpected(DecodeError{"TIME: an error frame is not a TIME"});
  if (frame.is_extended() != (cob_id > can::kMaxStandardId) || frame.id != cob_id) {
    return Unexpected(DecodeError{
        fmt::format("TIME: {} is not on the TIME CAN-ID {:03X}h", can::to_candump(frame), cob_id)});
  }
  if (frame.is_remote()) {
    return Unexpected(DecodeError{"TIME as a remote request: invalid (TIME is a data frame)"});
  }
  if (frame.dlc != 6) {
    return Unexpected(DecodeError{
        fmt::format("TIME with DLC {}: invalid (TIME_OF_DAY carries 6 bytes)", frame.dlc)});
  }
  const std::uint32_t raw = static_cast<std::uint32_t>(frame.data[0]) |
                            (static_cast<std::uint32_t>(frame.data[1]) << 8) |
                            (static_cast<std::uint32_t>(frame.data[2]) << 16) |
                            (static_cast<std::uint32_t>(frame.data[3]) << 24);
  if ((raw & 0xF0000000u) != 0) {
    return Unexpected(DecodeError{
        fmt::format("TIME ms field {:08X}h: invalid (bits 28..31 are reserved and 0)", raw)});
  }
  if (raw >= kMsPerDay) {
    return Unexpected(DecodeError{
        fmt::format("TIME ms after midnight {}: invalid (a day has 86400000 ms)", raw)});
  }
  const auto days = static_cast<std::uint16_t>(frame.data[4] | (frame.data[5] << 8));
  return TimeOfDay{raw, days};
}

}  // namespace drivecheck::cia301
