// The order in which `drivecheck run` runs the selected vectors (`--order`). A vector's verdict
// must not depend on the vectors that ran before it (vectors/FORMAT.md "Isolation"); running
// the suite in another order is how anyone checks that, on the simulated bus and on a real
// drive.
//
//   file            the order of the vector tree: files in path order, vectors in file order
//                   (the default)
//   reverse         the file order backwards
//   shuffle:SEED    a pseudo-random permutation that depends only on SEED (0..2^64-1) and the
//                   number of vectors: the same seed and the same selection give the same order
//                   on every platform (our own Fisher-Yates over splitmix64, not std::shuffle,
//                   whose result the C++ standard leaves to the library)
//   shuffle         the CLI draws a seed and records it (RunInfo::order "shuffle:SEED")
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "conformance/vector.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::conformance {

struct VectorOrder {
  enum class Kind { file, reverse, shuffle };
  Kind kind = Kind::file;
  std::optional<std::uint64_t> seed;  // shuffle only; nullopt: not chosen yet
  friend bool operator==(const VectorOrder&, const VectorOrder&) = default;
};

// "file" | "reverse" | "shuffle" | "shuffle:SEED" (SEED a decimal number 0..2^64-1).
// The error is a one-line message naming the bad text.
Expected<VectorOrder, std::string> parse_vector_order(std::string_view text);

// "file", "reverse", "shuffle:SEED" ("shuffle" while the seed is not chosen): what
// parse_vector_order reads back to the same order.
std::string to_string(const VectorOrder& order);

// The permutation of 0..count-1 that `order` gives: element i is the index (in file order) of
// the vector that runs i-th. A shuffle without a seed runs as shuffle:0.
std::vector<std::size_t> order_permutation(std::size_t count, const VectorOrder& order);

// Reorders `vectors` (given in file order) by order_permutation.
void apply_order(std::vector<Vector>& vectors, const VectorOrder& order);

}  // namespace drivecheck::conformance
