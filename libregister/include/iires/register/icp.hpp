// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file icp.hpp
/// @brief Trimmed point-to-point ICP with optional scale (Umeyama's closed form in every iteration;
/// trimming after Chetverikov et al.'s TrICP for partial overlap) — DESIGN §4 step 5.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "iires/execution.hpp"
#include "iires/knn.hpp"

namespace iires::reg {

/// @brief Parameters of similarityIcp().
struct IcpParams {
  int maxIterations = 50;      ///< iterations at most (≥ 1)
  bool estimateScale = true;   ///< estimate a similarity (sR | t); false = rigid (R | t)
  double overlap = 1.0;        ///< share of source points matched each iteration (the nearest ones), (0, 1]
  double reverseOverlap = 0.0; ///< bidirectional: the same for the target points, (0, 1]; 0 = as overlap
  /// Estimate the overlap in every iteration instead (trimmed ICP with unknown overlap, Chetverikov et al.
  /// 2005): per direction keep the k nearest pairs that minimise the fractional RMSD, see fractionalRmsd(),
  /// with k ≥ ⌈minOverlap·n⌉; @ref overlap is then ignored
  bool estimateOverlap = false;
  double minOverlap = 0.4;     ///< smallest overlap considered by the estimate, (0, 1]
  double overlapExponent = 1.5;  ///< λ of the estimate's penalty (n/k)^λ (≥ 0)
  bool bidirectional = false;  ///< also match every target point to its nearest source point (both sets
                               ///< trimmed to overlap): a part missing from either cloud cannot pull the fit
  double tolerance = 1e-6;     ///< stop when the update's rotation angle (rad) and relative translation and
                               ///< scale change all fall below this (> 0)

  /// @throws std::invalid_argument when a field is out of range.
  void validate() const;
};

/// @brief Per-point rim flags of the source and the target (OpenSide::rim), either may be null.
struct IcpRims {
  const std::vector<std::uint8_t>* source = nullptr;
  const std::vector<std::uint8_t>* target = nullptr;
};

/// @brief What similarityIcp() found.
struct IcpResult {
  Eigen::Matrix4d T_target_source = Eigen::Matrix4d::Identity();  ///< maps source into target coordinates
  double scale = 1.0;        ///< s of T = (sR | t)
  int iterations = 0;        ///< iterations run
  bool converged = false;    ///< the tolerance was met before maxIterations
  double rmse = 0.0;         ///< RMS distance of the matched (trimmed) pairs at the result, target units
  std::size_t matched = 0;   ///< pairs used in the last iteration
  double overlap = 1.0;        ///< share of the source points matched in the last iteration
  double reverseOverlap = 1.0; ///< bidirectional: share of the target points matched (else 1)
};

/// @brief The fractional RMSD of one set of residuals (Phillips, Liu & Tomasi 2007): the k nearest of n
/// pairs fit with RMS r_k = √(mean of the k smallest d²), scored r_k·(n/k)^λ so that dropping pairs pays only
/// when they are clearly worse than the rest; min over k ≥ ⌈minOverlap·n⌉.
struct FractionalFit {
  double score = 0;      ///< the minimum of r_k·(n/k)^λ
  double rms = 0;        ///< r_k at the minimum
  std::size_t keep = 0;  ///< k at the minimum
};

/// @brief fractionalRmsd of the squared distances @p sortedD2 (ascending, non-empty).
/// @param floor r_k below it counts as @p floor: residuals at rounding level (identical clouds) are all
/// "exact", and then every pair is kept
/// @throws std::invalid_argument for an empty list, minOverlap outside (0, 1] or a negative exponent.
FractionalFit fractionalRmsd(const std::vector<double>& sortedD2, double minOverlap, double exponent,
                             double floor = 0.0);

/// @brief Align @p source to @p target starting from @p init: each iteration matches every transformed source
/// point to its nearest target point, keeps the ⌈overlap·n⌉ closest pairs and solves for the similarity (or
/// rigid) transform minimising their squared distances in closed form (Umeyama 1991).
/// @param targetIndex a k-d tree over @p target
/// @throws std::invalid_argument for bad parameters or fewer than 3 source points.
/// @note Deterministic for any thread count (queries per point, then a serial solve).
/// @param sourceIndex (optional) a k-d tree of @p source the caller already has, for the reverse matches of
/// params.bidirectional (else one is built per call)
/// @param rims (optional) the clouds' rim flags (open_side.hpp): a pair whose nearest point lies on the other
/// cloud's rim is left out of the fit (Turk & Levoy's boundary rule): a point beyond that cloud's cut finds the
/// rim as its nearest point, not its counterpart, and such pairs pull the fit's scale and position towards the
/// cut. When fewer than 3 pairs would be left, all are used.
IcpResult similarityIcp(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
                        const KnnIndex& targetIndex, const Eigen::Matrix4d& init, const IcpParams& params,
                        const Execution& exec = {}, const KnnIndex* sourceIndex = nullptr, const IcpRims& rims = {});

/// @brief Closed-form similarity (or rigid) transform minimising Σ‖s·R·aᵢ + t − bᵢ‖² (Umeyama 1991).
/// @throws std::invalid_argument when the sizes differ or fewer than 3 pairs are given.
Eigen::Matrix4d umeyamaTransform(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                                 bool withScale);

}  // namespace iires::reg
