// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/reconstruct/triangulate.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_set>

#include "iires/knn.hpp"
#include "iires/sheets.hpp"
#include "iires/detail/tangent_cell.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"

namespace iires {
namespace {

constexpr std::uint32_t kNone = 0xffffffffu;
constexpr int kDiscSides = 16;

/// A proposed triangle, rotated so that its smallest vertex comes first (orientation kept).
struct Proposal {
  std::uint32_t a, b, c;
  std::uint32_t voter;
  bool operator<(const Proposal& o) const {
    const auto k = key(), ok = o.key();
    if (k != ok) return k < ok;
    if (b != o.b) return b < o.b;
    return voter < o.voter;
  }
  std::tuple<std::uint32_t, std::uint32_t, std::uint32_t> key() const {
    return {a, std::min(b, c), std::max(b, c)};
  }
};

Proposal makeProposal(std::uint32_t i, std::uint32_t j, std::uint32_t k) {
  if (i < j && i < k) return {i, j, k, i};
  if (j < i && j < k) return {j, k, i, i};
  return {k, i, j, i};
}

struct Candidate {
  std::uint32_t v[3];
  int votes;
  double quality;
};

std::uint64_t directed(std::uint32_t a, std::uint32_t b) { return (static_cast<std::uint64_t>(a) << 32) | b; }

}  // namespace

void TriangulateParams::validate() const {
  if (neighbours < 6) throw std::invalid_argument("neighbours must be at least 6 (got " + std::to_string(neighbours) + ")");
  if (!(cellRadiusFactor > 0.5)) throw std::invalid_argument("cellRadiusFactor must be greater than 0.5");
  if (!(minNormalDot >= -1.0 && minNormalDot <= 1.0)) throw std::invalid_argument("minNormalDot must be in [-1, 1]");
  if (!(minQuality >= 0.0 && minQuality < 1.0)) throw std::invalid_argument("minQuality must be in [0, 1)");
  if (!(minFaceNormalDot >= -1.0 && minFaceNormalDot <= 1.0))
    throw std::invalid_argument("minFaceNormalDot must be in [-1, 1]");
  if (minVotes < 1 || minVotes > 3) throw std::invalid_argument("minVotes must be 1, 2 or 3");
  if (!(flipMaxDihedral >= 0.0 && flipMaxDihedral < 180.0))
    throw std::invalid_argument("flipMaxDihedral must be in [0, 180)");
  if (maxFlipSweeps < 0) throw std::invalid_argument("maxFlipSweeps must be non-negative");
  if (!(sheetGap >= 0) || !std::isfinite(sheetGap)) throw std::invalid_argument("sheetGap must be finite and >= 0");
  if (!(sheetGapAngleDeg > 0 && sheetGapAngleDeg < 90)) throw std::invalid_argument("sheetGapAngleDeg must be in (0, 90)");
}

TriangulateResult triangulateLocal(const PointCloud& cloud, const TriangulateParams& params,
                                   const Execution& exec) {
  params.validate();
  const std::size_t n = cloud.size();
  if (n < 3) throw InputError("triangulation needs at least 3 points (got " + std::to_string(n) + ")");
  if (!cloud.hasNormals()) throw InputError("triangulation needs one normal per point");
  for (std::size_t i = 0; i < n; ++i)
    if (!cloud.points[i].allFinite() || !cloud.normals[i].allFinite() || cloud.normals[i].squaredNorm() == 0)
      throw InputError("point " + std::to_string(i) + " has a non-finite position or normal");

  NeighbourRule* rule = params.neighbourRule.get();
  EuclideanRule euclidean;
  if (!rule) rule = &euclidean;
  std::vector<Eigen::Vector3d> normals(cloud.normals);
  for (auto& v : normals) v.normalize();
  rule->update(cloud.points, normals);

  const KnnIndex index(cloud.points);
  const double gapCos = std::cos(params.sheetGapAngleDeg * M_PI / 180.0);
  if (!params.sheetNear.empty() && params.sheetNear.size() != n)
    throw std::invalid_argument("sheetNear must hold one flag per point");
  const bool gateAll = params.sheetNear.empty();
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(params.neighbours) + 1, n);
  // Per point: the triangles its 1-ring proposes (at most k + kDiscSides).
  std::vector<std::vector<Proposal>> proposals(n);
  parallelFor(n, exec.threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    const Eigen::Vector3d& nrm = normals[i];
    // The k nearest on the point's own sheet: candidates across a gap (sheetGap) are dropped and the query
    // widened, so that the spacing below and the ring are measured on the point's sheet.
    for (std::size_t want = k;; want = std::min(n, 2 * want)) {
      index.knn(cloud.points[i], want, idx, d2);
      std::size_t kept = 0;
      for (std::size_t c = 0; c < idx.size(); ++c) {
        const std::uint32_t j = idx[c];
        if (params.sheetGap > 0 && j != i && (gateAll || params.sheetNear[i] || params.sheetNear[j]) &&
            acrossGap(cloud.points[i], nrm, cloud.points[j], normals[j], params.sheetGap, gapCos))
          continue;
        idx[kept] = j, d2[kept] = d2[c], ++kept;
      }
      idx.resize(std::min(kept, k)), d2.resize(std::min(kept, k));
      if (kept >= k || want >= n) break;
    }
    const Eigen::Vector3d u = nrm.unitOrthogonal(), v = nrm.cross(u);
    // Local spacing: mean distance to the (up to) 6 nearest other points.
    double spacing = 0;
    int counted = 0;
    for (std::size_t c = 0; c < idx.size() && counted < 6; ++c)
      if (idx[c] != i && d2[c] > 0) spacing += std::sqrt(d2[c]), ++counted;
    if (counted == 0) return;
    spacing /= counted;
    const double radius = params.cellRadiusFactor * spacing;
    std::vector<Eigen::Vector2d> poly, tmpV;
    std::vector<std::uint32_t> lab, tmpL;
    const double rad = radius / std::cos(M_PI / kDiscSides);
    for (int e = 0; e < kDiscSides; ++e) {
      poly.emplace_back(rad * std::cos(2 * M_PI * e / kDiscSides), rad * std::sin(2 * M_PI * e / kDiscSides));
      lab.push_back(kNone);
    }
    for (std::size_t c = 0; c < idx.size(); ++c) {
      const std::uint32_t j = idx[c];
      if (j == i || d2[c] <= 0 || d2[c] > 4.0 * radius * radius) continue;
      if (normals[j].dot(nrm) < params.minNormalDot || !rule->accept(i, j)) continue;
      // Log-map approximation: the tangent direction with the true 3-D length.
      const Eigen::Vector3d d = cloud.points[j] - cloud.points[i];
      Eigen::Vector2d q(d.dot(u), d.dot(v));
      const double qn = q.norm(), len = std::sqrt(d2[c]);
      if (qn < 1e-9 * len) continue;
      q *= len / qn;
      clipByBisector(poly, lab, q, 0.5, j, tmpV, tmpL);
      if (poly.size() < 3) break;
    }
    if (poly.size() < 3) return;
    // Consecutive Voronoi neighbours (counter-clockwise about the normal) propose a triangle.
    const std::size_t m = lab.size();
    for (std::size_t e = 0; e < m; ++e) {
      const std::uint32_t a = lab[e], b = lab[(e + 1) % m];
      if (a == kNone || b == kNone || a == b) continue;
      proposals[i].push_back(makeProposal(static_cast<std::uint32_t>(i), a, b));
    }
  });

  // Count votes: distinct voters per oriented triangle; keep the orientation most voters agree on.
  std::vector<Proposal> all;
  for (const auto& p : proposals) all.insert(all.end(), p.begin(), p.end());
  proposals.clear();
  proposals.shrink_to_fit();
  std::sort(all.begin(), all.end());
  TriangulateResult result;
  std::vector<Candidate> cands;
  for (std::size_t s = 0; s < all.size();) {
    std::size_t e = s;
    while (e < all.size() && all[e].key() == all[s].key()) ++e;
    // Within [s, e): sorted by b, so one orientation then the other.
    std::size_t split = s;
    while (split < e && all[split].b == all[s].b) ++split;
    auto voters = [&](std::size_t from, std::size_t to) {
      int count = 0;
      for (std::size_t x = from; x < to; ++x)
        if (x == from || all[x].voter != all[x - 1].voter) ++count;
      return count;
    };
    const int first = voters(s, split), second = voters(split, e);
    const Proposal& p = first >= second ? all[s] : all[split];
    const int votes = std::max(first, second);
    ++result.candidates;
    if (votes >= 3) ++result.proposedBy3;
    if (votes == 2) ++result.proposedBy2;
    if (votes >= params.minVotes) {
      const double q = triangleQuality(cloud.points[p.a], cloud.points[p.b], cloud.points[p.c]);
      const Eigen::Vector3d fn =
          (cloud.points[p.b] - cloud.points[p.a]).cross(cloud.points[p.c] - cloud.points[p.a]).normalized();
      const double dot = std::min({fn.dot(normals[p.a]), fn.dot(normals[p.b]), fn.dot(normals[p.c])});
      if (q > 0 && q >= params.minQuality && dot >= params.minFaceNormalDot) cands.push_back({{p.a, p.b, p.c}, votes, q});
    }
    s = e;
  }
  all.clear();
  all.shrink_to_fit();

  // Greedy insertion: most votes, then best quality; each directed edge at most once.
  std::sort(cands.begin(), cands.end(), [](const Candidate& x, const Candidate& y) {
    if (x.votes != y.votes) return x.votes > y.votes;
    if (x.quality != y.quality) return x.quality > y.quality;
    return std::lexicographical_compare(x.v, x.v + 3, y.v, y.v + 3);
  });
  std::unordered_set<std::uint64_t> used;
  used.reserve(cands.size() * 3);
  result.mesh.vertices = cloud.points;
  for (const Candidate& c : cands) {
    const std::uint64_t e0 = directed(c.v[0], c.v[1]), e1 = directed(c.v[1], c.v[2]), e2 = directed(c.v[2], c.v[0]);
    if (used.count(e0) || used.count(e1) || used.count(e2)) {
      ++result.rejectedConflicts;
      continue;
    }
    used.insert(e0);
    used.insert(e1);
    used.insert(e2);
    result.mesh.triangles.emplace_back(static_cast<int>(c.v[0]), static_cast<int>(c.v[1]), static_cast<int>(c.v[2]));
  }
  result.removedFans = removeExtraFans(result.mesh, exec.threads);
  result.kept = result.mesh.triangles.size();
  if (params.flipMaxDihedral > 0 && params.maxFlipSweeps > 0)
    result.flips = flipToDelaunay(result.mesh, params.flipMaxDihedral, params.maxFlipSweeps);
  return result;
}

}  // namespace iires
