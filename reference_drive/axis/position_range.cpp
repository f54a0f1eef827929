#include "reference_drive/axis/position_range.hpp"

#include <cmath>
#include <limits>

namespace drivecheck::reference_drive {

PositionRange PositionRange::from_limits(std::int64_t min_limit, std::int64_t max_limit) {
  return PositionRange{static_cast<double>(min_limit), static_cast<double>(max_limit)};
}

bool PositionRange::active() const {
  constexpr double whole = static_cast<double>(std::numeric_limits<std::int32_t>::max()) -
                           static_cast<double>(std::numeric_limits<std::int32_t>::min());
  return min < max && period() < whole;
}

double PositionRange::wrap(double position) const {
  if (!active()) return position;
  double offset = std::fmod(position - min, period());
  if (offset < 0.0) offset += period();
  if (offset >= period()) offset = 0.0;  // fmod's rounding at the top end
  return min + offset;
}

double PositionRange::travel(double from, double target, RotaryDirection direction) const {
  if (!active()) return target - from;
  const double p = period();
  double d = wrap(target) - wrap(from);  // in (-p, p)
  // Already there (within half a position unit: the demand may stand a fraction off the integer
  // target): no turn in either direction.
  if (std::abs(d) < 0.5) return d;
  switch (direction) {
    case RotaryDirection::linear:
      break;
    case RotaryDirection::negative:
      if (d > 0.0) d -= p;
      break;
    case RotaryDirection::positive:
      if (d < 0.0) d += p;
      break;
    case RotaryDirection::shortest:
      if (d > p / 2.0) d -= p;
      if (d <= -p / 2.0) d += p;  // half a period either way: the positive direction
      break;
  }
  return d;
}

}  // namespace drivecheck::reference_drive
