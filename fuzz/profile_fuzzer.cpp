// Fuzz target: drive profiles (vectors/FORMAT.md "A drive profile";
// protocol/profile/drive_profile.hpp).
//
// Input: the text of a profile, parsed as in-memory text (no base directory: a list named by
// a file is an error; the name is not checked against a file name). Oracles:
//   - parse_profile never throws; an error names the file and a line of the input (or 0), with
//     a message;
//   - a profile that parses is written by to_yaml to text that parses to an equal profile
//     (DriveProfile::operator==: every field but the path), and writing that again gives the
//     same text;
//   - the profile's derived views run on it: effective_personality(), timing_value() of every
//     timing name, deviation_for() of its own deviation globs.
#include <fmt/format.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "fuzz/support/text_lines.hpp"
#include "protocol/profile/drive_profile.hpp"

namespace {

using namespace drivecheck;

std::string head(const std::string& text) {
  return text.size() <= 2000 ? text : text.substr(0, 2000) + "\n...";
}

profile::ParseOptions options(const char* file) {
  profile::ParseOptions parse;
  parse.file_name = file;
  parse.check_name = false;
  return parse;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = fuzz::as_text({data, size});
  const auto first = profile::parse_profile(text, options("fuzz.yaml"));
  if (!first) {
    const TextError& error = first.error();
    DRIVECHECK_FUZZ_CHECK_DETAIL(error.file == "fuzz.yaml", "the error names another file",
                                 error.to_string());
    DRIVECHECK_FUZZ_CHECK_DETAIL(error.line >= 0 && error.line <= fuzz::max_line_count(text),
                                 "the error names a line past the end of the input",
                                 error.to_string());
    DRIVECHECK_FUZZ_CHECK_DETAIL(!error.message.empty(), "an error without a message",
                                 error.to_string());
    return 0;
  }

  const std::string written = profile::to_yaml(*first);
  const auto second = profile::parse_profile(written, options("written.yaml"));
  DRIVECHECK_FUZZ_CHECK_DETAIL(
      second.has_value(), "the written profile does not parse",
      (second ? std::string() : second.error().to_string()) + "\n  written:\n" + head(written));
  DRIVECHECK_FUZZ_CHECK_DETAIL(
      *second == *first, "the profile changed in a write/read round trip",
      "written:\n" + head(written) + "\n  written again:\n" + head(profile::to_yaml(*second)));
  DRIVECHECK_FUZZ_CHECK_EQ(profile::to_yaml(*second), written,
                           "the written profile is not canonical");

  static_cast<void>(first->effective_personality());
  for (const profile::TimingName& timing : profile::timing_table()) {
    DRIVECHECK_FUZZ_CHECK_DETAIL(first->timing_value(timing.name).has_value(),
                                 "a timing name of the table has no value",
                                 std::string(timing.name));
  }
  for (const profile::Deviation& deviation : first->deviations) {
    for (const profile::DeviationVector& vector : deviation.vectors) {
      const auto found = first->deviations_for(vector.id);
      DRIVECHECK_FUZZ_CHECK_DETAIL(std::find(found.begin(), found.end(), &deviation) != found.end(),
                                   "a deviation is not found by a vector id it lists", vector.id);
    }
  }
  return 0;
}
