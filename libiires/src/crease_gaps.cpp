// SPDX-License-Identifier: GPL-3.0-or-later
// Steps 5 and 8 of snapToCreases(): gaps between held samples filled along their crease (fillCreaseGaps).
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

#include "features_internal.hpp"
#include "iires/knn.hpp"

namespace iires::detail {

void fillCreaseGaps(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                    std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner, double maxGap) {
  std::vector<double> gaps;
  for (std::size_t t = 1; t < out.size(); ++t)
    if (owner[t] == owner[t - 1]) gaps.push_back((out[t] - out[t - 1]).norm());
  if (gaps.empty()) return;
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
  const double step = gaps[gaps.size() / 2];
  if (!(step > 1e-9 * h)) return;
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  const std::size_t n0 = out.size();
  const KnnIndex placed(out);  // the samples before filling; the added ones are checked by brute force
  std::vector<Eigen::Vector3d> added;
  std::vector<std::uint32_t> addedOwner;
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  // The snap fit at y (re-centred once on the crease), as in tracing; false where it fails the thresholds.
  auto fit = [&](const Eigen::Vector3d& y0, Crease& c) {
    Eigen::Vector3d y = y0;
    const double hl = localSpacing(index, y, h);
    for (int it = 0; it < 2; ++it) {
      if (!snapFit(cloud, index, y, hl, params, params, c, idx, d2)) return false;
      y = c.point;
    }
    return true;
  };
  std::vector<signed char> fitted(n0, -1);  // lazily: the crease at each original sample
  std::vector<Crease> creaseAt(n0);
  auto creaseOf = [&](std::size_t i) -> const Crease* {
    if (fitted[i] < 0) fitted[i] = fit(out[i], creaseAt[i]) ? 1 : 0;
    return fitted[i] ? &creaseAt[i] : nullptr;
  };
  std::vector<std::uint32_t> near, ci;
  std::vector<double> nd2, cd2;
  // A sample within r of the midpoint m of a–b and within half a step of the line a–b splits the gap (one off
  // the line, e.g. an outlier of a biased fit, does not).
  auto covered = [&](const Eigen::Vector3d& m, double r, const Eigen::Vector3d& u) {
    auto blocks = [&](const Eigen::Vector3d& q) {
      const Eigen::Vector3d v = q - m;
      return v.squaredNorm() < r * r && (v - u * v.dot(u)).squaredNorm() <= 0.25 * step * step;
    };
    placed.radius(m, r, ci, cd2);
    for (std::uint32_t c : ci)
      if (blocks(out[c])) return true;
    for (const auto& q : added)
      if (blocks(q)) return true;
    return false;
  };
  // A sample of e's own chain 0.5–1.6 steps behind e (away from f) within 20° (or 0.15 step) of the line e–f: e's
  // crease runs on in line (up to the wobble of samples placed by biased fits). Another chain's sample there
  // says nothing about e's crease (a neighbouring crease may run in line by chance while e's bends away).
  const double kInLine = std::tan(20.0 * kDeg);
  auto inLine = [&](std::size_t e, std::size_t f) {
    const Eigen::Vector3d u = (out[f] - out[e]).normalized();
    placed.radius(out[e], 1.6 * step, ci, cd2);
    for (std::uint32_t c : ci) {
      if (owner[c] != owner[e]) continue;
      const Eigen::Vector3d v = out[c] - out[e];
      const double t = v.dot(u);
      if (-t >= 0.5 * step && (v - t * u).norm() <= std::max(0.15 * step, -t * kInLine)) return true;
    }
    return false;
  };
  std::vector<Eigen::Vector3d> fill;
  for (std::size_t i = 0; i < n0; ++i) {
    placed.radius(out[i], maxGap * step, near, nd2);
    std::vector<std::uint32_t> later;
    for (std::uint32_t j : near)
      if (j > i) later.push_back(j);
    std::sort(later.begin(), later.end());
    for (std::uint32_t j : later) {
      const Eigen::Vector3d &a = out[i], &b = out[j];
      const double g = (b - a).norm();
      if (g <= 1.5 * step || g > maxGap * step) continue;
      const Eigen::Vector3d m = 0.5 * (a + b), u = (b - a) / g;
      if (covered(m, 0.45 * g, u)) continue;
      const bool lineA = inLine(i, j), lineB = inLine(j, i);
      const bool chord = g <= 4.5 * step ? (lineA || lineB) : (lineA && lineB);
      const int pieces = static_cast<int>(std::ceil(g / step - 1e-9));
      fill.clear();
      bool ok = true;
      for (int k = 1; k < pieces && ok; ++k) {
        const Eigen::Vector3d q = a + (b - a) * (static_cast<double>(k) / pieces);
        Crease c;
        ok = false;
        if (fit(q, c) && std::abs(c.direction.dot(u)) >= cosTurn) {
          const Eigen::Vector3d off = c.point - a - u * (c.point - a).dot(u);  // off the chord
          if (off.norm() <= 0.3 * step && (c.point - q).norm() <= 0.5 * step) fill.push_back(c.point), ok = true;
        }
        for (std::size_t e : {static_cast<std::size_t>(i), static_cast<std::size_t>(j)}) {
          if (ok) break;
          const Crease* ce = creaseOf(e);
          if (!ce || std::abs(ce->direction.dot(u)) < cosTurn) continue;
          const Eigen::Vector3d onLine = ce->point + ce->direction * (q - ce->point).dot(ce->direction);
          if ((onLine - q).norm() <= 0.1 * step) fill.push_back(onLine), ok = true;
        }
        if (!ok && chord) fill.push_back(q), ok = true;
        if (ok) ok = offInput(cloud, index, fill.back(), h) <= 1.5 * params.maxOffCrease;
      }
      if (!ok) continue;
      for (const auto& q : fill) added.push_back(q), addedOwner.push_back(owner[i]);
    }
  }
  out.insert(out.end(), added.begin(), added.end());
  owner.insert(owner.end(), addedOwner.begin(), addedOwner.end());
}

}  // namespace iires::detail
