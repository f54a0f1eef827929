#include "protocol/cia402/object_requirements.hpp"

#include <iterator>

namespace drivecheck::cia402 {
namespace {

using cia301::ObjectClass;
using cia301::ObjectRequirement;

constexpr ObjectRequirement kRows[] = {
#define DRIVECHECK_OBJECT_REQUIREMENT(first, last, first_sub, last_sub, kind, condition, name, \
                                      clause)                                                  \
  {first, last, first_sub, last_sub, ObjectClass::kind, condition, name, clause},
#include "protocol/cia402/object_requirements.inc"
#undef DRIVECHECK_OBJECT_REQUIREMENT
};

constexpr bool rows_valid() {
  for (std::size_t i = 0; i < std::size(kRows); ++i) {
    const auto& row = kRows[i];
    if (row.first_index > row.last_index || row.first_sub > row.last_sub) return false;
    if (row.first_index < 0x6000 || row.last_index > 0x67FF) return false;
    if ((row.kind == ObjectClass::conditional) == row.condition.empty()) return false;
    if (i > 0 && row.first_index <= kRows[i - 1].last_index) return false;
  }
  return true;
}
static_assert(rows_valid(),
              "cia402/object_requirements.inc: rows within 6000h-67FFh, ascending, "
              "not overlapping; a conditional row names its feature, the others none");

}  // namespace

std::span<const ObjectRequirement> object_requirements() {
  return kRows;
}

std::optional<ObjectRequirement> find_object_requirement(std::uint16_t index, std::uint8_t sub) {
  for (const auto& row : kRows)
    if (row.contains(index, sub)) return row;
  return std::nullopt;
}

}  // namespace drivecheck::cia402
