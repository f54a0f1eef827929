#include "conformance/vector_order.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <numeric>
#include <utility>

namespace drivecheck::conformance {
namespace {

constexpr std::string_view kShufflePrefix = "shuffle:";

// splitmix64 (Steele, Lea, Flood 2014): a 64-bit generator fully defined by its seed.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next() {
    state_ += 0x9E3779B97F4A7C15ULL;
    std::uint64_t z = state_;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
  }
  // Uniform in 0..bound-1 (bound > 0), without modulo bias: draws in the biased tail are
  // rejected.
  std::uint64_t below(std::uint64_t bound) {
    const std::uint64_t limit = ~std::uint64_t{0} - (~std::uint64_t{0} % bound);
    for (;;) {
      const std::uint64_t draw = next();
      if (draw < limit) return draw % bound;
    }
  }

 private:
  std::uint64_t state_;
};

}  // namespace

Expected<VectorOrder, std::string> parse_vector_order(std::string_view text) {
  if (text == "file") return VectorOrder{VectorOrder::Kind::file, std::nullopt};
  if (text == "reverse") return VectorOrder{VectorOrder::Kind::reverse, std::nullopt};
  if (text == "shuffle") return VectorOrder{VectorOrder::Kind::shuffle, std::nullopt};
  if (text.starts_with(kShufflePrefix)) {
    const std::string_view digits = text.substr(kShufflePrefix.size());
    std::uint64_t seed = 0;
    const auto* end = digits.data() + digits.size();
    const auto [ptr, ec] = std::from_chars(digits.data(), end, seed);
    const bool all_digits =
        std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; });
    if (digits.empty() || !all_digits || ec != std::errc() || ptr != end) {
      return Unexpected(fmt::format(
          "order '{}': the shuffle seed must be a whole number 0..2^64-1 (shuffle:SEED)", text));
    }
    return VectorOrder{VectorOrder::Kind::shuffle, seed};
  }
  return Unexpected(
      fmt::format("order '{}' is not one of file, reverse, shuffle, shuffle:SEED", text));
}

std::string to_string(const VectorOrder& order) {
  switch (order.kind) {
    case VectorOrder::Kind::file:
      return "file";
    case VectorOrder::Kind::reverse:
      return "reverse";
    case VectorOrder::Kind::shuffle:
      return order.seed ? fmt::format("shuffle:{}", *order.seed) : std::string("shuffle");
  }
  return "file";
}

std::vector<std::size_t> order_permutation(std::size_t count, const VectorOrder& order) {
  std::vector<std::size_t> permutation(count);
  std::iota(permutation.begin(), permutation.end(), std::size_t{0});
  switch (order.kind) {
    case VectorOrder::Kind::file:
      break;
    case VectorOrder::Kind::reverse:
      std::reverse(permutation.begin(), permutation.end());
      break;
    case VectorOrder::Kind::shuffle: {
      // Fisher-Yates, from the back: element i swaps with one of 0..i.
      SplitMix64 random(order.seed.value_or(0));
      for (std::size_t i = count; i > 1; --i) {
        const auto j = static_cast<std::size_t>(random.below(i));
        std::swap(permutation[i - 1], permutation[j]);
      }
      break;
    }
  }
  return permutation;
}

void apply_order(std::vector<Vector>& vectors, const VectorOrder& order) {
  if (order.kind == VectorOrder::Kind::file) return;
  const auto permutation = order_permutation(vectors.size(), order);
  std::vector<Vector> ordered;
  ordered.reserve(vectors.size());
  for (const std::size_t index : permutation)
    ordered.push_back(std::move(vectors[index]));
  vectors = std::move(ordered);
}

}  // namespace drivecheck::conformance
