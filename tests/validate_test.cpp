// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/validate.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <tuple>
#include <vector>

namespace iires {
namespace {

using Eigen::Vector3d;

/// The message of the InputError that validateCloud throws; a test failure and "" when it throws none.
std::string validationError(PointCloud cloud, std::size_t minPoints = 1) {
  try {
    validateCloud(cloud, minPoints, "scan.ply");
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "no InputError thrown";
  return "";
}

::testing::AssertionResult contains(const std::string& text, const std::string& part) {
  if (text.find(part) != std::string::npos) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "\"" << text << "\" does not contain \"" << part << "\"";
}

PointCloud tetrahedron() {
  PointCloud cloud;
  cloud.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  cloud.normals = {{-1, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  return cloud;
}

TEST(Validate, AcceptsAGoodCloudUnchanged) {
  PointCloud cloud = tetrahedron();
  const ValidationReport report = validateCloud(cloud, 4);
  EXPECT_EQ(report.inputPoints, 4u);
  EXPECT_EQ(report.duplicatesMerged, 0u);
  EXPECT_EQ(report.outputPoints, 4u);
  EXPECT_EQ(cloud.points, tetrahedron().points);
  EXPECT_EQ(cloud.normals, tetrahedron().normals);
}

TEST(Validate, EmptyCloud) { EXPECT_EQ(validationError(PointCloud{}), "scan.ply: the cloud is empty"); }

TEST(Validate, NonFiniteCoordinatesNameTheFirstBadPoint) {
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                           -std::numeric_limits<double>::infinity()}) {
    PointCloud cloud = tetrahedron();
    cloud.points.push_back({0.5, 0.5, 0.5});
    cloud.points[3].y() = bad;
    cloud.points[4].x() = bad;
    cloud.normals.push_back({1, 0, 0});
    const std::string message = validationError(cloud);
    EXPECT_TRUE(contains(message, "scan.ply"));
    EXPECT_TRUE(contains(message, "point 3 "));
  }
}

TEST(Validate, MergesExactDuplicatesKeepingFirstOccurrenceAndItsNormal) {
  PointCloud cloud = tetrahedron();
  cloud.points.insert(cloud.points.begin(), Vector3d(0, 0, 1));  // duplicate of the (later) last point
  cloud.normals.insert(cloud.normals.begin(), Vector3d(0, 0, -1));
  cloud.points.push_back({1, 0, 0});
  cloud.normals.push_back({0, 1, 0});
  cloud.points.push_back({1, 0, 1e-12});  // close but not equal: kept
  cloud.normals.push_back({0, 0, 1});
  const ValidationReport report = validateCloud(cloud, 1);
  EXPECT_EQ(report.inputPoints, 7u);
  EXPECT_EQ(report.duplicatesMerged, 2u);
  EXPECT_EQ(report.outputPoints, 5u);
  EXPECT_EQ(cloud.points,
            (std::vector<Vector3d>{{0, 0, 1}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 0, 1e-12}}));
  EXPECT_EQ(cloud.normals, (std::vector<Vector3d>{{0, 0, -1}, {-1, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}));
}

TEST(Validate, MinPointsCountsDistinctPoints) {
  PointCloud cloud = tetrahedron();
  cloud.points.push_back(cloud.points[0]);
  const std::string message = validationError(cloud, 5);
  EXPECT_TRUE(contains(message, "scan.ply"));
  EXPECT_TRUE(contains(message, "at least 5 distinct points"));
  EXPECT_NO_THROW(validateCloud(cloud, 4));
}

TEST(Validate, CollinearSinglePointAndIdenticalPoints) {
  PointCloud line;
  for (int i = 0; i < 50; ++i) line.points.push_back(Vector3d(0.1, 0.3, 0.7) * i + Vector3d(1e3, -2e3, 5));
  EXPECT_TRUE(contains(validationError(line), "scan.ply: all points are collinear"));

  PointCloud two;
  two.points = {{0, 0, 0}, {1, 1, 1}};
  EXPECT_TRUE(contains(validationError(two), "all points are collinear"));

  PointCloud single;
  single.points = {{1, 2, 3}};
  EXPECT_TRUE(contains(validationError(single), "all points are collinear"));

  PointCloud identical;
  identical.points.assign(10, Vector3d(1, 2, 3));
  EXPECT_TRUE(contains(validationError(identical), "all points are collinear"));
  EXPECT_TRUE(contains(validationError(identical, 3), "at least 3 distinct points, the cloud has 1"));
}

// One point 10⁸ sizes away makes the covariance a line through it; the cloud is not collinear (the outlier
// stage removes that point). Points on a line with such a point off it still are.
TEST(Validate, AFarOutlierDoesNotMakeACloudCollinear) {
  PointCloud plane;
  for (int i = 0; i < 400; ++i) plane.points.push_back({0.05 * (i % 20), 0.05 * (i / 20), 0.0});
  plane.points.push_back({1e8, 0, 0});
  EXPECT_NO_THROW(validateCloud(plane, 4));
  PointCloud line;
  for (int i = 0; i < 50; ++i) line.points.push_back(Vector3d(0.1, 0.3, 0.7) * i);
  line.points.push_back({1e8, -1e8, 0});
  EXPECT_TRUE(contains(validationError(line), "all points are collinear"));
}

TEST(Validate, ThinButPlanarCloudIsAccepted) {
  PointCloud strip;
  for (int i = 0; i < 100; ++i) strip.points.push_back({i * 1.0, (i % 2) * 1e-4, 0});
  EXPECT_NO_THROW(validateCloud(strip, 3));
}

TEST(Validate, NonFiniteNormalsAreDropped) {
  PointCloud cloud = tetrahedron();
  cloud.normals[2].z() = std::numeric_limits<double>::quiet_NaN();
  validateCloud(cloud, 4);
  EXPECT_EQ(cloud.size(), 4u);
  EXPECT_TRUE(cloud.normals.empty());
}

// Many duplicates: every one merged, none left (the speed of the merge is bench material, not a test's).
TEST(Validate, MergesManyDuplicates) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> cell(0, 199);
  PointCloud cloud;
  for (int i = 0; i < 400000; ++i) cloud.points.push_back(Vector3d(cell(rng), cell(rng), cell(rng)) * 0.01);
  const ValidationReport report = validateCloud(cloud, 3);
  EXPECT_EQ(report.outputPoints + report.duplicatesMerged, 400000u);
  EXPECT_GT(report.duplicatesMerged, 0u);
  std::vector<Vector3d> sorted = cloud.points;
  std::sort(sorted.begin(), sorted.end(), [](const Vector3d& a, const Vector3d& b) {
    return std::tie(a.x(), a.y(), a.z()) < std::tie(b.x(), b.y(), b.z());
  });
  EXPECT_EQ(std::adjacent_find(sorted.begin(), sorted.end()), sorted.end());
}

// −0 and +0 are the same coordinate: such points are duplicates (the merge hashes bit patterns, so it must
// normalise the sign of zero first).
TEST(Validate, SignedZeroesAreTheSamePoint) {
  PointCloud cloud = tetrahedron();
  cloud.points.push_back({-0.0, 0.0, -0.0});  // == tetrahedron's (0, 0, 0)
  cloud.points.push_back({1.0, -0.0, 0.0});   // == (1, 0, 0)
  const ValidationReport report = validateCloud(cloud, 4);
  EXPECT_EQ(report.duplicatesMerged, 2u);
  EXPECT_EQ(cloud.size(), 4u);
}

// A volume is rejected; a surface is not, however noisy: a shell whose radial noise is 12 % of its radius (the
// neighbourhoods are three-dimensional up to 256 points and flat at a tenth of the cloud), a plane with noise of
// one spacing, a sheet scanned in lines ten times farther apart than the points along them.
TEST(SurfaceCheck, AVolumeIsRejectedANoisySurfaceIsNot) {
  std::mt19937_64 rng(9);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vector3d> ball, shell, plane, lines;
  while (ball.size() < 5000) {
    const Vector3d p(2 * u(rng) - 1, 2 * u(rng) - 1, 2 * u(rng) - 1);
    if (p.norm() <= 1) ball.push_back(p);
  }
  for (int i = 0; i < 20000; ++i)
    shell.push_back((1.0 + 0.12 * g(rng)) * Vector3d(g(rng), g(rng), g(rng)).normalized());
  for (int i = 0; i < 20000; ++i) plane.emplace_back(141 * u(rng), 141 * u(rng), g(rng));
  for (int line = 0; line < 30; ++line)
    for (int i = 0; i < 300; ++i) lines.emplace_back(0.1 * i, 1.0 * line, 0.01 * g(rng));
  try {
    checkSamplesASurface(ball, "ball.xyz");
    ADD_FAILURE() << "a solid ball was accepted";
  } catch (const InputError& e) {
    EXPECT_TRUE(contains(e.what(), "ball.xyz: the points fill a volume"));
  }
  EXPECT_NO_THROW(checkSamplesASurface(shell, "shell.xyz"));
  EXPECT_NO_THROW(checkSamplesASurface(plane, "plane.xyz"));
  EXPECT_NO_THROW(checkSamplesASurface(lines, "lines.xyz"));
}

}  // namespace
}  // namespace iires
