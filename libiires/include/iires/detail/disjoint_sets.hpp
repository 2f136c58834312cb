// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file disjoint_sets.hpp
/// @brief Union-find over indices, deterministic: the smaller index always becomes the root, so component ids
/// do not depend on the order of unions. Used for connected components of k-NN graphs and of meshes.

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <vector>

namespace iires {

/// @brief Union-find with path halving; union by smaller index.
/// @note find() and unite() are amortised near O(1); not thread-safe.
struct DisjointSets {
  explicit DisjointSets(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  std::vector<std::uint32_t> parent;
};

}  // namespace iires
