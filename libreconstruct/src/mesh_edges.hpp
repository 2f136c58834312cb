// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The edges of a triangle mesh keyed by their vertex pair. Internal to libreconstruct.
#include <algorithm>
#include <cstdint>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "iires/detail/radix_sort.hpp"
#include "iires/types.hpp"

namespace iires::detail {

/// The key of the undirected edge {a, b}: (min << 32) | max.
inline std::uint64_t undirectedKey(std::uint32_t a, std::uint32_t b) {
  return (static_cast<std::uint64_t>(std::min(a, b)) << 32) | std::max(a, b);
}

/// The key of the half-edge a → b.
inline std::uint64_t directedKey(std::uint32_t a, std::uint32_t b) { return (static_cast<std::uint64_t>(a) << 32) | b; }

/// Every face's use of each of its edges (a repeated vertex's edge left out): (undirectedKey, face · 2 + 1 when
/// the face runs along it from the lower vertex index to the higher), sorted by edge, faces ascending within an
/// edge. Faces sharing an edge are one run of equal keys. With @p only (a flag per vertex), only the edges with a
/// flagged end.
inline std::vector<KeyedIndex> sortedEdgeUses(const TriangleMesh& mesh, const std::vector<char>* only = nullptr) {
  std::vector<KeyedIndex> uses;
  if (!only) uses.reserve(3 * mesh.triangles.size());
  for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f)
    for (int c = 0; c < 3; ++c) {
      const auto a = static_cast<std::uint32_t>(mesh.triangles[f][c]);
      const auto b = static_cast<std::uint32_t>(mesh.triangles[f][(c + 1) % 3]);
      if (a != b && (!only || (*only)[a] || (*only)[b])) uses.emplace_back(undirectedKey(a, b), 2 * f + (a < b ? 1 : 0));
    }
  radixSort(uses, 1);  // stable: faces stay ascending within an edge
  return uses;
}

/// Calls @p f(i, j) for each edge's run uses[i] … uses[j − 1] of sortedEdgeUses().
template <class F>
void forEachEdge(const std::vector<KeyedIndex>& uses, F&& f) {
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i + 1;
    while (j < uses.size() && uses[j].first == uses[i].first) ++j;
    f(i, j);
    i = j;
  }
}

/// Faces per undirected edge, for look-ups while a repair changes a few edges: the mesh's edges in one sorted
/// array (from sortedEdgeUses), the changed counts and the edges added on top.
class EdgeCounts {
 public:
  EdgeCounts() = default;
  explicit EdgeCounts(const std::vector<KeyedIndex>& uses) {
    forEachEdge(uses, [&](std::size_t i, std::size_t j) {
      keys_.push_back(uses[i].first);
      counts_.push_back(static_cast<int>(j - i));
    });
  }

  /// Faces using edge @p key: the mesh's count unless set() changed it.
  int count(std::uint64_t key) const {
    if (const auto it = changed_.find(key); it != changed_.end()) return it->second;
    const auto it = std::lower_bound(keys_.begin(), keys_.end(), key);
    return it != keys_.end() && *it == key ? counts_[static_cast<std::size_t>(it - keys_.begin())] : 0;
  }
  void set(std::uint64_t key, int count) { changed_[key] = count; }

  /// Whether @p key is an edge of the mesh or was added.
  bool has(std::uint64_t key) const {
    return added_.count(key) > 0 || std::binary_search(keys_.begin(), keys_.end(), key);
  }
  void add(std::uint64_t key) { added_.insert(key); }

 private:
  std::vector<std::uint64_t> keys_;
  std::vector<int> counts_;
  std::unordered_map<std::uint64_t, int> changed_;
  std::unordered_set<std::uint64_t> added_;
};

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
