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

namespace iires {
namespace {

/// The k + 1 nearest of each point (itself normally first), flat with stride k + 1; missing entries = i.
std::vector<std::uint32_t> knnLists(const std::vector<Eigen::Vector3d>& points, std::size_t k, int threads) {
  KnnIndex index(points);
  const std::size_t stride = k + 1;
  std::vector<std::uint32_t> lists(points.size() * stride);
  parallelFor(points.size(), threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    const std::size_t f = index.knn(points[i], stride, idx, d2);
    for (std::size_t a = 0; a < stride; ++a)
      lists[i * stride + a] = a < f ? idx[a] : static_cast<std::uint32_t>(i);
  });
  return lists;
}

/// Orientation over a minimum spanning tree of the symmetric k-NN graph (j among i's first @p k neighbours
/// nbr[i·stride, i·stride + k), or i among j's; entries equal to i — itself, padding — skipped) on the weights
/// 1 − |nᵢ·nⱼ|, each normal flipped to agree with its tree parent. Kruskal: the edges (each once) sorted by
/// weight, ties by their order in the lists, so the tree is unique; then per component a walk from its root.
/// With @p sides, each component then takes the side most of those vectors are on.
void orientOverGraph(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                     const std::vector<std::uint32_t>& nbr, std::size_t stride, std::size_t k, int threads,
                     bool acrossEdge = false, const std::vector<Eigen::Vector3d>* sides = nullptr) {
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
  auto walk = [&](std::uint32_t root) {  // root's component, its normal made to face +x
    if (normals[root].x() < 0) normals[root] = -normals[root];
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
    if (!sides) return;
    long long vote = 0;  // the component's normals on the side of @p sides minus those against it
    for (std::uint32_t v : queue) vote += normals[v].dot((*sides)[v]) < 0 ? -1 : 1;
    if (vote < 0)
      for (std::uint32_t v : queue) normals[v] = -normals[v];
  };
  // Roots in decreasing x, so each component starts at its extreme point: the largest x first; the points its
  // tree leaves (other components) are sorted only when there are any.
  auto higher = [&](std::uint32_t a, std::uint32_t b) {
    return std::make_tuple(-points[a].x(), a) < std::make_tuple(-points[b].x(), b);
  };
  std::uint32_t first = 0;
  for (std::uint32_t i = 1; i < n; ++i)
    if (higher(i, first)) first = i;
  walk(first);
  std::vector<std::uint32_t> rest;
  for (std::uint32_t i = 0; i < n; ++i)
    if (!done[i]) rest.push_back(i);
  std::sort(rest.begin(), rest.end(), higher);
  for (std::uint32_t root : rest)
    if (!done[root]) walk(root);
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
                   bool acrossEdge, const std::vector<Eigen::Vector3d>* sides) {
  orientOverGraph(points, normals, neighbours, stride, std::min(k, stride), threads, acrossEdge, sides);
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
