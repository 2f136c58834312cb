// SPDX-License-Identifier: GPL-3.0-or-later
// peelRimSlivers(): poor triangles on an open rim whose obtuse corner lies inside the rim's diametral ball are
// removed (mesh_repair.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cstdint>
#include <utility>
#include <vector>

#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "mesh_edges.hpp"
#include "polygon_fill.hpp"

namespace iires {

using detail::vtx;

namespace {

constexpr int kMaxPasses = 4;  ///< a peel exposes two edges; their faces are looked at in the next pass

/// Angle at @p o of the triangle (o, x, y) is obtuse.
bool obtuseAt(const Eigen::Vector3d& o, const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
  return (x - o).dot(y - o) < 0;
}

/// Whether face @p t is to be peeled. @p rim: its corners' edges (c, c + 1) used by it alone; @p onRim: per vertex,
/// whether it ends a boundary edge. One rim edge: the opposite corner must be obtuse (inside the edge's diametral
/// ball) and on no rim (it becomes a rim vertex and stays manifold). Two rim edges (an ear): the corner between them
/// obtuse; it is left in no face.
bool peelable(const TriangleMesh& mesh, const Eigen::Vector3i& t, const std::array<bool, 3>& rim,
              const std::vector<char>& onRim) {
  const int rims = rim[0] + rim[1] + rim[2];
  const auto& P = mesh.vertices;
  for (int c = 0; c < 3; ++c) {
    const Eigen::Vector3d &o = P[vtx(t, c)], &x = P[vtx(t, (c + 1) % 3)], &y = P[vtx(t, (c + 2) % 3)];
    if (!obtuseAt(o, x, y)) continue;
    // Edge (c + 1, c + 2) lies opposite corner c; edges (c, c + 1) and (c + 2, c) meet at it.
    if (rims == 1 && rim[(c + 1) % 3] && !onRim[vtx(t, c)]) return true;
    if (rims == 2 && rim[c] && rim[(c + 2) % 3]) return true;
  }
  return false;
}

}  // namespace

std::size_t peelRimSlivers(TriangleMesh& mesh, double minQuality) {
  std::size_t peeled = 0;
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
      if (touched[vtx(t, 0)] || touched[vtx(t, 1)] || touched[vtx(t, 2)] || !peelable(mesh, t, rim, onRim)) continue;
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
