// TIME (CiA 301 §7.2.6): the time stamp object, data type TIME_OF_DAY.
//
// TIME frame, CAN-ID 100h (configurable in 1012h), DLC 6:
//
//   bytes 0..3  UNSIGNED28 ms: milliseconds after midnight, little-endian, bits 0..27;
//               bits 28..31 of byte 3 are reserved (0)
//   bytes 4..5  UNSIGNED16 days: days since 1 January 1984, little-endian
//
// None of the four drive manuals supports TIME (Kollmorgen: "TIME is not supported",
// 002_953174ea6ca45cdb.txt L717-719; Dunker: "The CANopen time stamp is not supported",
// 004_956552dcd17e975a.txt L679): the layout is CiA 301's.
#pragma once

#include <chrono>
#include <cstdint>

#include "protocol/can/frame.hpp"
#include "protocol/cia301/decode_error.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::cia301 {

inline constexpr std::uint16_t kTimeCobId = 0x100;
inline constexpr std::uint32_t kMsPerDay = 86'400'000;

// The CANopen epoch: 1984-01-01 00:00:00 (UTC when the producer uses UTC).
inline constexpr std::chrono::sys_days kTimeOfDayEpoch =
    std::chrono::sys_days{std::chrono::year{1984} / std::chrono::January / 1};

struct TimeOfDay {
  std::uint32_t ms = 0;    // 0..86'399'999
  std::uint16_t days = 0;  // since 1984-01-01

  // The instant, on the system clock's calendar (no leap seconds, as CiA 301).
  std::chrono::sys_time<std::chrono::milliseconds> to_sys_time() const;
  // Precondition: `time` is within 1984-01-01 .. 1984-01-01 + 65535 days (year 2163).
  static TimeOfDay from_sys_time(std::chrono::sys_time<std::chrono::milliseconds> time);

  friend bool operator==(const TimeOfDay&, const TimeOfDay&) = default;
};

// Precondition: ms < 86'400'000.
can::Frame encode(const TimeOfDay& time, std::uint32_t cob_id = kTimeCobId);

// Invalid: another identifier, remote or error frame, DLC other than 6, reserved bits 28..31
// set, ms at or past the end of the day.
Expected<TimeOfDay, DecodeError> decode_time(const can::Frame& frame,
                                             std::uint32_t cob_id = kTimeCobId);

}  // namespace drivecheck::cia301
