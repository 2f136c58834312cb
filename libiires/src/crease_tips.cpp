// SPDX-License-Identifier: GPL-3.0-or-later
// Step 3b of snapToCreases(): two creases that run into one point without a third crease get their tip.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "features_internal.hpp"
#include "iires/knn.hpp"

namespace iires::detail {

namespace {

/// The two planes of @p c refitted on @p nbr (the neighbourhood of @p y), robust to a third sheet: each point
/// goes to the plane it is nearer to, and only if within 3·maxResidual spacings of it (the points of another
/// sheet, as a second crease's far side, are left out), and each plane is refitted with weights exp(−d²/σ²);
/// twice. The line point is the line's point nearest y. Returns false (and leaves @p c) when a plane keeps
/// fewer than 5 points or fits worse than maxResidual.
bool refitPlanesRobust(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& y,
                       const std::vector<std::uint32_t>& nbr, double hl, const FeatureParams& prm,
                       double sigma, Crease& c) {
  Eigen::Vector3d na = c.normalA, nb = c.normalB;
  double oa = c.offsetA, ob = c.offsetB;
  const double tol = 3.0 * prm.maxResidual * hl;
  std::vector<std::uint32_t> pa, pb;
  for (int it = 0; it < 2; ++it) {
    pa.clear();
    pb.clear();
    for (std::uint32_t j : nbr) {
      const double da = std::abs(na.dot(points[j]) - oa), db = std::abs(nb.dot(points[j]) - ob);
      if (std::min(da, db) <= tol) (da <= db ? pa : pb).push_back(j);
    }
    if (pa.size() < 5 || pb.size() < 5) return false;
    Eigen::Vector3d ta, tb;
    double toa = 0, tob = 0;
    if (fitPlane(points, pa, y, sigma, na, ta, toa) > prm.maxResidual * hl ||
        fitPlane(points, pb, y, sigma, nb, tb, tob) > prm.maxResidual * hl)
      return false;
    na = ta, nb = tb, oa = toa, ob = tob;
  }
  const Eigen::Vector3d dir = na.cross(nb);
  if (dir.norm() < 1e-6) return false;
  c.point = lineNearest(na, oa, nb, ob, y);
  c.direction = dir.normalized();
  c.normalA = na, c.normalB = nb, c.offsetA = oa, c.offsetB = ob;
  return true;
}

/// A chain end of placeCreaseTips(): its crease line off the end.
struct TipEnd {
  std::size_t run;
  bool back;                         // the run's last sample (else its first)
  Eigen::Vector3d point, direction;  // on the fitted line, nearest the end sample; forward, off the end
  double step, hl;
  Crease crease;
};

/// The runs' ends with a crease fit near them (up to 3 samples in; the robust refit when it keeps the
/// direction), as points on the fitted line with the direction off the end.
std::vector<TipEnd> tipEnds(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                            const std::vector<Eigen::Vector3d>& out,
                            const std::vector<std::pair<std::size_t, std::size_t>>& runs) {
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  std::vector<std::uint32_t> idx, behind;
  std::vector<double> d2;
  std::vector<TipEnd> ends;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const auto [a, b] = runs[r];
    if (b == a) continue;
    for (int side = 0; side < 2; ++side) {
      const Eigen::Vector3d& tip = side ? out[b] : out[a];
      const Eigen::Vector3d& prev = side ? out[b - 1] : out[a + 1];
      const double step = (tip - prev).norm();
      if (!(step > 1e-9 * h)) continue;
      const Eigen::Vector3d forward = (tip - prev) / step;
      Crease c;
      double hl = h;
      bool ok = false;
      for (std::size_t k = 0; k <= 3 && k <= b - a && !ok; ++k) {
        const Eigen::Vector3d& y = side ? out[b - k] : out[a + k];
        hl = localSpacing(index, y, h);
        bool oneSided = false;
        ok = creaseAlong(cloud, index, y, forward, hl, params, c, idx, d2, behind, oneSided);
        Crease robust = c;
        if (ok && refitPlanesRobust(cloud.points, y, idx, hl, params, params.snapSigma * hl, robust) &&
            std::abs(robust.direction.dot(forward)) >= cosTurn)
          c = robust;
      }
      if (!ok) continue;
      const Eigen::Vector3d dir = c.direction.dot(forward) < 0 ? -c.direction : c.direction;
      ends.push_back({r, side == 1, c.point + dir * (tip - c.point).dot(dir), dir, step, hl, c});
    }
  }
  return ends;
}

/// The tip where ends @p ea and @p eb meet, as the three sheets' common point, starting from @p tip.
Eigen::Vector3d refineTip(const PointCloud& cloud, const KnnIndex& index, const FeatureParams& params,
                          const TipEnd& ea, const TipEnd& eb, bool sharedA, bool sharedB, double hl,
                          Eigen::Vector3d tip) {
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  // The tip as the three sheets' common point: the shared plane (from the ends' fits: the shared sheet
  // narrows to nothing at the tip) and the two other sheets' planes, refitted on the points around the
  // tip that lie nearest to them (within 3·maxResidual).
  Eigen::Vector3d pn[3] = {sharedA ? ea.crease.normalA : ea.crease.normalB,
                           sharedA ? ea.crease.normalB : ea.crease.normalA,
                           sharedB ? eb.crease.normalB : eb.crease.normalA};
  double po[3] = {sharedA ? ea.crease.offsetA : ea.crease.offsetB,
                  sharedA ? ea.crease.offsetB : ea.crease.offsetA,
                  sharedB ? eb.crease.offsetB : eb.crease.offsetA};
  const double tolc = 3.0 * params.maxResidual * hl;
  std::vector<std::uint32_t> part[3];
  for (int it = 0; it < 4; ++it) {
    index.radius(tip, params.radius * hl, idx, d2);
    partitionByPlanes(cloud.points, idx, pn, po, tolc, part);
    Eigen::Vector3d tn[3] = {pn[0], pn[1], pn[2]};
    double to[3] = {po[0], po[1], po[2]};
    bool fitted = true;
    for (int k = 1; k < 3 && fitted; ++k)
      fitted = part[k].size() >= 5 && fitPlane(cloud.points, part[k], tip, params.snapSigma * hl, pn[k],
                                               tn[k], to[k]) <= 2.0 * params.maxResidual * hl;
    if (!fitted) break;
    Eigen::Matrix3d m;
    m << tn[0].transpose(), tn[1].transpose(), tn[2].transpose();
    if (std::abs(m.determinant()) < 0.1) break;
    const Eigen::Vector3d k3 = m.inverse() * Eigen::Vector3d(to[0], to[1], to[2]);
    const double moved = (k3 - tip).norm();
    if (moved > hl) break;
    for (int k = 1; k < 3; ++k) pn[k] = tn[k], po[k] = to[k];
    tip = k3;
    if (moved < 0.1 * hl) break;
  }
  return tip;
}

}  // namespace

void placeCreaseTips(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                     std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) {
  const auto runs = ownerRuns(owner);
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  std::vector<TipEnd> ends = tipEnds(cloud, index, h, params, out, runs);
  const double cosMin = std::cos(8.0 * kDeg);  // closer to parallel: no tip within reach
  std::vector<char> used(ends.size(), 0);
  std::vector<std::vector<Eigen::Vector3d>> extension(ends.size());
  std::vector<Eigen::Vector3d> placed(out);
  auto nearPlaced = [&](const Eigen::Vector3d& y, double r) {
    for (const auto& q : placed)
      if ((q - y).squaredNorm() < r * r) return true;
    return false;
  };
  auto planeDistance = [](const Crease& k, const Eigen::Vector3d& q, bool& isA) {
    const double da = std::abs(k.normalA.dot(q) - k.offsetA), db = std::abs(k.normalB.dot(q) - k.offsetB);
    isA = da <= db;
    return std::min(da, db);
  };
  for (std::size_t a = 0; a < ends.size(); ++a)
    for (std::size_t b = a + 1; b < ends.size() && !used[a]; ++b) {
      if (used[b] || ends[a].run == ends[b].run) continue;
      const TipEnd &ea = ends[a], &eb = ends[b];
      const double hl = std::max(ea.hl, eb.hl), reach = 6.0 * params.radius * hl;
      if ((ea.point - eb.point).norm() > reach) continue;
      const double c = ea.direction.dot(eb.direction);
      if (c > cosMin || c < cosTurn) continue;  // not converging at a small angle
      bool sharedA = false, sharedB = false;    // which plane of each end is the shared sheet
      if (planeDistance(ea.crease, eb.point, sharedA) > params.maxLineDistance * hl ||
          planeDistance(eb.crease, ea.point, sharedB) > params.maxLineDistance * hl)
        continue;
      // Closest points of the two lines: ea.point + sa·da and eb.point + tb·db, both ahead.
      const Eigen::Vector3d w = ea.point - eb.point;
      const double d = ea.direction.dot(w), e = eb.direction.dot(w);
      const double sa = (c * e - d) / (1.0 - c * c), tb = (e - c * d) / (1.0 - c * c);
      if (sa <= 0 || tb <= 0 || sa > reach || tb > reach) continue;
      const Eigen::Vector3d pa = ea.point + sa * ea.direction, pb = eb.point + tb * eb.direction;
      if ((pa - pb).norm() > 0.5 * hl) continue;  // the two lines must (nearly) meet
      Eigen::Vector3d tip = 0.5 * (pa + pb);
      tip = refineTip(cloud, index, params, ea, eb, sharedA, sharedB, hl, tip);
      const auto onSurface = [&](const Eigen::Vector3d& q) {
        double d2 = 0;
        index.nearest(q, &d2);
        return std::sqrt(d2) <= params.maxOffCrease * hl;
      };
      if (!onSurface(tip)) continue;
      std::vector<Eigen::Vector3d> fill[2];
      bool clear = true;
      for (int side = 0; side < 2 && clear; ++side) {
        const TipEnd& ek = side ? eb : ea;
        const double gap = (tip - ek.point).norm();
        const int pieces = std::max(1, static_cast<int>(std::ceil(gap / ek.step - 0.25)));
        for (int t = 1; t <= pieces && clear; ++t) {
          const Eigen::Vector3d q = ek.point + (tip - ek.point) * (static_cast<double>(t) / pieces);
          clear = !nearPlaced(q, 0.5 * ek.step) && onSurface(q);
          fill[side].push_back(q);
        }
      }
      if (!clear) continue;
      used[a] = used[b] = 1;
      extension[a] = fill[0];
      for (const auto& q : fill[1]) {
        bool near = false;
        for (const auto& p : extension[a]) near = near || (p - q).norm() < 0.5 * eb.step;
        if (!near) extension[b].push_back(q);
      }
      placed.insert(placed.end(), extension[a].begin(), extension[a].end());
      placed.insert(placed.end(), extension[b].begin(), extension[b].end());
    }
  std::vector<const std::vector<Eigen::Vector3d>*> before(runs.size(), nullptr), after(runs.size(), nullptr);
  for (std::size_t k = 0; k < ends.size(); ++k)
    if (!extension[k].empty()) (ends[k].back ? after : before)[ends[k].run] = &extension[k];
  std::vector<Eigen::Vector3d> result;
  std::vector<std::uint32_t> resultOwner;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const auto [a, b] = runs[r];
    if (before[r])
      for (std::size_t t = before[r]->size(); t-- > 0;)
        result.push_back((*before[r])[t]), resultOwner.push_back(owner[a]);
    for (std::size_t t = a; t <= b; ++t) result.push_back(out[t]), resultOwner.push_back(owner[a]);
    if (after[r])
      for (const auto& q : *after[r]) result.push_back(q), resultOwner.push_back(owner[a]);
  }
  out = std::move(result);
  owner = std::move(resultOwner);
}

}  // namespace iires::detail
