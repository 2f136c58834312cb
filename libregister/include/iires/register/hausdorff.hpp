// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file hausdorff.hpp
/// @brief Directed, symmetric and trimmed (partial) Hausdorff distances between point sets — the energy of
/// the rotation search (paper eq. 11–12, DESIGN §4 steps 3–4).

#include <Eigen/Core>
#include <cstddef>
#include <limits>
#include <vector>

#include "iires/knn.hpp"
#include "iires/register/distance_field.hpp"

namespace iires::reg {

/// @brief Number of points a trimmed Hausdorff distance may ignore: n − ⌈overlap·n⌉ (at least one point kept).
/// @param n number of points in the "from" set
/// @param overlap share of points expected to have a partner, in (0, 1]; 1 = plain Hausdorff
/// @throws std::invalid_argument when overlap is not in (0, 1].
std::size_t allowedOutliers(std::size_t n, double overlap);

/// @brief Directed (trimmed) Hausdorff distance h_f(A → B): the ⌈f·n⌉-th smallest of the distances from each
/// point of @p from to its nearest point of @p to (f = @p overlap). f = 1 gives max_a min_b ‖a − b‖.
/// @param from the points a (n ≥ 1)
/// @param to a k-d tree over the points b (non-empty)
/// @param overlap f in (0, 1]
/// @param threads 0 = all cores; the result does not depend on it
/// @throws std::invalid_argument for an empty set or an overlap outside (0, 1].
/// @note O(n log m).
double directedHausdorff(const std::vector<Eigen::Vector3d>& from, const KnnIndex& to, double overlap = 1.0,
                         int threads = 0);

/// @brief Symmetric (trimmed) Hausdorff distance max(h_f(A → B), h_f(B → A)).
/// @throws std::invalid_argument for an empty set or an overlap outside (0, 1].
double hausdorffDistance(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                         double overlap = 1.0, int threads = 0);

/// @brief Directed trimmed Hausdorff distance of the rotated set R·A to B with early exit: returns +∞ as soon
/// as more than @p outliers points of R·A lie farther than @p bound from B, i.e. as soon as the result is
/// certainly greater than @p bound. Otherwise returns the exact (outliers+1)-th largest distance.
/// @param from the points a, in the order they are visited (shuffle them so an early exit comes early)
/// @param rotation R applied to every point of @p from before the query
/// @param to a k-d tree over B
/// @param outliers how many of the largest distances to ignore (see allowedOutliers()); < from.size()
/// @param bound the exit threshold (+∞ = none)
/// @param scratch reusable buffer (its content is overwritten)
/// @param[out] visited if not null, receives the number of points queried
/// @note Single-threaded; call it from parallel loops over candidates. Thread-safe (const queries).
double boundedDirectedHausdorff(const std::vector<Eigen::Vector3d>& from, const Eigen::Matrix3d& rotation,
                                const KnnIndex& to, std::size_t outliers, double bound,
                                std::vector<double>& scratch, std::size_t* visited = nullptr);

/// @brief One trimming level of a partial Hausdorff distance whose overlap is not known: the largest
/// @p outliers distances are ignored and the largest remaining one is multiplied by @p penalty.
struct TrimLevel {
  double overlap = 1.0;      ///< f: share of the points expected to have a partner
  std::size_t outliers = 0;  ///< n − ⌈f·n⌉ (see allowedOutliers())
  double penalty = 1.0;      ///< (f_max / f)^λ ≥ 1: a smaller overlap must fit proportionally better
};

/// @brief The trimming levels for a set of @p n points: one per overlap f of @p overlaps (each in (0, 1]),
/// penalty (max(overlaps) / f)^@p exponent. Scored by min over levels of penalty·h_f, the trimmed distance
/// does not drift to the smallest overlap (h_f alone only shrinks as f does) — the criterion of trimmed ICP
/// with unknown overlap (Chetverikov et al. 2005; Phillips et al.'s fractional RMSD, 2007) applied to the
/// Hausdorff quantile.
/// @throws std::invalid_argument for an empty list, an overlap outside (0, 1] or a negative exponent.
std::vector<TrimLevel> trimLevels(std::size_t n, const std::vector<double>& overlaps, double exponent);

/// @brief min over @p levels of penalty·(the (outliers+1)-th largest of √d2) — the partial Hausdorff distance
/// with the overlap estimated among the levels. @p d2 holds squared distances and is reordered.
/// @param[out] level if not null, receives the index of the minimising level (the lowest on ties)
double penalisedQuantile(std::vector<double>& d2, const std::vector<TrimLevel>& levels, std::size_t* level = nullptr);

/// @brief boundedDirectedHausdorff() over several trimming levels: the directed distance of R·A to B scored by
/// penalisedQuantile(). Returns +∞ as soon as every level has more than its outliers farther than
/// bound / penalty (the result is then certainly greater than @p bound).
/// @param levels from trimLevels() for from.size() points; every outliers < from.size()
/// @param[out] level if not null and the result is finite, the index of the minimising level
double boundedPartialHausdorff(const std::vector<Eigen::Vector3d>& from, const Eigen::Matrix3d& rotation,
                               const KnnIndex& to, const std::vector<TrimLevel>& levels, double bound,
                               std::vector<double>& scratch, std::size_t* visited = nullptr,
                               std::size_t* level = nullptr);

/// @brief boundedPartialHausdorff() of the affinely mapped set L·A + @p translation to B (L = @p linear, e.g. a
/// rotation times a scale): the search's energy at a pose with a translation.
double boundedPartialHausdorff(const std::vector<Eigen::Vector3d>& from, const Eigen::Matrix3d& linear,
                               const Eigen::Vector3d& translation, const KnnIndex& to,
                               const std::vector<TrimLevel>& levels, double bound, std::vector<double>& scratch,
                               std::size_t* visited = nullptr, std::size_t* level = nullptr);

/// @brief The same energy with the distances to B read from a DistanceField of B instead of a k-d tree: an
/// approximation (within the field's cell diagonal inside its grid) at O(1) per point. The early exit and
/// the levels work as in the k-d tree version; @p visited counts field queries.
double boundedPartialHausdorff(const std::vector<Eigen::Vector3d>& from, const Eigen::Matrix3d& linear,
                               const Eigen::Vector3d& translation, const DistanceField& to,
                               const std::vector<TrimLevel>& levels, double bound, std::vector<double>& scratch,
                               std::size_t* visited = nullptr, std::size_t* level = nullptr);

}  // namespace iires::reg
