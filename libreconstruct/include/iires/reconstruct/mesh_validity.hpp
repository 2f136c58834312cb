// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file mesh_validity.hpp
/// @brief Making a mesh valid where triangulation or hole filling left it invalid: self-intersecting faces
/// removed with their neighbourhood and the hole filled again, non-manifold edges and vertices split off.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "iires/execution.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief Parameters of repairValidity().
struct ValidityParams {
  /// Remove-and-refill rounds: round r removes the self-intersecting faces grown by r rings (through shared
  /// vertices) and fills the holes again; what still intersects afterwards is removed without a fill (≥ 0)
  int rounds = 3;
  bool refill = true;                   ///< fill the holes the removal opens (false: leave them open)
  HoleFillingParams holes;              ///< how they are filled (fillSmallHoles, then fillLargeHoles)
  std::size_t minComponentFaces = 20;   ///< components this small left by a removal are dropped (0 = keep)
  /// The large-hole fill looks only at the loops a removal opened or changed and those through unseenLoops (set
  /// where fillLargeHoles() has already looked at the others; false: every loop)
  bool onlyOpenedLoops = false;
  std::vector<std::uint32_t> unseenLoops;  ///< vertices of loops fillLargeHoles() kept unlooked-at (report.unseen)

  /// @throws std::invalid_argument when a field is out of range.
  void validate() const;
};

/// @brief What repairValidity() found and did.
struct ValidityReport {
  std::size_t intersectingPairs = 0;  ///< self-intersecting face pairs found before the repair
  std::size_t nonManifoldEdges = 0;   ///< edges with more than two faces found before the repair
  std::size_t rounds = 0;             ///< remove-and-refill rounds run
  std::size_t facesRemoved = 0;       ///< faces removed (intersecting faces and their rings, extra faces at
                                      ///< non-manifold edges and vertices, small components left over)
  std::size_t facesAdded = 0;         ///< faces the fills added
  std::size_t verticesAdded = 0;      ///< vertices the fills added (appended, with normals)
  std::size_t removedWithoutFill = 0; ///< faces removed in the end without a fill (their holes stay open)
  bool changed() const { return facesRemoved > 0 || facesAdded > 0; }
};

/// @brief Make @p mesh free of self-intersections (selfIntersections()) and of non-manifold edges and vertices,
/// changing it only locally: faces beyond the first two (lowest indices) at an edge are removed, then extra fans
/// at a vertex (removeExtraFans); self-intersecting faces are removed together with params.rounds growing rings
/// of neighbours and their holes filled again (fillSmallHoles, fillLargeHoles); faces still intersecting after
/// the last round are removed for good, with the extra fans that leaves. New vertices are appended to the mesh
/// and their normals to @p normals (when it holds one per vertex). Faces keep their orientation; call
/// orientConsistently() afterwards.
/// @post no self-intersecting pair, no non-manifold edge or vertex (removing faces cannot create either).
/// @param clean (optional) the mesh as it was when last free of self-intersections: then only the faces changed
/// since (facesChangedSince()) are checked for them (the refills' checks are always local in this way)
/// @note Deterministic for any thread count. Nothing is changed for a valid mesh (one check, O(F log F)).
ValidityReport repairValidity(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals,
                              const ValidityParams& params = {}, const Execution& exec = {},
                              const TriangleMesh* clean = nullptr);

}  // namespace iires
