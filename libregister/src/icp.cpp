// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/icp.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <tuple>
#include <utility>

#include "iires/detail/parallel.hpp"
#include "iires/register/hausdorff.hpp"
#include "iires/register/rotation_grid.hpp"

namespace iires::reg {

void IcpParams::validate() const {
  if (maxIterations < 1) throw std::invalid_argument("ICP: maxIterations must be at least 1");
  if (!(overlap > 0.0 && overlap <= 1.0)) throw std::invalid_argument("ICP: overlap must be in (0, 1]");
  if (!(reverseOverlap >= 0.0 && reverseOverlap <= 1.0))
    throw std::invalid_argument("ICP: reverseOverlap must be 0 or in (0, 1]");
  if (!(tolerance > 0.0)) throw std::invalid_argument("ICP: tolerance must be positive");
  if (!(minOverlap > 0.0 && minOverlap <= 1.0)) throw std::invalid_argument("ICP: minOverlap must be in (0, 1]");
  if (!(overlapExponent >= 0.0)) throw std::invalid_argument("ICP: overlapExponent must be >= 0");
}

FractionalFit fractionalRmsd(const std::vector<double>& sortedD2, double minOverlap, double exponent,
                             double floor) {
  if (sortedD2.empty()) throw std::invalid_argument("fractionalRmsd: no residuals");
  if (!(minOverlap > 0.0 && minOverlap <= 1.0))
    throw std::invalid_argument("fractionalRmsd: minOverlap must be in (0, 1]");
  if (!(exponent >= 0.0)) throw std::invalid_argument("fractionalRmsd: exponent must be >= 0");
  const std::size_t n = sortedD2.size();
  const std::size_t first = n - allowedOutliers(n, minOverlap);
  FractionalFit best;
  best.score = std::numeric_limits<double>::infinity();
  double sum = 0;
  for (std::size_t k = 1; k <= n; ++k) {
    sum += sortedD2[k - 1];
    if (k < first) continue;
    const double rms = std::sqrt(sum / static_cast<double>(k));
    const double score = std::max(rms, floor) * std::pow(static_cast<double>(n) / static_cast<double>(k), exponent);
    if (score <= best.score) best = {score, rms, k};  // ties: the larger overlap
  }
  return best;
}

namespace {

/// Residual RMS below this share of the source's radius is rounding noise (see fractionalRmsd's floor).
constexpr double kRoundingFloor = 1e-12;

double scaleOf(const Eigen::Matrix4d& t) { return t.topLeftCorner<3, 3>().col(0).norm(); }

/// Order the pair indices so that the pairs to use come first, and return how many: the ⌈overlap·n⌉ nearest
/// (fixed overlap), or the k nearest minimising the fractional RMSD (estimated). Ties broken by index, so
/// the choice is deterministic.
std::size_t selectNearest(const std::vector<double>& d2, std::vector<std::size_t>& order, const IcpParams& p,
                          double overlap, double floor) {
  const std::size_t n = d2.size();
  order.resize(n);
  if (p.estimateOverlap) {
    // (distance, index) pairs sort faster than indices compared through d2, in the same order
    thread_local std::vector<std::pair<double, std::size_t>> byDistance;
    byDistance.resize(n);
    for (std::size_t i = 0; i < n; ++i) byDistance[i] = {d2[i], i};
    std::sort(byDistance.begin(), byDistance.end());
    std::vector<double> sorted(n);
    for (std::size_t i = 0; i < n; ++i) std::tie(sorted[i], order[i]) = byDistance[i];
    const std::size_t keep = fractionalRmsd(sorted, p.minOverlap, p.overlapExponent, floor).keep;
    std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep));
    return keep;
  }
  std::iota(order.begin(), order.end(), std::size_t{0});
  auto closer = [&](std::size_t x, std::size_t y) { return d2[x] < d2[y] || (d2[x] == d2[y] && x < y); };
  const std::size_t keep = n - allowedOutliers(n, overlap);
  if (keep < n) {
    std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep - 1), order.end(), closer);
    std::sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep));
  }
  return keep;
}

}  // namespace

Eigen::Matrix4d umeyamaTransform(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                                 bool withScale) {
  if (a.size() != b.size()) throw std::invalid_argument("umeyamaTransform: point sets of different sizes");
  if (a.size() < 3) throw std::invalid_argument("umeyamaTransform: needs at least 3 pairs");
  Eigen::Matrix3Xd ma(3, a.size()), mb(3, b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    ma.col(static_cast<Eigen::Index>(i)) = a[i];
    mb.col(static_cast<Eigen::Index>(i)) = b[i];
  }
  return Eigen::umeyama(ma, mb, withScale);
}

IcpResult similarityIcp(const std::vector<Eigen::Vector3d>& source, const std::vector<Eigen::Vector3d>& target,
                        const KnnIndex& targetIndex, const Eigen::Matrix4d& init, const IcpParams& params,
                        const Execution& exec, const KnnIndex* sourceIndex, const IcpRims& rims) {
  params.validate();
  if (source.size() < 3 || target.size() < 3) throw std::invalid_argument("ICP needs at least 3 points per cloud");
  const std::size_t n = source.size();
  std::size_t keep = n;
  IcpResult result;
  Eigen::Matrix4d T = init;
  std::vector<std::int64_t> match(n);
  std::vector<double> d2(n);
  std::vector<std::size_t> order(n);
  std::vector<Eigen::Vector3d> a, b;
  // RMS radius of the source about its centroid: translation changes are measured relative to it.
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : source) centroid += p;
  centroid /= static_cast<double>(n);
  double radius = 0;
  for (const auto& p : source) radius += (p - centroid).squaredNorm();
  radius = std::sqrt(radius / static_cast<double>(n));
  auto matchAll = [&](const Eigen::Matrix4d& t) {
    const Eigen::Matrix3d m = t.topLeftCorner<3, 3>();
    const Eigen::Vector3d tr = t.topRightCorner<3, 1>();
    parallelFor(n, exec.threads, [&](std::size_t i) { match[i] = targetIndex.nearest(m * source[i] + tr, &d2[i]); });
    keep = selectNearest(d2, order, params, params.overlap, kRoundingFloor * radius * scaleOf(t));
  };
  // Reverse matches (target → source), for bidirectional mode: the target moved by T⁻¹ against a tree on
  // the source; distances are compared in target units (× scale).
  std::unique_ptr<KnnIndex> ownSourceTree;
  if (sourceIndex && sourceIndex->size() != source.size())
    throw std::invalid_argument("ICP: the source index is not of the source");
  const std::size_t m = target.size();
  if ((rims.source && rims.source->size() != source.size()) || (rims.target && rims.target->size() != m))
    throw std::invalid_argument("ICP: rim flags of another cloud");
  std::size_t keepReverse = m;
  std::vector<std::int64_t> rmatch(params.bidirectional ? m : 0);
  std::vector<double> rd2(rmatch.size());
  std::vector<std::size_t> rorder(rmatch.size());
  if (params.bidirectional && !sourceIndex) sourceIndex = (ownSourceTree = std::make_unique<KnnIndex>(source)).get();
  auto matchReverse = [&](const Eigen::Matrix4d& t) {
    const Eigen::Matrix4d inv = t.inverse();
    const Eigen::Matrix3d mi = inv.topLeftCorner<3, 3>();
    const Eigen::Vector3d ti = inv.topRightCorner<3, 1>();
    parallelFor(m, exec.threads, [&](std::size_t i) { rmatch[i] = sourceIndex->nearest(mi * target[i] + ti, &rd2[i]); });
    const double reverseOverlap = params.reverseOverlap > 0.0 ? params.reverseOverlap : params.overlap;
    keepReverse = selectNearest(rd2, rorder, params, reverseOverlap, kRoundingFloor * radius);  // source units
  };
  for (int it = 0; it < params.maxIterations; ++it) {
    matchAll(T);
    if (params.bidirectional) matchReverse(T);
    // The kept pairs, those matched to a rim point left out (all of them when that leaves fewer than 3).
    for (const bool boundaryRule : {true, false}) {
      a.clear();
      b.clear();
      for (std::size_t j = 0; j < keep; ++j) {
        const auto t = static_cast<std::size_t>(match[order[j]]);
        if (boundaryRule && rims.target && (*rims.target)[t]) continue;
        a.push_back(source[order[j]]);
        b.push_back(target[t]);
      }
      for (std::size_t j = 0; params.bidirectional && j < keepReverse; ++j) {
        const auto s = static_cast<std::size_t>(rmatch[rorder[j]]);
        if (boundaryRule && rims.source && (*rims.source)[s]) continue;
        a.push_back(source[s]);
        b.push_back(target[rorder[j]]);
      }
      if (a.size() >= 3) break;
    }
    const Eigen::Matrix4d next = umeyamaTransform(a, b, params.estimateScale);
    result.iterations = it + 1;
    // Convergence: the change between consecutive estimates.
    const Eigen::Matrix4d delta = next * T.inverse();
    const double s = delta.topLeftCorner<3, 3>().col(0).norm();
    const Eigen::Matrix3d rot = delta.topLeftCorner<3, 3>() / s;
    const double scaleOfT = T.topLeftCorner<3, 3>().col(0).norm();
    const double tChange = (next.topRightCorner<3, 1>() - T.topRightCorner<3, 1>()).norm() /
                           std::max(1e-300, scaleOfT * radius);
    T = next;
    if (rotationAngle(rot) < params.tolerance && std::abs(s - 1.0) < params.tolerance &&
        tChange < params.tolerance) {
      result.converged = true;
      break;
    }
  }
  matchAll(T);
  double sum = 0;
  for (std::size_t j = 0; j < keep; ++j) sum += d2[order[j]];
  result.T_target_source = T;
  result.scale = T.topLeftCorner<3, 3>().col(0).norm();
  result.rmse = std::sqrt(sum / static_cast<double>(keep));
  result.matched = keep;
  result.overlap = static_cast<double>(keep) / static_cast<double>(n);
  if (params.bidirectional) {
    matchReverse(T);
    result.reverseOverlap = static_cast<double>(keepReverse) / static_cast<double>(m);
  }
  return result;
}

}  // namespace iires::reg
