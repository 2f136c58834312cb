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
// Passes of neighbour averaging of the quadric's squared-bias estimate (liftShares()). Fewer leave the estimate too
// noisy to tell detail from noise both ways (armadillo, 100k points, noise 0.33·l: mean error 0.0781·l with none,
// 0.0769 with one, 0.0766 with three, 0.0767 with six; folded sheets 2.5 spacings apart, noise 0.2 spacings, 20k
// samples farther than 0.1 gap: 98, 82, 73, 66).
constexpr int kBiasPoolPasses = 3;
// Negative squared-bias estimates needed to read the estimates' spread where the bias is nil (nullSpread()).
constexpr std::size_t kMinNullEstimates = 100;

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

/// Degree-2 fit at one point: the θ-weighted least squares height field f(u,v) = c0 + c1 u + c2 v + c3 u² + c4 uv +
/// c5 v² over the plane (a, n), at p, with the statistics liftShares() weighs it by. @p weights: the neighbours' θ_j.
struct QuadricFit {
  bool ok = false;  ///< false: under-determined, keep the plane
  double move = 0;  ///< signed distance from p along n to the quadric (input units)
  double lift = 0;  ///< f at p (input units): the quadric's height above the plane there
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< n − ∇f at p (not normalised): the quadric's normal
  float liftVar = 0;       ///< Var(lift) / σ² under white noise σ² along n (the lift is linear in the heights)
  float heightVar = 0;     ///< Var(f(p)) / σ²: the share of white noise's variance the quadric lets through at p
  float residualVar = -1;  ///< σ² estimated from the weighted residuals (input units²; < 0: too few points to tell)
};

QuadricFit fitQuadric(const Eigen::Vector3d& p, const std::vector<Eigen::Vector3d>& points, const std::uint32_t* nbr,
                      std::size_t count, const double* weights, double h, const MlsPlane& plane) {
  QuadricFit q;
  if (count < 6) return q;
  const Eigen::Vector3d& n = plane.normal;
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  double qu[kMaxNeighbours], qv[kMaxNeighbours], qz[kMaxNeighbours], w2[kMaxNeighbours];
  double wsum = 0;
  const double invH = 1.0 / h;  // scaled, for conditioning
  for (std::size_t j = 0; j < count; ++j) {
    const Eigen::Vector3d d = (points[nbr[j]] - plane.centre) * invH;
    qu[j] = d.dot(u), qv[j] = d.dot(v), qz[j] = d.dot(n);
    wsum += weights[j];
    w2[j] = weights[j] * weights[j];
  }
  Eigen::Matrix<double, 6, 6> ata, btb;
  Eigen::Matrix<double, 6, 1> atb, unused;
  quadricNormalEquations(weights, qu, qv, qz, count, ata, atb);
  for (int r = 3; r < 6; ++r) ata(r, r) += 1e-2 * wsum;  // ridge on the curvature terms: flat if unsure
  // Positive definite with the ridge: Cholesky, with the pivoting LDLT as fallback (as in MlsSurface; then no
  // statistics: the full quadric is kept).
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(ata);
  const bool cholesky = llt.info() == Eigen::Success;
  const Eigen::Matrix<double, 6, 1> c =
      cholesky ? Eigen::Matrix<double, 6, 1>(llt.solve(atb)) : ata.ldlt().solve(atb).eval();
  if (!c.allFinite()) return q;
  const Eigen::Vector3d d = (p - plane.centre) / h;
  const double pu = d.dot(u), pv = d.dot(v);
  const double f = c[0] + c[1] * pu + c[2] * pv + c[3] * pu * pu + c[4] * pu * pv + c[5] * pv * pv;
  const double gu = c[1] + 2 * c[3] * pu + c[4] * pv, gv = c[2] + c[4] * pu + 2 * c[5] * pv;
  q.normal = n - gu * u - gv * v;
  if (!std::isfinite(f) || !q.normal.allFinite()) return q;
  q.ok = true;
  q.move = h * (f - d.dot(n));  // along n only, as eq. (3)
  q.lift = h * f;
  if (!cholesky) return q;
  Eigen::Matrix<double, 6, 1> m;
  m << 1, pu, pv, pu * pu, pu * pv, pv * pv;
  // f(p) = mᵀ c = Σ_j a_j z_j with a_j = w_j m_jᵀ A⁻¹ m; the plane's height at p is Σ_j (w_j / Σw) z_j (a is the
  // θ-weighted mean), so lift = Σ_j (a_j − w_j / Σw) z_j.
  const Eigen::Matrix<double, 6, 1> g = llt.solve(m);
  double liftVar = 0, heightVar = 0, rss = 0;
  for (std::size_t j = 0; j < count; ++j) {
    const double mj[6] = {1, qu[j], qv[j], qu[j] * qu[j], qu[j] * qv[j], qv[j] * qv[j]};
    double mg = 0, mc = 0;
    for (int k = 0; k < 6; ++k) mg += mj[k] * g[k], mc += mj[k] * c[k];
    const double a = weights[j] * mg, l = a - weights[j] / wsum;
    liftVar += l * l, heightVar += a * a;
    rss += weights[j] * (qz[j] - mc) * (qz[j] - mc);
  }
  // Weighted least squares: E[Σ w r²] = σ² (Σw − tr(A⁻¹B)) with B = Σ w² m mᵀ.
  quadricNormalEquations(w2, qu, qv, qz, count, btb, unused);
  const double dof = wsum - llt.solve(btb).trace();
  q.liftVar = static_cast<float>(liftVar), q.heightVar = static_cast<float>(heightVar);
  if (dof > 0.5) q.residualVar = static_cast<float>(h * h * rss / dof);
  return q;
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

/// The weights of one sweep at point i: the covariance's wide kernel exp(−|p_j − p_i|²/(2h_i)²) times the
/// bilateral normal term; θ_j (eq. 2) is its fourth power.
struct SweepKernel {
  const Rows& rows;
  const std::vector<Eigen::Vector3d>& points;
  const std::vector<Eigen::Vector3d>& normals;
  bool bilateral = false;
  bool oriented = false;  ///< the normals are oriented: the term reads the signed n_j·n_p
  double invSharp2 = 0;   ///< 1 / σ² of the bilateral term

  double wide(std::size_t i, std::uint32_t j) const {
    double e = -(points[j] - points[i]).squaredNorm() * (0.25 / (rows.h[i] * rows.h[i]));
    if (bilateral) {
      // Oriented normals (given, and every sweep's fits oriented like them): signed, so a neighbour facing
      // the other way — another sheet across a thin gap, e.g. between fingers — gets no weight, as in
      // MlsSurface. Unoriented fits (no normals given) only tell the line, not the side.
      const double dn = normals[j].dot(normals[i]);
      const double c = 1.0 - (oriented ? dn : std::abs(dn));
      e -= c * c * invSharp2;  // the two factors in one exp
    }
    return std::exp(e);
  }
};

/// The noise the first projection sweep measured: σ², the median of its fits' residual variances, and the median
/// share of white noise's variance its quadrics let through at the centre (QuadricFit::heightVar).
struct NoiseLevel {
  double variance = 0;
  double factor = 0;
};

/// The spread of the pooled squared-bias estimates where the bias is nil, in units of each one's lift variance σ² v:
/// a true squared bias is never negative, so the estimates below zero are noise, and as the estimate is symmetric
/// about the truth there, their median magnitude over 0.6745 (a half-normal's) is its standard deviation. 0 when
/// fewer than kMinNullEstimates are negative (a cloud curved everywhere, or noise so low that the lifts stand out).
double nullSpread(const std::vector<QuadricFit>& fits, const std::vector<double>& bias2, double noiseVar) {
  std::vector<double> below;
  for (std::size_t i = 0; i < fits.size(); ++i)
    if (fits[i].ok && fits[i].liftVar > 0 && bias2[i] < 0) below.push_back(-bias2[i] / (noiseVar * fits[i].liftVar));
  if (below.size() < kMinNullEstimates) return 0.0;
  return quantile(std::move(below), 0.5) / 0.6745;
}

/// Empirical-Bayes choice between the quadric and the plane at every point of a sweep: the share of the quadric's
/// lift d_i (the plane's bias at p_i, estimated with noise of variance σ² v_i) to apply. With b_i² the squared
/// bias, b²/(b² + c σ² v) minimises the squared error of p_i's height (the Wiener/James–Stein factor). σ² is
/// the median of the fits' residual variances; b² is estimated by d² − σ² v, averaged over the neighbours
/// (kBiasPoolPasses passes of the sweep's kernel), since curvature is coherent over the kernel where the noise
/// is not, and lowered by one standard deviation of that estimate where the bias is nil (nullSpread()): c is
/// small, so an estimate a little above zero by chance would keep most of the quadric, and its noise, on a flat
/// part (sheets 2.5 spacings apart with noise of 0.2 spacings: residual 0.069 → 0.06 spacings). c is the share
/// of this sweep's noise variance that reaches the output: the later sweeps average it again (each lets through the
/// quadric's variance factor at p, its median over the points, for white noise), while a bias left now stays.
/// Where the lift stands out of the noise the quadric is kept; on flat parts the point moves (nearly) onto the
/// plane, whose estimate has a fraction of the quadric's variance at the centre.
/// The first sweep (@p sweep 0) measures σ² on white noise and records it in @p first; what a sweep leaves is
/// smooth over the kernel, so a later sweep's quadrics follow it and their residuals understate it. There σ² is
/// at least what the earlier sweeps let through of the first one's: σ₀² times its variance factor per sweep.
std::vector<double> liftShares(const std::vector<QuadricFit>& fits, const SweepKernel& kernel, int sweep,
                               int laterSweeps, NoiseLevel& first, int threads) {
  const std::size_t n = fits.size();
  std::vector<double> residual, through;
  residual.reserve(n), through.reserve(n);
  for (const QuadricFit& f : fits)
    if (f.ok) {
      if (f.residualVar >= 0) residual.push_back(f.residualVar);
      through.push_back(f.heightVar);
    }
  std::vector<double> keep(n, 1.0);
  const double factor = quantile(std::move(through), 0.5);
  double noiseVar = quantile(std::move(residual), 0.5);
  if (sweep == 0) first = {noiseVar, factor};
  else noiseVar = std::max(noiseVar, first.variance * std::pow(first.factor, sweep));
  // Noise below a millionth of the kernel width is round-off: a noise-free cloud keeps the quadric everywhere.
  if (!(noiseVar > 1e-12 * kernel.rows.medianH * kernel.rows.medianH)) return keep;
  const double passed = std::pow(factor, laterSweeps);
  std::vector<double> bias2(n, 0.0), next(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    if (fits[i].ok) bias2[i] = fits[i].lift * fits[i].lift - noiseVar * fits[i].liftVar;
  for (int pass = 0; pass < kBiasPoolPasses; ++pass) {
    parallelFor(n, threads, [&](std::size_t i) {
      const std::uint32_t* nb = kernel.rows.nbr.data() + i * kernel.rows.stride;
      double sw = 0, sb = 0;
      for (std::size_t j = 0; j < kernel.rows.found[i]; ++j)
        if (fits[nb[j]].ok) {
          const double w = kernel.wide(i, nb[j]);
          sw += w, sb += w * bias2[nb[j]];
        }
      next[i] = sw > 0 ? sb / sw : bias2[i];
    });
    bias2.swap(next);
  }
  const double spread = nullSpread(fits, bias2, noiseVar);
  parallelFor(n, threads, [&](std::size_t i) {
    const double b2 = std::max(0.0, bias2[i] - spread * noiseVar * fits[i].liftVar);
    const double v = passed * noiseVar * fits[i].liftVar;
    keep[i] = b2 + v > 0 ? b2 / (b2 + v) : 1.0;
  });
  return keep;
}

/// One projection sweep (eq. 1–3) of every point of @p kernel.points: @p next (@p cur when !@p move) and the fitted
/// @p nextNormals; @p sweep: how many sweeps went before this one, @p laterSweeps: how many follow, @p first: the
/// first sweep's noise (liftShares()).
/// A probe below @p cleanBelow says the input is clean (the caller keeps its positions): the full quadric's normals
/// are returned, as for a noise-free cloud, and liftShares() is not run.
/// @return the noise probe: the mean distance from the points to their fits (the quadric's where it was fitted,
/// before liftShares() weighs it), which the sweeps' noise tests are calibrated on
double projectSweep(const SweepKernel& kernel, int degree, int sweep, int laterSweeps, NoiseLevel& first, bool move,
                    double cleanBelow, int threads, std::vector<Eigen::Vector3d>& next,
                    std::vector<Eigen::Vector3d>& nextNormals) {
  const Rows& rows = kernel.rows;
  const std::vector<Eigen::Vector3d>& cur = kernel.points;
  const std::size_t n = cur.size();
  std::vector<QuadricFit> fits(degree == 2 ? n : 0);
  std::vector<double> fitDistance(n);
  parallelFor(n, threads, [&](std::size_t i) {
    const std::uint32_t* nb = rows.nbr.data() + i * rows.stride;
    const std::size_t count = rows.found[i];
    // eq. (2): θ_j = exp(−|p_j − p|²/h²); the covariance uses the wider exp(−|p_j − p|²/(2h)²) = θ_j^¼ (one
    // exp per neighbour). The bilateral normal term, when on, multiplies all of them (centre, normal, quadric).
    double w[kMaxNeighbours], wn[kMaxNeighbours];
    for (std::size_t j = 0; j < count; ++j) {
      wn[j] = kernel.wide(i, nb[j]);
      const double w2 = wn[j] * wn[j];
      w[j] = w2 * w2;
    }
    double theta[kMaxNeighbours];
    if (degree == 2) std::copy(w, w + count, theta);  // the quadric's weights
    const MlsPlane plane = fitWeightedPlane(cur, nb, count, w, wn, nullptr, kernel.normals[i], 0.0);
    next[i] = move ? projectOntoPlane(cur[i], plane) : cur[i];  // eq. (3)
    nextNormals[i] = plane.normal;
    fitDistance[i] = std::abs(plane.normal.dot(plane.centre - cur[i]));
    if (degree == 2) {
      fits[i] = fitQuadric(cur[i], cur, nb, count, theta, rows.h[i], plane);
      if (fits[i].ok) fitDistance[i] = std::abs(fits[i].move);
    }
  });
  const double probe = std::accumulate(fitDistance.begin(), fitDistance.end(), 0.0) / static_cast<double>(n);
  if (degree != 2) return probe;
  // Degree 2: along the plane's normal onto the quadric, by the share of its lift the data support.
  const std::vector<double> keep =
      probe < cleanBelow ? std::vector<double>(n, 1.0) : liftShares(fits, kernel, sweep, laterSweeps, first, threads);
  parallelFor(n, threads, [&](std::size_t i) {
    const QuadricFit& f = fits[i];
    if (!f.ok) return;
    const Eigen::Vector3d& na = nextNormals[i];  // the plane's normal n_a
    const Eigen::Vector3d normal = (keep[i] == 1.0 ? f.normal : na + keep[i] * (f.normal - na)).normalized();
    if (!normal.allFinite()) return;
    // keep = 1 moves by the quadric's own arithmetic, so a clean input's positions and normals stay bit for bit
    // those of the unshrunk quadric (the resampler and the mesher follow round-off).
    if (move) next[i] = keep[i] == 1.0 ? cur[i] + f.move * na : next[i] + keep[i] * f.lift * na;
    nextNormals[i] = normal;
  });
  return probe;
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
  if (!(laterSharpnessAngle >= 0.0 && laterSharpnessAngle <= 90.0))
    fail("laterSharpnessAngle must lie in [0, 90] degrees");
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
  const double sharp = params.sharpnessAngle > 0 ? 1.0 - std::cos(params.sharpnessAngle * M_PI / 180.0) : 0.0;
  const double invSharp2 = sharp > 0 ? 1.0 / (sharp * sharp) : 0.0;
  const double later =
      params.laterSharpnessAngle > 0 ? 1.0 - std::cos(params.laterSharpnessAngle * M_PI / 180.0) : sharp;
  const double laterInvSharp2 = later > 0 ? 1.0 / (later * later) : 0.0;
  const int sweeps = std::max(1, params.iterations);  // at least one fit, for the normals
  bool probing = given && !params.keepGivenNormals;  // estimated normals: a first sweep without them decides
  NoiseLevel firstNoise;  // measured by every first sweep, the last one's kept (the sweeps may start again)
  for (int it = 0; it < sweeps; ++it) {
    const bool useBilateral = (it > 0 ? later : sharp) > 0 && ((given && !probing) || it > 0);
    const SweepKernel kernel{rows, cur, normals, useBilateral, given, it > 0 ? laterInvSharp2 : invSharp2};
    const double cleanBelow = it == 0 && params.iterations > 0 ? params.cleanDisplacement * rows.spacing : 0.0;
    const double meanMove = projectSweep(kernel, params.degree, it, sweeps - 1 - it, firstNoise,
                                         params.iterations > 0, cleanBelow, exec.threads, next, nextNormals);
    // Without given normals the first sweep's normals are unoriented; the bilateral term uses |n_j·n_p|,
    // and later sweeps orient each fit like the point's previous normal, so the sign only needs fixing
    // once at the end.
    normals.swap(nextNormals);
    if (params.iterations == 0) break;
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
