// Repeated patterns in a vector's evidence, summarised (result.hpp EvidenceRepeat): an SDO poll
// and its answer a hundred times over on CAN; on EtherCAT the SII read of every bring-up (an
// address written, the busy bit polled) and the mailbox polls of CoE transfers. Where a block of
// 1..kMaxRepeatLength entries comes at least three times in a row, its first occurrence stays
// (its first entry says how many repetitions were left out and until when), the repetitions
// between are left out, and the last repetition stays in full: a reader sees how the pattern
// began and how it ended (the values it last read, the answer before a failure), and counts.
// Entries are alike by a key the caller gives (an empty key is never part of a pattern).
//
// The bounding of a long vector (keep its first and last entries) must not cut a summarised
// block apart: safe_cut moves the cut to its edges.
#pragma once

#include <algorithm>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "conformance/result.hpp"

namespace drivecheck::conformance {

inline constexpr std::size_t kMaxRepeatLength = 8;

// Folds entries [from, end) of `entries` by `keys` (one per entry, kept in step with them);
// `time_of(entry)` is the entry's last time (EvidenceRepeat::until). Returns where a later call
// may start again: after the last summarised block's first occurrence, and no later than
// 2 x kMaxRepeatLength entries before the end (a pattern that has only begun).
template <class Entry, class TimeOf>
std::size_t fold_repeats(std::vector<Entry>& entries, std::vector<std::string>& keys,
                         std::size_t from, TimeOf time_of) {
  if (from >= entries.size() || keys.size() != entries.size()) return from;
  const std::size_t n = entries.size() - from;
  const auto key = [&](std::size_t i) -> const std::string& { return keys[from + i]; };
  // The repetitions of [i, i + p) right after it (0: none).
  const auto repetitions = [&](std::size_t i, std::size_t p) {
    for (std::size_t k = 0; k < p; ++k) {
      if (key(i + k).empty()) return std::size_t{0};
    }
    std::size_t r = 0;
    while (i + (r + 2) * p <= n) {
      bool same = true;
      for (std::size_t k = 0; k < p && same; ++k)
        same = key(i + k) == key(i + (r + 1) * p + k);
      if (!same) break;
      ++r;
    }
    return r;
  };
  std::vector<Entry> out;
  std::vector<std::string> out_keys;
  out.reserve(n);
  out_keys.reserve(n);
  const auto keep = [&](std::size_t i) {
    out.push_back(std::move(entries[from + i]));
    out_keys.push_back(std::move(keys[from + i]));
  };
  std::size_t resume = 0;  // in `out`
  std::size_t i = 0;
  while (i < n) {
    std::size_t best_p = 0;
    std::size_t best_r = 0;
    for (std::size_t p = 1; p <= kMaxRepeatLength && i + 3 * p <= n; ++p) {
      const std::size_t r = repetitions(i, p);
      // At least three occurrences (one left out); the most entries left out, then the shortest.
      if (r >= 2 && (r - 1) * p > (best_r > 0 ? (best_r - 1) * best_p : 0)) {
        best_p = p;
        best_r = r;
      }
    }
    if (best_p == 0) {
      keep(i);
      ++i;
      continue;
    }
    const std::size_t first = out.size();
    for (std::size_t k = 0; k < best_p; ++k)
      keep(i + k);
    auto& repeat = out[first].repeat;
    repeat.length = best_p;
    repeat.times = best_r - 1;
    repeat.until = time_of(entries[from + i + best_r * best_p - 1]);
    resume = out.size();
    for (std::size_t k = 0; k < best_p; ++k)
      keep(i + best_r * best_p + k);
    i += (best_r + 1) * best_p;
  }
  entries.resize(from);
  keys.resize(from);
  for (auto& entry : out)
    entries.push_back(std::move(entry));
  for (auto& k : out_keys)
    keys.push_back(std::move(k));
  const std::size_t tail =
      out.size() > 2 * kMaxRepeatLength ? out.size() - 2 * kMaxRepeatLength : 0;
  return from + std::max(resume, tail);
}

// [begin, end) moved so that no summarised block (a first occurrence: the entry with the repeat
// and the length - 1 after it, and the last repetition after those) is cut apart: a block the
// cut begins in is kept whole before it, one the cut ends in is kept whole after it. The range
// may come out empty.
template <class Entry>
std::pair<std::size_t, std::size_t> safe_cut(const std::vector<Entry>& entries, std::size_t begin,
                                             std::size_t end) {
  for (std::size_t g = 0; g < entries.size(); ++g) {
    const auto& repeat = entries[g].repeat;
    if (repeat.times == 0) continue;
    const std::size_t stop = g + 2 * repeat.length;  // first occurrence and last repetition
    if (g < begin && begin < stop) begin = stop;
    if (g < end && end < stop) end = g;
  }
  if (end < begin) end = begin;
  return {begin, std::min(end, entries.size())};
}

}  // namespace drivecheck::conformance
