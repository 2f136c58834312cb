// SPDX-License-Identifier: GPL-3.0-or-later
// Small holes closed with triangles of their own vertices (fillSmallHoles), and the polygon triangulation it and
// the bad-triangle repair share.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "mesh_edges.hpp"
#include "polygon_fill.hpp"

namespace iires {
namespace detail {

bool triangulatePolygon(const TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& normals,
                        const std::vector<std::uint32_t>& loop, const std::function<bool(std::uint64_t)>& isEdge,
                        bool useNormals, std::vector<Eigen::Vector3i>& out, double* minQuality,
                        const std::unordered_map<std::uint64_t, Eigen::Vector3d>* acrossNormals) {
  const int m = static_cast<int>(loop.size());
  constexpr double kForbidden = -1.0;
  auto weight = [&](int i, int j, int k) {
    const std::uint32_t a = loop[static_cast<std::size_t>(i)], b = loop[static_cast<std::size_t>(j)],
                        c = loop[static_cast<std::size_t>(k)];
    // Diagonals (non-adjacent loop vertices) must not be existing edges: that would make them non-manifold.
    if (j != i + 1 && isEdge(undirectedKey(a, b))) return kForbidden;
    if (k != j + 1 && isEdge(undirectedKey(b, c))) return kForbidden;
    if (!(i == 0 && k == m - 1) && isEdge(undirectedKey(a, c))) return kForbidden;
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
    out.emplace_back(static_cast<int>(loop[static_cast<std::size_t>(i)]),
                     static_cast<int>(loop[static_cast<std::size_t>(j)]),
                     static_cast<int>(loop[static_cast<std::size_t>(k)]));
    stack.emplace_back(i, j);
    stack.emplace_back(j, k);
  }
  return true;
}

}  // namespace detail

namespace {

using detail::directedKey;
using detail::EdgeCounts;
using detail::faceNormal;
using detail::triangulatePolygon;
using detail::undirectedKey;
using detail::vtx;

/// fillSmallHoles() in steps: the boundary's index, its loops, and each loop closed (or kept).
class HoleFiller {
 public:
  HoleFiller(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals, const HoleFillingParams& params)
      : mesh_(mesh), normals_(normals), params_(params), haveNormals_(normals.size() == mesh.vertices.size()) {}

  HoleFillingReport run() {
    if (!indexEdges()) return report_;
    const std::vector<std::vector<std::uint32_t>> loops = boundaryLoops();
    for (auto loop : loops) fill(loop);
    report_.facesAdded = added_.size();  // with the zips' extra faces
    mesh_.triangles.insert(mesh_.triangles.end(), added_.begin(), added_.end());
    return report_;
  }

 private:
  static constexpr std::uint32_t kNoVertex = std::numeric_limits<std::uint32_t>::max();

  /// Faces per undirected edge, the mean edge length, and the boundary half-edges a→b (of the one face using the
  /// edge), stored reversed (the hole is walked along b→a) with their faces and face normals. False for a mesh
  /// without edges.
  bool indexEdges() {
    const std::vector<KeyedIndex> uses = detail::sortedEdgeUses(mesh_);
    if (uses.empty()) return false;
    edges_ = EdgeCounts(uses);
    double edgeSum = 0;
    std::size_t edgeCount = 0;
    detail::forEachEdge(uses, [&](std::size_t i, std::size_t j) {
      const std::uint64_t key = uses[i].first;
      const auto lo = static_cast<std::uint32_t>(key >> 32), hi = static_cast<std::uint32_t>(key);
      edgeSum += (mesh_.vertices[lo] - mesh_.vertices[hi]).norm(), ++edgeCount;
      if (j > i + 1) return;
      const std::uint32_t f = uses[i].second / 2;
      const bool up = uses[i].second % 2;  // the face runs lo → hi
      const std::uint32_t a = up ? lo : hi, b = up ? hi : lo;
      const Eigen::Vector3i& t = mesh_.triangles[f];
      next_[b].push_back(a), ++boundaryEdges_;
      boundaryNormal_[directedKey(a, b)] = faceNormal(mesh_, vtx(t, 0), vtx(t, 1), vtx(t, 2)).normalized();
      boundaryFace_[key] = f;
    });
    meanEdge_ = edgeSum / static_cast<double>(edgeCount);
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
        if (x == near || edges_.has(undirectedKey(near, x)) || edges_.count(undirectedKey(s, x)) != 2 ||
            edges_.count(undirectedKey(t, x)) != 2)
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
        edges_.set(undirectedKey(v, near), 2), edges_.set(undirectedKey(near, x), 2);
        edges_.add(undirectedKey(near, x)), edges_.add(undirectedKey(u, w));
        if (loop.size() == 3) {  // a sliver hole (a T-junction): the zip closes it
          edges_.set(undirectedKey(u, w), 2);
          boundaryFace_.erase(undirectedKey(u, w));
        } else {
          edges_.set(undirectedKey(u, w), 1);
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
    const bool dp = triangulatePolygon(mesh_, normals_, loop, isEdge_, true, faces, &dpQuality);
    if (dp && dpQuality < params_.minQuality) {
      // Normals can be unreliable where the loop closes over a part thinner than the spacing (both sides' normals
      // in one loop): the best triangulation without it is taken if better, as long as no face folds back onto
      // the face across a loop edge.
      std::vector<Eigen::Vector3i> free;
      double freeQuality = 0;
      if (triangulatePolygon(mesh_, normals_, loop, isEdge_, false, free, &freeQuality, &boundaryNormal_) &&
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
      if (!triangulatePolygon(mesh_, normals_, loop, isEdge_, false, faces)) {
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
      for (int c = 0; c < 3; ++c) edges_.add(undirectedKey(vtx(f, c), vtx(f, (c + 1) % 3)));
    added_.insert(added_.end(), faces.begin(), faces.end());
    ++report_.filled;
  }

  TriangleMesh& mesh_;
  std::vector<Eigen::Vector3d>& normals_;
  const HoleFillingParams& params_;
  const bool haveNormals_;
  HoleFillingReport report_;
  EdgeCounts edges_;  ///< faces per undirected edge (as the zips change them); every edge and those of the fills
  const std::function<bool(std::uint64_t)> isEdge_ = [this](std::uint64_t key) { return edges_.has(key); };
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

}  // namespace iires
