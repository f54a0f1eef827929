#include "reference_drive/sdo_deviations.hpp"

#include <algorithm>
#include <array>

#include "protocol/cia301/object_dictionary.hpp"

namespace drivecheck::reference_drive {
namespace {

// Abort codes (CiA 301 §7.2.4.3.17) the deviations look at or give.
constexpr std::uint32_t kAbortInvalidCommand = 0x05040001;
constexpr std::uint32_t kAbortWriteReadOnly = 0x06010002;
constexpr std::uint32_t kAbortNoObject = 0x06020000;
constexpr std::uint32_t kAbortPdoLength = 0x06040042;
constexpr std::uint32_t kAbortParameterIncompatible = 0x06040043;
constexpr std::uint32_t kAbortLengthMismatch = 0x06070010;
constexpr std::uint32_t kAbortLengthHigh = 0x06070012;
constexpr std::uint32_t kAbortLengthLow = 0x06070013;
constexpr std::uint32_t kAbortNoSubIndex = 0x06090011;
constexpr std::uint32_t kAbortCannotStore = 0x08000020;

// 1010h "save" and 1011h "load" signatures, as the octets of a download.
constexpr std::array<std::uint8_t, 4> kSave{0x73, 0x61, 0x76, 0x65};
constexpr std::array<std::uint8_t, 4> kLoad{0x6C, 0x6F, 0x61, 0x64};

using Kind = SdoRequestView::Kind;

bool expedited_download(const SdoRequestView& r, std::uint16_t index) {
  return r.kind == Kind::download && r.expedited && r.index == index;
}

bool is_mapping(std::uint16_t index) {
  return (index >= 0x1600 && index <= 0x17FF) || (index >= 0x1A00 && index <= 0x1BFF);
}

// The bits of the mapping a download of a mapping count (sub 00h) would enable; 0 for a
// missing entry.
unsigned mapping_bits(const cia301::ObjectDictionary& od, std::uint16_t index, unsigned count) {
  unsigned bits = 0;
  for (unsigned sub = 1; sub <= count; ++sub) {
    const cia301::Entry* entry = od.find(index, static_cast<std::uint8_t>(sub));
    if (entry == nullptr) return 0;
    bits += static_cast<unsigned>(entry->as_unsigned() & 0xFF);
  }
  return bits;
}

// Whether a 1016h entry above `sub` monitors `node` with a non-zero time.
bool duplicate_above(const cia301::ObjectDictionary& od, std::uint8_t sub, std::uint8_t node) {
  const cia301::Object* consumers = od.find(0x1016);
  if (consumers == nullptr) return false;
  for (const cia301::Entry& entry : consumers->entries()) {
    const auto value = entry.as_unsigned();
    if (entry.sub_index() > sub && ((value >> 16) & 0xFF) == node && (value & 0xFFFF) != 0) {
      return true;
    }
  }
  return false;
}

void store_u32(std::vector<std::uint8_t>& data, std::uint32_t value) {
  data.assign(4, 0);
  for (std::size_t i = 0; i < 4; ++i)
    data[i] = static_cast<std::uint8_t>(value >> (8 * i));
}

}  // namespace

SdoAnswerView SdoAnswerView::abort_of(std::uint16_t index, std::uint8_t sub, std::uint32_t code) {
  SdoAnswerView a;
  a.kind = Kind::abort;
  a.index = index;
  a.sub = sub;
  a.code = code;
  return a;
}

SdoAnswerView SdoAnswerView::confirmed(std::uint16_t index, std::uint8_t sub) {
  SdoAnswerView a;
  a.kind = Kind::download_confirmed;
  a.index = index;
  a.sub = sub;
  return a;
}

SdoAnswerView SdoAnswerView::upload(std::uint16_t index, std::uint8_t sub,
                                    std::vector<std::uint8_t> data) {
  SdoAnswerView a;
  a.kind = Kind::expedited_upload;
  a.index = index;
  a.sub = sub;
  a.data = std::move(data);
  return a;
}

bool SdoDeviations::active() const {
  for (Deviation d : {Deviation::sdo_read_only_wrong_abort,
                      Deviation::sdo_read_only_write_accepted,
                      Deviation::sdo_no_object_wrong_abort,
                      Deviation::sdo_invalid_command_ignored,
                      Deviation::sdo_download_response_missing,
                      Deviation::sdo_toggle_not_alternated,
                      Deviation::sdo_abort_wrong_multiplexer,
                      Deviation::sdo_upload_size_wrong,
                      Deviation::sdo_length_not_checked,
                      Deviation::heartbeat_consumer_duplicate_accepted,
                      Deviation::emcy_history_not_cleared,
                      Deviation::emcy_history_appended,
                      Deviation::rpdo_mapping_not_mappable_accepted,
                      Deviation::tpdo_mapping_write_only_accepted,
                      Deviation::pdo_mapping_too_long_accepted,
                      Deviation::pdo_mapping_64_bits_refused,
                      Deviation::store_signature_ignored,
                      Deviation::restore_ignored,
                      Deviation::store_group_signature_ignored,
                      Deviation::store_application_group_ignored,
                      Deviation::device_type_wrong,
                      Deviation::error_register_not_set,
                      Deviation::od_sub_ff_wrong,
                      Deviation::od_write_back_refused,
                      Deviation::od_object_not_in_eds,
                      Deviation::identity_product_code_wrong,
                      Deviation::sdo_server_cob_ids_without_node_id,
                      Deviation::sdo_segmented_length_too_low_as_too_high,
                      Deviation::pdo_mapping_72_bits_accepted,
                      Deviation::pdo_cob_id_frame_bit_change_accepted,
                      Deviation::heartbeat_consumer_duplicate_lower_sub_accepted}) {
    if (has(d)) return true;
  }
  return false;
}

SdoBefore SdoDeviations::before(const SdoRequestView& r, const cia301::ObjectDictionary& od) const {
  SdoBefore out;
  // A mapping count (sub 00h of 1600h-17FFh / 1A00h-1BFFh) whose entries make exactly 64 bits:
  // refused as too long (the off-by-one of pdo-mapping-64-bits-refused).
  if (has(Deviation::pdo_mapping_64_bits_refused) && r.kind == Kind::download && r.expedited &&
      r.sub == 0 && is_mapping(r.index) && !r.data.empty() &&
      mapping_bits(od, r.index, r.data[0]) == 64) {
    out.answer = SdoAnswerView::abort_of(r.index, r.sub, kAbortPdoLength);
    return out;
  }
  // The COB-ID of a valid PDO (1400h-15FFh / 1800h-19FFh sub 01h) written with only bit 29
  // (frame) changed, still valid: confirmed, nothing written (only bits 0..10 compared).
  if (has(Deviation::pdo_cob_id_frame_bit_change_accepted) && r.kind == Kind::download &&
      r.expedited && r.sub == 1 && r.data.size() == 4 &&
      ((r.index >= 0x1400 && r.index <= 0x15FF) || (r.index >= 0x1800 && r.index <= 0x19FF))) {
    if (const cia301::Entry* entry = od.find(r.index, 1)) {
      const auto held = static_cast<std::uint32_t>(entry->as_unsigned());
      const auto next = static_cast<std::uint32_t>(r.data[0] | r.data[1] << 8 | r.data[2] << 16 |
                                                   static_cast<std::uint32_t>(r.data[3]) << 24);
      if ((held & 0x80000000U) == 0 && (next & 0x80000000U) == 0 && (held ^ next) == 0x20000000U) {
        out.answer = SdoAnswerView::confirmed(r.index, r.sub);
        return out;
      }
    }
  }
  // Sub-index FFh of an ARRAY/RECORD: answered 00000007h (object code VAR, no data type).
  if (has(Deviation::od_sub_ff_wrong) && r.kind == Kind::upload && r.sub == 0xFF) {
    const cia301::Object* object = od.find(r.index);
    if (object != nullptr && (object->code() == cia301::ObjectCode::array ||
                              object->code() == cia301::ObjectCode::record)) {
      out.answer = SdoAnswerView::upload(r.index, r.sub, {0x07, 0x00, 0x00, 0x00});
      return out;
    }
  }
  // 1027h sub 0 (an object the EDS lacks): answered 00h (one octet).
  if (has(Deviation::od_object_not_in_eds) && r.kind == Kind::upload && r.index == 0x1027 &&
      r.sub == 0) {
    out.answer = SdoAnswerView::upload(r.index, r.sub, {0x00});
    return out;
  }
  // 6082h sub 0 := the value it holds: refused 08000020h.
  if (has(Deviation::od_write_back_refused) && expedited_download(r, 0x6082) && r.sub == 0) {
    if (const cia301::Entry* entry = od.find(0x6082, 0)) {
      const auto held = entry->bytes();
      if (r.data.size() >= held.size() && std::equal(held.begin(), held.end(), r.data.begin())) {
        out.answer = SdoAnswerView::abort_of(r.index, r.sub, kAbortCannotStore);
        return out;
      }
    }
  }
  // An RPDO mapping entry naming a communication object (1000h-1FFFh): confirmed, not mapped.
  if (has(Deviation::rpdo_mapping_not_mappable_accepted) && r.kind == Kind::download &&
      r.expedited && r.index >= 0x1600 && r.index <= 0x17FF && r.sub >= 1 && r.sub <= 0x40 &&
      r.data.size() >= 4) {
    const auto mapped = static_cast<std::uint16_t>(r.data[2] | (r.data[3] << 8));
    if (mapped >= 0x1000 && mapped <= 0x1FFF) {
      out.answer = SdoAnswerView::confirmed(r.index, r.sub);
      return out;
    }
  }
  // A TPDO mapping entry naming a write-only entry: confirmed, not mapped.
  if (has(Deviation::tpdo_mapping_write_only_accepted) && r.kind == Kind::download && r.expedited &&
      r.index >= 0x1A00 && r.index <= 0x1BFF && r.sub >= 1 && r.sub <= 0x40 && r.data.size() >= 4) {
    const auto mapped = static_cast<std::uint16_t>(r.data[2] | (r.data[3] << 8));
    const cia301::Entry* target = od.find(mapped, r.data[1]);
    if (target != nullptr && !cia301::is_readable(target->access())) {
      out.answer = SdoAnswerView::confirmed(r.index, r.sub);
      return out;
    }
  }
  // 1003h sub 00h := 0 (the only value CiA 301 allows): confirmed, history kept.
  if (has(Deviation::emcy_history_not_cleared) && expedited_download(r, 0x1003) && r.sub == 0 &&
      !r.data.empty() && r.data[0] == 0) {
    out.answer = SdoAnswerView::confirmed(r.index, r.sub);
    return out;
  }
  // 1011h "load": confirmed, nothing restored.
  if (has(Deviation::restore_ignored) && expedited_download(r, 0x1011) &&
      std::equal(r.data.begin(), r.data.end(), kLoad.begin(), kLoad.end())) {
    out.answer = SdoAnswerView::confirmed(r.index, r.sub);
    return out;
  }
  // 1010h with any value: as if "save" had been written.
  if (has(Deviation::store_signature_ignored) && expedited_download(r, 0x1010)) {
    out.replaced.emplace(kSave.begin(), kSave.end());
  }
  // 1010h sub 03h "save" confirmed, nothing stored (store-application-group-ignored).
  if (has(Deviation::store_application_group_ignored) && r.sub == 3 &&
      expedited_download(r, 0x1010) &&
      std::equal(r.data.begin(), r.data.end(), kSave.begin(), kSave.end())) {
    out.answer = SdoAnswerView::confirmed(r.index, r.sub);
    return out;
  }
  // 1010h/1011h sub 02h and above with any value: as if "save"/"load" had been written (only
  // sub 01h checks its signature).
  if (has(Deviation::store_group_signature_ignored) && r.sub >= 2 &&
      (expedited_download(r, 0x1010) || expedited_download(r, 0x1011))) {
    const auto& signature = r.index == 0x1010 ? kSave : kLoad;
    out.replaced.emplace(signature.begin(), signature.end());
  }
  return out;
}

std::optional<SdoAnswerView> SdoDeviations::after(const SdoRequestView& r, SdoAnswerView a,
                                                  const cia301::ObjectDictionary& od) const {
  using AnswerKind = SdoAnswerView::Kind;
  switch (a.kind) {
    case AnswerKind::abort: {
      const std::uint32_t code = a.code;
      if (code == kAbortInvalidCommand && r.kind == Kind::invalid &&
          has(Deviation::sdo_invalid_command_ignored)) {
        return std::nullopt;
      }
      if (code == kAbortParameterIncompatible && a.index == 0x1016 &&
          has(Deviation::heartbeat_consumer_duplicate_accepted)) {
        return SdoAnswerView::confirmed(a.index, a.sub);
      }
      // The duplicate is at a higher sub-index than the one written: confirmed (the check
      // compares with the lower sub-indices only).
      if (code == kAbortParameterIncompatible && a.index == 0x1016 && r.data.size() == 4 &&
          has(Deviation::heartbeat_consumer_duplicate_lower_sub_accepted) &&
          duplicate_above(od, a.sub, r.data[2])) {
        return SdoAnswerView::confirmed(a.index, a.sub);
      }
      // 65 to 72 bits enabled: confirmed (the mapping stays off).
      if (code == kAbortPdoLength && has(Deviation::pdo_mapping_72_bits_accepted) &&
          r.kind == Kind::download && r.expedited && r.sub == 0 && is_mapping(r.index) &&
          !r.data.empty() && mapping_bits(od, r.index, r.data[0]) <= 72) {
        return SdoAnswerView::confirmed(a.index, a.sub);
      }
      // Too little data in a segmented download: reported as too much.
      if (code == kAbortLengthLow && !(r.kind == Kind::download && r.expedited) &&
          has(Deviation::sdo_segmented_length_too_low_as_too_high)) {
        a.code = kAbortLengthHigh;
      }
      const bool length =
          code == kAbortLengthMismatch || code == kAbortLengthHigh || code == kAbortLengthLow;
      if ((code == kAbortWriteReadOnly && has(Deviation::sdo_read_only_write_accepted)) ||
          (length && has(Deviation::sdo_length_not_checked)) ||
          (code == kAbortPdoLength && has(Deviation::pdo_mapping_too_long_accepted))) {
        return SdoAnswerView::confirmed(a.index, a.sub);
      }
      if (code == kAbortWriteReadOnly && has(Deviation::sdo_read_only_wrong_abort)) {
        a.code = kAbortNoObject;
      } else if (code == kAbortNoObject && has(Deviation::sdo_no_object_wrong_abort)) {
        a.code = kAbortNoSubIndex;
      }
      if (has(Deviation::sdo_abort_wrong_multiplexer)) {
        a.index = 0;
        a.sub = 0;
      }
      return a;
    }
    case AnswerKind::download_confirmed:
      if (has(Deviation::sdo_download_response_missing) && r.kind == Kind::download &&
          r.expedited) {
        return std::nullopt;
      }
      return a;
    case AnswerKind::expedited_upload: {
      if (a.index == 0x1000 && a.sub == 0 && has(Deviation::device_type_wrong))
        store_u32(a.data, 0);
      if (a.index == 0x1018 && a.sub == 2 && has(Deviation::identity_product_code_wrong)) {
        store_u32(a.data, 0);
      }
      // 1200h sub 01h/02h without the node-ID bits (6..0): 600h and 580h.
      if (a.index == 0x1200 && (a.sub == 1 || a.sub == 2) && a.data.size() == 4 &&
          has(Deviation::sdo_server_cob_ids_without_node_id)) {
        const auto cob_id =
            static_cast<std::uint32_t>(a.data[0] | a.data[1] << 8 | a.data[2] << 16 |
                                       static_cast<std::uint32_t>(a.data[3]) << 24);
        store_u32(a.data, cob_id & ~0x7FU);
      }
      if (a.index == 0x1001 && a.sub == 0 && has(Deviation::error_register_not_set) &&
          !a.data.empty()) {
        a.data[0] = 0;
      }
      if (a.index == 0x1003 && a.sub != 0 && has(Deviation::emcy_history_appended)) {
        // Oldest first: sub k shows the entry the drive keeps at sub (count + 1 - k).
        const cia301::Entry* count = od.find(0x1003, 0);
        const auto n = count != nullptr ? count->as_unsigned() : 0;
        if (a.sub <= n) {
          const auto mirrored = static_cast<std::uint8_t>(n + 1 - a.sub);
          if (const cia301::Entry* entry = od.find(0x1003, mirrored)) {
            store_u32(a.data, static_cast<std::uint32_t>(entry->as_unsigned()));
          }
        }
      }
      // 4 data octets indicated (n = 0) whatever the object's size.
      if (has(Deviation::sdo_upload_size_wrong)) a.data.resize(4, 0);
      return a;
    }
    case AnswerKind::upload_segment:
      if (r.kind == Kind::upload_segment && has(Deviation::sdo_toggle_not_alternated)) {
        a.toggle = false;
      }
      return a;
    case AnswerKind::other:
      return a;
  }
  return a;
}

}  // namespace drivecheck::reference_drive
