// SPDX-License-Identifier: GPL-3.0-or-later
// The local crease fit: two planes fitted to a neighbourhood, the crease as their intersection line.
#include "features_internal.hpp"



#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <list>
#include <map>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <unordered_map>

#include "iires/knn.hpp"
#include "iires/sheets.hpp"
#include "iires/detail/parallel.hpp"


namespace iires::detail {

double meanNearestDistance(const std::vector<double>& d2) {
  double sum = 0;
  int m = 0;
  for (std::size_t t = 0; t < d2.size() && m < 6; ++t)
    if (d2[t] > 0) sum += std::sqrt(d2[t]), ++m;
  return m > 0 ? sum / m : 0.0;
}

double localSpacing(const KnnIndex& index, const Eigen::Vector3d& y, double h) {
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  index.knn(y, 7, idx, d2);
  return std::max(h, meanNearestDistance(d2));
}

double offInput(const PointCloud& cloud, const KnnIndex& index, const Eigen::Vector3d& y, double h) {
  double d2 = 0;
  const std::int64_t j = index.nearest(y, &d2);
  if (j < 0) return std::numeric_limits<double>::infinity();
  return std::sqrt(d2) / localSpacing(index, cloud.points[static_cast<std::size_t>(j)], h);
}

double fitPlane(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
                const Eigen::Vector3d& p, double sigma, const Eigen::Vector3d& hint, Eigen::Vector3d& normal,
                double& offset) {
  auto w = [&](std::uint32_t i) { return sigma > 0 ? std::exp(-(points[i] - p).squaredNorm() / (sigma * sigma)) : 1.0; };
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  double sum = 0;
  for (std::uint32_t i : idx) c += w(i) * points[i], sum += w(i);
  c /= sum;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::uint32_t i : idx) {
    const Eigen::Vector3d d = points[i] - c;
    cov += w(i) * d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  normal = es.eigenvectors().col(0);
  if (normal.dot(hint) < 0) normal = -normal;
  offset = normal.dot(c);
  return std::sqrt(std::max(0.0, es.eigenvalues()(0)) / sum);
}

Eigen::Vector3d lineNearest(const Eigen::Vector3d& na, double oa, const Eigen::Vector3d& nb, double ob,
                            const Eigen::Vector3d& p) {
  Eigen::Matrix2d g;
  g << 1.0, na.dot(nb), na.dot(nb), 1.0;
  const Eigen::Vector2d ab = g.inverse() * Eigen::Vector2d(oa - na.dot(p), ob - nb.dot(p));
  return p + ab(0) * na + ab(1) * nb;
}

bool twoPlaneTest(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                  const Eigen::Vector3d& p, const std::vector<std::uint32_t>& nbr, double h, const FeatureParams& prm,
                  Crease& crease, double sigma) {
  crease = Crease{};
  const std::size_t m = nbr.size();
  if (m < 8) return false;
  // Seeds of the 2-means on normals: the normal farthest from the mean, then the one farthest from it.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::uint32_t j : nbr) mean += normals[j];
  mean.normalize();
  std::size_t a = 0, b = 0;
  for (std::size_t t = 1; t < m; ++t)
    if (normals[nbr[t]].dot(mean) < normals[nbr[a]].dot(mean)) a = t;
  for (std::size_t t = 1; t < m; ++t)
    if (normals[nbr[t]].dot(normals[nbr[a]]) < normals[nbr[b]].dot(normals[nbr[a]])) b = t;
  Eigen::Vector3d na = normals[nbr[a]], nb = normals[nbr[b]];
  if (na.dot(nb) > std::cos(prm.angle * kDeg)) return false;  // the neighbours' normals vary too little
  std::vector<char> side(m, 0);
  for (int it = 0; it < 5; ++it) {
    Eigen::Vector3d sa = Eigen::Vector3d::Zero(), sb = Eigen::Vector3d::Zero();
    for (std::size_t t = 0; t < m; ++t) {
      side[t] = normals[nbr[t]].dot(na) >= normals[nbr[t]].dot(nb) ? 0 : 1;
      (side[t] == 0 ? sa : sb) += normals[nbr[t]];
    }
    if (sa.squaredNorm() == 0 || sb.squaredNorm() == 0) return false;
    na = sa.normalized();
    nb = sb.normalized();
  }
  // Planes through each cluster's positions, refined by reassigning points to the nearer plane.
  std::vector<std::uint32_t> ca, cb;
  Eigen::Vector3d pa, pb;
  double oa = 0, ob = 0, ra = 0, rb = 0;
  const std::size_t minCount = std::max<std::size_t>(3, static_cast<std::size_t>(prm.minClusterShare * m));
  for (int it = 0; it < 3; ++it) {
    ca.clear();
    cb.clear();
    for (std::size_t t = 0; t < m; ++t) (side[t] == 0 ? ca : cb).push_back(nbr[t]);
    if (ca.size() < minCount || cb.size() < minCount) return false;
    ra = fitPlane(points, ca, p, sigma, na, pa, oa);
    rb = fitPlane(points, cb, p, sigma, nb, pb, ob);
    if (it == 2) break;
    for (std::size_t t = 0; t < m; ++t) {
      const double da = std::abs(pa.dot(points[nbr[t]]) - oa), db = std::abs(pb.dot(points[nbr[t]]) - ob);
      side[t] = da <= db ? 0 : 1;
    }
  }
  if (ra > prm.maxResidual * h || rb > prm.maxResidual * h) return false;
  const Eigen::Vector3d dir = pa.cross(pb);
  const double sinAngle = dir.norm();
  if (pa.dot(pb) > std::cos(prm.angle * kDeg) || sinAngle < 1e-6) return false;
  const Eigen::Vector3d x = lineNearest(pa, oa, pb, ob, p);
  if ((x - p).norm() > prm.maxLineDistance * h) return false;
  crease.valid = true;
  crease.point = x;
  crease.direction = dir / sinAngle;
  crease.normalA = pa;
  crease.normalB = pb;
  crease.offsetA = oa;
  crease.offsetB = ob;
  return true;
}


namespace {

/// Whether the crease @p c lies on the input: a crease is where two of its sheets meet, so its point is within
/// 1.5·maxOffCrease local spacings of an input point (of the points of a randomly sampled surface, 1 in 1,000 is
/// farther than 1.5 spacings from every sample). Off the surface a fit's ball, a few local spacings read where
/// it is centred, widens with the distance, and the planes fitted there (past a face's end, or blending a narrow
/// face into a sheet) meet off it.
bool onInput(const PointCloud& cloud, const KnnIndex& index, const Crease& c, const FeatureParams& params) {
  return offInput(cloud, index, c.point, 0.0) <= 1.5 * params.maxOffCrease;
}

/// Keeps the points of @p idx (input points near @p y) on a sheet through y: those whose tangent plane (the
/// point and its normal) passes within the sheet rule's gap (SheetParams::gapSpacings, 1.25 local spacings
/// @p hl) of y. Where another surface comes within a fit's radius (the far side of a thin wall, a part nearly
/// touching), its points' planes lie that far off, and a fit that took them in would blend it into the
/// crease's sheets.
void keepSheetsThrough(const PointCloud& cloud, const Eigen::Vector3d& y, double hl,
                       std::vector<std::uint32_t>& idx) {
  const double gap = SheetParams{}.gapSpacings * hl;
  std::size_t kept = 0;
  for (std::uint32_t j : idx)
    if (std::abs(cloud.normals[j].dot(y - cloud.points[j])) <= gap) idx[kept++] = j;
  idx.resize(kept);
}

}  // namespace

bool snapFit(const PointCloud& cloud, const KnnIndex& index, const Eigen::Vector3d& y, double hl,
             const FeatureParams& params, const FeatureParams& prm, Crease& c, std::vector<std::uint32_t>& idx,
             std::vector<double>& d2) {
  index.radius(y, params.radius * hl, idx, d2);
  if (idx.size() > kMaxFitPoints) idx.resize(kMaxFitPoints);
  keepSheetsThrough(cloud, y, hl, idx);
  return twoPlaneTest(cloud.points, cloud.normals, y, idx, hl, prm, c, params.snapSigma * hl) &&
         onInput(cloud, index, c, params);
}

FeatureParams looseParams(const FeatureParams& params) {
  FeatureParams loose = params;
  loose.angle = 1.0;
  loose.maxResidual = 2.0 * params.maxResidual;
  loose.minClusterShare = 0.5 * params.minClusterShare;
  return loose;
}

bool creaseAlong(const PointCloud& cloud, const KnnIndex& index, const Eigen::Vector3d& y,
                 const Eigen::Vector3d& dir, double hl, const FeatureParams& params, Crease& c,
                 std::vector<std::uint32_t>& idx, std::vector<double>& d2, std::vector<std::uint32_t>& behind,
                 bool& oneSided) {
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  oneSided = false;
  if (snapFit(cloud, index, y, hl, params, params, c, idx, d2) && std::abs(c.direction.dot(dir)) >= cosTurn)
    return true;
  behind.clear();
  for (std::uint32_t j : idx)
    if ((cloud.points[j] - y).dot(dir) <= 0) behind.push_back(j);
  oneSided = twoPlaneTest(cloud.points, cloud.normals, y, behind, hl, params, c, params.snapSigma * hl) &&
             onInput(cloud, index, c, params) && std::abs(c.direction.dot(dir)) >= cosTurn;
  return oneSided;
}

void partitionByPlanes(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
                       const Eigen::Vector3d (&n)[3], const double (&o)[3], double tol,
                       std::vector<std::uint32_t> (&part)[3]) {
  for (auto& pt : part) pt.clear();
  for (std::uint32_t j : idx) {
    int best = 0;
    double bd = 1e300;
    for (int k = 0; k < 3; ++k) {
      const double dk = std::abs(n[k].dot(points[j]) - o[k]);
      if (dk < bd) bd = dk, best = k;
    }
    if (bd <= tol) part[best].push_back(j);
  }
}

void dropSamples(const std::vector<char>& drop, std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < out.size(); ++i)
    if (!drop[i]) out[kept] = out[i], owner[kept] = owner[i], ++kept;
  out.resize(kept);
  owner.resize(kept);
}

std::vector<std::pair<std::size_t, std::size_t>> ownerRuns(const std::vector<std::uint32_t>& owner) {
  std::vector<std::pair<std::size_t, std::size_t>> runs;
  for (std::size_t a = 0; a < owner.size();) {
    std::size_t b = a;
    while (b + 1 < owner.size() && owner[b + 1] == owner[a]) ++b;
    runs.emplace_back(a, b);
    a = b + 1;
  }
  return runs;
}

}  // namespace iires::detail
