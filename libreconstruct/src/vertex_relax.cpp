// SPDX-License-Identifier: GPL-3.0-or-later
// relaxVertices(): tangential relaxation of the mesh's vertices, kept where their fans get better (mesh_repair.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "mesh_edges.hpp"
#include "point_triangle.hpp"
#include "vertex_faces.hpp"

namespace iires {

namespace {

constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

/// The vertices that may move, ascending, and for each vertex on a rim its two rim neighbours: a vertex on no
/// non-manifold edge and on either no boundary edge or exactly two ({kNone, kNone} for the others).
struct Movable {
  std::vector<std::uint32_t> vertices;
  std::vector<std::array<std::uint32_t, 2>> rim;
};

Movable movableVertices(const TriangleMesh& mesh) {
  Movable m;
  m.rim.assign(mesh.vertices.size(), {kNone, kNone});
  std::vector<int> boundaryEdges(mesh.vertices.size(), 0);
  std::vector<char> fixed(mesh.vertices.size(), 0);
  for (const auto& [key, faces] : detail::edgeFaces(mesh)) {
    const auto a = static_cast<std::uint32_t>(key >> 32), b = static_cast<std::uint32_t>(key & 0xffffffffu);
    if (faces.size() > 2) fixed[a] = fixed[b] = 1;
    if (faces.size() != 1) continue;
    for (auto [v, other] : {std::pair{a, b}, std::pair{b, a}}) {
      if (boundaryEdges[v] < 2) m.rim[v][boundaryEdges[v]] = other;
      ++boundaryEdges[v];
    }
  }
  for (std::uint32_t v = 0; v < mesh.vertices.size(); ++v) {
    if (boundaryEdges[v] != 0 && boundaryEdges[v] != 2) fixed[v] = 1;
    if (fixed[v]) m.rim[v] = {kNone, kNone};
    else m.vertices.push_back(v);
  }
  return m;
}

/// Where vertex @p v moves: inside, halfway to its neighbours' centroid (@p ring) in its tangent plane (normal @p n);
/// on a rim, halfway to its rim neighbours' midpoint, then back onto the rim's two edges (the rim keeps its shape).
Eigen::Vector3d relaxedPosition(const std::vector<Eigen::Vector3d>& P, std::uint32_t v,
                                const std::array<std::uint32_t, 2>& rim, const std::vector<std::uint32_t>& ring,
                                const Eigen::Vector3d& n) {
  if (rim[0] != kNone) {
    const Eigen::Vector3d target = P[v] + 0.5 * (0.5 * (P[rim[0]] + P[rim[1]]) - P[v]);
    const Eigen::Vector3d a = detail::closestPointOnSegment(target, P[rim[0]], P[v]);
    const Eigen::Vector3d b = detail::closestPointOnSegment(target, P[v], P[rim[1]]);
    return (a - target).squaredNorm() <= (b - target).squaredNorm() ? a : b;
  }
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (std::uint32_t r : ring) centroid += P[r];
  centroid /= static_cast<double>(ring.size());
  return P[v] + 0.5 * (centroid - P[v] - n * n.dot(centroid - P[v]));
}

}  // namespace

std::size_t relaxVertices(TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals, int sweeps,
                          double maxDeviation) {
  if (sweeps <= 0 || mesh.triangles.empty() || normals.size() != mesh.vertices.size()) return 0;
  const Movable movable = movableVertices(mesh);
  if (movable.vertices.empty()) return 0;
  auto& P = mesh.vertices;
  const auto& T = mesh.triangles;
  double edgeSum = 0;
  for (const auto& t : T)
    for (int c = 0; c < 3; ++c) edgeSum += (P[t[c]] - P[t[(c + 1) % 3]]).norm();
  const double tolerance = maxDeviation * edgeSum / (3.0 * static_cast<double>(T.size()));
  const detail::VertexFaces vf = detail::vertexFaces(mesh);
  std::vector<char> moved(P.size(), 0);
  std::vector<std::uint32_t> ring;
  for (int sweep = 0; sweep < sweeps; ++sweep) {
    for (std::uint32_t v : movable.vertices) {
      const auto first = vf.incident.begin() + vf.start[v], last = vf.incident.begin() + vf.start[v + 1];
      ring.clear();
      for (auto f = first; f != last; ++f)
        for (int c = 0; c < 3; ++c)
          if (static_cast<std::uint32_t>(T[*f][c]) != v) ring.push_back(static_cast<std::uint32_t>(T[*f][c]));
      std::sort(ring.begin(), ring.end());
      ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
      const bool onRim = movable.rim[v][0] != kNone;
      // One fan around v: a closed disc inside, a half disc on a rim.
      if (first == last || ring.size() != static_cast<std::size_t>(last - first) + (onRim ? 1 : 0)) continue;
      const Eigen::Vector3d& n = normals[v];
      const Eigen::Vector3d old = P[v], target = relaxedPosition(P, v, movable.rim[v], ring, n);
      double oldMin = 1, oldSum = 0, newMin = 1, newSum = 0, deviation = std::numeric_limits<double>::max();
      bool turned = false;
      for (auto f = first; f != last && !turned; ++f) {
        const Eigen::Vector3d &a = P[T[*f][0]], &b = P[T[*f][1]], &c = P[T[*f][2]];
        const Eigen::Vector3d before = (b - a).cross(c - a);
        const double q0 = triangleQuality(a, b, c);
        P[v] = target;
        const Eigen::Vector3d after = (b - a).cross(c - a);
        const double q1 = triangleQuality(a, b, c);
        deviation = std::min(deviation, detail::pointTriangleDistance(old, a, b, c));
        P[v] = old;
        turned = after.dot(before) <= 0 || after.dot(n) * before.dot(n) <= 0;
        oldMin = std::min(oldMin, q0), oldSum += q0, newMin = std::min(newMin, q1), newSum += q1;
      }
      if (turned || newMin < oldMin || newSum <= oldSum || deviation > tolerance) continue;
      P[v] = target;
      moved[v] = 1;
    }
  }
  return static_cast<std::size_t>(std::count(moved.begin(), moved.end(), 1));
}

}  // namespace iires
