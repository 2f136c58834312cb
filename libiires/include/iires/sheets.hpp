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
/// Test: q is on p's sheet when each lies within a height of the other's tangent plane,
///   |n_p·(q − p)| ≤ τ and |n_q·(p − q)| ≤ τ,  τ = heightSpacings·s + |q − p|·(heightSlope + sin(θ/2)),
/// s the local spacing (mean nearest-neighbour distance); and, with oriented normals, when the normals do not
/// face each other (angle ≤ maxNormalAngleDeg). Across a gap of g ≥ 2.5 spacings the height is ≈ g; on one
/// sheet it is noise, curvature (|q − p|²/2R ≈ |q − p|·θ/2, θ the angle between the normals) and the
/// normals' error (the slope term).

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <vector>

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
  /// The final rule (the rows every later stage reads), with the normals settled: height tolerance
  /// finalHeightSpacings·s + heightSlope·|q − p|, tight so that a normal the fit got a little wrong leaves no
  /// pair across a gap. Two points whose whole rows lie within the first tolerance of their planes (no other
  /// sheet near either) are neighbours without it, so a curved or noisy sheet keeps its rows.
  double finalHeightSpacings = 0.5;
  double maxNormalAngleDeg = 120.0;  ///< oriented normals: pairs whose normals differ by more are apart
  std::size_t minNeighbours = 3;  ///< a row left with fewer same-sheet neighbours keeps its Euclidean row
  int threads = 0;               ///< 0 = all cores; the result does not depend on it

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
  double spacing = 0;            ///< median local spacing
  double seconds = 0;

  /// @brief The report as a one-line JSON object.
  std::string toJson() const;
};

/// @brief Unit normals (oriented unless @p givenNormals were given, which are kept) and the sheet rule
/// applied to @p table, whose rows are filtered in place (NeighbourTable::filter).
/// @param table neighbour lists of exactly @p points, the point itself included (k ≥ pcaNeighbours + 1)
/// @param normals out: estimated (PCA over same-sheet neighbours, refined once, then oriented by a minimum
/// spanning tree over the same-sheet graph) unless @p givenNormals holds one normal per point (then a copy)
/// @note O(n k). Deterministic for any thread count.
SheetReport separateSheets(const std::vector<Eigen::Vector3d>& points, NeighbourTable& table,
                           std::vector<Eigen::Vector3d>& normals, const SheetParams& params = {},
                           const std::vector<Eigen::Vector3d>* givenNormals = nullptr);

/// @brief The distance-dependent part of the sheet tolerance for a pair @p d apart with unit normals @p np,
/// @p nq: slope·d for the normals' error, plus d·sin(θ/2) for the bend between them (θ the angle between the
/// unoriented normals): on a sheet curving with radius R, q lies ≈ d·θ/2 off p's tangent plane, while two
/// sheets facing each other across a gap are parallel and get no more than slope·d.
inline double sheetTolerance(double slope, double d, const Eigen::Vector3d& np, const Eigen::Vector3d& nq) {
  return d * (slope + std::sqrt(std::max(0.0, 0.5 * (1.0 - std::abs(np.dot(nq))))));
}

/// @brief The sheet test for one pair: @p tolerance is τ (absolute units), @p minNormalDot the cosine of the
/// largest normal angle (−1 for unoriented normals: then only the heights count).
inline bool sameSheet(const Eigen::Vector3d& p, const Eigen::Vector3d& np, const Eigen::Vector3d& q,
                      const Eigen::Vector3d& nq, double tolerance, double minNormalDot = -1.0) {
  const Eigen::Vector3d d = q - p;
  return std::abs(np.dot(d)) <= tolerance && std::abs(nq.dot(d)) <= tolerance && np.dot(nq) >= minNormalDot;
}

}  // namespace iires
