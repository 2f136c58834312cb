// SPDX-License-Identifier: GPL-3.0-or-later
// A mesh read as a point cloud: its vertices, and points on the faces too large for them to sample.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "io_format.hpp"

namespace iires::detail::io {

namespace {

/// A mesh's surface reads as at least about this many points (a cube's 8 vertices sample nothing of it) and
/// at most about kMaxFacePoints more than its vertices.
constexpr double kMinSurfacePoints = 1.0e5, kMaxFacePoints = 4.0e6;

/// The k-th point of the R2 low-discrepancy sequence in the unit square, folded into the triangle u + v ≤ 1:
/// well spread, and the same on every run (no random state).
Eigen::Vector2d foldedR2(std::size_t k) {
  constexpr double a1 = 0.7548776662466927, a2 = 0.5698402909980532;  // 1/φ₂, 1/φ₂² (φ₂: the plastic number)
  double u = std::fmod(0.5 + a1 * static_cast<double>(k), 1.0),
         v = std::fmod(0.5 + a2 * static_cast<double>(k), 1.0);
  if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
  return {u, v};
}

/// The median length of the faces' edges (each counted once per face; zero-length ones skipped): the
/// vertices' spacing, without a neighbour search over them.
double medianEdgeLength(const Geometry& g) {
  std::vector<double> lengths;
  lengths.reserve(3 * g.triangles.size());
  for (const Vector3i& t : g.triangles)
    for (int k = 0; k < 3; ++k) {
      const double l = (g.points[t[(k + 1) % 3]] - g.points[t[k]]).norm();
      if (l > 0 && std::isfinite(l)) lengths.push_back(l);
    }
  if (lengths.empty()) return 0.0;
  std::nth_element(lengths.begin(), lengths.begin() + static_cast<std::ptrdiff_t>(lengths.size() / 2),
                   lengths.end());
  return lengths[lengths.size() / 2];
}

}  // namespace

void addFaceSamples(Geometry& g) {
  const std::size_t vertices = g.points.size();
  double area = 0;
  std::vector<double> faceArea(g.triangles.size());
  for (std::size_t f = 0; f < g.triangles.size(); ++f) {
    const Vector3i& t = g.triangles[f];
    faceArea[f] = 0.5 * (g.points[t[1]] - g.points[t[0]]).cross(g.points[t[2]] - g.points[t[0]]).norm();
    if (std::isfinite(faceArea[f])) area += faceArea[f];
  }
  // One point per s² of a face, s the median edge length: a mesh as fine as its vertices (each face
  // smaller than s²) gets none, a CAD part's large flat faces as many as their area needs; and at least
  // kMinSurfacePoints over the whole surface.
  const double s = medianEdgeLength(g);
  if (!(s > 0) || !(area > 0)) return;
  const double cell = std::max(std::min(s * s, area / kMinSurfacePoints), area / kMaxFacePoints);
  const bool normals = g.normals.size() == vertices;
  for (std::size_t f = 0; f < g.triangles.size(); ++f) {
    if (!(faceArea[f] >= cell)) continue;
    const Vector3i& t = g.triangles[f];
    const Vector3d a = g.points[t[0]], b = g.points[t[1]], c = g.points[t[2]];  // copies: g.points grows
    const Vector3d faceNormal = (b - a).cross(c - a).normalized();
    const auto count = static_cast<std::size_t>(faceArea[f] / cell);
    for (std::size_t k = 0; k < count; ++k) {
      const Eigen::Vector2d uv = foldedR2(k + 1);
      const double w[3] = {1.0 - uv.x() - uv.y(), uv.x(), uv.y()};
      g.points.push_back(w[0] * a + w[1] * b + w[2] * c);
      if (normals) {  // the file's, blended
        const Vector3d n = w[0] * g.normals[t[0]] + w[1] * g.normals[t[1]] + w[2] * g.normals[t[2]];
        g.normals.push_back(n.norm() > 0 ? Vector3d(n.normalized()) : faceNormal);
      }
      // Attributes: a blend of the corners' values (as interpolateAttributes() averages), a label the nearest
      // corner's.
      const int nearest = static_cast<int>(std::max_element(w, w + 3) - w);
      for (PointAttribute& attr : g.attributes) {
        const std::vector<double>& v = attr.values;
        attr.values.push_back(attr.kind == AttributeKind::kLabel
                                  ? v[t[nearest]]
                                  : w[0] * v[t[0]] + w[1] * v[t[1]] + w[2] * v[t[2]]);
      }
    }
  }
}

}  // namespace iires::detail::io
