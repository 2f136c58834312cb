// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file rotation_search.hpp
/// @brief The global rotation search of the registration (paper eq. 11–12, DESIGN §4 step 3): over a grid of
/// candidate rotations R, minimise the (trimmed) Hausdorff energy E(R) = max(h(R·S → T), h(Rᵀ·T → S))
/// between two normalised clouds S and T; the best rotations are recentred by a small search over a
/// translation t (E(R, t)), since partial clouds normalise on biased centroids. With one overlap f,
/// h = h_f is the trimmed Hausdorff distance; with several (unknown overlap), each direction takes
/// min_f (f_max / f)^λ · h_f — its own overlap estimate.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "iires/execution.hpp"
#include "iires/knn.hpp"

namespace iires::reg {

/// @brief Parameters of the rotation search.
struct RotationSearchParams {
  /// Trimmed Hausdorff: the shares of points that may overlap, each in (0, 1]; {1} = plain, {f} = known
  /// overlap f, several = the overlap is estimated among them per direction and candidate (at most 16)
  std::vector<double> overlaps{1.0};
  double overlapExponent = 2.0;   ///< λ of the penalty (f_max / f)^λ of a smaller overlap (≥ 0)
  std::size_t coarsePoints = 96;  ///< points of each cloud used by the coarse pass (≥ 8)
  /// The coarse pass reads distances from a distance field of each cloud (distance_field.hpp) instead of its
  /// k-d tree: fieldCells cells along the longest side of the cloud's box grown by fieldMargin (normalised
  /// units) on each side. An approximation within one cell diagonal, O(1) per point. 0 = query the k-d trees
  std::size_t fieldCells = 32;
  double fieldMargin = 1.0;       ///< margin of the fields' grids, normalised units (≥ 0)
  /// The coarse pass scores each grid rotation at several translations and keeps the best (a partial cloud's
  /// centroid is biased, so at the true rotation the normalised clouds are offset): t = 0 and the lattice
  /// points of step coarseOffsetStep within coarseOffsetRadius (normalised units; 0.4 and 0.4 = the 6 axis
  /// offsets), then coarseOffsetRefineLevels pattern moves of ±step/2, ±step/4, … along each axis. The offset
  /// found is where the translation search of a survivor starts. Radius 0 = t = 0 only
  double coarseOffsetRadius = 0.4;
  double coarseOffsetStep = 0.4;     ///< lattice step of the coarse offsets (> 0)
  int coarseOffsetRefineLevels = 1;  ///< pattern moves around the best coarse offset, step halved each (≥ 0)
  /// Open sides (open_side.hpp) of the normalised clouds: unit vectors towards their rims, zero for a closed
  /// cloud. A partial cloud's normalised frame is offset from the whole's towards the part, i.e. away from its
  /// rim, and shrunk: the coarse pass also scores each rotation R at the offsets t = −a·R·u_S + b·u_T,
  /// a, b ∈ {0, openSideShift} (those with an open side), with the scale (1 − κa) / (1 − κb), κ =
  /// openSideScaleSlope. An offset along the rim's direction instead of the nearest lattice point: the pose a
  /// cut cloud needs is found without a finer lattice
  Eigen::Vector3d sourceOpenSide = Eigen::Vector3d::Zero();
  Eigen::Vector3d targetOpenSide = Eigen::Vector3d::Zero();  ///< see sourceOpenSide
  double openSideShift = 0.4;       ///< a and b above, normalised units (≥ 0; 0 = the open sides are not used)
  double openSideScaleSlope = 0.3;  ///< κ above (≥ 0, κ·openSideShift < 1) [40 % cuts: σ ≈ 1 − 0.3·|τ|]
  std::size_t coarseKeep = 96;    ///< best coarse candidates passed on to the exact energy (≥ 1): the coarse
                                  ///< energy (subsets, few offsets) ranks a partial scan's true rotation lower
  std::size_t fullKeep = 48;      ///< best exact candidates kept for the selection of distinct ones (≥ 1)
  std::size_t keep = 5;           ///< distinct candidates returned, best first (≥ 1)
  double minSeparationDeg = 25.0; ///< returned candidates differ pairwise by at least this rotation angle
  int refineLevels = 0;           ///< local refinement: step halvings around each returned candidate (0 = off;
                                  ///< the registration's ICP refines every candidate instead)
  double refineStepDeg = 5.0;     ///< first local step (≈ half the grid spacing), degrees (> 0)
  /// Translation search around each coarse survivor: partial clouds have biased centroids, so at the true
  /// rotation their normalised frames are offset (by up to ≈ 0.7 RMS radii for a 20 % cut on each side).
  /// Offsets on a cubic lattice of this step within this radius (normalised units) are scored by the energy
  /// on translationPoints of each cloud, the best refined by halving the step translationRefineLevels times.
  /// Radius 0 = rotation only (t = 0, s = 1; the coarse offsets then only rank the rotations).
  double translationRadius = 0.8;
  std::size_t translationPoints = 48;  ///< points of each cloud used by the translation search (≥ 8)
  /// Scales s of the source (s·R·S + t) tried by the translation search, each > 0: a cut shrinks a cloud's
  /// RMS radius, so the normalised clouds differ in scale as well. {1} = translation only
  std::vector<double> translationScales{1.0};
  double translationStep = 0.4;     ///< lattice step of the translation search (> 0)
  int translationRefineLevels = 2;  ///< step halvings of the local translation refinement (≥ 0)
  std::uint64_t seed = 0;         ///< order in which points are visited (early exits come early in random order)

  /// @throws std::invalid_argument when a field is out of range.
  void validate() const;
};

/// @brief One result of the search.
struct RotationCandidate {
  std::size_t gridIndex = 0;                               ///< index in the grid
  Eigen::Matrix3d gridRotation = Eigen::Matrix3d::Identity();  ///< the grid rotation
  double gridEnergy = 0;                                   ///< E at the grid rotation and its offset
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  ///< after local refinement
  double energy = 0;                                       ///< E after local refinement (≤ gridEnergy)
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   ///< offset t of the pose s·R·S + t (translation search)
  double scale = 1.0;                                      ///< scale s of that pose (translation search)
  double sourceOverlap = 1, targetOverlap = 1;  ///< overlap levels chosen at that energy (S → T, T → S)
};

/// @brief The search's answer and its cost.
struct RotationSearchResult {
  std::vector<RotationCandidate> candidates;  ///< up to keep distinct candidates, lowest energy first
  std::size_t gridSize = 0;                   ///< candidates in the grid
  std::size_t exactEvaluations = 0;           ///< full-energy evaluations (incl. refinement), early exits incl.
  std::size_t pointQueries = 0;               ///< nearest-neighbour (k-d tree) queries in total
  std::size_t fieldQueries = 0;               ///< distance-field queries in total (the coarse pass)
  double seconds = 0;                         ///< wall time
};

/// @brief Holds the two normalised clouds and a k-d tree on each, built once; evaluates E and runs the search.
class RotationSearch {
 public:
  /// @param source normalised source S (centroid at the origin, unit RMS radius), ≥ 3 points
  /// @param target normalised target T, ≥ 3 points
  /// @throws std::invalid_argument for bad parameters or too few points.
  /// @param exec threads, and progress reports of search() as stage "search" (the coarse pass over the grid is
  /// most of it)
  RotationSearch(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
                 const RotationSearchParams& params = {}, const Execution& exec = {});
  ~RotationSearch();
  RotationSearch(const RotationSearch&) = delete;
  RotationSearch& operator=(const RotationSearch&) = delete;

  /// @brief E(R) over all points, eq. (11); +∞ once it certainly exceeds @p bound.
  /// @param[out] sourceOverlap, targetOverlap if not null and E is finite: the overlap level each direction chose
  /// @note Thread-safe.
  double energy(const Eigen::Matrix3d& rotation, double bound = std::numeric_limits<double>::infinity(),
                double* sourceOverlap = nullptr, double* targetOverlap = nullptr) const;

  /// @brief E(R, t, s) = max(h(s·R·S + t → T), s·h(Rᵀ(T − t)/s → S)): the energy at a pose with a
  /// translation and a scale (@p scale > 0, else std::invalid_argument).
  /// @note Thread-safe.
  double energy(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation, double scale = 1.0,
                double bound = std::numeric_limits<double>::infinity(), double* sourceOverlap = nullptr,
                double* targetOverlap = nullptr) const;

  /// @brief E(R) on the coarse subsets only, the distances read from the distance fields (the k-d trees when
  /// fieldCells = 0): the coarse pass's energy at t = 0, s = 1.
  double coarseEnergy(const Eigen::Matrix3d& rotation,
                      double bound = std::numeric_limits<double>::infinity()) const;

  /// @brief Eq. (12): the best grid rotations. Coarse pass (subset energy on the distance fields, min over the
  /// coarse offsets and the open sides' poses, early exit, all candidates, in parallel) → translation search
  /// around each of the best coarseKeep (subset energy, from its coarse offset) → exact energy of
  /// those at their best translation (early exit against the fullKeep-th best so far) →
  /// distinct candidates (minSeparationDeg apart) → local refinement of each by a shrinking pattern of
  /// axis-angle steps (±h about each axis).
  /// @note Deterministic for any thread count: candidates are processed in fixed blocks, each block with the
  /// bound known before it, and merged in index order (ties → lower grid index).
  RotationSearchResult search(const std::vector<Eigen::Matrix3d>& grid) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace iires::reg
