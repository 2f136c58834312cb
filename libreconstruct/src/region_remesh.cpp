// SPDX-License-Identifier: GPL-3.0-or-later
// remeshBadRegions(): CGAL's isotropic remeshing around the triangles repairBadTriangles() could not raise. Each
// region is remeshed as a small mesh of its own (its faces and the ring of faces around it), so the cost follows
// the regions, not the whole mesh.
#include <CGAL/Polygon_mesh_processing/compute_normal.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <vector>

#include "iires/detail/disjoint_sets.hpp"
#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "local_mesh.hpp"
#include "surface_mesh.hpp"
#include "vertex_faces.hpp"

namespace iires {
namespace {

using detail::FaceIndex;
using detail::Mesh;
using detail::toEigen;
using detail::VertexIndex;
namespace PMP = CGAL::Polygon_mesh_processing;

double faceQuality(const TriangleMesh& mesh, const Eigen::Vector3i& t) {
  return triangleQuality(mesh.vertices[static_cast<std::size_t>(t[0])], mesh.vertices[static_cast<std::size_t>(t[1])],
                         mesh.vertices[static_cast<std::size_t>(t[2])]);
}

/// A remeshed region in the whole mesh's indices. A face's vertex index v < 0 names added[−v − 1].
struct RemeshedRegion {
  bool kept = false;
  std::vector<Eigen::Vector3i> faces;
  std::vector<std::uint32_t> moved;  ///< old vertices that moved, to movedTo
  std::vector<Eigen::Vector3d> movedTo, movedNormals, added, addedNormals;
  std::size_t removed = 0;           ///< old vertices in no face now (they stay in the mesh's list)
};

/// The faces to hand to the remesher: @p region (sorted) first, then every other face sharing a vertex with it, so
/// that its link tests see the same neighbourhood as in the whole mesh.
std::vector<std::uint32_t> regionWithRing(const TriangleMesh& mesh, const detail::VertexFaces& vf,
                                          const std::vector<std::uint32_t>& region) {
  std::vector<std::uint32_t> ring;
  for (std::uint32_t f : region)
    for (int c = 0; c < 3; ++c) {
      const auto v = static_cast<std::size_t>(mesh.triangles[f][c]);
      for (std::uint32_t k = vf.start[v]; k < vf.start[v + 1]; ++k)
        if (!std::binary_search(region.begin(), region.end(), vf.incident[k])) ring.push_back(vf.incident[k]);
    }
  std::sort(ring.begin(), ring.end());
  ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
  std::vector<std::uint32_t> faces = region;
  faces.insert(faces.end(), ring.begin(), ring.end());
  return faces;
}

/// Remeshes @p region (sorted face indices of @p mesh) on its own; kept when its worst face gets better.
RemeshedRegion remeshRegion(const TriangleMesh& mesh, const detail::VertexFaces& vf,
                            const std::vector<std::uint32_t>& region, int iterations) {
  RemeshedRegion out;
  const std::vector<std::uint32_t> faces = regionWithRing(mesh, vf, region);
  std::vector<Eigen::Vector3i> triangles;
  triangles.reserve(faces.size());
  for (std::uint32_t f : faces) triangles.push_back(mesh.triangles[f]);
  std::vector<std::uint32_t> global;
  Mesh sm;
  if (!detail::localSurfaceMesh(triangles, [&](std::uint32_t v) { return mesh.vertices[v]; }, sm, global))
    return out;  // not an oriented 2-manifold here: left as it is
  double before = 1, edgeSum = 0;
  std::vector<FaceIndex> patch;
  for (std::size_t f = 0; f < region.size(); ++f) {
    const Eigen::Vector3i& t = mesh.triangles[region[f]];
    patch.emplace_back(static_cast<Mesh::size_type>(f));
    before = std::min(before, faceQuality(mesh, t));
    for (int c = 0; c < 3; ++c)
      edgeSum += (mesh.vertices[static_cast<std::size_t>(t[c])] - mesh.vertices[static_cast<std::size_t>(t[(c + 1) % 3])]).norm();
  }
  const double target = edgeSum / static_cast<double>(3 * region.size());
  PMP::isotropic_remeshing(patch, target, sm,
                           CGAL::parameters::number_of_iterations(static_cast<unsigned>(iterations)).protect_constraints(true));
  // The ring's faces keep their index (the remesher changes only the patch; new faces take freed slots or go last).
  auto inRing = [&](FaceIndex f) {
    const auto i = static_cast<std::size_t>(f);
    return i >= region.size() && i < faces.size();
  };
  double after = 1;
  for (FaceIndex f : sm.faces()) {
    if (inRing(f)) continue;
    Eigen::Vector3d p[3];
    int c = 0;
    for (VertexIndex v : CGAL::vertices_around_face(sm.halfedge(f), sm)) p[c++] = toEigen(sm.point(v));
    after = std::min(after, triangleQuality(p[0], p[1], p[2]));
  }
  if (!(after > before)) return out;
  out.kept = true;
  std::vector<int> index(sm.number_of_vertices() + sm.number_of_removed_vertices(), 0);
  for (std::size_t v = 0; v < global.size(); ++v) {
    index[v] = static_cast<int>(global[v]);
    out.removed += sm.is_removed(VertexIndex(static_cast<Mesh::size_type>(v)));
  }
  for (VertexIndex v : sm.vertices()) {
    const Eigen::Vector3d x = toEigen(sm.point(v));
    const bool old = static_cast<std::size_t>(v) < global.size();
    if (old && x == mesh.vertices[global[v]]) continue;
    const Eigen::Vector3d n = toEigen(PMP::compute_vertex_normal(v, sm));
    if (old) {
      out.moved.push_back(global[v]), out.movedTo.push_back(x), out.movedNormals.push_back(n);
    } else {
      out.added.push_back(x), out.addedNormals.push_back(n);
      index[v] = -static_cast<int>(out.added.size());
    }
  }
  for (FaceIndex f : sm.faces()) {
    if (inRing(f)) continue;
    Eigen::Vector3i t;
    int c = 0;
    for (VertexIndex v : CGAL::vertices_around_face(sm.halfedge(f), sm)) t[c++] = index[v];
    out.faces.push_back(t);
  }
  return out;
}

/// The faces below @p minQuality grown by @p rings rings of faces (through shared vertices), split into regions
/// connected through shared vertices (so no two regions share a vertex); each region's faces ascending.
std::vector<std::vector<std::uint32_t>> badRegions(const TriangleMesh& mesh, double minQuality, int rings) {
  std::vector<char> selected(mesh.triangles.size(), 0);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) selected[f] = faceQuality(mesh, mesh.triangles[f]) < minQuality;
  for (int r = 0; r < rings; ++r) {
    std::vector<char> vertex(mesh.vertices.size(), 0);
    for (std::size_t f = 0; f < selected.size(); ++f)
      if (selected[f])
        for (int c = 0; c < 3; ++c) vertex[static_cast<std::size_t>(mesh.triangles[f][c])] = 1;
    for (std::size_t f = 0; f < selected.size(); ++f)
      for (int c = 0; c < 3; ++c) selected[f] = selected[f] || vertex[static_cast<std::size_t>(mesh.triangles[f][c])];
  }
  DisjointSets linked(mesh.vertices.size());
  for (std::size_t f = 0; f < selected.size(); ++f)
    if (selected[f])
      for (int c = 1; c < 3; ++c)
        linked.unite(static_cast<std::uint32_t>(mesh.triangles[f][0]), static_cast<std::uint32_t>(mesh.triangles[f][c]));
  std::vector<std::vector<std::uint32_t>> regions;
  std::map<std::uint32_t, std::size_t> id;
  for (std::size_t f = 0; f < selected.size(); ++f)
    if (selected[f]) {
      const auto [it, fresh] = id.emplace(linked.find(static_cast<std::uint32_t>(mesh.triangles[f][0])), regions.size());
      if (fresh) regions.emplace_back();
      regions[it->second].push_back(static_cast<std::uint32_t>(f));
    }
  return regions;
}

}  // namespace

std::size_t remeshBadRegions(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals, double minQuality,
                             int rings, int iterations) {
  if (!(minQuality > 0) || rings < 0 || iterations <= 0 || mesh.triangles.empty()) return 0;
  const std::vector<std::vector<std::uint32_t>> regions = badRegions(mesh, minQuality, rings);
  if (regions.empty()) return 0;
  // The regions share no vertex: each is remeshed against the mesh as it was, and the kept ones put together.
  const detail::VertexFaces vf = detail::vertexFaces(mesh);
  std::vector<RemeshedRegion> remeshed;
  remeshed.reserve(regions.size());
  for (const auto& region : regions) remeshed.push_back(remeshRegion(mesh, vf, region, iterations));
  std::vector<char> replaced(mesh.triangles.size(), 0);
  for (std::size_t r = 0; r < regions.size(); ++r)
    if (remeshed[r].kept)
      for (std::uint32_t f : regions[r]) replaced[f] = 1;
  std::vector<Eigen::Vector3i> faces;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    if (!replaced[f]) faces.push_back(mesh.triangles[f]);
  const bool haveNormals = normals.size() == mesh.vertices.size();
  std::size_t changed = 0;
  for (const RemeshedRegion& r : remeshed) {
    if (!r.kept) continue;
    for (std::size_t k = 0; k < r.movedTo.size(); ++k) {
      mesh.vertices[r.moved[k]] = r.movedTo[k];
      if (haveNormals) normals[r.moved[k]] = r.movedNormals[k];
    }
    const auto base = static_cast<int>(mesh.vertices.size());
    mesh.vertices.insert(mesh.vertices.end(), r.added.begin(), r.added.end());
    if (haveNormals) normals.insert(normals.end(), r.addedNormals.begin(), r.addedNormals.end());
    for (Eigen::Vector3i t : r.faces) {
      for (int c = 0; c < 3; ++c)
        if (t[c] < 0) t[c] = base - t[c] - 1;
      faces.push_back(t);
    }
    changed += r.moved.size() + r.removed + r.added.size();
  }
  mesh.triangles = std::move(faces);
  return changed;
}

}  // namespace iires
