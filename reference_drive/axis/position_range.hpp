// The position range limit of a rotary (modulo) axis: 607Bh (CiA 402-2, ARRAY, sub 01h min and
// sub 02h max position range limit, INTEGER32, position units) and the rotary axis direction
// option of 60F2h bits 7..6 for profile position.
//
// CiA 402-2 607Bh (the standard's text is not in the repository; wording as public reprints give
// it: Novanta EMCL 0x607B, TR-Electronic 0x607B, KEB ps18/ps19): the two limits bound the
// numerical range of the position values; on reaching or exceeding a limit the value wraps to
// the other end of the range. The two limits are the same physical position (Festo 000 §5.7
// L3821-3826 "0° and 360°"), so a wrapped value lies in [min, max) and the period is max − min.
// IRTSA 003 §5 L732-734: defaults 80000000h / 7FFFFFFFh; Novanta and Nanotec default to 0 / 0 and
// switch the wrap off with both at 0. The reference drive wraps only while min < max and the
// range is narrower than INTEGER32's: its defaults (the full INTEGER32 range) and 0 / 0 leave a
// linear axis, so no existing behaviour changes until a master sets a range.
//
// 60F2h bits 7..6, rotary axis direction option (ETG.6010 Table 78 and Novanta EMCL 0x60F2 reprint
// CiA 402-2's table):
//   00 normal positioning, as on a linear axis: an absolute target is reached without passing
//      the range limits; a relative move may pass them (the value wraps)
//   01 positioning only in negative direction
//   10 positioning only in positive direction
//   11 positioning the shortest way; a target half a period away either way: positive direction
// travel() is the signed distance an ABSOLUTE positioning covers for each option; a relative
// positioning travels its 607Ah whatever the option (the reference drive's reading: the option
// names a direction for an absolute target only).
//
// Positions here are user units (as 607Ah, 6062h and 6064h); the caller converts to and from the
// axis's internal units. Pure functions, no state.
#pragma once

#include <cstdint>

namespace drivecheck::reference_drive {

// 60F2h bits 7..6.
enum class RotaryDirection : std::uint8_t { linear = 0, negative = 1, positive = 2, shortest = 3 };

// The option in a 60F2h value.
constexpr RotaryDirection rotary_direction_of(std::uint64_t positioning_option_code) {
  return static_cast<RotaryDirection>((positioning_option_code >> 6) & 0x3);
}

struct PositionRange {
  double min = 0.0;
  double max = 0.0;

  // 607Bh sub 01h, 02h as the dictionary holds them.
  static PositionRange from_limits(std::int64_t min_limit, std::int64_t max_limit);
  // Whether values wrap: min < max and narrower than the whole INTEGER32 range.
  bool active() const;
  double period() const { return max - min; }
  // `position` in [min, max) (unchanged while not active).
  double wrap(double position) const;
  // The signed distance an absolute positioning from `from` to `target` travels (both wrapped
  // first; less than half a position unit apart: already there, no turn); not active:
  // target − from, as on a linear axis.
  double travel(double from, double target, RotaryDirection direction) const;
};

}  // namespace drivecheck::reference_drive
