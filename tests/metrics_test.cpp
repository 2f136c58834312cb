// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/metrics.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "iires/io.hpp"
#include "iires/sampling.hpp"
#include "test_util.hpp"

namespace iires {
namespace {

std::vector<Eigen::Vector3d> randomPoints(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> points(n);
  for (auto& p : points) p = {u(rng), u(rng), 0.3 * u(rng)};
  return points;
}

SpacingStats bruteForceSpacing(const std::vector<Eigen::Vector3d>& points) {
  std::vector<double> nn(points.size(), INFINITY);
  for (std::size_t i = 0; i < points.size(); ++i)
    for (std::size_t j = 0; j < points.size(); ++j)
      if (i != j) nn[i] = std::min(nn[i], (points[i] - points[j]).norm());
  SpacingStats s;
  s.min = *std::min_element(nn.begin(), nn.end());
  s.max = *std::max_element(nn.begin(), nn.end());
  for (double d : nn) s.mean += d / nn.size();
  double var = 0;
  for (double d : nn) var += (d - s.mean) * (d - s.mean) / nn.size();
  s.cv = std::sqrt(var) / s.mean;
  return s;
}

TriangleMesh unitCube() {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i) m.vertices.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  m.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                 {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  return m;
}

class MetricsThreads : public ::testing::TestWithParam<int> {};

TEST_P(MetricsThreads, SpacingMatchesBruteForce) {
  for (std::size_t n : {2, 10, 63, 64, 500, 3000}) {
    const auto points = randomPoints(n, n);
    const SpacingStats got = spacingStats(points, GetParam()), want = bruteForceSpacing(points);
    EXPECT_NEAR(got.mean, want.mean, 1e-12) << n;
    EXPECT_NEAR(got.min, want.min, 1e-12) << n;
    EXPECT_NEAR(got.max, want.max, 1e-12) << n;
    EXPECT_NEAR(got.cv, want.cv, 1e-9) << n;
  }
}

TEST_P(MetricsThreads, ResultsDoNotDependOnThreadCount) {
  const auto points = randomPoints(20000, 11);
  const auto reference = randomPoints(5000, 12);
  const SpacingStats a = spacingStats(points, 1), b = spacingStats(points, GetParam());
  EXPECT_EQ(a.mean, b.mean);
  EXPECT_EQ(a.cv, b.cv);
  const MeshDistance cube(unitCube());
  const DistanceStats d1 = cube.distances(points, 1), d2 = cube.distances(points, GetParam());
  EXPECT_EQ(d1.mean, d2.mean);
  EXPECT_EQ(d1.p99, d2.p99);
  const DistanceStats c1 = coverage(reference, points, 1), c2 = coverage(reference, points, GetParam());
  EXPECT_EQ(c1.mean, c2.mean);
  EXPECT_EQ(c1.max, c2.max);
  EXPECT_EQ(c1.p99, c2.p99);
}

INSTANTIATE_TEST_SUITE_P(Threads, MetricsThreads, ::testing::Values(1, 2, 0));

TEST(SpacingStats, SquareGridHasZeroVariation) {
  std::vector<Eigen::Vector3d> grid;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 30; ++j) grid.emplace_back(0.25 * i, 0.25 * j, 2.0);
  const SpacingStats s = spacingStats(grid);
  EXPECT_DOUBLE_EQ(s.mean, 0.25);
  EXPECT_DOUBLE_EQ(s.min, 0.25);
  EXPECT_DOUBLE_EQ(s.max, 0.25);
  EXPECT_NEAR(s.cv, 0.0, 1e-12);
}

TEST(SpacingStats, EmptySingleAndDuplicatePoints) {
  const SpacingStats empty = spacingStats({}), single = spacingStats({Eigen::Vector3d(1, 2, 3)});
  EXPECT_EQ(empty.mean, 0);
  EXPECT_EQ(single.max, 0);
  EXPECT_EQ(single.cv, 0);
  std::vector<Eigen::Vector3d> dup(100, Eigen::Vector3d(1, 1, 1));
  const SpacingStats s = spacingStats(dup);
  EXPECT_EQ(s.max, 0);
  EXPECT_EQ(s.cv, 0);
  auto points = randomPoints(200, 3);
  points.push_back(points[17]);
  EXPECT_EQ(spacingStats(points).min, 0);
}

// A plate thinner than its points' spacing: two grids of spacing 1, 0.3 apart (staggered by 0.1). Along the
// surface every point is one spacing from its nearest; in a straight line the plate's points are 0.33 apart.
TEST(SpacingStats, SheetNeighboursPassOverAFacingSheet) {
  std::vector<Eigen::Vector3d> pts, nrm;
  for (int i = 0; i < 12; ++i)
    for (int j = 0; j < 12; ++j) {
      pts.emplace_back(i, j, 0.3), nrm.emplace_back(0, 0, 1);
      pts.emplace_back(i + 0.1, j + 0.1, 0.0), nrm.emplace_back(0, 0, -1);  // the other side, facing away
    }
  EXPECT_NEAR(spacingStats(pts).max, std::sqrt(0.11), 1e-12);
  const std::vector<double> d = sheetNeighbourDistances(pts, nrm);
  ASSERT_EQ(d.size(), pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) EXPECT_NEAR(d[i], 1.0, 1e-12) << "point " << i;
  const SpacingStats s = summariseSpacing(d);
  EXPECT_NEAR(s.mean, 1.0, 1e-12);
  EXPECT_NEAR(s.cv, 0.0, 1e-12);
  // Unsigned: the same with both sides' normals pointing one way (a mesh whose winding is not consistent).
  for (auto& n : nrm) n = Eigen::Vector3d(0, 0, 1);
  EXPECT_EQ(sheetNeighbourDistances(pts, nrm), d);
  EXPECT_THROW(sheetNeighbourDistances(pts, {}), std::invalid_argument);
  EXPECT_TRUE(sheetNeighbourDistances({}, {}).empty());
}

// Across a crease the normals differ: the nearest point on the other face is a neighbour. Two points 0.2 from a
// right-angled crease on either side (0.28 apart), two more 1 and 1.5 along each face.
TEST(SpacingStats, SheetNeighboursCountAcrossACrease) {
  const std::vector<Eigen::Vector3d> pts = {{0, 0.2, 0}, {0, 0, 0.2}, {0, 1.2, 0}, {0, 0, 1.7}},
                                     nrm = {{0, 0, 1}, {0, 1, 0}, {0, 0, 1}, {0, 1, 0}};
  const std::vector<double> d = sheetNeighbourDistances(pts, nrm);
  EXPECT_NEAR(d[0], std::sqrt(0.08), 1e-12);
  EXPECT_NEAR(d[1], std::sqrt(0.08), 1e-12);
  EXPECT_NEAR(d[2], 1.0, 1e-12);
  EXPECT_NEAR(d[3], 1.5, 1e-12);
}

TEST(MeshDistance, UnitTriangle) {
  TriangleMesh tri;
  tri.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  tri.triangles = {{0, 1, 2}};
  const MeshDistance d(tri);
  EXPECT_NEAR(d.distance({0.2, 0.3, 0.0}), 0.0, 1e-15);              // inside
  EXPECT_NEAR(d.distance({0.2, 0.2, -3.0}), 3.0, 1e-15);             // above the face
  EXPECT_NEAR(d.distance({0.5, -1.0, 0.0}), 1.0, 1e-15);             // beside edge 01
  EXPECT_NEAR(d.distance({1.0, 1.0, 0.0}), std::sqrt(0.5), 1e-15);   // beside the hypotenuse
  EXPECT_NEAR(d.distance({2.0, -1.0, 1.0}), std::sqrt(3.0), 1e-15);  // nearest to vertex 1
  EXPECT_NEAR(d.distance({-1.0, 0.5, 2.0}), std::sqrt(5.0), 1e-15);  // edge 02 and height
  EXPECT_DOUBLE_EQ(d.diagonal(), std::sqrt(2.0));
}

TEST(MeshDistance, UnitCubeAndSummary) {
  const MeshDistance cube(unitCube());
  EXPECT_NEAR(cube.distance({0.5, 0.5, 0.5}), 0.5, 1e-15);
  EXPECT_NEAR(cube.distance({0.5, 0.4, 0.7}), 0.3, 1e-15);
  EXPECT_NEAR(cube.distance({2.0, 0.5, 0.5}), 1.0, 1e-15);
  EXPECT_NEAR(cube.distance({2.0, 2.0, 2.0}), std::sqrt(3.0), 1e-15);
  EXPECT_NEAR(cube.distance({-1.0, -1.0, 0.5}), std::sqrt(2.0), 1e-15);
  EXPECT_DOUBLE_EQ(cube.diagonal(), std::sqrt(3.0));
  // Points at distance 1, 2, ..., 200 above the top face: mean 100.5, max 200, p99 = 198th smallest.
  std::vector<Eigen::Vector3d> points;
  for (int i = 200; i >= 1; --i) points.emplace_back(0.5, 0.5, 1.0 + i);
  const DistanceStats s = cube.distances(points);
  EXPECT_NEAR(s.mean, 100.5, 1e-12);
  EXPECT_NEAR(s.max, 200.0, 1e-12);
  EXPECT_NEAR(s.p99, 198.0, 1e-12);
  EXPECT_EQ(cube.distances({}).max, 0);
  EXPECT_THROW(MeshDistance(TriangleMesh{}), InputError);
  // The nearest face's normal, signed by its winding (outwards on this cube).
  EXPECT_LT((cube.normal({0.5, 0.4, 1.2}) - Eigen::Vector3d(0, 0, 1)).norm(), 1e-12);
  EXPECT_LT((cube.normal({-0.1, 0.3, 0.6}) - Eigen::Vector3d(-1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((cube.normal({0.5, 0.05, 0.5}) - Eigen::Vector3d(0, -1, 0)).norm(), 1e-12);
}

TEST(Coverage, KnownConfiguration) {
  // Samples on the integer grid of the unit square z = 0; the reference holds the cell centres (all at
  // distance √0.5) plus one point far from every sample (a hole).
  std::vector<Eigen::Vector3d> samples, reference;
  for (int i = 0; i <= 10; ++i)
    for (int j = 0; j <= 10; ++j) samples.emplace_back(i, j, 0);
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j) reference.emplace_back(i + 0.5, j + 0.5, 0);
  DistanceStats s = coverage(reference, samples);
  EXPECT_NEAR(s.mean, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(s.max, std::sqrt(0.5), 1e-12);
  EXPECT_NEAR(s.p99, std::sqrt(0.5), 1e-12);
  reference.emplace_back(5, 5, 4);
  s = coverage(reference, samples);
  EXPECT_NEAR(s.max, 4.0, 1e-12);
  EXPECT_NEAR(s.p99, std::sqrt(0.5), 1e-12);  // one hole in 101 is above the 99th percentile
  EXPECT_NEAR(s.mean, (100 * std::sqrt(0.5) + 4) / 101, 1e-12);
  EXPECT_THROW(coverage(reference, {}), InputError);
  EXPECT_EQ(coverage({}, samples).max, 0);
}

TEST(Metrics, BoundingBoxDiagonal) {
  EXPECT_EQ(bboxDiagonal({}), 0);
  EXPECT_DOUBLE_EQ(bboxDiagonal({{1, 2, 3}, {4, 6, 3}, {2, 2, 2}}), std::sqrt(9 + 16 + 1.0));
}

TEST(Metrics, BunnySelfCoverageAndError) {
  const TriangleMesh bunny = readMesh(test::dataPath("meshes/bunny00.off"));
  const MeshDistance distance(bunny);
  EXPECT_DOUBLE_EQ(distance.diagonal(), bboxDiagonal(bunny.vertices));
  EXPECT_LE(distance.distances(bunny.vertices).max, 1e-12);
  MeshSamplingParams p;
  p.count = 50000;
  const auto dense = sampleMesh(bunny, p).points;
  p.count = 2000;
  p.seed = 2;
  const auto sparse = sampleMesh(bunny, p).points;
  // A sparse sampling leaves larger holes than a dense one, measured against the same reference.
  const DistanceStats coarse = coverage(dense, sparse), fine = coverage(dense, bunny.vertices);
  EXPECT_GT(coarse.p99, fine.p99);
  EXPECT_LT(coarse.max, 0.1 * distance.diagonal());
}

}  // namespace
}  // namespace iires
