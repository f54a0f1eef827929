#include "protocol/cia301/pdo.hpp"

#include <fmt/format.h>

#include <cassert>

namespace drivecheck::cia301 {

std::uint16_t pdo_communication_index(PdoDirection direction, std::uint16_t number) {
  assert(number >= 1 && number <= kMaxPdoNumber);
  const std::uint16_t base =
      direction == PdoDirection::receive ? kRpdoCommunicationBase : kTpdoCommunicationBase;
  return static_cast<std::uint16_t>(base + number - 1);
}

std::uint16_t pdo_mapping_index(PdoDirection direction, std::uint16_t number) {
  assert(number >= 1 && number <= kMaxPdoNumber);
  const std::uint16_t base =
      direction == PdoDirection::receive ? kRpdoMappingBase : kTpdoMappingBase;
  return static_cast<std::uint16_t>(base + number - 1);
}

std::uint32_t PdoCobId::encode() const {
  return (valid ? 0u : 0x80000000u) | (rtr_allowed ? 0u : 0x40000000u) |
         (extended ? 0x20000000u : 0u) |
         (can_id & (extended ? can::kMaxExtendedId : can::kMaxStandardId));
}

Expected<PdoCobId, DecodeError> decode_pdo_cob_id(std::uint32_t value) {
  PdoCobId cob;
  cob.valid = (value & 0x80000000u) == 0;
  cob.rtr_allowed = (value & 0x40000000u) == 0;
  cob.extended = (value & 0x20000000u) != 0;
  cob.can_id = value & can::kMaxExtendedId;
  if (!cob.extended && cob.can_id > can::kMaxStandardId) {
    return Unexpected(DecodeError{fmt::format(
        "PDO COB-ID {:08X}h: invalid (bits 28..11 must be 0 for an 11-bit CAN-ID)", value)});
  }
  return cob;
}

TransmissionKind transmission_kind(std::uint8_t type) {
  if (type == 0) return TransmissionKind::synchronous_acyclic;
  if (type <= 240) return TransmissionKind::synchronous_cyclic;
  if (type <= 251) return TransmissionKind::reserved;
  switch (type) {
    case 252:
      return TransmissionKind::rtr_synchronous;
    case 253:
      return TransmissionKind::rtr_event;
    case 254:
      return TransmissionKind::event_manufacturer;
    default:
      return TransmissionKind::event_profile;
  }
}

std::string_view to_string(TransmissionKind kind) {
  switch (kind) {
    case TransmissionKind::synchronous_acyclic:
      return "synchronous acyclic";
    case TransmissionKind::synchronous_cyclic:
      return "synchronous cyclic";
    case TransmissionKind::reserved:
      return "reserved";
    case TransmissionKind::rtr_synchronous:
      return "RTR-only synchronous";
    case TransmissionKind::rtr_event:
      return "RTR-only event-driven";
    case TransmissionKind::event_manufacturer:
      return "event-driven (manufacturer-specific)";
    case TransmissionKind::event_profile:
      return "event-driven (device profile)";
  }
  return "?";
}

bool is_valid_transmission_type(std::uint8_t type, PdoDirection direction) {
  switch (transmission_kind(type)) {
    case TransmissionKind::synchronous_acyclic:
    case TransmissionKind::synchronous_cyclic:
    case TransmissionKind::event_manufacturer:
    case TransmissionKind::event_profile:
      return true;
    case TransmissionKind::rtr_synchronous:
    case TransmissionKind::rtr_event:
      return direction == PdoDirection::transmit;
    case TransmissionKind::reserved:
      return false;
  }
  return false;
}

std::string describe_transmission_type(std::uint8_t type) {
  const TransmissionKind kind = transmission_kind(type);
  if (kind == TransmissionKind::synchronous_cyclic) {
    if (type == 1) return "synchronous cyclic (every SYNC)";
    return fmt::format("synchronous cyclic (every {}th SYNC)", type);
  }
  if (kind == TransmissionKind::reserved) return fmt::format("reserved ({})", type);
  return std::string(to_string(kind));
}

std::optional<unsigned> dummy_bits(std::uint16_t index) {
  switch (index) {
    case 0x0002:
      return 8;  // INTEGER8
    case 0x0003:
      return 16;  // INTEGER16
    case 0x0004:
      return 32;  // INTEGER32
    case 0x0005:
      return 8;  // UNSIGNED8
    case 0x0006:
      return 16;  // UNSIGNED16
    case 0x0007:
      return 32;  // UNSIGNED32
    default:
      return std::nullopt;
  }
}

std::uint32_t PdoMappingEntry::encode() const {
  return (static_cast<std::uint32_t>(index) << 16) | (static_cast<std::uint32_t>(sub_index) << 8) |
         bits;
}

bool PdoMappingEntry::is_dummy() const {
  return dummy_bits(index).has_value() && sub_index == 0;
}

Expected<PdoMappingEntry, DecodeError> decode_pdo_mapping_entry(std::uint32_t value) {
  PdoMappingEntry entry{static_cast<std::uint16_t>(value >> 16),
                        static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value)};
  if (entry.bits == 0 || entry.bits > kMaxPdoBits) {
    return Unexpected(DecodeError{fmt::format(
        "PDO mapping entry {:08X}h: invalid length {} bits (1..64)", value, entry.bits)});
  }
  if (entry.index < 0x1000) {
    const auto dummy = dummy_bits(entry.index);
    if (!dummy) {
      return Unexpected(DecodeError{fmt::format(
          "PDO mapping entry {:08X}h: index {:04X}h is neither an object nor a dummy data type "
          "(0002h..0007h)",
          value, entry.index)});
    }
    if (entry.sub_index != 0 || entry.bits != *dummy) {
      return Unexpected(DecodeError{
          fmt::format("PDO mapping entry {:08X}h: dummy {:04X}h must be sub-index 00h and {} bits",
                      value, entry.index, *dummy)});
    }
  }
  return entry;
}

unsigned PdoMapping::total_bits() const {
  unsigned total = 0;
  for (const PdoMappingEntry& entry : entries)
    total += entry.bits;
  return total;
}

Expected<void, DecodeError> PdoMapping::validate() const {
  if (entries.size() > kMaxMappedObjects) {
    return Unexpected(DecodeError{
        fmt::format("PDO mapping with {} entries: invalid (at most 64)", entries.size())});
  }
  const unsigned total = total_bits();
  if (total > kMaxPdoBits) {
    return Unexpected(DecodeError{
        fmt::format("PDO mapping of {} bits: invalid (a PDO carries at most 64 bits)", total)});
  }
  for (const PdoMappingEntry& entry : entries) {
    if (entry.bits == 0) {
      return Unexpected(DecodeError{
          fmt::format("PDO mapping entry {:08X}h: invalid length 0 bits", entry.encode())});
    }
  }
  return {};
}

std::int64_t MappedValue::as_signed() const {
  if (entry.bits == 0 || entry.bits >= 64) return static_cast<std::int64_t>(raw);
  const std::uint64_t sign = std::uint64_t{1} << (entry.bits - 1);
  const std::uint64_t mask = (std::uint64_t{1} << entry.bits) - 1;
  const std::uint64_t value = raw & mask;
  if ((value & sign) == 0) return static_cast<std::int64_t>(value);
  return static_cast<std::int64_t>(value | ~mask);
}

Expected<std::vector<MappedValue>, DecodeError> unpack_pdo(const PdoMapping& mapping,
                                                           std::span<const std::uint8_t> payload) {
  if (auto valid = mapping.validate(); !valid) return Unexpected(valid.error());
  const unsigned total = mapping.total_bits();
  const std::size_t needed = (total + 7) / 8;
  if (payload.size() < needed) {
    return Unexpected(DecodeError{fmt::format(
        "PDO with {} bytes: too short for its mapping of {} bits ({} bytes; CiA 301 EMCY 8210h)",
        payload.size(), total, needed)});
  }
  std::uint64_t all = 0;
  for (std::size_t i = 0; i < payload.size() && i < 8; ++i) {
    all |= static_cast<std::uint64_t>(payload[i]) << (8 * i);
  }
  std::vector<MappedValue> values;
  values.reserve(mapping.entries.size());
  unsigned offset = 0;
  for (const PdoMappingEntry& entry : mapping.entries) {
    const std::uint64_t mask =
        entry.bits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << entry.bits) - 1;
    const std::uint64_t raw = offset >= 64 ? 0 : (all >> offset) & mask;
    values.push_back(MappedValue{entry, offset, raw});
    offset += entry.bits;
  }
  return values;
}

std::vector<std::uint8_t> pack_pdo(const PdoMapping& mapping,
                                   std::span<const std::uint64_t> values) {
  assert(mapping.validate());
  assert(values.size() == mapping.entries.size());
  std::uint64_t all = 0;
  unsigned offset = 0;
  for (std::size_t i = 0; i < mapping.entries.size(); ++i) {
    const unsigned bits = mapping.entries[i].bits;
    const std::uint64_t mask = bits >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << bits) - 1;
    if (offset < 64) all |= (values[i] & mask) << offset;
    offset += bits;
  }
  std::vector<std::uint8_t> payload((offset + 7) / 8);
  for (std::size_t i = 0; i < payload.size(); ++i) {
    payload[i] = static_cast<std::uint8_t>(all >> (8 * i));
  }
  return payload;
}

}  // namespace drivecheck::cia301
