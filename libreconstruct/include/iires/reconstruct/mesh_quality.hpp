// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file mesh_quality.hpp
/// @brief Quality report of any triangle mesh (DESIGN §5.3): triangle shape, topology, and the distance to a
/// reference cloud or mesh. Works on meshes from any source, also a user's own.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "iires/execution.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief Triangle quality Q = 2√3·S/(p·h): S area, p half-perimeter, h longest edge (DESIGN §5.3).
/// @return 1 for an equilateral triangle, 0 for a degenerate one (zero area or zero-length edges).
double triangleQuality(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// @brief Smallest interior angle of a triangle in degrees (0 for a degenerate triangle).
double triangleMinAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c);

/// @brief Two-sided distance between a mesh and a reference (cloud or surface).
struct SurfaceDistance {
  bool computed = false;   ///< false when there was no reference
  double forwardMax = 0;   ///< max over mesh samples of the distance to the reference
  double forwardMean = 0;  ///< mean of the same
  double backwardMax = 0;  ///< max over reference points (or samples) of the distance to the mesh
  double backwardMean = 0; ///< mean of the same
  double hausdorff = 0;    ///< max(forwardMax, backwardMax)
  double mean = 0;         ///< (forwardMean + backwardMean) / 2
  double diagonal = 0;     ///< bounding-box diagonal of the reference
  double relativeHausdorff() const { return diagonal > 0 ? hausdorff / diagonal : 0.0; }
  double relativeMean() const { return diagonal > 0 ? mean / diagonal : 0.0; }
};

/// @brief Parameters of evaluateMesh() and surfaceDistance().
struct MeshQualityParams {
  std::size_t meshSamples = 100000;  ///< points drawn on the mesh for the mesh→reference side (plus its vertices)
  std::size_t referenceSamples = 100000;  ///< points drawn on a reference *mesh* for the reference→mesh side
  std::uint64_t seed = 1;            ///< seed of those samplings

  /// @throws std::invalid_argument when meshSamples or referenceSamples is 0.
  void validate() const;
};

/// @brief Topology of one connected component (through shared vertices) of a mesh.
struct ComponentTopology {
  std::size_t faces = 0, vertices = 0, edges = 0;  ///< counts within the component
  std::size_t boundaryLoops = 0;  ///< boundary loops (0: closed)
  long long euler = 0;            ///< χ = V − E + F of the component
  bool manifold = false;          ///< no non-manifold edge or vertex (and no degenerate face)
  bool orientable = false;        ///< its faces can be oriented consistently (checked only when manifold)
  bool closed = false;            ///< manifold and no boundary
  /// Genus g of the surface from χ = 2 − 2g − b (b boundary loops); −1 when it is not defined (a non-manifold
  /// or non-orientable component). Never printed as a number then.
  long long genus = -1;
};

/// @brief The quality report of a mesh.
struct MeshQuality {
  // Shape (over all faces; degenerate faces count with Q = 0 and angle 0).
  double qualityMin = 0, qualityMean = 0;    ///< Q_t min and mean
  double minAngleMin = 0, minAngleMean = 0;  ///< per-triangle smallest angle (degrees): min and mean
  double shareBelow30 = 0;                   ///< share of triangles with an angle under 30° (0–1)
  std::size_t degenerateFaces = 0;           ///< faces with Q < 1e-9 (zero area, repeated vertices)
  // Topology.
  std::size_t vertices = 0;            ///< vertices referenced by at least one face
  std::size_t isolatedVertices = 0;    ///< vertices of the mesh no face refers to
  std::size_t faces = 0, edges = 0;    ///< counts (edges = distinct undirected edges)
  std::size_t boundaryEdges = 0;       ///< edges with exactly one face
  std::size_t boundaryLoops = 0;       ///< connected components of the boundary-edge graph
  std::size_t nonManifoldEdges = 0;    ///< edges with more than two faces
  std::size_t nonManifoldVertices = 0; ///< vertices whose link is not a single path or cycle
  std::size_t components = 0;          ///< connected components (through shared vertices)
  long long euler = 0;                 ///< Euler characteristic χ = V − E + F (referenced vertices)
  bool closed = false;                 ///< no boundary and no non-manifold edge (and at least one face)
  bool oriented = false;               ///< every directed edge is used by at most one face
  bool manifold = false;               ///< no non-manifold edge or vertex
  bool orientable = false;             ///< every component is an orientable manifold
  /// Sum of the components' genera when every one has a genus (ComponentTopology::genus), −1 otherwise
  /// (then it is not printed: see parts). For one closed surface, its genus.
  long long genus = -1;
  std::size_t closedComponents = 0;    ///< components that are closed manifolds
  std::vector<ComponentTopology> parts;  ///< per component, most faces first (ties: lowest vertex index first)
  /// Pairs of faces that intersect other than in a common vertex or edge (selfIntersections(); degenerate
  /// faces are counted apart, in degenerateFaces).
  std::size_t selfIntersections = 0;
  double meanEdgeLength = 0;           ///< mean length of the distinct edges
  double area = 0;                     ///< total surface area
  // Distance to the reference (cloud or mesh), when one was given.
  SurfaceDistance distance;
  // Reference points the mesh does not cover (when a reference cloud was given).
  double uncoveredDistance = 0;  ///< the threshold: 2 × meanEdgeLength (the output spacing)
  std::size_t uncovered = 0;     ///< reference points farther than uncoveredDistance from the mesh
  double uncoveredShare = 0;     ///< uncovered / reference points (0–1)
  std::vector<std::size_t> uncoveredPoints;  ///< their indices in the reference, ascending
  /// The other way round: the share of the mesh's area (of its area-uniform samples) farther than
  /// uncoveredDistance from every reference point — parts of the mesh no input backs: a fill across missing
  /// data, a bridge or cap across a gap between parts (0–1).
  double unsupportedShare = 0;

  /// @brief Whether the mesh is valid for downstream use: faces, no self-intersection, no degenerate face,
  /// manifold and consistently oriented.
  bool valid() const {
    return faces > 0 && selfIntersections == 0 && degenerateFaces == 0 && manifold && oriented;
  }

  /// @brief The report as a JSON object.
  std::string toJson() const;
  /// @brief A readable two-column table (one quantity per line).
  std::string toTable() const;
};

/// @brief Shape and topology of @p mesh (self-intersections included); with @p reference, also the two-sided
/// distance to that cloud: reference→mesh exactly (point-to-triangle, CGAL AABB tree) and mesh→reference from
/// params.meshSamples area-uniform samples of the mesh plus its vertices (distance to the nearest reference
/// point), the reference points farther than two output spacings from the mesh (uncovered) and the share of the
/// mesh's area farther than that from the reference (unsupported).
/// @note O(F log F + (n + s) log F). Deterministic for any thread count.
MeshQuality evaluateMesh(const TriangleMesh& mesh, const PointCloud* reference = nullptr,
                         const MeshQualityParams& params = {}, const Execution& exec = {});

/// @brief The points of @p reference that @p quality found uncovered (MeshQuality::uncoveredPoints), with their
/// normals when it has them, in index order. @p reference must be the cloud evaluateMesh() measured.
PointCloud uncoveredInput(const PointCloud& reference, const MeshQuality& quality);

/// @brief Two-sided distance between @p mesh and a reference *surface* (e.g. the true mesh a cloud was
/// sampled from): both sides from area-uniform samples (plus vertices) measured exactly against the other mesh.
/// The diagonal is the reference's.
SurfaceDistance surfaceDistance(const TriangleMesh& mesh, const TriangleMesh& referenceMesh,
                                const MeshQualityParams& params = {}, const Execution& exec = {});

}  // namespace iires
