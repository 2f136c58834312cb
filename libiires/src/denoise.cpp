// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/denoise.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <string>

#include "iires/knn.hpp"
#include "iires/normals.hpp"
#include "iires/detail/parallel.hpp"
#include "quadric_fit.hpp"

namespace iires {
namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t kMaxNeighbours = 128;  // DenoiseParams::neighbours is at most this
// Normals that were estimated (DenoiseParams::keepGivenNormals false) orient the fits and sign the bilateral term
// only when a first sweep without that term moved the points by less than this many spacings: noise of
// the order of the spacing tilts a 16-neighbour fit enough that the orientation carried over the graph flips in
// places (a sphere with radial noise of 1.25 spacings: 0.5 spacings moved, and 526 of 3,000 output normals
// inward when the signs were trusted, 39 when not; sheets with noise of 0.2 spacings move 0.12).
constexpr double kTrustedSignNoise = 0.3;
// A first sweep that moves the points by more than 1/kNoiseKernelRatio of the median kernel width on average
// meets noise about as wide as the kernel, which its fits then follow instead of averaging: the sweeps start
// again with a kernel twice as wide, at most kWideNeighbours points per fit. CGAL's sphere_20k (radial noise
// σ = 1.6 spacings): first sweep 0.23 kernel widths, radial rms after pre-processing 0.023 → 0.008 with the
// wide kernel; moderate noise keeps it (bunny00, 100k: uniform noise of 0.66 spacings 0.08, Gaussian σ = 0.5
// spacings 0.16).
constexpr double kNoiseKernelRatio = 5.0;
constexpr std::size_t kWideNeighbours = 64;

void checkCloud(const PointCloud& cloud, std::size_t minPoints) {
  if (cloud.empty()) throw InputError("denoise: the cloud is empty");
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (!cloud.points[i].allFinite())
      throw InputError("denoise: point " + std::to_string(i) + " has a NaN/Inf coordinate");
  if (cloud.size() < minPoints)
    throw InputError("denoise: " + std::to_string(cloud.size()) + " points, need at least " +
                     std::to_string(minPoints));
}

/// q-quantile of @p values (copied; nth_element).
double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const auto at =
      std::min(values.size() - 1, static_cast<std::size_t>(q * static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<long>(at), values.end());
  return values[at];
}

/// Degree-2 correction: θ-weighted least squares height field f(u,v) = c0 + c1 u + c2 v + c3 u² + c4 uv + c5
/// v² over the plane (a, n); p moves along n onto it. @p weights: the neighbours' θ_j. Returns false (keep the
/// plane) when under-determined.
bool projectOntoQuadric(const Eigen::Vector3d& p, const std::vector<Eigen::Vector3d>& points,
                        const std::uint32_t* nbr, std::size_t count, const double* weights, double h,
                        const MlsPlane& plane, Eigen::Vector3d& out, Eigen::Vector3d& normal) {
  if (count < 6) return false;
  const Eigen::Vector3d& n = plane.normal;
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  double qu[kMaxNeighbours], qv[kMaxNeighbours], qz[kMaxNeighbours];
  double wsum = 0;
  const double invH = 1.0 / h;  // scaled, for conditioning
  for (std::size_t j = 0; j < count; ++j) {
    const Eigen::Vector3d d = (points[nbr[j]] - plane.centre) * invH;
    qu[j] = d.dot(u), qv[j] = d.dot(v), qz[j] = d.dot(n);
    wsum += weights[j];
  }
  Eigen::Matrix<double, 6, 6> ata;
  Eigen::Matrix<double, 6, 1> atb;
  quadricNormalEquations(weights, qu, qv, qz, count, ata, atb);
  for (int r = 3; r < 6; ++r) ata(r, r) += 1e-2 * wsum;  // ridge on the curvature terms: flat if unsure
  // Positive definite with the ridge: Cholesky, with the pivoting LDLT as fallback (as in MlsSurface).
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(ata);
  const Eigen::Matrix<double, 6, 1> c = llt.info() == Eigen::Success
                                            ? Eigen::Matrix<double, 6, 1>(llt.solve(atb))
                                            : ata.ldlt().solve(atb).eval();
  if (!c.allFinite()) return false;
  const Eigen::Vector3d d = (p - plane.centre) / h;
  const double pu = d.dot(u), pv = d.dot(v);
  const double f = c[0] + c[1] * pu + c[2] * pv + c[3] * pu * pu + c[4] * pu * pv + c[5] * pv * pv;
  const double fu = c[1] + 2 * c[3] * pu + c[4] * pv, fv = c[2] + c[4] * pu + 2 * c[5] * pv;
  const Eigen::Vector3d m = (n - fu * u - fv * v).normalized();
  if (!m.allFinite()) return false;
  out = p + h * (f - d.dot(n)) * n;  // along n only, as eq. (3)
  normal = m;
  return true;
}

/// eq. (1) with given θ weights @p w (eq. 2) for the centre and @p wn for the covariance (nullptr: @p w); @p w
/// is multiplied in place by the bilateral normal term when @p sharpness > 0 (see fitMlsPlane).
MlsPlane fitWeightedPlane(const std::vector<Eigen::Vector3d>& points,
                          const std::uint32_t* neighbours, std::size_t count, double* w, const double* wn,
                          const std::vector<Eigen::Vector3d>* normals, const Eigen::Vector3d& pointNormal,
                          double sharpness) {
  MlsPlane plane;
  if (count == 0) return plane;
  const bool bilateral = normals && sharpness > 0 && pointNormal.squaredNorm() > 0;
  const double invS2 = bilateral ? 1.0 / (sharpness * sharpness) : 0.0;
  double wsum = 0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < count; ++j) {
    const Eigen::Vector3d& q = points[neighbours[j]];
    if (bilateral) {
      const double c = 1.0 - std::abs((*normals)[neighbours[j]].dot(pointNormal));
      w[j] *= std::exp(-c * c * invS2);
    }
    w[j] += 1e-300;
    wsum += w[j];
    sum += w[j] * q;
  }
  plane.centre = sum / wsum;
  plane.weightSum = wsum;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < count; ++j) {
    const Eigen::Vector3d d = points[neighbours[j]] - plane.centre;
    cov.noalias() += (wn ? wn[j] : w[j]) * d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(cov);
  Eigen::Vector3d n = eig.eigenvectors().col(0);
  if (!n.allFinite() || n.squaredNorm() < 1e-24)
    n = pointNormal.squaredNorm() > 0 ? pointNormal : plane.normal;
  n.normalize();
  if (pointNormal.squaredNorm() > 0 && n.dot(pointNormal) < 0) n = -n;
  plane.normal = n;
  return plane;
}

/// Each point's neighbour rows (Morton order, the point itself first) and kernel width.
struct Rows {
  std::size_t stride = 0;          ///< entries per row (K)
  std::vector<std::uint32_t> nbr;  ///< n × stride, padded with the point itself
  std::vector<std::uint32_t> found;  ///< per point, the neighbours its fits read (at most k)
  std::vector<double> h;           ///< kernel width: distance to the kernelK-th neighbour, robustly clamped
  double spacing = 0;              ///< mean distance to the nearest neighbour
  double medianH = 0;              ///< median of h
};

/// The rows of @p in (point a = the caller's point order[a]): from @p table (the caller's order, mapped to ours)
/// when it holds K columns, else from a k-d tree of @p in.
Rows findRows(const std::vector<Eigen::Vector3d>& in, const std::vector<std::uint32_t>& order,
              const NeighbourTable* table, std::size_t k, std::size_t kernelK, double kernelQuantile, int threads) {
  const std::size_t n = in.size(), K = std::max(k, kernelK + 1);
  Rows r;
  r.stride = K;
  r.nbr.resize(n * K);
  r.found.resize(n);
  r.h.assign(n, 0.0);
  std::vector<double> nearest(n, 0.0);
  if (table && table->k() < K) table = nullptr;
  std::optional<KnnIndex> own;
  if (!table) own.emplace(in);
  std::vector<std::uint32_t> rankOf;
  if (table) {
    rankOf.resize(n);
    for (std::size_t a = 0; a < n; ++a) rankOf[order[a]] = static_cast<std::uint32_t>(a);
  }
  parallelFor(n, threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    const std::size_t f = table ? table->get(order[i], K, idx, d2) : own->knn(in[i], K, idx, d2);
    if (table)
      for (std::uint32_t& j : idx) j = rankOf[j];
    std::copy(idx.begin(), idx.begin() + static_cast<long>(f), r.nbr.begin() + static_cast<long>(i * K));
    std::fill(r.nbr.begin() + static_cast<long>(i * K + f), r.nbr.begin() + static_cast<long>((i + 1) * K),
              static_cast<std::uint32_t>(i));
    r.found[i] = static_cast<std::uint32_t>(std::min(f, k));
    r.h[i] = std::sqrt(d2[std::min(f - 1, kernelK)]);
    nearest[i] = std::sqrt(d2[std::min<std::size_t>(f - 1, 1)]);
  });
  r.spacing = std::accumulate(nearest.begin(), nearest.end(), 0.0) / static_cast<double>(n);
  // Robust kernel width (DESIGN §3.3): clamp h to a quantile, so one outlier's huge h_i stays local; a
  // point whose own h is 0 (duplicates) gets the median.
  const double cap = quantile(r.h, kernelQuantile);
  r.medianH = quantile(r.h, 0.5);
  for (double& hi : r.h) hi = hi > 0 ? std::min(hi, cap) : (r.medianH > 0 ? r.medianH : 1.0);
  return r;
}

}  // namespace

void DenoiseParams::validate() const {
  auto fail = [](const std::string& what) { throw std::invalid_argument("DenoiseParams: " + what); };
  if (neighbours < 3) fail("neighbours must be at least 3 (a plane needs 3 points)");
  if (kernelNeighbour < 1) fail("kernelNeighbour must be at least 1");
  if (!(kernelQuantile > 0.0 && kernelQuantile <= 1.0)) fail("kernelQuantile must lie in (0, 1]");
  if (iterations < 0) fail("iterations must be >= 0");
  if (degree != 1 && degree != 2) fail("degree must be 1 (plane) or 2 (quadric)");
  if (neighbours > static_cast<int>(kMaxNeighbours)) fail("neighbours must be at most 128");
  if (!(sharpnessAngle >= 0.0 && sharpnessAngle <= 90.0)) fail("sharpnessAngle must lie in [0, 90] degrees");
  if (!(cleanDisplacement >= 0) || !std::isfinite(cleanDisplacement))
    fail("cleanDisplacement must be a finite value >= 0");
  if (orientNeighbours < 1 || orientNeighbours > 128) fail("orientNeighbours must lie in [1, 128]");
}

MlsPlane fitMlsPlane(const Eigen::Vector3d& p, const std::vector<Eigen::Vector3d>& points,
                     const std::uint32_t* neighbours, std::size_t count, double h,
                     const std::vector<Eigen::Vector3d>* normals, const Eigen::Vector3d& pointNormal,
                     double sharpness, double normalH) {
  if (count == 0 || !(h > 0)) return MlsPlane{};
  std::vector<double> w(count), wn(normalH > 0 ? count : 0);
  const double invH2 = 1.0 / (h * h), invN2 = normalH > 0 ? 1.0 / (normalH * normalH) : 0.0;
  for (std::size_t j = 0; j < count; ++j) {
    const double d2 = (points[neighbours[j]] - p).squaredNorm();
    w[j] = std::exp(-d2 * invH2);  // eq. (2)
    if (normalH > 0) wn[j] = std::exp(-d2 * invN2);
  }
  return fitWeightedPlane(points, neighbours, count, w.data(), normalH > 0 ? wn.data() : nullptr, normals,
                          pointNormal, sharpness);
}

std::size_t denoiseNeighbours(const DenoiseParams& params) {
  return static_cast<std::size_t>(std::max(params.neighbours, params.kernelNeighbour + 1));
}

DenoiseResult denoise(const PointCloud& input, const DenoiseParams& params, const Execution& exec,
                      const NeighbourTable* table) {
  params.validate();
  const auto start = Clock::now();
  const std::size_t k = static_cast<std::size_t>(params.neighbours);
  checkCloud(input, k + 1);
  const std::size_t n = input.size();
  const std::size_t kernelK = static_cast<std::size_t>(params.kernelNeighbour);
  bool given = input.hasNormals();

  // Work in Morton order: neighbours in space are neighbours in memory (k-NN queries and sweeps stay in
  // cache). in[a] is the caller's point order[a]; the output is put back in the caller's order.
  const std::vector<std::uint32_t> order = mortonOrder(input.points, exec.threads);
  std::vector<Eigen::Vector3d> in(n), inNormals(n, Eigen::Vector3d::Zero());
  for (std::size_t a = 0; a < n; ++a) {
    in[a] = input.points[order[a]];
    if (given) inNormals[a] = input.normals[order[a]];
  }

  // Neighbour lists, found once on the input: each sweep moves points by a fraction of the spacing only.
  Rows rows = findRows(in, order, table, k, kernelK, params.kernelQuantile, exec.threads);
  bool widened = false;
  const std::size_t wideKernel = std::max(kernelK, std::min(4 * kernelK, kWideNeighbours / 2));  // see below
  DenoiseResult result;
  const auto sweepStart = Clock::now();
  result.neighbourSeconds = std::chrono::duration<double>(sweepStart - start).count();

  std::vector<Eigen::Vector3d> cur = in, normals = inNormals, next(n), nextNormals(n);
  std::vector<double> moved(n);
  const double sharp = params.sharpnessAngle > 0 ? 1.0 - std::cos(params.sharpnessAngle * M_PI / 180.0) : 0.0;
  const double invSharp2 = sharp > 0 ? 1.0 / (sharp * sharp) : 0.0;
  const int sweeps = std::max(1, params.iterations);  // at least one fit, for the normals
  bool probing = given && !params.keepGivenNormals;  // estimated normals: a first sweep without them decides
  for (int it = 0; it < sweeps; ++it) {
    const bool useBilateral = sharp > 0 && ((given && !probing) || it > 0);
    parallelFor(n, exec.threads, [&](std::size_t i) {
      const std::uint32_t* nb = rows.nbr.data() + i * rows.stride;
      const std::size_t count = rows.found[i];
      // eq. (2): θ_j = exp(−|p_j − p|²/h²); the covariance uses the wider exp(−|p_j − p|²/(2h)²) = θ_j^¼ (one
      // exp per neighbour). The bilateral normal term, when on, multiplies all of them (centre, normal, quadric).
      double w[kMaxNeighbours], wn[kMaxNeighbours];
      const double invN2 = 0.25 / (rows.h[i] * rows.h[i]);
      for (std::size_t j = 0; j < count; ++j) {
        double e = -(cur[nb[j]] - cur[i]).squaredNorm() * invN2;
        if (useBilateral) {
          // Oriented normals (given, and every sweep's fits oriented like them): signed, so a neighbour facing
          // the other way — another sheet across a thin gap, e.g. between fingers — gets no weight, as in
          // MlsSurface. Unoriented fits (no normals given) only tell the line, not the side.
          const double dn = normals[nb[j]].dot(normals[i]);
          const double c = 1.0 - (given ? dn : std::abs(dn));
          e -= c * c * invSharp2;  // the two factors in one exp
        }
        wn[j] = std::exp(e);
        const double w2 = wn[j] * wn[j];
        w[j] = w2 * w2;
      }
      double theta[kMaxNeighbours];
      if (params.degree == 2) std::copy(w, w + count, theta);  // the quadric's weights
      const MlsPlane plane = fitWeightedPlane(cur, nb, count, w, wn, nullptr, normals[i], 0.0);
      Eigen::Vector3d p = projectOntoPlane(cur[i], plane), normal = plane.normal;  // eq. (3)
      if (params.degree == 2) projectOntoQuadric(cur[i], cur, nb, count, theta, rows.h[i], plane, p, normal);
      next[i] = params.iterations > 0 ? p : cur[i];
      nextNormals[i] = normal;
      moved[i] = (next[i] - cur[i]).norm();
    });
    // Without given normals the first sweep's normals are unoriented; the bilateral term uses |n_j·n_p|,
    // and later sweeps orient each fit like the point's previous normal, so the sign only needs fixing
    // once at the end.
    normals.swap(nextNormals);
    if (params.iterations == 0) break;
    const double meanMove = std::accumulate(moved.begin(), moved.end(), 0.0) / static_cast<double>(n);
    // Noise as wide as the kernel: the fits follow it. Again from the input with a kernel twice as wide (four
    // times the points; Euclidean rows: a table's filtered rows are too short), where the caps leave room.
    if (it == 0 && !widened && wideKernel > kernelK && meanMove * kNoiseKernelRatio > rows.medianH) {
      widened = true;
      const std::size_t wideK = std::max({wideKernel + 1, k, std::min(4 * k, kWideNeighbours)});
      rows = findRows(in, order, nullptr, wideK, wideKernel, params.kernelQuantile, exec.threads);
      cur = in;
      normals = inNormals;
      probing = given && !params.keepGivenNormals;
      it = -1;
      continue;
    }
    if (probing) {
      probing = false;
      if (meanMove <= kTrustedSignNoise * rows.spacing) {  // trusted: the first sweep again, with the estimates
        normals.swap(nextNormals);
        it = -1;
        continue;
      }
      given = false;  // too noisy to trust their sign: the sweeps go on as without normals, from this one
    }
    if (it == 0 && params.cleanDisplacement > 0 && meanMove < params.cleanDisplacement * rows.spacing) {
      result.cleanInput = true;  // noise probe: keep the input positions
      if (given && params.keepGivenNormals) normals = std::move(nextNormals);
      break;
    }
    std::swap(cur, next);
    ++result.iterations;
  }
  const auto orientStart = Clock::now();
  result.sweepSeconds = std::chrono::duration<double>(orientStart - sweepStart).count();
  if (!given && params.orientNormals)
    orientNormals(cur, normals, rows.nbr, rows.stride,
                  std::min<std::size_t>(rows.stride, static_cast<std::size_t>(params.orientNeighbours) + 1),
                  exec.threads, true);
  result.orientSeconds = std::chrono::duration<double>(Clock::now() - orientStart).count();

  result.cloud.points.resize(n);
  result.cloud.normals.resize(n);
  double sum = 0, worst = 0;
  for (std::size_t a = 0; a < n; ++a) {
    const double d = (cur[a] - in[a]).norm();
    sum += d;
    worst = std::max(worst, d);
    result.cloud.points[order[a]] = cur[a];
    result.cloud.normals[order[a]] = normals[a];
  }
  result.meanDisplacement = sum / static_cast<double>(n);
  result.maxDisplacement = worst;
  result.kernelWidth = rows.medianH;
  result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return result;
}

}  // namespace iires
