// SPDX-License-Identifier: GPL-3.0-or-later
// Scoring detected features and sampled edges against the sharp edges of a reference mesh (tests, bench).
#include "iires/features.hpp"



#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <list>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>

#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"


#include "features_internal.hpp"

namespace iires {
using namespace detail;
namespace {

double segmentDistance(const Eigen::Vector3d& p, const Segment& s) {
  const Eigen::Vector3d e = s[1] - s[0];
  const double l2 = e.squaredNorm();
  const double t = l2 > 0 ? std::clamp((p - s[0]).dot(e) / l2, 0.0, 1.0) : 0.0;
  return (s[0] + t * e - p).norm();
}

}  // namespace

std::vector<Segment> sharpMeshEdges(const TriangleMesh& mesh, double minAngleDegrees, bool includeBoundary) {
  // Vertices at the same position are one vertex: a triangle soup (each face with its own copies, as some CAD
  // exports are) has the same edges as the mesh it was welded from.
  std::map<std::tuple<double, double, double>, int> weld;
  std::vector<int> id(mesh.vertices.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    const Eigen::Vector3d& p = mesh.vertices[v];
    id[v] = weld.emplace(std::make_tuple(p.x(), p.y(), p.z()), static_cast<int>(v)).first->second;
  }
  std::map<std::pair<int, int>, std::vector<std::size_t>> faces;
  std::vector<Eigen::Vector3d> fn(mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    fn[f] = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    if (fn[f].norm() > 0) fn[f].normalize();
    for (int e = 0; e < 3; ++e) {
      const int a = id[t[e]], b = id[t[(e + 1) % 3]];
      faces[{std::min(a, b), std::max(a, b)}].push_back(f);
    }
  }
  std::vector<Segment> out;
  const double cosMin = std::cos(minAngleDegrees * kDeg);
  for (const auto& [e, fs] : faces) {
    bool sharp = fs.size() == 1 ? includeBoundary : false;
    for (std::size_t a = 0; a < fs.size() && !sharp; ++a)
      for (std::size_t b = a + 1; b < fs.size() && !sharp; ++b) sharp = fn[fs[a]].dot(fn[fs[b]]) < cosMin;
    if (sharp) out.push_back({mesh.vertices[e.first], mesh.vertices[e.second]});
  }
  return out;
}

std::vector<Eigen::Vector3d> sampleSegments(const std::vector<Segment>& edges, double step,
                                            std::vector<std::uint32_t>* owner) {
  if (!(step > 0)) throw std::invalid_argument("sampleSegments: step must be > 0");
  std::vector<Eigen::Vector3d> out;
  if (owner) owner->clear();
  for (std::uint32_t e = 0; e < edges.size(); ++e) {
    const double len = (edges[e][1] - edges[e][0]).norm();
    const int m = std::max(1, static_cast<int>(std::ceil(len / step)));
    for (int t = 0; t <= m; ++t) {
      out.push_back(edges[e][0] + (edges[e][1] - edges[e][0]) * (static_cast<double>(t) / m));
      if (owner) owner->push_back(e);
    }
  }
  return out;
}

double distanceToSegments(const Eigen::Vector3d& p, const std::vector<Segment>& edges) {
  double best = std::numeric_limits<double>::infinity();
  for (const Segment& s : edges) best = std::min(best, segmentDistance(p, s));
  return best;
}

FeatureScore scoreFeatures(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<std::uint32_t>& featureIndices, const std::vector<Segment>& edges,
                           double tolerance, double band, int threads) {
  FeatureScore s;
  s.detected = featureIndices.size();
  if (edges.empty() || points.empty()) return s;
  // Densify the edges at step δ; a point within r of an edge has a densified sample within r + δ/2.
  const double reach = std::max(tolerance, band);
  const double step = std::max(reach, 1e-12);
  std::vector<std::uint32_t> owner;
  const std::vector<Eigen::Vector3d> dense = sampleSegments(edges, step, &owner);
  KnnIndex index(dense);
  std::vector<double> dist(points.size());
  parallelFor(points.size(), threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.radius(points[i], reach + step, idx, d2);
    double best = std::numeric_limits<double>::infinity();
    for (std::uint32_t j : idx) best = std::min(best, segmentDistance(points[i], edges[owner[j]]));
    dist[i] = best;
  });
  std::vector<char> flagged(points.size(), 0);
  std::size_t tp = 0;
  for (std::uint32_t i : featureIndices) {
    flagged[i] = 1;
    if (dist[i] <= tolerance) ++tp;
  }
  std::size_t found = 0;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (dist[i] <= band) {
      ++s.nearEdge;
      found += flagged[i];
    }
  s.precision = s.detected > 0 ? static_cast<double>(tp) / static_cast<double>(s.detected) : 1.0;
  s.recall = s.nearEdge > 0 ? static_cast<double>(found) / static_cast<double>(s.nearEdge) : 1.0;
  return s;
}


}  // namespace iires
