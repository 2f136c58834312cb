// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/detail/tangent_cell.hpp"

#include <algorithm>
#include <cmath>

namespace iires {

void clipByBisector(std::vector<Eigen::Vector2d>& v, std::vector<std::uint32_t>& lab, const Eigen::Vector2d& q,
                    double t, std::uint32_t label, std::vector<Eigen::Vector2d>& outV,
                    std::vector<std::uint32_t>& outL) {
  const double c = t * q.squaredNorm();
  const std::size_t m = v.size();
  if (std::none_of(v.begin(), v.end(), [&](const Eigen::Vector2d& a) { return a.dot(q) > c; })) return;
  outV.clear();
  outL.clear();
  for (std::size_t e = 0; e < m; ++e) {
    const Eigen::Vector2d& a = v[e];
    const Eigen::Vector2d& b = v[e + 1 < m ? e + 1 : 0];
    const double sa = a.dot(q) - c, sb = b.dot(q) - c;
    if (sa <= 0) {
      outV.push_back(a);
      outL.push_back(lab[e]);
      if (sb > 0) {
        outV.push_back(a + (b - a) * (sa / (sa - sb)));
        outL.push_back(label);
      }
    } else if (sb <= 0) {
      outV.push_back(a + (b - a) * (sa / (sa - sb)));
      outL.push_back(lab[e]);
    }
  }
  v.swap(outV);
  lab.swap(outL);
}

Eigen::Vector2d polygonCentroid(const std::vector<Eigen::Vector2d>& v) {
  double area = 0;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  for (std::size_t e = 0; e < v.size(); ++e) {
    const Eigen::Vector2d& a = v[e];
    const Eigen::Vector2d& b = v[(e + 1) % v.size()];
    const double cross = a.x() * b.y() - a.y() * b.x();
    area += cross;
    c += cross * (a + b);
  }
  return std::abs(area) < 1e-300 ? Eigen::Vector2d::Zero() : Eigen::Vector2d(c / (3.0 * area));
}

double pseudoAngle(const Eigen::Vector2d& d) {
  const double s = std::abs(d.x()) + std::abs(d.y());
  const double t = d.y() / s;  // in [−1, 1]
  return d.x() >= 0 ? (d.y() >= 0 ? t : 4.0 + t) : 2.0 - t;
}

std::optional<Eigen::Vector2d> gapBisector(const Eigen::Vector2d& from, const Eigen::Vector2d& to, bool full) {
  if (full) return -from;
  const double cross = from.x() * to.y() - from.y() * to.x(), dot = from.dot(to);
  if (cross > 0) {
    if (dot >= -std::sqrt(0.5)) return std::nullopt;  // at most 135°
    return (from + to).normalized();
  }
  if (cross == 0) {
    if (dot > 0) return std::nullopt;             // the same direction: no gap
    return Eigen::Vector2d(-from.y(), from.x());  // exactly 180°
  }
  return -(from + to).normalized();  // more than 180°
}

}  // namespace iires
