// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file patch_orientation.hpp
/// @brief Consistent normal signs between the patches a spanning-tree propagation can only guess across, decided
/// by the summed dipole interactions of the points on either side.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "iires/normals.hpp"

namespace iires::detail {

/// @brief Turns whole patches of oriented normals over where the evidence of all their pairs with the patches
/// already settled says so.
/// A spanning-tree propagation (orientNormals) decides each sign from one pair of neighbours. Where the normals
/// turn more between neighbours than one pair tells apart (creases and bores a sparse sampling does not resolve,
/// fits blended across them) it guesses, and a whole face or bore can come out turned over. Here:
/// 1. patches grow over the pairs of the first @p k columns that clearly agree, n_i·n_j − (n_i·d̂)(n_j·d̂) ≥ 0.9
///    (d = p_j − p_i), each point within 20° of the other's tangent plane (two sides of a thin part facing the same
///    way are not), inside one cubic cell 8 kernel radii wide (so that no patch spans a model and carries a wrong
///    link with it); and no patch grows to hold both points of a pair evidence.apart marks across a gap (round a
///    fold tighter than the normals' fit, the blended fits agree all the way from one side to the other);
/// 2. every pair of the @p evidence rows between two patches adds the interaction of the points as dipoles,
///    w = a_i a_j (3(n_i·r̂)(n_j·r̂) − n_i·n_j)/r³, negative where the signs agree (the gradient of the winding
///    number: it agrees over a crease of any angle, across a thin part and along a sheet alike); a = the area a
///    point stands for;
/// 3. per connected part, from its largest patch, the patch with the strongest summed interaction with the settled
///    ones is settled next (Prim's order): on the side that sum says when it is clear (|Σ s_p w| ≥ 0.4 Σ |w|),
///    else keeping the tree's relation to its settled neighbours;
/// 4. patches of fewer than four points (a point on a crease whose fit is neither face's) take the side of the
///    settled patch of their most agreeing neighbour, as the tree had them.
/// Each part's largest patch keeps its sign: the caller chooses the part's side afterwards.
/// @param neighbours point i's links are neighbours[i·stride, i·stride + k) (entries equal to i skipped)
/// @param evidence the pairs whose interactions are summed: rows of the same points, wider (and, unlike the links,
/// across thin gaps too: the two sides of a thin part are evidence of their sides), and those across a gap
/// @param threads for the per-point passes (0 = all cores); the result does not depend on it
/// @return how many normals were turned
/// @note O(n (k + evidence.stride)) and a radix sort of the pairs across patches. Deterministic.
std::size_t orientPatchesByField(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                                 const std::vector<std::uint32_t>& neighbours, std::size_t stride, std::size_t k,
                                 const OrientationEvidence& evidence, int threads);

}  // namespace iires::detail
