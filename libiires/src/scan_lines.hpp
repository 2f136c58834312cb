// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The geodesic graph's k-NN lists (geodesic.cpp) and their widening across scan lines.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "iires/knn.hpp"

namespace iires::detail {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
constexpr float kInf = std::numeric_limits<float>::infinity();

/// The k nearest neighbours of every point (internal order, k per point, padded with kNone / kInf), each point's
/// local spacing rho (distance to its spacingNeighbour-th neighbour) and unit normal (zero if unknown).
struct NeighbourLists {
  std::vector<std::uint32_t> index;
  std::vector<float> distance;
  std::vector<float> rho;
  std::vector<Eigen::Vector3d> line;  ///< where the k nearest lie on a line (onALine): its direction, else zero
  std::vector<float> across;          ///< on a scan line: the distance to the nearest point off it, else 0
  std::vector<Eigen::Vector3f> normal;
  bool givenNormals = false;
};

/// Scatter matrix of @p p and the @p w points @p list of @p pts about their mean.
Eigen::Matrix3d scatter(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& p, const std::uint32_t* list,
                        std::size_t w);

/// Whether points with scatter eigenvalues @p ev (ascending) lie on a line: their spread across it (the square
/// root of the middle over the largest eigenvalue) under a quarter of the spread along it.
inline bool onALine(const Eigen::Vector3d& ev) { return ev(1) < 0.0625 * ev(2); }

/// A sampling dense along scan lines and sparse across them (a lidar's) gives a point's k nearest all on its own
/// line: the graph then links neighbouring lines only where noise brings two within reach, and the distances
/// between them detour along the lines. Where the k nearest are collinear (lists.line), the search widens to 8·k
/// points and the list keeps the k − k/2 nearest and the k/2 nearest of those off the line (farther from it than
/// half the list's reach and than three times the spread across it), sorted by distance; the local spacing rho
/// becomes the nearest such distance when larger (the spacing across the lines bounds the edge lengths), lists.across
/// records it, and the PCA normal is the widened list's. A sampling even in every direction never meets the test,
/// and an object that is a line (a wire) has no points off it: both keep their lists. @p zp the points (internal
/// order), @p index a k-d tree over them.
void acrossScanLines(const std::vector<Eigen::Vector3d>& zp, const KnnIndex& index, std::size_t k, NeighbourLists& lists,
                     int threads);

}  // namespace iires::detail
