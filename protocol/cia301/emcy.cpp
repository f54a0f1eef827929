#include "protocol/cia301/emcy.hpp"

#include <fmt/compile.h>
#include <fmt/format.h>

#include <algorithm>
#include <cassert>
#include <iterator>

#include "protocol/cia301/cob_id.hpp"

namespace drivecheck::cia301 {
namespace {

constexpr EmcyCodeInfo kTable[] = {
#define DRIVECHECK_EMCY_CODE(name, code, mask, text, source) \
  {EmcyCode::name, mask, #name, text, source},
#include "protocol/cia301/emcy_codes.inc"
#undef DRIVECHECK_EMCY_CODE
};

constexpr bool table_is_sound() {
  for (std::size_t i = 0; i < std::size(kTable); ++i) {
    const auto code = static_cast<std::uint16_t>(kTable[i].code);
    // A class row's base has no bits outside its mask; masks are FFFFh, FF00h or F000h.
    if ((code & static_cast<std::uint16_t>(~kTable[i].mask)) != 0) return false;
    if (kTable[i].mask != 0xFFFF && kTable[i].mask != 0xFF00 && kTable[i].mask != 0xF000) {
      return false;
    }
    if (i > 0 && static_cast<std::uint16_t>(kTable[i - 1].code) >= code) return false;
  }
  return true;
}
static_assert(table_is_sound(),
              "emcy_codes.inc: ascending codes, once each, masks FFFFh/FF00h/F000h, class bases "
              "without bits outside the mask");

}  // namespace

std::span<const EmcyCodeInfo> emcy_code_table() {
  return kTable;
}

namespace {

// The row whose code is `code`, by binary search (the table is ascending, codes unique).
const EmcyCodeInfo* row_with_code(std::uint16_t code) {
  const auto* const end = std::end(kTable);
  const auto* const it =
      std::lower_bound(std::begin(kTable), end, code, [](const EmcyCodeInfo& row, std::uint16_t c) {
        return static_cast<std::uint16_t>(row.code) < c;
      });
  return (it != end && static_cast<std::uint16_t>(it->code) == code) ? it : nullptr;
}

// Calls `f` for every row that matches `value`, most general first. A row matches when
// value & mask == code, and masks are F000h, FF00h or FFFFh, so a matching row's code is one
// of value & F000h, value & FF00h, value; codes are unique, so looking up these three (each
// once) finds every matching row. Nested masks make the candidates ascend in mask width.
// (Three binary searches instead of a scan of every row: this runs for every EMCY code
// described, e.g. every EMCY the dissector explains.)
template <typename F>
void for_each_matching_row(std::uint16_t value, F&& f) {
  const std::uint16_t candidates[] = {static_cast<std::uint16_t>(value & 0xF000u),
                                      static_cast<std::uint16_t>(value & 0xFF00u), value};
  for (std::size_t i = 0; i < std::size(candidates); ++i) {
    if (i > 0 && candidates[i] == candidates[i - 1]) continue;
    const EmcyCodeInfo* row = row_with_code(candidates[i]);
    if (row != nullptr && row->matches(value)) f(*row);
  }
}

}  // namespace

std::optional<EmcyCodeInfo> find_emcy_code(std::uint16_t value) {
  std::optional<EmcyCodeInfo> best;
  for_each_matching_row(value, [&](const EmcyCodeInfo& row) { best = row; });
  return best;
}

std::vector<EmcyCodeInfo> emcy_code_hierarchy(std::uint16_t value) {
  std::vector<EmcyCodeInfo> rows;
  for_each_matching_row(value, [&](const EmcyCodeInfo& row) { rows.push_back(row); });
  return rows;
}

std::string describe_emcy_code(std::uint16_t value) {
  const auto row = find_emcy_code(value);
  if (!row) return fmt::format(FMT_COMPILE("{:04X}h (unknown error code)"), value);
  if (row->mask == 0xFFFF) return fmt::format(FMT_COMPILE("{:04X}h {}"), value, row->text);
  const auto base = static_cast<std::uint16_t>(row->code);
  if (row->mask == 0xFF00) {
    if (value == base) return fmt::format(FMT_COMPILE("{:04X}h {}"), value, row->text);
    return fmt::format(FMT_COMPILE("{:04X}h {} (class {:02X}xxh)"), value, row->text, base >> 8);
  }
  return fmt::format(FMT_COMPILE("{:04X}h {} (class {:X}xxxh)"), value, row->text, base >> 12);
}

std::string_view to_string(ErrorRegisterBit bit) {
  switch (bit) {
    case ErrorRegisterBit::generic:
      return "generic";
    case ErrorRegisterBit::current:
      return "current";
    case ErrorRegisterBit::voltage:
      return "voltage";
    case ErrorRegisterBit::temperature:
      return "temperature";
    case ErrorRegisterBit::communication:
      return "communication";
    case ErrorRegisterBit::device_profile:
      return "device-profile";
    case ErrorRegisterBit::reserved:
      return "reserved-bit-6";
    case ErrorRegisterBit::manufacturer:
      return "manufacturer";
  }
  return "?";
}

std::string describe_error_register(std::uint8_t value) {
  if (value == 0) return "none";
  std::string text;
  for (unsigned bit = 0; bit < 8; ++bit) {
    const auto mask = static_cast<std::uint8_t>(1u << bit);
    if ((value & mask) == 0) continue;
    if (!text.empty()) text += '+';
    text += to_string(static_cast<ErrorRegisterBit>(mask));
  }
  return text;
}

std::uint16_t emcy_cob_id(std::uint8_t node) {
  assert(is_valid_node_id(node));
  return static_cast<std::uint16_t>(kEmcyBase + node);
}

can::Frame encode(const Emcy& message, std::uint32_t cob_id, can::IdFormat format) {
  const std::uint8_t bytes[8] = {static_cast<std::uint8_t>(message.error_code),
                                 static_cast<std::uint8_t>(message.error_code >> 8),
                                 message.error_register,
                                 message.manufacturer[0],
                                 message.manufacturer[1],
                                 message.manufacturer[2],
                                 message.manufacturer[3],
                                 message.manufacturer[4]};
  return format == can::IdFormat::extended ? can::Frame::extended(cob_id, bytes)
                                           : can::Frame::standard(cob_id, bytes);
}

Expected<Emcy, DecodeError> decode_emcy(const can::Frame& frame) {
  if (frame.is_error()) return Unexpected(DecodeError{"EMCY: an error frame is not an EMCY"});
  if (frame.is_remote()) {
    return Unexpected(DecodeError{"EMCY as a remote request: invalid (EMCY is a data frame)"});
  }
  if (frame.dlc != 8) {
    return Unexpected(DecodeError{fmt::format(
        FMT_COMPILE("EMCY with DLC {}: invalid (EMCY frames carry 8 bytes)"), frame.dlc)});
  }
  Emcy emcy;
  emcy.error_code = static_cast<std::uint16_t>(frame.data[0] | (frame.data[1] << 8));
  emcy.error_register = frame.data[2];
  for (std::size_t i = 0; i < emcy.manufacturer.size(); ++i)
    emcy.manufacturer[i] = frame.data[3 + i];
  return emcy;
}

std::uint32_t EmcyCobIdEntry::encode() const {
  return (valid ? 0u : 0x80000000u) | (extended ? 0x20000000u : 0u) |
         (can_id & (extended ? can::kMaxExtendedId : can::kMaxStandardId));
}

Expected<EmcyCobIdEntry, DecodeError> decode_emcy_cob_id_entry(std::uint32_t value) {
  EmcyCobIdEntry entry;
  entry.valid = (value & 0x80000000u) == 0;
  entry.extended = (value & 0x20000000u) != 0;
  entry.can_id = value & can::kMaxExtendedId;
  if (!entry.extended && entry.can_id > can::kMaxStandardId) {
    return Unexpected(DecodeError{fmt::format(
        FMT_COMPILE("COB-ID EMCY {:08X}h: invalid (bits 28..11 must be 0 for an 11-bit CAN-ID)"),
        value)});
  }
  return entry;
}

}  // namespace drivecheck::cia301
