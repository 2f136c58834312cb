// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file outliers.hpp
/// @brief Outlier detection from non-mutual k-NN relations and pull-back onto the MLS surface
/// (paper §3.1, eq. 4–5; DESIGN §3 step 2).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "iires/execution.hpp"
#include "iires/knn.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief What to do with the detected outliers.
enum class OutlierMode {
  kPull,    ///< project each outlier onto the MLS plane of its nearest non-outlier's neighbourhood (eq. 5)
  kRemove,  ///< drop them
  kKeep,    ///< detect and report only
};

/// @brief Parse "pull" | "remove" | "keep". @throws std::invalid_argument otherwise.
OutlierMode parseOutlierMode(const std::string& name);
/// @brief "pull" | "remove" | "keep".
std::string toString(OutlierMode mode);

/// @brief Parameters of processOutliers(). Defaults in brackets are the paper's where it gives one.
struct OutlierParams {
  OutlierMode mode = OutlierMode::kPull;  ///< pull | remove | keep
  int k = 8;                              ///< the k-NN relation of eq. 4 [8]
  /// A point is *suspect* when it appears in fewer than this many of its k neighbours' k-NN lists
  /// (eq. 4 taken literally would be k: any non-mutual neighbour).
  int minMutual = 5;
  int planeNeighbours = 16;  ///< neighbours whose local plane the suspect's offset is measured against
  /// A suspect is an outlier when its distance to that plane exceeds this many local spacings
  /// (spacing = median over the plane's points of their mean distance to their 6 nearest neighbours).
  double planeThreshold = 2.0;
  /// A suspect is also an outlier when its distance to the plane of its nearest trusted point q (q and its 8
  /// nearest trusted neighbours) exceeds this many local spacings: near tight curvature or thin parts the
  /// plane of 16 points bends towards an outlier or passes between two sheets, q's own small plane does not
  /// (armadillo, 100k points, noise 0.66·l, 2 % outliers at 3–6·l: recall 0.918 → 0.963, false positives
  /// 0 → 0.1 %). Infinity switches the test off.
  double nearPlaneThreshold = 1.5;

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief What processOutliers() found and did.
struct OutlierResult {
  /// keep: the input; pull: the input with each outlier moved onto the surface, or removed where it has no
  /// surface to land on; remove: outliers gone (order kept)
  PointCloud cloud;
  std::vector<std::uint32_t> outliers;  ///< indices (into the input) of the detected outliers, ascending
  std::size_t found = 0;                ///< outliers detected
  std::size_t pulled = 0;               ///< outliers projected back (pull; not those in or beside the plane)
  std::size_t removed = 0;              ///< outliers dropped (remove; pull: those with no surface near)
  double seconds = 0;                   ///< wall time
};

/// @brief Neighbours per point processOutliers() finds (the point itself included): what a table must hold.
std::size_t outlierNeighbours(const OutlierParams& params);

/// @brief Detect outliers and pull them back, remove them or keep them.
///
/// The rule (eq. 4 plus a geometric check): point p is *suspect* when it is in fewer than minMutual of the
/// k-NN lists of its own k nearest neighbours (a non-mutual relation). A suspect is an *outlier* when it
/// also lies off the surface: its distance to the least-squares plane of its planeNeighbours nearest
/// *trusted* (non-suspect) points exceeds planeThreshold local spacings, or its distance to the plane of the
/// nearest of them (with its 8 nearest trusted neighbours) exceeds nearPlaneThreshold local spacings; any
/// point beyond twice planeThreshold is an outlier too (a small cluster of outliers can be mutual among
/// itself), and so is an *isolated* point: off a sheet of its neighbours, with a mean distance to its 6 nearest
/// neighbours over 10 times the 90th percentile of that distance over the cloud, or over 3 times when three in
/// four of its neighbours are as sparse and they fill space around it (local dimension over 2.6: background
/// clutter; a separate object sampled sparsely is a surface, of dimension about 2). The literal eq. 4 (any
/// non-mutual neighbour) flags ordinary points where the density changes —
/// those points are non-mutual too but lie on their neighbours' plane, so the second test clears them; an
/// outlier moved 3–6 spacings off the surface is non-mutual (the surface points' own neighbours are all
/// closer) and far from the plane. With a finite nearPlaneThreshold a flagged point is cleared again when it lies
/// on a sheet: within nearPlaneThreshold of the plane of one of its nearest trusted points and its 8 nearest
/// trusted neighbours, or on a plane through it that most of its planeNeighbours nearest share, around it (beside
/// a crease every fitted plane spans both faces, while the point's own face still holds its side's points).
///
/// Pull (eq. 5): an outlier o is moved to o + n_a n_aᵀ (a(q) − o), where q is its nearest trusted point
/// (mutual and within planeThreshold of its plane; any non-outlier when fewer than planeNeighbours exist) and
/// (a(q), n_a) the θ-weighted plane (eq. 1–2) of q and its planeNeighbours nearest trusted points (h = the
/// distance to the farthest of them, so the plane is stable under noise); its normal becomes n_a, oriented
/// like q's normal when the input has normals. An isolated point has no surface to land on and is removed
/// instead, and so is an outlier whose projection lands more than 2h from a(q), beyond where the plane stands
/// for the surface. An outlier no farther from the plane than twice its points' RMS distance stays where it is,
/// and so does one beside the plane's points rather than above them (the move under half its distance from q:
/// a curved surface may bend that far from the plane past its points).
/// @throws InputError when the cloud is empty, holds NaN/Inf, or has fewer than planeNeighbours + 1
/// points; std::invalid_argument for bad parameters.
/// @param table (optional) neighbour lists of exactly input.points with k ≥ outlierNeighbours(params),
/// borrowed, to save the k-NN search
/// @note O(n k log n). Deterministic for any thread count.
OutlierResult processOutliers(const PointCloud& input, const OutlierParams& params = {}, const Execution& exec = {},
                              const NeighbourTable* table = nullptr);

/// @brief @p cloud with its outliers pulled back or removed as params.mode says: the cloud itself for kKeep or
/// when it has too few points for the test (outlierNeighbours()). @p found, when given, adds the outliers found.
PointCloud cleanOutliers(const PointCloud& cloud, const OutlierParams& params, const Execution& exec = {},
                        std::size_t* found = nullptr);

}  // namespace iires
