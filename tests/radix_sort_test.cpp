// SPDX-License-Identifier: GPL-3.0-or-later
// Tests for radix_sort.hpp: the same order as a stable comparison sort, for keys that use few or all bits.
#include "iires/detail/radix_sort.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace iires {
namespace {

std::vector<KeyedIndex> keyed(const std::vector<std::uint64_t>& keys) {
  std::vector<KeyedIndex> out;
  for (std::size_t i = 0; i < keys.size(); ++i) out.push_back({keys[i], static_cast<std::uint32_t>(i)});
  return out;
}

void expectLikeStableSort(const std::vector<std::uint64_t>& keys) {
  std::vector<KeyedIndex> expected = keyed(keys);
  std::stable_sort(expected.begin(), expected.end(),
                   [](const KeyedIndex& a, const KeyedIndex& b) { return a.first < b.first; });
  for (int threads : {1, 2, 3}) {
    std::vector<KeyedIndex> items = keyed(keys);
    radixSort(items, threads);
    EXPECT_EQ(items, expected) << threads << " threads";
  }
}

TEST(RadixSort, MatchesStableSortOnFullWidthKeys) {
  std::mt19937_64 rng(3);
  std::vector<std::uint64_t> keys(20000);
  for (auto& k : keys) k = rng();
  expectLikeStableSort(keys);
}

TEST(RadixSort, EqualKeysKeepTheirInputOrder) {
  std::mt19937_64 rng(5);
  std::vector<std::uint64_t> keys(20000);
  for (auto& k : keys) k = (rng() % 37) << 40 | (rng() % 3);  // many ties, digits 1 and 3 constant
  expectLikeStableSort(keys);
}

TEST(RadixSort, BlocksPerThreadGiveTheStableOrder) {
  // Large enough for one block per thread (2^16 items each): ties across block boundaries keep input order.
  std::mt19937_64 rng(7);
  std::vector<std::uint64_t> keys(300001);
  for (auto& k : keys) k = (rng() % 5000) << 20 | (rng() % 2);
  expectLikeStableSort(keys);
}

TEST(RadixSort, ConstantAndTinyInputs) {
  expectLikeStableSort({});
  expectLikeStableSort({42});
  expectLikeStableSort(std::vector<std::uint64_t>(1000, 0xdeadbeefcafef00dull));  // every digit constant
  expectLikeStableSort({~0ull, 0, ~0ull, 1, 0});
}

}  // namespace
}  // namespace iires
