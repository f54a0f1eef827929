// The main() of a fuzz target in the normal build (no fuzzing engine): it runs the target once
// on every input it is given, so that seed corpora and crash regressions replay under CTest on
// every commit (STYLE.md item 12). A crash, sanitizer report or oracle failure of the target
// ends the process as it would under libFuzzer.
//
//   <name>_fuzzer [--optional] PATH...  [-libfuzzer_flag=value...]
//
// PATH is a file (one input) or a directory (each regular file in it is an input, in name
// order, not recursing; README* and dot files are skipped so that a directory can document
// itself). The run FAILS (exit 1) when
//   - no PATH is given, or a PATH does not exist;
//   - a directory holds no input, unless the `--optional` before it allows that (the crash
//     regressions directory: empty until the first crash). An empty seed corpus is always a
//     failure: a fuzz target that silently runs nothing is worse than none.
// Arguments that start with a single '-' are libFuzzer flags (-runs=, -dict=, ...): they are
// ignored, so a reproducer command line written for the libFuzzer build also works here.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
extern "C" __attribute__((weak)) int LLVMFuzzerInitialize(int* argc, char*** argv);

namespace {

namespace fs = std::filesystem;

bool is_input_file(const fs::directory_entry& entry) {
  std::error_code error;
  if (!entry.is_regular_file(error)) return false;
  const std::string name = entry.path().filename().string();
  return !name.starts_with('.') && !name.starts_with("README");
}

bool read_file(const fs::path& path, std::vector<std::uint8_t>& bytes) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) return false;
  bytes.clear();
  std::uint8_t buffer[65536];
  std::size_t got = 0;
  while ((got = std::fread(buffer, 1, sizeof buffer, file)) > 0)
    bytes.insert(bytes.end(), buffer, buffer + got);
  const bool ok = std::ferror(file) == 0;
  std::fclose(file);
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  if (LLVMFuzzerInitialize != nullptr) LLVMFuzzerInitialize(&argc, &argv);

  struct Source {
    fs::path path;
    bool optional = false;
  };
  std::vector<Source> sources;
  bool next_optional = false;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--optional") {
      next_optional = true;
    } else if (arg.starts_with("-")) {
      std::fprintf(stderr, "replay: ignoring libFuzzer flag %s\n", argv[i]);
    } else {
      sources.push_back({fs::path(arg), next_optional});
      next_optional = false;
    }
  }
  if (sources.empty()) {
    std::fprintf(stderr,
                 "replay: no inputs given (usage: %s [--optional] PATH...): an empty corpus is a "
                 "failure\n",
                 argc > 0 ? argv[0] : "fuzzer");
    return 1;
  }

  std::size_t total = 0;
  std::vector<std::uint8_t> bytes;
  for (const Source& source : sources) {
    std::error_code error;
    std::vector<fs::path> inputs;
    if (fs::is_directory(source.path, error)) {
      for (const auto& entry : fs::directory_iterator(source.path, error)) {
        if (is_input_file(entry)) inputs.push_back(entry.path());
      }
      if (error) {
        std::fprintf(stderr, "replay: cannot list %s: %s\n", source.path.c_str(),
                     error.message().c_str());
        return 1;
      }
      std::sort(inputs.begin(), inputs.end());
      if (inputs.empty() && !source.optional) {
        std::fprintf(stderr, "replay: %s holds no inputs: an empty corpus is a failure\n",
                     source.path.c_str());
        return 1;
      }
    } else if (fs::is_regular_file(source.path, error)) {
      inputs.push_back(source.path);
    } else {
      std::fprintf(stderr, "replay: %s does not exist or is no file or directory\n",
                   source.path.c_str());
      return 1;
    }
    for (const fs::path& input : inputs) {
      if (!read_file(input, bytes)) {
        std::fprintf(stderr, "replay: cannot read %s\n", input.c_str());
        return 1;
      }
      std::fprintf(stderr, "Running: %s (%zu bytes)\n", input.c_str(), bytes.size());
      // A copy in a buffer of exactly the input's size, as libFuzzer gives it: ASan then
      // catches a read one past the end.
      const auto exact = std::make_unique<std::uint8_t[]>(bytes.size());
      std::copy(bytes.begin(), bytes.end(), exact.get());
      LLVMFuzzerTestOneInput(exact.get(), bytes.size());
      ++total;
    }
    std::fprintf(stderr, "replay: %s: %zu inputs\n", source.path.c_str(), inputs.size());
  }
  std::fprintf(stderr, "replay: %zu inputs ran without a finding\n", total);
  return 0;
}
