// Object dictionary entries of the CiA 402 drive profile (IEC 61800-7-201) as typed constants,
// and their names for transcripts and reports. Both come from object_ids.inc, the one table:
//
//   cia402::kControlword == ObjectId{0x6040, 0x00}
//   cia402::find_object(0x6061, 0)->name == "modes of operation display"
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace drivecheck::cia402 {

struct ObjectId {
  std::uint16_t index = 0;
  std::uint8_t sub_index = 0;
  friend constexpr bool operator==(const ObjectId&, const ObjectId&) = default;
};

// How a value of the entry is encoded (CiA 301 basic data types, little-endian on the bus).
enum class ValueType : std::uint8_t { int8, uint8, int16, uint16, int32, uint32 };

// kControlword, kStatusword, kModesOfOperation, ... one per row of object_ids.inc.
#define DRIVECHECK_CIA402_OBJECT(name, index, sub, type, text) \
  inline constexpr ObjectId k##name{index, sub};
#include "protocol/cia402/object_ids.inc"
#undef DRIVECHECK_CIA402_OBJECT

struct ObjectInfo {
  ObjectId id;
  ValueType type;
  std::string_view name;  // CiA 402's name, e.g. "modes of operation display"
};

// Every row of object_ids.inc, ascending by index, then sub-index.
std::span<const ObjectInfo> object_table();
// The entry for an index and sub-index; nullopt when the table does not list it.
std::optional<ObjectInfo> find_object(std::uint16_t index, std::uint8_t sub_index);
// Size in bytes of a value type (1, 2 or 4).
constexpr unsigned size_of(ValueType type) {
  switch (type) {
    case ValueType::int8:
    case ValueType::uint8:
      return 1;
    case ValueType::int16:
    case ValueType::uint16:
      return 2;
    case ValueType::int32:
    case ValueType::uint32:
      return 4;
  }
  return 0;
}
constexpr bool is_signed(ValueType type) {
  return type == ValueType::int8 || type == ValueType::int16 || type == ValueType::int32;
}

}  // namespace drivecheck::cia402
