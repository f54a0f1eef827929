// SDO abort codes (CiA 301 §7.2.4.3.17) as an enum, a std::error_category and a table.
// All three come from sdo_abort_codes.inc, the one place a code is written down.
//
// Tests compare error codes, not strings:
//   EXPECT_EQ(result.error(), cia301::SdoAbort::write_read_only);
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <system_error>

namespace drivecheck::cia301 {

enum class SdoAbort : std::uint32_t {
#define DRIVECHECK_SDO_ABORT(name, value, text, source) name = value,
#include "protocol/cia301/sdo_abort_codes.inc"
#undef DRIVECHECK_SDO_ABORT
};

struct SdoAbortInfo {
  SdoAbort code;
  std::string_view name;    // the enumerator's name, e.g. "write_read_only"
  std::string_view text;    // CiA 301's sentence
  std::string_view source;  // where the code is defined
};

// Every known abort code, in ascending order of value.
std::span<const SdoAbortInfo> sdo_abort_table();

// The table row of a known code; nullopt for a value no table lists (a device may still send
// it: it is then reported as "unknown abort code XXXXXXXXh").
std::optional<SdoAbortInfo> find_sdo_abort(std::uint32_t value);

// "06010002h write_read_only: Attempt to write a read only object", or "…h (unknown abort code)".
std::string describe_sdo_abort(std::uint32_t value);

// The libFuzzer dictionary of abort codes: for every row of the table, a comment line naming
// the code, its text and source, then the token: the 4 bytes of the code as an SDO abort frame
// carries them (bytes 4..7, little-endian):
//
//   # 06010002h write_read_only: Attempt to write a read only object (CiA 301 §7.2.4.3.17)
//   sdo_abort_06010002="\x02\x00\x01\x06"
//
// The text ends with a newline; a fuzz target's .dict generator writes it as is.
std::string sdo_abort_fuzz_dictionary();

const std::error_category& sdo_abort_category();
std::error_code make_error_code(SdoAbort abort);

}  // namespace drivecheck::cia301

template <>
struct std::is_error_code_enum<drivecheck::cia301::SdoAbort> : std::true_type {};
