// Fuzz target: vector files (vectors/FORMAT.md; conformance/vector_file.hpp).
//
// Input: the text of a vector file. Oracles:
//   - every error names the file and a line of the input (or 0), with a message;
//   - nothing is dropped silently: a text that loads without errors gives one vector per item
//     of the YAML sequence and one step per item of each vector's `steps` (a `repeat:` item its
//     steps `times` over);
//   - the vectors that loaded (with or without errors elsewhere in the file) are written by
//     to_yaml to text that loads without errors to vectors of the same content (same_content:
//     all but file and line), and writing those again gives the same text.
#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "conformance/vector_file.hpp"
#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "fuzz/support/text_lines.hpp"

namespace {

using namespace drivecheck;

std::string errors_text(const conformance::VectorSet& set) {
  std::string text;
  for (std::size_t i = 0; i < set.errors.size() && i < 10; ++i)
    text += "\n    " + set.errors[i].to_string();
  return text;
}

std::string head(const std::string& text) {
  return text.size() <= 2000 ? text : text.substr(0, 2000) + "\n...";
}

// The steps a list of step items makes, a `repeat: {times, steps}` item its steps `times` over
// (FORMAT.md "Repeated steps"); nullopt when a repeat is not of that shape.
std::optional<std::size_t> unrolled_count(const YAML::Node& list) {
  std::size_t count = 0;
  for (const auto& item : list) {
    if (!item.IsMap() || !item["repeat"]) {
      ++count;
      continue;
    }
    const YAML::Node repeat = item["repeat"];
    if (!repeat.IsMap() || !repeat["times"] || !repeat["steps"] || !repeat["steps"].IsSequence())
      return std::nullopt;
    const auto inner = unrolled_count(repeat["steps"]);
    if (!inner) return std::nullopt;
    try {
      count += repeat["times"].as<std::size_t>() * *inner;
    } catch (const YAML::Exception&) {
      return std::nullopt;
    }
  }
  return count;
}

// The item counts of the YAML itself: vectors, and steps of each (repeats unrolled); nullopt
// when the text is not a sequence of maps with a `steps` sequence (the loader reports an error
// then anyway).
std::optional<std::vector<std::size_t>> step_counts(std::string_view text) {
  try {
    const YAML::Node root = YAML::Load(std::string(text));
    if (root.IsNull()) return std::vector<std::size_t>{};
    if (!root.IsSequence()) return std::nullopt;
    std::vector<std::size_t> counts;
    for (const auto& vector : root) {
      if (!vector.IsMap() || !vector["steps"] || !vector["steps"].IsSequence()) return std::nullopt;
      const auto count = unrolled_count(vector["steps"]);
      if (!count) return std::nullopt;
      counts.push_back(*count);
    }
    return counts;
  } catch (const YAML::Exception&) {
    return std::nullopt;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = fuzz::as_text({data, size});
  const conformance::VectorSet first = conformance::parse_vectors(text, "fuzz.yaml");

  const int line_count = fuzz::max_line_count(text);
  for (const TextError& error : first.errors) {
    DRIVECHECK_FUZZ_CHECK_DETAIL(error.file == "fuzz.yaml", "an error names another file",
                                 error.to_string());
    DRIVECHECK_FUZZ_CHECK_DETAIL(error.line >= 0 && error.line <= line_count,
                                 "an error names a line past the end of the input",
                                 error.to_string());
    DRIVECHECK_FUZZ_CHECK_DETAIL(!error.message.empty(), "an error without a message",
                                 error.to_string());
  }

  if (first.ok()) {
    if (const auto counts = step_counts(text)) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(
          counts->size() == first.vectors.size(), "a vector was dropped without an error",
          fmt::format("{} items, {} vectors", counts->size(), first.vectors.size()));
      for (std::size_t i = 0; i < counts->size(); ++i) {
        DRIVECHECK_FUZZ_CHECK_DETAIL(
            (*counts)[i] == first.vectors[i].steps.size(), "a step was dropped without an error",
            fmt::format("vector {}: {} items, {} steps", first.vectors[i].id, (*counts)[i],
                        first.vectors[i].steps.size()));
      }
    }
  }

  const std::string written = conformance::to_yaml(first.vectors);
  const conformance::VectorSet second = conformance::parse_vectors(written, "written.yaml");
  DRIVECHECK_FUZZ_CHECK_DETAIL(second.ok(), "written vectors do not load without errors",
                               errors_text(second) + "\n  written:\n" + head(written));
  DRIVECHECK_FUZZ_CHECK_DETAIL(second.vectors.size() == first.vectors.size(),
                               "the round trip changed the number of vectors",
                               "written:\n" + head(written));
  for (std::size_t i = 0; i < first.vectors.size(); ++i) {
    DRIVECHECK_FUZZ_CHECK_DETAIL(
        conformance::same_content(second.vectors[i], first.vectors[i]),
        "a vector changed in a write/read round trip",
        fmt::format("vector {} ({}); written:\n{}\n  written again:\n{}", i, first.vectors[i].id,
                    head(written), head(conformance::to_yaml(second.vectors))));
  }
  DRIVECHECK_FUZZ_CHECK_EQ(conformance::to_yaml(second.vectors), written,
                           "written vectors are not canonical");
  return 0;
}
