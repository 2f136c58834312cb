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

}  // namespace iires::reg
