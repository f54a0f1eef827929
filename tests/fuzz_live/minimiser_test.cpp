#include "fuzz/live/minimiser.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

namespace drivecheck::fuzz_live {
namespace {

bool contains_all(std::span<const std::size_t> indices, std::initializer_list<std::size_t> needed) {
  return std::all_of(needed.begin(), needed.end(), [&](std::size_t n) {
    return std::find(indices.begin(), indices.end(), n) != indices.end();
  });
}

TEST(LiveMinimiser, FindsTheOneFailingElement) {
  // Given 30 elements of which only element 17 makes the run fail
  // When the sequence is minimised
  // Then element 17 alone is kept
  const auto result =
      minimise(30, [](std::span<const std::size_t> s) { return contains_all(s, {17}); });
  EXPECT_EQ(result.kept, (std::vector<std::size_t>{17}));
  EXPECT_FALSE(result.budget_exhausted);
  EXPECT_LT(result.tries, 30U);
}

TEST(LiveMinimiser, KeepsTheFailingPairInOrder) {
  // Given 40 elements where the failure needs both 3 and 29 (say a session's initiate and
  // its segment)
  // When the sequence is minimised
  // Then exactly {3, 29} is kept, in that order
  const auto result = minimise(40, [](std::span<const std::size_t> s) {
    return contains_all(s, {3, 29});
  });
  EXPECT_EQ(result.kept, (std::vector<std::size_t>{3, 29}));
}

TEST(LiveMinimiser, KeepsAFailingTriple) {
  // Given 25 elements where the failure needs 0, 12 and 24
  // When the sequence is minimised
  // Then exactly those three are kept
  const auto result = minimise(25, [](std::span<const std::size_t> s) {
    return contains_all(s, {0, 12, 24});
  });
  EXPECT_EQ(result.kept, (std::vector<std::size_t>{0, 12, 24}));
}

TEST(LiveMinimiser, OrderMattersForThePredicate) {
  // Given a failure that needs element 5 somewhere before element 8 (the predicate sees the
  // subsequence in the original order)
  // When minimised
  // Then {5, 8}; every subsequence passed to the predicate is ascending
  bool ascending = true;
  const auto result = minimise(12, [&](std::span<const std::size_t> s) {
    ascending = ascending && std::is_sorted(s.begin(), s.end());
    const auto five = std::find(s.begin(), s.end(), 5);
    const auto eight = std::find(s.begin(), s.end(), 8);
    return five != s.end() && eight != s.end() && five < eight;
  });
  EXPECT_EQ(result.kept, (std::vector<std::size_t>{5, 8}));
  EXPECT_TRUE(ascending);
}

TEST(LiveMinimiser, AFailureWithoutInputMinimisesToNothing) {
  // Given a failure that happens whatever is sent (the device was broken already)
  // When minimised
  // Then nothing is kept, after a single try
  const auto result = minimise(10, [](std::span<const std::size_t>) { return true; });
  EXPECT_TRUE(result.kept.empty());
  EXPECT_EQ(result.tries, 1U);
}

TEST(LiveMinimiser, NeverRunsTheSameSubsequenceTwice) {
  // Given a failure needing {2, 7} out of 16
  // When minimised
  // Then no subsequence reached the predicate twice
  std::set<std::vector<std::size_t>> seen;
  bool repeated = false;
  (void)minimise(16, [&](std::span<const std::size_t> s) {
    repeated = repeated || !seen.insert({s.begin(), s.end()}).second;
    return contains_all(s, {2, 7});
  });
  EXPECT_FALSE(repeated);
}

TEST(LiveMinimiser, StopsAtTheTryBudget) {
  // Given a budget of 3 tries for a failure needing {1, 6, 11} out of 64
  // When minimised
  // Then it stops, says so, and what it keeps still fails
  const auto fails = [](std::span<const std::size_t> s) { return contains_all(s, {1, 6, 11}); };
  const auto result = minimise(64, fails, 3);
  EXPECT_TRUE(result.budget_exhausted);
  EXPECT_EQ(result.tries, 3U);
  EXPECT_TRUE(fails(result.kept));
}

}  // namespace
}  // namespace drivecheck::fuzz_live
