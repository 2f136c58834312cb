// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file distance_field.hpp
/// @brief A sampled distance field of a point set: the distance to the nearest point, stored at the nodes of
/// a regular grid and interpolated trilinearly. A cheap approximation of a k-d tree's nearest-point distance
/// (O(1) per query), used by the coarse pass of the rotation search.

#include <Eigen/Core>
#include <array>
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

  /// @brief The approximate distance from @p query to the nearest point of the set (≥ 0).
  double distance(const Eigen::Vector3d& query) const;
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
