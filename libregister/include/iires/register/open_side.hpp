// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file open_side.hpp
/// @brief Where a partial scan is open: its boundary (rim) points and the direction from the cloud's centroid
/// to their centroid. A scan cut by a plane, or seen from one side, lacks the part of the object on that
/// side, so the whole object's centroid lies from the part's centroid towards its rim. The rotation search
/// uses the direction to place the partial cloud in the other one's normalised frame.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "iires/knn.hpp"

namespace iires::reg {

/// @brief Parameters of openSide().
struct OpenSideParams {
  std::size_t neighbours = 12;  ///< k of the boundary test (≥ 4; the point itself is one of them)
  /// A point is on the rim when its neighbours, projected on their least-squares plane, leave an angular gap
  /// larger than this around it (degrees, in (0, 360)): an interior point is surrounded on all sides
  double minGapDeg = 108.0;

  /// @throws std::invalid_argument when a field is out of range.
  void validate() const;
};

/// @brief The rim of a cloud and the direction it lies in.
struct OpenSide {
  std::size_t rimPoints = 0;  ///< points that passed the boundary test
  /// Unit vector from the centroid of all points to the centroid of the rim points; zero without rim points
  /// (a closed surface) or when the two centroids coincide
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  std::vector<std::uint8_t> rim;  ///< per point: 1 when it passed the boundary test (empty: too few points)
};

/// @brief The rim points of @p points (an evenly spaced sampling of a surface) and their direction.
/// @throws std::invalid_argument for bad parameters.
/// @note Deterministic for any thread count.
OpenSide openSide(const std::vector<Eigen::Vector3d>& points, const OpenSideParams& params = {}, int threads = 0);
/// @brief The same, reading the neighbours from @p index, a k-d tree of @p points the caller already has.
OpenSide openSide(const std::vector<Eigen::Vector3d>& points, const KnnIndex& index, const OpenSideParams& params = {},
                  int threads = 0);

}  // namespace iires::reg
