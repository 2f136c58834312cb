#include "iires/normals.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstdint>
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

Graph symmetricKnnGraph(const std::vector<std::vector<std::uint32_t>>& knn) {
  const std::size_t n = knn.size();
  std::vector<std::uint32_t> degree(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t j : knn[i]) {
      ++degree[i];
      ++degree[j];
    }
  Graph g;
  g.offsets.assign(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) g.offsets[i + 1] = g.offsets[i] + degree[i];
  g.targets.resize(g.offsets[n]);
  std::vector<std::uint32_t> fill(g.offsets.begin(), g.offsets.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t j : knn[i]) {
      g.targets[fill[i]++] = j;
      g.targets[fill[j]++] = static_cast<std::uint32_t>(i);
    }
  return g;
}

std::vector<std::vector<std::uint32_t>> knnLists(const std::vector<Eigen::Vector3d>& points, int k,
                                                 int threads) {
  KnnIndex index(points);
  std::vector<std::vector<std::uint32_t>> lists(points.size());
  parallelFor(points.size(), threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.knn(points[i], static_cast<std::size_t>(k) + 1, idx, d2);
    idx.erase(std::remove(idx.begin(), idx.end(), static_cast<std::uint32_t>(i)), idx.end());
    lists[i] = std::move(idx);
  });
  return lists;
}

void orientOverGraph(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals,
                     const Graph& g) {
  const std::size_t n = points.size();
  std::vector<char> done(n, 0);
  // Roots: points in decreasing x, so each component starts at its extreme point (normal made to face +x).
  std::vector<std::uint32_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = static_cast<std::uint32_t>(i);
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
    return std::make_tuple(-points[a].x(), a) < std::make_tuple(-points[b].x(), b);
  });
  using Item = std::tuple<double, std::uint32_t, std::uint32_t>;  // weight, to, from
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> heap;
  for (std::uint32_t root : order) {
    if (done[root]) continue;
    if (normals[root].x() < 0) normals[root] = -normals[root];
    heap.emplace(0.0, root, root);
    while (!heap.empty()) {
      auto [w, v, from] = heap.top();
      heap.pop();
      if (done[v]) continue;
      done[v] = 1;
      if (v != from && normals[v].dot(normals[from]) < 0) normals[v] = -normals[v];
      for (std::uint32_t e = g.offsets[v]; e < g.offsets[v + 1]; ++e) {
        const std::uint32_t t = g.targets[e];
        if (!done[t]) heap.emplace(1.0 - std::abs(normals[v].dot(normals[t])), t, v);
      }
    }
  }
}

}  // namespace

std::vector<Eigen::Vector3d> estimateNormals(const std::vector<Eigen::Vector3d>& points,
                                             const NormalParams& params) {
  const auto lists = knnLists(points, params.k, params.threads);
  std::vector<Eigen::Vector3d> normals(points.size(), Eigen::Vector3d::UnitZ());
  parallelFor(points.size(), params.threads, [&](std::size_t i) {
    const auto& nb = lists[i];
    if (nb.size() < 2) return;
    Eigen::Vector3d mean = points[i];
    for (std::uint32_t j : nb) mean += points[j];
    mean /= static_cast<double>(nb.size() + 1);
    Eigen::Matrix3d cov = (points[i] - mean) * (points[i] - mean).transpose();
    for (std::uint32_t j : nb) cov += (points[j] - mean) * (points[j] - mean).transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    normals[i] = eig.eigenvectors().col(0).normalized();
  });
  if (params.orient) orientOverGraph(points, normals, symmetricKnnGraph(lists));
  return normals;
}

void orientNormals(const std::vector<Eigen::Vector3d>& points, std::vector<Eigen::Vector3d>& normals, int k) {
  orientOverGraph(points, normals, symmetricKnnGraph(knnLists(points, k, 0)));
}

}  // namespace iires
