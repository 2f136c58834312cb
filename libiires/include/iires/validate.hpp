// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file validate.hpp
/// @brief Input validation (DESIGN §3 step 1): the checks every algorithm runs before it starts.

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "iires/knn.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief What validateCloud found and changed.
struct ValidationReport {
  std::size_t inputPoints = 0;       ///< points before validation
  std::size_t duplicatesMerged = 0;  ///< exact duplicate positions removed
  std::size_t outputPoints = 0;      ///< points after validation
};

/// @brief Largest coordinate magnitude validateCloud accepts: beyond it squared distances and moments overflow.
constexpr double kMaxCoordinate = 1e30;
/// @brief Smallest extent (largest side of the bounding box) validateCloud accepts for a cloud of distinct points.
constexpr double kMinExtent = 1e-30;
/// @brief Coordinates of smaller magnitude are set to 0 by validateCloud (their squares would underflow).
constexpr double kTinyCoordinate = 1e-150;

/// @brief Check a cloud and merge exact duplicates (keeps the first occurrence; normals follow their points).
/// @param minPoints fewest distinct points the caller's method needs (>= 1)
/// @param what how to name the cloud in messages (usually the file path)
/// @throws InputError when the cloud is empty, holds NaN/Inf coordinates (the first bad index is named) or a
/// coordinate beyond ±kMaxCoordinate, spans less than kMinExtent (but more than 0),
/// has fewer than @p minPoints distinct points, or all its points are collinear (the second eigenvalue of
/// the covariance is at most 1e-12 times the first; one or two distinct points are collinear too).
/// @note Normals holding NaN/Inf, or not one per point, are dropped (cleared) rather than rejected.
/// Coordinates of magnitude below kTinyCoordinate are set to 0 before duplicates are merged.
/// O(n): duplicates are found by a radix sort of coordinate hashes. The order of the kept points is unchanged.
/// @param threads threads for the per-point checks (0 = all cores); the result does not depend on it.
ValidationReport validateCloud(PointCloud& cloud, std::size_t minPoints, const std::string& what = "input",
                               int threads = 0);

/// @brief Reject a cloud that fills a volume instead of sampling a surface: over three quarters of the
/// neighbourhoods probed (256 of an even subsample of at most 20,000 points) are three-dimensional — surface
/// variation λ₀/Σλ above 0.1 — at 16, 64 and 256 neighbours and at a tenth of the subsample (up to 2,048). A noisy
/// scan is flat at one of these scales (a shell with noise of 12 % of its radius at the largest). Clouds under
/// 1,000 points pass unchecked: a knot or a pipe sampled with 500 looks three-dimensional at 16 neighbours.
/// @throws InputError naming @p what and the share of three-dimensional neighbourhoods.
/// @param threads threads for the probes (0 = all cores); the result does not depend on it.
void checkSamplesASurface(const std::vector<Eigen::Vector3d>& points, const std::string& what = "input",
                          int threads = 0);

/// @brief The points to keep when a cloud holds points twice, a hair apart (the same scan exported twice and
/// rounded differently, or merged with itself): point i goes when a point of lower index lies within
/// kNearDuplicate of i's distance to its 8th nearest neighbour. Such twins carry no more of the surface than one
/// point, but every spacing measured from nearest neighbours would take the hair for the sampling's step. Only
/// a cloud where at least kDoubledShare of the points have a twin is treated so: in a random sampling of a
/// surface about 0.08 % of the points have a neighbour that close by chance, and that cloud is left as it is.
/// @param table k-NN rows of @p points with at least 9 columns (the point itself first)
/// @return the indices kept, ascending (all of them when the cloud is not doubled)
/// @param threads 0 = all cores; the result does not depend on it
/// @note A point repeated more than 8 times over is kept whole: its 8th neighbour is one of its copies.
std::vector<std::uint32_t> withoutNearDuplicates(const NeighbourTable& table, const std::vector<Eigen::Vector3d>& points,
                                                 int threads = 0);

/// @brief Relative distance under which withoutNearDuplicates() merges two points (of the 8th neighbour's).
constexpr double kNearDuplicate = 0.01;
/// @brief Share of the points with a twin from which withoutNearDuplicates() takes a cloud for doubled.
constexpr double kDoubledShare = 0.01;

/// @brief withoutNearDuplicates() on @p cloud itself (its own k-NN search; points and normals kept alike, in
/// order). @return the number of points merged.
std::size_t mergeNearDuplicates(PointCloud& cloud, int threads = 0);

}  // namespace iires
