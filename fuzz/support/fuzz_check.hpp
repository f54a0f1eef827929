// Oracles of the fuzz targets: a failed check prints what was expected, where, and the input's
// context, then traps, so that libFuzzer (and the replay main, under CTest) records a crash
// with a message a person can read. Checks stay on in every build type (they are the point of
// a fuzz target, not debug asserts).
//
//   DRIVECHECK_FUZZ_CHECK(reparsed == records, "candump log round trip changed the records");
//   DRIVECHECK_FUZZ_CHECK_EQ(to_candump(a), to_candump(b), "re-encoded EMCY differs");
#pragma once

#include <fmt/format.h>

#include <cstdio>
#include <string>
#include <string_view>

namespace drivecheck::fuzz {

// Prints "fuzz oracle failed at file:line: what\n  condition\n  detail" to stderr and traps.
[[noreturn]] inline void oracle_failed(const char* file, int line, const char* condition,
                                       std::string_view what, std::string_view detail = {}) {
  std::fprintf(stderr, "\n==drivecheck== fuzz oracle failed at %s:%d: %.*s\n  check: %s\n", file,
               line, static_cast<int>(what.size()), what.data(), condition);
  if (!detail.empty()) {
    std::fprintf(stderr, "  %.*s\n", static_cast<int>(detail.size()), detail.data());
  }
  std::fflush(stderr);
  __builtin_trap();
}

}  // namespace drivecheck::fuzz

// Marks a hot oracle helper (e.g. comparing a whole dictionary after every frame) as not
// instrumented for coverage: the oracle is not the code under test, its branches give the
// engine no signal, and the per-comparison callbacks cost more than the target itself.
// ASan and UBSan stay on. Not inlined: inlined into an instrumented caller, its loops would
// be instrumented there after all.
#if defined(__clang__)
#define DRIVECHECK_FUZZ_ORACLE_CODE __attribute__((no_sanitize("coverage"), noinline))
#else
#define DRIVECHECK_FUZZ_ORACLE_CODE
#endif

#define DRIVECHECK_FUZZ_CHECK(condition, what)                                   \
  do {                                                                           \
    if (!(condition)) {                                                          \
      ::drivecheck::fuzz::oracle_failed(__FILE__, __LINE__, #condition, (what)); \
    }                                                                            \
  } while (false)

// `detail` (a std::string expression) is evaluated only when the check fails.
#define DRIVECHECK_FUZZ_CHECK_DETAIL(condition, what, detail)                              \
  do {                                                                                     \
    if (!(condition)) {                                                                    \
      ::drivecheck::fuzz::oracle_failed(__FILE__, __LINE__, #condition, (what), (detail)); \
    }                                                                                      \
  } while (false)

// Both sides must be printable with fmt (frames, strings, integers).
#define DRIVECHECK_FUZZ_CHECK_EQ(actual, expected, what)                                        \
  do {                                                                                          \
    const auto& drivecheck_fuzz_a_ = (actual);                                                  \
    const auto& drivecheck_fuzz_e_ = (expected);                                                \
    if (!(drivecheck_fuzz_a_ == drivecheck_fuzz_e_)) {                                          \
      ::drivecheck::fuzz::oracle_failed(                                                        \
          __FILE__, __LINE__, #actual " == " #expected, (what),                                 \
          fmt::format("actual:   {}\n  expected: {}", drivecheck_fuzz_a_, drivecheck_fuzz_e_)); \
    }                                                                                           \
  } while (false)
