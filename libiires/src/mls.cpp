// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/mls.hpp"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>

#include "iires/detail/parallel.hpp"
#include "iires/sheets.hpp"
#include "quadric_fit.hpp"

namespace iires {
namespace {
constexpr std::size_t kKernelNeighbour = MlsSurface::kWidthNeighbours - 1;  // paper: h from the 8th neighbour
constexpr double kMaxQuadricHeight = 2.0;     // kernel widths: a quadric fit beyond this is not trusted
// Input spacing (mean nearest-neighbour distance) per kernel width: a uniform sampling's 8th neighbour lies
// √(8/π) grid spacings away, its nearest half a grid spacing.
const double kSpacingPerWidth = 0.5 / std::sqrt(8.0 / M_PI);
const double kGapParallelCos = std::cos(25.0 * M_PI / 180.0);  // SheetParams::gapAngleDeg

/// Distance from the origin to the segment [p, r].
double segmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& r) {
  const Eigen::Vector2d e = r - p;
  const double ee = e.squaredNorm();
  const double t = ee > 0 ? std::clamp(-p.dot(e) / ee, 0.0, 1.0) : 0.0;
  return (p + t * e).norm();
}

/// Distance in the tangent plane at @p x (normal @p normal) from x to the convex hull of the neighbours
/// @p idx that have weight in @p w (the last projection step's): 0 inside it.
/// Neighbours in all four open quadrants around x prove it inside (every line through x leaves a whole quadrant
/// on one side), which ends the scan early in the cloud's interior; only the rest (near an open boundary)
/// build the hull.
double beyondHull(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
                  const std::vector<double>& w, const Eigen::Vector3d& x, const Eigen::Vector3d& normal) {
  const Eigen::Vector3d u = normal.unitOrthogonal(), t = normal.cross(u);
  thread_local std::vector<Eigen::Vector2d> q;
  q.clear();
  unsigned quadrants = 0;
  for (std::size_t j = 0; j < idx.size(); ++j)
    if (w[j] != 0.0) {
      const Eigen::Vector3d d = points[idx[j]] - x;
      const double a = d.dot(u), b = d.dot(t);
      quadrants |= (a > 0 ? 1u : a < 0 ? 2u : 0u) << (b > 0 ? 0 : b < 0 ? 2 : 4);
      if ((quadrants & 15u) == 15u) return 0.0;
      q.emplace_back(a, b);
    }
  if (q.size() < 3) return q.empty() ? 0.0 : q.size() == 1 ? q[0].norm() : segmentDistance(q[0], q[1]);
  // The hull (Andrew's monotone chain, counter-clockwise), then x's distance to it: 0 inside, else to the
  // nearest hull edge.
  std::sort(q.begin(), q.end(), [](const Eigen::Vector2d& p, const Eigen::Vector2d& r) {
    return p.x() < r.x() || (p.x() == r.x() && p.y() < r.y());
  });
  thread_local std::vector<Eigen::Vector2d> hull;
  hull.assign(2 * q.size(), Eigen::Vector2d::Zero());
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& p, const Eigen::Vector2d& r) {
    return (p - o).x() * (r - o).y() - (p - o).y() * (r - o).x();
  };
  std::size_t m = 0;
  for (std::size_t j = 0; j < q.size(); ++j) {
    while (m >= 2 && cross(hull[m - 2], hull[m - 1], q[j]) <= 0) --m;
    hull[m++] = q[j];
  }
  for (std::size_t j = q.size() - 1, lowerEnd = m + 1; j-- > 0;) {
    while (m >= lowerEnd && cross(hull[m - 2], hull[m - 1], q[j]) <= 0) --m;
    hull[m++] = q[j];
  }
  --m;  // the last point is the first
  if (m < 3) return segmentDistance(hull[0], hull[m > 1 ? 1 : 0]);
  const Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  bool inside = true;
  double nearest = std::numeric_limits<double>::max();
  for (std::size_t e = 0; e < m; ++e) {
    const Eigen::Vector2d& p = hull[e];
    const Eigen::Vector2d& r = hull[e + 1 == m ? 0 : e + 1];
    if (cross(p, r, origin) < 0) inside = false;
    nearest = std::min(nearest, segmentDistance(p, r));
  }
  return inside ? 0.0 : nearest;
}

/// One weighted local fit and the projection of @p x onto it: eq. (1) the weighted average a and averaged normal,
/// eq. (3) the tangent plane at a, and with @p quadric a quadric height field over it.
struct LocalFit {
  Eigen::Vector3d point, normal;  ///< x projected, and the surface normal there
  Eigen::Vector3d centre;         ///< a, the weighted average of the neighbours
  double weight = 0;              ///< Σ w
};

LocalFit fitAndProject(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                       const std::vector<std::uint32_t>& idx, const std::vector<double>& w, std::size_t found,
                       double h, const Eigen::Vector3d& x, bool quadric) {
  double wsum = 0;
  Eigen::Vector3d a = Eigen::Vector3d::Zero(), nsum = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < found; ++j) {
    wsum += w[j];
    a += w[j] * points[idx[j]];
    nsum += w[j] * normals[idx[j]];
  }
  a /= wsum;
  if (nsum.squaredNorm() < 1e-24) nsum = normals[idx[0]];
  Eigen::Vector3d normal = nsum.normalized();
  Eigen::Vector3d next = x - normal * normal.dot(x - a);  // eq. (3): project onto the tangent plane at a
  if (quadric) {
    // Quadric height field over the tangent plane: f(u,v) = c0 + c1 u + c2 v + c3 u² + c4 uv + c5 v².
    const Eigen::Vector3d u = normal.unitOrthogonal(), v = normal.cross(u);
    const double invH = 1.0 / h;
    thread_local std::vector<double> qu, qv, qz;
    qu.resize(found), qv.resize(found), qz.resize(found);
    double lowest = std::numeric_limits<double>::max(), highest = std::numeric_limits<double>::lowest();
    for (std::size_t j = 0; j < found; ++j) {
      const Eigen::Vector3d d = (points[idx[j]] - a) * invH;
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
  return {next, normal, a, wsum};
}

/// The faces of a neighbourhood near a crease: the neighbours with weight, nearest first, each joining the face
/// whose first (nearest) point's normal is within the crease angle of its own (cos ≥ @p cosAngle), else starting
/// one. face[j] = the face of neighbour j (kNoFace: no weight, or beyond kMaxFaces). Returns the number of faces.
constexpr std::uint8_t kNoFace = 255;
constexpr std::size_t kMaxFaces = 4;
std::size_t splitFaces(const std::vector<Eigen::Vector3d>& normals, const std::vector<std::uint32_t>& idx,
                       const std::vector<double>& d2, const std::vector<double>& w, std::size_t found,
                       double cosAngle, std::vector<std::uint8_t>& face,
                       std::array<Eigen::Vector3d, kMaxFaces>& seed) {
  thread_local std::vector<std::uint32_t> order;
  order.clear();
  for (std::size_t j = 0; j < found; ++j)
    if (w[j] > 0) order.push_back(static_cast<std::uint32_t>(j));
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t p, std::uint32_t q) { return d2[p] < d2[q] || (d2[p] == d2[q] && p < q); });
  face.assign(found, kNoFace);
  std::size_t faces = 0;
  for (std::uint32_t j : order) {
    const Eigen::Vector3d& nj = normals[idx[j]];
    std::size_t best = kMaxFaces;
    double bestCos = cosAngle;
    for (std::size_t f = 0; f < faces; ++f)
      if (const double c = nj.dot(seed[f]); c >= bestCos) bestCos = c, best = f;
    if (best == kMaxFaces && faces < kMaxFaces) seed[best = faces++] = nj;
    if (best < kMaxFaces) face[j] = static_cast<std::uint8_t>(best);
  }
  return faces;
}

constexpr double kMinFaceShare = 0.1;  // a face with less of the neighbourhood's weight is no sheet of its own

/// x projected near a crease (MlsParams::creaseAngle): the neighbourhood split into faces (splitFaces), each face
/// fitted on its own points, and x taken to the nearest point of the piecewise surface they make — the nearest
/// projection that lies on the surface's side of every other face's tangent plane (below it at a convex crease,
/// above it at a concave one), else the nearest point of the line where the two heaviest faces' tangent planes
/// meet (x beyond a convex crease's corner). Continuous in x where the faces are: it does not depend on which
/// face x is nearest. Points of no face get weight 0 in @p w.
Eigen::Vector3d projectOnFaces(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                               const std::vector<std::uint32_t>& idx, const std::vector<double>& d2,
                               std::vector<double>& w, std::size_t found, double h, const Eigen::Vector3d& x,
                               bool quadric, double cosAngle, Eigen::Vector3d& normal) {
  thread_local std::vector<std::uint8_t> face;
  thread_local std::vector<double> wf;
  std::array<Eigen::Vector3d, kMaxFaces> seed;
  const std::size_t faces = splitFaces(normals, idx, d2, w, found, cosAngle, face, seed);
  std::array<double, kMaxFaces> share{};
  std::array<std::size_t, kMaxFaces> count{};
  double total = 0;
  for (std::size_t j = 0; j < found; ++j)
    if (face[j] != kNoFace) share[face[j]] += w[j], ++count[face[j]], total += w[j];
  std::array<LocalFit, kMaxFaces> fit;
  std::array<std::size_t, kMaxFaces> sheet{};
  std::size_t sheets = 0;
  for (std::size_t f = 0; f < faces; ++f) {
    if (share[f] < kMinFaceShare * total || count[f] < 3) continue;
    wf.assign(found, 0.0);
    for (std::size_t j = 0; j < found; ++j)
      if (face[j] == f) wf[j] = w[j];
    fit[sheets] = fitAndProject(points, normals, idx, wf, found, h, x, quadric && count[f] >= 6);
    sheet[sheets++] = f;
  }
  if (sheets == 0) {  // no face is a sheet: all of them as one
    const LocalFit all = fitAndProject(points, normals, idx, w, found, h, x, quadric);
    normal = all.normal;
    return all.point;
  }
  for (std::size_t j = 0; j < found; ++j)
    if (face[j] == kNoFace || std::find(sheet.begin(), sheet.begin() + sheets, face[j]) == sheet.begin() + sheets)
      w[j] = 0.0;
  std::size_t best = kMaxFaces;
  double bestD2 = std::numeric_limits<double>::max();
  for (std::size_t f = 0; f < sheets; ++f) {
    bool valid = true;
    for (std::size_t g = 0; g < sheets && valid; ++g) {
      if (g == f) continue;
      const LocalFit &a = fit[f], &b = fit[g];
      const bool convex = a.normal.dot(b.centre - a.point) + b.normal.dot(a.centre - b.point) < 0;
      const double height = b.normal.dot(a.point - b.point);
      valid = convex ? height <= 0 : height >= 0;
    }
    if (const double dd = (fit[f].point - x).squaredNorm(); valid && dd < bestD2) bestD2 = dd, best = f;
  }
  if (best < kMaxFaces) {
    normal = fit[best].normal;
    return fit[best].point;
  }
  // Beyond the corner: the nearest point of the line where the two heaviest faces' tangent planes meet.
  std::size_t first = 0, second = 1;
  if (fit[second].weight > fit[first].weight) std::swap(first, second);
  for (std::size_t f = 2; f < sheets; ++f)
    if (fit[f].weight > fit[first].weight) second = first, first = f;
    else if (fit[f].weight > fit[second].weight) second = f;
  const LocalFit &a = fit[first], &b = fit[second];
  const LocalFit& nearer = (a.point - x).squaredNorm() <= (b.point - x).squaredNorm() ? a : b;
  const double k = a.normal.dot(b.normal), det = 1 - k * k;
  const double ra = a.normal.dot(a.point - x), rb = b.normal.dot(b.point - x);
  const Eigen::Vector3d corner = x + ((ra - k * rb) / det) * a.normal + ((rb - k * ra) / det) * b.normal;
  if (det < 1e-6 || !((corner - nearer.point).squaredNorm() <= h * h)) {  // nearly parallel: the line is far off
    normal = nearer.normal;
    return nearer.point;
  }
  normal = (a.normal + b.normal).normalized();
  return corner;
}
}  // namespace

MlsSurface::MlsSurface(const std::vector<Eigen::Vector3d>& points,
                       const std::vector<Eigen::Vector3d>& normals, const MlsParams& params, const Execution& exec,
                       const KnnIndex* index, const NeighbourTable* table, std::vector<std::uint8_t> nearSheets)
    : points_(points),
      normals_(normals),
      params_(params),
      index_(index ? index : &own_.emplace(points)),
      nearSheets_(std::move(nearSheets)) {
  if (!nearSheets_.empty() && nearSheets_.size() != points.size())
    throw std::invalid_argument("MlsSurface: nearSheets must hold one flag per point");
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
  // Robust kernel width: clamp to the 90th percentile so a lone outlier cannot inflate it (DESIGN §3.3).
  std::vector<double> sorted = h_;
  const std::size_t q = std::min(n - 1, static_cast<std::size_t>(0.9 * static_cast<double>(n)));
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(q), sorted.end());
  const double cap = sorted[q];
  double area = 0, spacing = 0;
  for (std::size_t i = 0; i < n; ++i) {
    h_[i] = std::min(h_[i], cap);
    area += M_PI * h_[i] * h_[i] / static_cast<double>(kKernelNeighbour);
    spacing += nearest[i];
  }
  if (cap <= 0) std::fill(h_.begin(), h_.end(), 1.0);
  cosCrease_ = params.creaseAngle > 0 ? std::cos(params.creaseAngle * M_PI / 180.0) : 1.0;
  area_ = area;
  meanSpacing_ = n ? spacing / static_cast<double>(n) : 0.0;
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
  double lastH = 0;
  if (cache && cache->h > 0 && (x - cache->centre).squaredNorm() <= 0.0625 * cache->h * cache->h) {
    idx.assign(cache->indices.begin(), cache->indices.end());
    queried = cache->centre;
    lastH = cache->h;
    d2.resize(idx.size());
  }
  const int steps = std::max(1, iterations > 0 ? iterations : params_.iterations);
  for (int it = 0; it < steps; ++it) {
    // Re-centre the neighbourhood only when the estimate moved by more than a quarter kernel width.
    if (lastH == 0 || (x - queried).squaredNorm() > 0.0625 * lastH * lastH) {
      index_->knn(x, static_cast<std::size_t>(params_.k), idx, d2);
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
    // With the crease term a face across a crease sharper than a right angle faces away and yet is no other
    // sheet: only near-opposite normals (a thin part's other side) are.
    const bool crease = cosCrease_ < 1.0;
    auto eligible = [&](std::uint32_t j) {
      return crease ? normals_[j].dot(reference) > -kGapParallelCos : facing(j);
    };
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
    w.resize(found);  // eq. (2): Gaussian weights
    for (std::size_t j = 0; j < found; ++j)
      w[j] = eligible(idx[j]) && (!gate || onSheet(idx[j])) ? std::exp(-d2[j] * inv) + 1e-12 : 0.0;
    Eigen::Vector3d next;
    const bool quadric = params_.degree >= 2 && found >= 8;
    if (crease) {
      next = projectOnFaces(points_, normals_, idx, d2, w, found, h, x, quadric, cosCrease_, normal);
    } else {
      const LocalFit fit = fitAndProject(points_, normals_, idx, w, found, h, x, quadric);
      next = fit.point, normal = fit.normal;
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
  if (beyond) *beyond = idx.empty() || h <= 0 ? 0.0 : beyondHull(points_, idx, w, x, normal) / h;
  return x;
}

}  // namespace iires
