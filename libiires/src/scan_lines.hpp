// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The geodesic graph's k-NN lists (geodesic.cpp), and neighbour rows widened across scan lines (NeighbourTable).

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
  std::vector<float> across;  ///< on a scan line: the distance to the nearest point off it, else 0
  std::vector<Eigen::Vector3f> normal;
  bool givenNormals = false;
};

/// Scatter matrix of @p p and the @p w points @p list of @p pts about their mean.
Eigen::Matrix3d scatter(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& p, const std::uint32_t* list,
                        std::size_t w);

/// Whether points with scatter eigenvalues @p ev (ascending) lie on a line: their spread across it (the square
/// root of the middle over the largest eigenvalue) under a quarter of the spread along it.
inline bool onALine(const Eigen::Vector3d& ev) { return ev(1) < 0.0625 * ev(2); }

/// A sampling dense along scan lines and sparse across them (a lidar's) gives a point's nearest neighbours all on
/// its own line: a fit over them has no extent across it (its normal turns freely about the line), the normals'
/// orientation and the geodesic graph link neighbouring lines only where noise brings two within reach, and kernel
/// widths read from the 8th neighbour do not reach the next line. A point is on a scan line where most of its 16
/// nearest pass the line test (onALine over their own 8 or 16 nearest: a structure, not a chance alignment); its row
/// is then rebuilt from its 8·k nearest (more where the lines are far apart): the point, four of its line's
/// points, then the nearest points of other lines (farther from its line than half the test's reach and than
/// three times the spread across it) from both sides of it, nearest first, k in all — so that every prefix of six
/// entries or more reaches across. A sampling even in every direction never meets the test, and a line with no
/// other line near (a wire standing off a surface) keeps its row.
/// @param rows   k entries per point (the point itself among them, nearest first), @p found per point how many
/// @return per point, the distance to the nearest point off its line where its row was rebuilt, else 0; empty
///         when no row was
std::vector<float> widenAcrossScanLines(const std::vector<Eigen::Vector3d>& points, const KnnIndex& index,
                                       std::size_t k, std::uint32_t* rows, std::uint8_t* found, int threads);

}  // namespace iires::detail
