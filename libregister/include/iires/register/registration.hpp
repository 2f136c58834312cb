// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file registration.hpp
/// @brief Scale-free registration without features (paper §5, eq. 11–12; DESIGN §4): resample both clouds to
/// M isotropic points → normalise (centroid, unit RMS radius) → rotation-grid search for the minimum
/// (trimmed) Hausdorff energy, each surviving rotation recentred by a translation search (a partial cloud is
/// also tried at the pose its rim suggests, open_side.hpp) → ICP with scale on the best few → a similarity
/// T_target_source in original units.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "iires/register/icp.hpp"
#include "iires/register/rotation_grid.hpp"
#include "iires/register/rotation_search.hpp"
#include "iires/outliers.hpp"
#include "iires/resample.hpp"
#include "iires/types.hpp"

namespace iires::reg {

/// @brief Parameters of registerClouds().
struct RegistrationParams {
  std::size_t samples = 1000;  ///< M, points each cloud is resampled to (≥ 50) [paper: around 2000; 1000 is
                               ///< as accurate in the benchmark at half the cost]; an M above the default is
                               ///< capped at the larger input's point count
  RotationGridType grid = RotationGridType::kSo3;  ///< candidate rotations; kEuler is the paper's grid
  int eulerSteps = 24;         ///< Euler grid: steps per angle [24, θ = π/12]
  std::size_t so3Count = 6144; ///< SO(3) grid: rotations (6,144 cover SO(3) within ≈ 11.4°, as 24³ Euler)
  /// Share of each cloud expected to overlap the other: 0 = unknown, estimated (the default: the search
  /// scores every level of searchOverlaps, the ICP and the choice among candidates use the fractional RMSD);
  /// in (0, 1] = known (a hint the user is sure of): the energy and the ICP are trimmed to it, 1 = whole clouds
  double overlap = 0.0;
  /// Overlap levels the search scores when overlap = 0 (each in (0, 1], at most 16); the smallest is also the
  /// ICP's minOverlap
  std::vector<double> searchOverlaps{1.0, 0.8, 0.6};
  double searchOverlapExponent = 2.0;  ///< λ of the search's penalty (f_max / f)^λ (≥ 0)
  double fitOverlapExponent = 2.5;     ///< λ of the ICP's and the final score's fractional RMSD (≥ 0):
                                       ///< smaller lets a cut source slide along the target, larger takes in
                                       ///< pairs beyond the overlap of two partial scans [Phillips et al.: 3]
  bool estimateScale = true;   ///< false: the scale is fixed to 1 (rigid registration)
  std::size_t icpCandidates = 12;  ///< distinct search candidates refined by ICP (≥ 1): partial scans shift
                                  ///< the normalised frames, so the true rotation is often not the search's best
  int screenIterations = 8;    ///< ICP iterations per candidate before scoring; the best continues (≥ 1)
  double ambiguityTolerance = 0.05;  ///< another ICP result within this relative score of the best but
                                     ///< ≥ 10° away marks the result ambiguous (symmetric shape)
  double planarityThreshold = 1e-3;  ///< smallest/largest covariance eigenvalue below this → planar flag
  RotationSearchParams search;  ///< coarse/fine search settings (overlap and seed are set from here)
  IcpParams icp;               ///< ICP settings (overlap and estimateScale are set from here)
  ResampleParams resample = defaultResample();  ///< resampler settings (targetCount and seed are set from here)
  /// A cloud with more than this × M points is first cut to a seeded random subset of that many (cheap; the
  /// resampler then evens out the density). 0 = never. [4: the surface stays sampled twice as finely as M]
  std::size_t maxInputPerSample = 4;
  /// Outliers of each working cloud (after the thinning), as in the resampler: pulled back onto the surface
  /// (default), removed, or kept. Points far from the object would otherwise move the centroid and the RMS
  /// radius of the normalisation; they are removed in every mode but keep.
  OutlierParams outliers;
  std::uint64_t seed = 0;      ///< resampling tie-breaks and the search's visiting order

  /// @brief Resampler settings tuned for registration: the resampler's density initialisation only (weighted
  /// sample elimination to M: blue-noise, density-independent), without pre-processing, intrinsic control,
  /// edge passes or Lloyd relaxation. The Hausdorff search needs M evenly spread points, not a polished
  /// sampling; the full pipeline costs ≈ 3× more for the same success rate (BENCHMARKS.md). Use
  /// ResampleParams{} for noisy scans with outliers.
  static ResampleParams defaultResample();
  /// @throws std::invalid_argument when a field is out of range.
  void validate() const;
};

/// @brief A similarity transform with diagnostics (DESIGN §4 step 6).
struct RegistrationResult {
  Eigen::Matrix4d T_target_source = Eigen::Matrix4d::Identity();  ///< (sR | t): source → target, original units
  double scale = 1.0;                                    ///< s
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< R
  double rotationAngleDeg = 0;                           ///< angle of R, degrees
  Eigen::Vector3d rotationAxis = Eigen::Vector3d::UnitZ();  ///< axis of R (unit)
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  ///< t
  double rmse = 0;              ///< RMS distance of the ICP's (trimmed) matched pairs, target units
  double hausdorff = 0;         ///< symmetric Hausdorff distance of the aligned resampled clouds, target units
  double hausdorffTrimmed = 0;  ///< the same, trimmed to the overlap (= hausdorff when overlap = 1)
  double overlapShare = 0;      ///< share of the aligned source samples within one mean sample spacing of a
                                ///< target sample (1 = the source lies entirely on the target)
  double sourceOverlap = 1;     ///< estimated share of the source that overlaps the target (the ICP's, or the
                                ///< given overlap)
  double targetOverlap = 1;     ///< estimated share of the target that overlaps the source
  double score = 0;             ///< symmetric (fractional) RMS distance of the result, normalised units: lower
                                ///< is better; the candidates are ranked by it
  /// The runner-up: the best refined candidate ≥ 10° away from the result (identity and +∞ score if none)
  Eigen::Matrix4d runnerUpTransform = Eigen::Matrix4d::Identity();
  double runnerUpScore = 0;     ///< its score (0 = none)
  double normalisedEnergy = 0;  ///< search energy E of the chosen candidate (normalised units)
  std::string grid;             ///< "so3" or "euler"
  std::size_t gridSize = 0;     ///< candidates in the grid
  std::size_t bestCandidate = 0;  ///< grid index of the candidate the result came from
  std::size_t candidateRank = 0;  ///< its rank among the refined candidates (0 = lowest energy)
  int icpIterations = 0;        ///< ICP iterations of the chosen candidate
  bool icpConverged = false;    ///< whether that ICP met its tolerance
  std::size_t exactEvaluations = 0, pointQueries = 0;  ///< search cost
  std::size_t fieldQueries = 0;  ///< search cost: distance-field queries of the coarse pass
  bool ambiguous = false;       ///< another clearly different pose fits about as well (symmetry or a plane)
  bool planar = false;          ///< a cloud is (nearly) planar: mirror poses fit equally well
  std::string ambiguityReason;  ///< why ambiguous is set ("" otherwise)
  double secondBestScoreRatio = 0;  ///< runnerUpScore / score (≥ 1; 0 = none)
  std::size_t sourcePoints = 0, targetPoints = 0, samples = 0;  ///< input sizes, M (as used)
  std::size_t samplesRequested = 0;  ///< M as requested (samples is capped at the larger input, ≥ the default)
  double sourceRadius = 0, targetRadius = 0;  ///< RMS radii used for the normalisation, original units
  std::size_t sourceWorkingPoints = 0, targetWorkingPoints = 0;  ///< points given to the resampler (after thinning)
  /// Resampled points dropped as non-finite or far outside their input's bounding box (a failed surface
  /// projection); normally 0
  std::size_t strayDropped = 0;
  std::size_t outliersFound = 0;  ///< outliers found in the two working clouds (RegistrationParams::outliers)
  /// Rim points of the resampled clouds (open_side.hpp: the boundary of a partial scan; 0 for a closed
  /// surface); the search also tries the poses their directions suggest
  std::size_t sourceRimPoints = 0, targetRimPoints = 0;
  /// Wall time per stage: validate, thin, resample_source, resample_target, normalise, search, icp, evaluate, total
  std::vector<StageTime> timings;

  /// @brief The report as a JSON object: transform (4 rows), scale, rotation, rotation_angle_deg, translation,
  /// rmse, hausdorff, best_candidate, icp_iterations, ambiguous, timings, ...
  std::string toJson() const;
};

/// @brief Estimate T_target_source mapping @p source onto @p target (same object; any rotation, scale,
/// translation and sampling density).
/// @throws InputError when a cloud is unusable: empty, NaN/Inf, fewer than 10 distinct points, collinear
/// (messages start with "source: " or "target: "); std::invalid_argument for bad parameters.
/// @note Deterministic: same inputs and parameters give the same result for any thread count.
/// @param exec threads and progress reports (stages "resample source", "resample target", "search", "icp")
RegistrationResult registerClouds(const PointCloud& source, const PointCloud& target,
                                  const RegistrationParams& params = {}, const Execution& exec = {});

/// @brief Apply a 4×4 similarity to a cloud (normals are rotated and stay unit).
PointCloud transformCloud(const PointCloud& cloud, const Eigen::Matrix4d& T);

/// @brief The matrix as text: 4 lines of 4 numbers (17 significant digits), as --transform writes it.
std::string formatTransform(const Eigen::Matrix4d& T);

}  // namespace iires::reg
