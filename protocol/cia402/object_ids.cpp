#include "protocol/cia402/object_ids.hpp"

#include <algorithm>
#include <iterator>

namespace drivecheck::cia402 {
namespace {

constexpr ObjectInfo kObjects[] = {
#define DRIVECHECK_CIA402_OBJECT(name, index, sub, type, text) \
  {ObjectId{index, sub}, ValueType::type, text},
#include "protocol/cia402/object_ids.inc"
#undef DRIVECHECK_CIA402_OBJECT
};

constexpr bool ascending() {
  for (std::size_t i = 1; i < std::size(kObjects); ++i) {
    const auto& a = kObjects[i - 1].id;
    const auto& b = kObjects[i].id;
    if (a.index > b.index || (a.index == b.index && a.sub_index >= b.sub_index)) return false;
  }
  return true;
}
static_assert(ascending(), "object_ids.inc: rows ascend by index, then sub-index, once each");

}  // namespace

std::span<const ObjectInfo> object_table() {
  return kObjects;
}

std::optional<ObjectInfo> find_object(std::uint16_t index, std::uint8_t sub_index) {
  const auto* it =
      std::lower_bound(std::begin(kObjects), std::end(kObjects), ObjectId{index, sub_index},
                       [](const ObjectInfo& row, const ObjectId& id) {
                         return row.id.index < id.index ||
                                (row.id.index == id.index && row.id.sub_index < id.sub_index);
                       });
  if (it == std::end(kObjects) || !(it->id == ObjectId{index, sub_index})) return std::nullopt;
  return *it;
}

}  // namespace drivecheck::cia402
