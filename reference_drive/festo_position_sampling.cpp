#include "reference_drive/festo_position_sampling.hpp"

#include <utility>

#include "protocol/cia402/object_ids.hpp"
#include "reference_drive/axis/factor_group.hpp"

namespace drivecheck::reference_drive {
namespace {

cia301::EntryDefinition entry(std::uint8_t sub, std::string name, cia301::DataType type,
                              cia301::AccessType access, bool pdo) {
  const bool is_signed = type == cia301::DataType::integer32;
  return cia301::EntryDefinition::make(
      sub, std::move(name), type, access,
      is_signed ? cia301::Value::of_signed(0) : cia301::Value::of_unsigned(0), pdo);
}

}  // namespace

Expected<void, std::string> FestoPositionSampling::add_objects(cia301::ObjectDictionary& od) {
  using cia301::AccessType;
  using cia301::DataType;
  cia301::EntryDefinition mode =
      entry(kModeSub, "sample_mode", DataType::unsigned16, AccessType::rw, false);
  mode.low_limit = cia301::Value::of_unsigned(0);
  mode.high_limit = cia301::Value::of_unsigned(1);  // 0 continuous, 1 autolock (L4743-4748)
  cia301::ObjectDefinition def{
      kIndex,
      "sample_data",
      cia301::ObjectCode::record,
      {cia301::EntryDefinition::highest_sub_index(6), std::move(mode),
       entry(kStatusSub, "sample_status", DataType::unsigned8, AccessType::ro, true),
       entry(kMaskSub, "sample_status_mask", DataType::unsigned8, AccessType::rw, true),
       entry(kControlSub, "sample_control", DataType::unsigned8, AccessType::wo, true),
       entry(kRisingPositionSub, "sample_position_rising_edge", DataType::integer32, AccessType::ro,
             true),
       entry(kFallingPositionSub, "sample_position_falling_edge", DataType::integer32,
             AccessType::ro, true)}};
  auto added = od.add_object(std::move(def));
  if (!added) return Unexpected("204Ah sample_data: " + added.error());
  od_ = &od;
  // Volatile: events and their positions are not parameters.
  for (std::uint8_t sub : {kStatusSub, kControlSub, kRisingPositionSub, kFallingPositionSub}) {
    od.find(kIndex, sub)->set_store_group(cia301::kStoreNone);
  }
  od.find(kIndex, kControlSub)
      ->set_write_observer([this](cia301::ObjectDictionary& dict, cia301::Entry& e) {
        on_control_write(dict, static_cast<std::uint8_t>(e.as_unsigned()));
      });
  // An SDO read between two cycles shows the positions in the units of that moment.
  for (std::uint8_t sub : {kRisingPositionSub, kFallingPositionSub}) {
    od.find(kIndex, sub)
        ->set_read_hook([this](cia301::ObjectDictionary& dict,
                               cia301::Entry&) -> Expected<void, cia301::SdoAbort> {
          publish(dict);
          return {};
        });
  }
  return {};
}

void FestoPositionSampling::on_reset(cia301::ObjectDictionary& od, cia301::ResetKind kind) {
  od_ = &od;
  if (kind != cia301::ResetKind::application) return;
  enabled_ = 0;
  status_ = 0;
  rising_.reset();
  falling_.reset();
  publish(od);
}

void FestoPositionSampling::refresh(cia301::ObjectDictionary& od) {
  od_ = &od;
  publish(od);
}

Expected<void, std::string> FestoPositionSampling::set_input(std::int64_t level) {
  if (level != 0 && level != 1) {
    return Unexpected("simulate " + std::string(kInputName) + ": value " + std::to_string(level) +
                      " out of range (0 low, 1 high)");
  }
  const bool high = level == 1;
  if (high == input_) return {};
  input_ = high;
  sample(high ? kRisingBit : kFallingBit);
  return {};
}

void FestoPositionSampling::on_control_write(cia301::ObjectDictionary& od, std::uint8_t bits) {
  const auto edges = static_cast<std::uint8_t>(bits & (kFallingBit | kRisingBit));
  enabled_ = static_cast<std::uint8_t>(enabled_ | edges);
  status_ = static_cast<std::uint8_t>(status_ & ~edges);
  publish(od);
}

void FestoPositionSampling::sample(std::uint8_t edge_bit) {
  if ((enabled_ & edge_bit) == 0) return;
  const double position = application_.axis().position();
  (edge_bit == kRisingBit ? rising_ : falling_) = position;
  status_ = static_cast<std::uint8_t>(status_ | edge_bit);
  if (od_ == nullptr) return;
  const cia301::Entry* mode = od_->find(kIndex, kModeSub);
  const bool autolock = mode != nullptr && mode->as_unsigned() == 1;
  if (autolock) enabled_ = static_cast<std::uint8_t>(enabled_ & ~edge_bit);
  publish(*od_);
}

std::int32_t FestoPositionSampling::position_units(double increments) const {
  return FactorGroup::to_i32(application_.factors().position_to_user(increments));
}

void FestoPositionSampling::publish(cia301::ObjectDictionary& od) {
  if (cia301::Entry* e = od.find(kIndex, kStatusSub)) e->assign_unsigned(status_);
  if (cia301::Entry* e = od.find(kIndex, kRisingPositionSub)) {
    (void)e->assign(cia301::Value::of_signed(rising_ ? position_units(*rising_) : 0));
  }
  if (cia301::Entry* e = od.find(kIndex, kFallingPositionSub)) {
    (void)e->assign(cia301::Value::of_signed(falling_ ? position_units(*falling_) : 0));
  }
  const cia301::Entry* mask = od.find(kIndex, kMaskSub);
  const bool visible = mask != nullptr && (status_ & mask->as_unsigned()) != 0;
  PowerDriveSystem& pds = application_.pds();
  pds.set_manufacturer_bits(visible ? kStatuswordSampleBit : 0);
  // 6041h at once (the PDS publishes it again each cycle with the same bit).
  if (cia301::Entry* statusword =
          od.find(cia402::kStatusword.index, cia402::kStatusword.sub_index)) {
    statusword->assign_unsigned(pds.statusword());
  }
}

}  // namespace drivecheck::reference_drive
