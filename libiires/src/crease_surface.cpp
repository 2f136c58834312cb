// SPDX-License-Identifier: GPL-3.0-or-later
// The input around a held sample as planar sheets (one, two, a band between two, or a corner of up to five
// faces), each bounded by the lines where it meets the others: held samples off the surface move onto them
// (ontoSheets), and chain ends short of a corner get the corner, the sheets' common point (addSheetCorners).
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "features_internal.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/knn.hpp"

namespace iires::detail {

namespace {

constexpr int kMaxSheets = 5;                // a corner where up to five faces meet
constexpr std::size_t kMinModelPoints = 40;  // the sheets are fitted on at least this many input points

/// A planar sheet of the neighbourhood: its plane and, in it, the lines where it meets the other sheets, which
/// cut the plane into cells (the sign of w·(x − at) per line); the sheet covers the cells its points lie in (a
/// half-plane at a crease, a wedge at a corner, the rest of the plane around a concave one).
struct Sheet {
  Eigen::Vector3d n = Eigen::Vector3d::Zero();
  double o = 0;
  std::vector<std::uint32_t> pts;
  int lines = 0;
  Eigen::Vector3d w[kMaxSheets - 1], at[kMaxSheets - 1], dir[kMaxSheets - 1];
  bool covered[1 << (kMaxSheets - 1)] = {};
  int cell(const Eigen::Vector3d& x) const {
    int c = 0;
    for (int b = 0; b < lines; ++b) c |= (w[b].dot(x - at[b]) > 0 ? 1 : 0) << b;
    return c;
  }
  /// Whether @p x (in the plane) lies in a covered cell or on its border: within @p eps of a line counts as
  /// either side of it.
  bool inCovered(const Eigen::Vector3d& x, double eps) const {
    int fixedBits = 0, side = 0;
    for (int b = 0; b < lines; ++b) {
      const double t = w[b].dot(x - at[b]);
      if (std::abs(t) > eps) fixedBits |= 1 << b, side |= (t > 0 ? 1 : 0) << b;
    }
    for (int c = 0; c < (1 << lines); ++c)
      if (covered[c] && (c & fixedBits) == side) return true;
    return false;
  }
};

/// The seeds of the normals' clustering in @p nbr: the normal farthest from the mean; the one farthest from
/// it, if by the detector's angle (else one sheet); and a third sheet's, the normal farthest out of the plane
/// of the first two if by that angle (the normals of the points on a crease between two sheets lie between
/// theirs; a third sheet meeting them at a corner has its normal out of their plane).
std::vector<Eigen::Vector3d> normalSeeds(const std::vector<Eigen::Vector3d>& nrm,
                                         const std::vector<std::uint32_t>& nbr, const FeatureParams& params) {
  const std::size_t m = nbr.size();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::uint32_t j : nbr) mean += nrm[j];
  if (m == 0 || mean.norm() < 1e-12) return {};
  mean.normalize();
  std::vector<Eigen::Vector3d> seed;
  std::size_t a = 0, b = 0, c = 0;
  for (std::size_t t = 1; t < m; ++t)
    if (nrm[nbr[t]].dot(mean) < nrm[nbr[a]].dot(mean)) a = t;
  seed.push_back(nrm[nbr[a]]);
  for (std::size_t t = 1; t < m; ++t)
    if (nrm[nbr[t]].dot(seed[0]) < nrm[nbr[b]].dot(seed[0])) b = t;
  if (nrm[nbr[b]].dot(seed[0]) > std::cos(params.angle * kDeg)) return seed;
  seed.push_back(nrm[nbr[b]]);
  const Eigen::Vector3d across = seed[0].cross(seed[1]).normalized();
  for (std::size_t t = 1; t < m; ++t)
    if (std::abs(nrm[nbr[t]].dot(across)) > std::abs(nrm[nbr[c]].dot(across))) c = t;
  if (std::abs(nrm[nbr[c]].dot(across)) > std::sin(params.angle * kDeg)) {
    seed.push_back(nrm[nbr[c]]);
    return seed;
  }
  // Else a band between the two: the normal farthest from both (a chamfer's; at a crease, a normal blurred
  // across it, which the band's plane fit then rejects), if by the detector's angle from each.
  for (std::size_t t = 1; t < m; ++t)
    if (std::max(nrm[nbr[t]].dot(seed[0]), nrm[nbr[t]].dot(seed[1])) <
        std::max(nrm[nbr[c]].dot(seed[0]), nrm[nbr[c]].dot(seed[1])))
      c = t;
  if (std::max(nrm[nbr[c]].dot(seed[0]), nrm[nbr[c]].dot(seed[1])) < std::cos(params.angle * kDeg))
    seed.push_back(nrm[nbr[c]]);
  return seed;
}

/// The seeds of a corner where up to kMaxSheets faces meet, one per plane found greedily in @p nbr: the tangent
/// plane (a point and its normal) that explains the most points not yet explained (within 3·maxResidual local
/// spacings @p hl), its normal by the detector's angle from the seeds before, while it explains 5 points, up to
/// kMaxSheets. Normals blurred across a crease or a corner (the normals' farthest-point seeds take those) have
/// tangent planes that cut the faces and explain few of their points.
std::vector<Eigen::Vector3d> planeSeeds(const PointCloud& cloud, const std::vector<std::uint32_t>& nbr, double hl,
                                        const FeatureParams& params) {
  const double tol = 3.0 * params.maxResidual * hl, cosSharp = std::cos(params.angle * kDeg);
  const auto& P = cloud.points;
  const auto& nrm = cloud.normals;
  std::vector<char> explained(nbr.size(), 0);
  std::vector<Eigen::Vector3d> seed;
  while (seed.size() < static_cast<std::size_t>(kMaxSheets)) {
    std::size_t best = nbr.size(), bestCount = 0;
    for (std::size_t t = 0; t < nbr.size(); ++t) {
      if (explained[t] || std::any_of(seed.begin(), seed.end(), [&](const Eigen::Vector3d& s) {
            return std::abs(nrm[nbr[t]].dot(s)) > cosSharp;
          }))
        continue;
      std::size_t count = 0;
      for (std::size_t u = 0; u < nbr.size(); ++u)
        count += !explained[u] && std::abs(nrm[nbr[t]].dot(P[nbr[u]] - P[nbr[t]])) <= tol;
      if (count > bestCount) best = t, bestCount = count;
    }
    if (bestCount < 5) break;
    const Eigen::Vector3d n = nrm[nbr[best]], at = P[nbr[best]];
    for (std::size_t u = 0; u < nbr.size(); ++u) explained[u] |= std::abs(n.dot(P[nbr[u]] - at)) <= tol;
    seed.push_back(n);
  }
  return seed;
}

/// The neighbourhood @p nbr of @p y as one planar sheet per normal in @p seed: the input normals clustered
/// around the seeds (k-means), a plane fitted to each cluster and the points reassigned to the nearest plane,
/// three times. False unless every sheet keeps 5 points and fits within maxResidual local spacings @p hl,
/// 90 % of the points lie within 3·maxResidual of a sheet (else more sheets, or curved ones, than the model
/// has), no two sheets are within the detector's angle (a band and a face: half of it) and a third one either
/// crosses the first two's line (a corner, as do any further ones) or lies between them along it where their
/// line is off the surface (a band: a chamfer or a small fillet; @p band says so).
bool fitSheets(const PointCloud& cloud, const std::vector<std::uint32_t>& nbr, const Eigen::Vector3d& y,
               double hl, const FeatureParams& params, std::vector<Eigen::Vector3d> seed,
               std::vector<Sheet>& sheets, bool& band) {
  band = false;
  const std::size_t m = nbr.size();
  const auto& nrm = cloud.normals;
  const double cosSharp = std::cos(params.angle * kDeg);
  const int k = static_cast<int>(seed.size());
  std::vector<int> side(m, 0);
  for (int it = 0; it < 5; ++it) {  // k-means on the normals
    std::vector<Eigen::Vector3d> sum(k, Eigen::Vector3d::Zero());
    for (std::size_t t = 0; t < m; ++t) {
      int best = 0;
      for (int s = 1; s < k; ++s)
        if (nrm[nbr[t]].dot(seed[s]) > nrm[nbr[t]].dot(seed[best])) best = s;
      side[t] = best;
      sum[best] += nrm[nbr[t]];
    }
    for (int s = 0; s < k; ++s) {
      if (sum[s].squaredNorm() == 0) return false;
      seed[s] = sum[s].normalized();
    }
  }
  const double sigma = params.snapSigma * hl, tol = 3.0 * params.maxResidual * hl;
  sheets.assign(k, Sheet{});
  std::size_t explained = 0;
  for (int it = 0; it < 3; ++it) {
    for (auto& s : sheets) s.pts.clear();
    for (std::size_t t = 0; t < m; ++t)
      if (side[t] >= 0) sheets[side[t]].pts.push_back(nbr[t]);
    for (int s = 0; s < k; ++s) {
      if (sheets[s].pts.size() < 5) return false;
      const double r = fitPlane(cloud.points, sheets[s].pts, y, sigma, seed[s], sheets[s].n, sheets[s].o);
      if (it == 2 && r > params.maxResidual * hl) return false;
    }
    explained = 0;
    for (std::size_t t = 0; t < m; ++t) {
      int best = 0;
      double bd = std::numeric_limits<double>::infinity();
      for (int s = 0; s < k; ++s) {
        const double d = std::abs(sheets[s].n.dot(cloud.points[nbr[t]]) - sheets[s].o);
        if (d < bd) bd = d, best = s;
      }
      side[t] = bd <= tol ? best : -1;
      explained += bd <= tol;
    }
  }
  if (10 * explained < 9 * m) return false;
  // A third sheet crosses the first two's line (a corner) or lies between them along it (a band).
  band = k == 3 && std::abs(sheets[2].n.dot(sheets[0].n.cross(sheets[1].n).normalized())) <= 0.3;
  // Two sheets within the detector's angle are one; a band, a strip of facets or a fillet's arc between two
  // faces, may turn from each by half of it.
  const double cosBand = std::cos(0.5 * params.angle * kDeg);
  for (int s = 0; s < k; ++s)
    for (int s2 = 0; s2 < k; ++s2)
      if (s2 != s &&
          std::abs(sheets[s].n.dot(sheets[s2].n)) > (band && (s == 2 || s2 == 2) ? cosBand : cosSharp))
        return false;
  if (band && !(sheets[2].n.dot(sheets[0].n) > sheets[0].n.dot(sheets[1].n) &&
                sheets[2].n.dot(sheets[1].n) > sheets[0].n.dot(sheets[1].n)))
    return false;
  // A band is there only where the faces meet off the surface: no input point within 0.2 hl of their line.
  if (band) {
    const Eigen::Vector3d dir = sheets[0].n.cross(sheets[1].n).normalized();
    const Eigen::Vector3d x = lineNearest(sheets[0].n, sheets[0].o, sheets[1].n, sheets[1].o, y);
    for (std::uint32_t j : nbr) {
      const Eigen::Vector3d d = cloud.points[j] - x;
      if ((d - dir * d.dot(dir)).norm() < 0.2 * hl) return false;
    }
  }
  // Each sheet's lines and the cells its points cover (those a local spacing or more from every line).
  for (int s = 0; s < k; ++s) {
    Sheet& sh = sheets[s];
    for (int s2 = 0; s2 < k; ++s2) {
      if (s2 == s) continue;
      sh.dir[sh.lines] = sh.n.cross(sheets[s2].n).normalized();
      sh.w[sh.lines] = sh.dir[sh.lines].cross(sh.n);
      sh.at[sh.lines] = lineNearest(sh.n, sh.o, sheets[s2].n, sheets[s2].o, y);
      ++sh.lines;
    }
    // A point near a line may be the other sheet's, within the tolerance of this one: a cell counts the
    // points a local spacing or more from every line, or a third of its width, a band's between its two
    // lines.
    const double width = band && s == 2 ? std::abs(sh.w[0].dot(sh.at[1] - sh.at[0])) : 0.0;
    const double clearance = band && s == 2 ? std::min(hl, width / 3.0) : hl;
    int count[1 << (kMaxSheets - 1)] = {};
    for (std::uint32_t j : sh.pts) {
      if ((cloud.points[j] - y).norm() > params.radius * hl)
        continue;  // along a curved crease the lines bend
      bool clear = true;
      for (int b = 0; b < sh.lines; ++b)
        clear = clear && std::abs(sh.w[b].dot(cloud.points[j] - sh.at[b])) >= clearance;
      if (clear) sh.covered[sh.cell(cloud.points[j])] = true;
      ++count[sh.cell(cloud.points[j])];
    }
    // A sheet with no point clear of its lines (a face between a band and the ball's rim): the cell most of
    // its points lie in.
    if (std::none_of(std::begin(sh.covered), std::end(sh.covered), [](bool c) { return c; }))
      sh.covered[std::max_element(std::begin(count), std::end(count)) - std::begin(count)] = true;
  }
  return true;
}

/// The point of @p sh (the cells it covers of its plane) nearest @p q: q's foot on the plane if that is in a
/// covered cell, else the nearest of the feet on its lines and the lines' crossings that border a covered cell
/// (@p hl, the local spacing, sets the tolerance of "on a line").
Eigen::Vector3d nearestOnSheet(const Sheet& sh, const Eigen::Vector3d& q, double hl) {
  const double eps = 1e-6 * hl;
  const Eigen::Vector3d x = q - sh.n * (sh.n.dot(q) - sh.o);
  if (sh.inCovered(x, eps)) return x;
  Eigen::Vector3d best = x;
  double bd = std::numeric_limits<double>::infinity();
  auto consider = [&](const Eigen::Vector3d& e) {
    if ((e - q).norm() < bd && sh.inCovered(e, eps)) bd = (e - q).norm(), best = e;
  };
  for (int b = 0; b < sh.lines; ++b) {
    consider(sh.at[b] + sh.dir[b] * (x - sh.at[b]).dot(sh.dir[b]));
    for (int b2 = 0; b2 < b; ++b2) {
      const double c = sh.dir[b].dot(sh.dir[b2]);
      if (1.0 - c * c <= 1e-9) continue;  // parallel lines do not cross
      const Eigen::Vector3d r = sh.at[b] - sh.at[b2];
      const double t = (c * sh.dir[b2].dot(r) - sh.dir[b].dot(r)) / (1.0 - c * c);
      consider(sh.at[b] + t * sh.dir[b]);
    }
  }
  return best;
}

/// The sheets around @p q (local spacing @p hl): the input within the radius, at least the 40 nearest, as three
/// sheets where the normals say so, else (or where those do not fit) two, one only where the normals see no
/// second; where none of those fits (a corner where more faces meet, or whose faces are too small in those
/// points), the three to five planes found greedily in the 80 nearest. @p cornerFirst: the greedy planes
/// first (a corner's faces, none blended into another). False where no model fits.
bool sheetsAround(const PointCloud& cloud, const KnnIndex& index, const Eigen::Vector3d& q, double hl,
                  const FeatureParams& params, bool cornerFirst, std::vector<Sheet>& sheets, bool& band) {
  std::vector<std::uint32_t> ball, idx;
  std::vector<double> d2;
  index.radius(q, params.radius * hl, ball, d2);
  if (ball.size() > kMaxFitPoints) ball.resize(kMaxFitPoints);
  // The ball, or the @p least nearest points where it holds fewer (a sparse part: fits need points).
  auto neighbourhood = [&](std::size_t least) {
    if (ball.size() >= least) idx = ball;
    else index.knn(q, least, idx, d2);
  };
  auto byNormals = [&] {
    neighbourhood(kMinModelPoints);
    if (idx.size() < 12) return false;
    const std::vector<Eigen::Vector3d> seed = normalSeeds(cloud.normals, idx, params);
    for (std::size_t k = seed.size(); k >= 1 && !(k == 1 && seed.size() > 1); --k)
      if (fitSheets(cloud, idx, q, hl, params, {seed.begin(), seed.begin() + static_cast<long>(k)}, sheets, band))
        return true;
    return false;
  };
  auto byPlanes = [&] {
    neighbourhood(2 * kMinModelPoints);
    const std::vector<Eigen::Vector3d> planes = planeSeeds(cloud, idx, hl, params);
    for (std::size_t k = planes.size(); k >= 3; --k)
      if (fitSheets(cloud, idx, q, hl, params, {planes.begin(), planes.begin() + static_cast<long>(k)}, sheets,
                    band))
        return true;
    return false;
  };
  return cornerFirst ? byPlanes() || byNormals() : byNormals() || byPlanes();
}

}  // namespace

std::vector<char> ontoSheets(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                             std::vector<Eigen::Vector3d>& out, int threads) {
  constexpr double kOff = 0.3;   // local spacings: a sample farther than this from the sheets moves
  constexpr double kMove = 2.0;  // local spacings: and by at most this much (farther: not its own model)
  std::vector<char> drop(out.size(), 0);
  parallelFor(out.size(), threads, [&](std::size_t i) {
    std::vector<Sheet> sheets;
    const Eigen::Vector3d q = out[i];
    const double hl = localSpacing(index, q, h);
    bool band = false;
    const bool fitted = sheetsAround(cloud, index, q, hl, params, false, sheets, band);
    if (!fitted || sheets.size() == 1) {
      // No crease in the model: one sheet, or none that fits (a curved surface, a corner of many faces, a crease
      // between curved sheets). Two planes fitted there that meet under the crease angle say there is none:
      // the sample's chain ran off its crease (a trace carried on down a faceted cylinder's facet edge).
      Crease c;
      std::vector<std::uint32_t> idx;
      std::vector<double> d2;
      drop[i] = snapFit(cloud, index, q, hl, params, looseParams(params), c, idx, d2) &&
                c.normalA.dot(c.normalB) > std::cos(params.angle * kDeg);
      if (!fitted || drop[i]) return;
    }
    Eigen::Vector3d best = q;
    double bd = std::numeric_limits<double>::infinity();
    for (const Sheet& sh : sheets) {
      const Eigen::Vector3d x = nearestOnSheet(sh, q, hl);
      if ((x - q).norm() < bd) bd = (x - q).norm(), best = x;
    }
    // A move onto the surface brings the sample nearer the input; one away from it (a model biased by a sheet
    // it leaves out, as next to a corner) does not. A sample the model puts off the surface, with no move the
    // input confirms, is where neither the crease fits nor the model describe the input (a corner of more faces
    // than the model saw: tripod's, four faces, three in the model, the sample 0.6 local spacings inside all
    // four): it is dropped, and the free samples cover its place.
    // (localSpacing with no floor: the mean distance to the 6 nearest input points.)
    // Near a band (a chamfer narrower than the fits) the two faces' line, where the crease fits put the
    // sample, is off the surface by construction: the sample moves onto the band however near.
    if ((bd > kOff * hl || band) && bd <= kMove * hl) {
      if (localSpacing(index, best, 0) < localSpacing(index, q, 0))
        out[i] = best;
      else
        drop[i] = bd > kOff * hl;
    }
  });
  return drop;
}

void addSheetCorners(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                     std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner, int threads) {
  constexpr double kReach = 4.0;  // steps: an end this far short of its corner
  constexpr int kMaxProbes = 8;   // sheet models on the way there
  struct End {
    std::size_t sample;
    Eigen::Vector3d direction;  // forward, off the end of the run
    double step;                // the run's median spacing
  };
  std::vector<End> ends;
  for (const auto& [a, b] : ownerRuns(owner)) {
    if (b == a) continue;
    std::vector<double> gaps;
    for (std::size_t t = a; t < b; ++t) gaps.push_back((out[t + 1] - out[t]).norm());
    std::nth_element(gaps.begin(), gaps.begin() + static_cast<long>(gaps.size() / 2), gaps.end());
    const double step = gaps[gaps.size() / 2];
    if (!(step > 0)) continue;
    // The direction from the first sample back at least half a step away (two samples at one spot say none).
    for (const auto& [end, inward] : {std::pair{a, 1L}, std::pair{b, -1L}}) {
      std::size_t back = end + inward;
      while (back != (inward > 0 ? b : a) && (out[back] - out[end]).norm() < 0.5 * step) back += inward;
      const Eigen::Vector3d d = out[end] - out[back];
      ends.push_back({end, d.norm() > 1e-9 * h ? d.normalized() : Eigen::Vector3d::Zero(), step});
    }
  }
  std::vector<Eigen::Vector3d> corner(ends.size());
  std::vector<char> found(ends.size(), 0);
  parallelFor(ends.size(), threads, [&](std::size_t e) {
    const Eigen::Vector3d q = out[ends[e].sample];
    const double hl = localSpacing(index, q, h), reach = kReach * ends[e].step;
    // The sheets at the end and on ahead of it, a local spacing at a time, until they show a corner.
    const int probes = std::min(kMaxProbes, static_cast<int>(reach / hl) + 1);
    for (int j = 0; j < probes && !found[e]; ++j) {
      const Eigen::Vector3d y = q + (j * hl) * ends[e].direction;
      std::vector<Sheet> sheets;
      bool band = false;
      if (!sheetsAround(cloud, index, y, hl, params, true, sheets, band) || band || sheets.size() < 3) continue;
      // The planes' common point (least squares), where their normals span space: a corner, not a fan of
      // faces around one line.
      Eigen::MatrixX3d a(sheets.size(), 3);
      Eigen::VectorXd o(sheets.size());
      for (std::size_t k = 0; k < sheets.size(); ++k) a.row(static_cast<long>(k)) = sheets[k].n, o(k) = sheets[k].o;
      const Eigen::JacobiSVD<Eigen::MatrixX3d> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
      if (svd.singularValues()(2) < 0.3) continue;
      const Eigen::Vector3d c = svd.solve(o);
      if ((c - q).norm() > reach) continue;
      if (offInput(cloud, index, c, h) > 1.5 * params.maxOffCrease) continue;  // off the surface
      corner[e] = c;
      found[e] = 1;
    }
  });
  // In end order: the corner, unless a sample lies within half a step of it (a corner placed already: that
  // sample stands for it); then, where the end's run leads into it, the gap between them filled on the straight
  // line at the run's step.
  const std::size_t given = out.size();
  const KnnIndex placed(out);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  auto sampleNear = [&](const Eigen::Vector3d& x, double r, Eigen::Vector3d* at) {
    double best = r;
    bool any = false;
    placed.radius(x, r, idx, d2);
    for (std::size_t k = 0; k < idx.size(); ++k)
      if (std::sqrt(d2[k]) < best) best = std::sqrt(d2[k]), any = true, *at = out[idx[k]];
    for (std::size_t t = given; t < out.size(); ++t)
      if ((out[t] - x).norm() < best) best = (out[t] - x).norm(), any = true, *at = out[t];
    return any;
  };
  const double cosTurn = std::cos(params.maxChainTurn * kDeg);
  for (std::size_t e = 0; e < ends.size(); ++e) {
    if (!found[e]) continue;
    const End& end = ends[e];
    const Eigen::Vector3d from = out[end.sample];
    const std::uint32_t chain = owner[end.sample];
    Eigen::Vector3d target = corner[e], other;
    const bool taken = sampleNear(target, 0.5 * end.step, &other);
    if (taken) target = other;
    const double gap = (target - from).norm();
    if (end.direction.dot(target - from) < cosTurn * gap) continue;  // the end's crease does not lead there
    if (!taken) out.push_back(target), owner.push_back(chain);
    if (gap < 1.5 * end.step) continue;
    const int pieces = static_cast<int>(std::ceil(gap / end.step - 0.25));
    for (int k = 1; k < pieces; ++k) {
      const Eigen::Vector3d x = from + (target - from) * (static_cast<double>(k) / pieces);
      if (sampleNear(x, 0.5 * end.step, &other)) break;  // something lies between: not this end's gap
      out.push_back(x), owner.push_back(chain);
    }
  }
}

}  // namespace iires::detail
