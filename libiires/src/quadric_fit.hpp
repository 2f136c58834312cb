#pragma once
/// @file quadric_fit.hpp
/// @brief (internal) The normal equations of the weighted least-squares quadric height field
/// f(u, v) = c0 + c1 u + c2 v + c3 u² + c4 uv + c5 v² that the MLS surface and denoising fit.

#include <Eigen/Core>

namespace iires {

/// @brief Adds the sample (u, v, z) with weight w: ata += w·m·mᵀ, atb += w·z·m, m = (1, u, v, u², uv, v²).
/// @note Built from 2-vectors held in registers: a 6-vector assembled element by element goes through the
/// stack, and its packet reloads stall on store forwarding (the hottest loop of the resampler). Fills the
/// lower triangle and the diagonal blocks, which is what the Cholesky / LDLT solvers read.
inline void addQuadricSample(Eigen::Matrix<double, 6, 6>& ata, Eigen::Matrix<double, 6, 1>& atb, double w,
                             double u, double v, double z) {
  const Eigen::Vector2d m0(1.0, u), m1(v, u * u), m2(u * v, v * v);
  const Eigen::Vector2d w0 = w * m0, w1 = w * m1, w2 = w * m2;
  ata.block<2, 2>(0, 0).noalias() += w0 * m0.transpose();
  ata.block<2, 2>(2, 0).noalias() += w1 * m0.transpose();
  ata.block<2, 2>(2, 2).noalias() += w1 * m1.transpose();
  ata.block<2, 2>(4, 0).noalias() += w2 * m0.transpose();
  ata.block<2, 2>(4, 2).noalias() += w2 * m1.transpose();
  ata.block<2, 2>(4, 4).noalias() += w2 * m2.transpose();
  atb.segment<2>(0) += w0 * z;
  atb.segment<2>(2) += w1 * z;
  atb.segment<2>(4) += w2 * z;
}

}  // namespace iires
