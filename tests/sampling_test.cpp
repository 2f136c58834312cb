// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/sampling.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "iires/io.hpp"
#include "iires/metrics.hpp"
#include "test_util.hpp"

namespace iires {
namespace {

/// The rectangle [0, length] x [0, 1] in the z = 0 plane, split into 2·cells triangles, normal +z.
TriangleMesh strip(double length, int cells) {
  TriangleMesh m;
  for (int i = 0; i <= cells; ++i) {
    const double x = length * i / cells;
    m.vertices.emplace_back(x, 0, 0);
    m.vertices.emplace_back(x, 1, 0);
  }
  for (int i = 0; i < cells; ++i) {
    const int a = 2 * i;
    m.triangles.emplace_back(a, a + 2, a + 3);
    m.triangles.emplace_back(a, a + 3, a + 1);
  }
  return m;
}

MeshSamplingParams withCount(std::size_t count, std::uint64_t seed = 1) {
  MeshSamplingParams p;
  p.count = count;
  p.seed = seed;
  return p;
}

TEST(SampleMesh, ExactCountOnTheSurfaceWithWindingNormals) {
  const TriangleMesh mesh = strip(3.0, 4);
  const PointCloud cloud = sampleMesh(mesh, withCount(12345));
  ASSERT_EQ(cloud.size(), 12345u);
  ASSERT_TRUE(cloud.hasNormals());
  EXPECT_LE(MeshDistance(mesh).distances(cloud.points).max, 1e-9);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    EXPECT_EQ(cloud.normals[i], Eigen::Vector3d(0, 0, 1));
    EXPECT_TRUE(cloud.points[i].x() >= 0 && cloud.points[i].x() <= 3 && cloud.points[i].y() >= 0 &&
                cloud.points[i].y() <= 1);
  }
}

TEST(SampleMesh, AreaWeightedAndUniformWithinTriangles) {
  // Two triangles sharing an edge, areas 1/2 and 3/2: three times as many points in the second.
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-3, 0, 0}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  const PointCloud cloud = sampleMesh(mesh, withCount(40000, 7));
  int inFirst = 0, nearCorner = 0;
  for (const Eigen::Vector3d& p : cloud.points) {
    if (p.x() >= 0) {
      ++inFirst;
      if (p.x() + p.y() < 0.5) ++nearCorner;  // a quarter of the first triangle's area
    }
  }
  EXPECT_NEAR(inFirst / 40000.0, 0.25, 0.01);
  EXPECT_NEAR(nearCorner / static_cast<double>(inFirst), 0.25, 0.015);
}

TEST(SampleMesh, SeedDeterminesTheCloud) {
  const TriangleMesh mesh = strip(2.0, 3);
  MeshSamplingParams p = withCount(2000, 42);
  p.densityRatio = 3;
  p.noise = 0.01;
  p.outlierFraction = 0.05;
  p.outlierMin = 0.1;
  p.outlierMax = 0.2;
  const PointCloud a = sampleMesh(mesh, p), b = sampleMesh(mesh, p);
  EXPECT_EQ(a.points, b.points);
  EXPECT_EQ(a.normals, b.normals);
  p.seed = 43;
  const PointCloud c = sampleMesh(mesh, p);
  std::size_t same = 0;
  for (std::size_t i = 0; i < a.size(); ++i) same += a.points[i] == c.points[i];
  EXPECT_EQ(same, 0u);
}

TEST(SampleMesh, DensityRatioAlongTheLongestAxis) {
  const TriangleMesh mesh = strip(10.0, 10);  // longest axis x
  MeshSamplingParams p = withCount(60000, 3);
  p.densityRatio = 5;
  const PointCloud cloud = sampleMesh(mesh, p);
  ASSERT_EQ(cloud.size(), 60000u);
  int first = 0, last = 0;
  for (const Eigen::Vector3d& q : cloud.points) {
    first += q.x() < 1.0;
    last += q.x() > 9.0;
  }
  // Density 5^t: the slabs [0, 0.1] and [0.9, 1] hold a ratio of 5^0.9 ≈ 4.26.
  const double ratio = static_cast<double>(last) / first;
  EXPECT_GE(ratio, 3.5);
  EXPECT_LE(ratio, 7.0);
  EXPECT_NEAR(ratio, std::pow(5.0, 0.9), 0.4);
}

TEST(SampleMesh, GaussianNoiseAlongTheNormal) {
  const TriangleMesh mesh = strip(4.0, 2);
  MeshSamplingParams p = withCount(50000, 5);
  const PointCloud clean = sampleMesh(mesh, p);
  p.noise = 0.02;
  const PointCloud noisy = sampleMesh(mesh, p);
  double sum = 0, sumSq = 0;
  for (std::size_t i = 0; i < noisy.size(); ++i) {
    // Same seed: noise only moves the clean samples along the normal (+z).
    ASSERT_NEAR((noisy.points[i] - clean.points[i]).head<2>().norm(), 0.0, 1e-12);
    sum += noisy.points[i].z();
    sumSq += noisy.points[i].z() * noisy.points[i].z();
  }
  const double mean = sum / noisy.size(), std = std::sqrt(sumSq / noisy.size() - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.001);
  EXPECT_NEAR(std, 0.02, 0.0006);
}

TEST(SampleMesh, UniformNoiseWithinZeroAndAmplitude) {
  MeshSamplingParams p = withCount(20000, 6);
  p.noise = 0.05;
  p.gaussianNoise = false;
  const PointCloud cloud = sampleMesh(strip(1.0, 1), p);
  double sum = 0, lo = 1, hi = -1;
  for (const Eigen::Vector3d& q : cloud.points) {
    sum += q.z();
    lo = std::min(lo, q.z());
    hi = std::max(hi, q.z());
  }
  EXPECT_GE(lo, 0.0);
  EXPECT_LE(hi, 0.05);
  EXPECT_NEAR(sum / cloud.size(), 0.025, 0.001);
}

TEST(SampleMesh, OutlierCountAndOffsets) {
  MeshSamplingParams p = withCount(10000, 9);
  p.outlierFraction = 0.03;
  p.outlierMin = 0.3;
  p.outlierMax = 0.6;
  const PointCloud cloud = sampleMesh(strip(5.0, 5), p);
  int outliers = 0, above = 0;
  for (const Eigen::Vector3d& q : cloud.points) {
    if (q.z() == 0) continue;
    ++outliers;
    above += q.z() > 0;
    EXPECT_GE(std::abs(q.z()), 0.3);
    EXPECT_LE(std::abs(q.z()), 0.6);
  }
  EXPECT_EQ(outliers, 300);
  EXPECT_GT(above, 100);  // both sides of the surface
  EXPECT_LT(above, 200);
}

TEST(SampleMesh, RejectsDegenerateMeshesAndBadParameters) {
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.triangles = {{0, 1, 2}};
  EXPECT_THROW(sampleMesh(flat, withCount(10)), InputError);
  EXPECT_THROW(sampleMesh(TriangleMesh{}, withCount(10)), InputError);
  EXPECT_THROW(sampleMesh(strip(1, 1), withCount(0)), InputError);
  MeshSamplingParams p = withCount(10);
  p.densityRatio = 0.5;
  EXPECT_THROW(sampleMesh(strip(1, 1), p), InputError);
  TriangleMesh broken = strip(1, 1);
  broken.triangles.emplace_back(0, 1, 99);
  EXPECT_THROW(sampleMesh(broken, withCount(10)), InputError);
}

TEST(SampleMesh, BunnySamplesLieOnTheMesh) {
  const TriangleMesh bunny = readMesh(test::dataPath("meshes/bunny00.off"));
  const PointCloud cloud = sampleMesh(bunny, withCount(20000));
  ASSERT_EQ(cloud.size(), 20000u);
  const MeshDistance distance(bunny);
  EXPECT_LE(distance.distances(cloud.points).max, 1e-9);
  // Uniform sampling of a closed surface: nearest-neighbour CV of a Poisson process (≈0.52), not a grid.
  EXPECT_NEAR(spacingStats(cloud.points).cv, 0.52, 0.05);
}

TEST(SampleMeshTool, WritesTheRequestedCloudAndRejectsBadInput) {
  const std::string mesh = test::dataPath("meshes/fandisk.off"), out = test::tempDir() + "/noisy.ply";
  std::string log;
  ASSERT_EQ(test::run(test::tool("iires-sample-mesh") + " " + mesh + " " + out +
                          " -n 5000 --density-ratio 2 --noise-spacing 0.33 --uniform-noise --outliers 0.02"
                          " --outlier-min-spacing 3 --outlier-max-spacing 6 --seed 4",
                      &log),
            0)
      << log;
  const PointCloud cloud = readPointCloud(out);
  EXPECT_EQ(cloud.size(), 5000u);
  EXPECT_TRUE(cloud.hasNormals());
  EXPECT_NE(log.find("l = "), std::string::npos) << log;
  const std::string bin = test::tool("iires-sample-mesh") + " ";
  EXPECT_EQ(test::run(bin + "/nonexistent.off " + out + " -n 10", &log), 2) << log;
  EXPECT_EQ(test::run(bin + mesh + " " + out + " -n 0", &log), 2) << log;
  EXPECT_EQ(test::run(bin + mesh + " " + out + " -n -3", &log), 2) << log;
  EXPECT_EQ(test::run(bin + mesh + " " + out + " -n 10 --outliers 0.1", &log), 2) << log;
  EXPECT_EQ(test::run(bin + mesh + " " + out + " -n 10 --noise 1 --noise-spacing 1", &log), 2) << log;
  // Flags that would change nothing (no outliers, no noise) are refused, not ignored.
  EXPECT_EQ(test::run(bin + mesh + " " + out + " -n 10 --outlier-max 0.1 2>&1", &log), 2) << log;
  EXPECT_NE(log.find("--outlier-max has no effect"), std::string::npos) << log;
  EXPECT_EQ(test::run(bin + mesh + " " + out + " -n 10 --uniform-noise 2>&1", &log), 2) << log;
  EXPECT_NE(log.find("--uniform-noise has no effect"), std::string::npos) << log;
}

}  // namespace
}  // namespace iires
