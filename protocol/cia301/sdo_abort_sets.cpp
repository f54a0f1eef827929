#include "protocol/cia301/sdo_abort_sets.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <initializer_list>
#include <iterator>

namespace drivecheck::cia301 {
namespace {

constexpr SdoAbortSet make_set(std::string_view name, std::string_view citation,
                               std::string_view situation,
                               std::initializer_list<std::uint32_t> codes) {
  SdoAbortSet set{name, citation, situation, {}, 0};
  for (const auto code : codes) {
    if (set.count < kMaxAbortSetCodes) set.storage[set.count] = code;
    ++set.count;
  }
  return set;
}

constexpr SdoAbortSet kSets[] = {
#define DRIVECHECK_SDO_ABORT_SET(name, citation, situation, ...) \
  make_set(name, citation, situation, {__VA_ARGS__}),
#include "protocol/cia301/sdo_abort_sets.inc"
#undef DRIVECHECK_SDO_ABORT_SET
};

// The codes of sdo_abort_codes.inc, for the checks below.
constexpr std::uint32_t kKnownCodes[] = {
#define DRIVECHECK_SDO_ABORT(name, value, text, source) value,
#include "protocol/cia301/sdo_abort_codes.inc"
#undef DRIVECHECK_SDO_ABORT
};

constexpr bool known(std::uint32_t code) {
  return std::find(std::begin(kKnownCodes), std::end(kKnownCodes), code) != std::end(kKnownCodes);
}

constexpr bool kebab(std::string_view name) {
  if (name.empty() || name.front() == '-' || name.back() == '-') return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-';
  });
}

constexpr bool sets_are_well_formed() {
  for (std::size_t i = 0; i < std::size(kSets); ++i) {
    const auto& set = kSets[i];
    if (!kebab(set.name) || set.citation.empty() || set.situation.empty()) return false;
    if (set.count > kMaxAbortSetCodes) return false;
    for (std::size_t c = 0; c < set.count; ++c) {
      if (!known(set.storage[c])) return false;  // every code is a row of sdo_abort_codes.inc
      if (c > 0 && set.storage[c - 1] >= set.storage[c]) return false;  // ascending, once each
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (kSets[j].name == set.name) return false;
    }
  }
  return true;
}
static_assert(sets_are_well_formed(),
              "sdo_abort_sets.inc: names kebab-case and unique, citation and situation given, at "
              "most kMaxAbortSetCodes codes in ascending order, each one in sdo_abort_codes.inc");

}  // namespace

bool SdoAbortSet::accepts(std::uint32_t code) const {
  if (any()) return true;
  const auto list = codes();
  return std::find(list.begin(), list.end(), code) != list.end();
}

std::span<const SdoAbortSet> sdo_abort_sets() {
  return kSets;
}

std::optional<SdoAbortSet> find_sdo_abort_set(std::string_view name) {
  for (const auto& set : kSets) {
    if (set.name == name) return set;
  }
  return std::nullopt;
}

std::string describe(const SdoAbortSet& set) {
  if (set.any()) return fmt::format("{} {{any abort code}} ({})", set.name, set.citation);
  return fmt::format("{} {{{:08X}h}} ({})", set.name, fmt::join(set.codes(), "h, "), set.citation);
}

std::string sdo_abort_set_names() {
  std::string names;
  for (const auto& set : kSets) {
    if (!names.empty()) names += ", ";
    names += set.name;
  }
  return names;
}

}  // namespace drivecheck::cia301
