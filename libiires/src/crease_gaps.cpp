// SPDX-License-Identifier: GPL-3.0-or-later
// Steps 5 and 8 of snapToCreases(): gaps between held samples filled along their crease (fillCreaseGaps).
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <vector>

#include "features_internal.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/knn.hpp"

namespace iires::detail {

namespace {

/// A gap of fillCreaseGaps() between placed samples a (the caller's) and @p b: its midpoint @p m, the unit vector
/// @p u from a to b, the radius @p r of its "covered" test and the samples that fill it.
struct Gap {
  std::uint32_t b = 0;
  Eigen::Vector3d m, u;
  double r = 0;
  std::vector<Eigen::Vector3d> fill;
};

}  // namespace

// Two passes with the result of one in sample order: each gap's filling samples are found in parallel, the gap
// judged against the placed samples only; then, in order, a gap that an earlier gap's new samples cover is left
// out, the others filled.
void fillCreaseGaps(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                    std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner, double maxGap,
                    int threads) {
  std::vector<double> gaps;
  for (std::size_t t = 1; t < out.size(); ++t)
    if (owner[t] == owner[t - 1]) gaps.push_back((out[t] - out[t - 1]).norm());
  if (gaps.empty()) return;
  std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
  const double step = gaps[gaps.size() / 2];
  if (!(step > 1e-9 * h)) return;
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  const std::size_t n0 = out.size();
  const KnnIndex placed(out);  // the samples before filling
  // The snap fit at y (re-centred once on the crease), as in tracing; false where it fails the thresholds.
  auto fit = [&](const Eigen::Vector3d& y0, Crease& c) {
    thread_local std::vector<std::uint32_t> idx;  // scratch of the neighbour searches, kept across fits
    thread_local std::vector<double> d2;
    Eigen::Vector3d y = y0;
    const double hl = localSpacing(index, y, h);
    for (int it = 0; it < 2; ++it) {
      if (!snapFit(cloud, index, y, hl, params, params, c, idx, d2)) return false;
      y = c.point;
    }
    return true;
  };
  // The crease at each placed sample, fitted once when first asked for (−1: not yet, 2: being fitted: a thread
  // that finds it so fits it too, to the same result).
  std::vector<std::atomic<signed char>> fitted(n0);
  for (auto& f : fitted) f.store(-1, std::memory_order_relaxed);
  std::vector<Crease> creaseAt(n0);
  auto creaseOf = [&](std::size_t e, Crease& c) {
    const signed char state = fitted[e].load(std::memory_order_acquire);
    if (state == 0 || state == 1) {
      c = creaseAt[e];
      return state == 1;
    }
    const bool ok = fit(out[e], c);
    signed char expected = -1;
    if (fitted[e].compare_exchange_strong(expected, 2, std::memory_order_acq_rel)) {
      creaseAt[e] = c;
      fitted[e].store(ok ? 1 : 0, std::memory_order_release);
    }
    return ok;
  };
  // A sample within r of the midpoint m of a–b and within half a step of the line a–b splits the gap (one off
  // the line, e.g. an outlier of a biased fit, does not).
  auto blocks = [&](const Gap& gap, const Eigen::Vector3d& q) {
    const Eigen::Vector3d v = q - gap.m;
    return v.squaredNorm() < gap.r * gap.r && (v - gap.u * v.dot(gap.u)).squaredNorm() <= 0.25 * step * step;
  };
  // A sample of e's own chain 0.5–1.6 steps behind e (away from f) within 20° (or 0.15 step) of the line e–f: e's
  // crease runs on in line (up to the wobble of samples placed by biased fits). Another chain's sample there
  // says nothing about e's crease (a neighbouring crease may run in line by chance while e's bends away).
  const double kInLine = std::tan(20.0 * kDeg);
  auto inLine = [&](std::size_t e, std::size_t f, std::vector<std::uint32_t>& ci, std::vector<double>& cd2) {
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
  // The samples filling the gap a–b: at each piece the snap fit's crease where it runs along a–b near the chord,
  // else the fitted crease line of a or b, else the chord where @p chord allows it; false where a piece has none.
  auto fillGap = [&](std::size_t i, std::size_t j, bool chord, Gap& gap) {
    const Eigen::Vector3d &a = out[i], &b = out[j];
    const int pieces = static_cast<int>(std::ceil((b - a).norm() / step - 1e-9));
    for (int k = 1; k < pieces; ++k) {
      const Eigen::Vector3d q = a + (b - a) * (static_cast<double>(k) / pieces);
      Crease c;
      bool ok = false;
      if (fit(q, c) && std::abs(c.direction.dot(gap.u)) >= cosTurn) {
        const Eigen::Vector3d off = c.point - a - gap.u * (c.point - a).dot(gap.u);  // off the chord
        if (off.norm() <= 0.3 * step && (c.point - q).norm() <= 0.5 * step) gap.fill.push_back(c.point), ok = true;
      }
      for (std::size_t e : {i, j}) {
        if (ok) break;
        Crease ce;
        if (!creaseOf(e, ce) || std::abs(ce.direction.dot(gap.u)) < cosTurn) continue;
        const Eigen::Vector3d onLine = ce.point + ce.direction * (q - ce.point).dot(ce.direction);
        if ((onLine - q).norm() <= 0.1 * step) gap.fill.push_back(onLine), ok = true;
      }
      if (!ok && chord) gap.fill.push_back(q), ok = true;
      if (!ok || offInput(cloud, index, gap.fill.back(), h) > 1.5 * params.maxOffCrease) return false;
    }
    return true;
  };
  std::vector<std::vector<Gap>> found(n0);  // the gaps from each sample to later ones that can be filled
  parallelFor(n0, threads, [&](std::size_t i) {
    std::vector<std::uint32_t> near, ci;
    std::vector<double> nd2, cd2;
    placed.radius(out[i], maxGap * step, near, nd2);
    std::sort(near.begin(), near.end());
    for (std::uint32_t j : near) {
      const double g = (out[j] - out[i]).norm();
      if (j <= i || g <= 1.5 * step || g > maxGap * step) continue;
      Gap gap;
      gap.b = j, gap.m = 0.5 * (out[i] + out[j]), gap.u = (out[j] - out[i]) / g, gap.r = 0.45 * g;
      placed.radius(gap.m, gap.r, ci, cd2);
      if (std::any_of(ci.begin(), ci.end(), [&](std::uint32_t c) { return blocks(gap, out[c]); })) continue;
      const bool lineA = inLine(i, j, ci, cd2), lineB = inLine(j, i, ci, cd2);
      if (fillGap(i, j, g <= 4.5 * step ? (lineA || lineB) : (lineA && lineB), gap))
        found[i].push_back(std::move(gap));
    }
  });
  std::vector<Eigen::Vector3d> added;
  std::vector<std::uint32_t> addedOwner;
  for (std::size_t i = 0; i < n0; ++i)
    for (const Gap& gap : found[i]) {
      if (std::any_of(added.begin(), added.end(), [&](const Eigen::Vector3d& q) { return blocks(gap, q); }))
        continue;
      for (const auto& q : gap.fill) added.push_back(q), addedOwner.push_back(owner[i]);
    }
  out.insert(out.end(), added.begin(), added.end());
  owner.insert(owner.end(), addedOwner.begin(), addedOwner.end());
}

}  // namespace iires::detail
