// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/reconstruct/mesh_repair.hpp"

#include "mesh_edges.hpp"
#include "point_triangle.hpp"
#include "polygon_fill.hpp"
#include "vertex_faces.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <unordered_map>
#include <unordered_set>

#include "iires/detail/parallel.hpp"
#include "iires/reconstruct/mesh_quality.hpp"

namespace iires {
namespace {

using detail::directedKey;
using detail::edgeFaces;
using detail::faceNormal;
using detail::pointTriangleDistance;
using detail::triangulatePolygon;
using detail::undirectedKey;
using detail::vtx;

/// Angle at vertex o of triangle (o, x, y), radians.
double cornerAngle(const Eigen::Vector3d& o, const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
  const Eigen::Vector3d u = x - o, v = y - o;
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

}  // namespace

const SampledPoints::Adjacency& SampledPoints::adjacency() const {
  std::call_once(adjacencyBuilt_, [this] {
    if (!graph_) return;
    const Edges edges = graph_();
    adjacency_.start.assign(points_->size() + 1, 0);
    for (const auto& e : edges) ++adjacency_.start[e[0] + 1], ++adjacency_.start[e[1] + 1];
    for (std::size_t i = 0; i < points_->size(); ++i) adjacency_.start[i + 1] += adjacency_.start[i];
    adjacency_.neighbours.resize(adjacency_.start.back());
    std::vector<std::uint32_t> fill(adjacency_.start.begin(), adjacency_.start.end() - 1);
    for (const auto& e : edges) adjacency_.neighbours[fill[e[0]]++] = e[1], adjacency_.neighbours[fill[e[1]]++] = e[0];
  });
  return adjacency_;
}

BadTriangleReport repairBadTriangles(TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals,
                                     double minQuality, double maxDeviation) {
  BadTriangleReport report;
  if (!(minQuality > 0) || mesh.triangles.empty() || normals.size() != mesh.vertices.size()) return report;
  auto& T = mesh.triangles;
  auto& P = mesh.vertices;
  double edgeSum = 0;
  for (const auto& t : T)
    for (int c = 0; c < 3; ++c) edgeSum += (P[vtx(t, c)] - P[vtx(t, (c + 1) % 3)]).norm();
  const double tolerance = maxDeviation * edgeSum / (3.0 * static_cast<double>(T.size()));
  std::vector<std::vector<std::uint32_t>> incident(P.size());
  for (std::uint32_t f = 0; f < T.size(); ++f)
    for (int c = 0; c < 3; ++c) incident[vtx(T[f], c)].push_back(f);
  std::vector<char> removed(T.size(), 0);
  auto quality = [&](std::uint32_t f) { return triangleQuality(P[vtx(T[f], 0)], P[vtx(T[f], 1)], P[vtx(T[f], 2)]); };
  auto distanceTo = [&](const Eigen::Vector3d& x, const std::vector<Eigen::Vector3i>& faces) {
    double d = std::numeric_limits<double>::max();
    for (const auto& t : faces) d = std::min(d, pointTriangleDistance(x, P[vtx(t, 0)], P[vtx(t, 1)], P[vtx(t, 2)]));
    return d;
  };
  std::vector<std::pair<double, std::uint32_t>> bad;
  for (std::uint32_t f = 0; f < T.size(); ++f)
    if (const double q = quality(f); q < minQuality) bad.emplace_back(q, f);
  std::sort(bad.begin(), bad.end());
  for (const auto& entry : bad) {
    const std::uint32_t f = entry.second;
    if (removed[f]) continue;
    const double q0 = quality(f);  // an earlier repair nearby may have changed it
    if (q0 >= minQuality) continue;
    // Per vertex of the face with a closed disc fan: (1) moved within its tangent plane to its ring's centroid,
    // (2) removed and its ring re-triangulated. The move (which keeps the vertex) wins when it reaches minQuality
    // or does at least as well as the best removal.
    double moveQuality = q0, removeQuality = q0;
    std::uint32_t moveVertex = 0, removeVertex = 0;
    Eigen::Vector3d moveTo = Eigen::Vector3d::Zero();
    std::vector<Eigen::Vector3i> removeFaces;
    for (int corner = 0; corner < 3; ++corner) {
      const std::uint32_t v = vtx(T[f], corner);
      // v's fan as a map a → b over its faces (v, a, b); it must be one closed, consistently oriented disc.
      std::map<std::uint32_t, std::uint32_t> after;
      double fanQuality = 1;
      bool ok = true;
      for (std::uint32_t g : incident[v]) {
        int c = 0;
        while (vtx(T[g], c) != v) ++c;
        ok = ok && after.emplace(vtx(T[g], (c + 1) % 3), vtx(T[g], (c + 2) % 3)).second;
        fanQuality = std::min(fanQuality, quality(g));
      }
      if (!ok || after.size() < 3) continue;
      std::vector<std::uint32_t> ring{after.begin()->first};
      while (ring.size() <= after.size()) {
        const auto it = after.find(ring.back());
        if (it == after.end()) break;
        ring.push_back(it->second);
      }
      if (ring.size() != after.size() + 1 || ring.back() != ring.front()) continue;  // an open or pinched fan
      ring.pop_back();
      // (1) The move: the fan keeps its faces, none may flip against the vertex normal or its old normal.
      {
        Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
        for (std::uint32_t r : ring) centroid += P[r];
        centroid /= static_cast<double>(ring.size());
        const Eigen::Vector3d& n = normals[v];
        const Eigen::Vector3d target = P[v] + (centroid - P[v]) - n * n.dot(centroid - P[v]);
        double worst = 1;
        std::vector<Eigen::Vector3i> fan;
        for (std::size_t i = 0; i < ring.size(); ++i) {
          const Eigen::Vector3d &a = P[ring[i]], &b = P[ring[(i + 1) % ring.size()]];
          const Eigen::Vector3d before = (a - P[v]).cross(b - P[v]), now = (a - target).cross(b - target);
          worst = now.dot(n) > 0 && now.dot(before) > 0 ? std::min(worst, triangleQuality(target, a, b)) : 0.0;
          if (worst == 0) break;
          fan.emplace_back(static_cast<int>(ring[i]), static_cast<int>(ring[(i + 1) % ring.size()]), static_cast<int>(v));
        }
        if (worst > std::max(moveQuality, fanQuality)) {
          const Eigen::Vector3d old = P[v];
          P[v] = target;
          const bool near = distanceTo(old, fan) <= tolerance;
          P[v] = old;
          if (near) moveQuality = worst, moveVertex = v, moveTo = target;
        }
      }
      // (2) The removal: edges among the ring's vertices other than v's spokes, and the faces across the ring.
      std::unordered_set<std::uint64_t> edges;
      std::unordered_map<std::uint64_t, Eigen::Vector3d> across;
      for (std::uint32_t r : ring)
        for (std::uint32_t g : incident[r]) {
          const auto& t = T[g];
          if (t[0] == static_cast<int>(v) || t[1] == static_cast<int>(v) || t[2] == static_cast<int>(v)) continue;
          for (int c = 0; c < 3; ++c) {
            edges.insert(undirectedKey(vtx(t, c), vtx(t, (c + 1) % 3)));
            across[directedKey(vtx(t, c), vtx(t, (c + 1) % 3))] = faceNormal(mesh, vtx(t, 0), vtx(t, 1), vtx(t, 2)).normalized();
          }
        }
      std::vector<Eigen::Vector3i> faces;
      double ringQuality = 0;
      const auto isEdge = [&](std::uint64_t key) { return edges.count(key) > 0; };
      if (!triangulatePolygon(mesh, normals, ring, isEdge, true, faces, &ringQuality, &across) ||
          ringQuality <= std::max(removeQuality, fanQuality) || distanceTo(P[v], faces) > tolerance)
        continue;
      removeQuality = ringQuality, removeVertex = v, removeFaces = faces;
    }
    if (moveQuality > q0 && (moveQuality >= minQuality || moveQuality >= removeQuality)) {
      P[moveVertex] = moveTo;
      ++report.moved;
      continue;
    }
    if (removeFaces.empty()) continue;
    for (std::uint32_t g : std::vector<std::uint32_t>(incident[removeVertex])) {
      removed[g] = 1;
      for (int c = 0; c < 3; ++c) {
        auto& list = incident[vtx(T[g], c)];
        list.erase(std::find(list.begin(), list.end(), g));
      }
    }
    for (const auto& t : removeFaces) {
      const auto g = static_cast<std::uint32_t>(T.size());
      T.push_back(t);
      removed.push_back(0);
      for (int c = 0; c < 3; ++c) incident[vtx(t, c)].push_back(g);
    }
    ++report.removed;
  }
  std::size_t w = 0;
  for (std::size_t g = 0; g < T.size(); ++g)
    if (!removed[g]) T[w++] = T[g];
  T.resize(w);
  return report;
}

namespace {

/// The fans around one vertex: faces joined through a shared edge (v, x), by union-find over local indices.
struct Fans {
  std::vector<std::uint32_t> parent, size;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> spokes;  // (other vertex, local face)

  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  /// Groups @p faces (all around @p v) into fans; returns how many.
  std::size_t group(const std::vector<Eigen::Vector3i>& T, std::uint32_t v, const std::vector<std::uint32_t>& faces) {
    parent.resize(faces.size());
    for (std::uint32_t i = 0; i < faces.size(); ++i) parent[i] = i;
    spokes.clear();
    for (std::uint32_t i = 0; i < faces.size(); ++i)
      for (int c = 0; c < 3; ++c)
        if (const std::uint32_t x = vtx(T[faces[i]], c); x != v) spokes.emplace_back(x, i);
    std::sort(spokes.begin(), spokes.end());
    std::size_t fans = faces.size();
    for (std::size_t s = 1; s < spokes.size(); ++s)
      if (spokes[s].first == spokes[s - 1].first) {
        const std::uint32_t a = find(spokes[s].second), b = find(spokes[s - 1].second);
        if (a != b) parent[std::max(a, b)] = std::min(a, b), --fans;
      }
    return fans;
  }
};

}  // namespace

std::size_t removeExtraFans(TriangleMesh& mesh, int threads, const std::vector<char>* only) {
  auto& T = mesh.triangles;
  const std::size_t nv = mesh.vertices.size();
  const detail::VertexFaces vf = detail::vertexFaces(mesh);
  const std::vector<std::uint32_t>&start = vf.start, &incident = vf.incident;
  // Which vertices have several fans in the mesh as given (in parallel); the ordered pass below visits those,
  // and any vertex that lost a face to an earlier one.
  std::vector<char> several(nv, 0);
  parallelFor(nv, threads, [&](std::size_t v) {
    if (only && !(*only)[v]) return;
    thread_local Fans fans;
    thread_local std::vector<std::uint32_t> faces;
    faces.assign(incident.begin() + start[v], incident.begin() + start[v + 1]);
    several[v] = faces.size() > 1 && fans.group(T, static_cast<std::uint32_t>(v), faces) > 1;
  });
  std::vector<char> removed(T.size(), 0);
  std::size_t count = 0;
  std::vector<std::uint32_t> faces;
  Fans fans;
  for (std::uint32_t v = 0; v < nv; ++v) {
    faces.clear();
    for (std::uint32_t s = start[v]; s < start[v + 1]; ++s)
      if (!removed[incident[s]]) faces.push_back(incident[s]);
    if (faces.size() < 2 || (!several[v] && faces.size() == start[v + 1] - start[v])) continue;
    if (fans.group(T, v, faces) < 2) continue;
    fans.size.assign(faces.size(), 0);
    for (std::uint32_t i = 0; i < faces.size(); ++i) ++fans.size[fans.find(i)];
    std::uint32_t best = 0;
    for (std::uint32_t i = 1; i < faces.size(); ++i)
      if (fans.size[i] > fans.size[best]) best = i;  // roots only have size > 0; ties keep the lowest face
    for (std::uint32_t i = 0; i < faces.size(); ++i)
      if (fans.find(i) != best) removed[faces[i]] = 1, ++count;
  }
  if (count) {
    std::size_t w = 0;
    for (std::size_t f = 0; f < T.size(); ++f)
      if (!removed[f]) T[w++] = T[f];
    T.resize(w);
  }
  return count;
}

std::size_t removeSmallComponents(TriangleMesh& mesh, std::size_t minFaces) {
  auto& T = mesh.triangles;
  std::vector<std::uint32_t> parent(mesh.vertices.size());
  for (std::uint32_t i = 0; i < parent.size(); ++i) parent[i] = i;
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& t : T)
    for (int c = 1; c < 3; ++c) {
      const std::uint32_t a = find(vtx(t, 0)), b = find(vtx(t, c));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<std::size_t> size(parent.size(), 0);
  for (const auto& t : T) ++size[find(vtx(t, 0))];
  std::size_t w = 0;
  for (std::size_t f = 0; f < T.size(); ++f)
    if (size[find(vtx(T[f], 0))] >= minFaces) T[w++] = T[f];
  const std::size_t removed = T.size() - w;
  T.resize(w);
  return removed;
}

std::size_t flipToDelaunay(TriangleMesh& mesh, double maxDihedralDeg, int maxSweeps) {
  const double cosMax = std::cos(maxDihedralDeg * M_PI / 180.0);
  std::size_t flips = 0;
  auto& T = mesh.triangles;
  const auto& P = mesh.vertices;
  for (int sweep = 0; sweep < maxSweeps; ++sweep) {
    auto map = edgeFaces(mesh);
    std::vector<std::uint64_t> keys;
    keys.reserve(map.size());
    for (const auto& [key, faces] : map)
      if (faces.size() == 2) keys.push_back(key);
    std::sort(keys.begin(), keys.end());
    std::vector<char> dirty(T.size(), 0);
    std::size_t sweepFlips = 0;
    for (std::uint64_t key : keys) {
      const auto& faces = map[key];
      std::uint32_t f1 = faces[0], f2 = faces[1];
      if (dirty[f1] || dirty[f2]) continue;
      // Arrange f1 = (a, b, c) and f2 = (b, a, d).
      const std::uint32_t x = static_cast<std::uint32_t>(key >> 32), y = static_cast<std::uint32_t>(key);
      auto rotate = [&](std::uint32_t f, std::uint32_t from, std::uint32_t to, std::uint32_t& third) {
        const auto& t = T[f];
        for (int c = 0; c < 3; ++c)
          if (vtx(t, c) == from && vtx(t, (c + 1) % 3) == to) {
            third = vtx(t, (c + 2) % 3);
            return true;
          }
        return false;
      };
      std::uint32_t a = x, b = y, c = 0, d = 0;
      if (!rotate(f1, a, b, c)) std::swap(a, b);
      if (!rotate(f1, a, b, c) || !rotate(f2, b, a, d)) continue;  // inconsistent orientation: leave it
      if (c == d) continue;
      const double sum = cornerAngle(P[c], P[a], P[b]) + cornerAngle(P[d], P[b], P[a]);
      if (sum <= M_PI + 1e-9) continue;
      const Eigen::Vector3d n1 = faceNormal(mesh, a, b, c).normalized(), n2 = faceNormal(mesh, b, a, d).normalized();
      if (n1.dot(n2) < cosMax) continue;
      const Eigen::Vector3d m1 = faceNormal(mesh, a, d, c), m2 = faceNormal(mesh, d, b, c);
      if (m1.norm() == 0 || m2.norm() == 0) continue;
      const Eigen::Vector3d u1 = m1.normalized(), u2 = m2.normalized();
      if (u1.dot(u2) < cosMax || u1.dot(n1 + n2) <= 0 || u2.dot(n1 + n2) <= 0) continue;
      if (map.count(undirectedKey(c, d))) continue;
      const double before = std::min(triangleMinAngle(P[a], P[b], P[c]), triangleMinAngle(P[b], P[a], P[d]));
      const double after = std::min(triangleMinAngle(P[a], P[d], P[c]), triangleMinAngle(P[d], P[b], P[c]));
      if (after <= before) continue;
      T[f1] = Eigen::Vector3i(static_cast<int>(a), static_cast<int>(d), static_cast<int>(c));
      T[f2] = Eigen::Vector3i(static_cast<int>(d), static_cast<int>(b), static_cast<int>(c));
      dirty[f1] = dirty[f2] = 1;
      map[undirectedKey(c, d)] = {f1, f2};
      ++sweepFlips;
    }
    flips += sweepFlips;
    if (sweepFlips == 0) break;
  }
  return flips;
}

OrientationReport orientConsistently(TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals) {
  OrientationReport report;
  auto& T = mesh.triangles;
  const auto nf = static_cast<std::uint32_t>(T.size());
  // The manifold edges' face pairs.
  const std::vector<KeyedIndex> uses = detail::sortedEdgeUses(mesh);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> manifold;  // (f, g), f < g
  for (std::size_t i = 0; i < uses.size();) {
    std::size_t j = i + 1;
    while (j < uses.size() && uses[j].first == uses[i].first) ++j;
    if (j - i == 2) manifold.emplace_back(uses[i].second / 2, uses[i + 1].second / 2);
    i = j;
  }
  // Face adjacency through manifold edges (CSR), each face's neighbours ascending.
  std::vector<std::uint32_t> start(T.size() + 1, 0), adj(2 * manifold.size());
  for (const auto& [f, g] : manifold) ++start[f + 1], ++start[g + 1];
  for (std::size_t f = 0; f < T.size(); ++f) start[f + 1] += start[f];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (const auto& [f, g] : manifold) adj[fill[f]++] = g, adj[fill[g]++] = f;
  for (std::size_t f = 0; f < T.size(); ++f) std::sort(adj.begin() + start[f], adj.begin() + start[f + 1]);
  auto sharesDirection = [&](std::uint32_t f, std::uint32_t g) {
    for (int c = 0; c < 3; ++c)
      for (int e = 0; e < 3; ++e)
        if (T[f][c] == T[g][e] && T[f][(c + 1) % 3] == T[g][(e + 1) % 3]) return true;
    return false;
  };
  // Breadth-first from each component's lowest face; `order` holds the components' faces one after another.
  std::vector<char> seen(T.size(), 0);
  std::vector<std::uint32_t> order;
  std::vector<std::size_t> componentStart;
  order.reserve(T.size());
  for (std::uint32_t seed = 0; seed < nf; ++seed) {
    if (seen[seed]) continue;
    componentStart.push_back(order.size());
    seen[seed] = 1;
    order.push_back(seed);
    for (std::size_t head = componentStart.back(); head < order.size(); ++head) {
      const std::uint32_t f = order[head];
      for (std::uint32_t k = start[f]; k < start[f + 1]; ++k) {
        const std::uint32_t g = adj[k];
        if (seen[g]) continue;
        seen[g] = 1;
        if (sharesDirection(f, g)) {
          std::swap(T[g][1], T[g][2]);
          ++report.facesFlipped;
        }
        order.push_back(g);
      }
    }
  }
  componentStart.push_back(order.size());
  report.components = componentStart.size() - 1;
  for (std::size_t c = 0; c + 1 < componentStart.size(); ++c) {
    double sign = 0;
    for (std::size_t k = componentStart[c]; k < componentStart[c + 1]; ++k) {
      const auto& t = T[order[k]];
      const Eigen::Vector3d fn = faceNormal(mesh, vtx(t, 0), vtx(t, 1), vtx(t, 2));
      if (normals.size() == mesh.vertices.size())
        sign += fn.dot(normals[vtx(t, 0)] + normals[vtx(t, 1)] + normals[vtx(t, 2)]);
      else
        sign += mesh.vertices[vtx(t, 0)].dot(fn);  // 6 × signed volume
    }
    if (sign < 0) {
      for (std::size_t k = componentStart[c]; k < componentStart[c + 1]; ++k) std::swap(T[order[k]][1], T[order[k]][2]);
      report.facesFlipped += componentStart[c + 1] - componentStart[c];
    }
  }
  for (const auto& [f, g] : manifold)
    if (sharesDirection(f, g)) ++report.conflicts;
  return report;
}

std::vector<std::size_t> removeUnusedVertices(TriangleMesh& mesh) {
  std::vector<long long> remap(mesh.vertices.size(), -1);
  for (const auto& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) remap[static_cast<std::size_t>(t[c])] = 0;
  std::vector<std::size_t> kept;
  std::vector<Eigen::Vector3d> verts;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    if (remap[v] == 0) {
      remap[v] = static_cast<long long>(kept.size());
      kept.push_back(v);
      verts.push_back(mesh.vertices[v]);
    }
  for (auto& t : mesh.triangles)
    for (int c = 0; c < 3; ++c) t[c] = static_cast<int>(remap[static_cast<std::size_t>(t[c])]);
  mesh.vertices.swap(verts);
  return kept;
}

}  // namespace iires
