// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The closest point of a segment to a point, and the distance from a point to a triangle. Internal to libreconstruct.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>

namespace iires::detail {

/// The point of segment [a, b] closest to @p p.
inline Eigen::Vector3d closestPointOnSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                             const Eigen::Vector3d& b) {
  const Eigen::Vector3d d = b - a;
  const double t = d.squaredNorm() > 0 ? std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
  return a + t * d;
}

/// Distance from @p p to triangle (a, b, c).
inline double pointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                    const Eigen::Vector3d& c) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  if (n.squaredNorm() > 0) {
    const Eigen::Vector3d q = p - n * (p - a).dot(n) / n.squaredNorm();  // projection onto the plane
    if ((b - a).cross(q - a).dot(n) >= 0 && (c - b).cross(q - b).dot(n) >= 0 && (a - c).cross(q - c).dot(n) >= 0)
      return (p - q).norm();
  }
  return std::min({(p - closestPointOnSegment(p, a, b)).norm(), (p - closestPointOnSegment(p, b, c)).norm(),
                   (p - closestPointOnSegment(p, c, a)).norm()});
}

}  // namespace iires::detail
