// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file quadric_fit.hpp
/// @brief (internal) The normal equations of the weighted least-squares quadric height field
/// f(u, v) = c0 + c1 u + c2 v + c3 u² + c4 uv + c5 v² that the MLS surface and denoising fit.

#include <Eigen/Core>

namespace iires {

/// @brief ata = Σ w·m·mᵀ, atb = Σ w·z·m with m = (1, u, v, u², uv, v²), over the samples (w[j], u[j], v[j], z[j]),
/// j < @p count (full symmetric matrix).
/// @note ata holds only 15 distinct moments Σ w uᵃ vᵇ (a + b ≤ 4), atb 6 more: they are summed two samples at
/// a time in packed 2-lanes (structure-of-arrays input). Adding w·m·mᵀ per sample built m element by element
/// through the stack and stalled on store forwarding (19 % of MlsSurface::project's samples on that line).
inline void quadricNormalEquations(const double* w, const double* u, const double* v, const double* z,
                                   std::size_t count, Eigen::Matrix<double, 6, 6>& ata,
                                   Eigen::Matrix<double, 6, 1>& atb) {
  using A2 = Eigen::Array2d;
  A2 s1 = A2::Zero(), su = s1, sv = s1, suu = s1, suv = s1, svv = s1, s3u = s1, suuv = s1, suvv = s1, s3v = s1,
     s4u = s1, s3uv = s1, s2u2v = s1, su3v = s1, s4v = s1, sz = s1, szu = s1, szv = s1, szuu = s1, szuv = s1,
     szvv = s1;
  auto add = [&](const A2& W, const A2& U, const A2& V, const A2& Z) {
    const A2 wu = W * U, wv = W * V, wuu = wu * U, wuv = wu * V, wvv = wv * V, uv = U * V;
    s1 += W, su += wu, sv += wv, suu += wuu, suv += wuv, svv += wvv;
    s3u += wuu * U, suuv += wuu * V, suvv += wvv * U, s3v += wvv * V;
    s4u += wuu * U * U, s3uv += wuu * uv, s2u2v += wuu * V * V, su3v += wvv * uv, s4v += wvv * V * V;
    const A2 wz = W * Z;
    sz += wz, szu += wz * U, szv += wz * V, szuu += wz * U * U, szuv += wz * uv, szvv += wz * V * V;
  };
  std::size_t j = 0;
  for (; j + 1 < count; j += 2)
    add(Eigen::Map<const A2>(w + j), Eigen::Map<const A2>(u + j), Eigen::Map<const A2>(v + j),
        Eigen::Map<const A2>(z + j));
  if (j < count) add(A2(w[j], 0.0), A2(u[j], 0.0), A2(v[j], 0.0), A2(z[j], 0.0));
  const double m1 = s1.sum(), mu = su.sum(), mv = sv.sum(), muu = suu.sum(), muv = suv.sum(), mvv = svv.sum(),
               m3u = s3u.sum(), muuv = suuv.sum(), muvv = suvv.sum(), m3v = s3v.sum(), m4u = s4u.sum(),
               m3uv = s3uv.sum(), m2u2v = s2u2v.sum(), mu3v = su3v.sum(), m4v = s4v.sum();
  ata << m1, mu, mv, muu, muv, mvv,  //
      mu, muu, muv, m3u, muuv, muvv,   //
      mv, muv, mvv, muuv, muvv, m3v,   //
      muu, m3u, muuv, m4u, m3uv, m2u2v,  //
      muv, muuv, muvv, m3uv, m2u2v, mu3v,  //
      mvv, muvv, m3v, m2u2v, mu3v, m4v;
  atb << sz.sum(), szu.sum(), szv.sum(), szuu.sum(), szuv.sum(), szvv.sum();
}

}  // namespace iires
