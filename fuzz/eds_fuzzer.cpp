// Fuzz target: EDS/DCF files (CiA 306; protocol/cia306/eds.hpp, eds_lint.hpp).
//
// Input: the text of an EDS or DCF file. Oracles:
//   - reading never fails as a whole, and every diagnostic names a line of the input (or 0);
//   - the linter runs on every model the reader produces, errors or not;
//   - a model read without errors is written (CRLF and LF) to text that reads without errors
//     to an equal model, and writing that model again gives the same text (eds.hpp:
//     "read_eds(write_eds(m)).eds == m for any m read without errors");
//   - the bridge to the object dictionary (to_object_dictionary) runs on it for node 1.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/cia306/eds.hpp"
#include "protocol/cia306/eds_lint.hpp"

namespace {

using namespace drivecheck;

std::string diagnostics_text(const std::vector<cia306::Diagnostic>& diagnostics) {
  std::string text;
  for (std::size_t i = 0; i < diagnostics.size() && i < 10; ++i)
    text += "\n    " + diagnostics[i].to_string();
  return text;
}

std::string head(const std::string& text) {
  return text.size() <= 2000 ? text : text.substr(0, 2000) + "\n...";
}

// Lines of the input as the reader counts them (at most; CRLF counts twice here). Oracle
// bookkeeping over every byte: not instrumented.
DRIVECHECK_FUZZ_ORACLE_CODE std::size_t count_line_ends(std::string_view text) {
  std::size_t count = 1;
  for (const char c : text)
    count += (c == '\n' || c == '\r') ? 1 : 0;
  return count;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = fuzz::as_text({data, size});
  const cia306::ReadResult first = cia306::read_eds(text, "fuzz.eds");

  const std::size_t line_count = count_line_ends(text);
  for (const cia306::Diagnostic& diagnostic : first.diagnostics) {
    DRIVECHECK_FUZZ_CHECK_DETAIL(
        diagnostic.where.line >= 0 && static_cast<std::size_t>(diagnostic.where.line) <= line_count,
        "diagnostic names a line past the end of the input", diagnostic.to_string());
    DRIVECHECK_FUZZ_CHECK_DETAIL(!diagnostic.id.empty(), "diagnostic without an id",
                                 diagnostic.to_string());
  }

  const auto findings = cia306::lint_eds(first.eds, "fuzz.eds");
  static_cast<void>(findings);
  if (first.has_errors()) return 0;

  for (const bool crlf : {true, false}) {
    const std::string written = cia306::write_eds(first.eds, {crlf});
    const cia306::ReadResult second = cia306::read_eds(written, "written.eds");
    DRIVECHECK_FUZZ_CHECK_DETAIL(
        !second.has_errors(), "written EDS does not read without errors",
        diagnostics_text(second.diagnostics) + "\n  written:\n" + head(written));
    DRIVECHECK_FUZZ_CHECK_DETAIL(second.eds == first.eds,
                                 "EDS model changed in a write/read round trip",
                                 "written:\n" + head(written) + "\n  written again:\n" +
                                     head(cia306::write_eds(second.eds, {crlf})));
    DRIVECHECK_FUZZ_CHECK_EQ(cia306::write_eds(second.eds, {crlf}), written,
                             "written EDS is not canonical");
  }
  const auto dictionary = cia306::to_object_dictionary(first.eds, 1, "fuzz.eds");
  static_cast<void>(dictionary);
  return 0;
}
