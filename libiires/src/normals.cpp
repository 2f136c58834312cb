// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/normals.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <tuple>

#include "iires/detail/disjoint_sets.hpp"
#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/detail/radix_sort.hpp"
#include "patch_orientation.hpp"
#include "scan_lines.hpp"

namespace iires {
namespace {

/// The k + 1 nearest of each point (itself normally first; widened across scan lines as NeighbourTable's rows
/// are), flat with stride k + 1; missing entries = i.
std::vector<std::uint32_t> knnLists(const std::vector<Eigen::Vector3d>& points, std::size_t k, int threads) {
  const KnnIndex index(points);
  const std::size_t stride = k + 1;
  const NeighbourTable table(index, points, stride, threads);
  std::vector<std::uint32_t> lists(points.size() * stride);
  parallelFor(points.size(), threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const std::size_t f = table.get(i, stride, idx, d2);
    for (std::size_t a = 0; a < stride; ++a)
      lists[i * stride + a] = a < f ? idx[a] : static_cast<std::uint32_t>(i);
  });
  return lists;
}

/// Orientation over a minimum spanning tree of the symmetric k-NN graph (j among i's first @p k neighbours
/// nbr[i·stride, i·stride + k), or i among j's; entries equal to i — itself, padding — skipped) on the weights
/// 1 − |nᵢ·nⱼ|, each normal flipped to agree with its tree parent. Kruskal: the edges (each once) sorted by
/// weight, ties by their order in the lists, so the tree is unique; then per component a walk from its first point.
/// The patches the tree could only guess across are then settled by orientPatchesByField, and each component takes
/// the side most of @p sides are on, or its point of largest x faces +x.
void orientOverGraph(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                     const std::vector<std::uint32_t>& nbr, std::size_t stride, std::size_t k, int threads,
                     bool acrossEdge = false, const std::vector<Eigen::Vector3d>* sides = nullptr,
                     const OrientationEvidence* evidence = nullptr) {
  const std::size_t n = points.size();
  if (n == 0) return;
  auto listed = [&](std::uint32_t i, std::uint32_t j) {  // j among i's first k
    const std::uint32_t* row = nbr.data() + static_cast<std::size_t>(i) * stride;
    return std::find(row, row + k, j) != row + k;
  };
  // How far n_i and n_j agree: their dot product, or with acrossEdge that of their parts orthogonal to the edge
  // d = p_j − p_i, n_i·n_j − (n_i·d̂)(n_j·d̂): on a surface consistently oriented normals agree there however
  // sharply it turns between them (a crease, a tight fold), and across a gap (d along both normals) it vanishes.
  auto agreement = [&](std::size_t i, std::size_t j) {
    const double c = normals[i].dot(normals[j]);
    if (!acrossEdge) return c;
    const Eigen::Vector3d d = points[j] - points[i];
    const double d2 = d.squaredNorm();
    return d2 > 0 ? c - normals[i].dot(d) * normals[j].dot(d) / d2 : c;
  };
  // Each undirected edge once: from the lower end, or from the higher one when the lower does not list it.
  auto kept = [&](std::uint32_t i, std::uint32_t j) { return j != i && (i < j || !listed(j, i)); };
  std::vector<std::uint32_t> offset(n + 1, 0);
  parallelFor(n, threads, [&](std::size_t i) {
    for (std::size_t a = 0; a < k; ++a) offset[i + 1] += kept(static_cast<std::uint32_t>(i), nbr[i * stride + a]);
  });
  for (std::size_t i = 0; i < n; ++i) offset[i + 1] += offset[i];
  std::vector<std::array<std::uint32_t, 2>> edges(offset[n]);
  std::vector<KeyedIndex> byWeight(offset[n]);
  parallelFor(n, threads, [&](std::size_t i) {
    std::uint32_t e = offset[i];
    for (std::size_t a = 0; a < k; ++a) {
      const std::uint32_t j = nbr[i * stride + a];
      if (!kept(static_cast<std::uint32_t>(i), j)) continue;
      // Non-negative floats order like their bit patterns.
      const float w = std::max(0.0f, static_cast<float>(1.0 - std::abs(agreement(i, j))));
      std::uint32_t bits;
      std::memcpy(&bits, &w, sizeof bits);
      edges[e] = {static_cast<std::uint32_t>(i), j};
      byWeight[e] = {bits, e};
      ++e;
    }
  });
  radixSort(byWeight, threads);
  DisjointSets sets(n);
  std::vector<std::array<std::uint32_t, 2>> tree;  // at most n − 1 edges
  tree.reserve(n - 1);
  for (const auto& [key, e] : byWeight) {
    const auto [a, b] = edges[e];
    if (sets.find(a) == sets.find(b)) continue;
    sets.unite(a, b);
    tree.push_back({a, b});
    if (tree.size() + 1 == n) break;
  }
  // The tree's adjacency (CSR).
  std::vector<std::uint32_t> start(n + 1, 0), adjacent(2 * tree.size());
  for (const auto& [a, b] : tree) ++start[a + 1], ++start[b + 1];
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (const auto& [a, b] : tree) adjacent[fill[a]++] = b, adjacent[fill[b]++] = a;
  std::vector<char> done(n, 0);
  std::vector<std::uint32_t> queue;
  queue.reserve(n);
  auto walk = [&](std::uint32_t root) {  // each normal made to agree with its tree parent
    done[root] = 1;
    queue.assign(1, root);
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const std::uint32_t v = queue[q];
      for (std::uint32_t e = start[v]; e < start[v + 1]; ++e) {
        const std::uint32_t t = adjacent[e];
        if (done[t]) continue;
        done[t] = 1;
        if (agreement(v, t) < 0) normals[t] = -normals[t];
        queue.push_back(t);
      }
    }
  };
  for (std::uint32_t i = 0; i < n; ++i)
    if (!done[i]) walk(i);
  // Faces the tree could only guess across (a crease a sparse sampling does not resolve) turned to agree with the
  // rest of their part.
  detail::orientPatchesByField(points, normals, nbr, stride, k, evidence ? *evidence : OrientationEvidence{nbr, stride},
                               threads);
  // Each component then faces the side most of @p sides are on, or its point of largest x faces +x.
  auto higher = [&](std::uint32_t a, std::uint32_t b) {
    return std::make_tuple(-points[a].x(), a) < std::make_tuple(-points[b].x(), b);
  };
  std::vector<std::uint32_t> extreme(n, std::numeric_limits<std::uint32_t>::max());
  std::vector<long long> vote(n, 0);  // the component's normals on the side of @p sides minus those against it
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t c = sets.find(i);
    if (extreme[c] == std::numeric_limits<std::uint32_t>::max() || higher(i, extreme[c])) extreme[c] = i;
    if (sides) vote[c] += normals[i].dot((*sides)[i]) < 0 ? -1 : 1;
  }
  std::vector<char> turn(n, 0);
  for (std::uint32_t c = 0; c < n; ++c)
    if (extreme[c] != std::numeric_limits<std::uint32_t>::max())
      turn[c] = sides ? vote[c] < 0 : normals[extreme[c]].x() < 0;
  for (std::uint32_t i = 0; i < n; ++i)
    if (turn[sets.find(i)]) normals[i] = -normals[i];
}

/// orientAcrossCreases: normals whose lines differ by more than asin(this) (15°) meet at a crease.
const double kCreaseSin = std::sin(kCreaseAngleDegrees * M_PI / 180.0);
/// orientAcrossCreases: a point lies on its plane when at least this share of its row is within kCreaseSin of its
/// tangent plane; only such points grow a patch.
constexpr double kPlanarShare = 0.75;
/// orientAcrossCreases: a patch grows only over pairs whose agreement |n_i·n_j − (n_i·d̂)(n_j·d̂)| is at least this
/// (a pair across a thin gap has about none).
constexpr double kPatchAgreement = 0.5;
/// orientAcrossCreases: |(n_i·d̂)(n_j·d̂)| below this does not tell the sides of a crease apart (a point on or next
/// to the other's tangent plane).
constexpr double kCreaseSides = 0.1;
/// orientAcrossCreases: the weight of a pair whose normals' angle says the opposite of the sides' rule (a crease
/// sharper than 90°, or two sheets one above the other, which two points alone do not tell apart).
constexpr double kAmbiguous = 0.25;
/// orientAcrossCreases: with given sides, patches of fewer points keep them.
constexpr std::uint32_t kTrustedPatch = 8;

/// Signs along the trees of a forest given as edges (a, b, agree): from each tree's root (its smallest index, the
/// DisjointSets root), each node's sign is its parent's, turned over where the edge says the two disagree.
std::vector<signed char> signsAlongTrees(std::size_t n, const std::vector<std::tuple<std::uint32_t, std::uint32_t, bool>>& tree,
                                         DisjointSets& sets) {
  std::vector<std::uint32_t> start(n + 1, 0), adjacent(2 * tree.size());
  std::vector<char> agree(2 * tree.size());
  for (const auto& [a, b, same] : tree) ++start[a + 1], ++start[b + 1];
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (const auto& [a, b, same] : tree) {
    agree[fill[a]] = same, adjacent[fill[a]++] = b;
    agree[fill[b]] = same, adjacent[fill[b]++] = a;
  }
  std::vector<signed char> sign(n, 0);
  std::vector<std::uint32_t> queue;
  for (std::uint32_t root = 0; root < n; ++root) {
    if (sign[root] || sets.find(root) != root) continue;
    sign[root] = 1;
    queue.assign(1, root);
    for (std::size_t q = 0; q < queue.size(); ++q) {
      const std::uint32_t v = queue[q];
      for (std::uint32_t e = start[v]; e < start[v + 1]; ++e)
        if (const std::uint32_t t = adjacent[e]; !sign[t]) {
          sign[t] = static_cast<signed char>(agree[e] ? sign[v] : -sign[v]);
          queue.push_back(t);
        }
    }
  }
  return sign;
}

/// orientAcrossCreases' last step: a patch of fewer than kTrustedPatch points has too little evidence of its own
/// (its links can be one pair of stacked sheets); each of its points keeps the side it was @p given, turned over
/// like the nearest point of a larger patch on its plane (breadth first over the pairs whose normals' lines are
/// within 15°, from the larger patches' points in index order), or as given where none is reached.
void keepSmallPatchesAsGiven(std::vector<Eigen::Vector3d>& normals, const std::vector<Eigen::Vector3d>& given,
                             const std::uint32_t* nbr, std::size_t stride, std::size_t k, DisjointSets& patches) {
  const std::size_t n = normals.size();
  std::vector<std::uint32_t> size(n, 0);
  for (std::uint32_t i = 0; i < n; ++i) ++size[patches.find(i)];
  std::vector<signed char> turned(n, 0);  // +1 turned from the given side, −1 kept, 0 not reached yet
  std::vector<std::uint32_t> queue;
  for (std::uint32_t i = 0; i < n; ++i)
    if (size[patches.find(i)] >= kTrustedPatch) {
      turned[i] = normals[i].dot(given[i]) < 0 ? 1 : -1;
      queue.push_back(i);
    }
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const std::uint32_t i = queue[q];
    for (std::size_t a = 0; a < k; ++a) {
      const std::uint32_t j = nbr[i * stride + a];
      if (turned[j] || normals[i].cross(normals[j]).norm() > kCreaseSin) continue;
      turned[j] = turned[i];
      queue.push_back(j);
    }
  }
  for (std::uint32_t i = 0; i < n; ++i)
    if (size[patches.find(i)] < kTrustedPatch && (normals[i].dot(given[i]) < 0) != (turned[i] > 0))
      normals[i] = -normals[i];
}

}  // namespace

std::vector<Eigen::Vector3d> estimateNormals(const std::vector<Eigen::Vector3d>& points,
                                             const NormalParams& params, const Execution& exec) {
  const std::size_t n = points.size(), stride = static_cast<std::size_t>(params.k) + 1;
  const auto lists = knnLists(points, static_cast<std::size_t>(params.k), exec.threads);
  std::vector<Eigen::Vector3d> normals(n, Eigen::Vector3d::UnitZ());
  parallelFor(n, exec.threads, [&](std::size_t i) {
    const std::uint32_t* nb = lists.data() + i * stride;
    std::size_t count = 1;
    Eigen::Vector3d mean = points[i];
    for (std::size_t a = 0; a < stride; ++a)
      if (nb[a] != i) mean += points[nb[a]], ++count;
    if (count < 3) return;
    mean /= static_cast<double>(count);
    Eigen::Matrix3d cov = (points[i] - mean) * (points[i] - mean).transpose();
    for (std::size_t a = 0; a < stride; ++a)
      if (nb[a] != i) cov += (points[nb[a]] - mean) * (points[nb[a]] - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    normals[i] = eig.eigenvectors().col(0).normalized();
  });
  if (params.orient) orientOverGraph(points, normals, lists, stride, stride, exec.threads);
  return normals;
}

void orientNormals(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals, int k) {
  const std::size_t stride = static_cast<std::size_t>(k) + 1;
  orientOverGraph(points, normals, knnLists(points, stride - 1, 0), stride, stride, 0);
}

void orientNormals(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                   const std::vector<std::uint32_t>& neighbours, std::size_t stride, std::size_t k, int threads,
                   bool acrossEdge, const std::vector<Eigen::Vector3d>* sides,
                   const OrientationEvidence* evidence) {
  orientOverGraph(points, normals, neighbours, stride, std::min(k, stride), threads, acrossEdge, sides, evidence);
}

void orientAcrossCreases(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                         const std::vector<std::uint32_t>& neighbours, std::size_t stride, std::size_t k, int threads,
                         const std::vector<Eigen::Vector3d>* sides) {
  const std::size_t n = points.size();
  if (n == 0) return;
  k = std::min(k, stride);
  const std::uint32_t* nbr = neighbours.data();
  // How far each point's row lies on its tangent plane: next to a crease sharper than 90° a fitted normal can be
  // neither face's (a fit across the wedge), and its pairs are weak evidence.
  std::vector<double> planar(n, 0.0);
  parallelFor(n, threads, [&](std::size_t i) {
    int rows = 0, on = 0;
    for (std::size_t a = 0; a < k; ++a) {
      const std::uint32_t j = nbr[i * stride + a];
      const Eigen::Vector3d d = points[j] - points[i];
      if (j == i || d.squaredNorm() == 0) continue;
      ++rows;
      on += std::abs(normals[i].dot(d)) < kCreaseSin * d.norm();
    }
    planar[i] = rows > 0 ? static_cast<double>(on) / rows : 0.0;
  });
  auto listed = [&](std::uint32_t i, std::uint32_t j) { return std::find(nbr + i * stride, nbr + i * stride + k, j) != nbr + i * stride + k; };
  std::vector<std::array<std::uint32_t, 2>> edges;  // each undirected edge once
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::size_t a = 0; a < k; ++a)
      if (const std::uint32_t j = nbr[i * stride + a]; j != i && (i < j || !listed(j, i))) edges.push_back({i, j});
  auto across = [&](std::uint32_t i, std::uint32_t j) {  // (n_i·d̂)(n_j·d̂)
    const Eigen::Vector3d d = points[j] - points[i];
    const double d2 = d.squaredNorm();
    return d2 > 0 ? normals[i].dot(d) * normals[j].dot(d) / d2 : 0.0;
  };
  // Whether the surface turns between the two points: their normals not within 15° of parallel (a crease of any
  // angle, a thin part's two sides, a normal turned over).
  auto turns = [&](std::uint32_t i, std::uint32_t j) {
    return normals[i].dot(normals[j]) <= 0 || normals[i].cross(normals[j]).norm() > kCreaseSin;
  };
  // 1. Patches: a spanning forest over the pairs of points on their planes whose normals are within 15° of parallel
  // and agree clearly (on the weights 1 − |n_i·n_j − (n_i·d̂)(n_j·d̂)|, ties by edge), each turned consistent along
  // its tree.
  std::vector<std::pair<double, std::uint32_t>> order;
  for (std::uint32_t e = 0; e < edges.size(); ++e) {
    const auto [i, j] = edges[e];
    const double agree = std::abs(normals[i].dot(normals[j]) - across(i, j));
    if (!turns(i, j) && std::min(planar[i], planar[j]) >= kPlanarShare && agree >= kPatchAgreement)
      order.emplace_back(1.0 - agree, e);
  }
  std::sort(order.begin(), order.end());
  DisjointSets patches(n);
  std::vector<std::tuple<std::uint32_t, std::uint32_t, bool>> tree;
  for (const auto& [w, e] : order) {
    const auto [i, j] = edges[e];
    if (patches.find(i) == patches.find(j)) continue;
    patches.unite(i, j);
    tree.emplace_back(i, j, normals[i].dot(normals[j]) - across(i, j) >= 0);
  }
  const std::vector<signed char> inPatch = signsAlongTrees(n, tree, patches);
  for (std::size_t i = 0; i < n; ++i)
    if (inPatch[i] < 0) normals[i] = -normals[i];
  // 2. Between two patches, the evidence of all their pairs summed, each weighed by how far both points lie on
  // their planes: where the surface turns between them the sides' rule (consistent normals have (n_i·d)(n_j·d) ≤ 0
  // over a convex or a concave crease of any angle, where n_i·n_j has the wrong sign past 90°, and across a thin
  // part), elsewhere the normals compared.
  std::vector<std::tuple<std::uint32_t, std::uint32_t, double>> votes;
  for (const auto& [i, j] : edges) {
    const std::uint32_t pi = patches.find(i), pj = patches.find(j);
    if (pi == pj) continue;
    const double x = across(i, j), trust = std::min(planar[i], planar[j]);
    const double c = normals[i].dot(normals[j]);
    double vote = turns(i, j) ? (std::abs(x) >= kCreaseSides ? -x : 0.0) : c - x;
    if (turns(i, j) && vote * c < 0) vote *= kAmbiguous;  // the normals say otherwise: a crease or stacked sheets
    votes.emplace_back(std::min(pi, pj), std::max(pi, pj), trust * vote);
  }
  std::sort(votes.begin(), votes.end());
  std::vector<std::tuple<double, std::uint32_t, std::uint32_t, double>> links;  // (−|sum|, patch, patch, sum)
  for (std::size_t s = 0; s < votes.size();) {
    std::size_t e = s;
    double sum = 0;
    for (; e < votes.size() && std::get<0>(votes[e]) == std::get<0>(votes[s]) && std::get<1>(votes[e]) == std::get<1>(votes[s]); ++e)
      sum += std::get<2>(votes[e]);
    if (sum != 0) links.emplace_back(-std::abs(sum), std::get<0>(votes[s]), std::get<1>(votes[s]), sum);
    s = e;
  }
  // 3. The patches turned along a spanning forest of the strongest sums.
  std::sort(links.begin(), links.end());
  DisjointSets groups(n);
  tree.clear();
  for (const auto& [w, a, b, sum] : links) {
    if (groups.find(a) == groups.find(b)) continue;
    groups.unite(a, b);
    tree.emplace_back(a, b, sum > 0);
  }
  const std::vector<signed char> patchSign = signsAlongTrees(n, tree, groups);
  // 4. Each group of patches on the side most of @p sides are on, or with its point of largest x facing +x.
  std::vector<long long> side(n, 0);
  std::vector<std::uint32_t> extreme(n, std::numeric_limits<std::uint32_t>::max());
  for (std::uint32_t i = 0; i < n; ++i) {
    if (patchSign[patches.find(i)] < 0) normals[i] = -normals[i];
    const std::uint32_t g = groups.find(patches.find(i));
    if (sides) side[g] += normals[i].dot((*sides)[i]) < 0 ? -1 : 1;
    if (extreme[g] == std::numeric_limits<std::uint32_t>::max() || points[i].x() > points[extreme[g]].x()) extreme[g] = i;
  }
  std::vector<char> turn(n, 0);
  for (std::uint32_t g = 0; g < n; ++g)
    if (extreme[g] != std::numeric_limits<std::uint32_t>::max()) turn[g] = sides ? side[g] < 0 : normals[extreme[g]].x() < 0;
  for (std::uint32_t i = 0; i < n; ++i)
    if (turn[groups.find(patches.find(i))]) normals[i] = -normals[i];
  if (sides) keepSmallPatchesAsGiven(normals, *sides, nbr, stride, k, patches);
}

double orientationConflicts(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                            const std::vector<std::uint32_t>& neighbours, std::size_t stride, std::size_t k,
                            int threads) {
  constexpr double kNoiseSpacings = 0.5;  // a sheet's own noise: heights up to this many local spacings
  const double onPlane = std::sin(15.0 * M_PI / 180.0), parallel = std::cos(25.0 * M_PI / 180.0);
  const std::size_t n = points.size(), row = std::min(k, stride);
  // Local spacing: the mean nearest-neighbour distance over the point's row.
  std::vector<double> nearest(n, 0.0), spacing(n, 0.0);
  parallelFor(n, threads, [&](std::size_t i) {
    double d2 = std::numeric_limits<double>::infinity();
    for (std::size_t a = 0; a < row; ++a) {
      const std::uint32_t j = neighbours[i * stride + a];
      if (j != i) d2 = std::min(d2, (points[j] - points[i]).squaredNorm());
    }
    nearest[i] = std::isfinite(d2) ? std::sqrt(d2) : 0.0;
  });
  parallelFor(n, threads, [&](std::size_t i) {
    for (std::size_t a = 0; a < row; ++a) spacing[i] += nearest[neighbours[i * stride + a]];
    spacing[i] /= static_cast<double>(row);
  });
  std::vector<std::array<std::uint32_t, 2>> counts(n, {0, 0});  // {pairs, conflicts} per point
  parallelFor(n, threads, [&](std::size_t i) {
    for (std::size_t a = 0; a < row; ++a) {
      const std::uint32_t j = neighbours[i * stride + a];
      if (j == i) continue;
      const Eigen::Vector3d d = points[j] - points[i];
      const double c = normals[i].dot(normals[j]);
      const double height = std::min(onPlane * d.norm(), kNoiseSpacings * std::min(spacing[i], spacing[j]));
      if (std::abs(c) < parallel || std::abs(normals[i].dot(d)) > height || std::abs(normals[j].dot(d)) > height)
        continue;
      ++counts[i][0];
      counts[i][1] += c < 0;
    }
  });
  double pairs = 0, conflicts = 0;
  for (const auto& [p, c] : counts) pairs += p, conflicts += c;
  return pairs > 0 ? conflicts / pairs : 0.0;
}

bool givenNormalsDescribeSurface(const std::vector<Eigen::Vector3d>& points,
                                 const std::vector<Eigen::Vector3d>& normals, const NeighbourTable& table,
                                 int threads) {
  constexpr std::size_t kPlaneNeighbours = 16;
  constexpr double kFlat = 0.25;      // smallest over middle eigenvalue: the neighbours lie about a plane
  constexpr double kAgreeCos = 0.5;   // within 60° of the plane's normal, either sign
  constexpr double kAgreement = 0.75;  // a surface's own normals agree on over 95 %, random ones on half
  const std::size_t n = points.size();
  std::vector<std::uint8_t> verdict(n, 0);  // 0: no plane, 1: disagrees, 2: agrees
  parallelFor(n, threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    const std::size_t f = table.get(i, std::min(kPlaneNeighbours, table.k()), idx, d2);
    if (f < 8) return;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(detail::scatter(points, points[i], idx.data() + 1, f - 1));  // row 0 is the point itself
    const Eigen::Vector3d& l = eig.eigenvalues();
    if (detail::onALine(l) || l(0) > kFlat * l(1)) return;
    verdict[i] = std::abs(eig.eigenvectors().col(0).dot(normals[i].normalized())) >= kAgreeCos ? 2 : 1;
  });
  const auto planar = n - static_cast<std::size_t>(std::count(verdict.begin(), verdict.end(), 0));
  if (10 * planar < n || planar == 0) return true;  // too few planes to judge by
  return static_cast<double>(std::count(verdict.begin(), verdict.end(), 2)) >= kAgreement * static_cast<double>(planar);
}

std::size_t repairOrientation(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                              int k, int threads) {
  const std::size_t stride = static_cast<std::size_t>(k) + 1;
  const auto lists = knnLists(points, stride - 1, threads);
  if (orientationConflicts(points, normals, lists, stride, stride, threads) <= kMaxOrientationConflicts) return 0;
  const std::vector<Eigen::Vector3d> given = normals;
  orientOverGraph(points, normals, lists, stride, stride, threads, true, &given);
  std::size_t turned = 0;
  for (std::size_t i = 0; i < normals.size(); ++i) turned += normals[i].dot(given[i]) < 0;
  return turned;
}

}  // namespace iires
