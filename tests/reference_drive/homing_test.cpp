// Homing mode of the reference drive (reference_drive/modes/homing.hpp): every method of
// homing_methods.inc against a written-down switch layout, cycle by cycle (1 ms) with a
// simple ramp axis. The expected home positions and first directions below are worked out by
// hand from CiA 402-2 §"Homing mode" (method figures) and the manuals (Festo Tab. 7.1
// 000_33c1d912b8b6010a.txt L6185-6242, Kollmorgen 002_953174ea6ca45cdb.txt L4521-4564, IRTSA
// 003_111f14ab1c37c28a.txt L416-479), not computed by the engine's own rules.
//
// The layouts (physical positions, units; index pulse every 1000 at 250 + k·1000):
//
//   limits:        LS- active x <= -10000                 LS+ active x >= 10000
//   positive home: limits + home switch active x >= 2100
//   negative home: limits + home switch active x <= 2100
//   window:        limits + home switch active over [2100, 3400]
//   stops:         limits + mechanical stops at -11000 and +11000
//
//        -11000 -10000        250  1250 2100 2250  3250 3400 4250       10000 11000
//   stop |  LS- ]   ...   |    |    [====home====]    |          ...   [ LS+  | stop
//
// Index pulses near the edges: ... -10750 -9750 ... 1250 | 2100 | 2250 ... 3250 | 3400 | 4250
//
// The test axis stops dead at a mechanical stop; the mode finds the stop only through the
// following error of the velocity profile it commands (window 500, HomingConfig::stop_window).
#include "reference_drive/modes/homing.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <optional>
#include <tuple>
#include <vector>

#include "protocol/cia402/controlword.hpp"
#include "protocol/cia402/statusword.hpp"
#include "reference_drive/cia402_application.hpp"
#include "tests/reference_drive/drive_rig.hpp"

namespace drivecheck::reference_drive {
namespace {

using namespace std::chrono_literals;

constexpr std::uint16_t kInProgress = 0x0000;      // 13/12/10 = 0/0/0
constexpr std::uint16_t kNotStarted = 0x0400;      // 0/0/1 interrupted or not started
constexpr std::uint16_t kAttainedMoving = 0x1000;  // 0/1/0 attained, target not reached
constexpr std::uint16_t kCompleted = 0x1400;       // 0/1/1
constexpr std::uint16_t kErrorMoving = 0x2000;     // 1/0/0
constexpr std::uint16_t kErrorStopped = 0x2400;    // 1/0/1
constexpr std::uint16_t kEnable = 0x000F;          // enable operation
constexpr std::uint16_t kStart = 0x001F;           // enable operation + bit 4
constexpr std::uint16_t kStartHalt = 0x011F;       // + bit 8 halt

struct Layout {
  std::optional<double> limit_negative = -10000;
  std::optional<double> limit_positive = 10000;
  std::optional<double> home_from;  // home switch active over [home_from, home_to]
  std::optional<double> home_to;
  std::optional<double> stop_negative;
  std::optional<double> stop_positive;
  double index_period = 1000;
  double index_offset = 250;
};

Layout limits() {
  return {};
}
Layout positive_home() {
  Layout l;
  l.home_from = 2100;
  return l;
}
Layout negative_home() {
  Layout l;
  l.home_to = 2100;
  return l;
}
Layout window() {
  Layout l;
  l.home_from = 2100;
  l.home_to = 3400;
  return l;
}
Layout stops() {
  Layout l;
  l.stop_negative = -11000;
  l.stop_positive = 11000;
  return l;
}

// A velocity-ramped axis with the layout's switches, index pulses and stops (physical frame;
// actual = physical + offset).
class TestAxis final : public HomingAxis {
 public:
  TestAxis(Layout layout, double start) : layout_(layout), x_(start) {}

  double position() const override { return x_ + offset_; }
  double velocity() const override { return v_; }
  void command_velocity(double velocity, double acceleration) override {
    target_ = velocity;
    acceleration_ = acceleration;
    ++commands_;
  }
  bool limit_negative() const override {
    return layout_.limit_negative && x_ <= *layout_.limit_negative;
  }
  bool limit_positive() const override {
    return layout_.limit_positive && x_ >= *layout_.limit_positive;
  }
  bool home_switch() const override {
    if (!layout_.home_from && !layout_.home_to) return false;
    return (!layout_.home_from || x_ >= *layout_.home_from) &&
           (!layout_.home_to || x_ <= *layout_.home_to);
  }
  std::optional<double> index_pulse_between(double from, double to) const override {
    const double p = layout_.index_period;
    if (p <= 0 || from == to) return std::nullopt;
    const double a = from - offset_;
    const double b = to - offset_;
    const double base = layout_.index_offset;
    double pulse = 0;
    if (b > a) {
      pulse = base + (std::floor((a - base) / p) + 1) * p;
      if (pulse > b) return std::nullopt;
    } else {
      pulse = base + (std::ceil((a - base) / p) - 1) * p;
      if (pulse < b) return std::nullopt;
    }
    return pulse + offset_;
  }
  double index_period() const override { return layout_.index_period; }
  void shift_position(double delta) override { offset_ += delta; }

  void advance(double dt) {
    const double v0 = v_;
    if (acceleration_ <= 0) {
      v_ = target_;
    } else if (v_ < target_) {
      v_ = std::min(target_, v_ + acceleration_ * dt);
    } else if (v_ > target_) {
      v_ = std::max(target_, v_ - acceleration_ * dt);
    }
    x_ += (v0 + v_) / 2 * dt;
    if (layout_.stop_negative && x_ <= *layout_.stop_negative) {
      x_ = *layout_.stop_negative;
      if (v_ < 0) v_ = 0;
    }
    if (layout_.stop_positive && x_ >= *layout_.stop_positive) {
      x_ = *layout_.stop_positive;
      if (v_ > 0) v_ = 0;
    }
  }
  double physical() const { return x_; }
  double offset() const { return offset_; }
  int commands() const { return commands_; }

 private:
  Layout layout_;
  double x_;
  double offset_ = 0;
  double v_ = 0;
  double target_ = 0;
  double acceleration_ = 0;
  int commands_ = 0;
};

// One homing run, 1 ms per cycle: 10 cycles enabled with bit 4 = 0, then bit 4 = 1 until the
// run ends and the axis stands still (or `limit` passes).
struct HomingRun {
  std::vector<std::uint16_t> bits;  // each distinct consecutive pattern of bits 13/12/10
  int first_direction = 0;          // sign of the first velocity that is not 0
  double home_physical = 0;         // where 6064h = 607Ch (physical frame)
  double position_actual = 0;       // 6064h at the end
  double duration_s = 0;            // start edge to standstill after the end
  HomingStatus status = HomingStatus::not_started;
};

struct Rig {
  HomingMode mode;
  TestAxis axis;
  can::TimePoint now{};
  std::vector<std::uint16_t> bits;

  Rig(HomingConfig config, Layout layout, double start)
      : mode(std::move(config)), axis(layout, start) {}

  void cycle(std::uint16_t controlword, bool enabled = true) {
    now += 1ms;
    axis.advance(0.001);
    HomingInputs in;
    in.controlword = controlword;
    in.operation_enabled = enabled;
    in.mode_active = true;
    mode.step(now, in, axis);
    const std::uint16_t b = mode.statusword_bits();
    if (bits.empty() || bits.back() != b) bits.push_back(b);
  }
};

HomingRun run_method(std::int8_t method, Layout layout, double start,
                     HomingVendor vendor = HomingVendor::cia402, std::int32_t offset = 0) {
  HomingConfig config;
  config.vendor = vendor;
  Rig rig(config, layout, start);
  EXPECT_TRUE(rig.mode.set_method(method)) << "method " << int{method};
  rig.mode.set_home_offset(offset);
  for (int i = 0; i < 10; ++i)
    rig.cycle(kEnable);
  const can::TimePoint started = rig.now;
  HomingRun run;
  for (int i = 0; i < 70000; ++i) {
    rig.cycle(kStart);
    if (run.first_direction == 0 && rig.axis.velocity() != 0) {
      run.first_direction = rig.axis.velocity() > 0 ? 1 : -1;
    }
    if (!rig.mode.running() && rig.axis.velocity() == 0) break;
  }
  run.bits = rig.bits;
  run.status = rig.mode.status();
  run.position_actual = rig.axis.position();
  run.home_physical = rig.axis.physical() - (rig.axis.position() - offset);
  run.duration_s = std::chrono::duration<double>(rig.now - started).count();
  return run;
}

struct Case {
  std::int8_t method;
  Layout layout;
  double start;
  int first;    // expected direction of first travel (0: no motion)
  double home;  // expected home, physical
};

// A switch edge is seen at the first 1 ms cycle past it: crawl speed (200/s) × 1 ms.
constexpr double kEdgeTolerance = 0.5;

// `at_stop`: home is a mechanical stop, where the axis already stands: no 0/1/0 phase.
void check(const Case& c, HomingVendor vendor = HomingVendor::cia402, bool at_stop = false) {
  SCOPED_TRACE(::testing::Message() << "method " << int{c.method} << " from " << c.start);
  const HomingRun run = run_method(c.method, c.layout, c.start, vendor);
  EXPECT_EQ(run.status, HomingStatus::attained);
  EXPECT_EQ(run.first_direction, c.first);
  EXPECT_NEAR(run.home_physical, c.home, kEdgeTolerance);
  // 6064h = 607Ch (0) at home, plus the braking distance from crawl speed: 200²/(2·20000) = 1.
  EXPECT_NEAR(run.position_actual, 0.0, 1.0 + kEdgeTolerance);
  const std::vector<std::uint16_t> moving{kNotStarted, kInProgress, kAttainedMoving, kCompleted};
  const std::vector<std::uint16_t> still{kNotStarted, kCompleted};
  const std::vector<std::uint16_t> stopped{kNotStarted, kInProgress, kCompleted};
  EXPECT_EQ(run.bits, c.first == 0 ? still : (at_stop ? stopped : moving));
  EXPECT_LT(run.duration_s, 30.0);  // $timing.homing
}

// The cases, by layout (also run through the whole drive below).
std::vector<Case> limit_index_cases() {
  return {Case{1, limits(), 0, -1, -9750},     Case{1, limits(), -10500, +1, -9750},
          Case{1, limits(), 10500, -1, -9750}, Case{2, limits(), 0, +1, 9250},
          Case{2, limits(), 10500, -1, 9250},  Case{2, limits(), -10500, +1, 9250}};
}

std::vector<Case> limit_cases() {
  return {Case{17, limits(), 0, -1, -10000}, Case{17, limits(), -10500, +1, -10000},
          Case{18, limits(), 0, +1, 10000}, Case{18, limits(), 10500, -1, 10000}};
}

std::vector<Case> positive_home_cases() {
  return {Case{3, positive_home(), 0, +1, 1250},  Case{3, positive_home(), 5000, -1, 1250},
          Case{4, positive_home(), 0, +1, 2250},  Case{4, positive_home(), 5000, -1, 2250},
          Case{19, positive_home(), 0, +1, 2100}, Case{19, positive_home(), 5000, -1, 2100},
          Case{20, positive_home(), 0, +1, 2100}, Case{20, positive_home(), 5000, -1, 2100}};
}

std::vector<Case> negative_home_cases() {
  return {Case{5, negative_home(), 5000, -1, 2250},  Case{5, negative_home(), 0, +1, 2250},
          Case{6, negative_home(), 5000, -1, 1250},  Case{6, negative_home(), 0, +1, 1250},
          Case{21, negative_home(), 5000, -1, 2100}, Case{21, negative_home(), 0, +1, 2100},
          Case{22, negative_home(), 5000, -1, 2100}, Case{22, negative_home(), 0, +1, 2100}};
}

std::vector<Case> window_index_cases() {
  return {
      Case{7, window(), 0, +1, 1250},     Case{7, window(), 2800, -1, 1250},
      Case{7, window(), 6000, +1, 1250},  Case{8, window(), 0, +1, 2250},
      Case{8, window(), 2800, -1, 2250},  Case{8, window(), 6000, +1, 2250},
      Case{9, window(), 0, +1, 3250},     Case{9, window(), 2800, +1, 3250},
      Case{9, window(), 6000, +1, 3250},  Case{10, window(), 0, +1, 4250},
      Case{10, window(), 2800, +1, 4250}, Case{10, window(), 6000, +1, 4250},
      Case{11, window(), 0, -1, 4250},    Case{11, window(), 2800, +1, 4250},
      Case{11, window(), 6000, -1, 4250}, Case{12, window(), 0, -1, 3250},
      Case{12, window(), 2800, +1, 3250}, Case{12, window(), 6000, -1, 3250},
      Case{13, window(), 0, -1, 2250},    Case{13, window(), 2800, -1, 2250},
      Case{13, window(), 6000, -1, 2250}, Case{14, window(), 0, -1, 1250},
      Case{14, window(), 2800, -1, 1250}, Case{14, window(), 6000, -1, 1250},
  };
}

std::vector<Case> window_cases() {
  return {
      Case{23, window(), 0, +1, 2100},    Case{23, window(), 2800, -1, 2100},
      Case{23, window(), 6000, +1, 2100}, Case{24, window(), 0, +1, 2100},
      Case{24, window(), 2800, -1, 2100}, Case{24, window(), 6000, +1, 2100},
      Case{25, window(), 0, +1, 3400},    Case{25, window(), 2800, +1, 3400},
      Case{25, window(), 6000, +1, 3400}, Case{26, window(), 0, +1, 3400},
      Case{26, window(), 2800, +1, 3400}, Case{26, window(), 6000, +1, 3400},
      Case{27, window(), 0, -1, 3400},    Case{27, window(), 2800, +1, 3400},
      Case{27, window(), 6000, -1, 3400}, Case{28, window(), 0, -1, 3400},
      Case{28, window(), 2800, +1, 3400}, Case{28, window(), 6000, -1, 3400},
      Case{29, window(), 0, -1, 2100},    Case{29, window(), 2800, -1, 2100},
      Case{29, window(), 6000, -1, 2100}, Case{30, window(), 0, -1, 2100},
      Case{30, window(), 2800, -1, 2100}, Case{30, window(), 6000, -1, 2100},
  };
}

std::vector<Case> index_cases() {
  return {Case{33, limits(), 0, -1, -750}, Case{33, limits(), 500, -1, 250},
          Case{34, limits(), 0, +1, 250}, Case{34, limits(), 500, +1, 1250}};
}

TEST(HomingMethods, LimitSwitchWithIndexOneAndTwo) {
  // Given the limit layout, When methods 1/2 run from between, on LS- and on LS+, Then home is
  // the first index pulse inside the switch edge (-9750 / 9250), bits 0/0/0 → 0/1/0 → 0/1/1.
  for (const Case& c : limit_index_cases())
    check(c);
}

TEST(HomingMethods, LimitSwitchSeventeenAndEighteen) {
  // Given the limit layout, When 17/18 run, Then home is the switch edge itself (±10000).
  for (const Case& c : limit_cases())
    check(c);
}

TEST(HomingMethods, PositiveHomeSwitchThreeFourNineteenTwenty) {
  // Given a home switch active x >= 2100, When 3/4/19/20 run from its inactive (0) and active
  // (5000) side, Then the first travel is toward the edge and home is 1250 / 2250 / 2100.
  for (const Case& c : positive_home_cases())
    check(c);
}

TEST(HomingMethods, NegativeHomeSwitchFiveSixTwentyOneTwentyTwo) {
  // Given a home switch active x <= 2100, When 5/6/21/22 run from its inactive (5000) and
  // active (0) side, Then home is 2250 (5) / 1250 (6) / 2100 (21, 22).
  for (const Case& c : negative_home_cases())
    check(c);
}

TEST(HomingMethods, HomeSwitchSevenToFourteen) {
  // Given the window [2100, 3400], When 7..14 run from left (0), on it (2800) and right (6000;
  // reversal at a limit switch), Then home is the index pulse on the method's side of the edge.
  for (const Case& c : window_index_cases())
    check(c);
}

TEST(HomingMethods, HomeSwitchTwentyThreeToThirty) {
  // Given the window, When 23..30 run from the three sides, Then home is the edge itself:
  // 2100 (23, 24, 29, 30), 3400 (25..28).
  for (const Case& c : window_cases())
    check(c);
}

TEST(HomingMethods, IndexPulseThirtyThreeThirtyFour) {
  // Given index pulses at 250 + k·1000, When 33/34 run, Then home is the next pulse below /
  // above the start, reached at crawl speed.
  for (const Case& c : index_cases())
    check(c);
}

TEST(HomingMethods, CurrentPositionThirtyFiveThirtySeven) {
  // Given the axis at 1234, When 35/37 start, Then no motion, completed at once (0/1/1).
  check({35, limits(), 1234, 0, 1234});
  check({37, limits(), 1234, 0, 1234});
}

TEST(HomingMethods, FestoStopAndViaLimitMethods) {
  // Given mechanical stops at ±11000 (Festo: limit switches ignored on the way, L6196), When
  // -1/-2/-17/-18 run, Then home is the stop or the next index pulse off it; -23/-27 go to the
  // limit switch first and end at the window's lower / upper edge.
  check({-1, stops(), 0, -1, -10750}, HomingVendor::festo);
  check({-2, stops(), 0, +1, 10250}, HomingVendor::festo);
  check({-17, stops(), 0, -1, -11000}, HomingVendor::festo, true);
  check({-18, stops(), 0, +1, 11000}, HomingVendor::festo, true);
  for (const Case& c : {Case{-23, window(), 0, +1, 2100}, Case{-23, window(), 2800, +1, 2100},
                        Case{-23, window(), 6000, +1, 2100}, Case{-27, window(), 0, -1, 3400},
                        Case{-27, window(), 2800, -1, 3400}, Case{-27, window(), 6000, -1, 3400}}) {
    check(c, HomingVendor::festo);
  }
}

TEST(HomingMethods, KollmorgenMethods) {
  // Given Kollmorgen's table (L4521-4564), When -1 (nearest index), -2 (current position),
  // -6/-7 (stops) run, Then home is the nearer pulse / the start / the stop.
  for (const Case& c : {Case{-1, limits(), 600, -1, 250}, Case{-1, limits(), 1000, +1, 1250},
                        Case{-2, limits(), 1234, 0, 1234}}) {
    check(c, HomingVendor::kollmorgen);
  }
  check({-6, stops(), 0, +1, 11000}, HomingVendor::kollmorgen, true);
  check({-7, stops(), 0, -1, -11000}, HomingVendor::kollmorgen, true);
}

TEST(HomingMethods, KollmorgenStopWithZeroMarkTakesDrefFromThePreviousMethod) {
  // Given the stops layout and Kollmorgen's -3 (NREF=7, no DREF of its own, L4530), When -6
  // (DREF=1) was written before, Then -3 goes to the positive stop and home is the index pulse
  // crawling back off it (10250); after -7 (DREF=0) it is the negative one (-10750).
  for (const auto& [before, first, home] :
       {std::tuple{std::int8_t{-6}, +1, 10250.0}, std::tuple{std::int8_t{-7}, -1, -10750.0}}) {
    SCOPED_TRACE(::testing::Message() << "6098h = " << int{before} << " before -3");
    HomingConfig config;
    config.vendor = HomingVendor::kollmorgen;
    Rig rig(config, stops(), 0);
    ASSERT_TRUE(rig.mode.set_method(before));
    ASSERT_TRUE(rig.mode.set_method(-3));
    EXPECT_EQ(rig.mode.kollmorgen_dref(), first > 0 ? 1 : 0);
    for (int i = 0; i < 10; ++i)
      rig.cycle(kEnable);
    int direction = 0;
    for (int i = 0; i < 30000; ++i) {
      rig.cycle(kStart);
      if (direction == 0 && rig.axis.velocity() != 0) direction = rig.axis.velocity() > 0 ? 1 : -1;
      if (!rig.mode.running() && rig.axis.velocity() == 0) break;
    }
    EXPECT_EQ(rig.mode.status(), HomingStatus::attained);
    EXPECT_EQ(direction, first);
    EXPECT_NEAR(rig.axis.physical() - (rig.axis.position() - 0.0), home, kEdgeTolerance);
    EXPECT_EQ(rig.bits,
              (std::vector<std::uint16_t>{kNotStarted, kInProgress, kAttainedMoving, kCompleted}));
  }
  // Given power on (DREF 0) and only -3 written, Then the first travel is negative.
  HomingConfig config;
  config.vendor = HomingVendor::kollmorgen;
  EXPECT_EQ(HomingMode(config).kollmorgen_dref(), 0);
  EXPECT_EQ(run_method(-3, stops(), 0, HomingVendor::kollmorgen).first_direction, -1);
}

TEST(HomingStops, TheStopIsFoundByTheFollowingErrorAfterWindowOverSpeed) {
  // Given stops at ±11000, 6099h = 2000/200, 609Ah = 20000, the stop window 500 (6065h), When
  // Festo -17 runs from 0, Then the axis needs 0.1 s to reach 2000/s (100 units), 5.45 s more
  // to the stop, then 500 / 2000 = 0.25 s of growing following error: home after 5.8 s, at
  // the stop itself, and the mode's following error at the event is just over the window.
  HomingConfig config;
  config.vendor = HomingVendor::festo;
  Rig rig(config, stops(), 0);
  ASSERT_TRUE(rig.mode.set_method(-17));
  for (int i = 0; i < 10; ++i)
    rig.cycle(kEnable);
  const can::TimePoint started = rig.now;
  std::optional<double> touched;  // time the axis reached the stop
  double error_at_event = 0;
  do {
    rig.cycle(kStart);
    if (!touched && rig.axis.physical() <= -11000) {
      touched = std::chrono::duration<double>(rig.now - started).count();
    }
    if (!rig.mode.running()) error_at_event = rig.mode.following_error();
  } while (rig.mode.running() && rig.now - started < 20s);
  ASSERT_EQ(rig.mode.status(), HomingStatus::attained);
  ASSERT_TRUE(touched);
  EXPECT_NEAR(*touched, 5.55, 0.01);
  const double at = std::chrono::duration<double>(*rig.mode.finished_at() - started).count();
  EXPECT_NEAR(at - *touched, 0.25, 0.01);
  EXPECT_LT(error_at_event, -500.0);
  EXPECT_GT(error_at_event, -510.0);
  EXPECT_DOUBLE_EQ(rig.axis.physical(), -11000.0);
  EXPECT_DOUBLE_EQ(rig.axis.position(), 0.0);  // 607Ch = 0 there, no braking distance
  // And the axis is left at the stop, not driven into it (velocity command 0).
  for (int i = 0; i < 100; ++i)
    rig.cycle(kStart);
  EXPECT_DOUBLE_EQ(rig.axis.physical(), -11000.0);
  EXPECT_EQ(rig.mode.statusword_bits(), kCompleted);
}

TEST(HomingStops, StopInTheWayOfAnIndexMethodIsAnError) {
  // Given a negative stop at -500 between the start (0) and the next pulse below (-750), When
  // method 33 crawls negative, Then it is blocked (Festo 11-5: "zero pulse method: end stop
  // reached", L7845-7848) and ends in homing error 1/0/1 without a home.
  Layout l = limits();
  l.stop_negative = -500;
  const HomingRun run = run_method(33, l, 0);
  EXPECT_EQ(run.status, HomingStatus::error);
  EXPECT_EQ(run.bits.back(), kErrorStopped);
  EXPECT_LT(run.duration_s, 6.0);  // 2.5 s crawl + 2.5 s of following error at crawl speed
}

TEST(HomingStops, ViaLimitMethodsReverseAtAStopWithoutLimitSwitch) {
  // Given the window layout without LS+ but a positive stop at 11000, When Festo -23 runs from
  // 0 ("positive direction to stop or limit switch", L6235), Then it reverses at the stop and
  // ends at the lower edge 2100.
  Layout l = window();
  l.limit_positive.reset();
  l.stop_positive = 11000;
  check({-23, l, 0, +1, 2100}, HomingVendor::festo);
}

// Festo -17 from 0 against the stops at +-11000 with 607Ch = `offset` and the travel to zero
// (6510h:F0h bit 6, homing.hpp) on or off; runs until the axis stands after the run.
Rig run_to_zero(std::int32_t offset, bool travel_to_zero) {
  HomingConfig config;
  config.vendor = HomingVendor::festo;
  Rig rig(config, stops(), 0);
  EXPECT_TRUE(rig.mode.set_method(-17));
  rig.mode.set_home_offset(offset);
  rig.mode.set_travel_to_zero(travel_to_zero);
  for (int i = 0; i < 10; ++i)
    rig.cycle(kEnable);
  for (int i = 0; i < 30000; ++i) {
    rig.cycle(kStart);
    if (!rig.mode.running() && rig.axis.velocity() == 0) break;
  }
  return rig;
}

TEST(HomingTravelToZero, WithoutTheBitTheAxisStaysAtTheStop) {
  // Given Festo -17 with 607Ch = -1000 and 6510h:F0h bit 6 clear (the default: "the drive to
  // the zero position under CANopen is normally not a component of the reference travel",
  // L6040) / When homing ends / Then the axis stands on the stop, 6064h = 607Ch, 0/1/1
  Rig rig = run_to_zero(-1000, false);
  EXPECT_EQ(rig.mode.status(), HomingStatus::attained);
  EXPECT_DOUBLE_EQ(rig.axis.physical(), -11000.0);
  EXPECT_DOUBLE_EQ(rig.axis.position(), -1000.0);
  EXPECT_EQ(rig.bits, (std::vector<std::uint16_t>{kNotStarted, kInProgress, kCompleted}));
}

TEST(HomingTravelToZero, WithTheBitTheAxisLeavesTheStopForTheZeroPoint) {
  // Given Festo -17 with 607Ch = -1000 and bit 6 set ("the axis is not to remain at the stop,
  // the travel to the axis zero point must be parameterised and the axis zero point offset must
  // be not 0", Tab. 7.1 footnote 3 L6196-6197; bit 6 L2560-2566) / When homing runs / Then home
  // is the stop (6064h = -1000 there), the axis travels +1000 at search speed and brakes at the
  // zero point: 6064h = 0 +- one cycle (2000/s x 1 ms), in progress until it brakes
  Rig rig = run_to_zero(-1000, true);
  EXPECT_EQ(rig.mode.status(), HomingStatus::attained);
  ASSERT_TRUE(rig.mode.home_position());
  EXPECT_DOUBLE_EQ(*rig.mode.home_position(), -1000.0);
  EXPECT_NEAR(rig.axis.position(), 0.0, 2.5);
  EXPECT_NEAR(rig.axis.physical(), -10000.0, 2.5);
  EXPECT_NEAR(rig.axis.offset(), -1000.0 - (-11000.0), 1e-9);  // home (the stop) = -1000
  EXPECT_EQ(rig.bits,
            (std::vector<std::uint16_t>{kNotStarted, kInProgress, kAttainedMoving, kCompleted}));
}

TEST(HomingTravelToZero, OffsetZeroMovesNothingAndAZeroBeyondTheStopIsAnError) {
  // Given bit 6 set and 607Ch = 0 / When -17 homes / Then home is the zero point: the axis
  // stays at the stop, 0/1/1
  Rig at_home = run_to_zero(0, true);
  EXPECT_EQ(at_home.mode.status(), HomingStatus::attained);
  EXPECT_DOUBLE_EQ(at_home.axis.physical(), -11000.0);
  // Given 607Ch = +1000 (the zero point 1000 beyond the negative stop) / When the travel to
  // zero runs into the stop / Then it is blocked (following error): homing error 1/0/1, with
  // the home found kept
  Rig beyond = run_to_zero(1000, true);
  EXPECT_EQ(beyond.mode.status(), HomingStatus::error);
  EXPECT_EQ(beyond.mode.statusword_bits(), kErrorStopped);
  EXPECT_TRUE(beyond.mode.homed());
  EXPECT_DOUBLE_EQ(beyond.axis.physical(), -11000.0);
}

TEST(HomingMethods, IrtsaSettingAndTolerant) {
  // Given IRTSA's -127 with 607Ch = 500 at 1234, When started, Then 6064h = 500 at once.
  const HomingRun set = run_method(-127, limits(), 1234, HomingVendor::irtsa, 500);
  EXPECT_EQ(set.status, HomingStatus::attained);
  EXPECT_DOUBLE_EQ(set.position_actual, 500);
  EXPECT_EQ(set.bits, (std::vector<std::uint16_t>{kNotStarted, kCompleted}));
  // Given -126 with 607Ch = 5000 at 1234 (period 1000), When started, Then only whole periods
  // are taken: 6064h = 5234 (L421).
  const HomingRun tolerant = run_method(-126, limits(), 1234, HomingVendor::irtsa, 5000);
  EXPECT_DOUBLE_EQ(tolerant.position_actual, 5234);
}

TEST(HomingMethods, EveryTableRowHasACase) {
  // Given the table, When its rows are listed, Then each standard number appears once and the
  // set is CiA 402's 1..14, 17..30, 33..35, 37.
  std::vector<int> standard;
  for (const HomingMethod& row : kHomingMethods) {
    if (row.vendor == HomingVendor::cia402) standard.push_back(row.number);
  }
  std::vector<int> expected;
  for (int n = 1; n <= 37; ++n) {
    if (n == 15 || n == 16 || n == 31 || n == 32 || n == 36) continue;
    expected.push_back(n);
  }
  EXPECT_EQ(standard, expected);
  EXPECT_EQ(homing_methods_of(HomingVendor::festo).size(), expected.size() + 6);
  EXPECT_EQ(homing_methods_of(HomingVendor::irtsa).size(), expected.size() + 2);
  EXPECT_EQ(homing_methods_of(HomingVendor::kollmorgen).size(), expected.size() + 5);
}

TEST(HomingMethods, HomeOffsetIsPositionActualAtHome) {
  // Given 607Ch = 5000, When method 34 runs from 0, Then 6064h = 5000 at the pulse (250).
  const HomingRun run = run_method(34, limits(), 0, HomingVendor::cia402, 5000);
  EXPECT_NEAR(run.home_physical, 250, 1e-9);
  // + the braking distance 1 + up to one cycle past the pulse at crawl speed (0.2).
  EXPECT_NEAR(run.position_actual, 5001.1, 0.11);
}

// --- control and errors ---------------------------------------------------------------------

Rig started_rig(std::int8_t method, Layout layout, double start, HomingConfig config = {}) {
  Rig rig(config, layout, start);
  EXPECT_TRUE(rig.mode.set_method(method));
  for (int i = 0; i < 10; ++i)
    rig.cycle(kEnable);
  rig.cycle(kStart);
  return rig;
}

TEST(HomingControl, HaltInterruptsWithoutResume) {
  // Given method 17 running from 0, When halt (bit 8) is set after 500 ms, Then 0/0/0 while
  // braking, 0/0/1 at standstill, no error; clearing halt does not resume.
  Rig rig = started_rig(17, limits(), 0);
  for (int i = 0; i < 500; ++i)
    rig.cycle(kStart);
  ASSERT_TRUE(rig.mode.running());
  rig.bits.clear();
  for (int i = 0; i < 500; ++i)
    rig.cycle(kStartHalt);
  EXPECT_EQ(rig.mode.status(), HomingStatus::interrupted);
  EXPECT_EQ(rig.bits, (std::vector<std::uint16_t>{kInProgress, kNotStarted}));
  for (int i = 0; i < 500; ++i)
    rig.cycle(kStart);
  EXPECT_EQ(rig.axis.velocity(), 0);
  EXPECT_EQ(rig.mode.statusword_bits(), kNotStarted);
}

TEST(HomingControl, BitFourFallingEdgeInterrupts) {
  // Given method 18 running, When bit 4 falls, Then interrupted (0/0/1 at standstill).
  Rig rig = started_rig(18, limits(), 0);
  for (int i = 0; i < 200; ++i)
    rig.cycle(kStart);
  for (int i = 0; i < 500; ++i)
    rig.cycle(kEnable);
  EXPECT_EQ(rig.mode.status(), HomingStatus::interrupted);
  EXPECT_EQ(rig.mode.statusword_bits(), kNotStarted);
}

TEST(HomingControl, StartNeedsRisingEdgeWithoutHaltInOperationEnabled) {
  // Given bit 4 set with halt, or outside OPERATION ENABLED, When cycles pass, Then no start.
  Rig halted(HomingConfig{}, limits(), 0);
  for (int i = 0; i < 20; ++i)
    halted.cycle(kStartHalt);
  EXPECT_EQ(halted.mode.status(), HomingStatus::not_started);
  EXPECT_EQ(halted.mode.statusword_bits(), kNotStarted);
  Rig disabled(HomingConfig{}, limits(), 0);
  for (int i = 0; i < 20; ++i)
    disabled.cycle(kStart, false);
  EXPECT_EQ(disabled.mode.status(), HomingStatus::not_started);
  // When bit 4 is already 1 when the drive is enabled, Then it is no edge: still not started.
  for (int i = 0; i < 20; ++i)
    disabled.cycle(kStart, true);
  EXPECT_EQ(disabled.mode.status(), HomingStatus::not_started);
}

TEST(HomingControl, LeavingOperationEnabledIsAnError) {
  // Given a run, When the PDS leaves OPERATION ENABLED, Then bit 13 (Festo 11-1).
  Rig rig = started_rig(17, limits(), 0);
  for (int i = 0; i < 100; ++i)
    rig.cycle(kStart);
  rig.cycle(kStart, false);
  EXPECT_EQ(rig.mode.status(), HomingStatus::error);
  EXPECT_NE(rig.mode.statusword_bits() & 0x2000, 0);
}

TEST(HomingErrors, MissingLimitSwitchEndsAtTheStop) {
  // Given no LS- but a mechanical stop at -11000, When 17 runs, Then error: 1/0/0 while
  // braking (none here: the stop holds it), 1/0/1 at standstill.
  Layout l = stops();
  l.limit_negative.reset();
  const HomingRun run = run_method(17, l, 0);
  EXPECT_EQ(run.status, HomingStatus::error);
  EXPECT_EQ(run.bits.back(), kErrorStopped);
}

TEST(HomingErrors, MissingSwitchWithoutStopTimesOut) {
  // Given no LS- and no stop, When 17 runs, Then error after the 60 s timeout (Festo 11-3).
  Layout l = limits();
  l.limit_negative.reset();
  const HomingRun run = run_method(17, l, 0);
  EXPECT_EQ(run.status, HomingStatus::error);
  EXPECT_EQ(run.bits,
            (std::vector<std::uint16_t>{kNotStarted, kInProgress, kErrorMoving, kErrorStopped}));
  EXPECT_NEAR(run.duration_s, 60.1, 0.2);
}

TEST(HomingErrors, NoHomeSwitchBetweenTheLimits) {
  // Given no home switch, When 7 runs, Then it reverses at LS+ and errs at LS- (limit reached).
  const HomingRun run = run_method(7, limits(), 0);
  EXPECT_EQ(run.status, HomingStatus::error);
  EXPECT_EQ(run.first_direction, +1);
  EXPECT_EQ(run.bits.back(), kErrorStopped);
  EXPECT_LT(run.duration_s, 30.0);
}

TEST(HomingErrors, LimitSwitchAheadWhileSearchingTheHomeEdge) {
  // Given no home switch, When 4 runs (positive home switch) from 0, Then it crawls (200/s)
  // to LS+ at 10000 and ends in error there after 50 s, before the 60 s timeout.
  const HomingRun run = run_method(4, limits(), 0);
  EXPECT_EQ(run.status, HomingStatus::error);
  EXPECT_NEAR(run.duration_s, 50.0, 0.2);
}

TEST(HomingErrors, BothLimitSwitchesAtOnce) {
  // Given LS- and LS+ both active at the start (LS+ from 0 up, LS- from 0 down), When 1
  // runs, Then error at once (Festo 11-4).
  Layout l;
  l.limit_negative = 0;
  l.limit_positive = 0;
  const HomingRun run = run_method(1, l, 0);
  EXPECT_EQ(run.status, HomingStatus::error);
}

TEST(HomingErrors, IndexMethodWithoutIndexPulse) {
  // Given an axis without index pulse, When 34 starts, Then error at once (Festo 11-2).
  Layout l = limits();
  l.index_period = 0;
  const HomingRun run = run_method(34, l, 0);
  EXPECT_EQ(run.status, HomingStatus::error);
  EXPECT_EQ(run.bits, (std::vector<std::uint16_t>{kNotStarted, kErrorStopped}));
}

TEST(HomingObjectsRules, UnsupportedAndBusyMethodWritesAreRefused) {
  // Given the standard drive, When 6098h = 15 / -1 is set, Then 06090030h; while running any
  // method is refused with 08000022h (Festo L6119).
  HomingMode mode;
  EXPECT_EQ(mode.set_method(15).error(), cia301::SdoAbort::invalid_value);
  EXPECT_EQ(mode.set_method(-1).error(), cia301::SdoAbort::invalid_value);
  HomingConfig festo;
  festo.vendor = HomingVendor::festo;
  EXPECT_TRUE(HomingMode(festo).set_method(-1));
  Rig rig = started_rig(17, limits(), 0);
  ASSERT_TRUE(rig.mode.running());
  EXPECT_EQ(rig.mode.set_method(18).error(), cia301::SdoAbort::cannot_transfer_device_state);
}

TEST(HomingObjectsRules, ObjectsAreAddedWithDefaults) {
  // Given an empty dictionary, When the homing objects are added, Then 607Ch, 6098h, 6099h
  // sub 0..2 and 609Ah read their defaults.
  cia301::ObjectDictionary od;
  HomingConfig config;
  ASSERT_TRUE(add_homing_objects(od, config));
  EXPECT_EQ(od.find(0x6098, 0)->as_signed(), 17);
  EXPECT_EQ(od.find(0x6099, 0)->as_unsigned(), 2u);
  EXPECT_EQ(od.find(0x6099, 1)->as_unsigned(), config.search_speed);
  EXPECT_EQ(od.find(0x6099, 2)->as_unsigned(), config.zero_speed);
  EXPECT_EQ(od.find(0x609A, 0)->as_unsigned(), config.acceleration);
  EXPECT_EQ(od.find(0x607C, 0)->as_signed(), 0);
  HomingMode mode(config);
  HomingObjects binding(od, mode);
  const std::uint8_t bad[] = {15};
  EXPECT_FALSE(od.write(0x6098, 0, bad));
}

// --- deviations and personalities -----------------------------------------------------------

TEST(HomingDeviationRows, WrongEdgeEndsAtTheOtherEdge) {
  // Given homing-wrong-edge, When 23 runs, Then home is the upper edge (3400), not 2100.
  HomingConfig config;
  config.deviations.wrong_edge = true;
  Rig rig = started_rig(23, window(), 0, config);
  for (int i = 0; i < 30000 && (rig.mode.running() || rig.axis.velocity() != 0); ++i) {
    rig.cycle(kStart);
  }
  EXPECT_NEAR(rig.axis.physical() - rig.axis.position(), 3400, kEdgeTolerance);
}

TEST(HomingDeviationRows, HaltNotReportedStaysInProgress) {
  // Given homing-halt-not-reported, When halt stops a run, Then 0/0/0 stays.
  HomingConfig config;
  config.deviations.halt_not_reported = true;
  Rig rig = started_rig(17, limits(), 0, config);
  for (int i = 0; i < 100; ++i)
    rig.cycle(kStart);
  for (int i = 0; i < 500; ++i)
    rig.cycle(kStartHalt);
  EXPECT_EQ(rig.axis.velocity(), 0);
  EXPECT_EQ(rig.mode.statusword_bits(), kInProgress);
}

TEST(HomingDeviationRows, ErrorBitNeverSetAndOffsetIgnored) {
  // Given homing-error-bit-never-set, When LS- is missing (timeout), Then bit 13 stays 0.
  HomingConfig config;
  config.deviations.no_error_bit = true;
  config.timeout = 1s;
  Layout l = limits();
  l.limit_negative.reset();
  Rig rig = started_rig(17, l, 0, config);
  for (int i = 0; i < 3000; ++i)
    rig.cycle(kStart);
  EXPECT_EQ(rig.mode.status(), HomingStatus::error);
  EXPECT_EQ(rig.mode.statusword_bits() & 0x2000, 0);
  // Given homing-offset-ignored and 607Ch = 5000, When 35 runs, Then 6064h = 0.
  HomingConfig ignored;
  ignored.deviations.offset_ignored = true;
  Rig off(ignored, limits(), 1234);
  ASSERT_TRUE(off.mode.set_method(35));
  off.mode.set_home_offset(5000);
  off.cycle(kEnable);
  off.cycle(kStart);
  EXPECT_DOUBLE_EQ(off.axis.position(), 0);
}

TEST(HomingDeviationRows, FestoHaltSetsError) {
  // Given Festo's documented halt behaviour (L5584-5589), When halt stops a run, Then 1/0/1.
  HomingConfig config;
  config.deviations.halt_sets_error = true;
  Rig rig = started_rig(17, limits(), 0, config);
  for (int i = 0; i < 100; ++i)
    rig.cycle(kStart);
  for (int i = 0; i < 500; ++i)
    rig.cycle(kStartHalt);
  EXPECT_EQ(rig.mode.statusword_bits(), kErrorStopped);
}

TEST(HomingControl, NewStartClearsAttained) {
  // Given a completed run, When bit 4 rises again, Then bit 12 clears while the new run
  // runs (IRTSA L475) and is set again at its end.
  Rig rig = started_rig(34, limits(), 0);
  for (int i = 0; i < 5000 && rig.mode.statusword_bits() != kCompleted; ++i)
    rig.cycle(kStart);
  ASSERT_EQ(rig.mode.statusword_bits(), kCompleted);
  rig.cycle(kEnable);
  rig.cycle(kStart);
  EXPECT_EQ(rig.mode.statusword_bits(), kInProgress);
  for (int i = 0; i < 10000 && rig.mode.statusword_bits() != kCompleted; ++i)
    rig.cycle(kStart);
  EXPECT_EQ(rig.mode.statusword_bits(), kCompleted);
}

// --- in the reference drive (Cia402Application + AxisModel, over SDO on the simulated bus) ---

struct DriveHoming {
  Cia402Application app;
  std::unique_ptr<testing::DriveRig> rig;

  static Cia402ApplicationConfig with(DeviationSet deviations) {
    Cia402ApplicationConfig config;
    config.deviations = deviations;
    return config;
  }
  explicit DriveHoming(HomingVendor vendor = HomingVendor::cia402, DeviationSet deviations = {},
                       HomingConfig config = {})
      : app(with(deviations)) {
    config.vendor = vendor;
    app.add_mode(std::make_unique<HomingOperationMode>(config));
    DriveConfig drive;
    drive.application = &app;
    rig = std::make_unique<testing::DriveRig>(5, drive);
  }
  void simulate(std::string_view name, std::int64_t value) {
    ASSERT_TRUE(app.simulate(name, value)) << name;
  }
  std::int64_t read_signed(std::uint16_t index, unsigned bits) {
    const testing::SdoResult r = rig->read(index, 0);
    EXPECT_TRUE(r.answered && !r.abort) << std::hex << index;
    const std::uint64_t sign = std::uint64_t{1} << (bits - 1);
    const std::uint64_t mask = (sign << 1) - 1;
    const std::uint64_t v = r.value & mask;
    return static_cast<std::int64_t>(v ^ sign) - static_cast<std::int64_t>(sign);
  }
  std::uint16_t statusword() { return static_cast<std::uint16_t>(rig->read(0x6041, 0).value); }
};

TEST(HomingInTheDrive, MethodTwentyThreeOverSdo) {
  // Given the reference drive with the window layout at 0 and 607Ch = 1000, When method 23 is
  // started over SDO (6060h = 6, 6098h = 23, 000Fh then 001Fh), Then 6041h shows 0/0/0, then
  // 0/1/1 within 30 s, 6064h = 1000 - braking (approach negative), and with the axis put at 2600
  // (home + 500) 6064h reads 1500.
  DriveHoming d;
  d.simulate("switch-layout-clear", 1);
  d.simulate("limit-negative-at", -10000);
  d.simulate("limit-positive-at", 10000);
  d.simulate("home-switch-from", 2100);
  d.simulate("home-switch-to", 3400);
  d.simulate("index-period", 1000);
  d.simulate("index-offset", 250);
  d.simulate("axis-position", 0);
  auto& rig = *d.rig;
  ASSERT_EQ(rig.write(0x6060, 0, 6, 1), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6098, 0, 23, 1), 0u);
  ASSERT_EQ(rig.write(0x607C, 0, 1000, 4), 0u);
  ASSERT_EQ(rig.write(0x6099, 1, 2000, 4), 0u);
  ASSERT_EQ(rig.write(0x6099, 2, 200, 4), 0u);
  ASSERT_EQ(rig.write(0x609A, 0, 20000, 4), 0u);
  // A reserved method is refused (06090030h).
  EXPECT_EQ(rig.write(0x6098, 0, 15, 1), 0x06090030u);
  ASSERT_EQ(rig.write(0x6040, 0, 0x0006, 2), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6040, 0, 0x000F, 2), 0u);
  rig.run(10ms);
  EXPECT_EQ(d.statusword() & 0x346F, 0x0427);  // OE, not started
  ASSERT_EQ(rig.write(0x6040, 0, 0x001F, 2), 0u);
  rig.run(100ms);
  EXPECT_EQ(d.statusword() & 0x3400, 0x0000);
  EXPECT_GT(d.read_signed(0x606C, 32), 0);  // first travel positive
  // While running, 6098h cannot change (08000022h).
  EXPECT_EQ(rig.write(0x6098, 0, 24, 1), 0x08000022u);
  std::uint16_t sw = 0;
  for (int i = 0; i < 300 && (sw & 0x3400) != 0x1400; ++i) {
    rig.run(100ms);
    sw = d.statusword();
    ASSERT_EQ(sw & 0x2000, 0) << "homing error";
  }
  EXPECT_EQ(sw & 0x346F, 0x1427);
  const std::int64_t at_end = d.read_signed(0x6064, 32);
  EXPECT_GE(at_end, 997);  // braking from crawl speed, approach negative: 999
  EXPECT_LE(at_end, 1000);
  ASSERT_EQ(rig.write(0x6040, 0, 0x0006, 2), 0u);
  rig.run(20ms);
  d.simulate("axis-position", 2600);
  EXPECT_NEAR(static_cast<double>(d.read_signed(0x6064, 32)), 1500.0, 2.0);
}

// One case through the whole drive, as vectors/cia402/homing.yaml runs it: layout, 607Ch =
// 1000, start, 0/0/0 and 606Ch's sign after 100 ms, 0/1/1, 6064h = 1000 ± braking, then the
// axis put at home + 500 (disabled) reads 1500.
void check_in_drive(const Case& c, HomingVendor vendor = HomingVendor::cia402,
                    DeviationSet deviations = {}, std::optional<std::int8_t> method_before = {}) {
  SCOPED_TRACE(::testing::Message() << "method " << int{c.method} << " from " << c.start);
  DriveHoming d(vendor, deviations);
  d.simulate("switch-layout-clear", 1);
  const auto at = [](std::optional<double> v) { return static_cast<std::int64_t>(*v); };
  if (c.layout.limit_negative) d.simulate("limit-negative-at", at(c.layout.limit_negative));
  if (c.layout.limit_positive) d.simulate("limit-positive-at", at(c.layout.limit_positive));
  if (c.layout.home_from) d.simulate("home-switch-from", at(c.layout.home_from));
  if (c.layout.home_to) d.simulate("home-switch-to", at(c.layout.home_to));
  if (c.layout.stop_negative) d.simulate("stop-negative-at", at(c.layout.stop_negative));
  if (c.layout.stop_positive) d.simulate("stop-positive-at", at(c.layout.stop_positive));
  d.simulate("index-period", static_cast<std::int64_t>(c.layout.index_period));
  d.simulate("index-offset", static_cast<std::int64_t>(c.layout.index_offset));
  d.simulate("axis-position", static_cast<std::int64_t>(c.start));
  auto& rig = *d.rig;
  ASSERT_EQ(rig.write(0x6060, 0, 6, 1), 0u);
  rig.run(10ms);
  if (method_before) {
    ASSERT_EQ(rig.write(0x6098, 0, static_cast<std::uint8_t>(*method_before), 1), 0u);
  }
  ASSERT_EQ(rig.write(0x6098, 0, static_cast<std::uint8_t>(c.method), 1), 0u);
  // The stop detection: following error window 500 (the vectors write it too).
  if (c.layout.stop_negative || c.layout.stop_positive) {
    ASSERT_EQ(rig.write(0x6065, 0, 500, 4), 0u);
  }
  ASSERT_EQ(rig.write(0x607C, 0, 1000, 4), 0u);
  ASSERT_EQ(rig.write(0x6099, 1, 2000, 4), 0u);
  ASSERT_EQ(rig.write(0x6099, 2, 200, 4), 0u);
  ASSERT_EQ(rig.write(0x609A, 0, 20000, 4), 0u);
  ASSERT_EQ(rig.write(0x6040, 0, 0x0006, 2), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6040, 0, 0x000F, 2), 0u);
  rig.run(10ms);
  EXPECT_EQ(d.statusword() & 0x346F, 0x0427);
  ASSERT_EQ(rig.write(0x6040, 0, 0x001F, 2), 0u);
  rig.run(100ms);
  if (c.first != 0) {
    EXPECT_EQ(d.statusword() & 0x3400, 0x0000);
    const std::int64_t v = d.read_signed(0x606C, 32);
    EXPECT_EQ(v > 0 ? 1 : (v < 0 ? -1 : 0), c.first) << "606Ch = " << v;
  }
  std::uint16_t sw = d.statusword();
  for (int i = 0; i < 300 && (sw & 0x3400) != 0x1400; ++i) {
    rig.run(100ms);
    sw = d.statusword();
    ASSERT_EQ(sw & 0x2000, 0) << "homing error";
  }
  EXPECT_EQ(sw & 0x346F, 0x1427);
  EXPECT_NEAR(static_cast<double>(d.read_signed(0x6064, 32)), 1000.0, 3.0);
  ASSERT_EQ(rig.write(0x6040, 0, 0x0006, 2), 0u);
  rig.run(20ms);
  d.simulate("axis-position", static_cast<std::int64_t>(c.home) + 500);
  EXPECT_NEAR(static_cast<double>(d.read_signed(0x6064, 32)), 1500.0, 2.0);
}

TEST(HomingInTheDrive, EveryStandardMethodFromEverySide) {
  // Given the reference drive (AxisModel, factor group 1:1), When every standard case above
  // runs over SDO, Then each ends where the hand-worked table says.
  for (const auto& cases :
       {limit_index_cases(), limit_cases(), positive_home_cases(), negative_home_cases(),
        window_index_cases(), window_cases(), index_cases()}) {
    for (const Case& c : cases)
      check_in_drive(c);
  }
  check_in_drive({35, limits(), 1234, 0, 1234});
  check_in_drive({37, limits(), 1234, 0, 1234});
}

TEST(HomingInTheDrive, FestoAndKollmorgenMethodsWithoutStops) {
  // Given the Festo / Kollmorgen method sets, When -23/-27 and -1/-2 run, Then as above.
  for (const Case& c : {Case{-23, window(), 0, +1, 2100}, Case{-23, window(), 6000, +1, 2100},
                        Case{-27, window(), 0, -1, 3400}, Case{-27, window(), 2800, -1, 3400}}) {
    check_in_drive(c, HomingVendor::festo);
  }
  check_in_drive({-1, limits(), 600, -1, 250}, HomingVendor::kollmorgen);
  check_in_drive({-2, limits(), 1234, 0, 1234}, HomingVendor::kollmorgen);
}

TEST(HomingInTheDrive, StopMethodsAgainstTheAxisModelsEndStops) {
  // Given the reference drive's AxisModel with end stops at ±11000 (simulate stop-*-at) and
  // 6065h = 500, When Festo -1 -2 -17 -18 and Kollmorgen -6 -7 -3 run over SDO, Then each
  // ends at the stop or the pulse off it, 6064h = 607Ch there, no homing error on the way.
  check_in_drive({-1, stops(), 0, -1, -10750}, HomingVendor::festo);
  check_in_drive({-2, stops(), 0, +1, 10250}, HomingVendor::festo);
  check_in_drive({-17, stops(), 0, -1, -11000}, HomingVendor::festo);
  check_in_drive({-18, stops(), 0, +1, 11000}, HomingVendor::festo);
  check_in_drive({-6, stops(), 0, +1, 11000}, HomingVendor::kollmorgen);
  check_in_drive({-7, stops(), 0, -1, -11000}, HomingVendor::kollmorgen);
  check_in_drive({-3, stops(), 0, +1, 10250}, HomingVendor::kollmorgen, {}, std::int8_t{-6});
  check_in_drive({-3, stops(), 0, -1, -10750}, HomingVendor::kollmorgen, {}, std::int8_t{-7});
}

TEST(HomingInTheDrive, FestoViaLimitMethodsTurnAtTheEndStops) {
  // Given the window layout with mechanical stops at +-11000 and no limit switches (Festo -23
  // / -27: "to stop or limit switch", Tab. 7.1 L6235-6236), When -23 / -27 run over SDO from
  // either side of the switch, Then each turns at the stop it meets first (found by the
  // following error, 6065h = 500) and ends at the edge: -23 the lower 2100, -27 the upper 3400
  Layout l = window();
  l.limit_negative.reset();
  l.limit_positive.reset();
  l.stop_negative = -11000;
  l.stop_positive = 11000;
  for (const Case& c : {Case{-23, l, 0, +1, 2100}, Case{-23, l, 6000, +1, 2100},
                        Case{-27, l, 0, -1, 3400}, Case{-27, l, 6000, -1, 3400}}) {
    check_in_drive(c, HomingVendor::festo);
  }
}

TEST(HomingInTheDrive, DeviationSetReachesTheMode) {
  // Given --deviation homing-wrong-edge in the application config, When 23 runs from the left,
  // Then home is the upper edge 3400 (the vector cia402/homing/method-23/* catches it).
  check_in_drive({23, window(), 0, +1, 3400}, HomingVendor::cia402,
                 DeviationSet{Deviation::homing_wrong_edge});
}

TEST(HomingInTheDrive, HaltThenReleaseAsTheVectorRunsIt) {
  // Given method 17 running for 200 ms in the drive (605Dh = 1: slow down ramp), When halt is
  // set, Then 0/0/1 within 1 s; When halt is released with bit 4 still 1, Then no resume:
  // 0/0/1 and 606Ch = 0 after 300 ms (vector cia402/homing/halt/interrupts).
  DriveHoming d;
  d.simulate("switch-layout-clear", 1);
  d.simulate("limit-negative-at", -10000);
  d.simulate("limit-positive-at", 10000);
  d.simulate("axis-position", 0);
  auto& rig = *d.rig;
  ASSERT_EQ(rig.write(0x6060, 0, 6, 1), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6098, 0, 17, 1), 0u);
  ASSERT_EQ(rig.write(0x6040, 0, 0x0006, 2), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6040, 0, 0x000F, 2), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6040, 0, 0x001F, 2), 0u);
  rig.run(200ms);
  EXPECT_LT(d.read_signed(0x606C, 32), 0);
  ASSERT_EQ(rig.write(0x6040, 0, 0x011F, 2), 0u);
  rig.run(1s);
  EXPECT_EQ(d.statusword() & 0x3400, 0x0400);
  ASSERT_EQ(rig.write(0x6040, 0, 0x001F, 2), 0u);
  rig.run(300ms);
  EXPECT_EQ(d.statusword() & 0x3400, 0x0400);
  EXPECT_EQ(d.read_signed(0x606C, 32), 0);
  // When bit 4 falls and rises again, Then a new run starts (0/0/0, moving).
  ASSERT_EQ(rig.write(0x6040, 0, 0x000F, 2), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6040, 0, 0x001F, 2), 0u);
  rig.run(100ms);
  EXPECT_EQ(d.statusword() & 0x3400, 0x0000);
  EXPECT_LT(d.read_signed(0x606C, 32), 0);
}

TEST(HomingInTheDrive, PersonalityBehaviourSurvivesTheDeviationSet) {
  // Given a personality without bit 13 (IRTSA footnote 9 L493) and an unrelated deviation,
  // When method 4 finds no home switch (crawl from 9000 to LS+), Then the run fails and bit 13
  // stays 0.
  HomingConfig config;
  config.deviations.no_error_bit = true;
  DriveHoming d(HomingVendor::irtsa, DeviationSet{Deviation::homing_offset_ignored}, config);
  d.simulate("switch-layout-clear", 1);
  d.simulate("limit-negative-at", -10000);
  d.simulate("limit-positive-at", 10000);
  d.simulate("axis-position", 9000);
  auto& rig = *d.rig;
  ASSERT_EQ(rig.write(0x6060, 0, 6, 1), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6098, 0, 4, 1), 0u);
  ASSERT_EQ(rig.write(0x6099, 2, 200, 4), 0u);
  ASSERT_EQ(rig.write(0x6040, 0, 0x0006, 2), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6040, 0, 0x000F, 2), 0u);
  rig.run(10ms);
  ASSERT_EQ(rig.write(0x6040, 0, 0x001F, 2), 0u);
  rig.run(8s);
  const auto* mode = dynamic_cast<HomingOperationMode*>(d.app.mode(6));
  ASSERT_NE(mode, nullptr);
  EXPECT_EQ(mode->homing().status(), HomingStatus::error);
  EXPECT_EQ(d.statusword() & 0x3400, 0x0400);
}

}  // namespace
}  // namespace drivecheck::reference_drive
