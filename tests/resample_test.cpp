// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/resample.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "shapes.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "iires/sampling.hpp"

namespace {

iires::ResampleParams paramsFor(std::size_t n) {
  iires::ResampleParams p;
  p.targetCount = n;
  return p;
}

double maxRadiusError(const iires::PointCloud& c) {
  double worst = 0;
  for (const auto& p : c.points) worst = std::max(worst, std::abs(p.norm() - 1.0));
  return worst;
}

TEST(Resample, ExactCountOnSphereForManyN) {
  const auto cloud = iires::test::sphereCloud(20000, 1.0, 21);
  for (std::size_t n : {1u, 4u, 37u, 1000u, 4999u}) {
    const auto r = iires::resample(cloud, paramsFor(n));
    EXPECT_EQ(r.cloud.size(), n);
    EXPECT_EQ(r.cloud.normals.size(), n);
    EXPECT_LT(maxRadiusError(r.cloud), 1e-3) << "N = " << n;
    EXPECT_TRUE(r.ringEdges.empty()) << "only filled when asked for";
  }
}

TEST(Resample, UniformOnSphereAndOnTheSurface) {
  const auto cloud = iires::test::sphereCloud(30000, 1.0, 22);
  const auto r = iires::resample(cloud, paramsFor(3000));
  ASSERT_EQ(r.cloud.size(), 3000u);
  EXPECT_LT(r.spacing.cv, 0.08);
  EXPECT_LT(maxRadiusError(r.cloud), 2e-4);
  for (std::size_t i = 0; i < r.cloud.size(); ++i)
    EXPECT_GT(r.cloud.normals[i].dot(r.cloud.points[i]), 0.99);
  // Hexagonal packing of N points on area 4π: spacing sqrt(2A / (√3 N)). The nearest-neighbour distance is the
  // shortest of ~6 edges whose lengths vary by ~5 %, so it sits ~1.3σ ≈ 6–8 % below the mean edge (0.92 here).
  const double ideal = std::sqrt(2.0 * 4.0 * M_PI / (std::sqrt(3.0) * 3000.0));
  EXPECT_GT(r.spacing.mean, 0.90 * ideal);
  EXPECT_LT(r.spacing.mean, 1.00 * ideal);
}

TEST(Resample, NonUniformOpenPlaneBecomesUniform) {
  const auto cloud = iires::test::planeCloud(40000, 1.0, 6.0);
  const auto r = iires::resample(cloud, paramsFor(2000));
  ASSERT_EQ(r.cloud.size(), 2000u);
  EXPECT_LT(r.spacing.cv, 0.08);
  // Equal shares left and right of x = 0.5 although the input density differs ~4× between the halves.
  std::size_t left = 0;
  for (const auto& p : r.cloud.points) {
    EXPECT_NEAR(p.z(), 0.0, 1e-9);
    EXPECT_GT(p.x(), -0.02);
    EXPECT_LT(p.x(), 1.02);
    left += p.x() < 0.5;
  }
  EXPECT_NEAR(static_cast<double>(left) / 2000.0, 0.5, 0.03);
}

// A floor as one scanner 1 above its corner sees it: the density falls with the range (∝ cos θ / r²), 14 times
// more sparsely spaced at the far corner than at the median. Resampled so that the far part is upsampled, its
// samples must still see each other as neighbours: where the tolerance of the intrinsic rule stayed at the
// cloud's median spacing, they were refused one another (their nearest input points a far spacing apart differ
// in geodesic coordinates by that much) and piled up (at this size 194 pairs under 0.3 spacings, cv 0.27).
TEST(Resample, FarSideOfOneScanIsUpsampledWithoutClumps) {
  const auto r = iires::resample(iires::test::floorFromCorner(20000), paramsFor(6000));
  ASSERT_EQ(r.cloud.size(), 6000u);
  const iires::KnnIndex index(r.cloud.points);
  std::size_t close = 0;
  for (const auto& p : r.cloud.points) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.knn(p, 2, idx, d2);
    close += std::sqrt(d2[1]) < 0.3 * r.spacing.mean;
  }
  EXPECT_EQ(close, 0u);
  EXPECT_LT(r.spacing.cv, 0.15);
}

TEST(Resample, UpsamplesToExactCount) {
  const auto cloud = iires::test::sphereCloud(600, 1.0, 23);
  const auto r = iires::resample(cloud, paramsFor(5000));
  ASSERT_EQ(r.cloud.size(), 5000u);
  EXPECT_LT(r.spacing.cv, 0.08);
  EXPECT_LT(maxRadiusError(r.cloud), 5e-3);
}

TEST(Resample, SameOutputForAnyThreadCountAndSeedMatters) {
  const auto cloud = iires::test::planeCloud(20000, 1.0, 3.0);
  const auto a = iires::resample(cloud, paramsFor(1500), iires::Execution{1});
  const auto b = iires::resample(cloud, paramsFor(1500), iires::Execution{2});
  EXPECT_EQ(a.cloud.points, b.cloud.points);
  EXPECT_EQ(a.cloud.normals, b.cloud.normals);
  auto p = paramsFor(1500);
  p.seed = 99;
  EXPECT_NE(iires::resample(cloud, p).cloud.points, a.cloud.points);
}

TEST(Resample, FixedSamplesStayPut) {
  const auto cloud = iires::test::sphereCloud(20000, 1.0, 24);
  auto p = paramsFor(800);
  p.fixedSamples = {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 0, -1)};
  const auto r = iires::resample(cloud, p);
  ASSERT_EQ(r.cloud.size(), 800u);
  for (const auto& f : p.fixedSamples)
    EXPECT_NE(std::find(r.cloud.points.begin(), r.cloud.points.end(), f), r.cloud.points.end());
}

// Two objects 0.01 apart (radii 0.5 and 0.35, input spacing ≈ 0.009): two components, never linked by a
// 1-ring edge, and the samples shared in proportion to area (0.25 : 0.1225).
TEST(Resample, TwoNearlyTouchingSpheresSplitByArea) {
  const Eigen::Vector3d smallCentre(0.86, 0, 0);
  auto cloud = iires::test::sphereCloud(20000, 0.5, 31);
  const auto small = iires::test::sphereCloud(9800, 0.35, 32, smallCentre);
  cloud.points.insert(cloud.points.end(), small.points.begin(), small.points.end());
  cloud.normals.insert(cloud.normals.end(), small.normals.begin(), small.normals.end());
  auto params = paramsFor(2000);
  params.ringEdges = true;
  const auto r = iires::resample(cloud, params);
  ASSERT_EQ(r.cloud.size(), 2000u);
  EXPECT_EQ(r.components, 2u);
  EXPECT_GT(r.ringEdges.size(), 5000u);
  auto onSmall = [&](std::uint32_t i) { return (r.cloud.points[i] - smallCentre).norm() < 0.355; };
  std::size_t count = 0;
  for (std::uint32_t i = 0; i < 2000; ++i) count += onSmall(i);
  EXPECT_NEAR(static_cast<double>(count) / 2000.0, 0.1225 / 0.3725, 0.02);
  for (const auto& e : r.ringEdges) EXPECT_EQ(onSmall(e[0]), onSmall(e[1])) << "a 1-ring edge links the spheres";
}

// Objects at different densities (a tenth of the points on nine times the area): the samples split by area
// and are evenly spaced on both. Every stage used to read the sparse sphere at the dense one's scale — kernel
// widths and the area cut at the cloud's 90th percentile, the initial samples eliminated to N among the input
// points (the sparse sphere has fewer than its share), the neighbour rule's tolerance below the samples'
// distance to their nearest input point: 1,070 samples on the small sphere instead of 200, cv 0.48.
TEST(Resample, SeparateObjectsAtDifferentDensitiesSplitByArea) {
  const auto cloud = iires::test::twoDensitySpheres(10000, 41);
  const auto r = iires::resample(cloud, paramsFor(2000));
  ASSERT_EQ(r.cloud.size(), 2000u);
  std::size_t onSparse = 0;
  double worst = 0;
  for (const auto& p : r.cloud.points) {
    const bool sparse = p.x() > 5;
    onSparse += sparse;
    worst = std::max(worst, sparse ? std::abs((p - Eigen::Vector3d(10, 0, 0)).norm() - 3.0) / 3.0
                                   : std::abs(p.norm() - 1.0));
  }
  EXPECT_NEAR(static_cast<double>(onSparse) / 2000.0, 0.9, 0.02);
  EXPECT_LT(r.spacing.cv, 0.08);
  EXPECT_LT(worst, 2e-3);
}

// A lidar's scan lines (0.02 apart, points 0.002 apart along them, positions only) resampled to an output spacing
// about the lines' distance and half of it: one part, evenly spaced. The intrinsic rule used to keep samples of
// neighbouring lines from seeing each other (the geodesic graph linked the lines only here and there; cv 0.31 at
// 2,000); then, with every other stage's neighbours on one line, the normals' orientation split the cloud in two
// and the MLS kernel and the projections' fits did not reach the next line (10,000: cv 0.117).
TEST(Resample, ScanLinesResampledEvenly) {
  for (std::size_t n : {2000, 10000}) {  // output spacing about and half the lines' spacing
    const auto r = iires::resample(iires::test::scanLineCloud(4), paramsFor(n));
    ASSERT_EQ(r.cloud.size(), n);
    EXPECT_EQ(r.components, 1u) << n;
    EXPECT_LT(r.spacing.cv, 0.08) << n;
    EXPECT_GT(r.scanLinePoints, 23000u) << n;  // of 25,000; the lines' ends reach the next lines anyway
  }
  EXPECT_EQ(iires::resample(iires::test::sphereCloud(5000), paramsFor(500)).scanLinePoints, 0u);
  // Noisy (denoising moves the points) and with straight-line neighbourhoods: the table the MLS surface reads is
  // built again on the moved points, across the lines too (cv 0.101 when it was left out).
  iires::PointCloud noisy = iires::test::scanLineCloud(4);
  std::mt19937_64 rng(8);
  std::normal_distribution<double> g(0.0, 0.0006);
  for (auto& p : noisy.points) p.z() += g(rng);
  iires::ResampleParams p = paramsFor(5000);
  p.intrinsic = false;
  const auto r = iires::resample(noisy, p);
  EXPECT_FALSE(r.preprocessing.cleanInput);
  EXPECT_LT(r.spacing.cv, 0.08);
}

// A rotating scanner's rings on the ground (positions only; rings 0.15 apart near the sensor and 1.1 apart at the
// outer ones, points 0.015–0.05 apart along them) resampled to 2,000 (output spacing about 0.4): one part, even
// density from the inner rings to the outer. With every stage's neighbours on one ring there was no result
// (samples left the input's box); with rows across the rings, the passes at N stopped while the samples still
// crowded the dense inner rings (cv 0.104; 0.061 now, the band beyond radius 7 within 0.02 of its share). At 5,000
// (seed 3) the passes at N stopped at cv 0.28 with the outer band 39 % short, its cv still falling by 5–6 % a pass.
TEST(Resample, ScannerRingsOnTheGroundResampledEvenly) {
  for (const auto& [seed, n] : {std::pair<std::uint64_t, std::size_t>{2, 2000}, {3, 5000}}) {
    const iires::PointCloud cloud = iires::test::groundRings(seed);
    const auto r = iires::resample(cloud, paramsFor(n));
    ASSERT_EQ(r.cloud.size(), n);
    EXPECT_EQ(r.components, 1u);
    EXPECT_LT(r.spacing.cv, 0.08) << "seed " << seed;
    // The band beyond radius 7 holds its share of the area (the rings span radius 2.9 to 9.7).
    const double inner = 1.7 / std::tan(30.0 * M_PI / 180.0), outer = 1.7 / std::tan(10.0 * M_PI / 180.0);
    std::size_t far = 0;
    for (const auto& p : r.cloud.points) far += p.head<2>().norm() > 7.0;
    const double share = (outer * outer - 49.0) / (outer * outer - inner * inner);
    EXPECT_NEAR(static_cast<double>(far) / static_cast<double>(n), share, 0.05) << "seed " << seed;
  }
}

// A profile scanner's 30 slices of a torus across its ring (positions only; contours 0.093 apart, points a tenth
// of that apart along them): where the tube turns parallel to the planes the contours lie far apart, where a
// plane grazes the tube they turn tightly. One part, even spacing, whatever links the contours:
// - rows across the contours link them one way only (their points' own rows list their nearest on this
//   contour): kept (dropped as not mutual: cv 0.11–0.30);
// - with points 0.15 of the contours' distance apart along them a point's 16 nearest reach the next contour:
//   the line test reads 8 too (with 16 only, under half the points passed it: cv 0.19–0.20);
// - with noise of half the spacing along the contours 8 nearest do not show the line: the test reads 16 too
//   (with 8 only, a third of the points failed it: cv 0.12–0.13).
TEST(Resample, ProfileSlicesResampledEvenly) {
  struct Case {
    double tube, step, noise;
  };
  for (const Case c : {Case{0.4, 0.1, 0.03}, Case{0.4, 0.15, 0.03}, Case{0.4, 0.1, 0.5}}) {
    const iires::PointCloud cloud =
        iires::test::sliceContours(iires::test::torusMesh(1.0, c.tube, 96, 48), 30, 3, c.step, c.noise);
    for (std::size_t n : {1000, 3000}) {
      const auto r = iires::resample(cloud, paramsFor(n));
      SCOPED_TRACE(testing::Message() << "tube " << c.tube << " step " << c.step << " noise " << c.noise
                                      << " N " << n);
      ASSERT_EQ(r.cloud.size(), n);
      EXPECT_EQ(r.components, 1u);
      EXPECT_LT(r.spacing.cv, 0.08);
      EXPECT_GT(r.scanLinePoints, 9 * cloud.size() / 10);
    }
  }
}

// A thin plate's two faces scanned by lines 0.02 apart, the gap 0.75 and 1.5 times that: the faces stay apart
// (every output point on one of them, each with half the samples). The line distance is no resolution along
// the normal: read as the sheet rule's spacing it hid the gap (the faces merged, or the resampling failed).
TEST(Resample, ScannedThinPlateKeepsItsFacesApart) {
  for (double gap : {0.015, 0.03}) {
    SCOPED_TRACE(gap);
    const iires::PointCloud cloud = iires::test::scannedSheets(gap, 2);
    iires::ResampleResult r;
    ASSERT_NO_THROW(r = iires::resample(cloud, paramsFor(3000)));
    ASSERT_EQ(r.cloud.size(), 3000u);
    EXPECT_GT(r.scanLinePoints, 0u);
    std::size_t off = 0, low = 0;
    for (const auto& p : r.cloud.points) {
      off += std::min(std::abs(p.z()), std::abs(p.z() - gap)) > 0.1 * gap;
      low += std::abs(p.z()) < std::abs(p.z() - gap);
    }
    EXPECT_LE(off, 15u);  // 0.5 %
    EXPECT_NEAR(static_cast<double>(low) / 3000.0, 0.5, 0.02);
  }
}

// A sparse open tube (mesh-vertex-like rings of 24 points, 0.065 apart, the end rings exactly at z = 0 and
// z = 1) upsampled ten times: samples stay within a quarter input spacing of the open ends, where the MLS
// surface would carry on along the tube (it used to put samples 1.5 input spacings past them, like the CGAL
// hand's wrist), and on the tube.
TEST(Resample, UpsampledSparseTubeEndsStayAtTheInputsRims) {
  constexpr int kRing = 24, kRings = 16;
  constexpr double kRadius = 0.25;
  std::mt19937_64 rng(41);
  std::uniform_real_distribution<double> turn(0.0, 2.0 * M_PI / kRing);
  iires::PointCloud cloud;
  for (int z = 0; z <= kRings; ++z) {
    const double offset = turn(rng);
    for (int a = 0; a < kRing; ++a) {
      const double t = offset + 2.0 * M_PI * a / kRing;
      cloud.points.emplace_back(kRadius * std::cos(t), kRadius * std::sin(t), static_cast<double>(z) / kRings);
      cloud.normals.emplace_back(std::cos(t), std::sin(t), 0.0);
    }
  }
  const double spacing = 2.0 * M_PI * kRadius / kRing;  // ≈ 0.065, the ring spacing 1/16 ≈ 0.0625
  const auto r = iires::resample(cloud, paramsFor(4000));
  ASSERT_EQ(r.cloud.size(), 4000u);
  EXPECT_LT(r.spacing.cv, 0.08);
  double past = 0, radial = 0;
  for (const auto& p : r.cloud.points) {
    past = std::max({past, -p.z(), p.z() - 1.0});
    radial = std::max(radial, std::abs(std::hypot(p.x(), p.y()) - kRadius));
  }
  EXPECT_LE(past, 0.25 * spacing);
  EXPECT_LE(radial, 0.1 * spacing);
}

// A scanned head over a sparse neck: a sphere of 1,400 points (radius 0.3), below it a tube of radius 0.2 holding
// only 40 points, ending in its rim, a ring of 30 points at y = -0.45 (the scan's lower edge), normals given,
// upsampled to 15,000. The quadric fits at the rim extrapolate the tube, tilting the normal they give, and the
// rim's curve seen in that tilted plane bends around points below it: the footprint test judged them inside the
// input and samples went up to 2.6 output spacings past the rim (or out of the input's box: the run failed, as
// CGAL's oni scan did from 15,000 up). A sample now counts as inside only if it is inside
// in the plane of the neighbours' averaged normal too.
TEST(Resample, UpsampledSparseNeckStaysAboveItsRim) {
  for (const std::uint64_t seed : {1u, 2u, 3u, 4u}) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> g(0.0, 1.0);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    iires::PointCloud cloud;
    for (int i = 0; i < 1400; ++i) {
      const Eigen::Vector3d d = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
      cloud.points.push_back(0.3 * d), cloud.normals.push_back(d);
    }
    auto tube = [&](double t, double y) {
      cloud.points.emplace_back(0.2 * std::cos(t), y, 0.2 * std::sin(t));
      cloud.normals.emplace_back(std::cos(t), 0.0, std::sin(t));
    };
    for (int i = 0; i < 40; ++i) {
      const double t = 2.0 * M_PI * u(rng);
      tube(t, -0.45 + 0.2 * u(rng));
    }
    for (int i = 0; i < 30; ++i) tube(2.0 * M_PI * (i + u(rng)) / 30.0, -0.45);
    iires::ResampleResult r;
    ASSERT_NO_THROW(r = iires::resample(cloud, paramsFor(15000))) << "seed " << seed;
    ASSERT_EQ(r.cloud.size(), 15000u);
    double below = 0;
    for (const auto& p : r.cloud.points) below = std::max(below, -0.45 - p.y());
    EXPECT_LE(below, r.spacing.mean) << "seed " << seed;
  }
}

// Dense specks (30 points within 0.05) on a sheet sampled about 1 apart: each speck is a part of its own to the
// neighbour rule. A split of an edge passing over one lands on the speck, where neither end sees it; every pass
// split that edge again onto the same spot, stacking samples on one position.
TEST(Resample, SplitsNeverStackSamplesOnADenseSpeck) {
  for (std::uint64_t seed : {1u, 2u, 3u, 4u}) {
    const double side = std::sqrt(3000.0);
    iires::PointCloud cloud = iires::test::planeCloud(3000, side, 1.0, seed);
    std::mt19937_64 rng(seed + 100);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int speck = 0; speck < 10; ++speck) {
      const Eigen::Vector3d centre((0.1 + 0.8 * u(rng)) * side, (0.1 + 0.8 * u(rng)) * side, 0.0);
      for (int k = 0; k < 30; ++k) {
        const double a = 2.0 * M_PI * u(rng), r = 0.05 * std::sqrt(u(rng));
        cloud.points.push_back(centre + Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0.0));
      }
    }
    for (std::size_t n : {2000u, 3000u}) {
      const auto r = iires::resample(cloud, paramsFor(n));
      ASSERT_EQ(r.cloud.size(), n);
      const iires::KnnIndex index(r.cloud.points);
      std::size_t stacked = 0;
      std::vector<std::uint32_t> idx;
      std::vector<double> d2;
      for (const auto& p : r.cloud.points) stacked += index.knn(p, 2, idx, d2) == 2 && d2[1] < 1e-18;
      EXPECT_EQ(stacked, 0u) << "seed " << seed << ", N = " << n;
    }
  }
}

// The same scan exported twice, rounded differently (or merged with itself): every point has a twin a hair
// away. Every spacing measured from nearest neighbours took the hair for the sampling's step: the output came
// out in clumps (spacing cv 0.5, pairs of samples 2 % of the spacing apart). The twins are merged first.
TEST(Resample, PointsGivenTwiceAHairApartAreResampledAsOnce) {
  iires::PointCloud cloud = iires::test::sphereCloud(20000, 1.0, 23);
  cloud.normals.clear();
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1e-9, 1e-9);
  for (std::size_t i = 0; i < 20000; ++i)
    cloud.points.push_back(cloud.points[i] + Eigen::Vector3d(u(rng), u(rng), u(rng)));
  const auto r = iires::resample(cloud, paramsFor(3000));
  ASSERT_EQ(r.cloud.size(), 3000u);
  EXPECT_GE(r.nearDuplicatesMerged, 20000u);
  EXPECT_LT(r.spacing.cv, 0.08);
  EXPECT_GT(r.spacing.min, 0.5 * r.spacing.mean);
}

TEST(Resample, RejectsBadInputAndParameters) {
  iires::PointCloud empty;
  EXPECT_THROW(iires::resample(empty, paramsFor(10)), iires::InputError);
  auto cloud = iires::test::sphereCloud(100);
  EXPECT_THROW(iires::resample(cloud, paramsFor(0)), std::invalid_argument);
  cloud.points[3].x() = std::nan("");
  EXPECT_THROW(iires::resample(cloud, paramsFor(10)), iires::InputError);
  iires::PointCloud three;
  three.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_THROW(iires::resample(three, paramsFor(10)), iires::InputError);
  auto bad = paramsFor(10);
  bad.collapseRatio = 1.5;
  EXPECT_THROW(iires::resample(iires::test::sphereCloud(100), bad), std::invalid_argument);
}

TEST(Resample, ReportIsJsonWithTheFieldsUsersRead) {
  const auto r = iires::resample(iires::test::sphereCloud(3000), paramsFor(300));
  const std::string json = r.toJson();
  for (const char* key : {"\"input_points\": 3000", "\"output_points\": 300", "\"passes\"", "\"time_s\"",
                          "\"spacing\"", "\"cv\"", "\"total\""})
    EXPECT_NE(json.find(key), std::string::npos) << key << " missing in " << json;
}

TEST(Resample, ContextSamplesAreHeldButNeitherCountedNorOutput) {
  // A plane resampled with the left half's samples given as context: the N free samples fill the right half
  // and keep their spacing to the context.
  const auto cloud = iires::test::planeCloud(40000, 1.0, 1.0, 23);
  const auto full = iires::resample(cloud, paramsFor(2000));
  iires::ResampleParams p = paramsFor(1000);
  for (const auto& q : full.cloud.points)
    if (q.x() < 0.5) p.contextSamples.push_back(q);
  p.targetCount = 2000 - p.contextSamples.size();
  const auto r = iires::resample(cloud, p);
  ASSERT_EQ(r.cloud.size(), p.targetCount);
  EXPECT_TRUE(r.fixedIndices.empty());
  const iires::KnnIndex context(p.contextSamples);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  std::size_t left = 0;
  for (const auto& q : r.cloud.points) {
    left += q.x() < 0.5 - 0.5 * full.spacing.mean;
    context.knn(q, 1, idx, d2);
    EXPECT_GT(std::sqrt(d2[0]), 0.5 * full.spacing.mean) << "a free sample on top of a context sample";
  }
  EXPECT_LT(left, p.targetCount / 50) << "the free samples stay out of the covered half";
}

// A tile of an upsampled sparse scan: a hemisphere of ~380 points (positions only) beside 2,400 context samples of
// a finished neighbour, on a band below it that its points do not reach, upsampled to 2,000 and 6,000. The
// elimination counted the context in the samples to place, so the sparse deficit it left for the passes took
// every free candidate; with no free sample to split from, the count was met by adding input points over and
// over (min spacing 0, cv 2.1 and 3.9). Now the N samples are evenly spaced and none lies on another.
TEST(Resample, ContextBesideASparseInputLeavesItsSamplesToPlace) {
  iires::PointCloud hemisphere;
  for (const auto& q : iires::test::sphereCloud(800, 1.0, 7).points)
    if (q.z() > 0) hemisphere.points.push_back(q);
  iires::ResampleParams p;
  constexpr int kFibonacci = 12000;  // an even sampling of the sphere; the band z in (−0.3, 0.1) is the context
  for (int i = 0; i < kFibonacci; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / kFibonacci, r = std::sqrt(1.0 - z * z);
    const double a = M_PI * (1.0 + std::sqrt(5.0)) * (i + 0.5);
    if (z > -0.3 && z < 0.1) p.contextSamples.emplace_back(r * std::cos(a), r * std::sin(a), z);
  }
  for (const std::size_t n : {2000u, 6000u}) {
    p.targetCount = n;
    const auto r = iires::resample(hemisphere, p);
    ASSERT_EQ(r.cloud.size(), n);
    EXPECT_GT(r.spacing.min, 0.1 * r.spacing.mean) << n;
    EXPECT_LT(r.spacing.cv, 0.08) << n;
  }
}

// Two faces meeting at 90° along the x axis, cut off at x = 0 and x = 2 (open ends of the crease): the crease's
// samples end where the input does. Traced on along the planes fitted behind an end, they stood up to two local
// spacings past it (0.45 output spacings at N = 4000).
TEST(Resample, SharpEdgeSamplesEndWithTheInput) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    iires::PointCloud cloud;
    for (int i = 0; i < 80000; ++i) {
      const double x = 2.0 * u(rng), t = u(rng);
      cloud.points.push_back(i % 2 ? Eigen::Vector3d(x, t, 0.0) : Eigen::Vector3d(x, 0.0, t));
    }
    iires::ResampleParams p = paramsFor(4000);
    p.sharpEdges = true;
    const auto r = iires::resample(cloud, p);
    ASSERT_EQ(r.cloud.size(), 4000u);
    ASSERT_FALSE(r.fixedIndices.empty());
    double past = 0;
    for (std::uint32_t i : r.fixedIndices) past = std::max({past, -r.cloud.points[i].x(), r.cloud.points[i].x() - 2.0});
    EXPECT_LT(past, 0.1 * r.spacing.mean) << "seed " << seed;
  }
}

/// @p mesh sampled with 60k points (@p densityRatio: see MeshSamplingParams), moved along its normals by Gaussian noise
/// of @p noise input spacings (seed 7), positions only (a scan), resampled to 4000 points with sharp edges.
iires::ResampleResult sharpScanResampled(const iires::TriangleMesh& mesh, double densityRatio, double noise) {
  iires::MeshSamplingParams sp;
  sp.count = 60000;
  sp.densityRatio = densityRatio;
  iires::PointCloud cloud = iires::sampleMesh(mesh, sp);
  if (noise > 0) {
    const double l = iires::meanNeighbourSpacing(cloud.points);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> g(0.0, noise * l);
    for (std::size_t i = 0; i < cloud.size(); ++i) cloud.points[i] += g(rng) * cloud.normals[i];
  }
  cloud.normals.clear();
  iires::ResampleParams p;
  p.targetCount = 4000;
  p.sharpEdges = true;
  return iires::resample(cloud, p);
}

// With sharp edges the free samples beside a crease are fitted to their own face (the MLS fits weight the input
// points by their normals): on a prism sampled 5× denser at one end, positions only, their mean distance to the
// true surface is a fraction of what the plain fits leave, which round the 60° creases between the side faces.
TEST(Resample, SharpEdgesFitFreeSamplesToTheirOwnFace) {
  const iires::TriangleMesh prism = iires::test::prismMesh(6, 1.0, 1.5);  // creases 60° apart
  const auto r = sharpScanResampled(prism, 5, 0);
  ASSERT_EQ(r.cloud.size(), 4000u);
  std::vector<char> held(r.cloud.size(), 0);
  for (std::uint32_t i : r.fixedIndices) held[i] = 1;
  std::vector<Eigen::Vector3d> free;
  for (std::size_t i = 0; i < held.size(); ++i)
    if (!held[i]) free.push_back(r.cloud.points[i]);
  const auto err = iires::MeshDistance(prism).distances(free);
  // Measured: mean 6.8e-8, max 1.1e-4 (plain fits: 4.6e-7 and 4.8e-4); the output spacing is 0.055.
  EXPECT_LT(err.mean, 2e-7);
  EXPECT_LT(err.max, 2.5e-4);
}

// A cube scanned with noise (σ = 0.2 spacings along the normal, positions only), resampled with sharp edges: the
// denoiser's sweeps after the first keep apart the faces of every crease the feature stage holds (the bilateral
// term at the feature angle, 30°), so they do not round the creases off first — normals estimated across a crease
// blend its faces', and at the denoiser's own 45° those points still weigh in either face's fits. Mean distance to
// the cube of the output points within one output spacing of a crease: 0.0226 output spacings with 45° in every
// sweep, 0.0198 with 30° after the first.
TEST(Resample, SharpEdgesOnANoisyScanAreNotRoundedByTheDenoiser) {
  const iires::TriangleMesh cube = iires::test::cubeMesh();
  const auto r = sharpScanResampled(cube, 1, 0.2);
  ASSERT_EQ(r.cloud.size(), 4000u);
  std::vector<Eigen::Vector3d> nearCrease;  // within one output spacing of two faces of [0, 1]³
  for (const auto& q : r.cloud.points) {
    int close = 0;
    for (int a = 0; a < 3; ++a) close += std::min(q[a], 1 - q[a]) < r.spacing.mean;
    if (close >= 2) nearCrease.push_back(q);
  }
  ASSERT_GT(nearCrease.size(), 400u);
  EXPECT_LT(iires::MeshDistance(cube).distances(nearCrease).mean / r.spacing.mean, 0.021);
}

/// Distance from @p p to the surface of the axis-aligned box [@p lo, @p hi] (negative inside).
double boxDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Eigen::Vector3d q = (p - 0.5 * (lo + hi)).cwiseAbs() - 0.5 * (hi - lo);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// An L-bracket (two boxes) scanned from one view: only the faces turned to the camera, so its creases end at the
// scan's silhouette, and some corners join a face the scan never saw. Held samples traced past the end of the
// scan or put where the fitted planes meet beyond it lay up to 0.96 output spacings off the part (12 of 15 runs
// over 0.5: five views, N = 1,000 to 3,000); samples past the input's extent and a kernel width from it are
// dropped now.
TEST(Resample, SharpEdgesStayOnAScanThatEndsAtACrease) {
  const Eigen::Vector3d boxes[2][2] = {{{0, 0, 0}, {2, 1, 0.3}}, {{0, 0, 0}, {0.3, 1, 1.5}}};
  for (const Eigen::Vector3d& view : {Eigen::Vector3d(0.6, 0.4, -1), Eigen::Vector3d(-1, 0.5, -0.7)}) {
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    iires::PointCloud cloud;
    for (int b = 0; b < 2; ++b) {
      const Eigen::Vector3d &lo = boxes[b][0], &hi = boxes[b][1], e = hi - lo;
      const double faceArea[3] = {e.y() * e.z(), e.x() * e.z(), e.x() * e.y()};
      const double total = 2 * (faceArea[0] + faceArea[1] + faceArea[2]);
      for (int i = 0; i < 50000; ++i) {
        double pick = u(rng) * total;
        int axis = 0;
        while (pick >= 2 * faceArea[axis]) pick -= 2 * faceArea[axis++];
        const bool high = pick >= faceArea[axis];
        Eigen::Vector3d p(lo.x() + u(rng) * e.x(), lo.y() + u(rng) * e.y(), lo.z() + u(rng) * e.z());
        p[axis] = high ? hi[axis] : lo[axis];
        Eigen::Vector3d n = Eigen::Vector3d::Zero();
        n[axis] = high ? 1 : -1;
        const Eigen::Vector3d &olo = boxes[1 - b][0], &ohi = boxes[1 - b][1];
        if (boxDistance(p, olo, ohi) < -1e-9 || n.dot(view) >= 0) continue;  // inside the other box, or unseen
        cloud.points.push_back(p);
      }
    }
    for (std::size_t n : {2000u, 3000u}) {
      iires::ResampleParams p;
      p.targetCount = n;
      p.sharpEdges = true;
      const auto r = iires::resample(cloud, p);
      ASSERT_EQ(r.cloud.size(), n);
      double worst = 0;
      for (const Eigen::Vector3d& q : r.cloud.points)
        worst = std::max(worst, std::abs(std::min(boxDistance(q, boxes[0][0], boxes[0][1]),
                                                  boxDistance(q, boxes[1][0], boxes[1][1]))));
      EXPECT_LT(worst, 0.5 * r.spacing.mean) << "view " << view.transpose() << ", N = " << n;
    }
  }
}

}  // namespace

