// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file normals.hpp
/// @brief PCA normals with consistent orientation (DESIGN §3 step 4).

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "iires/execution.hpp"
#include "iires/knn.hpp"

namespace iires {

struct NormalParams {
  int k = 12;        ///< neighbours for the PCA fit (Open3D/PCL habit: 10–30)
  bool orient = true;  ///< propagate a consistent orientation over a minimum spanning tree
};

/// @brief Estimate unit normals by PCA of the k nearest neighbours, then orient them consistently per
/// connected component of the k-NN graph (minimum spanning tree on 1 − |nᵢ·nⱼ|, rooted at the point of
/// largest x in each component, whose normal is made to point to +x — outwards for a closed surface).
/// @note O(n k log n). Deterministic for any thread count.
std::vector<Eigen::Vector3d> estimateNormals(const std::vector<Eigen::Vector3d>& points,
                                             const NormalParams& params = {}, const Execution& exec = {});

/// @brief Whether given normals describe the points' surface: among the points whose 16 nearest (@p table's rows)
/// spread over a plane (not along a line: a scan line's or a crease's points leave the plane undetermined), at
/// least three in four have their normal within 60° of that plane's. A surface's own normals, noisy or estimated
/// elsewhere, agree on over 95 % of such points (CGAL's real point sets), normals tangent to the surface on none,
/// random ones on half. True when fewer than a tenth of the points spread over a plane (nothing to judge by).
/// @note O(n k). Deterministic for any thread count.
bool givenNormalsDescribeSurface(const std::vector<Eigen::Vector3d>& points,
                                 const std::vector<Eigen::Vector3d>& normals, const NeighbourTable& table,
                                 int threads = 0);

/// @brief Orient given (unoriented) normals consistently, as estimateNormals does.
void orientNormals(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                   int k = 12);

/// @brief Neighbour rows of the same points as orientNormals()' graph, wider, whose pairs settle the sides of the
/// patches the graph's spanning tree could only guess across (a face or bore past a crease a sparse sampling does not
/// resolve): point i's are rows[i·stride, i·stride + stride), entries equal to i skipped. @p apart, when given (one
/// flag per entry), marks the pairs that lie across a gap (two sheets, see sheets.hpp): no patch holds both points
/// of such a pair, whatever chain of agreeing neighbours (round a fold tighter than the normals' fit) joins them.
struct OrientationEvidence {
  const std::vector<std::uint32_t>& rows;
  std::size_t stride;
  const std::vector<std::uint8_t>* apart = nullptr;
};

/// @brief Orient normals consistently over a k-NN graph the caller already has (no search of its own).
/// @param neighbours point i's neighbours are neighbours[i·stride + 0 … i·stride + k − 1] (the point itself
/// may be among them and is skipped); the graph is made symmetric.
/// @param threads for the edge weights (0 = all cores); the result does not depend on it
/// @param acrossEdge compare the normals' parts orthogonal to each edge d = pⱼ − pᵢ (nᵢ·nⱼ − (nᵢ·d̂)(nⱼ·d̂))
/// instead of the normals: consistent normals keep a positive value over a crease or a tight fold, and a pair
/// across a thin gap (d along both normals) has none, so the tree neither guesses a sign across a right angle
/// nor carries one sheet's orientation to the other
/// @param sides (optional, one per point) each connected component takes the side most of these vectors are on
/// (e.g. given normals whose signs are mostly right) instead of facing +x at its root
/// @param evidence (optional) wider rows whose pairs settle the patches the tree could only guess across, and the
/// pairs among them that lie across a gap (see OrientationEvidence); without it, @p neighbours' rows
/// @note O(n k) (Kruskal's minimum spanning tree on 1 − |nᵢ·nⱼ| after a radix sort of the weights, roots as
/// estimateNormals). Deterministic.
void orientNormals(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                   const std::vector<std::uint32_t>& neighbours, std::size_t stride, std::size_t k,
                   int threads = 0, bool acrossEdge = false, const std::vector<Eigen::Vector3d>* sides = nullptr,
                   const OrientationEvidence* evidence = nullptr);

/// @brief Normals whose lines differ by more than this angle (degrees) meet at a crease: orientAcrossCreases()'s
/// threshold, and the local triangulation's for unfolding a neighbour over a crease.
inline constexpr double kCreaseAngleDegrees = 15.0;

/// @brief Orient normals that turn at once over a crease (per-face fits, not PCA normals that blend the faces)
/// over a caller's graph, for creases of any angle. A propagation over the normals' dot product turns a face over
/// past a crease sharper than 90° (the faces' normals differ by more than 90°), and one pair alone cannot tell such
/// a crease from two sheets one above the other. So: (1) patches grow over pairs of points on their planes (at least
/// 3/4 of the row within 15° of the tangent plane) whose normals are within 15° of parallel; (2) between two
/// patches all their pairs vote, summed: where the normals are not within 15° of parallel, the sides' rule —
/// consistent normals have (nᵢ·d)(nⱼ·d) ≤ 0 for d = pⱼ − pᵢ, each point on the side of the other's tangent plane
/// away from the other's normal or each towards it, over a convex or a concave crease of any angle and across a
/// thin part (a quarter weight where the normals' dot product says otherwise), elsewhere the normals compared;
/// (3) the patches are turned along a spanning forest of the strongest sums; (4) each connected group takes the
/// side most of @p sides are on (else its point of largest x faces +x), and with @p sides, patches of fewer than
/// 8 points keep their given side, turned like the nearest larger patch on their plane.
/// @param neighbours, stride, k, threads, sides as orientNormals'
/// @note O(n k log(n k)). Deterministic for any thread count.
void orientAcrossCreases(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                         const std::vector<std::uint32_t>& neighbours, std::size_t stride, std::size_t k,
                         int threads = 0, const std::vector<Eigen::Vector3d>* sides = nullptr);

/// Given normals are trusted to be oriented when at most this share of their neighbour pairs on one plane point
/// opposite ways (orientationConflicts); above it (normals from a tool that does not orient them) only their
/// directions are used.
constexpr double kMaxOrientationConflicts = 0.01;

/// @brief The share of neighbour pairs on one plane — each point within 15° of the other's tangent plane and
/// within half a local spacing (a sheet's own noise) of it, the normals within 25° of parallel either way — whose
/// normals point opposite ways. Consistently oriented normals turn gradually along a surface and have next to none
/// (two sides of a thin part, even one a spacing thick, are farther apart than that); normals whose signs were never
/// made consistent have up to half.
/// @param neighbours as orientNormals' (entries equal to the point itself skipped)
/// @note O(n k). Deterministic for any thread count.
double orientationConflicts(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                            const std::vector<std::uint32_t>& neighbours, std::size_t stride, std::size_t k,
                            int threads = 0);

/// @brief Given unit normals whose signs disagree (orientationConflicts above kMaxOrientationConflicts over the
/// @p k nearest) oriented over the k-NN graph (orientNormals with acrossEdge), each connected component on the side
/// most of them had; consistent ones are left as they are. Returns how many were turned over.
std::size_t repairOrientation(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                              int k = 12, int threads = 0);

}  // namespace iires
