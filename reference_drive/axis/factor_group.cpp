#include "reference_drive/axis/factor_group.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>

namespace drivecheck::reference_drive {
namespace {

double ratio(const Fraction& f) {
  return static_cast<double>(f.numerator) / static_cast<double>(f.divisor);
}

}  // namespace

bool reduce_fraction(std::uint64_t numerator, std::uint64_t divisor, Fraction& out) {
  if (numerator == 0 || divisor == 0) return false;
  const std::uint64_t g = std::gcd(numerator, divisor);
  numerator /= g;
  divisor /= g;
  constexpr std::uint64_t kMax = std::numeric_limits<std::uint32_t>::max();
  if (numerator > kMax || divisor > kMax) return false;
  out = Fraction{static_cast<std::uint32_t>(numerator), static_cast<std::uint32_t>(divisor)};
  return true;
}

double FactorGroup::position_to_internal(double user) const {
  const double sign = (polarity & kPositionPolarity) != 0 ? -1.0 : 1.0;
  return sign * user * ratio(position);
}

double FactorGroup::position_to_user(double internal) const {
  const double sign =
      (polarity & kPositionPolarity) != 0 && position_polarity_when_read ? -1.0 : 1.0;
  return sign * internal / ratio(position);
}

double FactorGroup::distance_to_internal(double user) const {
  return user * ratio(position);
}

double FactorGroup::distance_to_user(double internal) const {
  return internal / ratio(position);
}

double FactorGroup::velocity_to_internal(double user) const {
  const double sign = (polarity & kVelocityPolarity) != 0 ? -1.0 : 1.0;
  return sign * user * ratio(velocity);
}

double FactorGroup::velocity_to_user(double internal) const {
  const double sign = (polarity & kVelocityPolarity) != 0 ? -1.0 : 1.0;
  return sign * internal / ratio(velocity);
}

double FactorGroup::speed_to_internal(double user) const {
  return user * ratio(velocity);
}

double FactorGroup::speed_to_user(double internal) const {
  return internal / ratio(velocity);
}

double FactorGroup::acceleration_to_internal(double user) const {
  return user * ratio(acceleration);
}

double FactorGroup::acceleration_to_user(double internal) const {
  return internal / ratio(acceleration);
}

std::int32_t FactorGroup::to_i32(double value) {
  if (std::isnan(value)) return 0;
  const double r = std::round(value);
  if (r >= static_cast<double>(std::numeric_limits<std::int32_t>::max())) {
    return std::numeric_limits<std::int32_t>::max();
  }
  if (r <= static_cast<double>(std::numeric_limits<std::int32_t>::min())) {
    return std::numeric_limits<std::int32_t>::min();
  }
  return static_cast<std::int32_t>(r);
}

std::uint32_t FactorGroup::to_u32(double value) {
  if (std::isnan(value) || value <= 0.0) return 0;
  const double r = std::round(value);
  if (r >= static_cast<double>(std::numeric_limits<std::uint32_t>::max())) {
    return std::numeric_limits<std::uint32_t>::max();
  }
  return static_cast<std::uint32_t>(r);
}

}  // namespace drivecheck::reference_drive
