#include "reference_drive/modes/interpolated_position.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

namespace drivecheck::reference_drive {
namespace {

using cia301::AccessType;
using cia301::DataType;
using cia301::EntryDefinition;
using cia301::ObjectCode;
using cia301::ObjectDefinition;
using cia301::Value;

constexpr std::uint16_t kEnableIp = 0x0010;
constexpr std::uint16_t kIpActive = 0x1000;
constexpr std::uint16_t kFollowingError = 0x2000;

// The dictionary's factories under short names (object definitions below read as tables).
constexpr auto* entry = &EntryDefinition::make;
constexpr auto* count = &EntryDefinition::highest_sub_index;

}  // namespace

std::optional<double> interpolation_period_seconds(const cia301::ObjectDictionary& od) {
  const cia301::Entry* units = od.find(cia402::kInterpolationTimePeriodUnits.index, 1);
  const cia301::Entry* index = od.find(cia402::kInterpolationTimePeriodIndex.index, 2);
  if (units == nullptr || index == nullptr) return std::nullopt;
  const double u = static_cast<double>(units->as_unsigned());
  const auto i = index->as_signed();
  if (u <= 0.0 || i < -6 || i > 0) return std::nullopt;
  return u * std::pow(10.0, static_cast<double>(i));
}

Expected<void, std::string> InterpolatedPositionMode::add_objects(cia301::ObjectDictionary& od) {
  if (auto r = od.add_var(0x60C0, "interpolation sub mode select", DataType::integer16,
                          AccessType::rw, Value::of_signed(submode_), true);
      !r) {
    return Unexpected(r.error());
  }
  od.find(0x60C0, 0)->set_write_validator(
      [submode = submode_](const cia301::ObjectDictionary&, const cia301::Entry&,
                           std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
        if (cia301::load_signed(data) != submode) {
          return Unexpected(cia301::SdoAbort::invalid_value);
        }
        return {};
      });
  ObjectDefinition record{0x60C1,
                          "interpolation data record",
                          ObjectCode::array,
                          {count(1), entry(1, "interpolation data record 1", DataType::integer32,
                                           AccessType::rw, Value::of_signed(0), true)}};
  ObjectDefinition sync{0x60C3,
                        "interpolation sync definition",
                        ObjectCode::array,
                        {count(2),
                         entry(1, "synchronize on group", DataType::unsigned8, AccessType::rw,
                               Value::of_unsigned(0), false),
                         entry(2, "ip sync every n event", DataType::unsigned8, AccessType::rw,
                               Value::of_unsigned(1), false)}};
  ObjectDefinition config{0x60C4,
                          "interpolation data configuration",
                          ObjectCode::record,
                          {count(6),
                           entry(1, "maximum buffer size", DataType::unsigned32, AccessType::ro,
                                 Value::of_unsigned(max_buffer_), false),
                           entry(2, "actual buffer size", DataType::unsigned32, AccessType::rw,
                                 Value::of_unsigned(max_buffer_), false),
                           entry(3, "buffer organisation", DataType::unsigned8, AccessType::rw,
                                 Value::of_unsigned(0), false),
                           entry(4, "buffer position", DataType::unsigned16, AccessType::rw,
                                 Value::of_unsigned(0), false),
                           entry(5, "size of data record", DataType::unsigned8, AccessType::rw,
                                 Value::of_unsigned(1), false),
                           entry(6, "buffer clear", DataType::unsigned8, AccessType::rw,
                                 Value::of_unsigned(1), false)}};
  for (ObjectDefinition* def : {&record, &sync, &config}) {
    if (auto r = od.add_object(*def); !r) return Unexpected(r.error());
  }
  od.find(0x60C1, 1)->set_write_validator(
      [this](const cia301::ObjectDictionary&, const cia301::Entry&,
             std::span<const std::uint8_t>) -> Expected<void, cia301::SdoAbort> {
        // Without a buffer a new record replaces the one not yet taken.
        if (!buffer_enabled_ || (max_buffer_ != 0 && fifo_.size() >= capacity())) {
          return Unexpected(cia301::SdoAbort::cannot_transfer_device_state);
        }
        return {};
      });
  od.find(0x60C1, 1)->set_write_observer([this](cia301::ObjectDictionary&, cia301::Entry& e) {
    if (!buffer_enabled_) return;
    if (max_buffer_ == 0) fifo_.clear();
    if (fifo_.size() < capacity()) fifo_.push_back(static_cast<std::int32_t>(e.as_signed()));
  });
  // Deviation ip-actual-buffer-size-above-max-accepted: the check is off by one.
  // Deviation ip-actual-buffer-size-max-refused: off by one the other way.
  const std::uint64_t size_limit =
      deviations_.has(Deviation::ip_actual_buffer_size_above_max_accepted) ? max_buffer_ + 1
      : deviations_.has(Deviation::ip_actual_buffer_size_max_refused)      ? max_buffer_ - 1
                                                                           : max_buffer_;
  od.find(0x60C4, 2)->set_write_validator(
      [max = size_limit](const cia301::ObjectDictionary&, const cia301::Entry&,
                         std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
        const auto v = cia301::load_unsigned(data);
        // 1..max_buffer_size; without a buffer only 0 (Festo L6620-6626: value range 0).
        if (max == 0 ? v != 0 : (v < 1 || v > max)) {
          return Unexpected(cia301::SdoAbort::invalid_value);
        }
        return {};
      });
  od.find(0x60C4, 2)->set_write_observer([this](cia301::ObjectDictionary&, cia301::Entry& e) {
    buffer_size_ = std::min(static_cast<std::uint32_t>(e.as_unsigned()), max_buffer_);
    while (fifo_.size() > capacity())
      fifo_.pop_front();
    // Deviation ip-buffer-resize-drops-record: the trim loop one record too eager.
    if (deviations_.has(Deviation::ip_buffer_resize_drops_record) && !fifo_.empty()) {
      fifo_.pop_front();
    }
  });
  for (std::uint8_t sub : {std::uint8_t{3}, std::uint8_t{5}, std::uint8_t{6}}) {
    std::uint64_t max = sub == 6 ? 1 : (sub == 5 ? 1 : 0);
    std::uint64_t min = sub == 5 ? 1 : 0;
    // Deviations ip-buffer-clear-any-value-enables (sub 6: 2..255 taken as 1) and
    // ip-record-size-zero-accepted (sub 5: the range starts at 0).
    if (sub == 6 && deviations_.has(Deviation::ip_buffer_clear_any_value_enables)) max = 0xFF;
    if (sub == 5 && deviations_.has(Deviation::ip_record_size_zero_accepted)) min = 0;
    od.find(0x60C4, sub)
        ->set_write_validator(
            [min, max](const cia301::ObjectDictionary&, const cia301::Entry&,
                       std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
              const auto v = cia301::load_unsigned(data);
              if (v < min || v > max) return Unexpected(cia301::SdoAbort::invalid_value);
              return {};
            });
  }
  od.find(0x60C4, 6)->set_write_observer([this](cia301::ObjectDictionary&, cia301::Entry& e) {
    buffer_enabled_ = e.as_unsigned() != 0;
    if (!buffer_enabled_) fifo_.clear();
  });
  return {};
}

void InterpolatedPositionMode::on_reset(ModeContext& ctx) {
  fifo_.clear();
  buffer_enabled_ = ctx.read_unsigned({0x60C4, 6}) != 0;
  buffer_size_ = max_buffer_ == 0 ? 0
                                  : static_cast<std::uint32_t>(std::clamp<std::uint64_t>(
                                        ctx.read_unsigned({0x60C4, 2}), 1, max_buffer_));
  active_ = false;
  start_ = end_ = ctx.axis.position();
  segment_at_.reset();
  bits_ = 0;
}

void InterpolatedPositionMode::enter(ModeContext& ctx, const ModeCycle& cycle) {
  (void)cycle;
  active_ = false;
  start_ = end_ = ctx.axis.position();
  segment_at_.reset();
  bits_ = 0;
}

void InterpolatedPositionMode::on_sync(ModeContext& ctx, can::TimePoint at) {
  if (!active_) return;
  // The segment so far ends where the demand is now; the next record is the new end.
  if (fifo_.empty()) return;
  const double record = static_cast<double>(fifo_.front());
  fifo_.pop_front();
  start_ = end_;
  // Deviation ip-software-limit-ignored: 607Dh not applied to the records.
  const double end = ctx.factors.position_to_internal(record);
  end_ = deviations_.has(Deviation::ip_software_limit_ignored) ? end : ctx.clamp_position(end);
  segment_at_ = at;
}

void InterpolatedPositionMode::cycle(ModeContext& ctx, const ModeCycle& cycle) {
  const bool enable = (cycle.controlword & kEnableIp) != 0;
  if (!cycle.drive_enabled) {
    active_ = false;
    start_ = end_ = ctx.axis.position();
    segment_at_.reset();
    ctx.axis.command_position(ctx.axis.position());
  } else {
    if (enable && !active_) {
      // Deviation ip-records-cleared-on-enable: the records written before bit 4 are dropped.
      if (ctx.has(Deviation::ip_records_cleared_on_enable)) fifo_.clear();
      active_ = true;
      start_ = end_ = ctx.axis.demand_position();
      segment_at_.reset();
    } else if (!enable && active_) {
      active_ = false;
    }
    double demand = end_;
    double velocity = 0.0;
    if (active_ && segment_at_) {
      const double period = interpolation_period_seconds(ctx.od).value_or(0.001);
      const double t = std::chrono::duration<double>(cycle.now - *segment_at_).count();
      const double share = std::clamp(t / period, 0.0, 1.0);
      demand = start_ + (end_ - start_) * share;
      if (share < 1.0) velocity = (end_ - start_) / period;
    }
    if (!active_) {
      demand = ctx.axis.demand_position();
    }
    ctx.axis.command_position(demand, velocity);
  }
  bits_ = 0;
  if (active_ && !ctx.has(Deviation::ip_active_bit_never_set)) bits_ |= kIpActive;
  if (ctx.following_error) bits_ |= kFollowingError;
}

std::uint16_t InterpolatedPositionMode::statusword_bits(cia402::State state) const {
  if (state != cia402::State::operation_enabled) return 0;
  return bits_;
}

}  // namespace drivecheck::reference_drive
