// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/curvature.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "iires/knn.hpp"
#include "iires/normals.hpp"
#include "shapes.hpp"

namespace {

double mean(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / v.size(); }

double cv(const std::vector<double>& v) {
  const double m = mean(v);
  double s = 0;
  for (double x : v) s += (x - m) * (x - m);
  return std::sqrt(s / v.size()) / m;
}

/// Mean over points of the mean distance to the k nearest neighbours (brute-force oracle input).
double meanKnnDistance(const std::vector<Eigen::Vector3d>& p, int k) {
  iires::KnnIndex index(p);
  double sum = 0;
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < p.size(); ++i) {
    index.knn(p[i], k + 1, idx, d2);
    for (std::size_t t = 1; t < idx.size(); ++t) sum += std::sqrt(d2[t]) / k;
  }
  return sum / p.size();
}

/// Random points on a cylinder of radius R, height H (no caps), outward normals.
iires::PointCloud cylinderCloud(std::size_t n, double r, double height, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  iires::PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const double phi = 2 * M_PI * u(rng), z = height * u(rng);
    c.points.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
    c.normals.emplace_back(std::cos(phi), std::sin(phi), 0.0);
  }
  return c;
}

TEST(CurvatureParams, ValidateRejectsBadValues) {
  iires::CurvatureParams p;
  EXPECT_NO_THROW(p.validate());
  p.beta = 1.5;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.k = 2;
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p = {};
  p.ratios = {1.0, 2.0};  // must go flat → curved, non-increasing
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p.ratios = {};
  EXPECT_THROW(p.validate(), std::invalid_argument);
  p.ratios = {1.0, -1.0};
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

TEST(Curvature, SizeMismatchAndEmpty) {
  const auto c = iires::test::sphereCloud(100);
  EXPECT_THROW(iires::computeCurvature(c.points, {}), std::invalid_argument);
  const auto r = iires::computeCurvature({}, {});
  EXPECT_TRUE(r.eta.empty());
  EXPECT_EQ(r.pointsPerLevel.size(), 5u);
}

TEST(Curvature, PlaneIsFlatAndOneLevel) {
  auto c = iires::test::planeCloud(5000, 1.0, 3.0);
  c.normals = iires::estimateNormals(c.points);
  const auto r = iires::computeCurvature(c.points, c.normals);
  for (double e : r.eta) EXPECT_LT(e, 1e-6);
  EXPECT_TRUE(r.uniform);
  for (int q : r.level) EXPECT_EQ(q, 2);  // the level of ratio 1.0
  EXPECT_NEAR(r.normalization, 1.0, 1e-12);
  for (double s : r.sizeFactor) EXPECT_NEAR(s, 1.0, 1e-12);
}

// With exact normals the angle between n_p and n_q on a sphere of radius R is 2·asin(|p − q|/(2R)), so eq. 9
// has a brute-force oracle. Its expected value for a uniform (Poisson) sampling of density ρ = n/(4πR²):
// E[d_j] = Γ(j + ½)/(Γ(j)·√(πρ)) for the j-th neighbour, so η ≈ (1/R)·(1/k)Σ_j E[d_j] — the h/R scale.
TEST(Curvature, SphereMatchesAnalyticMeanAngle) {
  const double R = 2.0;
  const std::size_t n = 20000;
  const int k = 10;
  const auto c = iires::test::sphereCloud(n, R, 5);
  const auto eta = iires::curvatureField(c.points, c.normals, k, 2);
  // Oracle per point.
  iires::KnnIndex index(c.points);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < n; i += 97) {
    index.knn(c.points[i], k + 1, idx, d2);
    double sum = 0;
    for (std::size_t t = 1; t < idx.size(); ++t) sum += 2 * std::asin(std::sqrt(d2[t]) / (2 * R));
    EXPECT_NEAR(eta[i], sum / k, 1e-9);
  }
  // Analytic expectation.
  const double rho = n / (4 * M_PI * R * R);
  double expected = 0;
  for (int j = 1; j <= k; ++j) expected += std::exp(std::lgamma(j + 0.5) - std::lgamma(j)) / std::sqrt(M_PI * rho);
  expected /= k * R;
  EXPECT_NEAR(mean(eta), expected, 0.03 * expected);
  // With estimated (PCA) normals the field stays close and nearly constant on a uniform (Fibonacci) sphere.
  const auto fib = iires::test::fibonacciSphere(n, R);
  const auto fibEta = iires::curvatureField(fib, iires::estimateNormals(fib), k);
  const double fibExpected = meanKnnDistance(fib, k) / R;
  EXPECT_NEAR(mean(fibEta), fibExpected, 0.05 * fibExpected);
  EXPECT_LT(cv(fibEta), 0.1);
  // Smoothing (eq. 8) keeps the mean and lowers the spread; the whole field is judged uniform: one level.
  const auto r = iires::computeCurvature(fib, iires::estimateNormals(fib));
  EXPECT_NEAR(mean(r.smoothedEta), mean(r.eta), 0.01 * mean(r.eta));
  EXPECT_LT(cv(r.smoothedEta), cv(r.eta));
  EXPECT_TRUE(r.uniform);
  EXPECT_EQ(r.pointsPerLevel[2], n);
}

// A sphere sampled 25 times more densely at one pole than at the other has one curvature everywhere: the field
// is uniform and every point takes the middle level. Eq. 9's raw angle, taken over k neighbours whose radius
// follows the density, is five times larger on the sparse side and split the sphere into all five levels.
TEST(Curvature, DensityGradientIsNotCurvature) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const auto dense = iires::test::sphereCloud(60000, 1.0, 11);
  iires::PointCloud c;
  for (std::size_t i = 0; i < dense.size(); ++i)
    if (u(rng) < std::pow(25.0, -(1.0 - dense.points[i].x()) / 2.0)) {  // keep 1 at x = 1, 1/25 at x = −1
      c.points.push_back(dense.points[i]);
      c.normals.push_back(dense.normals[i]);
    }
  ASSERT_GT(c.size(), 10000u);
  const auto r = iires::computeCurvature(c.points, c.normals);
  EXPECT_TRUE(r.uniform);
  EXPECT_EQ(r.pointsPerLevel[2], c.size());
  EXPECT_LT(cv(r.smoothedEta), 0.15);
}

// On a cylinder only the circumferential offset turns the normal: angle = |Δs_φ|/R = d·|cos θ|/R for a
// neighbour at distance d and direction θ, and E|cos θ| = 2/π for isotropic neighbours, so
// η_cylinder ≈ (2/π)·η_sphere at equal radius and density.
TEST(Curvature, CylinderIsBetweenPlaneAndSphere) {
  const double R = 1.0, H = 2 * M_PI * R;  // area 4π²R²·... chosen so that density equals the sphere's below
  const std::size_t nCyl = 20000;
  const auto cyl = cylinderCloud(nCyl, R, H, 9);
  const std::size_t nSph = static_cast<std::size_t>(nCyl * (4 * M_PI * R * R) / (2 * M_PI * R * H));
  const auto sph = iires::test::sphereCloud(nSph, R, 10);
  const double etaCyl = mean(iires::curvatureField(cyl.points, cyl.normals, 10));
  const double etaSph = mean(iires::curvatureField(sph.points, sph.normals, 10));
  EXPECT_GT(etaCyl, 0.0);
  EXPECT_NEAR(etaCyl / etaSph, 2.0 / M_PI, 0.05);
}

TEST(Curvature, QuantileLevelsHaveEqualCounts) {
  std::vector<double> v(1003);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (double& x : v) x = u(rng);
  std::vector<double> th;
  const auto level = iires::quantileLevels(v, 5, &th);
  ASSERT_EQ(th.size(), 4u);
  EXPECT_TRUE(std::is_sorted(th.begin(), th.end()));
  std::vector<std::size_t> count(5, 0);
  for (std::size_t i = 0; i < v.size(); ++i) {
    ++count[level[i]];
    if (level[i] > 0) {
      EXPECT_GT(v[i], th[level[i] - 1]);
    }
    if (level[i] < 4) {
      EXPECT_LE(v[i], th[level[i]]);
    }
  }
  for (std::size_t c : count) EXPECT_TRUE(c == 200 || c == 201) << c;
  // Ties stay together, in the lowest level they reach: a field that is mostly 0 puts all zeros in level 0.
  const auto tied = iires::quantileLevels(std::vector<double>(10, 1.0), 5, nullptr);
  for (int q : tied) EXPECT_EQ(q, 0);
  std::vector<double> mostlyFlat(100, 0.0);
  for (int i = 90; i < 100; ++i) mostlyFlat[i] = i;
  const auto mf = iires::quantileLevels(mostlyFlat, 5, nullptr);
  for (int i = 0; i < 90; ++i) EXPECT_EQ(mf[i], 0);
  for (int i = 90; i < 100; ++i) EXPECT_EQ(mf[i], 4);
}

/// A plane with a hemisphere bump: flat, curved and the transition in one cloud.
iires::PointCloud planeWithBump(std::size_t nPlane, std::size_t nBump) {
  auto c = iires::test::planeCloud(nPlane, 4.0, 1.0, 21);
  std::vector<Eigen::Vector3d> kept;
  for (const auto& p : c.points)
    if ((p.head<2>() - Eigen::Vector2d(2, 2)).norm() > 0.5) kept.push_back(p);
  c.points = kept;
  c.normals.assign(kept.size(), Eigen::Vector3d::UnitZ());
  const auto s = iires::test::sphereCloud(nBump * 2, 0.5, 22, Eigen::Vector3d(2, 2, 0));
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s.points[i].z() > 0) {
      c.points.push_back(s.points[i]);
      c.normals.push_back(s.normals[i]);
    }
  return c;
}

TEST(Curvature, LevelsFollowCurvatureAndSizeFactorsAreMonotone) {
  const auto c = planeWithBump(30000, 3000);
  iires::CurvatureParams p;
  p.sizeSmoothIterations = 0;  // s exactly c·r_level (the smoothed field: SizeFactorSmoothedAcrossLevels)
  const auto r = iires::computeCurvature(c.points, c.normals, p);
  ASSERT_FALSE(r.uniform);
  const std::size_t n = c.size();
  std::size_t total = 0;
  for (std::size_t q = 0; q < 5; ++q) {
    total += r.pointsPerLevel[q];
    if (q > 0 && r.pointsPerLevel[q] > 0 && r.pointsPerLevel[q - 1] > 0) {
      EXPECT_GE(r.meanEtaPerLevel[q], r.meanEtaPerLevel[q - 1]);
    }
  }
  EXPECT_EQ(total, n);
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_DOUBLE_EQ(r.sizeFactor[i], r.normalization * p.ratios[r.level[i]]);
    for (std::size_t j = i + 1; j < std::min(n, i + 3); ++j)
      if (r.level[i] < r.level[j]) {
        EXPECT_GE(r.sizeFactor[i], r.sizeFactor[j]);
      }
  }
  // Bump points (on the sphere, away from its rim) are in the most curved levels; far plane points flattest.
  std::size_t bumpHigh = 0, bump = 0, farLow = 0, far = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double rad = (c.points[i].head<2>() - Eigen::Vector2d(2, 2)).norm();
    if (c.points[i].z() > 0.15) {
      ++bump;
      bumpHigh += r.level[i] >= 3;
    } else if (rad > 1.2) {
      ++far;
      farLow += r.level[i] <= 2;
    }
  }
  EXPECT_GT(static_cast<double>(bumpHigh) / bump, 0.95);
  EXPECT_GT(static_cast<double>(farLow) / far, 0.95);
  // Normalisation: area-weighted mean of 1/s² is 1 (weights = squared mean k-NN distance).
  iires::KnnIndex index(c.points);
  double sw = 0, swInv = 0;
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < n; ++i) {
    index.knn(c.points[i], p.k + 1, idx, d2);
    double m = 0;
    for (std::size_t t = 1; t < idx.size(); ++t) m += std::sqrt(d2[t]) / p.k;
    sw += m * m;
    swInv += m * m / (r.sizeFactor[i] * r.sizeFactor[i]);
  }
  EXPECT_NEAR(swInv / sw, 1.0, 1e-6);
}

// Level borders: the smoothed size factor stays within the ratios' range, keeps the flat and curved ends, and
// has a smaller worst jump between neighbours (6 nearest; |log ratio|) than the raw c·r_level.
TEST(Curvature, SizeFactorSmoothedAcrossLevels) {
  const auto c = planeWithBump(30000, 3000);
  iires::CurvatureParams raw, smooth;
  raw.sizeSmoothIterations = 0;
  const auto a = iires::computeCurvature(c.points, c.normals, raw);
  const auto b = iires::computeCurvature(c.points, c.normals, smooth);
  ASSERT_EQ(a.level, b.level);
  iires::KnnIndex index(c.points);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  double jumpA = 0, jumpB = 0;
  for (std::size_t i = 0; i < c.size(); ++i) {
    EXPECT_GE(b.sizeFactor[i], b.normalization * raw.ratios.back() * (1 - 1e-9));
    EXPECT_LE(b.sizeFactor[i], b.normalization * raw.ratios.front() * (1 + 1e-9));
    index.knn(c.points[i], 7, idx, d2);
    for (std::size_t t = 1; t < idx.size(); ++t) {
      jumpA = std::max(jumpA, std::abs(std::log(a.sizeFactor[i] / a.sizeFactor[idx[t]])));
      jumpB = std::max(jumpB, std::abs(std::log(b.sizeFactor[i] / b.sizeFactor[idx[t]])));
    }
  }
  EXPECT_LT(jumpB, 0.6 * jumpA);
  // Far plane points keep (about) the flattest ratio; the bump's top the most curved one.
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double rad = (c.points[i].head<2>() - Eigen::Vector2d(2, 2)).norm();
    if (rad > 1.5) {
      EXPECT_NEAR(b.sizeFactor[i] / b.normalization, raw.ratios.front(), 0.05);
    }
    if (c.points[i].z() > 0.45) {
      EXPECT_NEAR(b.sizeFactor[i] / b.normalization, raw.ratios.back(), 0.05);
    }
  }
}

TEST(Curvature, SmoothingIsEq8) {
  // Two points far apart from a cluster: check one Jacobi step by hand on a 4-point line with k = 1.
  const std::vector<Eigen::Vector3d> p = {{0, 0, 0}, {1, 0, 0}, {10, 0, 0}, {11.5, 0, 0}};
  const std::vector<double> f = {0, 1, 2, 4};
  const auto s = iires::smoothField(p, f, 1, 0.5, 1);
  EXPECT_DOUBLE_EQ(s[0], 0.5 * 0 + 0.5 * 1);
  EXPECT_DOUBLE_EQ(s[1], 0.5 * 1 + 0.5 * 0);
  EXPECT_DOUBLE_EQ(s[2], 0.5 * 2 + 0.5 * 4);
  EXPECT_DOUBLE_EQ(s[3], 0.5 * 4 + 0.5 * 2);
  EXPECT_EQ(iires::smoothField(p, f, 1, 0.5, 0), f);
}

TEST(Curvature, DeterministicAcrossThreadCounts) {
  const auto c = planeWithBump(20000, 2000);
  const auto a = iires::computeCurvature(c.points, c.normals, {}, iires::Execution{1});
  const auto b = iires::computeCurvature(c.points, c.normals, {}, iires::Execution{2});
  EXPECT_EQ(a.eta, b.eta);
  EXPECT_EQ(a.smoothedEta, b.smoothedEta);
  EXPECT_EQ(a.level, b.level);
  EXPECT_EQ(a.sizeFactor, b.sizeFactor);
}

}  // namespace
