// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/open_side.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <stdexcept>
#include <vector>

namespace {

using Points = std::vector<Eigen::Vector3d>;
using iires::reg::openSide;
using iires::reg::OpenSideParams;

/// n evenly spread points on the unit sphere (Fibonacci lattice), as the registration's resampling gives.
Points fibonacciSphere(std::size_t n) {
  Points p;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (std::size_t i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * static_cast<double>(i) + 1.0) / static_cast<double>(n);
    const double r = std::sqrt(1.0 - z * z), a = golden * static_cast<double>(i);
    p.emplace_back(r * std::cos(a), r * std::sin(a), z);
  }
  return p;
}

TEST(OpenSide, AClosedSurfaceHasNoRim) {
  const auto side = openSide(fibonacciSphere(2000));
  EXPECT_EQ(side.rimPoints, 0u);
  EXPECT_EQ(side.direction, Eigen::Vector3d::Zero());
}

TEST(OpenSide, ACutSphereOpensTowardsTheCut) {
  // The cap above z = 0.5 removed: the rim is the circle at z = 0.5 (circumference 2π·0.87 ≈ 5.4, spacing
  // ≈ 0.08: about 70 points), and it lies towards +z from the part's centroid.
  Points cut;
  for (const auto& x : fibonacciSphere(2000))
    if (x.z() < 0.5) cut.push_back(x);
  const auto side = openSide(cut);
  EXPECT_GT(side.rimPoints, 40u);
  EXPECT_LT(side.rimPoints, 140u);
  EXPECT_GT(side.direction.z(), 0.99);
  EXPECT_NEAR(side.direction.norm(), 1.0, 1e-12);
  // A rotated copy opens the rotated way.
  const Eigen::Matrix3d R = Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Points rotated;
  for (const auto& x : cut) rotated.push_back(R * x);
  EXPECT_GT(openSide(rotated).direction.dot(R * Eigen::Vector3d::UnitZ()), 0.99);
}

TEST(OpenSide, SameResultForAnyThreadCount) {
  Points cut;
  for (const auto& x : fibonacciSphere(3000))
    if (x.x() + 0.3 * x.y() < 0.4) cut.push_back(x);
  const auto one = openSide(cut, {}, 1), two = openSide(cut, {}, 2);
  EXPECT_EQ(one.rimPoints, two.rimPoints);
  EXPECT_EQ(one.direction, two.direction);
}

TEST(OpenSide, TinyInputsAndBadParameters) {
  EXPECT_EQ(openSide(Points(3, Eigen::Vector3d::Zero())).rimPoints, 0u);  // fewer points than neighbours
  OpenSideParams p;
  p.neighbours = 3;
  EXPECT_THROW(openSide(fibonacciSphere(100), p), std::invalid_argument);
  p = {};
  p.minGapDeg = 360;
  EXPECT_THROW(p.validate(), std::invalid_argument);
}

}  // namespace
