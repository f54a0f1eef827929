// The engine's floor for scripts/fuzz-bench: a target that does nothing, built with the same
// flags as the real ones, so that "exec/s of a target / exec/s of this one" says how much of
// the engine's speed a target keeps. Not a fuzz target: no corpus, not in fuzz/build.sh.
#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static_cast<void>(data);
  static_cast<void>(size);
  return 0;
}
