// SPDX-License-Identifier: GPL-3.0-or-later
// Tests for geodesic.hpp: graph distances against exact geodesics, components and satellites, thin gaps,
// determinism, validation, export.
#include "iires/geodesic.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "iires/io.hpp"
#include "shapes.hpp"
#include "test_util.hpp"

namespace iires {
namespace {

using test::uStrip;

double greatCircle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.dot(b), -1.0, 1.0));
}

/// Mean relative error of the single-source fields from a few sources against great-circle distances.
double sphereError(const GeodesicCoordinates& g, const PointCloud& c, bool fastMarching) {
  double sum = 0;
  std::size_t count = 0;
  for (std::uint32_t src : {0u, 4321u, 17777u}) {
    const std::vector<float> f = g.distanceField(src, fastMarching);
    for (std::size_t i = 0; i < c.size(); ++i) {
      const double exact = greatCircle(c.points[i], c.points[src]);
      if (i == src || exact <= 0) continue;
      sum += std::abs(f[i] - exact) / exact;
      ++count;
    }
  }
  return sum / static_cast<double>(count);
}

// Acceptance (issue 3): on a 20k-point unit sphere the geodesic distances from a point are within a mean
// relative error of 3 % of the exact great-circle distances. Measured (k = 16, mutual graph, random
// sampling, sources 0/4321/17777): 0.70 % with the fast-marching segment updates, 2.4 % with plain Dijkstra
// on the same graph (which always overestimates: zig-zag paths).
TEST(Geodesic, SphereMatchesGreatCircleDistances) {
  PointCloud c = test::sphereCloud(20000, 1.0, 7);
  c.normals.clear();  // PCA normals inside
  const GeodesicCoordinates g(c);
  EXPECT_EQ(g.components(), 1u);
  const double fm = sphereError(g, c, true), plain = sphereError(g, c, false);
  std::printf("sphere 20k: mean relative error %.3f %% (fast marching), %.3f %% (plain Dijkstra)\n", 100 * fm,
              100 * plain);
  EXPECT_LE(fm, 0.03);
  EXPECT_LT(fm, plain);
  // The coordinates are the satellites' fields.
  for (int s = 0; s < 3; ++s) {
    const std::uint32_t sat = g.satellites(0)[static_cast<std::size_t>(s)];
    const std::vector<float> f = g.distanceField(sat);
    for (std::size_t i = 0; i < c.size(); i += 97) EXPECT_EQ(g.coordinate(i, s), f[i]);
    EXPECT_EQ(g.coordinate(sat, s), 0.0f);
  }
}

// Scan coordinates: a small object 1e7 from the origin gets the same graph and coordinates as at the origin
// (the float copy used by the sweeps must not round its spacing away).
TEST(Geodesic, FarFromTheOriginLikeAtTheOrigin) {
  const PointCloud near = test::sphereCloud(4000, 1.0, 9);
  PointCloud far = near;
  for (auto& p : far.points) p += Eigen::Vector3d(1e7, -2e7, 1e7);
  const GeodesicCoordinates a(near), b(far);
  EXPECT_EQ(b.components(), 1u);
  EXPECT_EQ(a.components(), b.components());
  double worst = 0;
  for (std::size_t i = 0; i < near.size(); ++i)
    for (int s = 0; s < a.dimensions(); ++s)
      worst = std::max(worst, double(std::abs(a.coordinate(i, s) - b.coordinate(i, s))));
  EXPECT_LT(worst, 0.01);  // unit sphere: geodesic distances up to π
}

// Scan lines (dense along, sparse across): the graph links each point to the next lines too, so the distance to
// a point on a line nearby is about the straight one (worst 1.08 here); with the k nearest alone the lines were
// linked only where jitter brought two within reach, and those distances detoured along the lines (15×).
TEST(Geodesic, ScanLinesAreLinkedAcross) {
  const PointCloud cloud = test::scanLineCloud(3);
  const GeodesicCoordinates geo(cloud);
  EXPECT_EQ(geo.components(), 1u);
  const std::uint32_t source = 25 * 500 + 250;  // line 25, middle
  const std::vector<float> field = geo.distanceField(source);
  double worst = 0;
  for (int line = 20; line <= 30; ++line)
    for (int a = 200; a <= 300; a += 10) {
      const std::size_t j = static_cast<std::size_t>(line) * 500 + static_cast<std::size_t>(a);
      if (j == source) continue;
      worst = std::max(worst, field[j] / (cloud.points[j] - cloud.points[source]).norm());
    }
  EXPECT_LT(worst, 1.5) << "geodesic over straight-line distance";
}

// A profile scanner's 20 slices of a cube: the contours' corners (where a contour turns 90° the line test fails)
// sample the surface as coarsely as the lines beside them — no point's sampling scale is under half the median
// (the corners' points had scale 1: the intrinsic rule's tolerance was a few spacings along the contours there,
// and rejected neighbours across them).
TEST(Geodesic, ScanLineCornersTakeTheLinesScale) {
  const PointCloud cloud = test::sliceContours(test::cubeMesh(), 20, 1);
  const GeodesicCoordinates geo(cloud);
  std::vector<float> scale = geo.samplingScales();
  ASSERT_EQ(scale.size(), cloud.size());
  std::sort(scale.begin(), scale.end());
  EXPECT_GT(scale.front(), 0.5f * scale[scale.size() / 2]);
  EXPECT_GT(scale.front(), 5.0f);  // the contours lie ten spacings apart
}

TEST(Geodesic, SatellitesAreFarApart) {
  PointCloud c = test::sphereCloud(8000, 1.0, 3);
  const GeodesicCoordinates g(c);
  const auto& sat = g.satellites(0);
  ASSERT_EQ(sat.size(), 3u);
  // Satellite 2 is (nearly) antipodal to satellite 1; satellite 3 lies on (near) their bisecting great circle.
  EXPECT_GT(greatCircle(c.points[sat[0]], c.points[sat[1]]), 0.95 * M_PI);
  EXPECT_GT(greatCircle(c.points[sat[2]], c.points[sat[0]]), 0.4 * M_PI);
  EXPECT_GT(greatCircle(c.points[sat[2]], c.points[sat[1]]), 0.4 * M_PI);
}

TEST(Geodesic, FieldsAreLipschitzOnGraphEdges) {
  PointCloud c = test::sphereCloud(5000, 2.0, 11);
  const GeodesicCoordinates g(c);
  for (const auto& e : g.edges()) {
    const double len = (c.points[e[0]] - c.points[e[1]]).norm();
    for (int s = 0; s < 3; ++s)
      ASSERT_LE(std::abs(g.coordinate(e[0], s) - g.coordinate(e[1], s)), len * (1 + 1e-5) + 1e-6);
  }
}

// Two spheres of radius 0.5, 0.01 apart (20k points each, spacing ≈ 0.006): two components, each with its
// own satellites, no graph edge between them.
TEST(Geodesic, TwoSpheresAreTwoComponents) {
  PointCloud a = test::sphereCloud(20000, 0.5, 5, Eigen::Vector3d(-0.505, 0, 0));
  const PointCloud b = test::sphereCloud(20000, 0.5, 6, Eigen::Vector3d(0.505, 0, 0));
  a.points.insert(a.points.end(), b.points.begin(), b.points.end());
  a.normals.insert(a.normals.end(), b.normals.begin(), b.normals.end());
  const GeodesicCoordinates g(a);
  ASSERT_EQ(g.components(), 2u);
  EXPECT_EQ(g.componentSize(0), 20000u);
  EXPECT_EQ(g.componentSize(1), 20000u);
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(g.component(i), i < 20000 ? 0u : 1u);
  for (std::size_t c = 0; c < 2; ++c)
    for (std::uint32_t s : g.satellites(c)) EXPECT_EQ(g.component(s), c);
  for (const auto& e : g.edges()) ASSERT_EQ(e[0] < 20000, e[1] < 20000);
  // Distances do not leak into the other component.
  const std::vector<float> f = g.distanceField(0);
  EXPECT_TRUE(std::isinf(f[30000]));
  EXPECT_TRUE(std::isfinite(f[10000]));
}

// The U-strip of issue 3 (gap 0.02, 40k random points per square, spacing ≈ 0.0025): one component, no
// graph edge across the gap, and distances that go round the fold.
class UStrip : public ::testing::TestWithParam<bool> {};

TEST_P(UStrip, GraphFollowsTheFold) {
  PointCloud c = uStrip(40000, 0.02, 3);
  if (!GetParam()) c.normals.clear();
  const GeodesicCoordinates g(c);
  EXPECT_EQ(g.components(), 1u);
  EXPECT_NEAR(g.spacing(), 0.0025, 0.0006);
  std::size_t across = 0;
  for (const auto& e : g.edges()) {
    const Eigen::Vector3d &p = c.points[e[0]], &q = c.points[e[1]];
    if ((p.z() < 0.01) != (q.z() < 0.01) && std::max(p.x(), q.x()) < 1.0) ++across;
  }
  EXPECT_EQ(across, 0u);
  // From the middle of the bottom square to the point above it: 0.5 + π·0.01 + 0.5 round the fold.
  std::uint32_t below = 0, above = 0;
  double bestBelow = 1e9, bestAbove = 1e9;
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double db = (c.points[i] - Eigen::Vector3d(0.5, 0.5, 0)).norm();
    const double da = (c.points[i] - Eigen::Vector3d(0.5, 0.5, 0.02)).norm();
    if (db < bestBelow) bestBelow = db, below = static_cast<std::uint32_t>(i);
    if (da < bestAbove) bestAbove = da, above = static_cast<std::uint32_t>(i);
  }
  const std::vector<float> f = g.distanceField(below);
  EXPECT_NEAR(f[above], 1.0 + M_PI * 0.01, 0.03 * (1.0 + M_PI * 0.01));
  // G separates the two sheets: a point and the one straight across differ by far more than 0.02.
  double maxJump = 0;
  for (int s = 0; s < 3; ++s) maxJump = std::max(maxJump, double(std::abs(g.coordinate(below, s) - g.coordinate(above, s))));
  EXPECT_GT(maxJump, 0.5);
}

INSTANTIATE_TEST_SUITE_P(WithAndWithoutNormals, UStrip, ::testing::Bool());

// Neighbour lists borrowed from a table over the caller's (unsorted) order give the graph of the own search.
TEST(Geodesic, BorrowedNeighbourTableGivesTheSameCoordinates) {
  const PointCloud c = uStrip(15000, 0.05, 9);
  const iires::KnnIndex index(c.points);
  const iires::NeighbourTable table(index, c.points, 17);
  const GeodesicCoordinates own(c), borrowed(c, {}, {}, &table);
  EXPECT_EQ(own.edges(), borrowed.edges());
  EXPECT_EQ(own.coordinates(), borrowed.coordinates());
  const iires::NeighbourTable tooShort(index, c.points, 8);  // fewer than k + 1: not used
  EXPECT_EQ(GeodesicCoordinates(c, {}, {}, &tooShort).coordinates(), own.coordinates());
}

// Work handed to the constructor runs once (beside the sweeps when a thread is idle), leaves the coordinates
// as they are, and its exception reaches the caller.
TEST(Geodesic, RunsIndependentWorkAlongsideTheSweeps) {
  const PointCloud c = uStrip(8000, 0.05, 9);
  GeodesicParams p;
  const GeodesicCoordinates plain(c, p);
  for (int threads : {1, 2}) {
    int calls = 0, given = 0;
    const GeodesicCoordinates g(c, p, Execution{threads}, nullptr, [&](int t, const KnnIndex*, const std::vector<float>&) {
      ++calls, given = t;
    });
    EXPECT_EQ(calls, 1);
    EXPECT_EQ(given, 1)
        << "one component: one thread sweeps, the other is free (or, on one thread, after it)";
    EXPECT_EQ(g.coordinates(), plain.coordinates());
    EXPECT_THROW(
        GeodesicCoordinates(c, p, {}, nullptr,
                            [](int, const KnnIndex*, const std::vector<float>&) {
                              throw std::runtime_error("alongside failed");
                            }),
        std::runtime_error);
  }
}

// The work beside the sweeps gets the graph's k-d tree when the cloud comes in Z-order (it then indexes the
// cloud's own order), else none.
TEST(Geodesic, AlongsideGetsThePointIndexOfAZOrderedCloud) {
  const PointCloud c = uStrip(8000, 0.05, 9);
  PointCloud z;
  for (std::uint32_t i : mortonOrder(c.points)) z.points.push_back(c.points[i]);
  for (const bool ordered : {false, true}) {
    const PointCloud& cloud = ordered ? z : c;
    const KnnIndex* seen = nullptr;
    std::int64_t nearest = -1;
    const GeodesicCoordinates g(cloud, {}, {}, nullptr, [&](int, const KnnIndex* index, const std::vector<float>&) {
      seen = index;
      if (index) nearest = index->nearest(cloud.points[1234]);
    });
    EXPECT_EQ(seen != nullptr, ordered);
    if (ordered) {
      EXPECT_EQ(seen->size(), cloud.size());
      EXPECT_EQ(nearest, 1234);
    }
  }
}

TEST(Geodesic, DeterministicForAnyThreadCount) {
  PointCloud c = uStrip(15000, 0.05, 9);
  GeodesicParams p;
  const GeodesicCoordinates g1(c, p, Execution{1});
  const GeodesicCoordinates g2(c, p, Execution{2});
  EXPECT_EQ(g1.coordinates(), g2.coordinates());
  EXPECT_EQ(g1.componentIds(), g2.componentIds());
  EXPECT_EQ(g1.satellites(0), g2.satellites(0));
  EXPECT_EQ(g1.edges(), g2.edges());
}

TEST(Geodesic, TinyComponentsAreAttached) {
  PointCloud c = test::sphereCloud(3000, 1.0, 4);
  c.normals.clear();
  c.points.emplace_back(3, 0, 0);  // an isolated speck of three points
  c.points.emplace_back(3.01, 0, 0);
  c.points.emplace_back(3, 0.01, 0);
  const GeodesicCoordinates g(c);
  EXPECT_EQ(g.components(), 1u);
  EXPECT_EQ(g.report().attachedComponents, 1u);
  for (int s = 0; s < 3; ++s) EXPECT_TRUE(std::isfinite(g.coordinate(c.size() - 1, s)));
  GeodesicParams p;
  p.minComponentSize = 0;  // keep them apart
  const GeodesicCoordinates h(c, p);
  EXPECT_EQ(h.components(), 2u);
  EXPECT_EQ(h.componentSize(1), 3u);
}

TEST(Geodesic, ValidatesInput) {
  EXPECT_THROW(GeodesicCoordinates(PointCloud{}), InputError);
  PointCloud bad = test::sphereCloud(100);
  bad.points[5].x() = std::nan("");
  EXPECT_THROW(GeodesicCoordinates{bad}, InputError);
  GeodesicParams p;
  p.k = 1;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.spacingNeighbour = 40;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.satellites = 0;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.maxEdgeSlopeDeg = 0;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  EXPECT_THROW(Execution{-1}.validate(), std::invalid_argument);
  EXPECT_NO_THROW(GeodesicParams{}.validate());
  // A single point: one component, coordinates 0.
  PointCloud one;
  one.points.emplace_back(1, 2, 3);
  const GeodesicCoordinates g(one);
  EXPECT_EQ(g.components(), 1u);
  EXPECT_EQ(g.coordinate(0, 2), 0.0f);
}

TEST(Geodesic, ExportsPlyWithCoordinates) {
  const PointCloud c = test::sphereCloud(500, 1.0, 2);
  const GeodesicCoordinates g(c);
  const std::string dir = test::tempDir();
  const std::string path = dir + "/geo.ply";
  writeGeodesicPly(path, g);
  const std::string text = test::readText(path);
  EXPECT_NE(text.find("property float g1\nproperty float g2\nproperty float g3\nproperty uint component\n"),
            std::string::npos);
  const std::size_t body = text.find("end_header\n") + 11;
  EXPECT_EQ(text.size() - body, 500u * (48 + 12 + 4));
  const PointCloud back = readPointCloud(path);  // any PLY reader skips the extra properties
  ASSERT_EQ(back.size(), 500u);
  EXPECT_EQ(back.points[17], c.points[17]);
  // The coordinates and component ids come back as the reader's attributes, in their types.
  ASSERT_EQ(back.attributes.size(), 4u);
  for (int s = 0; s < 3; ++s) {
    EXPECT_EQ(back.attributes[static_cast<std::size_t>(s)].name, "g" + std::to_string(s + 1));
    EXPECT_EQ(back.attributes[static_cast<std::size_t>(s)].type, "float");
    for (std::size_t i : {0u, 17u, 499u})
      EXPECT_EQ(back.attributes[static_cast<std::size_t>(s)].values[i], g.coordinate(i, s));
  }
  EXPECT_EQ(back.attributes[3].name, "component");
  EXPECT_EQ(back.attributes[3].type, "uint");
  EXPECT_EQ(back.attributes[3].values[17], g.component(17));
  EXPECT_THROW(writeGeodesicPly(dir + "/missing/geo.ply", g), InputError);
  EXPECT_THROW(writeGeodesicPly(dir + "/geo.xyz", g), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir + "/geo.xyz"));
}

}  // namespace
}  // namespace iires
