// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file self_intersections.hpp
/// @brief Self-intersecting face pairs of any triangle mesh (also non-manifold ones, or a soup), with the
/// semantics of CGAL's Polygon_mesh_processing::self_intersections.

#include <cstddef>
#include <utility>
#include <vector>

#include "iires/types.hpp"

namespace iires {

/// @brief The pairs of faces (f < g) of @p mesh whose triangles intersect anywhere but in a vertex or edge both
/// faces have (by index): faces with a common edge intersect when they are coplanar and overlap, faces with a
/// common vertex when the edge of one opposite that vertex meets the other triangle, other faces when their
/// triangles meet at all; a face repeated with the same three vertices intersects its copy. Degenerate faces
/// (collinear corners, a repeated vertex index) take part in no pair: they are MeshQuality::degenerateFaces.
/// Exact predicates (CGAL's Epick kernel), so the answer does not depend on rounding.
/// @return the pairs sorted by (f, g).
/// @note Candidates are the pairs of overlapping bounding boxes (a uniform grid; CGAL's box intersection when the
/// face sizes vary too much for one), less the pairs with a common vertex around which the faces provably do not
/// overlap (seen along the fan's normal, their angular wedges are disjoint); O(F + k) for k candidates on a mesh of
/// similar triangles. The tests run in parallel on @p threads (0 = all cores); the result does not depend on it.
std::vector<std::pair<std::size_t, std::size_t>> selfIntersections(const TriangleMesh& mesh, int threads = 0);

/// @brief The pairs of selfIntersections() that hold a face flagged in @p changed (one flag per face of @p mesh):
/// the check of a mesh that was free of them before a repair added or moved those faces (facesChangedSince()).
/// The other faces are looked at only where their boxes come near a changed face's.
/// @throws std::invalid_argument when @p changed does not hold one flag per face.
std::vector<std::pair<std::size_t, std::size_t>> selfIntersections(const TriangleMesh& mesh,
                                                                   const std::vector<char>& changed, int threads = 0);

/// @brief One flag per face of @p after: 1 unless @p before has a face with the same three vertex indices, none of
/// which moved (a face a repair added, or one whose vertex it moved). Every flag is 1 for meshes over 2²¹ vertices.
std::vector<char> facesChangedSince(const TriangleMesh& before, const TriangleMesh& after);

/// @brief The same pairs as selfIntersections() by testing every pair of faces: the oracle for small meshes.
/// @note O(F²).
std::vector<std::pair<std::size_t, std::size_t>> selfIntersectionsBruteForce(const TriangleMesh& mesh);

/// @brief Faces of @p mesh that are in at least one pair of selfIntersections(), sorted.
std::vector<std::size_t> selfIntersectingFaces(const TriangleMesh& mesh, int threads = 0);

}  // namespace iires
