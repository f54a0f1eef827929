// Accepted SDO abort-code sets (sdo_abort_sets.inc): named sets of the codes a conformant
// device may answer one situation with, each with the CiA 301 clause or CTT case that gives it.
// Vectors name them (`expect: {abort: write-read-only}`); reports print them with describe().
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace drivecheck::cia301 {

inline constexpr std::size_t kMaxAbortSetCodes = 8;

struct SdoAbortSet {
  std::string_view name;       // "write-read-only"
  std::string_view citation;   // "CTT 2.3, 4.3; CiA 301 §7.2.4.3.17"
  std::string_view situation;  // "download to a read-only or const object"
  std::array<std::uint32_t, kMaxAbortSetCodes> storage{};
  std::size_t count = 0;  // 0: any abort code

  std::span<const std::uint32_t> codes() const { return {storage.data(), count}; }
  bool any() const { return count == 0; }
  // Whether the set accepts `code` (any set accepts every code).
  bool accepts(std::uint32_t code) const;
};

// Every set, in the order of the .inc.
std::span<const SdoAbortSet> sdo_abort_sets();

// The set of that name; nullopt for an unknown name.
std::optional<SdoAbortSet> find_sdo_abort_set(std::string_view name);

// "write-read-only {06010000h, 06010002h, 08000000h} (CTT 2.3, 4.3; CiA 301 §7.2.4.3.17)";
// the any set: "any {any abort code} (CiA 301 ...)".
std::string describe(const SdoAbortSet& set);

// The names of every set, comma-separated (for "unknown set" messages).
std::string sdo_abort_set_names();

}  // namespace drivecheck::cia301
