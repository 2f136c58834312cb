// SPDX-License-Identifier: GPL-3.0-or-later
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "iires/detail/parallel.hpp"
#include "iires/knn.hpp"
#include "iires/normals.hpp"

namespace iires {
namespace {

constexpr std::size_t kWidthRank = 8;  // h as the MLS kernel's: the distance to the 8th neighbour

/// Point i's row of the table with its kernel width and plane tolerance (as reciprocals).
struct Row {
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  std::size_t found = 0;
  double invH2 = 0, invTol = 0;
};

/// Support of the plane through p_i with normal @p c: Σ θ(dⱼ) exp(−(rⱼ/τ)²) over the row, rⱼ = c·(pⱼ − pᵢ).
/// @p weights (optional) receives the terms.
double support(const std::vector<Eigen::Vector3d>& points, std::size_t i, const Row& row, const Eigen::Vector3d& c,
               std::vector<double>* weights = nullptr) {
  double sum = 0;
  for (std::size_t a = 0; a < row.found; ++a) {
    const double r = c.dot(points[row.idx[a]] - points[i]) * row.invTol;
    const double w = std::exp(-row.d2[a] * row.invH2 - r * r);
    if (weights) (*weights)[a] = w;
    sum += w;
  }
  return sum;
}

/// Point i's face normal from the normals @p in of the previous pass (see faceNormals); @p in[i] when its own
/// plane is as good as any neighbour's.
Eigen::Vector3d faceNormal(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& in,
                           const NeighbourTable& table, const FaceNormalParams& params, std::size_t i) {
  thread_local Row row;
  thread_local std::vector<double> w;
  row.found = table.get(i, table.k(), row.idx, row.d2);
  if (row.found <= kWidthRank || !(row.d2[kWidthRank] > 0)) return in[i];
  const double h2 = row.d2[kWidthRank];
  row.invH2 = 1.0 / h2;
  row.invTol = 1.0 / (params.tolerance * std::sqrt(h2));
  // The neighbours' normals are the candidate planes through p_i: near a crease those of the face's own points
  // are the face's, a blend of both faces is not.
  const double own = support(points, i, row, in[i]);
  double best = own;
  Eigen::Vector3d chosen = in[i];
  for (std::size_t a = 0; a < row.found; ++a)
    if (const double s = support(points, i, row, in[row.idx[a]]); s > best) best = s, chosen = in[row.idx[a]];
  if (!(best > params.margin * own)) return in[i];
  // The chosen plane refitted: weighted PCA over the neighbours it supports.
  w.resize(row.found);
  const double total = support(points, i, row, chosen, &w);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t a = 0; a < row.found; ++a) mean += w[a] * points[row.idx[a]];
  mean /= total;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t a = 0; a < row.found; ++a) {
    const Eigen::Vector3d d = points[row.idx[a]] - mean;
    cov += w[a] * d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d n = eig.eigenvectors().col(0);
  if (!n.allFinite() || std::abs(n.dot(chosen)) < std::cos(params.maxRefit * M_PI / 180.0)) n = chosen;
  return n.dot(in[i]) < 0 ? -n : n;
}

}  // namespace

std::vector<Eigen::Vector3d> faceNormals(const std::vector<Eigen::Vector3d>& points,
                                         const std::vector<Eigen::Vector3d>& normals, const NeighbourTable& table,
                                         const FaceNormalParams& params, int threads) {
  std::vector<Eigen::Vector3d> out = normals;
  if (table.size() != points.size() || normals.size() != points.size()) return out;
  std::vector<Eigen::Vector3d> in;
  for (int pass = 0; pass < params.passes; ++pass) {  // Jacobi: each pass reads the previous one's normals
    in = out;
    parallelFor(points.size(), threads, [&](std::size_t i) { out[i] = faceNormal(points, in, table, params, i); });
  }
  return out;
}

}  // namespace iires
