// SPDX-License-Identifier: GPL-3.0-or-later
// fillLargeHoles(): boundary loops too long for fillSmallHoles() but small next to their component, closed with
// new vertices (CGAL: refined and faired hole filling, then isotropic remeshing of the patch) where the fill lies on
// the input or the input ends at the loop.
#ifndef CGAL_EIGEN3_ENABLED
#define CGAL_EIGEN3_ENABLED 1  // fairing's sparse solver
#endif
#include <CGAL/Polygon_mesh_processing/compute_normal.h>
#include <CGAL/Polygon_mesh_processing/fair.h>
#include <CGAL/Polygon_mesh_processing/refine.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/boost/graph/Euler_operations.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <memory>
#include <optional>
#include <unordered_map>
#include <vector>

#include "iires/detail/disjoint_sets.hpp"
#include "iires/knn.hpp"
#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "local_mesh.hpp"
#include "surface_mesh.hpp"

namespace iires {
namespace {

using detail::FaceIndex;
using detail::HalfedgeIndex;
using detail::Kernel;
using detail::Mesh;
using detail::toEigen;
using detail::toSurfaceMesh;
using detail::VertexIndex;
namespace PMP = CGAL::Polygon_mesh_processing;

/// Loops up to this many edges are triangulated by CGAL's exhaustive search (O(n³): 0.02 s at 100 edges, 0.27 s at
/// 240); longer ones are kept open (an ear-clipped start would be a fan of slivers on a near-circular loop, which
/// refining and fairing, with their cotangent weights, turn into faces outside the loop). CGAL's faster search in a
/// 3-D Delaunay triangulation is not used: its fills change from run to run on two threads (3torus, loops of
/// 124-240 edges).
constexpr std::size_t kExhaustiveEdges = 250;

/// A faired patch whose triangles fall this far short of Q 0.4 in all (FinishedPatch::shortfall: a degenerate
/// triangle's worth) is made again without fairing; the repairs after the fill handle a poor triangle or two, not
/// a fold.
constexpr double kRefairShortfall = 0.4;

/// The input points (HoleFillingParams::inputPoints): whether a loop's fill lies on the sampled surface, and
/// whether the input goes on beyond the loop.
class InputSupport {
 public:
  explicit InputSupport(const HoleFillingParams& params) : params_(params) {}
  bool active() const { return params_.inputPoints && !params_.inputPoints->points().empty(); }

  /// The unit u of the tests for the loop at @p h with mean edge @p l: the larger of l and the input's spacing
  /// there (the median, over the loop's vertices, of the distance from the input point nearest to each to its
  /// own nearest neighbour).
  double unit(const Mesh& sm, HalfedgeIndex h, double l) {
    std::vector<double> spacing;
    HalfedgeIndex g = h;
    do {
      const std::int64_t q = index().nearest(toEigen(sm.point(sm.target(g))));
      if (index().knn(points()[static_cast<std::size_t>(q)], 2, idx_, sq_) == 2)
        spacing.push_back(std::sqrt(sq_[1]));
      g = sm.next(g);
    } while (g != h);
    if (spacing.empty()) return l;
    std::nth_element(spacing.begin(), spacing.begin() + static_cast<long>(spacing.size() / 2), spacing.end());
    return std::max(l, spacing[spacing.size() / 2]);
  }

  /// Share of the loop's edges with an input point beyond them: within 2u of the edge's midpoint and more than u
  /// past it towards the hole (along the edge's face's plane; any normal offset, so a crease counts too).
  double continuedShare(const Mesh& sm, HalfedgeIndex h, double u) {
    std::size_t edges = 0, continued = 0;
    HalfedgeIndex g = h;
    do {
      const Eigen::Vector3d a = toEigen(sm.point(sm.source(g))), b = toEigen(sm.point(sm.target(g)));
      const Eigen::Vector3d c = toEigen(sm.point(sm.target(sm.next(sm.opposite(g)))));  // the face's third vertex
      const Eigen::Vector3d m = 0.5 * (a + b), e = (b - a).normalized();
      const Eigen::Vector3d t = ((m - c) - (m - c).dot(e) * e).normalized();  // in the face's plane, into the hole
      index().radius(m, 2 * u, idx_, sq_);
      continued +=
          std::any_of(idx_.begin(), idx_.end(), [&](std::uint32_t i) { return (points()[i] - m).dot(t) > u; });
      ++edges;
      g = sm.next(g);
    } while (g != h);
    return static_cast<double>(continued) / static_cast<double>(std::max<std::size_t>(edges, 1));
  }

  /// Whether every vertex of @p added lies within @p distance of an input point.
  bool supports(const Mesh& sm, const std::vector<VertexIndex>& added, double distance) {
    double sq = 0;
    return std::all_of(added.begin(), added.end(), [&](VertexIndex v) {
      return index().nearest(toEigen(sm.point(v)), &sq) >= 0 && sq <= distance * distance;
    });
  }

 private:
  const std::vector<Eigen::Vector3d>& points() const { return params_.inputPoints->points(); }
  const KnnIndex& index() const { return params_.inputPoints->index(); }
  const HoleFillingParams& params_;
  std::vector<std::uint32_t> idx_;
  std::vector<double> sq_;
};

/// The border cycles of @p sm, each once (by its smallest halfedge index).
std::vector<HalfedgeIndex> borderCycles(const Mesh& sm) {
  std::vector<HalfedgeIndex> cycles;
  std::vector<char> seen(sm.number_of_halfedges(), 0);
  for (HalfedgeIndex h : sm.halfedges()) {
    if (!sm.is_border(h) || seen[h]) continue;
    HalfedgeIndex g = h;
    do {
      seen[g] = 1;
      g = sm.next(g);
    } while (g != h);
    cycles.push_back(h);
  }
  return cycles;
}

/// One loop to close: its border halfedge, edges, the share of it the input goes on beyond, the input's unit there
/// (InputSupport::unit) and the patch's target edge length (the loop's spacing, and every loop edge under twice it).
struct LoopFill {
  HalfedgeIndex h;
  std::size_t edges = 0;
  double continued = 0, unit = 0, target = 0;
};

/// A loop's patch: its faces and the vertices refining added.
struct Patch {
  std::vector<FaceIndex> faces;
  std::vector<VertexIndex> added;
};

/// @p loop closed in @p sm by CGAL's exhaustive triangulation, then refined; false (nothing done) when the loop is
/// too long for the search or it found no triangulation.
bool triangulateLoop(Mesh& sm, const LoopFill& loop, Patch& patch) {
  if (loop.edges <= kExhaustiveEdges)
    PMP::triangulate_hole(sm, loop.h, std::back_inserter(patch.faces),
                          CGAL::parameters::use_delaunay_triangulation(false));
  if (patch.faces.empty()) return false;
  PMP::refine(sm, std::vector<FaceIndex>(patch.faces), std::back_inserter(patch.faces),
              std::back_inserter(patch.added));
  return true;
}

/// Whether the refined @p patch may stay: it lies on the sampled surface or across a gap in the data.
bool supported(const Mesh& sm, const LoopFill& loop, const Patch& patch, const HoleFillingParams& params,
               InputSupport& input) {
  return !input.active() || loop.continued < params.maxContinuedShare ||
         input.supports(sm, patch.added, params.supportDistance * loop.unit);
}

/// A loop's patch as it goes into the mesh: faces in sm's vertex indices, −k − 1 naming inner[k]; the patch's
/// refined vertices are all replaced by the inner ones. shortfall: how far its faces with an inner vertex fall
/// short of a good shape (the sum of max(0, 0.4 − Q): additive, so two fills of one loop compare by it).
struct FinishedPatch {
  std::vector<Eigen::Vector3i> faces;
  std::vector<Eigen::Vector3d> inner, innerNormals;
  double shortfall = 0;
};

/// @p faces of @p m as a FinishedPatch: a vertex is the whole mesh's (@p global maps m's vertices to it; empty:
/// m is the whole mesh) unless it is new or one of @p added (sorted: the patch's refined vertices, all replaced).
FinishedPatch collectPatch(const Mesh& m, const std::vector<FaceIndex>& faces, const std::vector<std::uint32_t>& global,
                           const std::vector<VertexIndex>& added) {
  constexpr double kGoodQuality = 0.4;  // the reconstruction's repair threshold
  FinishedPatch out;
  std::unordered_map<std::uint32_t, int> inner;  // m's vertex → −k − 1
  for (FaceIndex f : faces) {
    Eigen::Vector3i t;
    std::array<Eigen::Vector3d, 3> q;
    bool hasInner = false;
    int c = 0;
    for (VertexIndex v : CGAL::vertices_around_face(m.halfedge(f), m)) {
      const auto mv = static_cast<std::uint32_t>(v);
      q[static_cast<std::size_t>(c)] = toEigen(m.point(v));
      const bool known = global.empty() || mv < global.size();
      const std::uint32_t g = global.empty() ? mv : known ? global[mv] : 0;
      if (known && !std::binary_search(added.begin(), added.end(), VertexIndex(g))) {
        t[c++] = static_cast<int>(g);
        continue;
      }
      hasInner = true;
      const auto [it, fresh] = inner.emplace(mv, -static_cast<int>(out.inner.size()) - 1);
      if (fresh) {
        out.inner.push_back(q[static_cast<std::size_t>(c)]);
        out.innerNormals.push_back(toEigen(PMP::compute_vertex_normal(v, m)));
      }
      t[c++] = it->second;
    }
    out.faces.push_back(t);
    if (hasInner) out.shortfall += std::max(0.0, kGoodQuality - triangleQuality(q[0], q[1], q[2]));
  }
  return out;
}

/// @p patch evened out by @p iterations of isotropic remeshing at @p target (the loop itself, the patch's border,
/// is neither split, collapsed nor moved), as a mesh of its own: the patch and the ring of faces around it, so
/// that the remesher's link tests see the same neighbourhood as in the whole mesh.
FinishedPatch remeshPatch(const Mesh& sm, const Patch& patch, double target, int iterations) {
  std::vector<FaceIndex> faces = patch.faces, ring;
  std::sort(faces.begin(), faces.end());
  for (FaceIndex f : patch.faces)
    for (VertexIndex v : CGAL::vertices_around_face(sm.halfedge(f), sm))
      for (FaceIndex g : CGAL::faces_around_target(sm.halfedge(v), sm))
        if (g != Mesh::null_face() && !std::binary_search(faces.begin(), faces.end(), g)) ring.push_back(g);
  std::sort(ring.begin(), ring.end());
  ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
  std::vector<Eigen::Vector3i> triangles;
  for (const std::vector<FaceIndex>* part : {&patch.faces, static_cast<const std::vector<FaceIndex>*>(&ring)})
    for (FaceIndex f : *part) {
      Eigen::Vector3i t;
      int c = 0;
      for (VertexIndex v : CGAL::vertices_around_face(sm.halfedge(f), sm)) t[c++] = static_cast<int>(v);
      triangles.push_back(t);
    }
  std::vector<VertexIndex> added = patch.added;
  std::sort(added.begin(), added.end());
  std::vector<std::uint32_t> global;
  Mesh lm;
  if (!detail::localSurfaceMesh(triangles, [&](std::uint32_t v) { return toEigen(sm.point(VertexIndex(v))); }, lm,
                                global))
    return collectPatch(sm, patch.faces, {}, added);  // as it is (not seen: sm is an oriented 2-manifold)
  const std::size_t patchFaces = patch.faces.size();
  if (iterations > 0) {
    std::vector<FaceIndex> region;
    for (std::size_t f = 0; f < patchFaces; ++f) region.emplace_back(static_cast<Mesh::size_type>(f));
    PMP::isotropic_remeshing(region, target, lm,
                             CGAL::parameters::number_of_iterations(static_cast<unsigned>(iterations))
                                 .protect_constraints(true));
  }
  // The ring keeps its face indices (the remesher changes only the patch; new faces take freed slots or go last).
  std::vector<FaceIndex> remeshed;
  for (FaceIndex f : lm.faces())
    if (const auto i = static_cast<std::size_t>(f); i < patchFaces || i >= triangles.size()) remeshed.push_back(f);
  return collectPatch(lm, remeshed, global, added);
}

/// The positions of @p vertices in @p sm.
std::vector<Kernel::Point_3> positions(const Mesh& sm, const std::vector<VertexIndex>& vertices) {
  std::vector<Kernel::Point_3> p;
  for (VertexIndex v : vertices) p.push_back(sm.point(v));
  return p;
}

void setPositions(Mesh& sm, const std::vector<VertexIndex>& vertices, const std::vector<Kernel::Point_3>& p) {
  for (std::size_t k = 0; k < vertices.size(); ++k) sm.point(vertices[k]) = p[k];
}

/// The refined @p patch C⁰-faired, then remeshed, where it lies on the sampled surface or across a gap in the data
/// (else removed again, nothing returned: the loop is a border again). Where the membrane folds (a loop round a
/// crease), the patch comes out of the remeshing with slivers: then it is remeshed again from the refined
/// triangulation without fairing, and the patch with the better triangles kept. sm keeps the faired patch's
/// faces (the context of the next loops); the returned patch replaces them.
std::optional<FinishedPatch> finishPatch(Mesh& sm, const LoopFill& loop, const Patch& patch,
                                         const HoleFillingParams& params, InputSupport& input) {
  const std::vector<Kernel::Point_3> refined = positions(sm, patch.added);
  PMP::fair(sm, patch.added, CGAL::parameters::fairing_continuity(0));
  if (!supported(sm, loop, patch, params, input)) {
    for (FaceIndex f : patch.faces) CGAL::Euler::remove_face(sm.halfedge(f), sm);
    return std::nullopt;
  }
  FinishedPatch faired = remeshPatch(sm, patch, loop.target, params.refineIterations);
  if (faired.shortfall <= kRefairShortfall) return faired;
  const std::vector<Kernel::Point_3> fairedPositions = positions(sm, patch.added);
  setPositions(sm, patch.added, refined);
  if (supported(sm, loop, patch, params, input)) {
    FinishedPatch flat = remeshPatch(sm, patch, loop.target, params.refineIterations);
    if (flat.shortfall < faired.shortfall) return flat;
  }
  setPositions(sm, patch.added, fairedPositions);
  return faired;
}

}  // namespace

LargeHoleReport fillLargeHoles(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals,
                               const HoleFillingParams& params, const std::vector<char>* only) {
  params.validate();
  LargeHoleReport report;
  if (!(params.maxRefinedExtent > 0) || mesh.triangles.empty()) return report;
  const std::size_t nv = mesh.vertices.size();
  // Components (through shared vertices) and their bounding boxes: a loop is measured against its own part.
  DisjointSets parts(nv);
  for (const auto& t : mesh.triangles)
    for (int c = 1; c < 3; ++c) parts.unite(static_cast<std::uint32_t>(t[0]), static_cast<std::uint32_t>(t[c]));
  std::unordered_map<std::uint32_t, Eigen::AlignedBox3d> boxes;
  for (const auto& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) boxes[parts.find(static_cast<std::uint32_t>(t[c]))].extend(mesh.vertices[static_cast<std::size_t>(t[c])]);

  // The faces CGAL cannot add (at a non-manifold edge or vertex, or turned against their neighbours) stay as they
  // are; a loop through one of their vertices may be no hole at all and is kept.
  Mesh sm;
  std::vector<std::size_t> leftOut;
  toSurfaceMesh(mesh, sm, &leftOut);
  std::vector<char> blocked(nv, 0);
  for (std::size_t f : leftOut)
    for (int c = 0; c < 3; ++c) blocked[static_cast<std::size_t>(mesh.triangles[f][c])] = 1;
  report.facesLeftOut = leftOut.size();
  for (std::uint32_t v = 0; v < nv; ++v)
    if (blocked[v]) report.unseen.push_back(v);
  const std::vector<HalfedgeIndex> cycles = borderCycles(sm);
  double edgeSum = 0;
  for (auto e : sm.edges()) edgeSum += std::sqrt(CGAL::squared_distance(sm.point(sm.source(sm.halfedge(e))), sm.point(sm.target(sm.halfedge(e)))));
  const double meanEdge = edgeSum / static_cast<double>(std::max<std::size_t>(sm.number_of_edges(), 1));
  InputSupport input(params);
  std::vector<FinishedPatch> patches;
  auto through = [&](HalfedgeIndex h, const std::vector<char>& flags) {
    HalfedgeIndex g = h;
    do {
      const auto v = static_cast<std::size_t>(sm.target(g));
      if (v < flags.size() && flags[v]) return true;
      g = sm.next(g);
    } while (g != h);
    return false;
  };
  for (HalfedgeIndex h : cycles) {
    if (only && !through(h, *only)) continue;
    ++report.loops;
    if (!leftOut.empty() && through(h, blocked)) {
      ++report.kept;
      continue;
    }
    Eigen::AlignedBox3d box;
    std::size_t edges = 0;
    double longest = 0, perimeter = 0;
    HalfedgeIndex g = h;
    do {
      box.extend(toEigen(sm.point(sm.target(g))));
      const double l = std::sqrt(CGAL::squared_distance(sm.point(sm.source(g)), sm.point(sm.target(g))));
      longest = std::max(longest, l), perimeter += l;
      ++edges;
      g = sm.next(g);
    } while (g != h);
    const Eigen::AlignedBox3d& whole = boxes[parts.find(static_cast<std::uint32_t>(sm.target(h)))];
    if (edges < 3 || box.diagonal().norm() > params.maxRefinedExtent * whole.diagonal().norm()) {
      ++report.kept;
      continue;
    }
    // The input's spacing there (u) and how much of it goes on beyond the loop, measured on the open loop.
    double u = 0, continued = 0;
    if (input.active()) {
      u = input.unit(sm, h, perimeter / static_cast<double>(edges));
      continued = input.continuedShare(sm, h, u);
    }
    // Triangulated, refined (new vertices inside, CGAL's density control), then faired and remeshed
    // (finishPatch): C⁰ fairing (a membrane) gives a planar loop a flat cap; C¹ would carry the walls' tangents
    // into a dome (measured on the sparse hand's wrist: Hausdorff 9.0 % of the diagonal with C¹, 3.4 % with C⁰).
    const LoopFill fill{h, edges, continued, u,
                        std::max(perimeter / static_cast<double>(edges), std::max(meanEdge, longest / 1.9))};
    Patch patch;
    if (!triangulateLoop(sm, fill, patch)) {
      ++report.kept;
      continue;
    }
    std::optional<FinishedPatch> finished = finishPatch(sm, fill, patch, params, input);
    if (!finished) {
      ++report.kept, ++report.unsupported;
      continue;
    }
    patches.push_back(std::move(*finished));
    ++report.filled;
  }
  if (!report.filled) return report;
  // Back to the TriangleMesh: its faces stay as they are (a fill only adds faces), the finished patches follow,
  // their inner vertices appended with their normals (sm's vertices past nv are the patches' refined ones).
  const std::size_t before = mesh.triangles.size();
  const bool haveNormals = normals.size() == nv;
  for (const FinishedPatch& p : patches) {
    const auto base = static_cast<int>(mesh.vertices.size());
    mesh.vertices.insert(mesh.vertices.end(), p.inner.begin(), p.inner.end());
    if (haveNormals) normals.insert(normals.end(), p.innerNormals.begin(), p.innerNormals.end());
    report.verticesAdded += p.inner.size();
    for (Eigen::Vector3i t : p.faces) {
      for (int c = 0; c < 3; ++c)
        if (t[c] < 0) t[c] = base - t[c] - 1;
      mesh.triangles.push_back(t);
    }
  }
  report.facesAdded = mesh.triangles.size() - before;
  return report;
}

}  // namespace iires
