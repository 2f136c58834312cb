// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file triangulate.hpp
/// @brief The local method (DESIGN §5.2): a triangle mesh over a cloud's points from each point's
/// tangent-plane Delaunay 1-ring, keeping the triangles its vertices agree on.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "iires/execution.hpp"
#include "iires/neighbourhood.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief Parameters of triangulateLocal().
struct TriangulateParams {
  int neighbours = 16;           ///< Euclidean candidates per point for its 1-ring (≥ 6; the resampler uses 14)
  double cellRadiusFactor = 2.0; ///< a point's Voronoi cell is cut at this × its mean distance to its 6 nearest
                                 ///< neighbours; a cell that reaches the cut is open there (a boundary)
  double minNormalDot = -0.5;    ///< candidates whose normal makes a larger angle than acos(this) with the
                                 ///< point's normal are ignored (the far side of a thin part) unless their
                                 ///< tangent planes meet between them (a crease: see triangulateLocal); in [−1, 1]
  /// Turn the normals consistent over creases first (orientAcrossCreases over each point's 8 nearest that the
  /// neighbour rule accepts, the given normals as its sides): normals propagated over a point graph come out
  /// turned over past a crease sharper than 90° (the faces' normals there differ by more than 90°), and a 1-ring
  /// needs its neighbours' normals on its own side
  bool orientAcrossCreases = true;
  double minQuality = 0.25;      ///< proposals with a worse Q are dropped (their hole is filled better later)
  double minFaceNormalDot = -0.5; ///< proposals whose face normal makes a larger angle than acos(this) with any
                                 ///< of its vertex normals are dropped (faces bridging a gap); in [−1, 1]
  int minVotes = 2;              ///< a triangle is kept when at least this many of its 3 vertices propose it (1–3)
  double flipMaxDihedral = 25.0; ///< Delaunay edge flips only where the two faces' normals differ by less than
                                 ///< this (degrees), so creases are kept; 0 = no flips
  int maxFlipSweeps = 10;        ///< cap on the flip sweeps
  /// > 0: candidates across a gap at least this wide (sheets.hpp's acrossGap: near-parallel tangent planes,
  /// each point beyond the other's) are ignored — two sheets closer than the points' spacing, which the normals'
  /// angle does not tell apart when both sheets face the same way; 0 = off
  double sheetGap = 0;
  double sheetGapAngleDeg = 25.0;  ///< "near parallel" for sheetGap: normals within this angle, in (0, 90)
  /// With sheetGap: per point, 1 where another sheet is near (the sheet rule's finding on the dense cloud); the
  /// pair test applies where either point has one (elsewhere noise could offset two points of one sheet);
  /// empty: everywhere
  std::vector<std::uint8_t> sheetNear;
  /// Neighbour rule for the 1-rings (nullptr = Euclidean); an intrinsic rule keeps rings off thin gaps.
  std::shared_ptr<NeighbourRule> neighbourRule;

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief What triangulateLocal() produced, with diagnostics.
struct TriangulateResult {
  TriangleMesh mesh;                ///< vertices = the input points (same order), oriented by the normals
  std::size_t candidates = 0;       ///< distinct triangles proposed by at least one vertex
  std::size_t proposedBy3 = 0;      ///< ... proposed by all three vertices
  std::size_t proposedBy2 = 0;      ///< ... proposed by exactly two
  std::size_t kept = 0;             ///< triangles kept after the manifold/orientation check
  std::size_t rejectedConflicts = 0;///< candidates with enough votes rejected because an edge was taken
  std::size_t removedFans = 0;      ///< faces removed from extra fans at non-manifold vertices
  std::size_t flips = 0;            ///< Delaunay edge flips applied
  std::size_t normalsTurned = 0;    ///< normals turned over by orientAcrossCreases
  std::vector<Eigen::Vector3d> normals;  ///< the unit normals the mesh is oriented by (one per point)
};

/// @brief Triangulate an oriented cloud from local tangent-plane Delaunay 1-rings.
///
/// The normals are first made consistent over creases (params.orientAcrossCreases). Per point: its candidates
/// (accepted by the neighbour rule, normals compatible) are mapped to its tangent plane by a log-map approximation
/// (tangent direction, 3-D length; a candidate whose normal differs by more than 15° is unfolded about the line
/// where the two tangent planes meet, and then linked at any angle between the normals: the far side of a thin
/// part has no such line near, the unfolded path is long) and its Voronoi cell is clipped from a disc;
/// consecutive Voronoi neighbours (i, j, k) propose a triangle, oriented counter-clockwise about the normal.
/// Triangles proposed by ≥ minVotes vertices are inserted greedily, most votes and best quality first, each only
/// if none of its directed edges is already used — so every edge has at most two faces and they agree in
/// orientation. Extra fans at a vertex are removed (removeExtraFans), then Delaunay edge flips on nearly flat
/// edges. Holes are left for fillSmallHoles().
/// @param cloud points with consistently oriented unit normals
/// @throws InputError when the cloud has fewer than 3 points, no normals, or non-finite values;
/// std::invalid_argument for bad parameters.
/// @note Deterministic for any thread count; O(n k log n).
TriangulateResult triangulateLocal(const PointCloud& cloud, const TriangulateParams& params = {},
                                   const Execution& exec = {});

}  // namespace iires
