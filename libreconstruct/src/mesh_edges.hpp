// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The edges of a triangle mesh keyed by their vertex pair. Internal to libreconstruct.
#include <algorithm>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "iires/detail/radix_sort.hpp"
#include "iires/types.hpp"

namespace iires::detail {

/// The key of the undirected edge {a, b}: (min << 32) | max.
inline std::uint64_t undirectedKey(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

/// Every face's use of each of its edges (a repeated vertex's edge left out): (undirectedKey, face · 2 + 1 when
/// the face runs along it from the lower vertex index to the higher), sorted by edge, faces ascending within an
/// edge. Faces sharing an edge are one run of equal keys.
inline std::vector<KeyedIndex> sortedEdgeUses(const TriangleMesh& mesh) {
  std::vector<KeyedIndex> uses;
  uses.reserve(3 * mesh.triangles.size());
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
    for (int c = 0; c < 3; ++c) {
      const auto a = static_cast<std::uint32_t>(mesh.triangles[f][c]);
      const auto b = static_cast<std::uint32_t>(mesh.triangles[f][(c + 1) % 3]);
      if (a != b) uses.emplace_back(undirectedKey(a, b), 2 * f + (a < b ? 1 : 0));
    }
  radixSort(uses, 1);  // stable: faces stay ascending within an edge
  return uses;
}

/// Edge → the faces using it, built fresh from the face list.
inline std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> edgeFaces(const TriangleMesh& mesh) {
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> map;
  map.reserve(mesh.triangles.size() * 2);
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
    for (int c = 0; c < 3; ++c)
      map[undirectedKey(static_cast<std::uint32_t>(mesh.triangles[f][c]),
                        static_cast<std::uint32_t>(mesh.triangles[f][(c + 1) % 3]))]
          .push_back(f);
  return map;
}

}  // namespace iires::detail
