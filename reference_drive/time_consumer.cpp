#include "reference_drive/time_consumer.hpp"

#include "protocol/cia301/cob_id.hpp"
#include "protocol/cia301/sdo_codec.hpp"
#include "protocol/cia301/time.hpp"
#include "reference_drive/dictionary.hpp"

namespace drivecheck::reference_drive {
namespace {

constexpr std::uint32_t kConsume = 0x80000000u;   // bit 31
constexpr std::uint32_t kProduce = 0x40000000u;   // bit 30
constexpr std::uint32_t kFrame = 0x20000000u;     // bit 29: 29-bit CAN-ID
constexpr std::uint32_t kReserved = 0x1FFFF800u;  // bits 28..11 with an 11-bit CAN-ID
constexpr std::uint32_t kCanId = 0x7FFu;

}  // namespace

TimeConsumer::TimeConsumer(cia301::ObjectDictionary& od, TimeConsumerOptions options)
    : od_(od),
      options_(options),
      cob_id_(od.find(kTimeCobIdIndex, 0)),
      received_(od.find(kTimeReceivedIndex)) {
  if (cob_id_ == nullptr) return;
  cob_id_->set_write_validator(
      [options](const cia301::ObjectDictionary&, const cia301::Entry&,
                std::span<const std::uint8_t> data) -> Expected<void, cia301::SdoAbort> {
        const auto value = static_cast<std::uint32_t>(cia301::load_unsigned(data));
        if (options.refuse_producer_frame && (value & (kProduce | kFrame)) != 0) {
          return Unexpected(cia301::SdoAbort::invalid_value);  // a consumer of 11-bit CAN-IDs
        }
        if ((value & kFrame) == 0 && (value & kReserved) != 0) {
          return Unexpected(cia301::SdoAbort::invalid_value);
        }
        if (options.refuse_restricted && (value & kFrame) == 0 &&
            cia301::is_restricted_cob_id(value & kCanId)) {
          return Unexpected(cia301::SdoAbort::invalid_value);  // CiA 301 §7.3.5
        }
        return {};
      });
}

bool TimeConsumer::on_frame(const can::Frame& frame, cia301::NmtState state) {
  if (!present() || frame.is_error() || frame.format != can::IdFormat::standard) return false;
  const auto cob_id = static_cast<std::uint32_t>(cob_id_->as_unsigned());
  if ((cob_id & kFrame) != 0 || frame.id != (cob_id & kCanId)) return false;
  const bool consumer = (cob_id & kConsume) != 0 || options_.consumer_bit_ignored;
  const bool allowed =
      state == cia301::NmtState::pre_operational || state == cia301::NmtState::operational;
  if (!consumer || !allowed) return false;  // not ours now: another service may take the frame
  const auto time = cia301::decode_time(frame, frame.id);
  if (!time) return true;  // an invalid TIME frame is dropped
  received_->entries()[1].assign_unsigned(time->ms);
  received_->entries()[2].assign_unsigned(time->days);
  cia301::Entry& count = received_->entries()[3];
  count.assign_unsigned(static_cast<std::uint32_t>(count.as_unsigned() + 1));
  return true;
}

void TimeConsumer::reset() {
  if (received_ == nullptr) return;
  for (cia301::Entry& entry : received_->entries()) {
    if (entry.sub_index() != 0) entry.assign_unsigned(0);
  }
}

}  // namespace drivecheck::reference_drive
