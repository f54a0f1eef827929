// A manufacturer-specific mode of operation (6060h = -128..-1) that runs the logic of a
// standard mode: the drive's manual names the mode and what it takes as set-point, and the
// personality says which standard mode that is (`manufacturer_modes: behaves_as`, e.g.
// Kollmorgen -128 "digital speed controller" takes 60FFh as profile velocity does,
// 002_953174ea6ca45cdb.txt L7201-7203). 6061h shows the manufacturer value; the statusword's
// mode bits are those of the standard mode.
//
// The standard mode's own objects (e.g. 60F8h of pv) exist once: added here only when the
// drive does not also host the standard mode itself (add_objects_too).
#pragma once

#include <memory>

#include "reference_drive/modes/operation_mode.hpp"

namespace drivecheck::reference_drive {

class ManufacturerMode final : public OperationMode {
 public:
  ManufacturerMode(std::int8_t value, std::unique_ptr<OperationMode> logic, bool add_objects_too)
      : value_(value), logic_(std::move(logic)), add_objects_too_(add_objects_too) {}

  std::int8_t mode() const override { return value_; }
  // The standard mode whose logic runs.
  std::int8_t behaves_as() const { return logic_->mode(); }

  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od) override {
    if (!add_objects_too_) return {};
    return logic_->add_objects(od);
  }
  void on_reset(ModeContext& ctx) override { logic_->on_reset(ctx); }
  void enter(ModeContext& ctx, const ModeCycle& cycle) override { logic_->enter(ctx, cycle); }
  void leave(ModeContext& ctx, const ModeCycle& cycle) override { logic_->leave(ctx, cycle); }
  void on_sync(ModeContext& ctx, can::TimePoint at) override { logic_->on_sync(ctx, at); }
  void cycle(ModeContext& ctx, const ModeCycle& cycle) override { logic_->cycle(ctx, cycle); }
  std::uint16_t statusword_bits(cia402::State state) const override {
    return logic_->statusword_bits(state);
  }

 private:
  std::int8_t value_;
  std::unique_ptr<OperationMode> logic_;
  bool add_objects_too_;
};

}  // namespace drivecheck::reference_drive
