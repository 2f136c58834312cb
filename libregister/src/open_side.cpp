// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/open_side.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "iires/detail/parallel.hpp"
#include "iires/knn.hpp"

namespace iires::reg {

namespace {

/// Whether point i's neighbours leave an angular gap wider than @p minGap (radians) around it in their plane.
bool onRim(const std::vector<Eigen::Vector3d>& points, std::size_t i, const std::vector<std::uint32_t>& idx,
           double minGap) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::uint32_t j : idx) mean += points[j];
  mean /= static_cast<double>(idx.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::uint32_t j : idx) cov += (points[j] - mean) * (points[j] - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Eigen::Vector3d u = eig.eigenvectors().col(2), v = eig.eigenvectors().col(1);  // the plane's axes
  std::vector<double> angles;
  for (std::uint32_t j : idx) {
    const Eigen::Vector3d d = points[j] - points[i];
    if (j != i && d.squaredNorm() > 0) angles.push_back(std::atan2(d.dot(v), d.dot(u)));
  }
  if (angles.size() < 2) return true;
  std::sort(angles.begin(), angles.end());
  double gap = 2.0 * M_PI - (angles.back() - angles.front());
  for (std::size_t k = 1; k < angles.size(); ++k) gap = std::max(gap, angles[k] - angles[k - 1]);
  return gap > minGap;
}

}  // namespace

void OpenSideParams::validate() const {
  if (neighbours < 4) throw std::invalid_argument("open side: neighbours must be at least 4");
  if (!(minGapDeg > 0.0 && minGapDeg < 360.0))
    throw std::invalid_argument("open side: minGapDeg must lie in (0, 360)");
}

OpenSide openSide(const std::vector<Eigen::Vector3d>& points, const OpenSideParams& params, int threads) {
  return openSide(points, KnnIndex(points), params, threads);
}

OpenSide openSide(const std::vector<Eigen::Vector3d>& points, const KnnIndex& index, const OpenSideParams& params,
                  int threads) {
  params.validate();
  if (index.size() != points.size()) throw std::invalid_argument("open side: the index is not of these points");
  OpenSide out;
  if (points.size() < params.neighbours) return out;
  std::vector<std::uint8_t>& rim = out.rim;
  rim.assign(points.size(), 0);
  const double minGap = params.minGapDeg * M_PI / 180.0;
  parallelFor(points.size(), threads, [&](std::size_t i) {
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    index.knn(points[i], params.neighbours, idx, d2);
    rim[i] = onRim(points, i, idx, minGap);
  });
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero(), rimCentroid = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {  // in index order: the same sums for any thread count
    centroid += points[i];
    if (rim[i]) {
      rimCentroid += points[i];
      ++out.rimPoints;
    }
  }
  if (out.rimPoints == 0) return out;
  const Eigen::Vector3d d =
      rimCentroid / static_cast<double>(out.rimPoints) - centroid / static_cast<double>(points.size());
  if (d.squaredNorm() > 0) out.direction = d.normalized();
  return out;
}

}  // namespace iires::reg
