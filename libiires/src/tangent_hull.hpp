// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file tangent_hull.hpp
/// @brief How far a point lies outside the footprint of a neighbourhood on its tangent plane: the MLS projection
/// reads it to tell an open boundary (the surface ends there), the outlier pull to tell where a local plane no
/// longer stands for the surface.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace iires::detail {

/// Distance in the tangent plane at @p x (normal @p normal) from x to the convex hull of the points
/// @p idx[0, count) (those with non-zero weight in @p w; nullptr: all of them): 0 inside it.
double beyondHull(const std::vector<Eigen::Vector3d>& points, const std::uint32_t* idx, std::size_t count,
                  const double* w, const Eigen::Vector3d& x, const Eigen::Vector3d& normal);

}  // namespace iires::detail
