#include "protocol/cia301/sdo_abort.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <iterator>
#include <string>

namespace drivecheck::cia301 {
namespace {

constexpr SdoAbortInfo kTable[] = {
#define DRIVECHECK_SDO_ABORT(name, value, text, source) {SdoAbort::name, #name, text, source},
#include "protocol/cia301/sdo_abort_codes.inc"
#undef DRIVECHECK_SDO_ABORT
};

constexpr bool is_sorted_by_value() {
  for (std::size_t i = 1; i < std::size(kTable); ++i) {
    if (static_cast<std::uint32_t>(kTable[i - 1].code) >=
        static_cast<std::uint32_t>(kTable[i].code)) {
      return false;
    }
  }
  return true;
}
static_assert(is_sorted_by_value(),
              "sdo_abort_codes.inc must list codes in ascending order, once each");

class SdoAbortCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "sdo-abort"; }
  std::string message(int value) const override {
    return describe_sdo_abort(static_cast<std::uint32_t>(value));
  }
};

}  // namespace

std::span<const SdoAbortInfo> sdo_abort_table() {
  return kTable;
}

std::optional<SdoAbortInfo> find_sdo_abort(std::uint32_t value) {
  const auto* it = std::lower_bound(std::begin(kTable), std::end(kTable), value,
                                    [](const SdoAbortInfo& row, std::uint32_t v) {
                                      return static_cast<std::uint32_t>(row.code) < v;
                                    });
  if (it == std::end(kTable) || static_cast<std::uint32_t>(it->code) != value) return std::nullopt;
  return *it;
}

std::string describe_sdo_abort(std::uint32_t value) {
  if (const auto info = find_sdo_abort(value)) {
    return fmt::format("{:08X}h {}: {}", value, info->name, info->text);
  }
  return fmt::format("{:08X}h (unknown abort code)", value);
}

std::string sdo_abort_fuzz_dictionary() {
  std::string text;
  for (const SdoAbortInfo& row : kTable) {
    const auto value = static_cast<std::uint32_t>(row.code);
    fmt::format_to(std::back_inserter(text), "# {:08X}h {}: {} ({})\n", value, row.name, row.text,
                   row.source);
    fmt::format_to(std::back_inserter(text),
                   "sdo_abort_{:08X}=\"\\x{:02X}\\x{:02X}\\x{:02X}\\x{:02X}\"\n", value,
                   value & 0xFF, (value >> 8) & 0xFF, (value >> 16) & 0xFF, value >> 24);
  }
  return text;
}

const std::error_category& sdo_abort_category() {
  static const SdoAbortCategory category;
  return category;
}

std::error_code make_error_code(SdoAbort abort) {
  return {static_cast<int>(abort), sdo_abort_category()};
}

}  // namespace drivecheck::cia301
