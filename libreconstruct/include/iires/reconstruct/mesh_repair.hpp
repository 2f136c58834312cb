// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file mesh_repair.hpp
/// @brief Post-processing shared by the reconstruction methods: closing small holes, Delaunay edge flips,
/// consistent orientation, dropping unused vertices.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <vector>

#include "iires/knn.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief The points a mesh was made from, with a k-d tree over them built on first use and kept, so that every
/// fill tested against them (fillLargeHoles() in each hole-filling and repair pass) shares one; and, when given,
/// their surface graph (edges between neighbours on one sheet, e.g. GeodesicCoordinates::edges(): it does not
/// cross thin gaps), for paths along the sampled surface.
class SampledPoints {
 public:
  using Edges = std::vector<std::array<std::uint32_t, 2>>;
  explicit SampledPoints(std::shared_ptr<const std::vector<Eigen::Vector3d>> points, std::function<Edges()> graph = {})
      : points_(std::move(points)), graph_(std::move(graph)) {}
  const std::vector<Eigen::Vector3d>& points() const { return *points_; }
  /// @brief The k-d tree over points(); built by the first call (thread-safe).
  const KnnIndex& index() const {
    std::call_once(built_, [this] { index_ = std::make_unique<KnnIndex>(*points_); });
    return *index_;
  }
  bool hasGraph() const { return static_cast<bool>(graph_); }
  /// @brief Point i's graph neighbours: neighbours[start[i]] … neighbours[start[i + 1] − 1]; built by the first
  /// call from the graph given (thread-safe); empty without one.
  struct Adjacency {
    std::vector<std::uint32_t> start, neighbours;
  };
  const Adjacency& adjacency() const;

 private:
  std::shared_ptr<const std::vector<Eigen::Vector3d>> points_;
  std::function<Edges()> graph_;
  mutable std::once_flag built_, adjacencyBuilt_;
  mutable std::unique_ptr<KnnIndex> index_;
  mutable Adjacency adjacency_;
};

/// @brief Which boundary loops fillSmallHoles() closes. A loop is closed only when it is short in both senses,
/// so the real boundary of an open surface (long loops) is kept.
struct HoleFillingParams {
  std::size_t maxEdges = 16;   ///< loops of at most this many edges (≥ 3)
  double maxPerimeter = 20.0;  ///< ... and a perimeter of at most this × the mesh's mean edge length (> 0)
  double minQuality = 0.4;     ///< a fan around a new centroid vertex replaces a triangulation of the loop's own
                               ///< vertices whose worst Q is below this, when the fan's worst Q is better (0–1)
  /// Loops up to this factor longer (in edges and perimeter) are closed too when the fill chosen for them (as for
  /// a small loop) has a worst Q of at least minQuality — holes the local method leaves at a sharp rim, e.g. 18–20
  /// edges on hand 20k's wrist cap for some samplings, fill well; 1 = off (≥ 1)
  double goodFillFactor = 1.5;
  /// fillLargeHoles(): loops whose bounding-box diagonal is at most this fraction of their component's are closed
  /// with new vertices — a gap in a closed object's scan (the 0.70-wide wrist cap of a 1.57-wide hand: 0.45),
  /// while the boundary of an open surface spans most of it (a sphere cut at z = 0.5: 0.77, bunny00 cut at 60 %
  /// of its height: 0.86); 0 = off (0–1)
  double maxRefinedExtent = 0.6;
  int refineIterations = 3;  ///< isotropic remeshing iterations over a large hole's patch (≥ 0)
  /// fillLargeHoles(): the points the mesh was made from (null = no test), so that a fill stays on the sampled
  /// surface: when a new vertex of a loop's fill lies farther than supportDistance × u from every input point
  /// (u: the larger of the loop's mean edge and the input's spacing there), the fill is kept only across a gap in
  /// the data — where the input ends at the loop (fewer than maxContinuedShare of its edges have an input point
  /// within 2u of their midpoint and more than u past them, towards the hole) — and otherwise undone, the loop left
  /// open: a membrane that leaves the data where the data goes on spans empty space (between two tubes, across a
  /// wedge) where the triangulation rightly did not link. reconstruct() sets the resampler's working cloud here.
  std::shared_ptr<const SampledPoints> inputPoints;
  double supportDistance = 3.0;     ///< see inputPoints, in units u (> 0)
  double maxContinuedShare = 0.25;  ///< see inputPoints (0–1)

  /// @throws std::invalid_argument when a field is out of range.
  void validate() const;
};

/// @brief What fillSmallHoles() did.
struct HoleFillingReport {
  std::size_t loops = 0;       ///< boundary loops found
  std::size_t filled = 0;      ///< loops closed
  std::size_t kept = 0;        ///< loops left open (too long, not simple, or no valid triangulation)
  std::size_t facesAdded = 0;  ///< triangles added
  std::size_t verticesAdded = 0;  ///< centroid vertices added (loops whose every diagonal already existed)
  std::size_t zipped = 0;      ///< loop corners zipped (a face split where the loop turned back on itself)
};

/// @brief Close the small boundary loops of @p mesh without new vertices: each loop gets the triangulation
/// (dynamic programming over the polygon, Liepa 2003 / Barequet–Sharir) that maximises the minimum triangle
/// quality Q, then the sum of Q; triangles that would repeat an existing edge, or whose normal opposes the
/// vertex normals (when @p normals holds one per vertex), are avoided: if no triangulation qualifies, the normal
/// test is dropped (corners where creases meet); if every triangulation repeats an edge, or its worst Q is below
/// params.minQuality and a fan does better, the loop becomes a fan around a new vertex at its centroid (appended to the mesh, and to @p normals when it holds one per vertex).
/// When the best triangulation under the normal test is still below params.minQuality, the best one without it is
/// taken if better and none of its faces folds back onto the face across a loop edge (normals are unreliable where
/// a loop closes over a part thinner than the spacing, e.g. a fingertip).
/// Before a loop is triangulated, each corner where it turns back on itself (its two loop edges within 15° of each
/// other, e.g. a hole running out along a knife edge, or a T-junction) is zipped: the nearer neighbour is inserted
/// into the longer edge by splitting the face across that edge in two (when both halves have Q ≥ 0.2 and keep its
/// normal), so the corner vertex leaves the loop instead of ending up in slivers; a 3-edge sliver loop closes so.
/// New faces follow the loop's orientation.
/// @note O(loops · m³) with m ≤ goodFillFactor · maxEdges. Deterministic.
HoleFillingReport fillSmallHoles(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals,
                                 const HoleFillingParams& params = {});

/// @brief What fillLargeHoles() did.
struct LargeHoleReport {
  std::size_t loops = 0;          ///< boundary loops found
  std::size_t filled = 0;         ///< loops closed
  std::size_t kept = 0;           ///< loops left open (too large next to their component, no fill found, or
                                  ///< unsupported)
  std::size_t unsupported = 0;    ///< of those, loops whose fill left the input where it goes on (undone)
  std::size_t facesAdded = 0;     ///< net triangles added
  std::size_t verticesAdded = 0;  ///< vertices added inside the holes
  /// faces CGAL could not add to a 2-manifold (at a non-manifold edge or vertex, or turned against their
  /// neighbours): left as they are, with the loops through their vertices (unseen) kept open unlooked-at
  std::size_t facesLeftOut = 0;
  std::vector<std::uint32_t> unseen;
};

/// @brief What closeRimBands() did.
struct RimBandReport {
  std::size_t bands = 0;        ///< loop pairs joined by a band
  std::size_t facesAdded = 0;   ///< triangles in the bands
  std::size_t partsTurned = 0;  ///< open parts turned over so that a band could join them
};

/// @brief Close the rim of a part thinner than the mesh's edges (a plate, a shell's lip): the resampling keeps
/// samples on both faces and the triangulation does not link them across the gap, so the two faces end in two
/// boundary loops running side by side along the rim — or, where samples on the rim itself join the faces in
/// places, in slits: one loop running out along the rim and back, its two sides side by side. Two loops, or the two
/// sides of a slit, are joined by a band of triangles (zipped along them, each step taking the shorter edge across)
/// when at least 90 % of each loop's vertices (a slit's but its two ends) have their nearest vertex across, within
/// 1.5 mean edges, on the other side and at least 90 % of those pairs are joined along params.inputPoints' surface
/// graph (a path at most 5 mean edges long): across a rim the input runs round it; two sheets facing each other
/// across a gap are joined only round its far end, so their loops stay open. Two parts whose loops run the same
/// way (each oriented on its own) are first made to agree: the second is turned over (faces and normals). Nothing
/// is done without params.inputPoints and its graph.
/// @pre @p mesh is consistently oriented per component (orientConsistently()).
/// @note Deterministic.
RimBandReport closeRimBands(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals, const HoleFillingParams& params);

/// @brief Close the boundary loops of at most 250 edges whose bounding-box diagonal is at most
/// params.maxRefinedExtent × that of their component (through shared vertices) with new vertices: CGAL's refined,
/// faired hole filling (Liepa 2003: a minimal-area triangulation by exhaustive search, refined to the loop's edge density, its new vertices faired with C⁰ continuity — a
/// membrane, flat for a planar loop, where C¹ would carry the surrounding walls into a dome), then params.refineIterations of isotropic remeshing of the patch at the loop's mean edge
/// length (the loop's own edges and vertices unchanged). Meant for what fillSmallHoles() leaves: a gap of a scan
/// wider than many mesh edges (e.g. an object's flat cap sampled only at its rim), while the boundary of an open
/// surface, spanning most of it, is kept. With params.inputPoints, a fill that leaves the input where the input
/// goes on beyond the loop is undone and the loop kept (report.unsupported; see HoleFillingParams::inputPoints).
/// New vertices are appended to the mesh, and their normals (of the incident faces) to @p normals when it holds
/// one per vertex; the faces are rebuilt (old faces first, in order).
/// @pre @p mesh is consistently oriented (orientConsistently()); where it is not, or not a 2-manifold, the faces
/// there stay as they are and the loops through their vertices are kept (report.facesLeftOut, report.unseen).
/// With @p only (a flag per vertex), only the loops through a flagged vertex are looked at (where a repair opened
/// or changed a loop; the others were looked at before).
/// @note Deterministic. With params.inputPoints, their k-d tree is built when a loop is first to be filled.
LargeHoleReport fillLargeHoles(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals,
                               const HoleFillingParams& params = {}, const std::vector<char>* only = nullptr);

/// @brief Remesh the neighbourhood of the triangles still below @p minQuality: those faces grown by @p rings rings
/// (through shared vertices) get @p iterations passes of CGAL's isotropic remeshing at the region's mean edge
/// length, vertices projected onto the region's old surface, the region's border unchanged. The result is kept only
/// when the region's worst Q rises (else the mesh is left as it was). Moved vertices keep their index (and get the
/// normal of their new faces in @p normals when it holds one per vertex), removed ones stay in the list unused,
/// new ones are appended; the faces outside the remeshed regions keep their order, the regions' new faces follow.
/// Each region is remeshed as a mesh of its own (its faces and the ring around them): a region where that is not
/// an oriented 2-manifold is left as it is.
/// @return vertices moved, removed or added (0: nothing changed, including when no face is below @p minQuality —
/// then nothing at all is done).
/// @pre @p mesh is consistently oriented (orientConsistently()).
/// @note Deterministic.
std::size_t remeshBadRegions(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals, double minQuality,
                             int rings = 2, int iterations = 3);

/// @brief Make every vertex manifold: where a vertex's faces form several fans (its link has several parts),
/// keep the fan with the most faces (ties: the one with the lowest face index) and remove the others' faces.
/// The holes this opens are for fillSmallHoles(). With @p only (a flag per vertex), only the flagged vertices
/// and those losing a face here are looked at: where a change to the faces can have pinched a vertex.
/// @return number of faces removed.
/// @note Vertices are visited in index order; deterministic for any @p threads (0 = all cores). O(F log F).
std::size_t removeExtraFans(TriangleMesh& mesh, int threads = 0, const std::vector<char>* only = nullptr);

/// @brief Remove the faces of connected components (through shared vertices) with fewer than @p minFaces faces:
/// stray islands a local method leaves inside a hole. @return number of faces removed.
std::size_t removeSmallComponents(TriangleMesh& mesh, std::size_t minFaces);

/// @brief Tangential relaxation, Gauss–Seidel in index order, @p sweeps sweeps: each vertex with a closed fan moves
/// halfway to its neighbours' centroid within its tangent plane (@p normals, one per vertex); each vertex on one
/// rim (two boundary edges, a half-disc fan) halfway to its two rim neighbours' midpoint, taken back onto the rim's
/// two edges, so the rim keeps its shape. Vertices on non-manifold edges or where rims meet stay. A move is taken
/// when no face of the fan turns over, the fan's worst Q does not drop and its mean Q rises, and the old position
/// lies within @p maxDeviation × the mean edge length of the new fan (the surface stays where it was). Evenly spaced
/// samples still leave triangles that their neighbours' centroid improves, more so next to a rim (Lloyd cells are
/// cut there) and next to creases.
/// @return the vertices moved at least once. Deterministic.
std::size_t relaxVertices(TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals, int sweeps,
                          double maxDeviation);

/// @brief Remove the triangles below @p minQuality that sit on an open rim and lie close to the rim left without
/// them: with one boundary edge, when the corner opposite it is on no rim (it becomes a rim vertex, still
/// manifold); with two (an ear), the corner between them is left in no face. Close: that corner is obtuse (inside
/// the rim edge's diametral ball, so the rim moves in by less than half that edge), or no point of the triangle is
/// farther than the mesh's mean edge from the new rim (input under it stays within a spacing of the mesh). A rim
/// triangle has no neighbour to flip with, and its apex cannot move away from the rim edge without squeezing the
/// faces behind it. Peeling exposes two edges, whose faces are looked at again (a few passes; one peel per vertex
/// and pass, so no vertex is pinched).
/// @return faces removed. Deterministic.
std::size_t peelRimSlivers(TriangleMesh& mesh, double minQuality);

/// @brief What repairBadTriangles() did.
struct BadTriangleReport {
  std::size_t moved = 0;    ///< vertices moved within their tangent plane
  std::size_t removed = 0;  ///< vertices removed (their ring re-triangulated; they stay in the list, unused)
  std::size_t peeled = 0;   ///< faces on an open rim removed (peelRimSlivers)
};

/// @brief Raise the worst triangles (Q below @p minQuality, worst first) by changing one of their vertices whose
/// fan is a closed, consistently oriented disc: either move it within its tangent plane (@p normals, one per
/// vertex) to its ring's centroid, or remove it and re-triangulate its ring (the triangulation maximising the worst
/// Q, faces agreeing with the normals, none folding onto the face across a ring edge). A change is taken only when
/// it raises the worst Q of the vertex's fan above that of the old fan and of the bad triangle, keeps every fan
/// face's orientation, and the old vertex position lies within @p maxDeviation × the mean edge length of the new
/// faces (the surface stays in place). The move is preferred: it is taken when it reaches minQuality or does at
/// least as well as the best removal.
/// @note Deterministic. O(F + b·k³) for b bad triangles with rings of k vertices. Nothing happens without normals.
BadTriangleReport repairBadTriangles(TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals,
                                     double minQuality, double maxDeviation);

/// @brief Delaunay edge flips: flip an interior edge whose opposite angles sum to more than π when both faces
/// and both new faces lie within @p maxDihedralDeg of each other (creases are kept), the new edge is new and
/// the smallest angle improves. Sweeps until nothing flips or @p maxSweeps.
/// @return number of flips.
std::size_t flipToDelaunay(TriangleMesh& mesh, double maxDihedralDeg = 25.0, int maxSweeps = 10);

/// @brief What orientConsistently() did.
struct OrientationReport {
  std::size_t components = 0;         ///< face components (through manifold edges)
  std::size_t facesFlipped = 0;       ///< faces reversed
  std::size_t conflicts = 0;          ///< edges left inconsistent (a non-orientable or non-manifold part)
};

/// @brief Orient each component consistently (breadth-first over manifold edges from its lowest face), then
/// choose each component's sign: agreeing with @p normals (one per vertex) when given, else outward (positive
/// signed volume).
/// @note Deterministic.
OrientationReport orientConsistently(TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals);

/// @brief Remove vertices no face refers to. @return old index of every kept vertex, in the new order.
std::vector<std::size_t> removeUnusedVertices(TriangleMesh& mesh);

}  // namespace iires
