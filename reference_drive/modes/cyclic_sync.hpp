// The cyclic synchronous modes (CiA 402-2 §"Cyclic synchronous position/velocity/torque
// mode"): the master sends a command value every SYNC period (RPDO + SYNC); the drive takes it
// at the SYNC and follows it with its own loops.
//   8 csp  607Ah target position + 60B0h position offset (user units, clamped to 607Dh); the
//          demand moves linearly from the previous command to the new one over the
//          interpolation period 60C2h; 60B1h velocity offset is the velocity feed-forward
//   9 csv  60FFh target velocity + 60B1h velocity offset (limited by 6080h), velocity control
//  10 cst  6071h target torque + 60B2h torque offset (limited by 6072h), torque control
// The command is latched at every SYNC (a 607Ah written between two SYNCs waits for the
// next one); while no SYNC has come since the mode started (or the drive was reset) it is
// latched every drive cycle instead, so that masters without SYNC work too.
// Statusword (OPERATION ENABLED): bit 12 drive follows the command value (1 while the drive
// function follows set-points, 0 with halt or a stop ramp); bit 13 following error (csp: the
// application's 6065h/6066h check, CiA 402-2 6066h; it stays set through the fault reaction
// the reference drive takes on it, until the drive is enabled again); bit 10 0 (reserved).
// Deviations: csp/csv/cst-follows-bit-never-set, csv-velocity-offset-ignored,
// cst-torque-offset-ignored, csp-position-offset-ignored, csp-following-error-bit-never-set,
// csp-software-limit-ignored.
#pragma once

#include <cstdint>
#include <optional>

#include "reference_drive/modes/operation_mode.hpp"

namespace drivecheck::reference_drive {

enum class CyclicKind : std::int8_t { position = 8, velocity = 9, torque = 10 };

class CyclicSyncMode final : public OperationMode {
 public:
  explicit CyclicSyncMode(CyclicKind kind) : kind_(kind) {}
  std::int8_t mode() const override { return static_cast<std::int8_t>(kind_); }
  void on_reset(ModeContext& ctx) override;
  void enter(ModeContext& ctx, const ModeCycle& cycle) override;
  void on_sync(ModeContext& ctx, can::TimePoint at) override;
  void cycle(ModeContext& ctx, const ModeCycle& cycle) override;
  std::uint16_t statusword_bits(cia402::State state) const override;

  std::uint64_t syncs() const { return syncs_; }

 private:
  void latch(ModeContext& ctx, can::TimePoint at);

  CyclicKind kind_;
  double start_ = 0.0;  // csp segment (internal)
  double end_ = 0.0;
  double feed_forward_ = 0.0;
  double command_ = 0.0;  // csv: velocity (internal), cst: torque (‰)
  std::optional<can::TimePoint> latched_at_;
  std::optional<can::TimePoint> last_sync_;
  bool tracking_ = true;  // not enabled: the command follows the actual values
  std::uint64_t syncs_ = 0;
  std::uint16_t bits_ = 0;
  bool following_error_latched_ = false;  // csp bit 13 through the fault reaction it caused
};

}  // namespace drivecheck::reference_drive
