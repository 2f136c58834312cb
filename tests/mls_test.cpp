// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/mls.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <random>

#include "iires/geodesic.hpp"
#include "iires/knn.hpp"

#include "shapes.hpp"

namespace {

/// A uniformly random unit vector.
Eigen::Vector3d randomDirection(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  return Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
}

TEST(MlsSurface, ProjectsOntoSphere) {
  const auto cloud = iires::test::sphereCloud(20000, 1.0, 11);
  for (int degree : {1, 2}) {
    iires::MlsParams p;
    p.degree = degree;
    iires::MlsSurface surface(cloud.points, cloud.normals, p);
    std::mt19937_64 rng(3);
    std::normal_distribution<double> g(0.0, 1.0);
    double worst = 0;
    for (int i = 0; i < 200; ++i) {
      const Eigen::Vector3d d = randomDirection(rng);
      const Eigen::Vector3d x = d * (1.0 + 0.01 * g(rng));  // a little off the surface
      Eigen::Vector3d n;
      double off = 0;
      const Eigen::Vector3d y = surface.project(x, &n, &off);
      worst = std::max(worst, std::abs(y.norm() - 1.0));
      EXPECT_GT(n.dot(y.normalized()), 0.99);
      EXPECT_LT(off, 1.0);
    }
    // Input spacing is ~0.013; the quadric fit is far more accurate than the plane fit.
    EXPECT_LT(worst, degree == 2 ? 2e-4 : 2e-3) << "degree " << degree;
  }
}

// With the sampling scales of the geodesic coordinates' components, the kernel widths of a separate object
// sampled at a tenth of the density keep its own scale (the clamp at the cloud's 90th percentile alone gives it
// the dense object's, a fraction of its spacing: every point a step off the sparse sphere then goes to its nearest
// input point); a lone far point's width is still cut.
TEST(MlsSurface, SparseSeparateObjectKeepsItsKernelWidth) {
  auto cloud = iires::test::twoDensitySpheres(10000, 12);
  cloud.points.emplace_back(0, 0, 4);  // far from both: its 8th neighbour is 3 away
  cloud.normals.emplace_back(0, 0, 1);
  const iires::GeodesicCoordinates geo(cloud);
  const std::vector<float>& scales = geo.samplingScales();
  EXPECT_GT(scales[cloud.size() - 2], 5.0f);  // on the sparse sphere
  EXPECT_EQ(scales[0], 1.0f);
  iires::MlsSurface surface(cloud.points, cloud.normals, {}, {}, nullptr, nullptr, {}, &scales);
  EXPECT_LT(surface.kernelWidth(cloud.size() - 1), 0.2);
  EXPECT_NEAR(surface.area(), 4 * M_PI * 10, 0.15 * 4 * M_PI * 10);
  std::mt19937_64 rng(4);
  std::normal_distribution<double> g(0.0, 1.0);
  double worst = 0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d d = randomDirection(rng);
    const Eigen::Vector3d y = surface.project(Eigen::Vector3d(10, 0, 0) + d * (3.0 + 0.03 * g(rng)));
    worst = std::max(worst, std::abs((y - Eigen::Vector3d(10, 0, 0)).norm() - 3.0));
  }
  EXPECT_LT(worst, 3e-3);
}

// A borrowed tree over the same points answers like the surface's own; one projection step from a point that
// was on the surface before a small move lands close to the full projection (the relaxation relies on it).
TEST(MlsSurface, BorrowedIndexAndSingleStepProjection) {
  const auto cloud = iires::test::sphereCloud(20000, 1.0, 12);
  const iires::KnnIndex index(cloud.points);
  const iires::MlsSurface own(cloud.points, cloud.normals);
  const iires::NeighbourTable table(index, cloud.points, iires::MlsSurface::kWidthNeighbours);
  const iires::MlsSurface borrowed(cloud.points, cloud.normals, {}, {}, &index, &table);
  EXPECT_EQ(&borrowed.index(), &index);
  EXPECT_DOUBLE_EQ(own.area(), borrowed.area());  // the kernel widths from the table are the tree's
  EXPECT_DOUBLE_EQ(own.meanSpacing(), borrowed.meanSpacing());
  std::mt19937_64 rng(4);
  double worstStep = 0;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d d = randomDirection(rng);
    const Eigen::Vector3d x = own.project(d);
    EXPECT_EQ(x, borrowed.project(d));
    const Eigen::Vector3d t = d.unitOrthogonal();
    const Eigen::Vector3d moved = x + 0.01 * t;  // a relaxation-sized move along the tangent plane
    worstStep = std::max(worstStep, (own.project(moved, nullptr, nullptr, nullptr, nullptr, 1) - own.project(moved)).norm());
  }
  EXPECT_LT(worstStep, 1e-4);  // input spacing ~0.013
  EXPECT_GT(worstStep, 0.0);   // the step count is honoured (one step is not the full projection)
}

TEST(MlsSurface, FlagsPointsBeyondAnOpenBoundary) {
  auto cloud = iires::test::planeCloud(20000);
  cloud.normals.assign(cloud.size(), Eigen::Vector3d::UnitZ());
  iires::MlsSurface surface(cloud.points, cloud.normals);
  double inside = 0, outside = 0;
  const Eigen::Vector3d p = surface.project(Eigen::Vector3d(0.5, 0.5, 0.05), nullptr, &inside);
  EXPECT_NEAR(p.z(), 0.0, 1e-9);
  surface.project(Eigen::Vector3d(1.2, 0.5, 0.0), nullptr, &outside);
  EXPECT_LT(inside, 1.0);
  EXPECT_GT(outside, 1.0);
  EXPECT_NEAR(surface.area(), 1.0, 0.35);  // a density estimate: right to within tens of per cent
}

// `beyond` (distance past the hull of the input neighbours, in kernel widths) is 0 inside the cloud, even in
// a sampling hole where offSurface is large, and grows past an open boundary.
TEST(MlsSurface, BeyondIsZeroInAHoleAndGrowsPastTheBoundary) {
  auto cloud = iires::test::planeCloud(20000);  // spacing ≈ 0.0035, kernel width ≈ 0.011
  const Eigen::Vector3d hole(0.5, 0.5, 0.0);
  iires::PointCloud holed;
  for (const auto& p : cloud.points)
    if ((p - hole).norm() > 0.03) holed.points.push_back(p);
  holed.normals.assign(holed.size(), Eigen::Vector3d::UnitZ());
  iires::MlsSurface surface(holed.points, holed.normals);
  double off = 0, beyond = 1;
  surface.project(Eigen::Vector3d(0.3, 0.6, 0.01), nullptr, &off, nullptr, nullptr, 0, &beyond);
  EXPECT_EQ(beyond, 0.0);
  surface.project(hole, nullptr, &off, nullptr, nullptr, 0, &beyond);
  EXPECT_GT(off, 1.0);
  EXPECT_EQ(beyond, 0.0);
  double last = 0;
  for (const double x : {1.01, 1.02, 1.04}) {
    surface.project(Eigen::Vector3d(x, 0.5, 0.0), nullptr, &off, nullptr, nullptr, 0, &beyond);
    EXPECT_GT(beyond, last) << "x = " << x;
    last = beyond;
  }
  EXPECT_GT(last, 1.0);  // 0.04 past the last points: more than a kernel width
}

// A roof: two planes whose normals are 50° apart meet along the y axis, sampled on a jittered grid. Points
// 0.8–1.8 spacings beside the crease, a little above face A, project onto A's plane when the fit weights the
// neighbours by their normals (normalSigma); the plain fit, which the other face's points still reach with
// positive weight, rounds the crease and leaves them off the plane.
TEST(MlsSurface, NormalWeightsKeepAFitOnItsOwnSideOfACrease) {
  const double half = 25.0 * M_PI / 180.0;
  const Eigen::Vector3d nA(-std::sin(half), 0, std::cos(half)), nB(std::sin(half), 0, std::cos(half));
  const Eigen::Vector3d uA(-std::cos(half), 0, -std::sin(half)), uB(std::cos(half), 0, -std::sin(half));
  iires::PointCloud roof;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  for (int i = 0; i < 60; ++i)
    for (int j = -30; j < 30; ++j) {
      const double s = (i + 0.5 + jitter(rng)) * 0.01, t = (j + jitter(rng)) * 0.01;
      roof.points.push_back(s * uA + Eigen::Vector3d(0, t, 0)), roof.normals.push_back(nA);
      roof.points.push_back(s * uB + Eigen::Vector3d(0, t, 0)), roof.normals.push_back(nB);
    }
  auto offA = [&](double sigma) {
    iires::MlsParams p;
    p.normalSigma = sigma;
    const iires::MlsSurface surface(roof.points, roof.normals, p);
    double worst = 0;
    for (double s = 0.008; s < 0.019; s += 0.002)
      worst = std::max(worst, std::abs(nA.dot(surface.project(s * uA + 0.003 * nA))));
    return worst;
  };
  EXPECT_LT(offA(0.5), 1e-4);
  EXPECT_GT(offA(0.0), 2e-4);  // spacing 0.01: the plain fit leaves up to 3 % of a spacing
}

}  // namespace
