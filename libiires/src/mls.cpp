// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/mls.hpp"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "iires/detail/parallel.hpp"
#include "iires/sheets.hpp"
#include "quadric_fit.hpp"
#include "tangent_hull.hpp"

namespace iires {
namespace {
constexpr std::size_t kKernelNeighbour = MlsSurface::kWidthNeighbours - 1;  // paper: h from the 8th neighbour
constexpr double kMaxQuadricHeight = 2.0;     // kernel widths: a quadric fit beyond this is not trusted
// Input spacing (mean nearest-neighbour distance) per kernel width: a uniform sampling's 8th neighbour lies
// √(8/π) grid spacings away, its nearest half a grid spacing.
const double kSpacingPerWidth = 0.5 / std::sqrt(8.0 / M_PI);
const double kGapParallelCos = std::cos(25.0 * M_PI / 180.0);  // SheetParams::gapAngleDeg

/// How far @p x lies outside the footprint of its fit's neighbours (those with weight): the larger of its hull
/// distances in the quadric's tangent plane (@p tangentNormal), which follows the surface's curvature inside the
/// data, and in the fit's plane (@p planeNormal), which does not tilt where the quadric extrapolates past a rim.
double beyondFootprint(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
                       const std::vector<double>& w, const Eigen::Vector3d& x, const Eigen::Vector3d& tangentNormal,
                       const Eigen::Vector3d& planeNormal) {
  return std::max(detail::beyondHull(points, idx.data(), idx.size(), w.data(), x, tangentNormal),
                  detail::beyondHull(points, idx.data(), idx.size(), w.data(), x, planeNormal));
}

}  // namespace

MlsSurface::MlsSurface(const std::vector<Eigen::Vector3d>& points,
                       const std::vector<Eigen::Vector3d>& normals, const MlsParams& params, const Execution& exec,
                       const KnnIndex* index, const NeighbourTable* table, std::vector<std::uint8_t> nearSheets,
                       const std::vector<float>* samplingScale)
    : points_(points),
      normals_(normals),
      params_(params),
      index_(index ? index : &own_.emplace(points)),
      nearSheets_(std::move(nearSheets)) {
  if (!nearSheets_.empty() && nearSheets_.size() != points.size())
    throw std::invalid_argument("MlsSurface: nearSheets must hold one flag per point");
  if (samplingScale && samplingScale->size() != points.size())
    throw std::invalid_argument("MlsSurface: samplingScale must hold one value per point");
  const std::size_t n = points.size();
  h_.assign(n, 0.0);
  std::vector<double> nearest(n, 0.0);
  if (table && (table->k() < MlsSurface::kWidthNeighbours || table->size() != n)) table = nullptr;
  parallelFor(n, exec.threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    const std::size_t found = table ? table->get(i, MlsSurface::kWidthNeighbours, idx, d2)
                                    : index_->knn(points[i], MlsSurface::kWidthNeighbours, idx, d2);
    if (found < 2) return;
    h_[i] = std::sqrt(d2[found - 1]);
    nearest[i] = std::sqrt(d2[1]);
  });
  // Robust kernel width: clamp to the 90th percentile so a lone outlier cannot inflate it (DESIGN §3.3), the
  // clamp scaled by the point's sampling scale (a separate object sampled more coarsely keeps its own widths).
  std::vector<double> sorted = h_;
  const std::size_t q = std::min(n - 1, static_cast<std::size_t>(0.9 * static_cast<double>(n)));
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(q), sorted.end());
  const double cap = sorted[q];
  for (std::size_t i = 0; i < n; ++i) h_[i] = std::min(h_[i], samplingScale ? cap * (*samplingScale)[i] : cap);
  if (table && table->linePoints() > 0) readScanLines(*table, exec.threads);
  double area = 0, spacing = 0;
  for (std::size_t i = 0; i < n; ++i) {
    area += M_PI * h_[i] * h_[i] / (within_.empty() ? static_cast<double>(kKernelNeighbour) : within_[i]);
    spacing += nearest[i];
  }
  if (cap <= 0) std::fill(h_.begin(), h_.end(), 1.0);
  area_ = area;
  meanSpacing_ = n ? spacing / static_cast<double>(n) : 0.0;
  if (n > 0) {
    sorted = h_;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(n / 2), sorted.end());
    resolution_ = sorted[n / 2];
  }
}

void MlsSurface::readScanLines(const NeighbourTable& table, int threads) {
  const std::size_t n = points_.size();
  // The points each kernel width holds: 8 off the lines, many more of their own line on them.
  within_.assign(n, static_cast<double>(kKernelNeighbour));
  parallelFor(n, threads, [&](std::size_t i) {
    if (!(table.acrossLines(i) > 0)) return;
    thread_local std::vector<std::uint32_t> idx;
    thread_local std::vector<double> d2;
    within_[i] = static_cast<double>(std::max<std::size_t>(index_->radius(points_[i], h_[i], idx, d2), 2) - 1);
  });
  // The rows that reach across, for the projections' neighbourhoods.
  acrossStart_.assign(n + 1, 0);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < n; ++i) {
    if (table.acrossLines(i) > 0) {
      table.get(i, table.k(), idx, d2);
      for (std::uint32_t j : idx)
        if (j != i) acrossRows_.push_back(j);
    }
    acrossStart_[i + 1] = acrossRows_.size();
  }
}

MlsSurface::~MlsSurface() = default;

Eigen::Vector3d MlsSurface::project(const Eigen::Vector3d& x0, Eigen::Vector3d* normalOut, double* offSurface,
                                    const Eigen::Vector3d* hint, MlsCache* cache, int iterations,
                                    double* beyond) const {
  // Per-thread scratch: this runs for every sample in every relaxation iteration.
  thread_local std::vector<std::uint32_t> idx;
  thread_local std::vector<double> d2, w;
  Eigen::Vector3d x = x0, normal = Eigen::Vector3d::UnitZ();
  double off = 0, h = 0;
  Eigen::Vector3d queried = x;
  Eigen::Vector3d planeNormal = normal;  // the neighbours' averaged normal, before the quadric's tilt
  double lastH = 0;
  if (cache && cache->h > 0 && (x - cache->centre).squaredNorm() <= 0.0625 * cache->h * cache->h) {
    idx.assign(cache->indices.begin(), cache->indices.end());
    queried = cache->centre;
    lastH = cache->h;
    d2.resize(idx.size());
  }
  const int steps = std::max(1, iterations > 0 ? iterations : params_.iterations);
  const double normalInv = params_.normalSigma > 0 ? 1.0 / (params_.normalSigma * params_.normalSigma) : 0.0;
  for (int it = 0; it < steps; ++it) {
    // Re-centre the neighbourhood only when the estimate moved by more than a quarter kernel width.
    if (lastH == 0 || (x - queried).squaredNorm() > 0.0625 * lastH * lastH) {
      index_->knn(x, static_cast<std::size_t>(params_.k), idx, d2);
      if (!acrossStart_.empty() && !idx.empty()) {  // on a scan line: the nearest point's row reaches across
        const std::uint32_t nearest = idx[0];
        const std::size_t k = idx.size();
        for (std::size_t e = acrossStart_[nearest]; e < acrossStart_[nearest + 1]; ++e) {
          const std::uint32_t j = acrossRows_[e];
          if (std::find(idx.begin(), idx.begin() + static_cast<long>(k), j) != idx.begin() + static_cast<long>(k))
            continue;
          idx.push_back(j);
          d2.push_back((points_[j] - x).squaredNorm());
        }
      }
      queried = x;
      lastH = 0;
    } else {
      for (std::size_t j = 0; j < idx.size(); ++j) d2[j] = (points_[idx[j]] - x).squaredNorm();
    }
    const std::size_t found = idx.size();
    if (found == 0) break;
    // Only the sheet the query belongs to: neighbours whose normals face away from the reference get no weight.
    Eigen::Vector3d reference = it > 0 ? normal : hint ? *hint : normals_[idx[0]];
    auto facing = [&](std::uint32_t j) { return normals_[j].dot(reference) > 0; };
    if (std::none_of(idx.begin(), idx.end(), facing)) reference = normals_[idx[0]];
    // The sheet rule (sheets.hpp) against an anchor on the query's sheet — the nearest facing input point, then
    // the estimate itself — so that a sheet facing the same way a few spacings off (a shell inside a shell)
    // gets no weight either; only where a neighbour has another sheet near (all of them without near flags).
    bool gate = params_.sheetGap > 0 &&
                (nearSheets_.empty() || std::any_of(idx.begin(), idx.begin() + static_cast<long>(found),
                                                    [&](std::uint32_t j) { return nearSheets_[j] != 0; }));
    Eigen::Vector3d anchor = x, anchorNormal = normal;
    double anchorSpacing = 0;
    bool anchorNear = nearSheets_.empty();
    if (gate) {
      std::size_t first = 0;
      while (first + 1 < found && !facing(idx[first])) ++first;
      anchorSpacing = kSpacingPerWidth * h_[idx[first]];
      anchorNear = anchorNear || nearSheets_[idx[first]];
      if (it == 0) anchor = points_[idx[first]], anchorNormal = normals_[idx[first]];
    }
    auto onSheet = [&](std::uint32_t j) {
      if (!(anchorNear || nearSheets_[j])) return true;
      return !acrossGap(anchor, anchorNormal, points_[j], normals_[j],
                        params_.sheetGap * std::max(anchorSpacing, kSpacingPerWidth * h_[j]), kGapParallelCos);
    };
    if (gate && std::none_of(idx.begin(), idx.end(), [&](std::uint32_t j) { return facing(j) && onSheet(j); }))
      gate = false;
    h = 0;
    for (std::size_t j = 0; j < found; ++j) h += h_[idx[j]];
    h /= static_cast<double>(found);
    if (lastH == 0 && cache) *cache = {idx, queried, h};
    lastH = h;
    const double inv = 1.0 / (h * h);
    // eq. (2): Gaussian weights; eq. (1): weighted average a(x) and averaged oriented normal n_a.
    double wsum = 0;
    Eigen::Vector3d a = Eigen::Vector3d::Zero(), nsum = Eigen::Vector3d::Zero();
    w.resize(found);
    for (std::size_t j = 0; j < found; ++j) {
      w[j] = facing(idx[j]) && (!gate || onSheet(idx[j])) ? std::exp(-d2[j] * inv) + 1e-12 : 0.0;
      if (normalInv > 0 && w[j] > 0) w[j] *= std::exp(-(normals_[idx[j]] - reference).squaredNorm() * normalInv);
      wsum += w[j];
      a += w[j] * points_[idx[j]];
      nsum += w[j] * normals_[idx[j]];
    }
    a /= wsum;
    if (nsum.squaredNorm() < 1e-24) nsum = normals_[idx[0]];
    normal = nsum.normalized();
    planeNormal = normal;
    Eigen::Vector3d next = x - normal * normal.dot(x - a);  // eq. (3): project onto the tangent plane at a
    if (params_.degree >= 2 && found >= 8) {
      // Quadric height field over the tangent plane: f(u,v) = c0 + c1 u + c2 v + c3 u² + c4 uv + c5 v².
      const Eigen::Vector3d u = normal.unitOrthogonal(), v = normal.cross(u);
      const double invH = 1.0 / h;
      thread_local std::vector<double> qu, qv, qz;
      qu.resize(found), qv.resize(found), qz.resize(found);
      double lowest = std::numeric_limits<double>::max(), highest = std::numeric_limits<double>::lowest();
      for (std::size_t j = 0; j < found; ++j) {
        const Eigen::Vector3d d = (points_[idx[j]] - a) * invH;
        qu[j] = d.dot(u), qv[j] = d.dot(v), qz[j] = d.dot(normal);
        if (w[j] > 0) lowest = std::min(lowest, qz[j]), highest = std::max(highest, qz[j]);
      }
      Eigen::Matrix<double, 6, 6> ata;
      Eigen::Matrix<double, 6, 1> atb;
      quadricNormalEquations(w.data(), qu.data(), qv.data(), qz.data(), found, ata, atb);
      for (int r = 3; r < 6; ++r) ata(r, r) += 1e-3 * wsum;  // mild ridge: flat when under-determined
      // The ridge makes the system positive definite: Cholesky (unrolled at this fixed size) is several times
      // cheaper than a pivoting LDLT, which remains the fallback when the plane part is degenerate.
      const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(ata);
      const Eigen::Matrix<double, 6, 1> c =
          llt.info() == Eigen::Success ? Eigen::Matrix<double, 6, 1>(llt.solve(atb)) : ata.ldlt().solve(atb).eval();
      if (c.allFinite()) {
        const Eigen::Vector3d d = (x - a) / h;
        const double pu = d.dot(u), pv = d.dot(v);
        // A quadric fit across a crease (the rim of a plate a few spacings thick) bulges past the crease's corner,
        // off the surface. The kernel resolves no curvature radius below its width h, and a surface of radius h
        // rises above (or dips below) a point at distance r by at most r²/2h: the height is kept within that
        // of every point it was fit to (r: the nearest one, in the tangent plane; units of h here).
        double r2 = std::numeric_limits<double>::max();
        for (std::size_t j = 0; j < found; ++j)
          if (w[j] > 0) r2 = std::min(r2, (qu[j] - pu) * (qu[j] - pu) + (qv[j] - pv) * (qv[j] - pv));
        const double slack = 0.5 * r2;
        const double f = std::clamp(c[0] + c[1] * pu + c[2] * pv + c[3] * pu * pu + c[4] * pu * pv + c[5] * pv * pv,
                                    lowest - slack, highest + slack);
        const double fu = c[1] + 2 * c[3] * pu + c[4] * pv, fv = c[2] + c[4] * pu + 2 * c[5] * pv;
        // An ill-conditioned fit (a query far outside its few neighbours) can put the height field kernel
        // widths away from the plane: the plane's projection is the safe answer there.
        if (std::abs(f) <= kMaxQuadricHeight && std::isfinite(fu) && std::isfinite(fv)) {
          next = a + h * (pu * u + pv * v + f * normal);
          normal = (normal - fu * u - fv * v).normalized();
        }
      }
    }
    x = next;
    double best = std::numeric_limits<double>::max();
    std::size_t bestJ = 0;
    for (std::size_t j = 0; j < found; ++j) {
      if (w[j] == 0.0) continue;
      const double dd = (points_[idx[j]] - x).squaredNorm();
      if (dd < best) best = dd, bestJ = j;
    }
    off = std::sqrt(best) / h_[idx[bestJ]];
  }
  if (normalOut) *normalOut = normal;
  if (offSurface) *offSurface = off;
  if (beyond) *beyond = idx.empty() || h <= 0 ? 0.0 : beyondFootprint(points_, idx, w, x, normal, planeNormal) / h;
  return x;
}

}  // namespace iires
