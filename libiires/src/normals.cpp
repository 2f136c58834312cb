#include "iires/normals.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstdint>
#include <limits>
#include <queue>
#include <tuple>

#include "iires/knn.hpp"
#include "iires/parallel.hpp"

namespace iires {
namespace {

/// Symmetric adjacency (CSR) of the k-NN graph: j ∈ adj(i) when j is among i's k nearest or vice versa.
struct Graph {
  std::vector<std::uint32_t> offsets, targets;
};

/// Point i's neighbours are nbr[i·stride, i·stride + k); entries equal to i (itself, or padding) are skipped.
Graph symmetricKnnGraph(const std::vector<std::uint32_t>& nbr, std::size_t n, std::size_t stride, std::size_t k) {
  std::vector<std::uint32_t> degree(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t a = 0; a < k; ++a) {
      const std::uint32_t j = nbr[i * stride + a];
      if (j == i) continue;
      ++degree[i];
      ++degree[j];
    }
  Graph g;
  g.offsets.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) g.offsets[i + 1] = g.offsets[i] + degree[i];
  g.targets.resize(g.offsets[n]);
  std::vector<std::uint32_t> fill(g.offsets.begin(), g.offsets.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t a = 0; a < k; ++a) {
      const std::uint32_t j = nbr[i * stride + a];
      if (j == i) continue;
      g.targets[fill[i]++] = j;
      g.targets[fill[j]++] = static_cast<std::uint32_t>(i);
    }
  return g;
}

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

/// Prim's minimum spanning tree on the weights 1 − |nᵢ·nⱼ|, flipping each normal to agree with its tree
/// parent. A point is pushed again only when its best known weight drops (lazy decrease-key).
void orientOverGraph(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                     const Graph& g) {
  const std::size_t n = points.size();
  std::vector<char> done(n, 0);
  std::vector<float> best(n, std::numeric_limits<float>::infinity());
  using Item = std::tuple<float, std::uint32_t, std::uint32_t>;  // weight, to, from
  std::vector<Item> storage;
  storage.reserve(n);
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap(std::greater<Item>(), std::move(storage));
  auto grow = [&](std::uint32_t root) {  // the tree of root's component
    if (normals[root].x() < 0) normals[root] = -normals[root];
    heap.emplace(0.0f, root, root);
    while (!heap.empty()) {
      const auto [w, v, from] = heap.top();
      heap.pop();
      if (done[v]) continue;
      done[v] = 1;
      if (v != from && normals[v].dot(normals[from]) < 0) normals[v] = -normals[v];
      for (std::uint32_t e = g.offsets[v]; e < g.offsets[v + 1]; ++e) {
        const std::uint32_t t = g.targets[e];
        if (done[t]) continue;
        const auto wt = static_cast<float>(1.0 - std::abs(normals[v].dot(normals[t])));
        if (wt < best[t]) {
          best[t] = wt;
          heap.emplace(wt, t, v);
        }
      }
    }
  };
  // Roots in decreasing x, so each component starts at its extreme point (normal made to face +x): the
  // largest x first; the points its tree leaves (other components) are sorted only when there are any.
  auto higher = [&](std::uint32_t a, std::uint32_t b) {
    return std::make_tuple(-points[a].x(), a) < std::make_tuple(-points[b].x(), b);
  };
  std::uint32_t first = 0;
  for (std::uint32_t i = 1; i < n; ++i)
    if (higher(i, first)) first = i;
  if (n > 0) grow(first);
  std::vector<std::uint32_t> rest;
  for (std::uint32_t i = 0; i < n; ++i)
    if (!done[i]) rest.push_back(i);
  std::sort(rest.begin(), rest.end(), higher);
  for (std::uint32_t root : rest)
    if (!done[root]) grow(root);
}

}  // namespace

std::vector<Eigen::Vector3d> estimateNormals(const std::vector<Eigen::Vector3d>& points,
                                             const NormalParams& params) {
  const std::size_t n = points.size(), stride = static_cast<std::size_t>(params.k) + 1;
  const auto lists = knnLists(points, static_cast<std::size_t>(params.k), params.threads);
  std::vector<Eigen::Vector3d> normals(n, Eigen::Vector3d::UnitZ());
  parallelFor(n, params.threads, [&](std::size_t i) {
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
  if (params.orient) orientOverGraph(points, normals, symmetricKnnGraph(lists, n, stride, stride));
  return normals;
}

void orientNormals(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals, int k) {
  const std::size_t stride = static_cast<std::size_t>(k) + 1;
  orientOverGraph(points, normals, symmetricKnnGraph(knnLists(points, stride - 1, 0), points.size(), stride, stride));
}

void orientNormals(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                   const std::vector<std::uint32_t>& neighbours, std::size_t stride, std::size_t k) {
  orientOverGraph(points, normals, symmetricKnnGraph(neighbours, points.size(), stride, std::min(k, stride)));
}

}  // namespace iires
