// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/curvature.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"

namespace iires {
namespace {

/// k nearest neighbours of every point (itself excluded), flat array of n·k entries (padded by repeating
/// the last neighbour when a point has fewer), plus the mean neighbour distance per point.
struct KnnTable {
  std::size_t k = 0;
  std::vector<std::uint32_t> nbr;
  std::vector<double> meanDist;
};

KnnTable buildKnn(const std::vector<Eigen::Vector3d>& points, int k, int threads) {
  KnnTable t;
  const std::size_t n = points.size();
  t.k = std::min<std::size_t>(static_cast<std::size_t>(k), n > 0 ? n - 1 : 0);
  t.nbr.assign(n * t.k, 0);
  t.meanDist.assign(n, 0.0);
  if (t.k == 0) return t;
  KnnIndex index(points);
  parallelFor(n, threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.knn(points[i], t.k + 1, idx, d2);
    std::size_t m = 0;
    double sum = 0;
    for (std::size_t j = 0; j < idx.size() && m < t.k; ++j) {
      if (idx[j] == i) continue;
      t.nbr[i * t.k + m++] = idx[j];
      sum += std::sqrt(d2[j]);
    }
    // Duplicate-free clouds always give k; with i not first (exact duplicates) we may have one too few.
    for (std::size_t j = m; j < t.k; ++j) t.nbr[i * t.k + j] = m > 0 ? t.nbr[i * t.k + m - 1] : idx[0];
    t.meanDist[i] = m > 0 ? sum / static_cast<double>(m) : 0.0;
  });
  return t;
}

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  // atan2 of |a×b| and a·b: accurate for small angles, where acos(dot) loses half the digits.
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

std::vector<double> fieldFromTable(const std::vector<Eigen::Vector3d>& normals, const KnnTable& t,
                                   int threads) {
  std::vector<double> eta(normals.size(), 0.0);
  if (t.k == 0) return eta;
  parallelFor(normals.size(), threads, [&](std::size_t i) {
    double sum = 0;
    for (std::size_t j = 0; j < t.k; ++j) sum += angleBetween(normals[i], normals[t.nbr[i * t.k + j]]);
    eta[i] = sum / static_cast<double>(t.k);  // eq. (9)
  });
  return eta;
}

std::vector<double> smoothFromTable(std::vector<double> f, const KnnTable& t, double beta, int iterations,
                                    int threads) {
  if (t.k == 0 || iterations <= 0 || beta == 0.0) return f;
  std::vector<double> next(f.size());
  for (int it = 0; it < iterations; ++it) {
    parallelFor(f.size(), threads, [&](std::size_t i) {
      double sum = 0;
      for (std::size_t j = 0; j < t.k; ++j) sum += f[t.nbr[i * t.k + j]];
      next[i] = (1.0 - beta) * f[i] + beta * sum / static_cast<double>(t.k);  // eq. (8)
    });
    f.swap(next);
  }
  return f;
}

/// Eq. 9's angle is taken over the k nearest neighbours, whose radius follows the sampling density: where the
/// input is five times sparser the same bend reads five times the angle, and the sparse part would take the
/// curved levels' small spacing. Each angle is scaled to the cloud's median neighbourhood radius (the angle
/// per length, in the radians a median neighbourhood would see), so the levels follow the surface's
/// curvature, not its sampling.
void perUnitLength(std::vector<double>& eta, const KnnTable& t) {
  if (t.k == 0 || eta.empty()) return;
  std::vector<double> radius(t.meanDist);
  std::nth_element(radius.begin(), radius.begin() + static_cast<std::ptrdiff_t>(radius.size() / 2), radius.end());
  const double median = radius[radius.size() / 2];
  for (std::size_t i = 0; i < eta.size(); ++i)
    if (t.meanDist[i] > 0) eta[i] *= median / t.meanDist[i];
}

double quantileOfSorted(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0.0;
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(pos));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  const double w = pos - static_cast<double>(lo);
  return (1.0 - w) * sorted[lo] + w * sorted[hi];
}

void checkInput(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals) {
  if (normals.size() != points.size())
    throw std::invalid_argument("curvature: " + std::to_string(normals.size()) + " normals for " +
                                std::to_string(points.size()) + " points");
}

}  // namespace

void CurvatureParams::validate() const {
  if (k < 3) throw std::invalid_argument("CurvatureParams: k must be >= 3, got " + std::to_string(k));
  if (!(beta >= 0.0 && beta <= 1.0))
    throw std::invalid_argument("CurvatureParams: beta must be in [0, 1], got " + std::to_string(beta));
  if (smoothIterations < 0) throw std::invalid_argument("CurvatureParams: smoothIterations must be >= 0");
  if (sizeSmoothIterations < 0) throw std::invalid_argument("CurvatureParams: sizeSmoothIterations must be >= 0");
  if (ratios.empty()) throw std::invalid_argument("CurvatureParams: ratios must not be empty (t >= 1)");
  for (std::size_t i = 0; i < ratios.size(); ++i) {
    if (!(ratios[i] > 0.0) || !std::isfinite(ratios[i]))
      throw std::invalid_argument("CurvatureParams: ratios must be positive and finite");
    if (i > 0 && ratios[i] > ratios[i - 1])
      throw std::invalid_argument("CurvatureParams: ratios must be non-increasing from flat to curved");
  }
  if (ratios.front() > 100 * ratios.back())
    throw std::invalid_argument("CurvatureParams: ratios may span at most 100x (largest / smallest)");
  if (!(uniformSpread >= 0.0)) throw std::invalid_argument("CurvatureParams: uniformSpread must be >= 0");
  if (!(minCurvature >= 0.0)) throw std::invalid_argument("CurvatureParams: minCurvature must be >= 0");
}

std::vector<double> curvatureField(const std::vector<Eigen::Vector3d>& points,
                                   const std::vector<Eigen::Vector3d>& normals, int k, int threads) {
  checkInput(points, normals);
  if (k < 1) throw std::invalid_argument("curvatureField: k must be >= 1");
  return fieldFromTable(normals, buildKnn(points, k, threads), threads);
}

std::vector<double> smoothField(const std::vector<Eigen::Vector3d>& points, std::vector<double> field, int k,
                                double beta, int iterations, int threads) {
  if (field.size() != points.size()) throw std::invalid_argument("smoothField: field size != point count");
  if (k < 1) throw std::invalid_argument("smoothField: k must be >= 1");
  return smoothFromTable(std::move(field), buildKnn(points, k, threads), beta, iterations, threads);
}

std::vector<int> quantileLevels(const std::vector<double>& values, int levels, std::vector<double>* thresholds) {
  if (levels < 1) throw std::invalid_argument("quantileLevels: levels must be >= 1");
  std::vector<double> sorted(values);
  std::sort(sorted.begin(), sorted.end());
  const std::size_t n = sorted.size();
  std::vector<double> th;
  if (n > 0)
    for (int j = 1; j < levels; ++j)
      th.push_back(sorted[std::min(n - 1, static_cast<std::size_t>(j) * n / static_cast<std::size_t>(levels))]);
  std::vector<int> level(n);
  // level = number of thresholds strictly below the value: ties with a threshold go to the lower level, so a
  // field that is mostly one value (exactly flat regions) puts all of them in the flattest level.
  for (std::size_t i = 0; i < n; ++i)
    level[i] = static_cast<int>(std::lower_bound(th.begin(), th.end(), values[i]) - th.begin());
  if (thresholds) *thresholds = th;
  return level;
}

CurvatureResult computeCurvature(const std::vector<Eigen::Vector3d>& points,
                                 const std::vector<Eigen::Vector3d>& normals, const CurvatureParams& params,
                                 const Execution& exec) {
  params.validate();
  checkInput(points, normals);
  const auto start = std::chrono::steady_clock::now();
  const int t = static_cast<int>(params.ratios.size());
  const std::size_t n = points.size();

  CurvatureResult r;
  const KnnTable table = buildKnn(points, params.k, exec.threads);
  r.eta = fieldFromTable(normals, table, exec.threads);  // eq. (9)
  perUnitLength(r.eta, table);
  r.smoothedEta = smoothFromTable(r.eta, table, params.beta, params.smoothIterations, exec.threads);  // (8)

  // Quantisation (eq. 10's groups): equal-count quantiles, unless the field is uniform.
  std::vector<double> sorted(r.smoothedEta);
  std::sort(sorted.begin(), sorted.end());
  const double p5 = quantileOfSorted(sorted, 0.05), p95 = quantileOfSorted(sorted, 0.95);
  r.uniform = n == 0 || p95 < params.minCurvature || (p95 - p5) < params.uniformSpread * p95;
  if (r.uniform) {
    int neutral = 0;
    for (int q = 1; q < t; ++q)
      if (std::abs(std::log(params.ratios[q])) < std::abs(std::log(params.ratios[neutral]))) neutral = q;
    r.level.assign(n, neutral);
  } else {
    r.level = quantileLevels(r.smoothedEta, t, &r.thresholds);
  }

  r.pointsPerLevel.assign(t, 0);
  r.meanEtaPerLevel.assign(t, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    ++r.pointsPerLevel[r.level[i]];
    r.meanEtaPerLevel[r.level[i]] += r.smoothedEta[i];
  }
  for (int q = 0; q < t; ++q)
    if (r.pointsPerLevel[q] > 0) r.meanEtaPerLevel[q] /= static_cast<double>(r.pointsPerLevel[q]);

  // Size factors r_q (eq. 10). Normalisation: each input point stands for an area ∝ (mean k-NN distance)²;
  // a sample of size s covers ∝ s²·l², so the expected sample count is ∝ Σ w_i / s_i². Choose c with
  // Σ w_i / (c r_i)² = Σ w_i (the isotropic count), summed in index order (deterministic).
  r.sizeFactor.resize(n);
  for (std::size_t i = 0; i < n; ++i) r.sizeFactor[i] = params.ratios[r.level[i]];
  if (params.sizeSmoothIterations > 0 && !r.uniform) {
    // Level borders: smooth log s by eq. 8 so the target length changes by a steady factor across a few
    // samples instead of jumping by r_q/r_{q+1} at once (the paper's smooth gradation).
    for (double& s : r.sizeFactor) s = std::log(s);
    r.sizeFactor = smoothFromTable(r.sizeFactor, table, params.beta, params.sizeSmoothIterations, exec.threads);
    for (double& s : r.sizeFactor) s = std::exp(s);
  }
  if (params.normalize && n > 0) {
    double sw = 0, swInv = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double w = table.k > 0 ? table.meanDist[i] * table.meanDist[i] : 1.0;
      sw += w;
      swInv += w / (r.sizeFactor[i] * r.sizeFactor[i]);
    }
    if (sw > 0 && swInv > 0) r.normalization = std::sqrt(swInv / sw);
    for (double& s : r.sizeFactor) s *= r.normalization;
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace iires
