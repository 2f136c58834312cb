// SPDX-License-Identifier: GPL-3.0-or-later
// closeRimBands(): the rim of a part thinner than the mesh's edges closed by a band of triangles between the two
// boundary loops that run side by side along it, or between the two sides of a slit along it.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <queue>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "iires/detail/disjoint_sets.hpp"
#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "mesh_edges.hpp"

namespace iires {
namespace {

using detail::undirectedKey;

constexpr double kPartnerEdges = 1.5;  ///< a loop vertex's partner on the other loop: within this × the mean edge
/// ... and joined to it along the input by a path at most this long: along a rim a few input spacings wide the input's
/// graph is thin (a rim point's neighbours are mostly the faces'), and the path may detour; two sheets with no rim
/// between them are joined only round their far end.
constexpr double kPathEdges = 5.0;
constexpr double kMatchedShare = 0.9;  ///< two loops run side by side: this share of each one's vertices matched
constexpr double kMinBandQuality = 0.05;  ///< a band with a flatter triangle is not added
constexpr int kMaxPasses = 8;             ///< passes (a pass that turns a part over starts the next)
constexpr std::size_t kMaxVisited = 4096; ///< input points one path search visits at most
constexpr std::size_t kSlitSteps = 3;     ///< a loop's vertex partners with its own loop this many steps along or more

/// Whether the input's surface graph joins @p a and @p b (through the input points nearest to them) by a path of
/// at most @p maxPath, the gaps to the first and from the last point included: A* on the graph. Two sheets facing
/// each other across a gap are joined only round the gap's end.
bool joinedAlongInput(const SampledPoints& input, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double maxPath) {
  const std::vector<Eigen::Vector3d>& P = input.points();
  const SampledPoints::Adjacency& graph = input.adjacency();
  double sa = 0, sb = 0;
  const std::int64_t from = input.index().nearest(a, &sa), to = input.index().nearest(b, &sb);
  if (from < 0 || to < 0 || graph.start.empty()) return false;
  const double budget = maxPath - std::sqrt(sa) - std::sqrt(sb);
  const Eigen::Vector3d& goal = P[static_cast<std::size_t>(to)];
  using Entry = std::pair<double, std::uint32_t>;  // (path so far + straight distance to the goal, point)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  std::unordered_map<std::uint32_t, double> best{{static_cast<std::uint32_t>(from), 0.0}};
  open.emplace((P[static_cast<std::size_t>(from)] - goal).norm(), static_cast<std::uint32_t>(from));
  for (std::size_t visited = 0; !open.empty() && visited < kMaxVisited; ++visited) {
    const auto [f, i] = open.top();
    open.pop();
    if (f > budget) return false;
    if (i == static_cast<std::uint32_t>(to)) return true;
    const double g = best[i];
    if (f > g + (P[i] - goal).norm() + 1e-12) continue;  // a stale entry
    for (std::uint32_t k = graph.start[i]; k < graph.start[i + 1]; ++k) {
      const std::uint32_t j = graph.neighbours[k];
      const double gj = g + (P[j] - P[i]).norm();
      const auto [it, fresh] = best.emplace(j, gj);
      if (!fresh && it->second <= gj) continue;
      it->second = gj;
      open.emplace(gj + (P[j] - goal).norm(), j);
    }
  }
  return false;
}

/// The mesh's boundary: its simple loops (each a→b a face's edge, in the face's direction), the mean edge, and the
/// mesh's edges (for the bands' edges across, which must be new).
struct Boundary {
  std::vector<std::vector<std::uint32_t>> loops;
  double meanEdge = 0;
  detail::EdgeCounts edges;
};

Boundary boundaryOf(const TriangleMesh& mesh) {
  Boundary out;
  const std::vector<KeyedIndex> uses = detail::sortedEdgeUses(mesh);
  out.edges = detail::EdgeCounts(uses);
  std::unordered_map<std::uint32_t, std::uint32_t> next;
  std::unordered_set<std::uint32_t> branching;  // vertices with two boundary edges leaving them
  double sum = 0;
  std::size_t edges = 0;
  detail::forEachEdge(uses, [&](std::size_t i, std::size_t j) {
    const auto lo = static_cast<std::uint32_t>(uses[i].first >> 32), hi = static_cast<std::uint32_t>(uses[i].first);
    sum += (mesh.vertices[lo] - mesh.vertices[hi]).norm(), ++edges;
    if (j != i + 1) return;
    const bool up = uses[i].second % 2;  // the face runs lo → hi
    const std::uint32_t a = up ? lo : hi, b = up ? hi : lo;
    if (!next.emplace(a, b).second) branching.insert(a);
  });
  out.meanEdge = edges ? sum / static_cast<double>(edges) : 0;
  std::vector<std::uint32_t> starts;
  for (const auto& [a, b] : next) starts.push_back(a);
  std::sort(starts.begin(), starts.end());
  std::unordered_set<std::uint32_t> seen;
  for (std::uint32_t s : starts) {
    if (seen.count(s)) continue;
    std::vector<std::uint32_t> loop;
    bool simple = true;
    for (std::uint32_t v = s;;) {
      simple = simple && !branching.count(v);
      loop.push_back(v);
      seen.insert(v);
      const auto it = next.find(v);
      if (it == next.end()) { simple = false; break; }
      v = it->second;
      if (v == s) break;
      if (seen.count(v)) { simple = false; break; }
    }
    if (simple && loop.size() >= 3) out.loops.push_back(std::move(loop));
  }
  return out;
}

/// For each vertex of each loop, the nearest vertex within @p radius of another loop, or of its own at least
/// kSlitSteps along it (across a slit): (loop, position) or (npos, 0).
std::vector<std::vector<std::pair<std::size_t, std::size_t>>> partners(const TriangleMesh& mesh, const Boundary& b,
                                                                         double radius) {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::pair<std::size_t, std::size_t>> owner;
  for (std::size_t l = 0; l < b.loops.size(); ++l)
    for (std::size_t p = 0; p < b.loops[l].size(); ++p) points.push_back(mesh.vertices[b.loops[l][p]]), owner.emplace_back(l, p);
  const KnnIndex index(points);
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> out(b.loops.size());
  std::vector<std::uint32_t> idx;
  std::vector<double> sq;
  std::size_t k = 0;
  for (std::size_t l = 0; l < b.loops.size(); ++l)
    for (std::size_t p = 0; p < b.loops[l].size(); ++p, ++k) {
      std::pair<std::size_t, std::size_t> found{std::string::npos, 0};
      index.radius(points[k], radius, idx, sq);
      const std::size_t n = b.loops[l].size();
      for (std::uint32_t q : idx) {  // nearest first
        const std::size_t along = owner[q].second > p ? owner[q].second - p : p - owner[q].second;
        if (owner[q].first != l || std::min(along, n - along) >= kSlitSteps) {
          found = owner[q];
          break;
        }
      }
      out[l].push_back(found);
    }
  return out;
}

/// Whether the band triangle @p f of @p mesh would be nearly flat (its quality under kMinBandQuality).
bool flatTriangle(const TriangleMesh& mesh, const Eigen::Vector3i& f) {
  const auto& P = mesh.vertices;
  return triangleQuality(P[static_cast<std::size_t>(f[0])], P[static_cast<std::size_t>(f[1])],
                         P[static_cast<std::size_t>(f[2])]) < kMinBandQuality;
}

/// The band between loops @p a and @p b (each in its faces' direction, running opposite ways along the rim),
/// zipped from a's first vertex and its partner @p b0 in b: each step adds the triangle whose new edge across the
/// band is shorter, or the other one where that triangle would be nearly flat. Empty when both would be, or an edge
/// across the band exists already.
std::vector<Eigen::Vector3i> zipBand(const TriangleMesh& mesh, const std::vector<std::uint32_t>& a,
                                     const std::vector<std::uint32_t>& b, std::size_t b0,
                                     const detail::EdgeCounts& edges) {
  const std::size_t n = a.size(), m = b.size();
  auto A = [&](std::size_t i) { return a[i % n]; };
  auto B = [&](std::size_t j) { return b[(b0 + m - j % m) % m]; };  // b walked backwards: along the rim like a
  const auto& P = mesh.vertices;
  auto dist = [&](std::uint32_t u, std::uint32_t v) { return (P[u] - P[v]).norm(); };
  auto flat = [&](const Eigen::Vector3i& f) { return flatTriangle(mesh, f); };
  std::vector<Eigen::Vector3i> faces;
  std::unordered_set<std::uint64_t> across{undirectedKey(A(0), B(0))};
  for (std::size_t i = 0, j = 0; i < n || j < m;) {
    // a's edge A(i) → A(i+1) belongs to a face: the band's face runs it backwards; b's likewise.
    const Eigen::Vector3i onA(static_cast<int>(A(i + 1)), static_cast<int>(A(i)), static_cast<int>(B(j)));
    const Eigen::Vector3i onB(static_cast<int>(B(j)), static_cast<int>(B(j + 1)), static_cast<int>(A(i)));
    bool stepA = j == m || (i < n && dist(A(i + 1), B(j)) <= dist(A(i), B(j + 1)));
    if (i < n && j < m && flat(stepA ? onA : onB)) stepA = !stepA;
    const Eigen::Vector3i& f = stepA ? onA : onB;
    if (flat(f)) return {};
    stepA ? ++i : ++j;
    const std::uint64_t key = undirectedKey(A(i), B(j));
    if ((i < n || j < m) && (edges.has(key) || !across.insert(key).second)) return {};
    faces.push_back(f);
  }
  return faces;
}

/// The band across a slit: loop @p a (in its faces' direction) running out along a thin rim and back, its two sides
/// side by side. Zipped from vertex @p i0 and its partner @p j0 on the far side towards both ends, where the sides
/// meet: from (i0, j0) forwards on one side and backwards on the other, then from (j0, i0) likewise; each step as
/// zipBand's, the last triangle of each half closing its end. Empty when a triangle would be nearly flat or an
/// edge across exists already.
std::vector<Eigen::Vector3i> zipSlit(const TriangleMesh& mesh, const std::vector<std::uint32_t>& a, std::size_t i0,
                                     std::size_t j0, const detail::EdgeCounts& edges) {
  const std::size_t n = a.size();
  const auto& P = mesh.vertices;
  auto dist = [&](std::uint32_t u, std::uint32_t v) { return (P[u] - P[v]).norm(); };
  auto flat = [&](const Eigen::Vector3i& f) { return flatTriangle(mesh, f); };
  std::vector<Eigen::Vector3i> faces;
  std::unordered_set<std::uint64_t> across{undirectedKey(a[i0], a[j0])};
  for (const auto& [start, end] : {std::pair{i0, j0}, std::pair{j0, i0}}) {
    // The open end between them: a[start], a[start + 1], …, a[end] forwards along the loop.
    std::size_t i = start, j = end, left = (end + n - start) % n + 1;
    auto next = [&](std::size_t x) { return (x + 1) % n; };
    auto prev = [&](std::size_t x) { return (x + n - 1) % n; };
    while (left >= 3) {
      const Eigen::Vector3i onA(static_cast<int>(a[next(i)]), static_cast<int>(a[i]), static_cast<int>(a[j]));
      const Eigen::Vector3i onB(static_cast<int>(a[j]), static_cast<int>(a[prev(j)]), static_cast<int>(a[i]));
      bool stepA = left == 3 || dist(a[next(i)], a[j]) <= dist(a[i], a[prev(j)]);
      if (left > 3 && flat(stepA ? onA : onB)) stepA = !stepA;
      const Eigen::Vector3i& f = stepA ? onA : onB;
      if (flat(f)) return {};
      faces.push_back(f);
      stepA ? i = next(i) : j = prev(j);
      --left;
      if (left >= 3 && (edges.has(undirectedKey(a[i], a[j])) || !across.insert(undirectedKey(a[i], a[j])).second))
        return {};
    }
  }
  return faces;
}

/// One pass: the slits and the loop pairs found, their bands added; at most one part turned over, only for the band it
/// lets in (returns true then: the boundary must be found again).
bool bandPass(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals, const SampledPoints& input,
              RimBandReport& report) {
  Boundary boundary = boundaryOf(mesh);
  if (boundary.loops.empty() || !(boundary.meanEdge > 0)) return false;
  const auto partner = partners(mesh, boundary, kPartnerEdges * boundary.meanEdge);
  const std::size_t nl = boundary.loops.size();
  // Each loop's main partner loop (most of its vertices' partners).
  std::vector<std::size_t> mainPartner(nl, std::string::npos);
  for (std::size_t l = 0; l < nl; ++l) {
    std::unordered_map<std::size_t, std::size_t> count;
    for (const auto& p : partner[l])
      if (p.first != std::string::npos) ++count[p.first];
    // A slit's two ends, where its sides meet, have no vertex across.
    for (const auto& [other, c] : count)
      if (static_cast<double>(c) >= kMatchedShare * static_cast<double>(partner[l].size() - (other == l ? 2 : 0)))
        mainPartner[l] = other;
  }
  DisjointSets parts(mesh.vertices.size());
  for (const auto& t : mesh.triangles)
    for (int c = 1; c < 3; ++c) parts.unite(static_cast<std::uint32_t>(t[0]), static_cast<std::uint32_t>(t[c]));
  // Whether loop l's vertices are joined along the input to their partners on loop o where matched.
  auto joinedToPartners = [&](std::size_t l, std::size_t o) {
    std::size_t joined = 0, matched = 0;
    for (std::size_t i = 0; i < boundary.loops[l].size(); ++i) {
      const auto& p = partner[l][i];
      if (p.first != o) continue;
      ++matched;
      joined += joinedAlongInput(input, mesh.vertices[boundary.loops[l][i]],
                                 mesh.vertices[boundary.loops[o][p.second]], kPathEdges * boundary.meanEdge);
    }
    return static_cast<double>(joined) >= kMatchedShare * static_cast<double>(matched);
  };
  std::vector<char> used(nl, 0);
  for (std::size_t l = 0; l < nl; ++l) {
    if (mainPartner[l] != l || !joinedToPartners(l, l)) continue;
    // A slit: zipped from the vertex whose partner is farthest along the loop (the middle of the slit).
    const auto& a = boundary.loops[l];
    std::size_t i0 = 0, farthest = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      const std::size_t j = partner[l][i].second, along = std::max(i, j) - std::min(i, j);
      if (partner[l][i].first == l && std::min(along, a.size() - along) > farthest)
        farthest = std::min(along, a.size() - along), i0 = i;
    }
    const std::vector<Eigen::Vector3i> band = zipSlit(mesh, a, i0, partner[l][i0].second, boundary.edges);
    if (band.empty()) continue;
    used[l] = 1;
    mesh.triangles.insert(mesh.triangles.end(), band.begin(), band.end());
    ++report.bands;
    report.facesAdded += band.size();
  }
  for (std::size_t l = 0; l < nl; ++l) {
    const std::size_t o = mainPartner[l];
    if (o == std::string::npos || o <= l || mainPartner[o] != l || used[l] || used[o] || !joinedToPartners(l, o))
      continue;
    const auto& a = boundary.loops[l];
    const auto& b = boundary.loops[o];
    // Which way b runs against a.
    long along = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      const auto& p = partner[l][i];
      const auto& q = partner[l][(i + 1) % a.size()];
      if (p.first != o || q.first != o) continue;
      const long d = (static_cast<long>(q.second) - static_cast<long>(p.second) + static_cast<long>(b.size())) %
                     static_cast<long>(b.size());
      along += d == 0 ? 0 : (2 * d < static_cast<long>(b.size()) ? 1 : -1);
    }
    // Both loops running the same way: two open parts oriented apart; the band needs b's part turned over, so it
    // is zipped against b reversed (as b runs once turned), and the part is turned only when the band is made.
    const bool turn = along > 0;
    const std::uint32_t partB = parts.find(b[0]);
    if (turn && parts.find(a[0]) == partB) continue;
    std::vector<std::uint32_t> side(b);
    if (turn) std::reverse(side.begin(), side.end());
    // Zipped from the first vertex of a with a partner in b.
    std::size_t i0 = 0;
    while (partner[l][i0].first != o) ++i0;
    std::vector<std::uint32_t> from(a.begin() + static_cast<long>(i0), a.end());
    from.insert(from.end(), a.begin(), a.begin() + static_cast<long>(i0));
    const std::size_t b0 = turn ? b.size() - 1 - partner[l][i0].second : partner[l][i0].second;
    const std::vector<Eigen::Vector3i> band = zipBand(mesh, from, side, b0, boundary.edges);
    if (band.empty()) continue;
    if (turn) {
      for (auto& t : mesh.triangles)
        if (parts.find(static_cast<std::uint32_t>(t[0])) == partB) std::swap(t[1], t[2]);
      if (normals.size() == mesh.vertices.size())
        for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
          if (parts.find(static_cast<std::uint32_t>(v)) == partB) normals[v] = -normals[v];
      ++report.partsTurned;
    }
    used[l] = used[o] = 1;
    for (const auto& f : band)
      for (int c = 0; c < 3; ++c) boundary.edges.add(undirectedKey(static_cast<std::uint32_t>(f[c]), static_cast<std::uint32_t>(f[(c + 1) % 3])));
    mesh.triangles.insert(mesh.triangles.end(), band.begin(), band.end());
    ++report.bands;
    report.facesAdded += band.size();
    if (turn) return true;  // the other loops of the part turned over run the other way now: find them again
  }
  return false;
}

}  // namespace

RimBandReport closeRimBands(TriangleMesh& mesh, std::vector<Eigen::Vector3d>& normals, const HoleFillingParams& params) {
  RimBandReport report;
  if (!params.inputPoints || !params.inputPoints->hasGraph() || params.inputPoints->points().empty() ||
      mesh.triangles.empty())
    return report;
  for (int pass = 0; pass < kMaxPasses && bandPass(mesh, normals, *params.inputPoints, report); ++pass) {
  }
  return report;
}

}  // namespace iires
