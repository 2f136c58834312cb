// SPDX-License-Identifier: GPL-3.0-or-later
// The geodesic graph's neighbour lists across scan lines (scan_lines.hpp).
#include "scan_lines.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <utility>

#include "iires/detail/parallel.hpp"

namespace iires::detail {

/// Scatter matrix of @p p and the @p w points @p list of @p pts about their mean.
Eigen::Matrix3d scatter(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& p, const std::uint32_t* list,
                        std::size_t w) {
  Eigen::Vector3d mean = p;
  for (std::size_t r = 0; r < w; ++r) mean += pts[list[r]];
  mean /= static_cast<double>(w + 1);
  Eigen::Matrix3d cov = (p - mean) * (p - mean).transpose();
  for (std::size_t r = 0; r < w; ++r) cov += (pts[list[r]] - mean) * (pts[list[r]] - mean).transpose();
  return cov;
}

void acrossScanLines(const std::vector<Eigen::Vector3d>& zp, const KnnIndex& index, std::size_t k, NeighbourLists& lists,
                     int threads) {
  constexpr std::size_t kLineWiden = 8;
  const std::size_t n = zp.size();
  const std::vector<Eigen::Vector3d>& axis = lists.line;
  lists.across.assign(n, 0.0f);
  parallelFor(n, threads, [&](std::size_t i) {
    if (axis[i].isZero()) return;
    const std::uint32_t* list = &lists.index[i * k];
    const double reach = lists.distance[i * k + k - 1];
    double across = 0;
    for (std::size_t r = 0; r < k; ++r) {
      const Eigen::Vector3d d = zp[list[r]] - zp[i];
      across += (d - axis[i].dot(d) * axis[i]).squaredNorm();
    }
    const double offLine = std::max(0.5 * reach, 3.0 * std::sqrt(across / static_cast<double>(k)));
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.knn(zp[i], kLineWiden * k + 1, idx, d2);
    std::vector<std::pair<float, std::uint32_t>> keep;
    const std::size_t near = k - k / 2;
    for (std::size_t r = 0; r < idx.size() && keep.size() < k; ++r) {
      if (idx[r] == i) continue;
      const Eigen::Vector3d d = zp[idx[r]] - zp[i];
      const bool off = (d - axis[i].dot(d) * axis[i]).norm() > offLine;
      if (keep.size() < near || off) keep.emplace_back(static_cast<float>(std::sqrt(d2[r])), idx[r]);
    }
    if (keep.size() == near) return;  // nothing off the line: a line of its own
    float nearestOff = kInf;
    for (std::size_t r = near; r < keep.size(); ++r) nearestOff = std::min(nearestOff, keep[r].first);
    for (std::size_t r = 0; r < k; ++r) {
      lists.index[i * k + r] = r < keep.size() ? keep[r].second : kNone;
      lists.distance[i * k + r] = r < keep.size() ? keep[r].first : kInf;
    }
    lists.rho[i] = std::max(lists.rho[i], nearestOff);
    lists.across[i] = nearestOff;
    if (lists.givenNormals) return;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;  // the normal of the widened list
    eig.computeDirect(scatter(zp, zp[i], &lists.index[i * k], keep.size()));
    lists.normal[i] = eig.eigenvectors().col(0).cast<float>();
  });
}

}  // namespace iires::detail
