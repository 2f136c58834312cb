#pragma once
/// @file radix_sort.hpp
/// @brief Stable least-significant-digit radix sort of (64-bit key, 32-bit index) pairs: the cell, Morton and
/// duplicate orders of millions of points in O(n) instead of a comparison sort's O(n log n).

#include <array>
#include <cstdint>
#include <utility>
#include <vector>

namespace iires {

using KeyedIndex = std::pair<std::uint64_t, std::uint32_t>;

/// @brief Sort @p items by key, keeping the input order of equal keys (stable): on input in index order the
/// result equals std::sort of the pairs.
/// @note O(n) per 11-bit digit (2048 buckets: the counts stay in L1 and the scatter in few streams, 15–30 %
/// faster than 16-bit digits on 550k keys); digits above the keys' highest set bit, and digits equal in every
/// key, are skipped, so keys that use few bits sort in few passes. Deterministic, single-threaded, one
/// scratch array of n pairs.
inline void radixSort(std::vector<KeyedIndex>& items) {
  constexpr int kBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kBits;
  if (items.size() < 2) return;
  std::uint64_t used = 0;
  for (const KeyedIndex& x : items) used |= x.first;
  std::vector<KeyedIndex> scratch(items.size());
  std::vector<std::uint32_t> count(kBuckets);
  for (int shift = 0; shift < 64 && (used >> shift) != 0; shift += kBits) {
    std::fill(count.begin(), count.end(), 0u);
    for (const KeyedIndex& x : items) ++count[(x.first >> shift) & (kBuckets - 1)];
    if (count[(items.front().first >> shift) & (kBuckets - 1)] == items.size()) continue;  // digit constant
    std::uint32_t sum = 0;
    for (std::uint32_t& c : count) {
      const std::uint32_t here = c;
      c = sum;
      sum += here;
    }
    for (const KeyedIndex& x : items) scratch[count[(x.first >> shift) & (kBuckets - 1)]++] = x;
    items.swap(scratch);
  }
}

}  // namespace iires
