// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/rotation_grid.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>

namespace {

constexpr double kDeg = M_PI / 180.0;

std::vector<Eigen::Matrix3d> randomRotations(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  std::vector<Eigen::Matrix3d> r;
  for (std::size_t i = 0; i < n; ++i)
    r.push_back(Eigen::Quaterniond(g(rng), g(rng), g(rng), g(rng)).normalized().toRotationMatrix());
  return r;
}

/// Largest angle from a random rotation to its nearest grid rotation (≈ the covering radius).
double coveringAngle(const std::vector<Eigen::Matrix3d>& grid, std::size_t probes) {
  double worst = 0;
  for (const auto& r : randomRotations(probes, 42)) {
    double best = 4;
    for (const auto& g : grid) {
      const double c = ((r.transpose() * g).trace() - 1) * 0.5;  // cos of the angle: compare without acos
      best = std::min(best, 1 - c);
    }
    worst = std::max(worst, std::acos(std::clamp(1 - best, -1.0, 1.0)));
  }
  return worst;
}

void expectRotations(const std::vector<Eigen::Matrix3d>& grid) {
  for (const auto& r : grid) {
    ASSERT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    ASSERT_NEAR(r.determinant(), 1.0, 1e-12);
  }
}

TEST(RotationGrid, EulerGridIsThePapersGrid) {
  const auto grid = iires::reg::eulerRotationGrid(24);
  ASSERT_EQ(grid.size(), 13824u);  // 24³, θ = π/12
  expectRotations(grid);
  EXPECT_TRUE(grid[0].isApprox(Eigen::Matrix3d::Identity()));
  // index (i·24 + j)·24 + k ↔ Rz(kθ)·Ry(jθ)·Rx(iθ)
  const double t = M_PI / 12;
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(3 * t, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(5 * t, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(7 * t, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  EXPECT_TRUE(grid[(7 * 24 + 5) * 24 + 3].isApprox(r, 1e-12));
}

TEST(RotationGrid, So3GridCountsAndIsDeterministic) {
  for (std::size_t n : {1u, 72u, 576u, 6144u}) {
    const auto grid = iires::reg::so3RotationGrid(n);
    ASSERT_EQ(grid.size(), n);
    expectRotations(grid);
  }
  EXPECT_EQ(iires::reg::so3RotationGrid(100), iires::reg::so3RotationGrid(100));
  EXPECT_THROW(iires::reg::so3RotationGrid(0), std::invalid_argument);
  EXPECT_THROW(iires::reg::eulerRotationGrid(0), std::invalid_argument);
}

TEST(RotationGrid, EveryRotationIsNearAGridRotation) {
  const auto so3 = iires::reg::so3RotationGrid(6144);
  const auto euler = iires::reg::eulerRotationGrid(24);
  const double coverSo3 = coveringAngle(so3, 1500), coverEuler = coveringAngle(euler, 1500);
  RecordProperty("cover_so3_deg", std::to_string(coverSo3 / kDeg));
  RecordProperty("cover_euler_deg", std::to_string(coverEuler / kDeg));
  std::printf("covering angle: so3(6144) %.2f deg, euler(24^3) %.2f deg\n", coverSo3 / kDeg, coverEuler / kDeg);
  EXPECT_LT(coverSo3, 12.0 * kDeg);
  EXPECT_LT(coverEuler, 12.5 * kDeg);
  EXPECT_LE(coverSo3, coverEuler);  // the uniform grid is at least as fine with 44 % of the candidates
  // Uniformity: no two SO(3) grid rotations (nearly) coincide, unlike the Euler grid's duplicates.
  double closest = 4;
  for (std::size_t i = 0; i < 600; ++i)
    for (std::size_t j = i + 1; j < so3.size(); ++j)
      closest = std::min(closest, iires::reg::rotationAngle(so3[i], so3[j]));
  EXPECT_GT(closest, 2.0 * kDeg);
  // Rz(π)·Ry(π)·Rx(π) = I: the Euler grid holds duplicates.
  EXPECT_LT(iires::reg::rotationAngle(euler[0], euler[(12 * 24 + 12) * 24 + 12]), 1e-6);
}

TEST(RotationGrid, AnglesAndNames) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(2.0, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  EXPECT_NEAR(iires::reg::rotationAngle(r), 2.0, 1e-9);
  EXPECT_NEAR(iires::reg::rotationAngle(r, r), 0.0, 1e-6);
  EXPECT_EQ(iires::reg::parseRotationGridType("euler"), iires::reg::RotationGridType::kEuler);
  EXPECT_EQ(iires::reg::toString(iires::reg::parseRotationGridType("so3")), "so3");
  EXPECT_THROW(iires::reg::parseRotationGridType("hopf"), std::invalid_argument);
}

}  // namespace
