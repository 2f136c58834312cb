// SPDX-License-Identifier: GPL-3.0-or-later
// Regression tests for inputs the libFuzzer targets (tests/fuzz/) found. Each test rebuilds the crashing input
// the way the harness decodes it (or replays its bytes through the harness's decoder) and checks the fixed
// behaviour.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "iires/resample.hpp"
#include "iires/validate.hpp"
#include "fuzz/resample_input.hpp"

namespace iires::test {
namespace {

/// fuzz_resample-crash-1126177256 (raw-double mode, N = 10, Euclidean, no pre-processing): 14 points of which
/// most are denormal (~1e-312) plus one at 5e244. The point's square overflows, and the resampler returned 10
/// NaN points without an error. Now validation rejects coordinates beyond kMaxCoordinate.
PointCloud fuzzCloud(bool withHugePoint) {
  PointCloud cloud;
  cloud.points = {{-500.0, -500.0, 250.0},
                  {-500.0, -300.0, 4.074231918653e-312},
                  {4.081609169645e-312, 1.36605551305e-312, 4.084779729763e-312},
                  {1.36545455721e-312, 1.36605551305e-312, 4.084779729763e-312},
                  {1.36758898657e-312, 1.36646996535e-312, 4.084779729763e-312},
                  {1.368625117327e-312, 1.36729886996e-312, 4.083743599005e-312},
                  {4.084779729763e-312, 1.36646996535e-312, 4.083743599005e-312},
                  {4.083743599005e-312, 1.36524733106e-312, 4.083743599005e-312},
                  {4.081609169645e-312, 1.36412830984e-312, 4.083743599005e-312},
                  {1.36545455721e-312, 1.36412830984e-312, 1.33228334907999e-309},
                  {1.36758898657e-312, 1.36524733106e-312, 4.083743599005e-312},
                  {1.368625117327e-312, 1.36646996535e-312, 4.081609169645e-312},
                  {4.084779729763e-312, 1.36605551305e-312, 4.081609169645e-312},
                  {4.083743599005e-312, 1.367526818724e-312, 4.083743599005e-312}};
  if (withHugePoint) cloud.points.emplace_back(5.164816636419451e+120, 4.460149039706188e+43, 5.462437423415254e+244);
  return cloud;
}

ResampleParams fuzzParams() {
  ResampleParams params;
  params.targetCount = 10;
  params.intrinsic = false;
  params.preprocess = false;
  params.maxPasses = 4;
  params.maxRelaxIterations = 8;
  return params;
}

TEST(FuzzRegression, HugeFiniteCoordinateIsRejectedNotTurnedIntoNaN) {
  try {
    const ResampleResult result = resample(fuzzCloud(true), fuzzParams());
    FAIL() << "accepted a point at 5e244 and returned " << result.cloud.size() << " points";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("magnitude"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("point 14"), std::string::npos) << e.what();
  }
}

TEST(FuzzRegression, ValidateRejectsCoordinatesBeyondTheLimitOnly) {
  PointCloud ok;
  const double m = kMaxCoordinate;
  ok.points = {{m, 0, 0}, {0, m, 0}, {0, 0, -m}, {-m, -m, m}};
  EXPECT_NO_THROW(validateCloud(ok, 4));
  PointCloud bad = ok;
  bad.points[2].y() = -2 * m;
  EXPECT_THROW(validateCloud(bad, 4, "cloud.ply"), InputError);
}

TEST(FuzzRegression, DenormalClusterGivesAnErrorOrFiniteOutput) {
  // The same cloud without the huge point: a cluster of denormal coordinates next to two ordinary points. The
  // contract: either an InputError or exactly N finite points with unit normals.
  try {
    const ResampleResult result = resample(fuzzCloud(false), fuzzParams());
    ASSERT_EQ(result.cloud.size(), 10u);
    ASSERT_TRUE(result.cloud.hasNormals());
    for (std::size_t i = 0; i < result.cloud.size(); ++i) {
      EXPECT_TRUE(result.cloud.points[i].allFinite()) << i;
      EXPECT_NEAR(result.cloud.normals[i].norm(), 1.0, 1e-6) << i;
    }
  } catch (const InputError&) {
  }
}

/// fuzz_resample-crash-e278560 (raw-double mode, N = 10, Euclidean): a 6×6 paraboloid grid of which 24 points
/// were overwritten with denormal coordinates (1e-317 .. 1e-309), i.e. a cluster of near-coincident points.
/// Differences inside the cluster have squared norms that underflow to 0 and the output held NaN. Validation
/// now sets coordinates below kTinyCoordinate to 0, so the cluster merges into one point.
TEST(FuzzRegression, DenormalNearDuplicatesDoNotProduceNaN) {
  PointCloud cloud;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      const double x = i * 200.0 - 500.0, y = j * 200.0 - 500.0;
      cloud.points.emplace_back(x, y, std::floor((x * x + y * y) / 2000.0));
    }
  const double tiny[] = {4.07e-312, 1.37e-312, 2.08e-317, 3.50e-310, 1.05e-309, 7.4e-315};
  for (int i = 9; i < 33; ++i)
    cloud.points[i] = Eigen::Vector3d(tiny[i % 6], tiny[(i + 1) % 6], tiny[(i + 3) % 6]);
  try {
    const ResampleResult result = resample(cloud, fuzzParams());
    ASSERT_EQ(result.cloud.size(), 10u);
    for (std::size_t i = 0; i < result.cloud.size(); ++i) {
      EXPECT_TRUE(result.cloud.points[i].allFinite()) << i;
      EXPECT_TRUE(result.cloud.normals[i].allFinite()) << i;
    }
  } catch (const InputError&) {
  }
  PointCloud single;
  single.points = {{1e-200, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, 0}};
  EXPECT_EQ(validateCloud(single, 4).duplicatesMerged, 1u);  // 1e-200 is 0
}

/// fuzz_resample-crash-b5f4b6ed (int16 mode with normals, scale 1000, N = 20, intrinsic, sharp edges, 6 fixed
/// samples, seed 31): the input normals include zero vectors (the first of five duplicates at the origin keeps
/// its zero normal), and the output had non-finite points and normals. Zero-length input normals
/// now make the given normals unusable (they are recomputed), as non-finite ones do.
TEST(FuzzRegression, ZeroLengthInputNormalsGiveUnitOutputNormals) {
  const int rows[][6] = {
      {500, 250, -300, -500, 170, -300},
      {-300, 90, -300, -100, 50, -300},
      {154, -500, -500, 250, -500, -300},
      {170, -500, -100, 130, -500, -11164},
      {25854, 12800, -11264, 11518, 23041, 10752},
      {-2818, -22015, -25600, 3327, -32002, -25600},
      {-11009, 13054, -25600, -25345, 2815, -25600},
      {25855, 100, 50, -300, 300, 90},
      {-300, 500, 170, -100, -500, 130},
      {-100, -300, 50, -100, -100, 10},
      {0, 0, 0, 0, 0, 0},
      {0, 0, 0, 0, 0, 0},
      {0, 0, 0, 0, 0, 0},
      {0, 0, 0, 0, 0, 0},
      {0, 0, 0, 0, 0, 0},
      {0, 0, 0, -25600, 25855, 2560},
      {90, 300, 500, 170, 500, -500},
      {250, 500, -300, 170, 500, -100},
      {130, 500, 100, 130, 500, 300}};
  PointCloud cloud;
  for (const auto& r : rows) {
    cloud.points.emplace_back(1000.0 * r[0], 1000.0 * r[1], 1000.0 * r[2]);
    cloud.normals.emplace_back(r[3], r[4], r[5]);
  }
  ResampleParams params;
  params.targetCount = 20;
  params.intrinsic = true;
  params.preprocess = false;
  params.sharpEdges = true;
  params.mls.k = 3;
  params.maxPasses = 0;
  params.maxRelaxIterations = 12;
  params.relaxPerPass = 1;
  params.neighbours = 6;
  params.seed = 31;
  for (int i = 0; i < 6; ++i) params.fixedSamples.push_back(cloud.points[i]);
  const ResampleResult result = resample(cloud, params);
  ASSERT_EQ(result.cloud.size(), 20u);
  ASSERT_TRUE(result.cloud.hasNormals());
  for (std::size_t i = 0; i < result.cloud.size(); ++i) {
    EXPECT_TRUE(result.cloud.points[i].allFinite()) << i;
    EXPECT_NEAR(result.cloud.normals[i].norm(), 1.0, 1e-6) << i;
  }
}

TEST(FuzzRegression, ValidateDropsNormalsWhenOneIsZero) {
  PointCloud cloud;
  cloud.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  cloud.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 0}, {0, 0, 1}};
  validateCloud(cloud, 4);
  EXPECT_EQ(cloud.size(), 4u);
  EXPECT_TRUE(cloud.normals.empty());
}

/// fuzz_resample-crash-020e56d2 (int16 mode, N = 3, Euclidean, pre-processing on, 2 passes, 8 final iterations):
/// 26 scattered points whose 1-rings give the edge operations nothing to collapse, so the resampler threw "could
/// not reach the requested count". Now a last-resort step drops the closest samples (or adds the input points
/// farthest from them): exactly N finite points with unit normals.
TEST(FuzzRegression, DegenerateRingsStillGiveExactlyN) {
  PointCloud cloud;
  cloud.points = {{-1524, 3326, 3326}, {-512, -300, 170}, {-500, -100, 130}, {-500, 100, 130}, {-500, 300, 170},
                  {-500, 500, 250},    {-300, -500, 170}, {-300, -300, 90},  {-300, -100, 50},  {12244, 100, 50},
                  {-300, 300, 90},     {-300, 500, 170},  {-100, -500, 130}, {-100, -300, 50},  {156, 500, -100},
                  {10, 25678, 25600},  {2560, 25600, 42}, {300, 50, 100},    {500, 130, 300},   {-500, 170, 300},
                  {-300, 90, 300},     {-100, 50, 300},   {100, 50, 300},    {300, 90, 300},    {500, 170, 500},
                  {500, 500, 250}};
  ResampleParams params;
  params.targetCount = 3;
  params.intrinsic = false;
  params.maxPasses = 2;
  params.maxRelaxIterations = 8;
  const ResampleResult r = resample(cloud, params);
  ASSERT_EQ(r.cloud.size(), 3u);
  ASSERT_EQ(r.cloud.normals.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_TRUE(r.cloud.points[i].allFinite());
    EXPECT_NEAR(r.cloud.normals[i].norm(), 1.0, 1e-6);
  }
}

}  // namespace
/// fuzz_resample-crash-3e4116f8 (int16 mode, scale 1, N = 40, Euclidean, no pre-processing, sharp edges, 2 passes,
/// 8 final iterations, 14 candidates): 65 points on a coarse grid. The crease fits traced lines off the cloud,
/// and those held samples failed the run ("output points left the input's bounding box", 30 of them by up to
/// 2,989 units; 3 by 309 once traces stopped off the input). Held samples outside the box every output point must
/// lie in are dropped now.
TEST(FuzzRegression, SharpEdgesOnACoarseGridStayWithinTheInput) {
  const std::uint8_t input[] = {
      0x27, 0x90, 0x08, 0x9a, 0x00, 0x0c, 0xfe, 0x0c, 0xfe, 0x06, 0xff, 0x0c, 0xfe, 0x9a, 0xfe, 0x06, 0xff, 0x0c,
      0xfe, 0x29, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0xff, 0x06, 0xff, 0x0c, 0xfe, 0xb8, 0xff, 0x06,
      0xff, 0x0c, 0xfe, 0x47, 0x00, 0x06, 0xff, 0x0c, 0xfe, 0xd6, 0x00, 0x06, 0xff, 0x0c, 0xfe, 0x65, 0x01, 0x06,
      0xff, 0x0c, 0xfe, 0xf4, 0x01, 0x06, 0xff, 0x9a, 0xfe, 0x0c, 0xfe, 0x4d, 0xff, 0x9a, 0xfe, 0x9a, 0xfe, 0x4d,
      0xff, 0x9a, 0xfe, 0x29, 0xff, 0x4d, 0xff, 0x9a, 0xfe, 0xb8, 0xff, 0x4d, 0xff, 0x9a, 0xfe, 0x47, 0x00, 0x4d,
      0xff, 0x9a, 0xfe, 0xd6, 0x00, 0x4d, 0xff, 0x9a, 0xfe, 0x65, 0x01, 0x4d, 0xff, 0x9a, 0xfe, 0xf4, 0x01, 0x4d,
      0xff, 0x29, 0xff, 0x0c, 0xfe, 0x94, 0xff, 0x29, 0xff, 0x9a, 0xfe, 0x94, 0xff, 0x29, 0xff, 0x29, 0xff, 0x94,
      0xff, 0x29, 0xff, 0xb8, 0xff, 0x94, 0xff, 0x29, 0xff, 0x47, 0x00, 0x94, 0xff, 0x29, 0xff, 0xd6, 0x00, 0x94,
      0xff, 0x29, 0xff, 0x65, 0x01, 0x94, 0xff, 0x29, 0xff, 0xf4, 0x01, 0x94, 0xff, 0xb8, 0xff, 0x0c, 0xfe, 0xdc,
      0xff, 0xb8, 0xff, 0x9a, 0xfe, 0xdc, 0xff, 0xb8, 0xff, 0x29, 0xff, 0xdc, 0xff, 0xb8, 0xff, 0xb8, 0xff, 0xdc,
      0xff, 0xb8, 0xff, 0x47, 0x00, 0xdc, 0xff, 0xb8, 0xff, 0xd6, 0x00, 0xdc, 0xff, 0xb8, 0xff, 0x65, 0x01, 0xdc,
      0xff, 0xb8, 0xff, 0xf4, 0x01, 0xdc, 0xff, 0x47, 0x00, 0x0c, 0xfe, 0xdc, 0xff, 0x47, 0x00, 0x9a, 0xfe, 0xdc,
      0xff, 0x47, 0x00, 0x29, 0xff, 0xdc, 0xff, 0x47, 0x00, 0xb8, 0xff, 0xdc, 0xff, 0x47, 0x00, 0x47, 0x00, 0xdc,
      0xff, 0x47, 0x00, 0xd6, 0x00, 0xdc, 0xff, 0x47, 0x00, 0x65, 0x01, 0xdc, 0xff, 0x47, 0x00, 0xf4, 0x01, 0xdc,
      0xff, 0xd6, 0x00, 0x0c, 0xfe, 0x95, 0xff, 0xd6, 0x00, 0x9a, 0xfe, 0x95, 0xff, 0xd6, 0x00, 0x29, 0xff, 0x95,
      0xff, 0xd6, 0x00, 0xb8, 0xff, 0x95, 0xff, 0xd6, 0x00, 0x47, 0x00, 0x95, 0xff, 0xd6, 0x00, 0xd6, 0x00, 0x95,
      0xff, 0xd6, 0x00, 0x65, 0x01, 0x95, 0xff, 0xd6, 0x00, 0xf4, 0x01, 0x95, 0xff, 0x65, 0x01, 0x0c, 0xfe, 0x4d,
      0xff, 0x65, 0x01, 0x9a, 0xfe, 0x4d, 0xff, 0x65, 0x01, 0x29, 0xff, 0x4d, 0xff, 0x65, 0x01, 0xb8, 0xff, 0x4d,
      0xff, 0x65, 0x01, 0x47, 0x00, 0x4d, 0xff, 0x65, 0x01, 0xd6, 0x00, 0x4d, 0xff, 0x65, 0x01, 0x65, 0x01, 0x4d,
      0xff, 0x65, 0x01, 0xf4, 0x01, 0x4d, 0xff, 0xf4, 0x01, 0x0c, 0xfe, 0x06, 0xff, 0xf4, 0x01, 0x9a, 0xfe, 0x06,
      0xff, 0xf4, 0x01, 0x29, 0xff, 0x06, 0xff, 0xf4, 0x01, 0xb8, 0xff, 0x06, 0xff, 0xf4, 0x01, 0x47, 0x00, 0x06,
      0xff, 0xf4, 0x01, 0xd6, 0x00, 0x06, 0xff, 0xf4, 0x01, 0x65, 0x01, 0x06, 0xff, 0xf4, 0x01, 0xf4, 0x01, 0x06,
      0xff};
  const auto in = iires::fuzz::decodeResampleInput(input, sizeof input);
  ASSERT_TRUE(in);
  ASSERT_EQ(in->cloud.size(), 65u);
  ASSERT_TRUE(in->params.sharpEdges);
  const ResampleResult result = resample(in->cloud, in->params, iires::Execution{1});
  ASSERT_EQ(result.cloud.size(), 40u);
  for (std::size_t i = 0; i < result.cloud.size(); ++i) EXPECT_TRUE(result.cloud.points[i].allFinite()) << i;
}

}  // namespace iires::test
