// Whether a CiA 402 drive must have an object (6000h-67FFh): the rows of object_requirements.inc,
// in the type of protocol/cia301/object_requirements.hpp.
#pragma once

#include <cstdint>
#include <optional>
#include <span>

#include "protocol/cia301/object_requirements.hpp"

namespace drivecheck::cia402 {

// The rows of object_requirements.inc, ascending by index.
std::span<const cia301::ObjectRequirement> object_requirements();
// The CiA 402 row for index/sub; nullopt when the table has none.
std::optional<cia301::ObjectRequirement> find_object_requirement(std::uint16_t index,
                                                                 std::uint8_t sub);

}  // namespace drivecheck::cia402
