// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Synthetic shapes with known answers for the tests.
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "iires/types.hpp"

namespace iires::test {

/// Random points on a sphere (uniform by area), outward normals.
inline PointCloud sphereCloud(std::size_t n, double radius = 1.0, std::uint64_t seed = 1,
                              const Eigen::Vector3d& centre = Eigen::Vector3d::Zero()) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    c.points.push_back(centre + radius * d);
    c.normals.push_back(d);
  }
  return c;
}

/// A closed box [0,1]² × [0, t] sampled uniformly by area on all six faces, t = @p thicknessSpacings times the
/// sampling's spacing (0.5/√density, the mean nearest-neighbour distance); positions only. @p spacing receives it.
inline PointCloud thinBoxCloud(std::size_t n, double thicknessSpacings, std::uint64_t seed, double* spacing = nullptr,
                               double* thickness = nullptr) {
  double t = 0, s = 0;
  for (int it = 0; it < 20; ++it) {  // the thickness changes the area, which changes the spacing
    s = 0.5 / std::sqrt(static_cast<double>(n) / (2.0 + 4.0 * t));
    t = thicknessSpacings * s;
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud c;
  for (std::size_t i = 0; i < n; ++i) {
    const double pick = u(rng) * (2.0 + 4.0 * t), a = u(rng), b = u(rng);
    if (pick < 2.0) {
      c.points.emplace_back(a, b, pick < 1.0 ? 0.0 : t);
      continue;
    }
    const int face = std::min(3, static_cast<int>((pick - 2.0) / t));  // which rim face
    const Eigen::Vector3d rim[4] = {{0, a, b * t}, {1, a, b * t}, {a, 0, b * t}, {a, 1, b * t}};
    c.points.push_back(rim[face]);
  }
  if (spacing) *spacing = s;
  if (thickness) *thickness = t;
  return c;
}

/// Random points on the square [0,size]² in the z = 0 plane; density grows by @p ratio along x.
inline PointCloud planeCloud(std::size_t n, double size = 1.0, double ratio = 1.0, std::uint64_t seed = 2) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud c;
  while (c.points.size() < n) {
    const double x = u(rng), y = u(rng);
    if (u(rng) * ratio > 1.0 + (ratio - 1.0) * x) continue;  // accept with weight 1 + (ratio − 1) x
    c.points.emplace_back(size * x, size * y, 0.0);
  }
  return c;
}

/// A regular grid on the unit sphere's octahedral parameterisation is overkill; a Fibonacci sphere is
/// near-uniform and deterministic.
inline std::vector<Eigen::Vector3d> fibonacciSphere(std::size_t n, double radius = 1.0) {
  std::vector<Eigen::Vector3d> p;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (std::size_t i = 0; i < n; ++i) {
    const double z = 1.0 - 2.0 * (static_cast<double>(i) + 0.5) / static_cast<double>(n);
    const double r = std::sqrt(1.0 - z * z), t = golden * static_cast<double>(i);
    p.emplace_back(radius * r * std::cos(t), radius * r * std::sin(t), radius * z);
  }
  return p;
}

/// The U-shaped strip of issue 3: bottom square z = 0 and top square z = gap over [0,1]², joined at x = 1 by
/// a half-cylinder of radius gap/2 (axis along y). Uniform random points, perSquare per square and the same
/// density on the cylinder; outward normals (bottom −z, top +z, cylinder radial).
inline PointCloud uStrip(std::size_t perSquare, double gap, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  PointCloud c;
  const double r = gap / 2;
  for (int sheet = 0; sheet < 2; ++sheet)
    for (std::size_t i = 0; i < perSquare; ++i) {
      const double x = u(rng), y = u(rng);
      c.points.emplace_back(x, y, sheet ? gap : 0.0);
      c.normals.emplace_back(0, 0, sheet ? 1 : -1);
    }
  const auto nc = static_cast<std::size_t>(std::lround(M_PI * r * static_cast<double>(perSquare)));
  for (std::size_t i = 0; i < nc; ++i) {
    const double th = M_PI * u(rng), y = u(rng);
    c.points.emplace_back(1 + r * std::sin(th), y, r - r * std::cos(th));
    c.normals.emplace_back(std::sin(th), 0, -std::cos(th));
  }
  return c;
}

}  // namespace iires::test
