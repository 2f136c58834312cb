// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/distance_field.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "iires/detail/parallel.hpp"
#include "iires/knn.hpp"

namespace iires::reg {

void DistanceFieldParams::validate() const {
  if (cells < 2) throw std::invalid_argument("distance field: cells must be at least 2");
  if (!(margin >= 0.0) || !std::isfinite(margin))
    throw std::invalid_argument("distance field: margin must be finite and >= 0");
}

DistanceField::DistanceField(const std::vector<Eigen::Vector3d>& points, const DistanceFieldParams& params) {
  if (points.empty()) throw std::invalid_argument("distance field of an empty point set");
  build(points, KnnIndex(points), params);
}

DistanceField::DistanceField(const std::vector<Eigen::Vector3d>& points, const KnnIndex& index,
                             const DistanceFieldParams& params) {
  build(points, index, params);
}

void DistanceField::build(const std::vector<Eigen::Vector3d>& points, const KnnIndex& index,
                          const DistanceFieldParams& params) {
  params.validate();
  if (points.empty()) throw std::invalid_argument("distance field of an empty point set");
  if (index.size() != points.size()) throw std::invalid_argument("distance field: the index is not of these points");
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  lo.array() -= params.margin;
  hi.array() += params.margin;
  const double longest = (hi - lo).maxCoeff();
  if (!(longest > 0.0) || !std::isfinite(longest))
    throw std::invalid_argument(
        "distance field: the points must be finite and not all equal when margin is 0");
  cell_ = longest / static_cast<double>(params.cells);
  inverseCell_ = 1.0 / cell_;
  origin_ = lo;
  for (int a = 0; a < 3; ++a) {
    const auto cells = static_cast<std::size_t>(std::ceil((hi[a] - lo[a]) / cell_ - 1e-9));
    nodes_[a] = std::max<std::size_t>(1, cells) + 1;
    far_[a] = lo[a] + static_cast<double>(nodes_[a] - 1) * cell_;
  }
  const std::size_t nx = nodes_[0], ny = nodes_[1];
  values_.resize(nx * ny * nodes_[2]);
  parallelFor(values_.size(), params.threads, [&](std::size_t i) {
    const Eigen::Vector3d node =
        origin_ + cell_ * Eigen::Vector3d(static_cast<double>(i % nx), static_cast<double>((i / nx) % ny),
                                          static_cast<double>(i / (nx * ny)));
    double d2 = 0;
    index.nearest(node, &d2);
    values_[i] = static_cast<float>(std::sqrt(d2));
  });
}

double DistanceField::distance(const Eigen::Vector3d& query) const {
  // Outside the box: the distance to the box plus the field at the nearest point of the box (the exact
  // distance is at most that, by the triangle inequality).
  double outside2 = 0;
  std::size_t cell[3];
  double f[3];
  for (int a = 0; a < 3; ++a) {
    const double q = std::clamp(query[a], origin_[a], far_[a]);
    outside2 += (query[a] - q) * (query[a] - q);
    const double u = (q - origin_[a]) * inverseCell_;  // ≥ 0: truncation is the floor
    cell[a] = std::min(static_cast<std::size_t>(u), nodes_[a] - 2);
    f[a] = u - static_cast<double>(cell[a]);
  }
  const std::size_t sx = 1, sy = nodes_[0], sz = nodes_[0] * nodes_[1];
  const float* v = values_.data() + cell[0] * sx + cell[1] * sy + cell[2] * sz;
  // Trilinear interpolation: along x on the four edges, then y, then z.
  const double x00 = v[0] + f[0] * (v[sx] - v[0]);
  const double x10 = v[sy] + f[0] * (v[sy + sx] - v[sy]);
  const double x01 = v[sz] + f[0] * (v[sz + sx] - v[sz]);
  const double x11 = v[sz + sy] + f[0] * (v[sz + sy + sx] - v[sz + sy]);
  const double y0 = x00 + f[1] * (x10 - x00);
  const double y1 = x01 + f[1] * (x11 - x01);
  const double inside = y0 + f[2] * (y1 - y0);
  return outside2 > 0 ? inside + std::sqrt(outside2) : inside;
}

}  // namespace iires::reg
