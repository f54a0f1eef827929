#include "fuzz/live/minimiser.hpp"

#include <algorithm>
#include <map>
#include <numeric>

namespace drivecheck::fuzz_live {

MinimiseResult minimise(std::size_t size,
                        const std::function<bool(std::span<const std::size_t>)>& fails,
                        std::size_t max_tries) {
  MinimiseResult result;
  std::vector<std::size_t> current(size);
  std::iota(current.begin(), current.end(), std::size_t{0});
  std::map<std::vector<std::size_t>, bool> cache;
  cache[current] = true;
  const auto test = [&](const std::vector<std::size_t>& candidate) {
    if (auto it = cache.find(candidate); it != cache.end()) return it->second;
    if (result.tries >= max_tries) {
      result.budget_exhausted = true;
      return false;
    }
    ++result.tries;
    const bool failed = fails(candidate);
    cache[candidate] = failed;
    return failed;
  };

  // The empty sequence first: a failure that needs no frame at all (the device was already
  // broken) minimises to nothing.
  if (size > 0 && test({})) {
    result.kept.clear();
    return result;
  }

  std::size_t granularity = 2;
  while (current.size() >= 2) {
    const std::size_t n = std::min(granularity, current.size());
    const std::size_t chunk = (current.size() + n - 1) / n;
    std::vector<std::vector<std::size_t>> subsets;
    for (std::size_t start = 0; start < current.size(); start += chunk) {
      const std::size_t end = std::min(current.size(), start + chunk);
      subsets.emplace_back(current.begin() + static_cast<std::ptrdiff_t>(start),
                           current.begin() + static_cast<std::ptrdiff_t>(end));
    }
    bool reduced = false;
    // Reduce to a subset.
    for (const auto& subset : subsets) {
      if (test(subset)) {
        current = subset;
        granularity = 2;
        reduced = true;
        break;
      }
    }
    // Reduce to a complement.
    if (!reduced && subsets.size() > 2) {
      for (std::size_t i = 0; i < subsets.size(); ++i) {
        std::vector<std::size_t> complement;
        for (std::size_t j = 0; j < subsets.size(); ++j) {
          if (j != i) complement.insert(complement.end(), subsets[j].begin(), subsets[j].end());
        }
        if (test(complement)) {
          current = complement;
          granularity = std::max<std::size_t>(granularity - 1, 2);
          reduced = true;
          break;
        }
      }
    }
    if (result.budget_exhausted) break;
    if (!reduced) {
      if (n >= current.size()) break;  // single elements tried: 1-minimal
      granularity = std::min(current.size(), granularity * 2);
    }
  }
  result.kept = current;
  return result;
}

}  // namespace drivecheck::fuzz_live
