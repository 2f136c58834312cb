// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file metrics.hpp
/// @brief The measures DESIGN §7 defines, computed one way everywhere: uniformity, geometric error, coverage.

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "iires/types.hpp"

namespace iires {

/// @brief Statistics of each point's nearest-neighbour distance.
struct SpacingStats {
  double mean = 0, min = 0, max = 0;
  double cv = 0;  ///< coefficient of variation std/mean; lower is more uniform
};

/// @brief Nearest-neighbour spacing statistics (brute force below 64 points, k-d tree above).
SpacingStats spacingStats(const std::vector<Eigen::Vector3d>& points, int threads = 0);

/// @brief SpacingStats of given nearest-neighbour distances (population std / mean).
SpacingStats summariseSpacing(const std::vector<double>& nearest);

/// @brief Each point's distance to its nearest neighbour on its own sheet. A neighbour on a facing sheet — the
/// two points' normals within 25° of parallel (either sign) and their offset over 15° out of the point's tangent
/// plane, as across a plate thinner than the spacing — is passed over for the next one (of the 15 nearest; past
/// them, the nearest). Across a crease the normals differ, so neighbours there count. @p normals: one per point
/// (the true surface's where known: a benchmark's measure).
std::vector<double> sheetNeighbourDistances(const std::vector<Eigen::Vector3d>& points,
                                            const std::vector<Eigen::Vector3d>& normals, int threads = 0);

/// @brief The paper's §6.1 length unit l: each point's mean distance to its @p k nearest neighbours (6 in the
/// paper), averaged over the points (0 for fewer than 2 points). Deterministic for any thread count.
double meanNeighbourSpacing(const std::vector<Eigen::Vector3d>& points, int k = 6, int threads = 0);

/// @brief Mean, max and 99th percentile of a set of distances.
struct DistanceStats {
  double mean = 0, max = 0, p99 = 0;
};

/// @brief Exact point-to-triangle-mesh distances (CGAL AABB tree inside).
class MeshDistance {
 public:
  explicit MeshDistance(const TriangleMesh& mesh);
  ~MeshDistance();
  double distance(const Eigen::Vector3d& p) const;
  /// @brief The unit normal of the mesh's face nearest to @p p (the face's winding sets its sign).
  Eigen::Vector3d normal(const Eigen::Vector3d& p) const;
  /// @brief Distances from every point to the mesh, summarised.
  DistanceStats distances(const std::vector<Eigen::Vector3d>& points, int threads = 0) const;
  /// @brief Length of the mesh's bounding-box diagonal.
  double diagonal() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// @brief Coverage: distance from each of @p reference (a dense sampling of the true surface) to the nearest
/// of @p points, summarised. A large p99/max means the points leave holes.
DistanceStats coverage(const std::vector<Eigen::Vector3d>& reference, const std::vector<Eigen::Vector3d>& points,
                       int threads = 0);

/// @brief Length of the bounding-box diagonal of a point set.
double bboxDiagonal(const std::vector<Eigen::Vector3d>& points);

}  // namespace iires
