// SPDX-License-Identifier: GPL-3.0-or-later
#include "crowded.hpp"

#include <algorithm>
#include <cstdint>
#include <tuple>

#include "iires/knn.hpp"

namespace iires::detail {

std::vector<char> mostCrowded(const std::vector<Eigen::Vector3d>& points, const std::vector<char>& held,
                              std::size_t excess) {
  std::vector<char> removed(points.size(), 0);
  if (excess == 0 || points.size() < 2) return removed;
  const KnnIndex index(points);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> crowded;  // (d², point, its nearest)
  for (std::uint32_t i = 0; i < points.size(); ++i)
    if (!held[i] && index.knn(points[i], 2, idx, d2) == 2) crowded.emplace_back(d2[1], i, idx[1]);
  std::sort(crowded.begin(), crowded.end());
  for (const bool pairwise : {true, false})
    for (const auto& [d, i, nearest] : crowded)
      if (excess > 0 && !removed[i] && !(pairwise && removed[nearest])) removed[i] = 1, --excess;
  return removed;
}

}  // namespace iires::detail
