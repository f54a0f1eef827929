// Delta debugging (Zeller and Hildebrandt's ddmin) over a failing sequence: the smallest
// subsequence, in the original order, that still fails, found by re-running subsequences.
//
// The live fuzzer minimises the frames the harness sent in a case: each try replays a
// subsequence against a fresh device (the simulated bus) or a reset one (a real bus) and asks
// the liveness oracle whether the same anomaly comes back. The result is 1-minimal: removing
// any one element makes it pass (or the try budget ran out, which the result says).
#pragma once

#include <cstddef>
#include <functional>
#include <span>
#include <vector>

namespace drivecheck::fuzz_live {

struct MinimiseResult {
  std::vector<std::size_t> kept;  // indices into the original sequence, ascending
  std::size_t tries = 0;          // predicate calls (cached repeats not counted)
  bool budget_exhausted = false;  // stopped at max_tries: `kept` fails but may not be minimal
};

// `fails(indices)` runs the subsequence (ascending indices into 0..size-1) and says whether
// it still shows the failure. The whole sequence is assumed to fail and is not re-run.
// Subsequences already tried are not run again.
MinimiseResult minimise(std::size_t size,
                        const std::function<bool(std::span<const std::size_t>)>& fails,
                        std::size_t max_tries = 200);

}  // namespace drivecheck::fuzz_live
