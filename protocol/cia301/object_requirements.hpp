// Whether a device must have an object: the CiA 301 rows (object_requirements.inc) and, through
// the same type, the CiA 402 rows (protocol/cia402/object_requirements.hpp). The tables are data,
// each row cited; this header only reads them.
//
//   cia301::find_object_requirement(0x1017, 0)->condition == "heartbeat.producer"
//   cia301::find_object_requirement(0x1029, 0)->kind == ObjectClass::optional
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace drivecheck::cia301 {

enum class ObjectClass : std::uint8_t { mandatory, conditional, optional };
std::string_view to_string(ObjectClass kind);

struct ObjectRequirement {
  std::uint16_t first_index = 0;
  std::uint16_t last_index = 0;
  std::uint8_t first_sub = 0;
  std::uint8_t last_sub = 255;
  ObjectClass kind = ObjectClass::optional;
  // conditional: the feature(s) of protocol/profile/vocabulary.hpp, '|' between alternatives.
  std::string_view condition;
  std::string_view name;
  std::string_view clause;
  bool whole_object() const { return first_sub == 0 && last_sub == 255; }
  bool contains(std::uint16_t index, std::uint8_t sub) const {
    return index >= first_index && index <= last_index && sub >= first_sub && sub <= last_sub;
  }
};

// The rows of object_requirements.inc, ascending by index, then sub-index.
std::span<const ObjectRequirement> object_requirements();
// The CiA 301 row for index/sub; nullopt when CiA 301 defines no such object.
std::optional<ObjectRequirement> find_object_requirement(std::uint16_t index, std::uint8_t sub);

}  // namespace drivecheck::cia301
