// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/rotation_grid.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace iires::reg {

std::string toString(RotationGridType type) { return type == RotationGridType::kEuler ? "euler" : "so3"; }

RotationGridType parseRotationGridType(const std::string& name) {
  if (name == "euler") return RotationGridType::kEuler;
  if (name == "so3") return RotationGridType::kSo3;
  throw std::invalid_argument("unknown rotation grid '" + name + "' (expected euler or so3)");
}

std::vector<Eigen::Matrix3d> eulerRotationGrid(int steps) {
  if (steps < 1) throw std::invalid_argument("Euler grid needs at least 1 step per axis");
  const double theta = 2.0 * M_PI / steps;  // the paper's θ = π/12 for 24 steps
  std::vector<Eigen::Matrix3d> grid;
  grid.reserve(static_cast<std::size_t>(steps) * steps * steps);
  for (int i = 0; i < steps; ++i)
    for (int j = 0; j < steps; ++j)
      for (int k = 0; k < steps; ++k) {
        const Eigen::Matrix3d r = (Eigen::AngleAxisd(k * theta, Eigen::Vector3d::UnitZ()) *
                                   Eigen::AngleAxisd(j * theta, Eigen::Vector3d::UnitY()) *
                                   Eigen::AngleAxisd(i * theta, Eigen::Vector3d::UnitX()))
                                      .toRotationMatrix();
        grid.push_back(r);
      }
  return grid;
}

std::vector<Eigen::Matrix3d> so3RotationGrid(std::size_t count) {
  if (count < 1) throw std::invalid_argument("SO(3) grid needs at least 1 rotation");
  // Alexa, "Super-Fibonacci spirals: fast, low-discrepancy sampling of SO(3)", CVPR 2022, Algorithm 1.
  const double phi = std::sqrt(2.0), psi = 1.533751168755204288118041;
  const double n = static_cast<double>(count);
  std::vector<Eigen::Matrix3d> grid;
  grid.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double s = static_cast<double>(i) + 0.5;
    const double r = std::sqrt(s / n), big = std::sqrt(1.0 - s / n);
    const double alpha = 2.0 * M_PI * s / phi, beta = 2.0 * M_PI * s / psi;
    Eigen::Quaterniond q(big * std::cos(beta), r * std::sin(alpha), r * std::cos(alpha), big * std::sin(beta));
    grid.push_back(q.normalized().toRotationMatrix());
  }
  return grid;
}

std::vector<Eigen::Matrix3d> rotationGrid(RotationGridType type, int eulerSteps, std::size_t so3Count) {
  return type == RotationGridType::kEuler ? eulerRotationGrid(eulerSteps) : so3RotationGrid(so3Count);
}

double rotationAngle(const Eigen::Matrix3d& r) {
  const double c = std::clamp((r.trace() - 1.0) * 0.5, -1.0, 1.0);
  return std::acos(c);
}

double rotationAngle(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return rotationAngle(a.transpose() * b);
}

}  // namespace iires::reg
