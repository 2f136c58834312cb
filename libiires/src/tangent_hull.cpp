// SPDX-License-Identifier: GPL-3.0-or-later
#include "tangent_hull.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

namespace iires::detail {
namespace {

/// Distance from the origin to the segment [p, r].
double segmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& r) {
  const Eigen::Vector2d e = r - p;
  const double ee = e.squaredNorm();
  const double t = ee > 0 ? std::clamp(-p.dot(e) / ee, 0.0, 1.0) : 0.0;
  return (p + t * e).norm();
}

}  // namespace

// Neighbours in all four open quadrants around x prove it inside (every line through x leaves a whole quadrant
// on one side), which ends the scan early in a cloud's interior; only the rest (near an open boundary) build
// the hull.
double beyondHull(const std::vector<Eigen::Vector3d>& points, const std::uint32_t* idx, std::size_t count,
                  const double* w, const Eigen::Vector3d& x, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d u = normal.unitOrthogonal(), t = normal.cross(u);
  thread_local std::vector<Eigen::Vector2d> q;
  q.clear();
  unsigned quadrants = 0;
  for (std::size_t j = 0; j < count; ++j)
    if (!w || w[j] != 0.0) {
      const Eigen::Vector3d d = points[idx[j]] - x;
      const double a = d.dot(u), b = d.dot(t);
      quadrants |= (a > 0 ? 1u : a < 0 ? 2u : 0u) << (b > 0 ? 0 : b < 0 ? 2 : 4);
      if ((quadrants & 15u) == 15u) return 0.0;
      q.emplace_back(a, b);
    }
  if (q.size() < 3) return q.empty() ? 0.0 : q.size() == 1 ? q[0].norm() : segmentDistance(q[0], q[1]);
  // The hull (Andrew's monotone chain, counter-clockwise), then x's distance to it: 0 inside, else to the
  // nearest hull edge.
  std::sort(q.begin(), q.end(), [](const Eigen::Vector2d& p, const Eigen::Vector2d& r) {
    return p.x() < r.x() || (p.x() == r.x() && p.y() < r.y());
  });
  thread_local std::vector<Eigen::Vector2d> hull;
  hull.assign(2 * q.size(), Eigen::Vector2d::Zero());
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& p, const Eigen::Vector2d& r) {
    return (p - o).x() * (r - o).y() - (p - o).y() * (r - o).x();
  };
  std::size_t m = 0;
  for (std::size_t j = 0; j < q.size(); ++j) {
    while (m >= 2 && cross(hull[m - 2], hull[m - 1], q[j]) <= 0) --m;
    hull[m++] = q[j];
  }
  for (std::size_t j = q.size() - 1, lowerEnd = m + 1; j-- > 0;) {
    while (m >= lowerEnd && cross(hull[m - 2], hull[m - 1], q[j]) <= 0) --m;
    hull[m++] = q[j];
  }
  --m;  // the last point is the first
  if (m < 3) return segmentDistance(hull[0], hull[m > 1 ? 1 : 0]);
  const Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  bool inside = true;
  double nearest = std::numeric_limits<double>::max();
  for (std::size_t e = 0; e < m; ++e) {
    const Eigen::Vector2d& p = hull[e];
    const Eigen::Vector2d& r = hull[e + 1 == m ? 0 : e + 1];
    if (cross(p, r, origin) < 0) inside = false;
    nearest = std::min(nearest, segmentDistance(p, r));
  }
  return inside ? 0.0 : nearest;
}

}  // namespace iires::detail
