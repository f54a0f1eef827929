// Interpolated position mode (6060h = 7; CiA 402-2 §"Interpolated position mode"; Festo §7.4
// 000_33c1d912b8b6010a.txt L6447-6729): the master writes position records (60C1h sub 1,
// usually by RPDO) and sends SYNC; at every SYNC the drive takes the next record from its FIFO
// and moves the demand linearly from the previous record to it over the interpolation period
// 60C2h (sub 1 units × 10^sub 2 s; default 1 × 10⁻³ s, an application object).
//
// Objects (this mode's own):
//   60C0h interpolation sub mode select  INTEGER16 rw PDO  0 (linear); other values 06090030h
//   60C1h interpolation data record      ARRAY sub 1 INTEGER32 rw PDO: a position (user units,
//                                        absolute); each write is one record
//   60C3h interpolation sync definition  ARRAY sub 1 synchronize on group U8 (0: SYNC), sub 2
//                                        ip sync every n event U8 (1) rw
//   60C4h interpolation data configuration RECORD: 1 maximum buffer size U32 ro (16), 2 actual
//                                        buffer size U32 rw (1..16, default 16), 3 buffer
//                                        organisation U8 rw (0 FIFO), 4 buffer position U16 rw,
//                                        5 size of data record U8 rw (1), 6 buffer clear U8 rw
//                                        (0: clear the buffer and refuse records, 1: enable)
// A record written while the buffer is disabled or full: abort 08000022h (not in the present
// device state). Records are consumed (one per SYNC) only while ip is active.
//
// Controlword bit 4 enable ip mode (OPERATION ENABLED): 1 = the records are interpolated;
// statusword bit 12 ip mode active follows it (same cycle); clearing bit 4 holds the demand
// where it is. Bit 13 following error (the application's check). Halt: the PDS stops the axis,
// the FIFO is kept.
// Records written before bit 4 is set wait in the FIFO (only 60C4h sub 6 = 0 clears it).
// Deviations: ip-active-bit-never-set, ip-records-cleared-on-enable, and of 60C4h
// ip-buffer-clear-any-value-enables, ip-record-size-zero-accepted,
// ip-actual-buffer-size-above-max-accepted, ip-buffer-resize-drops-record,
// ip-software-limit-ignored.
#pragma once

#include <algorithm>
#include <cstdint>
#include <deque>
#include <optional>

#include "reference_drive/modes/operation_mode.hpp"

namespace drivecheck::reference_drive {

// 60C2h as a duration (units × 10^index s); nullopt for a zero or unusable period.
std::optional<double> interpolation_period_seconds(const cia301::ObjectDictionary& od);

class InterpolatedPositionMode final : public OperationMode {
 public:
  static constexpr std::uint32_t kMaxBuffer = 16;

  // `submode`: the one 60C0h value accepted, also its default (CiA 402: 0, linear
  // interpolation; a personality's manufacturer value, Festo -2, runs the same interpolation).
  // `max_buffer`: 60C4h sub 01h, 0..kMaxBuffer; 0: no buffer (one record, the last written,
  // taken at the next SYNC; 60C4h sub 02h then reads and accepts 0 only).
  // `deviations`: the ones its objects' checks show (the rows of 60C4h; the others are read
  // from the ModeContext at run time).
  explicit InterpolatedPositionMode(std::int16_t submode = 0, std::uint32_t max_buffer = kMaxBuffer,
                                    DeviationSet deviations = {})
      : submode_(submode), max_buffer_(std::min(max_buffer, kMaxBuffer)), deviations_(deviations) {}

  std::int8_t mode() const override { return 7; }
  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override;
  void on_reset(ModeContext& ctx) override;
  void enter(ModeContext& ctx, const ModeCycle& cycle) override;
  void on_sync(ModeContext& ctx, can::TimePoint at) override;
  void cycle(ModeContext& ctx, const ModeCycle& cycle) override;
  std::uint16_t statusword_bits(cia402::State state) const override;

  bool active() const { return active_; }
  std::size_t buffered() const { return fifo_.size(); }

 private:
  std::deque<std::int32_t> fifo_;  // user units
  bool buffer_enabled_ = true;
  std::uint32_t buffer_size_ = kMaxBuffer;
  bool active_ = false;
  double start_ = 0.0;  // segment, internal units
  double end_ = 0.0;
  std::optional<can::TimePoint> segment_at_;
  std::uint16_t bits_ = 0;
  std::int16_t submode_ = 0;
  std::uint32_t max_buffer_ = kMaxBuffer;
  DeviationSet deviations_;
  // The records the FIFO holds at most: the buffer size, or one without a buffer.
  std::size_t capacity() const { return max_buffer_ == 0 ? 1 : buffer_size_; }
};

}  // namespace drivecheck::reference_drive
