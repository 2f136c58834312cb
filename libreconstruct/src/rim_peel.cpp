// SPDX-License-Identifier: GPL-3.0-or-later
// peelRimSlivers(): poor triangles on an open rim that lie within a mesh spacing of the rim left without them (or
// whose obtuse corner lies inside the rim edge's diametral ball) are removed (mesh_repair.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "mesh_edges.hpp"
#include "point_triangle.hpp"
#include "polygon_fill.hpp"

namespace iires {

using detail::vtx;

namespace {

constexpr int kMaxPasses = 4;  ///< a peel exposes two edges; their faces are looked at in the next pass

/// Angle at @p o of the triangle (o, x, y) is obtuse.
bool obtuseAt(const Eigen::Vector3d& o, const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
  return (x - o).dot(y - o) < 0;
}

double segmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return (p - detail::closestPointOnSegment(p, a, b)).norm();
}

/// How far the rim edge [x, y] of a triangle with apex o lies from its other two edges at most (sampled along it):
/// the depth the rim moves in by when the triangle goes.
double rimEdgeDepth(const Eigen::Vector3d& o, const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
  constexpr int kSteps = 16;
  double depth = 0;
  for (int k = 1; k < kSteps; ++k) {
    const Eigen::Vector3d p = x + (y - x) * (static_cast<double>(k) / kSteps);
    depth = std::max(depth, std::min(segmentDistance(p, o, x), segmentDistance(p, o, y)));
  }
  return depth;
}

/// Whether face @p t is to be peeled. @p rim: its corners' edges (c, c + 1) used by it alone; @p onRim: per vertex,
/// whether it ends a boundary edge. One rim edge: the opposite corner must be on no rim (it becomes a rim vertex and
/// stays manifold) and obtuse (inside the edge's diametral ball), or the rim edge within @p reach of the other two.
/// Two rim edges (an ear): the corner between them obtuse, or within @p reach of the opposite edge; it is left in
/// no face.
bool peelable(const TriangleMesh& mesh, const Eigen::Vector3i& t, const std::array<bool, 3>& rim,
              const std::vector<char>& onRim, double reach) {
  const int rims = rim[0] + rim[1] + rim[2];
  const auto& P = mesh.vertices;
  for (int c = 0; c < 3; ++c) {
    const Eigen::Vector3d &o = P[vtx(t, c)], &x = P[vtx(t, (c + 1) % 3)], &y = P[vtx(t, (c + 2) % 3)];
    // Edge (c + 1, c + 2) lies opposite corner c; edges (c, c + 1) and (c + 2, c) meet at it.
    if (rims == 1 && rim[(c + 1) % 3] && !onRim[vtx(t, c)])
      return obtuseAt(o, x, y) || rimEdgeDepth(o, x, y) <= reach;
    if (rims == 2 && rim[c] && rim[(c + 2) % 3]) return obtuseAt(o, x, y) || segmentDistance(o, x, y) <= reach;
  }
  return false;
}

}  // namespace

std::size_t peelRimSlivers(TriangleMesh& mesh, double minQuality) {
  std::size_t peeled = 0;
  // The mesh spacing: input under a peeled face stays within it of the mesh (the coverage test allows two).
  double edgeSum = 0;
  for (const auto& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) edgeSum += (mesh.vertices[vtx(t, c)] - mesh.vertices[vtx(t, (c + 1) % 3)]).norm();
  const double reach = edgeSum / static_cast<double>(3 * std::max<std::size_t>(mesh.triangles.size(), 1));
  for (int pass = 0; pass < kMaxPasses; ++pass) {
    std::vector<std::uint32_t> poor;  // most meshes have none: then no edge map is built
    for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) {
      const auto& t = mesh.triangles[f];
      if (triangleQuality(mesh.vertices[vtx(t, 0)], mesh.vertices[vtx(t, 1)], mesh.vertices[vtx(t, 2)]) < minQuality)
        poor.push_back(f);
    }
    if (poor.empty()) break;
    const auto faces = detail::edgeFaces(mesh);
    std::vector<char> onRim(mesh.vertices.size(), 0), remove(mesh.triangles.size(), 0), touched(onRim.size(), 0);
    for (const auto& [key, list] : faces)
      if (list.size() == 1) onRim[key >> 32] = onRim[key & 0xffffffffu] = 1;
    std::size_t now = 0;
    for (const std::uint32_t f : poor) {
      const auto& t = mesh.triangles[f];
      std::array<bool, 3> rim{};
      for (int c = 0; c < 3; ++c) rim[c] = faces.at(detail::undirectedKey(vtx(t, c), vtx(t, (c + 1) % 3))).size() == 1;
      // Neighbouring peels in one pass could pinch a vertex between them: one peel per vertex and pass.
      if (touched[vtx(t, 0)] || touched[vtx(t, 1)] || touched[vtx(t, 2)] || !peelable(mesh, t, rim, onRim, reach))
        continue;
      remove[f] = 1;
      for (int c = 0; c < 3; ++c) touched[vtx(t, c)] = 1;
      ++now;
    }
    if (now == 0) break;
    std::size_t w = 0;
    for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
      if (!remove[f]) mesh.triangles[w++] = mesh.triangles[f];
    mesh.triangles.resize(w);
    peeled += now;
  }
  return peeled;
}

}  // namespace iires
