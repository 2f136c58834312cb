// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/hausdorff.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "shapes.hpp"

namespace {

using Points = std::vector<Eigen::Vector3d>;

Points randomPoints(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Points p(n);
  for (auto& x : p) x = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return p;
}

/// Brute force: the ⌈f n⌉-th smallest nearest distance from a to b.
double oracle(const Points& a, const Points& b, double overlap) {
  std::vector<double> d;
  for (const auto& x : a) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& y : b) best = std::min(best, (x - y).norm());
    d.push_back(best);
  }
  std::sort(d.begin(), d.end());
  const auto keep = static_cast<std::size_t>(std::ceil(overlap * static_cast<double>(a.size()) - 1e-9));
  return d[std::max<std::size_t>(1, keep) - 1];
}

TEST(Hausdorff, DirectedMatchesBruteForceOracle) {
  const Points a = randomPoints(300, 1), b = randomPoints(200, 2);
  const iires::KnnIndex ib(b);
  for (double f : {1.0, 0.99, 0.9, 0.75, 0.5, 0.01}) {
    EXPECT_NEAR(iires::reg::directedHausdorff(a, ib, f), oracle(a, b, f), 1e-12) << "overlap " << f;
  }
}

TEST(Hausdorff, SymmetricIsTheLargerDirection) {
  Points a = randomPoints(150, 3);
  Points b = randomPoints(180, 4);
  b.emplace_back(5, 5, 5);  // far from a: decides b → a
  const double h = iires::reg::hausdorffDistance(a, b);
  EXPECT_NEAR(h, std::max(oracle(a, b, 1.0), oracle(b, a, 1.0)), 1e-12);
  EXPECT_NEAR(h, oracle(b, a, 1.0), 1e-12);
  // Trimming one point of 181 drops the far point.
  EXPECT_LT(iires::reg::hausdorffDistance(a, b, 0.99), 1.0);
  EXPECT_DOUBLE_EQ(iires::reg::hausdorffDistance(a, a), 0.0);
}

TEST(Hausdorff, SameForAnyThreadCount) {
  const Points a = randomPoints(5000, 5), b = randomPoints(4000, 6);
  const iires::KnnIndex ib(b);
  EXPECT_EQ(iires::reg::directedHausdorff(a, ib, 0.9, 1), iires::reg::directedHausdorff(a, ib, 0.9, 2));
}

TEST(Hausdorff, BoundedEqualsExactUnderTheBoundAndExitsAbove) {
  const Points a = randomPoints(400, 7), b = randomPoints(300, 8);
  const iires::KnnIndex ib(b);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Points ra;
  for (const auto& x : a) ra.push_back(r * x);
  std::vector<double> scratch;
  for (double f : {1.0, 0.9, 0.6}) {
    const std::size_t out = iires::reg::allowedOutliers(a.size(), f);
    const double exact = oracle(ra, b, f);
    std::size_t visited = 0;
    EXPECT_NEAR(iires::reg::boundedDirectedHausdorff(a, r, ib, out, exact * (1 + 1e-9), scratch, &visited), exact,
                1e-12);
    EXPECT_EQ(visited, a.size());
    EXPECT_NEAR(
        iires::reg::boundedDirectedHausdorff(a, r, ib, out, std::numeric_limits<double>::infinity(), scratch),
        exact, 1e-12);
    const double below = iires::reg::boundedDirectedHausdorff(a, r, ib, out, 0.5 * exact, scratch, &visited);
    EXPECT_TRUE(std::isinf(below));
    EXPECT_LE(visited, a.size());
  }
}

TEST(Hausdorff, PartialWithUnknownOverlapMatchesTheOracleAndItsBound) {
  // Every level's exact value is the oracle's quantile; the multi-level distance is their penalised minimum,
  // and the bound exits exactly when that minimum is above it.
  const Points a = randomPoints(400, 17), b = randomPoints(300, 18);
  const iires::KnnIndex ib(b);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.4, Eigen::Vector3d(3, -1, 2).normalized()).toRotationMatrix();
  Points ra;
  for (const auto& x : a) ra.push_back(r * x);
  const std::vector<double> overlaps{1.0, 0.8, 0.6};
  const auto levels = iires::reg::trimLevels(a.size(), overlaps, 2.0);
  ASSERT_EQ(levels.size(), 3u);
  EXPECT_EQ(levels[1].outliers, 80u);
  EXPECT_NEAR(levels[2].penalty, std::pow(1.0 / 0.6, 2.0), 1e-12);
  double expected = std::numeric_limits<double>::infinity();
  std::size_t expectedLevel = 0;
  for (std::size_t j = 0; j < overlaps.size(); ++j) {
    const double v = levels[j].penalty * oracle(ra, b, overlaps[j]);
    if (v < expected) expected = v, expectedLevel = j;
  }
  std::vector<double> scratch;
  std::size_t visited = 0, level = 99;
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_NEAR(iires::reg::boundedPartialHausdorff(a, r, ib, levels, inf, scratch, &visited, &level), expected, 1e-12);
  EXPECT_EQ(level, expectedLevel);
  EXPECT_NEAR(iires::reg::boundedPartialHausdorff(a, r, ib, levels, expected * (1 + 1e-9), scratch), expected, 1e-12);
  EXPECT_TRUE(std::isinf(iires::reg::boundedPartialHausdorff(a, r, ib, levels, expected * (1 - 1e-9), scratch)));
  EXPECT_THROW(iires::reg::trimLevels(10, {}, 2.0), std::invalid_argument);
  EXPECT_THROW(iires::reg::trimLevels(10, {1.0, 0.0}, 2.0), std::invalid_argument);
}

TEST(Hausdorff, PenalisedQuantileFindsTheOverlapOfAPartialSet) {
  // 70 % of the points have a partner at distance ≈ 0.01, the rest are 1–2 away: every level down to 0.7 is
  // worse (the far points), and smaller levels only pay their penalty — the estimate is 0.7, not the smallest.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> near(0.005, 0.01), far(1.0, 2.0);
  std::vector<double> d2;
  for (int i = 0; i < 700; ++i) d2.push_back(std::pow(near(rng), 2));
  for (int i = 0; i < 300; ++i) d2.push_back(std::pow(far(rng), 2));
  const auto levels = iires::reg::trimLevels(d2.size(), {1.0, 0.85, 0.7, 0.55, 0.4}, 2.0);
  std::size_t level = 99;
  iires::reg::penalisedQuantile(d2, levels, &level);
  EXPECT_EQ(level, 2u);
}

TEST(Hausdorff, AllowedOutliersAndBadOverlap) {
  EXPECT_EQ(iires::reg::allowedOutliers(100, 1.0), 0u);
  EXPECT_EQ(iires::reg::allowedOutliers(100, 0.75), 25u);
  EXPECT_EQ(iires::reg::allowedOutliers(100, 0.001), 99u);  // at least one point is kept
  EXPECT_THROW(iires::reg::allowedOutliers(100, 0.0), std::invalid_argument);
  EXPECT_THROW(iires::reg::allowedOutliers(100, 1.5), std::invalid_argument);
  EXPECT_THROW(iires::reg::hausdorffDistance({}, randomPoints(3, 1)), std::invalid_argument);
}

}  // namespace
