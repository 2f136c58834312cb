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
#include "iires/normals.hpp"
#include "iires/sheets.hpp"
#include "iires/detail/tangent_cell.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"

namespace iires {
namespace {

constexpr std::uint32_t kNone = 0xffffffffu;
constexpr int kDiscSides = 16;
constexpr std::size_t kOrientRow = 9;  // the point and its 8 nearest: the graph the normals are oriented over
/// Normals whose lines differ by more than this meet at a crease (orientAcrossCreases' threshold).
constexpr double kCreaseAngle = kCreaseAngleDegrees * M_PI / 180.0;
const double kCreaseSin = std::sin(kCreaseAngle);

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

/// Each point's k nearest on its own sheet (itself first), flat with stride k; rows padded with the point itself.
struct SheetRows {
  std::size_t k = 0;
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  std::vector<std::uint32_t> found;
  const std::uint32_t* row(std::size_t i) const { return idx.data() + i * k; }
  const double* dist2(std::size_t i) const { return d2.data() + i * k; }
};

/// The k nearest of each point on its own sheet: candidates across a gap (params.sheetGap) are dropped and the
/// query widened, so that the spacing and the 1-ring are measured on the point's sheet.
SheetRows sheetRows(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                    const KnnIndex& index, std::size_t k, const TriangulateParams& params, double gapCos,
                    int threads) {
  const std::size_t n = points.size();
  const bool gateAll = params.sheetNear.empty();
  SheetRows rows;
  rows.k = k;
  rows.idx.assign(n * k, 0);
  rows.d2.assign(n * k, 0.0);
  rows.found.assign(n, 0);
  parallelFor(n, threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    std::size_t kept = 0;
    for (std::size_t want = k;; want = std::min(n, 2 * want)) {
      index.knn(points[i], want, idx, d2);
      kept = 0;
      for (std::size_t c = 0; c < idx.size(); ++c) {
        const std::uint32_t j = idx[c];
        if (params.sheetGap > 0 && j != i && (gateAll || params.sheetNear[i] || params.sheetNear[j]) &&
            acrossGap(points[i], normals[i], points[j], normals[j], params.sheetGap, gapCos))
          continue;
        idx[kept] = j, d2[kept] = d2[c], ++kept;
      }
      if (kept >= k || want >= n) break;
    }
    kept = std::min(kept, k);
    rows.found[i] = static_cast<std::uint32_t>(kept);
    for (std::size_t a = 0; a < k; ++a) {
      rows.idx[i * k + a] = a < kept ? idx[a] : static_cast<std::uint32_t>(i);
      rows.d2[i * k + a] = a < kept ? d2[a] : 0.0;
    }
  });
  return rows;
}

/// Per point, its kOrientRow − 1 nearest on its sheet that the neighbour rule accepts (padded with itself): the
/// graph orientAcrossCreases() turns the normals over.
std::vector<std::uint32_t> orientationGraph(const SheetRows& rows, const NeighbourRule& rule, int threads) {
  const std::size_t n = rows.found.size();
  std::vector<std::uint32_t> graph(n * kOrientRow);
  parallelFor(n, threads, [&](std::size_t i) {
    std::uint32_t* out = graph.data() + i * kOrientRow;
    std::size_t m = 0;
    out[m++] = static_cast<std::uint32_t>(i);
    for (std::size_t a = 0; a < rows.found[i] && m < kOrientRow; ++a) {
      const std::uint32_t j = rows.row(i)[a];
      if (j != i && rule.accept(i, j)) out[m++] = j;
    }
    while (m < kOrientRow) out[m++] = static_cast<std::uint32_t>(i);
  });
  return graph;
}

/// Where the surface runs from point i (unit normal ni) to a neighbour at offset d (unit normal nj), as a vector
/// in i's tangent plane: the chord projected onto that plane, or, where the normals' lines differ by more than 15°
/// (kCreaseSin; a crease), the neighbour unfolded about the line where the two tangent planes meet (rotated about
/// it by the rotation taking nj to ni), so that a neighbour beyond a crease of any angle lies beyond the crease
/// line, at the length of the path over the two planes, instead of folded back over i's side.
Eigen::Vector3d towardNeighbour(const Eigen::Vector3d& d, const Eigen::Vector3d& ni, const Eigen::Vector3d& nj,
                                bool* crease) {
  const Eigen::Vector3d axis = ni.cross(nj);
  const double s = axis.norm();
  const Eigen::Vector3d projected = d - ni.dot(d) * ni;
  *crease = s > kCreaseSin;
  if (!*crease) return projected;
  const Eigen::Vector3d m = (axis / s).cross(ni);  // in i's plane, orthogonal to the crease line
  // i and j lie (nj·d)/s and (ni·d)/s from the line along m; unfolded, j lies the difference away.
  return projected + ((nj - ni).dot(d) / s - m.dot(d)) * m;
}

/// Whether a face (unit normal fn) faces the way its vertices' normals do: it may differ from each by up to
/// acos(minFaceNormalDot), or, over a crease, by as much as the vertices' normals differ from each other plus the
/// crease threshold, and it faces the side of their sum — a face across a crease of any angle has its normal
/// between the faces' (a face that bridges a gap, or lies folded over, differs from them all, or from most, by
/// more).
bool faceFollowsNormals(const Eigen::Vector3d& fn, const Eigen::Vector3d& na, const Eigen::Vector3d& nb,
                        const Eigen::Vector3d& nc, const TriangulateParams& params) {
  const double spread = std::acos(std::clamp(std::min({na.dot(nb), nb.dot(nc), nc.dot(na)}), -1.0, 1.0));
  const double limit = std::min(params.minFaceNormalDot, std::cos(std::min(M_PI, spread + kCreaseAngle)));
  return std::min({fn.dot(na), fn.dot(nb), fn.dot(nc)}) >= limit && fn.dot(na + nb + nc) > 0;
}

/// The triangles point i's 1-ring proposes: its sheet neighbours (accepted by the rule, normals compatible) in its
/// tangent plane (towardNeighbour), its Voronoi cell clipped from a disc; consecutive Voronoi neighbours (i, j, k)
/// propose a triangle, oriented counter-clockwise about the normal.
std::vector<Proposal> ringProposals(const std::vector<Eigen::Vector3d>& points,
                                    const std::vector<Eigen::Vector3d>& normals, const SheetRows& rows,
                                    std::size_t i, const NeighbourRule& rule, const TriangulateParams& params) {
  std::vector<Proposal> out;
  const std::uint32_t* idx = rows.row(i);
  const double* d2 = rows.dist2(i);
  const std::size_t found = rows.found[i];
  const Eigen::Vector3d& nrm = normals[i];
  const Eigen::Vector3d u = nrm.unitOrthogonal(), v = nrm.cross(u);
  // Local spacing: mean distance to the (up to) 6 nearest other points.
  double spacing = 0;
  int counted = 0;
  for (std::size_t c = 0; c < found && counted < 6; ++c)
    if (idx[c] != i && d2[c] > 0) spacing += std::sqrt(d2[c]), ++counted;
  if (counted == 0) return out;
  spacing /= counted;
  const double radius = params.cellRadiusFactor * spacing;
  std::vector<Eigen::Vector2d> poly, tmpV;
  std::vector<std::uint32_t> lab, tmpL;
  const double rad = radius / std::cos(M_PI / kDiscSides);
  for (int e = 0; e < kDiscSides; ++e) {
    poly.emplace_back(rad * std::cos(2 * M_PI * e / kDiscSides), rad * std::sin(2 * M_PI * e / kDiscSides));
    lab.push_back(kNone);
  }
  for (std::size_t c = 0; c < found; ++c) {
    const std::uint32_t j = idx[c];
    if (j == i || d2[c] <= 0 || d2[c] > 4.0 * radius * radius) continue;
    bool crease = false;
    const Eigen::Vector3d t = towardNeighbour(points[j] - points[i], nrm, normals[j], &crease);
    // Normals far apart without a crease between the points: the far side of a thin part.
    if ((!crease && normals[j].dot(nrm) < params.minNormalDot) || !rule.accept(i, j)) continue;
    // Log-map approximation: the tangent direction with the true 3-D length (over a crease, the unfolded one).
    Eigen::Vector2d q(t.dot(u), t.dot(v));
    const double qn = q.norm(), len = crease ? t.norm() : std::sqrt(d2[c]);
    if (qn < 1e-9 * std::sqrt(d2[c]) || len > 2.0 * radius) continue;
    q *= len / qn;
    clipByBisector(poly, lab, q, 0.5, j, tmpV, tmpL);
    if (poly.size() < 3) break;
  }
  if (poly.size() < 3) return out;
  const std::size_t m = lab.size();
  for (std::size_t e = 0; e < m; ++e) {
    const std::uint32_t a = lab[e], b = lab[(e + 1) % m];
    if (a == kNone || b == kNone || a == b) continue;
    out.push_back(makeProposal(static_cast<std::uint32_t>(i), a, b));
  }
  return out;
}

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
  const std::size_t k = std::min<std::size_t>(static_cast<std::size_t>(params.neighbours) + 1, n);
  const SheetRows rows = sheetRows(cloud.points, normals, index, k, params, gapCos, exec.threads);
  TriangulateResult result;
  if (params.orientAcrossCreases) {
    const std::vector<Eigen::Vector3d> given = normals;
    const std::vector<std::uint32_t> graph = orientationGraph(rows, *rule, exec.threads);
    orientAcrossCreases(cloud.points, normals, graph, kOrientRow, kOrientRow, exec.threads, &given);
    for (std::size_t i = 0; i < n; ++i) result.normalsTurned += normals[i].dot(given[i]) < 0;
  }
  // Per point: the triangles its 1-ring proposes (at most k + kDiscSides).
  std::vector<std::vector<Proposal>> proposals(n);
  parallelFor(n, exec.threads, [&](std::size_t i) {
    proposals[i] = ringProposals(cloud.points, normals, rows, i, *rule, params);
  });

  // Count votes: distinct voters per oriented triangle; keep the orientation most voters agree on.
  std::vector<Proposal> all;
  for (const auto& p : proposals) all.insert(all.end(), p.begin(), p.end());
  proposals.clear();
  proposals.shrink_to_fit();
  std::sort(all.begin(), all.end());
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
      if (q > 0 && q >= params.minQuality && faceFollowsNormals(fn, normals[p.a], normals[p.b], normals[p.c], params))
        cands.push_back({{p.a, p.b, p.c}, votes, q});
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
  result.normals = std::move(normals);
  return result;
}

}  // namespace iires
