// SPDX-License-Identifier: GPL-3.0-or-later
#include "patch_orientation.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <queue>
#include <tuple>

#include "iires/detail/disjoint_sets.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/detail/radix_sort.hpp"

namespace iires::detail {
namespace {

constexpr double kLinkAgreement = 0.9;  // n_i·n_j − x at or above this links two points into one patch
constexpr double kLinkOffPlane = 0.34;  // ... and each point within asin(this) (20°) of the other's tangent plane
constexpr double kCellRadii = 8.0;      // patch cells: this many median kernel radii wide
constexpr std::size_t kSmallPatch = 4;  // patches of fewer points follow their most agreeing neighbour
constexpr double kClearEvidence = 0.4;  // |Σ s_p w| at least this share of Σ |w| decides a patch's side
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

/// The interaction of points i and j as dipoles (their normals, a = the area each stands for), softened at a quarter
/// spacing (two points that close say little about their sides): negative where their signs agree.
double dipole(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
              const std::vector<double>& area, std::size_t i, std::size_t j) {
  const Eigen::Vector3d d = points[j] - points[i];
  const double r2 = d.squaredNorm() + 0.0625 * 0.5 * (area[i] + area[j]);
  const double x = normals[i].dot(d) * normals[j].dot(d) / r2;
  return area[i] * area[j] * (3.0 * x - normals[i].dot(normals[j])) / (r2 * std::sqrt(r2));
}

struct PatchPair {
  std::uint32_t a, b;  // a < b
  double weight;       // Σ a_i a_j (3x − n_i·n_j)/r³ over their pairs: negative where their signs agree
};

/// The interactions between patches, summed over every directed row entry (i, j) with patch[i] ≠ patch[j];
/// pairs sorted by (a, b).
std::vector<PatchPair> patchInteractions(const std::vector<Eigen::Vector3d>& points,
                                         const std::vector<Eigen::Vector3d>& normals, const OrientationEvidence& rows,
                                         const std::vector<std::uint32_t>& patch, const std::vector<double>& area,
                                         int threads) {
  const std::size_t n = points.size(), stride = rows.stride;
  const std::uint32_t* nbr = rows.rows.data();
  std::vector<std::uint32_t> offset(n + 1, 0);
  parallelFor(n, threads, [&](std::size_t i) {
    for (std::size_t a = 0; a < stride; ++a) offset[i + 1] += patch[nbr[i * stride + a]] != patch[i];
  });
  for (std::size_t i = 0; i < n; ++i) offset[i + 1] += offset[i];
  std::vector<double> weight(offset[n]);
  std::vector<KeyedIndex> keys(offset[n]);  // ((a << 32) | b, entry): radix-sorted, equal keys in entry order
  parallelFor(n, threads, [&](std::size_t i) {
    std::uint32_t e = offset[i];
    for (std::size_t a = 0; a < stride; ++a) {
      const std::uint32_t j = nbr[i * stride + a];
      if (patch[j] == patch[i]) continue;
      weight[e] = dipole(points, normals, area, i, j);
      const std::uint64_t lo = std::min(patch[i], patch[j]), hi = std::max(patch[i], patch[j]);
      keys[e] = {lo << 32 | hi, e};
      ++e;
    }
  });
  radixSort(keys, threads);
  std::vector<PatchPair> pairs;
  for (const auto& [key, e] : keys) {
    const auto a = static_cast<std::uint32_t>(key >> 32), b = static_cast<std::uint32_t>(key);
    if (!pairs.empty() && pairs.back().a == a && pairs.back().b == b)
      pairs.back().weight += weight[e];
    else
      pairs.push_back({a, b, weight[e]});
  }
  return pairs;
}

/// Prim's order over the patches (step 3): sign[p] = +1 keep, −1 turn, 0 never reached. @p size per patch root.
std::vector<signed char> settlePatches(const std::vector<PatchPair>& pairs, const std::vector<std::size_t>& size,
                                       const std::vector<std::uint32_t>& roots) {
  const std::size_t n = size.size();
  std::vector<std::uint32_t> start(n + 1, 0), other(2 * pairs.size());
  std::vector<double> weight(2 * pairs.size());
  for (const PatchPair& p : pairs) ++start[p.a + 1], ++start[p.b + 1];
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (const PatchPair& p : pairs) {
    other[fill[p.a]] = p.b, weight[fill[p.a]++] = p.weight;
    other[fill[p.b]] = p.a, weight[fill[p.b]++] = p.weight;
  }
  std::vector<signed char> sign(n, 0);
  std::vector<double> score(n, 0.0), total(n, 0.0), follow(n, 0.0);  // Σ s_p w, Σ |w|, Σ s_p |w|
  std::priority_queue<std::pair<double, std::uint32_t>> heap;  // (|score|, patch); stale entries skipped
  auto settle = [&](std::uint32_t p, signed char s) {
    sign[p] = s;
    for (std::uint32_t e = start[p]; e < start[p + 1]; ++e) {
      const std::uint32_t q = other[e];
      if (sign[q] != 0 || size[q] < kSmallPatch) continue;
      score[q] += s * weight[e], total[q] += std::abs(weight[e]), follow[q] += s * std::abs(weight[e]);
      heap.emplace(std::abs(score[q]), kNone - q);  // ties: the lower patch first
    }
  };
  for (std::uint32_t root : roots) {  // largest first: each part starts at its largest patch
    if (sign[root] != 0) continue;
    settle(root, 1);
    while (!heap.empty()) {
      const auto [strength, key] = heap.top();
      heap.pop();
      const std::uint32_t q = kNone - key;
      if (sign[q] != 0 || strength != std::abs(score[q])) continue;
      // The interactions decide only when they agree clearly; else the patch keeps the tree's relation to its
      // settled neighbours (turned like most of their summed weight).
      if (std::abs(score[q]) >= kClearEvidence * total[q])
        settle(q, score[q] <= 0 ? 1 : -1);
      else
        settle(q, follow[q] >= 0 ? 1 : -1);
    }
  }
  return sign;
}

/// Step 1's union: the links (link[i·k + a] for nbr[i·stride + a]) united in order (deterministic roots), but never
/// two sets that would then hold both points of a pair across a gap (evidence.apart). Returns each point's patch.
std::vector<std::uint32_t> unitePatches(std::size_t n, const std::uint32_t* nbr, std::size_t stride, std::size_t k,
                                        const std::vector<char>& link, const OrientationEvidence& evidence) {
  // The pairs across a gap, both ways (compressed rows).
  std::vector<std::uint32_t> start(n + 1, 0), to;
  auto apartAt = [&](std::size_t i, std::size_t a) {
    return evidence.apart && (*evidence.apart)[i * evidence.stride + a] && evidence.rows[i * evidence.stride + a] != i;
  };
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t a = 0; a < evidence.stride; ++a)
      if (apartAt(i, a)) ++start[i + 1], ++start[evidence.rows[i * evidence.stride + a] + 1];
  for (std::size_t i = 0; i < n; ++i) start[i + 1] += start[i];
  to.resize(start[n]);
  std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::size_t a = 0; a < evidence.stride; ++a)
      if (apartAt(i, a)) {
        const std::uint32_t j = evidence.rows[i * evidence.stride + a];
        to[fill[i]++] = j, to[fill[j]++] = i;
      }
  // Per set (at its root): its points that have a pair across a gap.
  std::vector<std::vector<std::uint32_t>> constrained(n);
  for (std::uint32_t i = 0; i < n; ++i)
    if (start[i + 1] > start[i]) constrained[i].push_back(i);
  DisjointSets sets(n);
  auto clash = [&](std::uint32_t from, std::uint32_t into) {
    for (std::uint32_t m : constrained[from])
      for (std::uint32_t e = start[m]; e < start[m + 1]; ++e)
        if (sets.find(to[e]) == into) return true;
    return false;
  };
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::size_t a = 0; a < k; ++a) {
      if (!link[i * k + a]) continue;
      std::uint32_t ra = sets.find(i), rb = sets.find(nbr[i * stride + a]);
      if (ra == rb) continue;
      if (constrained[ra].size() > constrained[rb].size()) std::swap(ra, rb);
      if (!constrained[ra].empty() && clash(ra, rb)) continue;
      sets.unite(ra, rb);
      const std::uint32_t root = std::min(ra, rb), other = std::max(ra, rb);
      if (constrained[other].size() > constrained[root].size()) std::swap(constrained[other], constrained[root]);
      constrained[root].insert(constrained[root].end(), constrained[other].begin(), constrained[other].end());
      std::vector<std::uint32_t>().swap(constrained[other]);
    }
  std::vector<std::uint32_t> patch(n);
  for (std::uint32_t i = 0; i < n; ++i) patch[i] = sets.find(i);
  return patch;
}

}  // namespace

std::size_t orientPatchesByField(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                                 const std::vector<std::uint32_t>& neighbours, std::size_t stride, std::size_t k,
                                 const OrientationEvidence& evidence, int threads) {
  const std::size_t n = points.size();
  if (n == 0) return 0;
  k = std::min(k, stride);
  const std::uint32_t* nbr = neighbours.data();
  // a_i = π r²/k, r = the distance to the farthest of its first k: the area the point stands for.
  std::vector<double> radius(n, 0.0), area(n);
  parallelFor(n, threads, [&](std::size_t i) {
    for (std::size_t a = 0; a < k; ++a)
      radius[i] = std::max(radius[i], (points[nbr[i * stride + a]] - points[i]).norm());
    area[i] = M_PI * radius[i] * radius[i] / static_cast<double>(k);
  });
  std::vector<double> sorted = radius;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(n / 2), sorted.end());
  const double cell = kCellRadii * sorted[n / 2];
  auto cellOf = [&](std::size_t i) {
    return cell > 0 ? std::array<long long, 3>{static_cast<long long>(std::floor(points[i].x() / cell)),
                                               static_cast<long long>(std::floor(points[i].y() / cell)),
                                               static_cast<long long>(std::floor(points[i].z() / cell))}
                    : std::array<long long, 3>{0, 0, 0};
  };
  // n_i·n_j − x and, in @p off, how far the pair leaves the points' tangent planes: max(|n_i·d̂|, |n_j·d̂|).
  auto agreement = [&](std::size_t i, std::size_t j, double* off) {
    const Eigen::Vector3d d = points[j] - points[i];
    const double len = d.norm();
    const double hi = len > 0 ? normals[i].dot(d) / len : 0.0, hj = len > 0 ? normals[j].dot(d) / len : 0.0;
    *off = std::max(std::abs(hi), std::abs(hj));
    return normals[i].dot(normals[j]) - hi * hj;
  };
  // Step 1: patches over the links (found in parallel).
  std::vector<std::array<long long, 3>> cells(n);
  parallelFor(n, threads, [&](std::size_t i) { cells[i] = cellOf(i); });
  std::vector<char> link(n * k, 0);
  parallelFor(n, threads, [&](std::size_t i) {
    for (std::size_t a = 0; a < k; ++a) {
      const std::uint32_t j = nbr[i * stride + a];
      double off = 0;
      link[i * k + a] =
          j != i && cells[i] == cells[j] && agreement(i, j, &off) >= kLinkAgreement && off <= kLinkOffPlane;
    }
  });
  const std::vector<std::uint32_t> patch = unitePatches(n, nbr, stride, k, link, evidence);
  std::vector<std::size_t> size(n, 0);
  for (std::uint32_t i = 0; i < n; ++i) ++size[patch[i]];
  std::vector<std::uint32_t> roots;
  for (std::uint32_t i = 0; i < n; ++i)
    if (patch[i] == i && size[i] >= kSmallPatch) roots.push_back(i);
  if (roots.size() < 2) return 0;
  std::stable_sort(roots.begin(), roots.end(), [&](std::uint32_t a, std::uint32_t b) { return size[a] > size[b]; });
  // Steps 2 and 3.
  const std::vector<signed char> sign =
      settlePatches(patchInteractions(points, normals, evidence, patch, area, threads), size, roots);
  // Step 4: a small patch as its most agreeing neighbour in a settled patch.
  std::vector<double> best(n, -std::numeric_limits<double>::max());
  std::vector<signed char> follow(n, 0);
  for (std::uint32_t i = 0; i < n; ++i) {
    if (size[patch[i]] >= kSmallPatch) continue;
    for (std::size_t a = 0; a < k; ++a) {
      const std::uint32_t j = nbr[i * stride + a];
      double off = 0;
      const double agree = j != i && sign[patch[j]] != 0 ? std::abs(agreement(i, j, &off)) : -1.0;
      if (agree > best[patch[i]]) best[patch[i]] = agree, follow[patch[i]] = sign[patch[j]];
    }
  }
  std::size_t turned = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const signed char s = size[patch[i]] >= kSmallPatch ? sign[patch[i]] : follow[patch[i]];
    if (s < 0) normals[i] = -normals[i], ++turned;
  }
  return turned;
}

}  // namespace iires::detail
