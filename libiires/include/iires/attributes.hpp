// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file attributes.hpp
/// @brief Per-point attributes (colours, intensities, labels) carried from a cloud to new points: the
/// resampler's output points and a reconstructed mesh's vertices.

#include <Eigen/Core>
#include <functional>
#include <vector>

#include "iires/execution.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief Parameters of interpolateAttributes().
struct AttributeParams {
  int neighbours = 8;  ///< nearest source points each new point draws from (≥ 1)
  /// With the new points' normals: a source point is skipped when the line to it leaves the new point's tangent
  /// plane at more than this angle (degrees): a facing sheet across a thin gap lies straight along the normal,
  /// neighbours on the same smooth sheet near the plane. 90 = off.
  double maxSlopeDeg = 40.0;

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief Whether the source point at @p source lies on the same sheet as the new point at @p target (may give
/// it its values); e.g. IntrinsicRule::acceptPoints. An empty function accepts every neighbour.
using SameSheet = std::function<bool(const Eigen::Vector3d& target, const Eigen::Vector3d& source)>;

/// @brief The attributes of @p source at the points @p targets.
///
/// Each target takes the values of its params.neighbours nearest source points that @p sameSheet accepts and,
/// with @p targetNormals, that lie within params.maxSlopeDeg of its tangent plane (its nearest source point
/// alone when none does), weighted by a Gaussian of the distance whose width is the
/// mean distance to them: colours and scalars are the weighted mean, labels the value with the largest total
/// weight (the smallest such value on a tie). Kinds, names and types are kept.
/// @throws std::invalid_argument for bad params or a source attribute without one value per point.
/// @note Deterministic for any thread count; O(|targets| · k · log |source|) plus the cost of @p sameSheet.
/// @param targetNormals empty, or one unit normal per target
std::vector<PointAttribute> interpolateAttributes(const PointCloud& source, const std::vector<Eigen::Vector3d>& targets,
                                                  const std::vector<Eigen::Vector3d>& targetNormals = {},
                                                  const SameSheet& sameSheet = {}, const AttributeParams& params = {},
                                                  const Execution& exec = {});

}  // namespace iires
