// The factor group of the reference drive: user units (what the master reads and writes in
// 607Ah, 6064h, 60FFh, 606Ch, 6083h, ...) ↔ internal units of the axis (increments,
// increments/s, increments/s²; axis_model.hpp). As the Festo and Kollmorgen manuals describe
// it (CiA DSP 402 v2 factor group):
//
//   internal position      = user position     × 6093h sub 1 / 6093h sub 2   (position factor)
//   internal velocity      = user velocity     × 6094h sub 1 / 6094h sub 2   (velocity encoder
//                                                                            factor)
//   internal acceleration  = user acceleration × 6097h sub 1 / 6097h sub 2   (acceleration
//                                                                            factor)
//   (000_33c1d912b8b6010a.txt §5.3 L2585-2855; 002_953174ea6ca45cdb.txt §5.5 L3632-3891)
//
// Writing 6091h (gear ratio) or 6092h (feed constant) recomputes the position factor from them
// and the encoder resolution 608Fh: 6093h = 608Fh × gear ratio / feed constant, reduced
// (Kollmorgen L3632-3674: "position factor = position encoder resolution × gear ratio / feed
// constant"; Festo L2656). All factors default to 1/1, so user units = internal units until the
// master configures them. A divisor of 0 is refused (06090030h invalid value; also a factor
// whose reduced numerator or divisor does not fit 32 bits).
//
// Polarity 607Eh (UNSIGNED8; 00h, 40h, 80h, C0h, else 06090030h; Festo L2857-2880): bit 7
// multiplies positions (607Ah, 6062h, 6064h, 607Ch not) by −1, bit 6 velocities (60FFh, 606Bh,
// 606Ch). Torques are not affected here.
#pragma once

#include <cstdint>

namespace drivecheck::reference_drive {

struct Fraction {
  std::uint32_t numerator = 1;
  std::uint32_t divisor = 1;
  friend bool operator==(const Fraction&, const Fraction&) = default;
};

// Reduces a / b and checks it fits: false when b == 0, a == 0 or it does not fit 32 bits.
bool reduce_fraction(std::uint64_t numerator, std::uint64_t divisor, Fraction& out);

class FactorGroup {
 public:
  static constexpr std::uint8_t kPositionPolarity = 0x80;
  static constexpr std::uint8_t kVelocityPolarity = 0x40;

  Fraction position{};      // 6093h
  Fraction velocity{};      // 6094h
  Fraction acceleration{};  // 6097h
  std::uint8_t polarity = 0;
  // Deviation factor-position-polarity-set-points-only clears it: position_to_user leaves the
  // position polarity out (the values read back keep the internal sign).
  bool position_polarity_when_read = true;

  // Position (607Ah, 6064h, ...): user ↔ internal, polarity applied.
  double position_to_internal(double user) const;
  double position_to_user(double internal) const;
  // Position quantities without sign (windows, 6065h, 6067h): factor only.
  double distance_to_internal(double user) const;
  double distance_to_user(double internal) const;
  double velocity_to_internal(double user) const;  // polarity applied
  double velocity_to_user(double internal) const;
  double speed_to_internal(double user) const;  // no polarity (6081h, 607Fh, windows)
  double speed_to_user(double internal) const;
  double acceleration_to_internal(double user) const;
  double acceleration_to_user(double internal) const;

  // Values that round-trip to the integer objects: round half away from zero, saturated to
  // INTEGER32.
  static std::int32_t to_i32(double value);
  static std::uint32_t to_u32(double value);
};

}  // namespace drivecheck::reference_drive
