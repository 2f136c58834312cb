// SPDX-License-Identifier: GPL-3.0-or-later
// relaxVertices(): tangential relaxation of the mesh's vertices, kept where their fans get better (mesh_repair.hpp).
#include <Eigen/Geometry>
#include <algorithm>
#include <limits>
#include <vector>

#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "mesh_edges.hpp"
#include "point_triangle.hpp"
#include "vertex_faces.hpp"

namespace iires {

namespace {

/// The vertices that may move: those on no boundary or non-manifold edge, ascending.
std::vector<std::uint32_t> innerVertices(const TriangleMesh& mesh) {
  std::vector<char> fixed(mesh.vertices.size(), 0);
  for (const auto& [key, faces] : detail::edgeFaces(mesh))
    if (faces.size() != 2) fixed[key >> 32] = fixed[key & 0xffffffffu] = 1;
  std::vector<std::uint32_t> inner;
  for (std::uint32_t v = 0; v < mesh.vertices.size(); ++v)
    if (!fixed[v]) inner.push_back(v);
  return inner;
}

}  // namespace

std::size_t relaxVertices(TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals, int sweeps,
                          double maxDeviation) {
  if (sweeps <= 0 || mesh.triangles.empty() || normals.size() != mesh.vertices.size()) return 0;
  const std::vector<std::uint32_t> inner = innerVertices(mesh);
  if (inner.empty()) return 0;
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
    for (std::uint32_t v : inner) {
      const auto first = vf.incident.begin() + vf.start[v], last = vf.incident.begin() + vf.start[v + 1];
      ring.clear();
      for (auto f = first; f != last; ++f)
        for (int c = 0; c < 3; ++c)
          if (static_cast<std::uint32_t>(T[*f][c]) != v) ring.push_back(static_cast<std::uint32_t>(T[*f][c]));
      std::sort(ring.begin(), ring.end());
      ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
      if (first == last || ring.size() != static_cast<std::size_t>(last - first)) continue;  // not a closed disc
      Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
      for (std::uint32_t r : ring) centroid += P[r];
      centroid /= static_cast<double>(ring.size());
      const Eigen::Vector3d& n = normals[v];
      const Eigen::Vector3d step = 0.5 * (centroid - P[v] - n * n.dot(centroid - P[v]));
      const Eigen::Vector3d old = P[v], target = P[v] + step;
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
