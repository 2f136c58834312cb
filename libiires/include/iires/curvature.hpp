// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file curvature.hpp
/// @brief Curvature field and size levels for adaptively isotropic resampling (paper §4.2, eq. 8–10;
/// DESIGN §3 step 8).
///
/// Per input point p this unit computes
///  - η_c(p): the mean angle (radians) between the oriented normal at p and the normals of its k nearest
///    neighbours (eq. 9), scaled by the cloud's median k-NN radius over p's: the angle per length, so a part
///    sampled more sparsely does not read as more curved;
///  - η_s(p): η_c smoothed over the k-NN graph (eq. 8, see CurvatureParams::beta);
///  - a level q ∈ [0, t) from flat (0) to curved (t − 1), by equal-count quantiles of η_s (eq. 10's groups);
///  - a size factor s(p) = c·r_q, the target edge length at p in units of the isotropic length l
///    (l_q = r_q·l, eq. 10), with c a normalisation constant (CurvatureParams::normalize), smoothed across
///    level borders (CurvatureParams::sizeSmoothIterations).

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "iires/execution.hpp"

namespace iires {

/// @brief Parameters of computeCurvature().
struct CurvatureParams {
  int k = 10;             ///< neighbours for eq. 9 and for the eq. 8 smoothing (≥ 3)
  double beta = 0.5;      ///< eq. 8 smoothing weight: η ← (1 − β)·η + β·mean_{k-NN}(η) [paper 0.5], in [0, 1]
  int smoothIterations = 3;  ///< applications of eq. 8 (0 = no smoothing)
  /// Applications of eq. 8 (same k and β) to log s after quantisation, so the size factor changes gradually
  /// across level borders (≈ one output spacing wide when the input is ~10× denser than the output) instead
  /// of jumping by r_q/r_{q+1}; levels stay discrete. 0 = s is exactly c·r_level.
  int sizeSmoothIterations = 10;
  /// Length ratios r_q per level, flat → curved [paper t = 5: 2.0, 1.5, 1.0, 0.8, 0.6]; t = ratios.size().
  /// Must be positive and non-increasing.
  std::vector<double> ratios{2.0, 1.5, 1.0, 0.8, 0.6};
  /// A field whose spread (95th − 5th percentile of η_s) is below this share of its 95th percentile, or
  /// whose 95th percentile is below minCurvature, is treated as uniform: every point gets the level whose
  /// ratio is closest to 1 (a plane or a sphere is not split into arbitrary levels).
  double uniformSpread = 0.35;
  double minCurvature = 1e-3;  ///< radians; below this mean angle everything counts as flat (see above)
  /// Scale the size factors by one constant c so that the area-weighted mean of 1/s² is 1, i.e. the
  /// adaptive layout at length l has about as many samples as the isotropic one. The resampler's count
  /// control still scales l to hit N exactly; this only makes its first guess right.
  bool normalize = true;

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief Per-point curvature, level and size factor.
struct CurvatureResult {
  std::vector<double> eta;          ///< η_c(p), eq. 9, radians, per the cloud's median k-NN radius (see below)
  std::vector<double> smoothedEta;  ///< η_s(p) after eq. 8
  std::vector<int> level;           ///< 0 = flattest … t − 1 = most curved
  std::vector<double> sizeFactor;   ///< s(p) = c·r_level (smoothed across level borders), units of l
  std::vector<double> thresholds;   ///< t − 1 η_s bounds between levels (empty when uniform)
  std::vector<std::size_t> pointsPerLevel;  ///< size t
  std::vector<double> meanEtaPerLevel;      ///< size t (0 for empty levels)
  double normalization = 1.0;       ///< c
  bool uniform = false;             ///< the field was judged uniform (see CurvatureParams::uniformSpread)
  double seconds = 0;               ///< wall time
};

/// @brief η_c (eq. 9): mean angle between n_p and the normals of p's k nearest neighbours.
/// @param normals oriented unit normals, one per point (orientation matters: a flipped neighbour counts π − α)
/// @note O(n k log n). Deterministic for any thread count.
std::vector<double> curvatureField(const std::vector<Eigen::Vector3d>& points,
                                   const std::vector<Eigen::Vector3d>& normals, int k = 10, int threads = 0);

/// @brief Smooth a per-point field by eq. 8: f ← (1 − β)·f + β·mean of f over the k nearest neighbours,
/// @p iterations times (Jacobi updates).
/// @note O(n k log n + iterations·n k). Deterministic for any thread count.
std::vector<double> smoothField(const std::vector<Eigen::Vector3d>& points, std::vector<double> field, int k,
                                double beta, int iterations, int threads = 0);

/// @brief Full pipeline: eq. 9 → eq. 8 → quantisation into t = ratios.size() levels (equal-count quantiles
/// of η_s) → size factors r_q (eq. 10), normalised if asked.
/// @throws std::invalid_argument for bad parameters or normals.size() != points.size().
/// @note O(n k log n + n log n). Deterministic for any thread count.
CurvatureResult computeCurvature(const std::vector<Eigen::Vector3d>& points,
                                 const std::vector<Eigen::Vector3d>& normals, const CurvatureParams& params = {},
                                 const Execution& exec = {});

/// @brief Quantise a field into levels by equal-count quantiles (the part of computeCurvature() after eq. 8).
/// @param[out] thresholds (optional) the levels − 1 bounds: thresholds[j] is the value at rank ⌊(j+1)·n/t⌋
/// of the sorted values, and a value v gets level #{j : thresholds[j] < v} (ties go down)
/// @return level per value, 0 = smallest values. Ties stay in one level, so each level holds ⌊n/t⌋ or
/// ⌈n/t⌉ values when all values differ, and counts are equal up to ties otherwise.
/// @note O(n log n).
std::vector<int> quantileLevels(const std::vector<double>& values, int levels, std::vector<double>* thresholds);

}  // namespace iires
