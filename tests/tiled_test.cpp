// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/tiled.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <array>
#include <filesystem>
#include <fstream>
#include <random>

#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "test_util.hpp"

namespace {

using iires::PointCloud;
using Eigen::Vector3d;

constexpr double kSphereRadius = 0.25;
const Vector3d kSphereCentre(0.5, 0.5, 0.45);

/// A terrain z = 0.15 sin(1.5x) cos(2y) over [0,4] × [0,2] with a square hole at its far corner (x > 2.9,
/// y > 0.9: tile (3,1) of a unit grid holds no point) and a floating sphere inside tile (0,0).
PointCloud scene(std::size_t terrainPoints, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  PointCloud c;
  while (c.points.size() < terrainPoints) {
    const double x = 4 * u(rng), y = 2 * u(rng);
    if (x > 2.9 && y > 0.9) continue;
    c.points.emplace_back(x, y, 0.15 * std::sin(1.5 * x) * std::cos(2 * y));
  }
  const auto sphere = static_cast<std::size_t>(static_cast<double>(terrainPoints) * 0.8 / 7.0);
  for (std::size_t i = 0; i < sphere; ++i) {
    Vector3d d(g(rng), g(rng), g(rng));
    c.points.push_back(kSphereCentre + kSphereRadius * d.normalized());
  }
  return c;
}

/// Per output point, the distance to its nearest other point and whether that neighbour lies in another tile.
struct Spacing {
  std::vector<double> nearest;
  std::vector<char> acrossSeam;
};

Spacing spacings(const PointCloud& c, const iires::TiledResult& r) {
  const iires::KnnIndex index(c.points);
  Spacing s;
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  auto tileOf = [&](const Vector3d& p) {
    return std::make_pair(static_cast<int>(std::floor((p.x() - r.origin.x()) / r.tileSize)),
                          static_cast<int>(std::floor((p.y() - r.origin.y()) / r.tileSize)));
  };
  for (const Vector3d& p : c.points) {
    index.knn(p, 2, idx, d2);
    s.nearest.push_back(std::sqrt(d2[1]));
    s.acrossSeam.push_back(tileOf(p) != tileOf(c.points[idx[1]]));
  }
  return s;
}

/// Distance from @p p to the nearest interior tile boundary (x or y) of the unit grid.
double toSeam(const Vector3d& p, const iires::TiledResult& r) {
  double d = 1e300;
  for (int a = 0; a < 2; ++a)
    for (int k = 1; k < r.grid[a]; ++k) d = std::min(d, std::abs(p[a] - (r.origin[a] + k * r.tileSize)));
  return d;
}

double cv(const std::vector<double>& v) {
  double mean = 0, var = 0;
  for (double x : v) mean += x;
  mean /= static_cast<double>(v.size());
  for (double x : v) var += (x - mean) * (x - mean);
  return std::sqrt(var / static_cast<double>(v.size())) / mean;
}

std::size_t onSphere(const PointCloud& c) {
  std::size_t n = 0;
  for (const Vector3d& p : c.points) n += std::abs((p - kSphereCentre).norm() - kSphereRadius) < 0.02;
  return n;
}

iires::ResampleParams paramsFor(std::size_t n) {
  iires::ResampleParams p;
  p.targetCount = n;
  return p;
}

iires::TileParams unitTiles(const std::string& scratch) {
  iires::TileParams tp;
  tp.tileSize = 1.0;
  tp.scratchDir = scratch;
  return tp;
}

bool emptyDirectory(const std::string& dir) { return std::filesystem::is_empty(dir); }

TEST(Tiled, EightTilesMatchTheInMemoryRunWithoutSeams) {
  const std::string dir = iires::test::tempDir();
  const PointCloud input = scene(900000, 3);  // 1.0M points
  iires::writePointCloud(dir + "/scene.ply", input);
  constexpr std::size_t kN = 60000;
  const iires::ResampleResult memory = iires::resample(input, paramsFor(kN));
  const std::string scratch = iires::test::tempDir();
  const iires::TiledResult tiled = iires::resampleTiled(dir + "/scene.ply", paramsFor(kN), unitTiles(scratch));
  EXPECT_TRUE(emptyDirectory(scratch)) << "spill files left behind";

  ASSERT_EQ(tiled.cloud.size(), kN);
  ASSERT_EQ(tiled.cloud.normals.size(), kN);
  EXPECT_EQ(tiled.grid[0] * tiled.grid[1] * tiled.grid[2], 8);
  EXPECT_EQ(tiled.inputPoints, input.size());
  const iires::SpacingStats m = iires::spacingStats(memory.cloud.points);
  const iires::SpacingStats t = iires::spacingStats(tiled.cloud.points);
  EXPECT_LT(t.cv, 1.1 * m.cv) << "in memory " << m.cv << ", tiled " << t.cv;
  EXPECT_NEAR(t.mean, m.mean, 0.03 * m.mean);

  const Spacing s = spacings(tiled.cloud, tiled);
  std::vector<double> seam, interior;
  double minAcross = 1e300;
  for (std::size_t i = 0; i < kN; ++i) {
    (toSeam(tiled.cloud.points[i], tiled) < 2 * t.mean ? seam : interior).push_back(s.nearest[i]);
    if (s.acrossSeam[i]) minAcross = std::min(minAcross, s.nearest[i]);
  }
  ASSERT_GT(seam.size(), 500u);
  EXPECT_GE(minAcross, 0.5 * t.mean) << "a near-duplicate pair across a seam";
  EXPECT_LE(cv(seam), 1.1 * cv(interior)) << "seam " << cv(seam) << ", interior " << cv(interior);
  // The sphere lies whole in tile (0,0): it gets its share of N as in memory.
  const double sphere = static_cast<double>(onSphere(memory.cloud));
  EXPECT_NEAR(static_cast<double>(onSphere(tiled.cloud)), sphere, 0.05 * sphere);
  // Tile (3,1) holds no point: no share, nothing produced.
  const iires::TileReport& empty = tiled.tiles[1 * 4 + 3];
  EXPECT_EQ(empty.points, 0u);
  EXPECT_EQ(empty.share, 0u);
  EXPECT_EQ(empty.produced, 0u);
}

// The scene sampled sparsely (3,400 points) and upsampled six times in tiles: each tile's region holds a few
// hundred points beside context samples of its finished neighbours. Those context samples were counted among the
// samples to place when the tile's candidates were thinned, so no free candidate survived, and the count was met
// by adding input points over and over (exact duplicates, spacing cv 0.59 here, 0.26–1.4 on real scans). Now a
// handful of samples by the tiles' open rims lie closer than 0.3 spacings to another, and the spacing is about as
// even as in memory.
TEST(Tiled, SparseInputUpsampledInTilesKeepsItsSamplesApart) {
  const std::string dir = iires::test::tempDir();
  const PointCloud input = scene(3000, 5);
  iires::writePointCloud(dir + "/scene.ply", input);
  constexpr std::size_t kN = 20000;
  const iires::SpacingStats memory = iires::spacingStats(iires::resample(input, paramsFor(kN)).cloud.points);
  const iires::TiledResult tiled = iires::resampleTiled(dir + "/scene.ply", paramsFor(kN), unitTiles(dir));
  ASSERT_EQ(tiled.cloud.size(), kN);
  const iires::SpacingStats t = iires::spacingStats(tiled.cloud.points);
  const Spacing s = spacings(tiled.cloud, tiled);
  const auto close = std::count_if(s.nearest.begin(), s.nearest.end(), [&](double d) { return d < 0.3 * t.mean; });
  EXPECT_LT(close, 100) << "samples on top of each other (of " << kN << ")";
  EXPECT_LT(t.cv, 1.5 * memory.cv) << "in memory " << memory.cv << ", tiled " << t.cv;
}

// A sparse scan (oni: 1,435 points) upsampled in tiles an eighth of its extent wide, about ten points each. At
// 10,000 the tiles overshot their quotas and passed the surplus on, until the last tile of a region held a
// negative quota it could not meet ("a quota of −25"); a tile now keeps at most its quota, dropping its most
// crowded samples. At 5,000 a tile fell short with every neighbour finished ("93 samples for a quota of 98"); the
// shortfall now goes to the nearest tile still to run.
TEST(Tiled, SmallTilesOfASparseScanMeetTheirQuotas) {
  const std::string input = iires::test::dataPath("points_3/oni.ply");
  Eigen::AlignedBox3d box;
  for (const Vector3d& p : iires::readPointCloud(input).points) box.extend(p);
  iires::TileParams tp = unitTiles(iires::test::tempDir());
  tp.tileSize = box.sizes().maxCoeff() / 8;
  for (const std::size_t n : {5000u, 10000u}) {
    const iires::TiledResult r = iires::resampleTiled(input, paramsFor(n), tp, iires::Execution{2});
    ASSERT_EQ(r.cloud.size(), n);
    for (const iires::TileReport& t : r.tiles) EXPECT_GE(t.quota, 0) << "tile " << t.index << ", N = " << n;
  }
}

// A real scan in tiles a quarter of its extent wide, upsampled: the free samples between a tile's points and the
// context samples of its finished neighbours lie on the surface, past the box of the tile's own points, and the
// run failed ("output points left the input's bounding box"). The box holds the context samples too.
TEST(Tiled, FreeSamplesBesideTheContextStayInTheRun) {
  const std::string dir = iires::test::tempDir();
  const std::string input = iires::test::dataPath("points_3/kitten.xyz");
  const PointCloud cloud = iires::readPointCloud(input);
  Eigen::AlignedBox3d box;
  for (const Vector3d& p : cloud.points) box.extend(p);
  iires::TileParams tp = unitTiles(dir);
  tp.tileSize = box.sizes().maxCoeff() / 4;
  const iires::TiledResult r = iires::resampleTiled(input, paramsFor(20000), tp);
  ASSERT_EQ(r.cloud.size(), 20000u);
  EXPECT_LT(iires::spacingStats(r.cloud.points).cv, 0.08);
}

TEST(Tiled, ScratchIsRemovedWhenATileFails) {
  const std::string dir = iires::test::tempDir(), scratch = iires::test::tempDir();
  iires::writePointCloud(dir + "/scene.xyz", scene(30000, 4));
  bool spilled = false;
  iires::Execution exec;
  exec.progress = [&](const std::string& stage, double) {
    if (stage != "tiles") return;
    spilled = !emptyDirectory(scratch);
    throw std::runtime_error("stop");
  };
  EXPECT_THROW(iires::resampleTiled(dir + "/scene.xyz", paramsFor(2000), unitTiles(scratch), exec),
               std::runtime_error);
  EXPECT_TRUE(spilled) << "the spill files were there while the tiles ran";
  EXPECT_TRUE(emptyDirectory(scratch));
}

TEST(Tiled, SameOutputForOneAndTwoThreads) {
  const std::string dir = iires::test::tempDir();
  iires::writePointCloud(dir + "/scene.ply", scene(16000, 5));
  const iires::TiledResult one = iires::resampleTiled(dir + "/scene.ply", paramsFor(1000), unitTiles(dir), iires::Execution{1});
  const iires::TiledResult two = iires::resampleTiled(dir + "/scene.ply", paramsFor(1000), unitTiles(dir), iires::Execution{2});
  ASSERT_EQ(one.cloud.size(), 1000u);
  EXPECT_EQ(one.cloud.points, two.cloud.points);
  EXPECT_EQ(one.cloud.normals, two.cloud.normals);
}

TEST(Tiled, FewerPointsThanTilesStillExact) {
  const std::string dir = iires::test::tempDir();
  iires::writePointCloud(dir + "/scene.ply", scene(20000, 6));
  for (std::size_t n : {1u, 5u, 40u}) {
    iires::TileParams tp = unitTiles(dir);
    tp.tileSize = 0.05;  // raised to two margins: few tiles at such spacings
    const iires::TiledResult r = iires::resampleTiled(dir + "/scene.ply", paramsFor(n), tp);
    EXPECT_EQ(r.cloud.size(), n);
    EXPECT_GE(r.tileSize, 2 * r.margin);
  }
}

TEST(Tiled, AutoTileSizeFollowsTheMemoryBudget) {
  const std::string dir = iires::test::tempDir();
  iires::writePointCloud(dir + "/scene.ply", scene(20000, 7));
  iires::TileParams tp;
  tp.scratchDir = dir;
  const iires::TiledResult whole = iires::resampleTiled(dir + "/scene.ply", paramsFor(1000), tp);
  EXPECT_EQ(whole.grid[0] * whole.grid[1] * whole.grid[2], 1) << "fits the default budget: one tile";
  EXPECT_EQ(whole.cloud.size(), 1000u);
}

/// Spheres of radius 0.3 on a 3 × 3 × 3 lattice of unit step, @p count points in all (a scene whose tiles stack
/// in 3-D: eight colours).
PointCloud sphereLattice(std::size_t count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  PointCloud c;
  for (std::size_t i = 0; i < count; ++i) {
    const Vector3d centre(static_cast<double>(i % 3), static_cast<double>(i / 3 % 3), static_cast<double>(i / 9 % 3));
    c.points.push_back(centre + 0.3 * Vector3d(g(rng), g(rng), g(rng)).normalized());
  }
  return c;
}

TEST(Tiled, AutoTilesLeaveNoRankIdle) {
  // The smallest budget (a tile holds 10⁵ points): the terrain scene's 171k points fit 3 × 2 tiles, where two
  // colours hold one tile each, so a second rank would sit idle through their rounds; the sphere lattice's fit
  // 2 × 2 × 2 tiles, one per colour.
  for (const PointCloud& input : {scene(150000, 11), sphereLattice(170000, 12)}) {
    const std::string dir = iires::test::tempDir();
    iires::writePointCloud(dir + "/scene.ply", input);
    iires::TileParams tp;
    tp.scratchDir = dir;
    tp.memoryBudgetGB = 0.01;
    tp.marginSpacings = 2;
    const iires::TiledResult r = iires::resampleTiled(dir + "/scene.ply", paramsFor(40000), tp, iires::Execution{2});
    ASSERT_EQ(r.cloud.size(), 40000u);
    // No split of the tiles over two ranks can end before the largest tile of each colour, or before half of it.
    std::array<double, 8> largest{}, sum{};
    for (const iires::TileReport& t : r.tiles) {
      largest[t.colour] = std::max(largest[t.colour], static_cast<double>(t.points));
      sum[t.colour] += static_cast<double>(t.points);
    }
    double twoRanks = 0, total = 0;
    for (int c = 0; c < 8; ++c) twoRanks += std::max(largest[c], sum[c] / 2), total += sum[c];
    EXPECT_LE(twoRanks / (total / 2), 1.25) << "on a " << r.grid[0] << "x" << r.grid[1] << "x" << r.grid[2] << " grid";
  }
}

TEST(Tiled, BadInputAndParameters) {
  const std::string dir = iires::test::tempDir();
  EXPECT_THROW(iires::resampleTiled(dir + "/missing.ply", paramsFor(10), unitTiles(dir)), iires::InputError);
  iires::writePointCloud(dir + "/scene.ply", scene(5000, 8));
  iires::TileParams tp = unitTiles(dir + "/no-such-dir");
  EXPECT_THROW(iires::resampleTiled(dir + "/scene.ply", paramsFor(10), tp), iires::InputError);
  tp = unitTiles(dir);
  tp.memoryBudgetGB = 0;
  EXPECT_THROW(iires::resampleTiled(dir + "/scene.ply", paramsFor(10), tp), std::invalid_argument);
}

TEST(Tiled, ToolWritesExactlyNOrNothing) {
  const std::string dir = iires::test::tempDir(), scratch = iires::test::tempDir();
  iires::writePointCloud(dir + "/in.ply", scene(8000, 9));
  const std::string tool = iires::test::tool("iires-resample") + " " + dir + "/in.ply " + dir + "/out.ply -n 500 -q ";
  std::string output;
  EXPECT_EQ(iires::test::run(tool + "--tiles 1.0 --scratch " + scratch, &output), 0) << output;
  EXPECT_EQ(iires::readPointCloud(dir + "/out.ply").size(), 500u);
  EXPECT_TRUE(emptyDirectory(scratch));
  std::filesystem::remove(dir + "/out.ply");
  for (const std::string& bad : std::vector<std::string>{"--tiles nope", "--tiles -1", "--tiles 1 --scratch " + dir + "/missing",
                                "--tiles auto --memory 0", "--tiles 1 --sharp-edges"}) {
    EXPECT_EQ(iires::test::run(tool + bad, &output), 2) << bad << ": " << output;
    EXPECT_NE(output.find("error"), std::string::npos) << output;
    EXPECT_FALSE(iires::test::fileExists(dir + "/out.ply")) << bad;
  }
  // A file the stream reader rejects: the message names it once.
  const std::string broken = dir + "/broken.ply";
  std::ofstream(broken) << "ply\nformat nonsense\n";
  EXPECT_EQ(iires::test::run(iires::test::tool("iires-resample") + " " + broken + " " + dir + "/out.ply -n 500 --tiles 1",
                             &output), 2) << output;
  const std::size_t first = output.find(broken);
  ASSERT_NE(first, std::string::npos) << output;
  EXPECT_EQ(output.find(broken, first + 1), std::string::npos) << output;
}

/// `mpiexec -n R` as the MPI test runs it: as root too, and with more ranks than cores (OpenMPI's switches,
/// given as environment variables, which other MPIs ignore).
std::string mpiexec(int ranks) {
#ifdef IIRES_MPIEXEC
  return "env OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1 " +
         std::string(IIRES_MPIEXEC) + " -n " + std::to_string(ranks) + " ";
#else
  return std::to_string(ranks) + " ";
#endif
}

TEST(Tiled, MpiRanksWriteTheBytesOfTheSingleProcessRun) {
#ifndef IIRES_MPIEXEC
  GTEST_SKIP() << "built without MPI (configure with -DIIRES_WITH_MPI=ON)";
#endif
  const std::string mpiTool = iires::test::tool("iires-resample-mpi");
  std::string output;
  if (iires::test::run(mpiexec(2) + mpiTool + " --version", &output) != 0)
    GTEST_SKIP() << "mpiexec cannot start two ranks here: " << output;
  const std::string dir = iires::test::tempDir(), scratch = iires::test::tempDir();
  iires::writePointCloud(dir + "/in.ply", scene(12000, 10));
  const std::string args = " " + dir + "/in.ply " + dir + "/%.ply -n 800 -q --tiles 1.0 --memory 1 --scratch " + scratch;
  auto command = [&](const std::string& tool, const std::string& out) {
    std::string c = tool + args;
    c.replace(c.find('%'), 1, out);
    return c;
  };
  ASSERT_EQ(iires::test::run(command(iires::test::tool("iires-resample"), "one") + " --threads 2", &output), 0)
      << output;
  const std::string one = iires::test::readText(dir + "/one.ply");
  ASSERT_EQ(iires::readPointCloud(dir + "/one.ply").size(), 800u);
  for (int ranks : {2, 3, 4}) {  // 4: more ranks than cores (oversubscribed)
    const std::string out = "ranks" + std::to_string(ranks);
    const std::string report = dir + "/" + out + ".json";
    ASSERT_EQ(iires::test::run(mpiexec(ranks) + command(mpiTool, out) + " --threads 1 --report " + report, &output),
              0) << output;
    EXPECT_TRUE(iires::test::readText(dir + "/" + out + ".ply") == one) << ranks << " ranks: other bytes";
    // the report names the rank that resampled each tile: rank 1 had its share
    EXPECT_NE(iires::test::readText(report).find("\"rank\": 1,"), std::string::npos) << iires::test::readText(report);
  }
  EXPECT_TRUE(emptyDirectory(scratch)) << "spill files left behind";
  // A failure stops every rank with a message and exit code 2, and nothing is written.
  EXPECT_EQ(iires::test::run(mpiexec(2) + mpiTool + " " + dir + "/missing.ply " + dir + "/bad.ply -n 10", &output), 2)
      << output;
  EXPECT_NE(output.find("rank 1"), std::string::npos) << output;
  EXPECT_FALSE(iires::test::fileExists(dir + "/bad.ply"));
}

}  // namespace

