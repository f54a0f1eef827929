#include "protocol/cia301/object_requirements.hpp"

#include <array>

namespace drivecheck::cia301 {
namespace {

constexpr ObjectRequirement kRows[] = {
#define DRIVECHECK_OBJECT_REQUIREMENT(first, last, first_sub, last_sub, kind, condition, name, \
                                      clause)                                                  \
  {first, last, first_sub, last_sub, ObjectClass::kind, condition, name, clause},
#include "protocol/cia301/object_requirements.inc"
#undef DRIVECHECK_OBJECT_REQUIREMENT
};

constexpr bool rows_valid() {
  for (std::size_t i = 0; i < std::size(kRows); ++i) {
    const auto& row = kRows[i];
    if (row.first_index > row.last_index || row.first_sub > row.last_sub) return false;
    // A conditional row names its feature; the others name none.
    if ((row.kind == ObjectClass::conditional) == row.condition.empty()) return false;
    if (i > 0) {
      const auto& before = kRows[i - 1];
      const bool after_index = row.first_index > before.last_index;
      const bool same_object_after_sub = row.first_index == before.first_index &&
                                         row.last_index == before.last_index &&
                                         row.first_sub > before.last_sub;
      if (!after_index && !same_object_after_sub) return false;
    }
  }
  return true;
}
static_assert(rows_valid(),
              "object_requirements.inc: rows ascend and do not overlap; a "
              "conditional row names its feature, the others none");

}  // namespace

std::string_view to_string(ObjectClass kind) {
  constexpr std::array<std::string_view, 3> kNames{"mandatory", "conditional", "optional"};
  return kNames[static_cast<std::size_t>(kind)];
}

std::span<const ObjectRequirement> object_requirements() {
  return kRows;
}

std::optional<ObjectRequirement> find_object_requirement(std::uint16_t index, std::uint8_t sub) {
  for (const auto& row : kRows)
    if (row.contains(index, sub)) return row;
  return std::nullopt;
}

}  // namespace drivecheck::cia301
