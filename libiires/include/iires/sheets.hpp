// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file sheets.hpp
/// @brief The sheet rule (DESIGN §3 step 6, scope of the invariant): which of a point's Euclidean neighbours
/// lie on its own sheet of the surface. Where two sheets come within a few spacings of each other (a thin
/// plate, a fold, fingers that nearly touch, a shell inside a shell) a k-NN neighbourhood spans both; every
/// stage that fits, averages or links over neighbours would then pull the sheets together. The rule gives
/// the first graph on the raw cloud — before any stage moves a point — from which the normals are estimated
/// and oriented, and which every later stage reads (outliers, denoising, the MLS kernel widths, the geodesic
/// graph) instead of the straight-line neighbourhood.
///
/// Two tests. The normals' fits take a point's neighbours within a height of its tangent plane (sameSheet,
/// sheetTolerance: noise, the normals' error and the sheet's bend). The final rule, on the settled normals,
/// parts a pair only on positive evidence of a gap between them (acrossGap): two near-parallel planes, each
/// point beyond the other's, offset by more than noise can explain — so creases, bends and noise keep their
/// rows, and the straight-line neighbourhood stays wherever no second sheet is near.

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

#include "iires/execution.hpp"
#include "iires/knn.hpp"

namespace iires {

/// @brief Parameters of the sheet rule.
struct SheetParams {
  /// Neighbours (besides the point) of the first normal: the plane through the point and two of its 6
  /// nearest that most of them support (the minority on another sheet, where two are close, does not).
  int firstNeighbours = 16;
  int pcaNeighbours = 16;        ///< neighbours (besides the point) of the refits, those on the point's sheet
  int refits = 1;                ///< refits over the same-sheet neighbours by the last normals
  double heightSpacings = 1.0;   ///< height tolerance, in local spacings (a gap must exceed ≈ 2 of them)
  double heightSlope = 0.1;      ///< plus this × the pair's distance (normal error, curvature; ≈ 6°)
  /// The final rule (the rows every later stage reads), with the normals settled: a pair is apart when it
  /// lies across a gap (acrossGap): near-parallel planes (within gapAngleDeg) on opposite sides of each
  /// other, offset by at least gapSpacings local spacings. A point whose whole row lies within the first
  /// tolerance of its plane (no other sheet near) keeps its row.
  double gapSpacings = 1.25;
  double gapAngleDeg = 25.0;
  double maxNormalAngleDeg = 120.0;  ///< oriented normals: pairs whose normals differ by more are apart
  std::size_t minNeighbours = 3;  ///< a row left with fewer same-sheet neighbours keeps its Euclidean row

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief What separateSheets() found.
struct SheetReport {
  std::size_t points = 0;
  std::size_t crossPairs = 0;    ///< neighbour pairs (directed table entries) found on different sheets
  std::size_t nearPoints = 0;    ///< points with a Euclidean neighbour on another sheet
  std::size_t nearZones = 0;     ///< near-contact zones: connected groups (same-sheet graph) of such points
  std::size_t sheetPairs = 0;    ///< zones grouped by the pair of sheets (components of the graph) they face
  /// Given normals only: the share of near-parallel neighbours on one plane whose normals point opposite ways
  /// (next to none when the normals are consistently oriented), and how many given normals were turned over
  /// because that share was above kMaxOrientationConflicts (normals.hpp; 0 when they were kept as given).
  double orientationConflicts = 0;
  std::size_t reorientedNormals = 0;
  double spacing = 0;            ///< median local spacing
  double seconds = 0;

  /// @brief The report as a one-line JSON object.
  std::string toJson() const;
};

/// @brief Unit normals (oriented unless @p givenNormals were given, which are kept, turned over where they were
/// not consistently oriented) and the sheet rule applied to @p table, whose rows are filtered in place
/// (NeighbourTable::filter).
/// @param table neighbour lists of exactly @p points, the point itself included (k ≥ pcaNeighbours + 1)
/// @param normals out: estimated (PCA over same-sheet neighbours, refined once, then oriented by a minimum
/// spanning tree over the same-sheet graph) unless @p givenNormals holds one normal per point (then a unit
/// copy, oriented over the same-sheet graph when the given ones were not consistently oriented: see
/// kMaxOrientationConflicts in normals.hpp)
/// @param near (optional) out: per point, 1 where a neighbour was found on another sheet
/// @param exec threads (the result does not depend on them)
/// @note O(n k). Deterministic for any thread count.
SheetReport separateSheets(const std::vector<Eigen::Vector3d>& points, NeighbourTable& table,
                           std::vector<Eigen::Vector3d>& normals, const SheetParams& params = {},
                           const Execution& exec = {}, const std::vector<Eigen::Vector3d>* givenNormals = nullptr,
                           std::vector<std::uint8_t>* near = nullptr);

/// @brief The distance-dependent part of the sheet tolerance for a pair @p d apart with unit normals @p np,
/// @p nq: slope·d for the normals' error, plus d·sin(θ/2) for the bend between them (θ the angle between the
/// unoriented normals): on a sheet curving with radius R, q lies ≈ d·θ/2 off p's tangent plane, while two
/// sheets facing each other across a gap are parallel and get no more than slope·d.
inline double sheetTolerance(double slope, double d, const Eigen::Vector3d& np, const Eigen::Vector3d& nq) {
  return d * (slope + std::sqrt(std::max(0.0, 0.5 * (1.0 - std::abs(np.dot(nq))))));
}

/// @brief The sheet test for one pair p, q with unit normals @p np, @p nq: each lies within @p tolerance of
/// the other's tangent plane, and (oriented normals) the normals differ by at most acos(@p minNormalDot) (−1
/// for unoriented normals: then only the heights count). The loose test of the normals' fits.
inline bool sameSheet(const Eigen::Vector3d& p, const Eigen::Vector3d& np, const Eigen::Vector3d& q,
                      const Eigen::Vector3d& nq, double tolerance, double minNormalDot = -1.0) {
  const Eigen::Vector3d d = q - p;
  return std::abs(np.dot(d)) <= tolerance && std::abs(nq.dot(d)) <= tolerance && np.dot(nq) >= minNormalDot;
}

/// @brief Whether p and q (unit normals @p np, @p nq, either orientation) lie on two sheets across a gap:
/// their tangent planes are near parallel (|n_p·n_q| ≥ @p minParallelCos), each point lies on the far side
/// of the other's plane — q above p's plane and p below q's, n_q turned to agree with n_p — and the mean
/// offset is at least @p minGap (a normal tilted by the fit shortens one offset and lengthens the other). One surface, where it bends or folds over a crease, puts each point on the same side
/// of the other's plane (or turns the normals apart); noise and a normal's error offset the planes by less
/// than the gap.
inline bool acrossGap(const Eigen::Vector3d& p, const Eigen::Vector3d& np, const Eigen::Vector3d& q,
                      const Eigen::Vector3d& nq, double minGap, double minParallelCos) {
  const double c = np.dot(nq);
  if (std::abs(c) < minParallelCos) return false;
  const Eigen::Vector3d d = q - p;
  const double hp = np.dot(d), hq = c >= 0 ? -nq.dot(d) : nq.dot(d);
  return hp * hq < 0 && std::abs(hp - hq) >= 2 * minGap;
}

}  // namespace iires
