// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file distance_field.hpp
/// @brief A sampled distance field of a point set: the distance to the nearest point, stored at the nodes of
/// a regular grid and interpolated trilinearly. A cheap approximation of a k-d tree's nearest-point distance
/// (O(1) per query), used by the coarse pass of the rotation search.

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <vector>

#include "iires/knn.hpp"

namespace iires::reg {

/// @brief Parameters of a DistanceField.
struct DistanceFieldParams {
  std::size_t cells = 32;  ///< grid cells along the longest side of the grown bounding box (≥ 2)
  double margin = 1.0;  ///< the bounding box is grown by this much on each side, in the points' units (≥ 0)
  int threads = 0;      ///< threads filling the grid (0 = all cores); the field does not depend on it

  /// @throws std::invalid_argument when a field is out of range.
  void validate() const;
};

/// @brief Distance to the nearest point of a fixed set, sampled on a regular grid of cubic cells.
/// Inside the grid the value is the trilinear interpolation of the node values; since the exact distance d
/// is 1-Lipschitz, it differs from d by at most one cell diagonal. Outside the grid the value is the
/// distance to the grid's box plus the field at the nearest point of the box, which is at least d minus
/// that same error.
/// @note Queries are const and thread-safe.
class DistanceField {
 public:
  /// @param points the set (non-empty); it is only read while constructing
  /// @throws std::invalid_argument for an empty set or bad parameters.
  /// @note O(nodes · log n) construction with a k-d tree; nodes ≈ cells³ at most.
  explicit DistanceField(const std::vector<Eigen::Vector3d>& points, const DistanceFieldParams& params = {});
  /// @brief The same, reading the nearest points from @p index, a k-d tree of @p points the caller already has.
  DistanceField(const std::vector<Eigen::Vector3d>& points, const KnnIndex& index,
                const DistanceFieldParams& params = {});

  /// @brief The approximate distance from @p query to the nearest point of the set (≥ 0). Inline: the coarse
  /// rotation search asks it for every point of every pose.
  double distance(const Eigen::Vector3d& query) const {
    // Outside the box: the distance to the box plus the field at the nearest point of the box (the exact
    // distance is at most that, by the triangle inequality).
    double outside2 = 0;
    std::size_t cell[3];
    double f[3];
    for (int a = 0; a < 3; ++a) {
      const double q = std::clamp(query[a], origin_[a], far_[a]);
      outside2 += (query[a] - q) * (query[a] - q);
      const double u = (q - origin_[a]) * inverseCell_;  // ≥ 0: truncation is the floor
      cell[a] = std::min(static_cast<std::size_t>(u), nodes_[a] - 2);
      f[a] = u - static_cast<double>(cell[a]);
    }
    const std::size_t sx = 1, sy = nodes_[0], sz = nodes_[0] * nodes_[1];
    const float* v = values_.data() + cell[0] * sx + cell[1] * sy + cell[2] * sz;
    // Trilinear interpolation: along x on the four edges, then y, then z.
    const double x00 = v[0] + f[0] * (v[sx] - v[0]);
    const double x10 = v[sy] + f[0] * (v[sy + sx] - v[sy]);
    const double x01 = v[sz] + f[0] * (v[sz + sx] - v[sz]);
    const double x11 = v[sz + sy] + f[0] * (v[sz + sy + sx] - v[sz + sy]);
    const double y0 = x00 + f[1] * (x10 - x00);
    const double y1 = x01 + f[1] * (x11 - x01);
    const double inside = y0 + f[2] * (y1 - y0);
    return outside2 > 0 ? inside + std::sqrt(outside2) : inside;
  }
  /// @brief distance()², the quantity a k-d tree's nearest() reports.
  double squaredDistance(const Eigen::Vector3d& query) const {
    const double d = distance(query);
    return d * d;
  }

  /// @brief Edge length of a cell.
  double cellSize() const { return cell_; }
  /// @brief Corner of the grid with the smallest coordinates (node (0, 0, 0)).
  const Eigen::Vector3d& origin() const { return origin_; }
  /// @brief Nodes along each axis (≥ 2 each).
  const std::array<std::size_t, 3>& nodes() const { return nodes_; }

 private:
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero(), far_ = Eigen::Vector3d::Zero();  // the grid's box
  double cell_ = 1, inverseCell_ = 1;
  std::array<std::size_t, 3> nodes_{2, 2, 2};
  std::vector<float> values_;  // node distances, x fastest

  void build(const std::vector<Eigen::Vector3d>& points, const KnnIndex& index, const DistanceFieldParams& params);
};

}  // namespace iires::reg
