// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/reconstruct/mesh_repair.hpp"

#include "mesh_edges.hpp"
#include "point_triangle.hpp"
#include "vertex_faces.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "iires/detail/parallel.hpp"
#include "iires/reconstruct/mesh_quality.hpp"

namespace iires {
namespace {

using detail::edgeFaces;
using detail::pointTriangleDistance;
using detail::undirectedKey;

std::uint64_t directedKey(std::uint32_t a, std::uint32_t b) { return (static_cast<std::uint64_t>(a) << 32) | b; }

std::uint32_t vtx(const Eigen::Vector3i& t, int c) { return static_cast<std::uint32_t>(t[c]); }

Eigen::Vector3d faceNormal(const TriangleMesh& m, std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  return (m.vertices[b] - m.vertices[a]).cross(m.vertices[c] - m.vertices[a]);
}

/// Angle at vertex o of triangle (o, x, y), radians.
double cornerAngle(const Eigen::Vector3d& o, const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
  const Eigen::Vector3d u = x - o, v = y - o;
  return std::atan2(u.cross(v).norm(), u.dot(v));
}

/// Optimal triangulation of one hole polygon (vertices in the order new faces must follow).
/// Returns false when every triangulation contains a forbidden triangle. With @p acrossNormals (the unit normal of
/// the face at each boundary half-edge, keyed by that half-edge), faces folding back onto those are forbidden.
bool triangulatePolygon(const TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals,
                        const std::vector<std::uint32_t>& loop, const std::unordered_set<std::uint64_t>& edges,
                        bool useNormals, std::vector<Eigen::Vector3i>& out, double* minQuality = nullptr,
                        const std::unordered_map<std::uint64_t, Eigen::Vector3d>* acrossNormals = nullptr) {
  const int m = static_cast<int>(loop.size());
  constexpr double kForbidden = -1.0;
  auto weight = [&](int i, int j, int k) {
    const std::uint32_t a = loop[static_cast<std::size_t>(i)], b = loop[static_cast<std::size_t>(j)],
                        c = loop[static_cast<std::size_t>(k)];
    // Diagonals (non-adjacent loop vertices) must not be existing edges: that would make them non-manifold.
    if (j != i + 1 && edges.count(undirectedKey(a, b))) return kForbidden;
    if (k != j + 1 && edges.count(undirectedKey(b, c))) return kForbidden;
    if (!(i == 0 && k == m - 1) && edges.count(undirectedKey(a, c))) return kForbidden;
    const double q = triangleQuality(mesh.vertices[a], mesh.vertices[b], mesh.vertices[c]);
    if (q <= 1e-6) return kForbidden;
    const Eigen::Vector3d fn = faceNormal(mesh, a, b, c);
    if (useNormals && normals.size() == mesh.vertices.size() && fn.dot(normals[a] + normals[b] + normals[c]) <= 0)
      return kForbidden;
    if (acrossNormals) {
      // A face on a loop edge must not fold back onto the face across it (an angle under ~37° between them).
      const std::uint32_t corner[3] = {a, b, c};
      for (int e = 0; e < 3; ++e) {
        const auto it = acrossNormals->find(directedKey(corner[(e + 1) % 3], corner[e]));
        if (it != acrossNormals->end() && fn.normalized().dot(it->second) < -0.8) return kForbidden;
      }
    }
    return q;
  };
  // best[i][k]: (min Q, sum Q) of the best triangulation of the sub-polygon i..k.
  std::vector<std::vector<std::pair<double, double>>> best(
      static_cast<std::size_t>(m), std::vector<std::pair<double, double>>(static_cast<std::size_t>(m), {2.0, 0.0}));
  std::vector<std::vector<int>> split(static_cast<std::size_t>(m), std::vector<int>(static_cast<std::size_t>(m), -1));
  for (int len = 2; len < m; ++len)
    for (int i = 0; i + len < m; ++i) {
      const int k = i + len;
      std::pair<double, double> top{-2.0, 0.0};
      for (int j = i + 1; j < k; ++j) {
        const double w = weight(i, j, k);
        const auto& l = best[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
        const auto& r = best[static_cast<std::size_t>(j)][static_cast<std::size_t>(k)];
        const std::pair<double, double> cand{std::min({w, l.first, r.first}), w + l.second + r.second};
        if (cand > top) top = cand, split[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = j;
      }
      best[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)] = top;
    }
  if (best[0][static_cast<std::size_t>(m - 1)].first <= 0) return false;
  if (minQuality) *minQuality = best[0][static_cast<std::size_t>(m - 1)].first;
  std::vector<std::pair<int, int>> stack{{0, m - 1}};
  while (!stack.empty()) {
    const auto [i, k] = stack.back();
    stack.pop_back();
    if (k - i < 2) continue;
    const int j = split[static_cast<std::size_t>(i)][static_cast<std::size_t>(k)];
    out.emplace_back(static_cast<int>(loop[static_cast<std::size_t>(i)]), static_cast<int>(loop[static_cast<std::size_t>(j)]),
                     static_cast<int>(loop[static_cast<std::size_t>(k)]));
    stack.emplace_back(i, j);
    stack.emplace_back(j, k);
  }
  return true;
}

/// fillSmallHoles() in steps: the boundary's index, its loops, and each loop closed (or kept).
class HoleFiller {
 public:
  HoleFiller(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals, const HoleFillingParams& params)
      : mesh_(mesh), normals_(normals), params_(params), haveNormals_(normals.size() == mesh.vertices.size()) {}

  HoleFillingReport run() {
    if (!indexEdges()) return report_;
    const std::vector<std::vector<std::uint32_t>> loops = boundaryLoops();
    indexBoundaryFaces();
    for (auto loop : loops) fill(loop);
    report_.facesAdded = added_.size();  // with the zips' extra faces
    mesh_.triangles.insert(mesh_.triangles.end(), added_.begin(), added_.end());
    return report_;
  }

 private:
  static constexpr std::uint32_t kNoVertex = std::numeric_limits<std::uint32_t>::max();

  /// Faces per undirected edge, the mean edge length, and the boundary half-edges a→b (of the one face using the
  /// edge), stored reversed (the hole is walked along b→a) with their face normals. False for a mesh without edges.
  bool indexEdges() {
    double edgeSum = 0;
    count_.reserve(mesh_.triangles.size() * 2);
    for (const auto& t : mesh_.triangles)
      for (int c = 0; c < 3; ++c) {
        auto [it, inserted] = count_.emplace(undirectedKey(vtx(t, c), vtx(t, (c + 1) % 3)), 0);
        if (inserted) edgeSum += (mesh_.vertices[vtx(t, c)] - mesh_.vertices[vtx(t, (c + 1) % 3)]).norm();
        ++it->second;
      }
    if (count_.empty()) return false;
    meanEdge_ = edgeSum / static_cast<double>(count_.size());
    edges_.reserve(count_.size());
    for (const auto& [key, c] : count_) edges_.insert(key);
    for (const auto& t : mesh_.triangles)
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t a = vtx(t, c), b = vtx(t, (c + 1) % 3);
        if (count_[undirectedKey(a, b)] != 1) continue;
        next_[b].push_back(a), ++boundaryEdges_;
        boundaryNormal_[directedKey(a, b)] = faceNormal(mesh_, vtx(t, 0), vtx(t, 1), vtx(t, 2)).normalized();
      }
    for (auto& [v, list] : next_) std::sort(list.begin(), list.end());
    return true;
  }

  /// At a vertex with several boundary edges leaving it (two fans meeting), the one that closes the smallest
  /// hole wedge: the smallest clockwise turn (about the vertex normal) from the edge we arrived on.
  std::uint32_t choose(std::uint32_t prev, std::uint32_t cur, const std::vector<std::uint32_t>& outs,
                       const std::unordered_set<std::uint64_t>& seen) const {
    std::uint32_t bestV = kNoVertex;
    double bestTurn = std::numeric_limits<double>::max();
    const Eigen::Vector3d back = mesh_.vertices[prev] - mesh_.vertices[cur];
    for (std::uint32_t cand : outs) {
      if (seen.count(directedKey(cur, cand))) continue;
      if (!haveNormals_ || outs.size() == 1) return cand;
      const Eigen::Vector3d& n = normals_[cur];
      const Eigen::Vector3d out = mesh_.vertices[cand] - mesh_.vertices[cur];
      double turn = std::atan2(back.cross(out).dot(n), back.dot(out));  // counter-clockwise from back
      turn = turn <= 0 ? -turn : 2 * M_PI - turn;                        // clockwise angle in (0, 2π]
      if (cand == prev) turn = 2 * M_PI;
      if (turn < bestTurn) bestTurn = turn, bestV = cand;
    }
    return bestV;
  }

  /// The simple boundary loops: each closed boundary walk split into simple cycles at the vertices it passes
  /// more than once. A walk that does not close is counted as a loop kept open.
  std::vector<std::vector<std::uint32_t>> boundaryLoops() {
    std::unordered_set<std::uint64_t> visited;
    std::vector<std::vector<std::uint32_t>> loops;
    for (const auto& [start, outs] : next_)
      for (std::uint32_t first : outs) {
        if (visited.count(directedKey(start, first))) continue;
        // Walk the closed boundary start → first → ... → start.
        std::vector<std::uint32_t> walk{start};
        visited.insert(directedKey(start, first));
        std::uint32_t prev = start, cur = first;
        bool closedWalk = true;
        while (cur != start) {
          walk.push_back(cur);
          const auto it = next_.find(cur);
          const std::uint32_t nxt = it == next_.end() ? kNoVertex : choose(prev, cur, it->second, visited);
          if (nxt == kNoVertex || walk.size() > boundaryEdges_) {
            closedWalk = false;
            break;
          }
          visited.insert(directedKey(cur, nxt));
          prev = cur;
          cur = nxt;
        }
        if (!closedWalk) {
          ++report_.loops;
          ++report_.kept;
          continue;
        }
        std::vector<std::uint32_t> stack;
        std::unordered_map<std::uint32_t, std::size_t> position;
        for (std::uint32_t v : walk) {
          const auto it = position.find(v);
          if (it != position.end()) {
            // The cycle v ... (top of stack) closes here.
            loops.emplace_back(stack.begin() + static_cast<std::ptrdiff_t>(it->second), stack.end());
            for (std::size_t x = it->second + 1; x < stack.size(); ++x) position.erase(stack[x]);
            stack.resize(it->second + 1);
          } else {
            position[v] = stack.size();
            stack.push_back(v);
          }
        }
        loops.push_back(stack);
      }
    return loops;
  }

  /// Boundary face of each boundary edge; indices ≥ the mesh's triangle count are faces in added_.
  void indexBoundaryFaces() {
    for (std::size_t f = 0; f < mesh_.triangles.size(); ++f)
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t a = vtx(mesh_.triangles[f], c), b = vtx(mesh_.triangles[f], (c + 1) % 3);
        if (count_[undirectedKey(a, b)] == 1) boundaryFace_[undirectedKey(a, b)] = f;
      }
  }

  Eigen::Vector3i& faceAt(std::size_t f) {
    return f < mesh_.triangles.size() ? mesh_.triangles[f] : added_[f - mesh_.triangles.size()];
  }

  /// Zip a corner of the loop where it turns back on itself (a near-zero angle at v between its loop edges to u
  /// and w, e.g. where a hole runs out along a knife edge): the nearer neighbour is inserted into the longer
  /// edge, whose face is split in two, so v leaves the loop instead of ending up in a sliver.
  void zip(std::vector<std::uint32_t>& loop) {
    const auto& P = mesh_.vertices;
    for (bool again = true; again && loop.size() >= 3;) {
      again = false;
      for (std::size_t i = 0; i < loop.size() && loop.size() >= 3; ++i) {
        const std::uint32_t u = loop[(i + loop.size() - 1) % loop.size()], v = loop[i], w = loop[(i + 1) % loop.size()];
        const bool nearIsW = (P[w] - P[v]).norm() < (P[u] - P[v]).norm();
        const std::uint32_t near = nearIsW ? w : u, far = nearIsW ? u : w;
        const Eigen::Vector3d d = P[far] - P[v], e = P[near] - P[v];
        if (!(e.norm() > 0) || e.normalized().dot(d.normalized()) < std::cos(15.0 * M_PI / 180.0)) continue;
        const auto it = boundaryFace_.find(undirectedKey(v, far));
        if (it == boundaryFace_.end()) continue;
        const Eigen::Vector3i old = faceAt(it->second);
        int c = 0;
        while (!((vtx(old, c) == v || vtx(old, c) == far) && (vtx(old, (c + 1) % 3) == v || vtx(old, (c + 1) % 3) == far))) ++c;
        const std::uint32_t s = vtx(old, c), t = vtx(old, (c + 1) % 3), x = vtx(old, (c + 2) % 3);
        if (x == near || edges_.count(undirectedKey(near, x)) || count_[undirectedKey(s, x)] != 2 ||
            count_[undirectedKey(t, x)] != 2)
          continue;
        const Eigen::Vector3d n0 = faceNormal(mesh_, s, t, x).normalized();
        const Eigen::Vector3i first(static_cast<int>(s), static_cast<int>(near), static_cast<int>(x)),
            second(static_cast<int>(near), static_cast<int>(t), static_cast<int>(x));
        bool ok = true;
        for (const auto& f : {first, second})
          ok = ok && triangleQuality(P[vtx(f, 0)], P[vtx(f, 1)], P[vtx(f, 2)]) >= 0.2 &&
               faceNormal(mesh_, vtx(f, 0), vtx(f, 1), vtx(f, 2)).normalized().dot(n0) > 0.5;
        if (!ok) continue;
        const std::size_t oldIndex = it->second, newIndex = mesh_.triangles.size() + added_.size();
        faceAt(oldIndex) = first;
        added_.push_back(second);
        boundaryFace_.erase(undirectedKey(v, far));
        boundaryFace_.erase(undirectedKey(v, near));
        count_[undirectedKey(v, near)] = 2, count_[undirectedKey(near, x)] = 2;
        edges_.insert(undirectedKey(near, x)), edges_.insert(undirectedKey(u, w));
        if (loop.size() == 3) {  // a sliver hole (a T-junction): the zip closes it
          count_[undirectedKey(u, w)] = 2;
          boundaryFace_.erase(undirectedKey(u, w));
        } else {
          count_[undirectedKey(u, w)] = 1;
          boundaryFace_[undirectedKey(u, w)] = nearIsW ? newIndex : oldIndex;
          const Eigen::Vector3i& keeper = nearIsW ? second : first;
          boundaryNormal_[directedKey(w, u)] =
              faceNormal(mesh_, vtx(keeper, 0), vtx(keeper, 1), vtx(keeper, 2)).normalized();
        }
        loop.erase(loop.begin() + static_cast<std::ptrdiff_t>(i));
        ++report_.zipped;
        again = true;
        break;
      }
    }
  }

  /// Closes @p loop when it is small (or medium and the fill is good), else counts it as kept.
  void fill(std::vector<std::uint32_t>& loop) {
    ++report_.loops;
    double perimeter = 0;
    for (std::size_t i = 0; i < loop.size(); ++i)
      perimeter += (mesh_.vertices[loop[i]] - mesh_.vertices[loop[(i + 1) % loop.size()]]).norm();
    const bool small = loop.size() <= params_.maxEdges && perimeter <= params_.maxPerimeter * meanEdge_;
    const bool medium = !small &&
                        static_cast<double>(loop.size()) <= params_.goodFillFactor * static_cast<double>(params_.maxEdges) &&
                        perimeter <= params_.goodFillFactor * params_.maxPerimeter * meanEdge_;
    if (loop.size() < 3 || !(small || medium)) {
      ++report_.kept;
      return;
    }
    zip(loop);
    if (loop.size() < 3) {  // zipped shut
      ++report_.filled;
      return;
    }
    // Best: no new vertex and faces agreeing with the normals; then without the normal test (a corner of
    // several creases, or a small fold); last, a fan around a new vertex at the loop's centroid (when every
    // diagonal already exists elsewhere).
    std::vector<Eigen::Vector3i> faces;
    double dpQuality = 0;
    const bool dp = triangulatePolygon(mesh_, normals_, loop, edges_, true, faces, &dpQuality);
    if (dp && dpQuality < params_.minQuality) {
      // Normals can be unreliable where the loop closes over a part thinner than the spacing (both sides' normals
      // in one loop): the best triangulation without it is taken if better, as long as no face folds back onto
      // the face across a loop edge.
      std::vector<Eigen::Vector3i> free;
      double freeQuality = 0;
      if (triangulatePolygon(mesh_, normals_, loop, edges_, false, free, &freeQuality, &boundaryNormal_) &&
          freeQuality > dpQuality)
        faces.swap(free), dpQuality = freeQuality;
    }
    // The fan around the centroid, for comparison.
    Eigen::Vector3d centre = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::Zero();
    for (std::uint32_t v : loop) centre += mesh_.vertices[v];
    centre /= static_cast<double>(loop.size());
    if (haveNormals_)
      for (std::uint32_t v : loop) normal += normals_[v];
    double fanQuality = 1;
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const Eigen::Vector3d &a = mesh_.vertices[loop[i]], &b = mesh_.vertices[loop[(i + 1) % loop.size()]];
      const bool folded = haveNormals_ && (b - a).cross(centre - a).dot(normal) <= 0;
      fanQuality = std::min(fanQuality, folded ? 0.0 : triangleQuality(a, b, centre));
    }
    const bool useFan = (!dp && fanQuality > 0) || (dp && dpQuality < params_.minQuality && fanQuality > dpQuality);
    if (!dp && !useFan) {
      faces.clear();
      if (!triangulatePolygon(mesh_, normals_, loop, edges_, false, faces)) {
        ++report_.kept;
        return;
      }
    }
    if (medium) {  // closed only when the fill is good
      double worst = useFan ? fanQuality : 1.0;
      if (!useFan)
        for (const auto& t : faces)
          worst = std::min(worst, triangleQuality(mesh_.vertices[vtx(t, 0)], mesh_.vertices[vtx(t, 1)], mesh_.vertices[vtx(t, 2)]));
      if (worst < params_.minQuality) {
        ++report_.kept;
        return;
      }
    }
    if (useFan) {
      faces.clear();
      const auto c = static_cast<int>(mesh_.vertices.size());
      mesh_.vertices.push_back(centre);
      if (haveNormals_) normals_.push_back(normal.normalized());
      for (std::size_t i = 0; i < loop.size(); ++i)
        faces.emplace_back(static_cast<int>(loop[i]), static_cast<int>(loop[(i + 1) % loop.size()]), c);
      ++report_.verticesAdded;
    }
    for (const auto& f : faces)
      for (int c = 0; c < 3; ++c) edges_.insert(undirectedKey(vtx(f, c), vtx(f, (c + 1) % 3)));
    added_.insert(added_.end(), faces.begin(), faces.end());
    ++report_.filled;
  }

  TriangleMesh& mesh_;
  std::vector<Eigen::Vector3d>& normals_;
  const HoleFillingParams& params_;
  const bool haveNormals_;
  HoleFillingReport report_;
  std::unordered_map<std::uint64_t, int> count_;  ///< faces per undirected edge
  std::unordered_set<std::uint64_t> edges_;       ///< every edge, and the edges of the faces added
  double meanEdge_ = 0;
  std::map<std::uint32_t, std::vector<std::uint32_t>> next_;  ///< reversed boundary edges, deterministic order
  std::size_t boundaryEdges_ = 0;
  std::unordered_map<std::uint64_t, Eigen::Vector3d> boundaryNormal_;  ///< face normal at boundary half-edge a→b
  std::unordered_map<std::uint64_t, std::size_t> boundaryFace_;
  std::vector<Eigen::Vector3i> added_;
};

}  // namespace

void HoleFillingParams::validate() const {
  if (maxEdges < 3) throw std::invalid_argument("hole filling: maxEdges must be at least 3");
  if (!(maxPerimeter > 0)) throw std::invalid_argument("hole filling: maxPerimeter must be positive");
  if (!(minQuality >= 0 && minQuality <= 1)) throw std::invalid_argument("hole filling: minQuality must be in [0, 1]");
  if (!(goodFillFactor >= 1)) throw std::invalid_argument("hole filling: goodFillFactor must be at least 1");
  if (!(maxRefinedExtent >= 0 && maxRefinedExtent <= 1))
    throw std::invalid_argument("hole filling: maxRefinedExtent must be in [0, 1]");
  if (refineIterations < 0) throw std::invalid_argument("hole filling: refineIterations must be non-negative");
  if (!(supportDistance > 0)) throw std::invalid_argument("hole filling: supportDistance must be positive");
  if (!(maxContinuedShare >= 0 && maxContinuedShare <= 1))
    throw std::invalid_argument("hole filling: maxContinuedShare must be in [0, 1]");
}

HoleFillingReport fillSmallHoles(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals,
                                 const HoleFillingParams& params) {
  params.validate();
  return HoleFiller(mesh, normals, params).run();
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
      if (!triangulatePolygon(mesh, normals, ring, edges, true, faces, &ringQuality, &across) ||
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

std::size_t removeExtraFans(TriangleMesh& mesh, int threads) {
  auto& T = mesh.triangles;
  const std::size_t nv = mesh.vertices.size();
  const detail::VertexFaces vf = detail::vertexFaces(mesh);
  const std::vector<std::uint32_t>&start = vf.start, &incident = vf.incident;
  // Which vertices have several fans in the mesh as given (in parallel); the ordered pass below visits those,
  // and any vertex that lost a face to an earlier one.
  std::vector<char> several(nv, 0);
  parallelFor(nv, threads, [&](std::size_t v) {
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
