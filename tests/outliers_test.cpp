// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/outliers.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "iires/resample.hpp"
#include "iires/sampling.hpp"
#include "shapes.hpp"
#include "test_util.hpp"

namespace {

using iires::OutlierMode;
using iires::OutlierParams;
using iires::PointCloud;

/// A unit plane (z = 0) with noise uniform in ±noise·l and a share of points moved ±[3, 6]·l along z.
struct Noisy {
  PointCloud cloud;
  std::vector<std::uint8_t> injected;
  std::size_t count = 0;
  double l = 0;
};

Noisy noisyPlane(std::size_t n, double ratio, double noise, double fraction, std::uint64_t seed) {
  Noisy out;
  out.cloud = iires::test::planeCloud(n, 1.0, ratio, seed);
  out.l = iires::meanNeighbourSpacing(out.cloud.points);
  std::mt19937_64 rng(seed + 100);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  out.injected.assign(n, 0);
  for (auto& p : out.cloud.points) p.z() = (2 * u(rng) - 1) * noise * out.l;
  for (std::size_t i = 0; i < n; ++i) {
    if (u(rng) >= fraction) continue;
    out.injected[i] = 1, ++out.count;
    out.cloud.points[i].z() = (u(rng) < 0.5 ? -1 : 1) * (3 + 3 * u(rng)) * out.l;
  }
  return out;
}

struct Rates {
  double recall = 0, falsePositive = 0;
};

Rates rates(const Noisy& data, const std::vector<std::uint32_t>& found) {
  std::size_t tp = 0;
  for (auto i : found) tp += data.injected[i];
  Rates r;
  r.recall = data.count ? double(tp) / double(data.count) : 1.0;
  r.falsePositive = double(found.size() - tp) / double(data.injected.size() - data.count);
  return r;
}

TEST(Outliers, ParseMode) {
  EXPECT_EQ(iires::parseOutlierMode("pull"), OutlierMode::kPull);
  EXPECT_EQ(iires::parseOutlierMode("remove"), OutlierMode::kRemove);
  EXPECT_EQ(iires::parseOutlierMode("keep"), OutlierMode::kKeep);
  EXPECT_THROW(iires::parseOutlierMode("drop"), std::invalid_argument);
  EXPECT_EQ(iires::toString(OutlierMode::kRemove), "remove");
}

TEST(Outliers, RuleFindsOutliersOnANoisyPlane) {
  for (double noise : {0.0, 0.33, 0.66}) {
    const Noisy data = noisyPlane(30000, 1.0, noise, 0.03, 11);
    OutlierParams p;
    p.mode = OutlierMode::kKeep;
    const auto r = iires::processOutliers(data.cloud, p);
    const Rates rt = rates(data, r.outliers);
    EXPECT_GE(rt.recall, 0.95) << "noise " << noise;
    EXPECT_LT(rt.falsePositive, 0.01) << "noise " << noise;
    EXPECT_EQ(r.found, r.outliers.size());
    EXPECT_EQ(r.pulled + r.removed, 0u);
    EXPECT_EQ(r.cloud.points, data.cloud.points);  // keep: untouched
    EXPECT_TRUE(std::is_sorted(r.outliers.begin(), r.outliers.end()));
  }
}

TEST(Outliers, DensityChangeIsNotAnOutlier) {
  // 5× density change across the plane, no outliers: the literal eq. 4 flags many of these points.
  for (double noise : {0.0, 0.33}) {
    const Noisy data = noisyPlane(30000, 5.0, noise, 0.0, 12);
    OutlierParams p;
    p.mode = OutlierMode::kKeep;
    const auto r = iires::processOutliers(data.cloud, p);
    EXPECT_LT(double(r.found) / double(data.cloud.size()), 0.01) << "noise " << noise << " found " << r.found;
    // The literal rule (any non-mutual neighbour) on the same cloud flags far more: the reason for the
    // geometric test.
    OutlierParams literal = p;
    literal.minMutual = literal.k;
    literal.planeThreshold = 1e-9;
    literal.nearPlaneThreshold = std::numeric_limits<double>::infinity();  // no sheet rescues a flagged point
    const auto lit = iires::processOutliers(data.cloud, literal);
    if (noise > 0) {
      EXPECT_GT(lit.found, 10 * std::max<std::size_t>(r.found, 10));
    }
  }
}

TEST(Outliers, NearPlaneFindsOutliersBetweenTwoSheets) {
  // Two noisy parallel sheets 5·l apart (a thin part) with 3 % of the first sheet's points moved to mid-height.
  // The 16 nearest trusted points of such an outlier come from both sheets, so their plane passes near it;
  // the small plane of its nearest trusted point (on one sheet) is 2.5·l away.
  Noisy data = noisyPlane(15000, 1.0, 0.33, 0.0, 16);
  const std::size_t half = data.cloud.size();
  const Noisy top = noisyPlane(15000, 1.0, 0.33, 0.0, 17);
  const double gap = 5.0 * data.l;
  for (Eigen::Vector3d p : top.cloud.points) data.cloud.points.push_back(p + Eigen::Vector3d(0, 0, gap));
  data.injected.assign(data.cloud.size(), 0);
  std::mt19937_64 rng(18);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (std::size_t i = 0; i < half; ++i) {
    const Eigen::Vector2d xy = data.cloud.points[i].head<2>();
    if (u(rng) >= 0.03 || xy.minCoeff() < 0.1 || xy.maxCoeff() > 0.9) continue;  // away from the borders
    data.injected[i] = 1, ++data.count;
    data.cloud.points[i].z() = 0.5 * gap + (2 * u(rng) - 1) * 0.3 * data.l;
  }
  OutlierParams p;
  p.mode = OutlierMode::kKeep;
  const Rates with = rates(data, iires::processOutliers(data.cloud, p).outliers);
  EXPECT_GE(with.recall, 0.95);
  EXPECT_LT(with.falsePositive, 0.01);
  p.nearPlaneThreshold = std::numeric_limits<double>::infinity();  // the 16-point plane alone
  const Rates without = rates(data, iires::processOutliers(data.cloud, p).outliers);
  EXPECT_LT(without.recall, 0.5);
}

TEST(Outliers, PullBringsOutliersWithinOneSpacing) {
  const Noisy data = noisyPlane(30000, 1.0, 0.33, 0.03, 13);
  PointCloud withNormals = data.cloud;
  withNormals.normals.assign(withNormals.size(), Eigen::Vector3d::UnitZ());
  const auto r = iires::processOutliers(withNormals, {});
  EXPECT_EQ(r.cloud.size(), data.cloud.size());
  EXPECT_EQ(r.pulled, r.found);
  std::size_t within = 0;
  for (std::size_t i = 0; i < data.cloud.size(); ++i) {
    if (data.injected[i]) within += std::abs(r.cloud.points[i].z()) <= data.l;
  }
  EXPECT_GE(double(within) / double(data.count), 0.95);
  for (auto i : r.outliers) {
    EXPECT_GT(r.cloud.normals[i].z(), 0.95);  // n_a, oriented like the nearest non-outlier's normal
    // eq. (5) moves along n_a only: the tangential move is |height|·sin(tilt of n_a), ≤ 6·l·sin 18°.
    EXPECT_LT((r.cloud.points[i] - data.cloud.points[i]).head<2>().norm(), 2.0 * data.l);
  }
}

// Points far from the object, scattered and so each other's neighbours, are outliers too; pulling one would
// carry it along a slightly tilted plane far off the surface, so it is removed instead.
TEST(Outliers, ScatteredFarPointsAreFoundAndNeverPulledOffTheSurface) {
  PointCloud cloud;
  for (const auto& p : iires::test::fibonacciSphere(4000)) cloud.points.push_back(p);
  std::mt19937_64 rng(21);
  std::normal_distribution<double> g(0.0, 1.0);
  std::uniform_real_distribution<double> exponent(1.0, 6.0);
  for (int i = 0; i < 50; ++i)
    cloud.points.push_back(std::pow(10.0, exponent(rng)) * 3.5 * Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized());
  for (const OutlierMode mode : {OutlierMode::kPull, OutlierMode::kRemove}) {
    OutlierParams p;
    p.mode = mode;
    const auto r = iires::processOutliers(cloud, p);
    EXPECT_EQ(std::count_if(r.outliers.begin(), r.outliers.end(), [](std::uint32_t i) { return i >= 4000; }), 50);
    for (const auto& q : r.cloud.points) EXPECT_NEAR(q.norm(), 1.0, 0.01) << q.transpose();
    EXPECT_EQ(r.pulled + r.removed, r.found);
  }
}

// Outliers scattered near the surface (2 % of the points, 5–20 spacings off it, as a noisy scanner makes them) have
// one another among their nearest: the ones a round of the test passes keep each other company. Each one left
// stands for a surface patch and drew an output sample (fandisk: 2.4 % of the samples 1.5 spacings off). The later
// rounds, each over the points the last one kept, find them alone: here 0 points are left over 3 spacings off the
// sphere (pull and remove), 55 and 40 after one round.
TEST(Outliers, OutliersInOneAnothersCompanyAreFoundInLaterRounds) {
  PointCloud cloud;
  std::mt19937_64 rng(25);
  std::normal_distribution<double> noise(0.0, 0.003);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto sphere = iires::test::fibonacciSphere(20000);
  const double l = std::sqrt(4 * M_PI / 20000.0);
  for (const auto& p : sphere) cloud.points.push_back(p * (1 + noise(rng)));
  for (int i = 0; i < 400; ++i) {
    const Eigen::Vector3d& p = sphere[static_cast<std::size_t>(u(rng) * 20000) % 20000];
    cloud.points.push_back(p * (1 + (u(rng) < 0.5 ? -1 : 1) * (5 + 15 * u(rng)) * l));
  }
  for (const OutlierMode mode : {OutlierMode::kPull, OutlierMode::kRemove}) {
    OutlierParams p;
    p.mode = mode;
    const auto r = iires::processOutliers(cloud, p);
    const auto off = std::count_if(r.cloud.points.begin(), r.cloud.points.end(),
                                   [&](const Eigen::Vector3d& q) { return std::abs(q.norm() - 1.0) > 3 * l; });
    EXPECT_LE(off, 4) << iires::toString(mode);
  }
}

// Background clutter: 5 % of the points uniform in a noisy sphere's box, ten times sparser than the sphere, each
// other's neighbours and mutual (so the local tests keep them). Each one that stays stands for a large area and
// draws resampled points. They fill space around them (local dimension 3): most are found as isolated, and
// resampling puts few points off the sphere.
TEST(Outliers, BackgroundClutterIsFoundAndTakesFewSamples) {
  PointCloud cloud;
  std::mt19937_64 rng(24);
  std::normal_distribution<double> noise(0.0, 0.01);  // 0.4 of the sphere's spacing, along the radius
  for (const auto& p : iires::test::fibonacciSphere(20000)) cloud.points.push_back(p * (1 + noise(rng)));
  std::uniform_real_distribution<double> box(-2.0, 2.0);
  for (int i = 0; i < 1000; ++i) cloud.points.emplace_back(box(rng), box(rng), box(rng));
  const auto r = iires::processOutliers(cloud, OutlierParams{});
  const auto clutter = std::count_if(r.outliers.begin(), r.outliers.end(), [](std::uint32_t i) { return i >= 20000; });
  EXPECT_GT(clutter, 850);  // 904; 642 under the tenfold rule alone
  EXPECT_LT(static_cast<std::size_t>(std::count_if(r.outliers.begin(), r.outliers.end(),
                                                   [](std::uint32_t i) { return i < 20000; })),
            20u);
  iires::ResampleParams params;
  params.targetCount = 2000;
  const iires::ResampleResult out = iires::resample(cloud, params);
  const auto off = std::count_if(out.cloud.points.begin(), out.cloud.points.end(),
                                 [](const Eigen::Vector3d& p) { return std::abs(p.norm() - 1.0) > 0.1; });
  EXPECT_LT(off, 150);  // 89 (4.5 %); under the tenfold rule alone 1,188 (59 %)
}

// Clutter over a tenth of the points (15 %: a room's contents around the object, a noisy sensor) sets the cloud's
// 90th-percentile spacing itself: measured against it, little of it stood out (the run failed with "output points
// left the input's bounding box" at 10 %, and at 20 % 85 % of the output lay off the sphere). Measured against the
// surface's spacing (at most 1.5 times the median), it is found as at 5 %.
TEST(Outliers, HeavyBackgroundClutterIsFoundToo) {
  PointCloud cloud;
  std::mt19937_64 rng(31);
  std::normal_distribution<double> noise(0.0, 0.01);
  for (const auto& p : iires::test::fibonacciSphere(20000)) cloud.points.push_back(p * (1 + noise(rng)));
  std::uniform_real_distribution<double> box(-2.0, 2.0);
  for (int i = 0; i < 3500; ++i) cloud.points.emplace_back(box(rng), box(rng), box(rng));
  const auto r = iires::processOutliers(cloud, OutlierParams{});
  const auto clutter = std::count_if(r.outliers.begin(), r.outliers.end(), [](std::uint32_t i) { return i >= 20000; });
  EXPECT_GT(clutter, 3000);
  EXPECT_LT(static_cast<std::size_t>(std::count_if(r.outliers.begin(), r.outliers.end(),
                                                   [](std::uint32_t i) { return i < 20000; })),
            20u);
}

// The isolation rule must not take a scan's sparse far field for outliers: a plane whose density falls as 1/r²
// from r = 1 to 100 (a terrestrial scanner's fall-off; spacing 20× wider at the rim than at the centre) has none.
TEST(Outliers, DensityFallOffOfAScannerIsNotIsolation) {
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud cloud;
  for (int i = 0; i < 30000; ++i) {
    const double r = std::exp(u(rng) * std::log(100.0)), t = 2 * M_PI * u(rng);  // radial density ∝ 1/r
    cloud.points.emplace_back(r * std::cos(t), r * std::sin(t), 0.0);
  }
  OutlierParams p;
  p.mode = OutlierMode::kRemove;
  EXPECT_EQ(iires::processOutliers(cloud, p).found, 0u);
}

// Nor a separate object sampled at a tenth of the density (under a tenth of the points): its spacing is many
// times the cloud's 90th percentile, but its points lie on a sheet. It used to lose points as isolated ones
// that the report did not count as found.
TEST(Outliers, SparseSeparateObjectIsNotIsolation) {
  const PointCloud cloud = iires::test::twoDensitySpheres(10000, 23);
  const auto r = iires::processOutliers(cloud, OutlierParams{});
  EXPECT_EQ(r.removed, 0u);
  EXPECT_EQ(r.cloud.size(), cloud.size());
  EXPECT_LE(r.pulled + r.removed, r.found);
}

TEST(Outliers, RemoveDropsThem) {
  const Noisy data = noisyPlane(20000, 1.0, 0.33, 0.03, 14);
  OutlierParams p;
  p.mode = OutlierMode::kRemove;
  const auto r = iires::processOutliers(data.cloud, p);
  EXPECT_EQ(r.removed, r.found);
  EXPECT_EQ(r.cloud.size(), data.cloud.size() - r.found);
  std::size_t far = 0;
  for (const auto& q : r.cloud.points) far += std::abs(q.z()) > 2.5 * data.l;
  EXPECT_LE(double(far), 0.05 * double(data.count));
}

// A borrowed neighbour table (preprocess() shares one with denoising) gives the output of the own search.
TEST(Outliers, BorrowedNeighbourTableGivesTheSameOutput) {
  const Noisy data = noisyPlane(10000, 3.0, 0.5, 0.03, 15);
  const iires::KnnIndex index(data.cloud.points);
  const iires::NeighbourTable table(index, data.cloud.points, iires::outlierNeighbours({}));
  const auto own = iires::processOutliers(data.cloud),
             borrowed = iires::processOutliers(data.cloud, {}, {}, &table);
  EXPECT_GT(own.found, 0u);
  EXPECT_EQ(own.outliers, borrowed.outliers);
  EXPECT_EQ(own.cloud.points, borrowed.cloud.points);
}

TEST(Outliers, SameOutputForOneAndTwoThreads) {
  const Noisy data = noisyPlane(10000, 3.0, 0.5, 0.03, 15);
  const auto a = iires::processOutliers(data.cloud, {}, iires::Execution{1});
  const auto b = iires::processOutliers(data.cloud, {}, iires::Execution{2});
  EXPECT_EQ(a.outliers, b.outliers);
  EXPECT_EQ(a.cloud.points, b.cloud.points);
}

TEST(Outliers, DegenerateInputs) {
  EXPECT_THROW(iires::processOutliers(PointCloud{}), iires::InputError);
  const PointCloud few = iires::test::planeCloud(16);  // planeNeighbours = 16 needs 17 points
  EXPECT_THROW(iires::processOutliers(few), iires::InputError);
  EXPECT_NO_THROW(iires::processOutliers(iires::test::planeCloud(17)));
  OutlierParams bad;
  bad.minMutual = 9;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = {};
  bad.planeThreshold = -1;
  EXPECT_THROW(iires::processOutliers(iires::test::planeCloud(100), bad), std::invalid_argument);
  // A clean cloud: nothing found, output equal to the input.
  const PointCloud plane = iires::test::planeCloud(2000);
  const auto r = iires::processOutliers(plane);
  EXPECT_EQ(r.found, 0u);
  EXPECT_EQ(r.cloud.points, plane.points);
}

TEST(Outliers, NonUniformBunnyWithOutliers) {
  // Real data: bunny00 sampled with a 5× density change, 0.33·l uniform noise and 2 % outliers at 3–6·l.
  const iires::TriangleMesh mesh = iires::readMesh(iires::test::dataPath("meshes/bunny00.off"));
  const iires::MeshDistance md(mesh);
  iires::MeshSamplingParams sp;
  sp.count = 60000;
  sp.densityRatio = 5.0;
  sp.seed = 21;
  const PointCloud clean = iires::sampleMesh(mesh, sp);
  const double l = iires::meanNeighbourSpacing(clean.points);
  sp.noise = 0.33 * l;
  sp.gaussianNoise = false;
  sp.outlierFraction = 0.02;
  sp.outlierMin = 3 * l;
  sp.outlierMax = 6 * l;
  PointCloud noisy = iires::sampleMesh(mesh, sp);
  noisy.normals.clear();
  // Same seed → same surface samples: an injected outlier is a point that moved more than the noise.
  std::vector<std::uint8_t> injected(noisy.size());
  std::size_t count = 0;
  for (std::size_t i = 0; i < noisy.size(); ++i)
    count += injected[i] = (noisy.points[i] - clean.points[i]).norm() > 0.34 * l;
  ASSERT_EQ(count, 1200u);
  const auto r = iires::processOutliers(noisy, {});
  std::size_t tp = 0, within = 0;
  for (auto i : r.outliers) tp += injected[i];
  for (std::size_t i = 0; i < noisy.size(); ++i)
    if (injected[i] && md.distance(r.cloud.points[i]) <= l) ++within;
  EXPECT_GE(double(tp) / double(count), 0.95);
  EXPECT_LT(double(r.found - tp) / double(noisy.size() - count), 0.01);
  EXPECT_GE(double(within) / double(count), 0.95);
}

/// 100k points on @p mesh, 5× denser at one end, positions only (as a scan).
PointCloud gradientSampling(const iires::TriangleMesh& mesh, std::uint64_t seed) {
  iires::MeshSamplingParams sp;
  sp.count = 100000;
  sp.densityRatio = 5;
  sp.seed = seed;
  PointCloud cloud = iires::sampleMesh(mesh, sp);
  cloud.normals.clear();
  return cloud;
}

// A clean cube sampled 5× denser at one end: beside an edge or a corner the random sampling leaves true points
// whose neighbours are not mutual and whose planes span two faces, and the rule flags them. Most lie on a plane
// that most of their neighbours share (their face) and are not outliers: 34 flagged over these 12 samplings
// without that test, 19 with it. Pulled onto the plane of their nearest trusted point's neighbourhood, which
// spans the crease too, the others would move inside the cube (5 of the 34, up to 0.021 deep; the spacing at
// the dense end is about 0.01; 3 of the 19); one within that plane's own scatter stays where it is (1 left).
TEST(Outliers, PullLeavesTruePointsBesideACreaseOnTheSurface) {
  std::size_t flagged = 0, inside = 0;
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    const auto r = iires::processOutliers(gradientSampling(iires::test::cubeMesh(2.0), seed), OutlierParams{});
    flagged += r.found;
    for (std::uint32_t o : r.outliers) {
      const Eigen::Vector3d q = r.cloud.points[o];
      inside += std::min(q.minCoeff(), 2.0 - q.maxCoeff()) > 0.001;  // off every face, inwards
    }
  }
  EXPECT_GT(flagged, 12u);
  EXPECT_LE(flagged, 25u);
  EXPECT_LE(inside, 1u);
}

// The same on a shape the rules were not tuned on: a triangular prism (acute 60° edges, 120° between the faces'
// normals) sampled 5× denser at one end, positions only, 6 samplings. Measured: 22 points flagged, 16 of them
// moved off the surface by over 0.08 spacings (41 and 35 without the two rules).
TEST(Outliers, TruePointsBesideAnAcuteEdgeAreMostlyLeftOnTheSurface) {
  const iires::TriangleMesh wedge = iires::test::prismMesh(3, 1.0, 3.0);
  const iires::MeshDistance distance(wedge);
  std::size_t flagged = 0, movedOff = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const auto r = iires::processOutliers(gradientSampling(wedge, seed), OutlierParams{});
    ASSERT_EQ(r.removed, 0u);  // clean: every flagged point is pulled or left, none removed
    flagged += r.found;
    for (std::uint32_t o : r.outliers) movedOff += distance.distances({r.cloud.points[o]}).max > 1e-3;
  }
  EXPECT_LE(flagged, 30u);
  EXPECT_LE(movedOff, 24u);
}

// A face seen at a grazing angle (a one-view scan of a hexagonal nut): its points lie far sparser than those of
// the face it meets at a convex 120° crease, and the rule flags some of them. Their nearest trusted points are
// on the dense face, whose plane they were pulled onto: past the crease, off the part and up to five spacings
// from any input point (a sample of the resampled nut ended 1.9 output spacings off). Past its points the plane
// only extrapolates: no pull lands farther than kPullBeyond (0.75) fit radii beyond them, about 2.2 l here (3.9
// before).
TEST(Outliers, GrazingFaceIsNotPulledPastTheCrease) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud cloud;
  for (int i = 0; i < 20000; ++i) cloud.points.emplace_back(u(rng), 0.0, u(rng));  // the face in view: y = 0, x ≥ 0
  const Eigen::Vector3d along(-0.5, std::sqrt(3.0) / 2, 0.0);  // the grazing face, 120° from the first
  for (int i = 0; i < 150; ++i) cloud.points.push_back(0.06 * u(rng) * along + Eigen::Vector3d(0, 0, u(rng)));
  const double l = iires::meanNeighbourSpacing(cloud.points);
  const auto r = iires::processOutliers(cloud, OutlierParams{});
  const iires::KnnIndex input(cloud.points);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  double farthest = 0;
  for (const Eigen::Vector3d& p : r.cloud.points) {
    input.knn(p, 1, idx, d2);
    farthest = std::max(farthest, std::sqrt(d2[0]));
  }
  std::printf("  %zu flagged (%zu pulled, %zu removed); the farthest point from the input %.2f l off\n",
              r.found, r.pulled, r.removed, farthest / l);
  EXPECT_GE(r.found, 1u);  // the case is the one above: the grazing face is flagged
  EXPECT_LE(farthest, 2.5 * l);
}

// A sphere sampled as a scanner's far field: dense arcs (scan lines, 600 points each) and sparse points between
// them, 1,500 over the sphere. Sparse points beside an arc lie off its plane by the sphere's sag — many arc
// spacings — and the test flags some; the pull moved 25–39 of them onto that plane, up to 0.034 radii off the
// sphere (seeds 1–3). A point beside the plane's points rather than above them stays now.
TEST(Outliers, SparsePointsBesideScanLinesOfACurvedSurfaceStayOnIt) {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> g(0.0, 1.0);
    PointCloud cloud;
    for (int line = 0; line < 12; ++line) {
      const double theta = M_PI * (0.15 + 0.7 * (line + 0.5 * u(rng)) / 12.0);
      const double phi0 = 2 * M_PI * u(rng), length = 0.5 + u(rng);
      for (int k = 0; k < 600; ++k) {
        const double phi = phi0 + length * k / 600.0, t = theta + 0.004 * (u(rng) - 0.5);
        cloud.points.emplace_back(std::sin(t) * std::cos(phi), std::sin(t) * std::sin(phi), std::cos(t));
      }
    }
    for (int k = 0; k < 1500; ++k) cloud.points.push_back(Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized());
    const auto r = iires::processOutliers(cloud, {});
    double worst = 0;
    for (const Eigen::Vector3d& p : r.cloud.points) worst = std::max(worst, std::abs(p.norm() - 1.0));
    EXPECT_LE(r.pulled, 2u) << seed;
    EXPECT_LE(worst, 0.02) << seed;
  }
}

}  // namespace
