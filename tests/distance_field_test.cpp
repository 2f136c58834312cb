// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/distance_field.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "iires/register/hausdorff.hpp"
#include "shapes.hpp"

namespace {

using Points = std::vector<Eigen::Vector3d>;
using iires::reg::DistanceField;
using iires::reg::DistanceFieldParams;

/// Brute force: the distance from q to the nearest point of p.
double nearestDistance(const Points& p, const Eigen::Vector3d& q) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& x : p) best = std::min(best, (x - q).norm());
  return best;
}

/// n points drawn uniformly in the box [lo, hi]³.
Points boxPoints(std::size_t n, double lo, double hi, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  Points q(n);
  for (auto& x : q) x = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return q;
}

class DistanceFieldThreads : public ::testing::TestWithParam<int> {};

TEST_P(DistanceFieldThreads, MatchesTheNearestDistanceWithinACellDiagonal) {
  // The exact distance is 1-Lipschitz, so the trilinear interpolation of its node values is within one cell
  // diagonal of it everywhere inside the grid.
  const Points sphere = iires::test::sphereCloud(2000, 1.0, 3).points;
  DistanceFieldParams p;
  p.threads = GetParam();
  const DistanceField field(sphere, p);
  const double diagonal = std::sqrt(3.0) * field.cellSize();
  EXPECT_NEAR(field.cellSize(), 4.0 / 32.0, 0.01);  // the sphere's box ≈ 2, grown by 1 on each side
  double worst = 0;
  for (const auto& q : boxPoints(3000, -1.9, 1.9, 4)) {
    const double exact = nearestDistance(sphere, q);
    const double approx = field.distance(q);
    worst = std::max(worst, std::abs(approx - exact));
    EXPECT_NEAR(approx * approx, field.squaredDistance(q), 1e-12);
  }
  EXPECT_LE(worst, diagonal + 1e-6);
  // At the grid nodes the field is the exact distance (up to the stored precision).
  for (std::size_t i = 0; i < field.nodes()[0]; i += 5) {
    const Eigen::Vector3d node = field.origin() + field.cellSize() * Eigen::Vector3d(double(i), 7.0, 3.0);
    EXPECT_NEAR(field.distance(node), nearestDistance(sphere, node), 1e-5);
  }
}

TEST_P(DistanceFieldThreads, OutsideTheGridIsFiniteAndNotBelowTheDistance) {
  const Points sphere = iires::test::sphereCloud(1000, 1.0, 5).points;
  DistanceFieldParams p;
  p.threads = GetParam();
  p.cells = 16;
  p.margin = 0.5;
  const DistanceField field(sphere, p);
  const double diagonal = std::sqrt(3.0) * field.cellSize();
  std::size_t outside = 0;
  for (const auto& q : boxPoints(2000, -12, 12, 6)) {
    if ((q.array().abs() < 1.4).all()) continue;  // inside the grid
    ++outside;
    const double d = field.distance(q);
    ASSERT_TRUE(std::isfinite(d));
    EXPECT_GE(d, nearestDistance(sphere, q) - diagonal - 1e-6);
    // The fallback |q − c| + field(c) (c the nearest point of the box) is at most d(q) + 2|q − c| + diagonal,
    // and |q − c| ≤ d(q) since the points lie in the box.
    EXPECT_LE(d, 3 * nearestDistance(sphere, q) + diagonal + 1e-6);
  }
  EXPECT_GT(outside, 1000u);
}

INSTANTIATE_TEST_SUITE_P(Threads, DistanceFieldThreads, ::testing::Values(1, 2));

TEST(DistanceField, SameFieldForAnyThreadCount) {
  const Points sphere = iires::test::sphereCloud(1500, 2.0, 7).points;
  DistanceFieldParams one, two;
  one.threads = 1;
  two.threads = 2;
  const DistanceField a(sphere, one), b(sphere, two);
  for (const auto& q : boxPoints(500, -4, 4, 8)) EXPECT_EQ(a.distance(q), b.distance(q));
}

TEST(DistanceField, PartialHausdorffOnTheFieldApproximatesTheTree) {
  // The coarse energy of the rotation search: the same trimmed distance from a field as from a k-d tree,
  // within one cell diagonal; with a bound below it, +inf.
  const Points a = iires::test::sphereCloud(300, 1.0, 9).points;
  const Points b = iires::test::sphereCloud(400, 1.1, 10).points;
  const iires::KnnIndex tree(b);
  const DistanceField field(b);
  const auto levels = iires::reg::trimLevels(a.size(), {1.0, 0.8}, 2.0);
  const Eigen::Vector3d t(0.2, -0.1, 0.05);
  const Eigen::Matrix3d l = 0.9 * Eigen::Matrix3d::Identity();
  std::vector<double> scratch;
  const double inf = std::numeric_limits<double>::infinity();
  const double exact = iires::reg::boundedPartialHausdorff(a, l, t, tree, levels, inf, scratch);
  const double approx = iires::reg::boundedPartialHausdorff(a, l, t, field, levels, inf, scratch);
  EXPECT_NEAR(approx, exact, std::sqrt(3.0) * field.cellSize());
  EXPECT_TRUE(std::isinf(iires::reg::boundedPartialHausdorff(a, l, t, field, levels, 0.5 * approx, scratch)));
}

TEST(DistanceField, EmptySetAndBadParametersThrow) {
  EXPECT_THROW(DistanceField(Points{}), std::invalid_argument);
  const Points one{Eigen::Vector3d(1, 2, 3)};
  DistanceFieldParams p;
  p.cells = 1;
  EXPECT_THROW(DistanceField(one, p), std::invalid_argument);
  p = {};
  p.margin = -0.1;
  EXPECT_THROW(DistanceField(one, p), std::invalid_argument);
  p.margin = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.margin = 0;  // a single point and no margin: an empty box
  EXPECT_THROW(DistanceField(one, p), std::invalid_argument);
  // A single point with the default margin is a valid field: the distance to that point, within a diagonal.
  const DistanceField single(one);
  EXPECT_NEAR(single.distance(Eigen::Vector3d(1.5, 2, 3)), 0.5, std::sqrt(3.0) * single.cellSize());
}

}  // namespace
