#pragma once
/// @file icp.hpp
/// @brief Trimmed point-to-point ICP with optional scale (Umeyama's closed form in every iteration;
/// trimming after Chetverikov et al.'s TrICP for partial overlap) — DESIGN §4 step 5.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "iires/knn.hpp"

namespace iires::reg {

/// @brief Parameters of similarityIcp().
struct IcpParams {
  int maxIterations = 50;      ///< iterations at most (≥ 1)
  bool estimateScale = true;   ///< estimate a similarity (sR | t); false = rigid (R | t)
  double overlap = 1.0;        ///< share of source points matched each iteration (the nearest ones), (0, 1]
  bool bidirectional = false;  ///< also match every target point to its nearest source point (both sets
                               ///< trimmed to overlap): a part missing from either cloud cannot pull the fit
  double tolerance = 1e-6;     ///< stop when the update's rotation angle (rad) and relative translation and
                               ///< scale change all fall below this (> 0)
  int threads = 0;             ///< 0 = all cores; the result does not depend on it

  /// @throws std::invalid_argument when a field is out of range.
  void validate() const;
};

/// @brief What similarityIcp() found.
struct IcpResult {
  Eigen::Matrix4d T_target_source = Eigen::Matrix4d::Identity();  ///< maps source into target coordinates
  double scale = 1.0;        ///< s of T = (sR | t)
  int iterations = 0;        ///< iterations run
  bool converged = false;    ///< the tolerance was met before maxIterations
  double rmse = 0.0;         ///< RMS distance of the matched (trimmed) pairs at the result, target units
  std::size_t matched = 0;   ///< pairs used in the last iteration
};

/// @brief Align @p source to @p target starting from @p init: each iteration matches every transformed source
/// point to its nearest target point, keeps the ⌈overlap·n⌉ closest pairs and solves for the similarity (or
/// rigid) transform minimising their squared distances in closed form (Umeyama 1991).
/// @param targetIndex a k-d tree over @p target
/// @throws std::invalid_argument for bad parameters or fewer than 3 source points.
/// @note Deterministic for any thread count (queries per point, then a serial solve).
IcpResult similarityIcp(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
                        const KnnIndex& targetIndex, const Eigen::Matrix4d& init, const IcpParams& params);

/// @brief Closed-form similarity (or rigid) transform minimising Σ‖s·R·aᵢ + t − bᵢ‖² (Umeyama 1991).
/// @throws std::invalid_argument when the sizes differ or fewer than 3 pairs are given.
Eigen::Matrix4d umeyamaTransform(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                                 bool withScale);

}  // namespace iires::reg
