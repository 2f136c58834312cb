// SPDX-License-Identifier: GPL-3.0-or-later
// snapToCreases(): feature samples moved exactly onto their creases (the steps; curved sheets and corners here,
// tracing in crease_trace.cpp, tips in crease_tips.cpp, gaps in crease_gaps.cpp, sheets in crease_surface.cpp).
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
#include "iires/detail/parallel.hpp"


namespace iires {
using namespace detail;
namespace {

/// A sheet keeps the bend across its crease where that leaves under this share of the residual without it.
constexpr double kAcrossGain = 0.45;

/// A sheet curving along a crease, as a height field over its plane: the points x with n·(x − o) = h(u, v),
/// (u, v) = (e1·(x − o), e2·(x − o)), e1 along the crease, h = c0 + c1 u + c2 v + c3 u² + c4 v². The bend along
/// the crease (a cylinder meeting a plate at its foot) is always fitted; the bend across it (a blade's faces
/// rounding into its edge) only where it explains the points far better (fitAcross()): on a flat face with
/// noise it would bend onto the noise next to the crease.
struct CreaseSheet {
  using Coefficients = Eigen::Matrix<double, 5, 1>;
  Eigen::Vector3d o, e1, e2, n;
  Coefficients c = Coefficients::Zero();
  /// n·(x − o) − h(u, v) (about the signed distance near the sheet) and, if @p grad, its gradient.
  double value(const Eigen::Vector3d& x, Eigen::Vector3d* grad = nullptr) const {
    const Eigen::Vector3d d = x - o;
    const double u = e1.dot(d), v = e2.dot(d);
    if (grad) *grad = n - (c(1) + 2 * c(3) * u) * e1 - (c(2) + 2 * c(4) * v) * e2;
    return n.dot(d) - (c(0) + c(1) * u + c(2) * v + c(3) * u * u + c(4) * v * v);
  }
  /// Fitted by least squares to @p idx, idx[t] weighted rw[t]·exp(−|idx[t] − o|²/σ²), with the first @p terms
  /// of h (4: no bend across); returns the weighted RMS residual (infinity with fewer than 10 points).
  double fit(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
             const std::vector<double>& rw, double sigma, int terms = 4) {
    if (idx.size() < 10) return std::numeric_limits<double>::infinity();
    Eigen::Matrix<double, 5, 5> ata = Eigen::Matrix<double, 5, 5>::Zero();
    Coefficients atb = Coefficients::Zero();
    std::vector<double> w(idx.size());
    for (std::size_t t = 0; t < idx.size(); ++t) {
      const Eigen::Vector3d d = points[idx[t]] - o;
      w[t] = rw[t] * std::exp(-d.squaredNorm() / (sigma * sigma));
      const double u = e1.dot(d) / sigma, v = e2.dot(d) / sigma;  // in units of σ: well conditioned
      const Coefficients a = (Coefficients() << 1, u, v, u * u, v * v).finished();
      ata += w[t] * a * a.transpose();
      atb += w[t] * a * n.dot(d);
    }
    c.setZero();
    c.head(terms) = ata.topLeftCorner(terms, terms).ldlt().solve(atb.head(terms));
    c = c.cwiseQuotient((Coefficients() << 1, sigma, sigma, sigma * sigma, sigma * sigma).finished());
    if (!c.allFinite()) return std::numeric_limits<double>::infinity();
    double r2 = 0, sum = 0;
    for (std::size_t t = 0; t < idx.size(); ++t) r2 += w[t] * std::pow(value(points[idx[t]]), 2), sum += w[t];
    return std::sqrt(r2 / sum);
  }
  /// fit() with the bend across the crease where it leaves under kAcrossGain of the residual without it.
  double fitAcross(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
                   const std::vector<double>& rw, double sigma) {
    const double flat = fit(points, idx, rw, sigma, 4);
    const Coefficients along = c;
    const double bent = fit(points, idx, rw, sigma, 5);
    if (bent < kAcrossGain * flat) return bent;
    c = along;
    return flat;
  }
};

constexpr std::size_t kSheetFitPoints = 40;  // the curved sheets are fitted on this many nearest points

/// The crease point near @p c.point on the intersection of its two sheets fitted as CreaseSheets (over the
/// planes of @p c, bending along c.direction): a plane fitted to a sheet that curves along the crease lies off
/// it, and so does the planes' line. The kSheetFitPoints input points nearest c.point, Gaussian weights of
/// width 0.6 × their radius; four rounds of: each point to the sheet it is nearer to (the planes, then the
/// fitted sheets), left out beyond 3·maxResidual local spacings @p hl of both and weighted 1/(1 + (d/τ)²),
/// τ = maxResidual·hl, by its distance d (a third sheet's points, stray points); then Gauss-Newton from
/// c.point onto both sheets. Returns false where a sheet keeps under 10 points, the last round leaves out 10 %
/// of the points or more (a third sheet: a corner) or its fits leave a residual over maxResidual·hl.
bool curvedCreasePoint(const PointCloud& cloud, const KnnIndex& index, double hl, const FeatureParams& prm,
                       const Crease& c, Eigen::Vector3d& x) {
  std::vector<std::uint32_t> nbr;
  std::vector<double> d2;
  const Eigen::Vector3d x0 = c.point;
  if (index.knn(x0, kSheetFitPoints, nbr, d2) < kSheetFitPoints) return false;
  const double sigma = 0.6 * std::sqrt(d2.back());
  CreaseSheet sheet[2];
  const Eigen::Vector3d normal[2] = {c.normalA, c.normalB};
  const double offset[2] = {c.offsetA, c.offsetB};
  for (int s = 0; s < 2; ++s) {  // start: the planes
    CreaseSheet& q = sheet[s];
    q.o = x0, q.n = normal[s];
    q.e1 = (c.direction - q.n * q.n.dot(c.direction)).normalized();
    q.e2 = q.n.cross(q.e1);
    q.c(0) = offset[s] - q.n.dot(x0);
  }
  std::vector<std::uint32_t> part[2];
  std::vector<double> rw[2];
  const double tau = prm.maxResidual * hl;
  for (int it = 0; it < 4; ++it) {
    for (int s = 0; s < 2; ++s) part[s].clear(), rw[s].clear();
    for (std::uint32_t j : nbr) {
      const double da = std::abs(sheet[0].value(cloud.points[j])), db = std::abs(sheet[1].value(cloud.points[j]));
      const double d = std::min(da, db);
      if (d > 3.0 * tau) continue;
      const int s = da <= db ? 0 : 1;
      part[s].push_back(j);
      rw[s].push_back(1.0 / (1.0 + (d / tau) * (d / tau)));
    }
    if (it == 3 && 10 * (part[0].size() + part[1].size()) < 9 * nbr.size()) return false;  // a third sheet
    for (int s = 0; s < 2; ++s) {
      const double r = sheet[s].fitAcross(cloud.points, part[s], rw[s], sigma);
      if (!std::isfinite(r) || (it == 3 && r > tau)) return false;
    }
  }
  x = x0;
  for (int it = 0; it < 10; ++it) {  // the minimum-norm step onto both: x ← x − Jᵀ(JJᵀ)⁻¹f
    Eigen::Matrix<double, 2, 3> j;
    Eigen::Vector2d f;
    for (int s = 0; s < 2; ++s) {
      Eigen::Vector3d g;
      f(s) = sheet[s].value(x, &g);
      j.row(s) = g.transpose();
    }
    const Eigen::Vector3d dx = -j.transpose() * (j * j.transpose()).inverse() * f;
    if (!dx.allFinite()) return false;
    x += dx;
    if (dx.norm() < 1e-9 * hl) break;
  }
  return true;
}

/// Step 6 of snapToCreases(): each sample where the snap fit with the loose thresholds (looseParams; a sample
/// the tracing placed where the strict fit fails) puts the planes' line within maxLineDistance/2 local spacings
/// of it (the planes describe the crease the sample is on, not a corner or another crease near it) moves onto
/// the two sheets' curved crease (curvedCreasePoint), where that lies within maxLineDistance local spacings.
/// Each sample on its own: deterministic, in parallel.
void refineOnCurvedSheets(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                          std::vector<Eigen::Vector3d>& out, int threads) {
  const FeatureParams loose = looseParams(params);
  parallelFor(out.size(), threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    const double hl = localSpacing(index, out[i], h);
    Crease c;
    Eigen::Vector3d x;
    if (snapFit(cloud, index, out[i], hl, params, loose, c, idx, d2) &&
        (c.point - out[i]).norm() <= 0.5 * params.maxLineDistance * hl &&
        curvedCreasePoint(cloud, index, hl, params, c, x) && (x - out[i]).norm() <= params.maxLineDistance * hl)
      out[i] = x;
  });
}




/// Step 3 of snapToCreases(): corners. Two chain ends whose crease lines, continued forward, meet within a few
/// spacings of both get a sample where they meet (the end samples of chains stop short of a corner, where the
/// two-plane fit fails), and the gaps to it samples at the chains' spacing.
void addCorners(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) {
  struct End {
    Eigen::Vector3d point, direction;  // direction: forward, off the end of the chain
    double step;                       // the chain's sample spacing there
    std::uint32_t chain;
    bool filled;                       // already linked to a corner
  };
  std::vector<End> ends;
  for (const auto& [a, b] : ownerRuns(owner))
    if (b > a) {
      ends.push_back({out[a], (out[a] - out[a + 1]).normalized(), (out[a] - out[a + 1]).norm(), owner[a], false});
      ends.push_back({out[b], (out[b] - out[b - 1]).normalized(), (out[b] - out[b - 1]).norm(), owner[a], false});
    }
  const double reach = 3.0 * params.radius * h;
  std::vector<Eigen::Vector3d> corners, cornerPoints;  // all added samples; the corners alone
  std::vector<std::uint32_t> cornerOwner;
  // The gap between a chain end and its corner gets samples at the chain's spacing, on the straight line.
  auto fill = [&](End& e, const Eigen::Vector3d& corner) {
    if (e.filled) return;
    e.filled = true;
    const double gap = (corner - e.point).norm();
    const int pieces = static_cast<int>(std::ceil(gap / std::max(e.step, 1e-300) - 0.25));
    for (int k = 1; k < pieces; ++k) {
      corners.push_back(e.point + (corner - e.point) * (static_cast<double>(k) / pieces));
      cornerOwner.push_back(e.chain);
    }
  };
  for (std::size_t a = 0; a < ends.size(); ++a)
    for (std::size_t b = a + 1; b < ends.size(); ++b) {
      End &ea = ends[a], &eb = ends[b];
      if (ea.chain == eb.chain || (ea.point - eb.point).norm() > reach) continue;
      // Closest points of the two lines: ea.point + s·da and eb.point + t·db.
      const double c = ea.direction.dot(eb.direction);
      if (1.0 - c * c < 0.05) continue;  // nearly parallel (under 13°): no corner between them
      const Eigen::Vector3d w = ea.point - eb.point;
      const double d = ea.direction.dot(w), e = eb.direction.dot(w);
      const double sa = (c * e - d) / (1.0 - c * c), tb = (e - c * d) / (1.0 - c * c);
      if (sa < -0.5 * h || tb < -0.5 * h || sa > reach || tb > reach) continue;
      const Eigen::Vector3d pa = ea.point + sa * ea.direction, pb = eb.point + tb * eb.direction;
      if ((pa - pb).norm() > 0.5 * h) continue;  // the two lines must (nearly) meet
      Eigen::Vector3d corner = 0.5 * (pa + pb);
      if (offInput(cloud, index, corner, h) > 1.5 * params.maxOffCrease) continue;  // off the surface
      // A corner the tracing already placed (or any sample there): nothing to add.
      bool taken = false;
      for (const auto& q : out)
        if ((q - corner).norm() < 0.5 * std::min(ea.step, eb.step)) taken = true;
      if (taken) continue;
      bool dup = false;
      for (const auto& q : cornerPoints)
        if ((q - corner).norm() < h) dup = true, corner = q;
      if (!dup) {
        cornerPoints.push_back(corner);
        corners.push_back(corner);
        cornerOwner.push_back(ea.chain);
      }
      fill(ea, corner);
      fill(eb, corner);
    }
  owner.insert(owner.end(), cornerOwner.begin(), cornerOwner.end());
  out.insert(out.end(), corners.begin(), corners.end());
}

/// Step 8 of snapToCreases(): the gaps left next to the samples that steps 5–7 placed or moved, filled as in
/// step 5, the new samples moved onto curved sheets' creases as in step 6 and onto the surface as in 6b (a
/// chord from a sample that 6b moved into a corner can cut across a face beside it). Step 5 sees only the gaps
/// between the samples it started with: its own samples (a gap filled up to a point short of a corner), the
/// moves of 6 and 6b (a corner sample placed off its corner and moved onto it) and the separation of 7 each
/// leave a gap of about two steps. Longer gaps were there at step 5, which left them open (no fit holds and the
/// chains do not run on in line: a bend, two creases meeting), and stay open.
void refillGaps(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner, int threads) {
  constexpr double kOpenedGap = 2.5;  // steps: the longest gap a new, moved or dropped sample leaves
  const std::size_t settled = out.size();
  fillCreaseGaps(cloud, index, h, params, out, owner, kOpenedGap, threads);
  if (out.size() == settled) return;
  std::vector<Eigen::Vector3d> added(out.begin() + static_cast<long>(settled), out.end());
  std::vector<std::uint32_t> addedOwner(owner.begin() + static_cast<long>(settled), owner.end());
  refineOnCurvedSheets(cloud, index, h, params, added, threads);
  dropSamples(ontoSheets(cloud, index, h, params, added, threads), added, addedOwner);
  out.resize(settled);
  owner.resize(settled);
  out.insert(out.end(), added.begin(), added.end());
  owner.insert(owner.end(), addedOwner.begin(), addedOwner.end());
}

/// Steps 4b and 7 of snapToCreases(): the held samples closer than half the chains' median step to an earlier one are
/// dropped (in sample order: the chains' samples before the traced ones, tips and corners). Several samples may
/// land on one spot — jumps onto the same crease, chain ends meeting at a corner, a chain doubling back under
/// noise — and a pile of held samples leaves its stretch of crease short of samples that the gap filling
/// restores only once the pile is gone.
void separateSamples(double h, std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner) {
  std::vector<double> steps;
  for (std::size_t t = 1; t < out.size(); ++t)
    if (owner[t] == owner[t - 1]) steps.push_back((out[t] - out[t - 1]).norm());
  if (steps.empty()) return;
  std::nth_element(steps.begin(), steps.begin() + static_cast<long>(steps.size() / 2), steps.end());
  const double reach = 0.5 * steps[steps.size() / 2];
  if (!(reach > 1e-9 * h)) return;
  const KnnIndex index(out);
  std::vector<char> keep(out.size(), 1);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (std::size_t i = 0; i < out.size(); ++i) {
    index.radius(out[i], reach, idx, d2);
    for (std::uint32_t j : idx)
      if (j < i && keep[j]) {
        keep[i] = 0;
        break;
      }
  }
  std::size_t m = 0;
  for (std::size_t i = 0; i < out.size(); ++i)
    if (keep[i]) out[m] = out[i], owner[m] = owner[i], ++m;
  out.resize(m);
  owner.resize(m);
}

}  // namespace

// The steps of snapToCreases():
//  1. At each sample x, the neighbours within params.radius spacings are split into two sheets as in the
//     normal-variation test, a plane is fitted to each with weights exp(−d²/σ²) (d the distance to x, σ =
//     params.snapSigma spacings: local planes, so curved sheets bias the line less than the detector's
//     unweighted fit), and x moves to the nearest point of the two planes' intersection; once more from there.
//     Where no crease lies within maxLineDistance, x may jump to one up to 0.8·radius away that runs along
//     its chain (within maxChainTurn); failing that, a looser fit (any angle, 2× residual, half the cluster
//     share) may correct it by at most h/4.
//  2. A sample where that fit fails the detector's thresholds goes onto the chord between the nearest fitted
//     samples of its chain (at most 3 away on each side) if the chord's sagitta, L·θ/8 (θ the turn between the
//     two fits' crease directions), is below maxResidual spacings; otherwise it is dropped (a chain end
//     extended past the feature would sit off the surface; a chord across a bend would cut inside it).
//  3. Tracing: each chain's samples are split where samples were dropped (gaps over 1.6 × the chain's median
//     spacing), and every piece's ends (a lone sample: both ways along its own crease) are continued along the
//     crease: step one spacing along the last crease direction, fit the two sheets there (the snap fit; on the
//     half-ball behind the prediction where the full ball fails), place the sample one step on along the fitted
//     line; stop where the fit fails (over one or two failed steps the trace may resume), where the fit lands
//     more than half a step (+ h/4) off the prediction, or where a sample is already within 0.75 steps (the gap
//     is bridged). Near a corner the points ahead that neither plane explains (3·maxResidual off both, a normal
//     unlike both) fit a third plane: the corner is the three planes' intersection (refined by reassigning the
//     points around it to the nearest plane, twice), the gap to it is filled, and the corner's two other creases
//     (the third plane with each sheet, on the side where the sheet lies) are followed along those planes while
//     the points around stay explained by them and both sheets have points just ahead, handing over to the
//     stepped fit once it holds. Traced branches get chain indices after the given ones. Sequential in a fixed
//     order: deterministic.
//  3b. Tips: two open ends whose crease lines (each the last fit that holds within 3 samples of the end,
//     its planes refitted without the points off both) share a plane and converge at 8°–maxChainTurn,
//     meeting ahead of both within 6·radius spacings, are continued on those lines to the tip: the common
//     point of the shared plane and the two other sheets' planes, refitted on the points around it (a step
//     in a surface fading out, as fandisk's wedge: two creases end at one point without a third crease).
//  4. Where two chains' end lines (at least 13° apart), continued, meet within 3·radius spacings of both ends and within
//     1.5·params.maxOffCrease local spacings of an input point (offInput: the nearest input point is farther
//     from a convex corner than from an edge), and no sample is
//     within half a spacing of it (tracing placed most corners already), a corner sample is added there, and
//     the gap from each of those chain ends to the corner gets samples at the chain's spacing on the straight
//     line.
//  4a. Corners of up to five faces: where the sheets at a chain end, or a little ahead of it, are three or more
//     planes meeting at a point the end's crease leads to, a corner sample there and the gap to it filled
//     (addSheetCorners).
//  4b. Separation: a sample closer than half the chains' median step to an earlier one is dropped (separateSamples).
//  5. Gaps: two samples 1.5–6 × the chains' median spacing apart with no sample between them (within 0.45 × their
//     distance of the midpoint and half a spacing of their line) get samples at ≤ that spacing between them: on
//     the snap fit's crease where it runs along them and near their chord, else on the fitted crease line of
//     either, else on the chord where the chains on either side run on in line with it (a sample of the end's own
//     chain within 20°; one side suffices up to 4.5 spacings); a gap where none holds (two creases meeting)
//     stays open.
//  6. Curved sheets: a plane fitted to a sheet that curves along the crease (a plate meeting a cylinder) lies
//     off it, and so does the planes' line. Every sample whose looser snap fit (as in 1) puts the planes'
//     line within maxLineDistance/2 local spacings of it moves to the crease of the two sheets fitted as
//     height fields over those planes, bending along the crease (h = c0 + c1·u + c2·v + c3·u², u along it),
//     on the 40 nearest input points (each to the nearer sheet; points over 3·maxResidual off both left out,
//     the others weighted down by their distance), if both fit within maxResidual, under 10 % of the points
//     are left out (more: a third sheet, as at a corner) and the move is at most maxLineDistance local spacings.
//  6b. Off the surface: a sample that the steps above left off it (a chord across a bend, a line followed past
//     the end of a sheet, a biased fit next to a corner) moves onto the input's sheets around it, modelled as
//     planes (a face, a crease, a band, a corner of up to five faces), each bounded by the lines where it meets the
//     others (ontoSheets). Dropped: a sample where no such model, or only one sheet, fits and two planes
//     fitted there meet under the crease angle (off every crease: its chain ran on along a curved or finely
//     faceted surface), and one the model puts off the surface whose move onto it the input does not confirm.
//  7. Separation once more (steps 6 and 6b moved samples).
//  8. Gaps once more, as in 5, up to 2.5 steps long: step 5's own samples, the moves of 6 and 6b (a corner
//     sample placed off its corner and moved onto it) and the separation of 7 may leave a gap of about two
//     steps next to them. The new samples go through steps 6 and 6b (refillGaps).
std::vector<Eigen::Vector3d> snapToCreases(const PointCloud& cloud, const std::vector<Eigen::Vector3d>& samples,
                                           const std::vector<std::uint32_t>& chainOfSample, double spacing,
                                           const FeatureParams& params, const Execution& exec,
                                           std::vector<std::uint32_t>* chainOut) {
  params.validate();
  if (!(spacing > 0)) throw std::invalid_argument("snapToCreases: spacing must be > 0");
  if (!cloud.hasNormals()) throw std::invalid_argument("snapToCreases: the cloud needs one normal per point");
  if (chainOfSample.size() != samples.size())
    throw std::invalid_argument("snapToCreases: one chain index per sample is needed");
  const double h = spacing;
  const std::size_t n = samples.size();
  const KnnIndex index(cloud.points);
  // 1. Each sample onto the intersection of its two sheets' local planes (the detector's thresholds).
  std::vector<Eigen::Vector3d> moved(samples);
  std::vector<char> good(n, 0);
  std::vector<Eigen::Vector3d> creaseDir(n, Eigen::Vector3d::Zero());  // of the fit that placed each good sample
  parallelFor(n, exec.threads, [&](std::size_t i) {
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    // A chain may run beside its crease (its points come from the detector's unweighted fits): when the crease
    // is not within maxLineDistance, the sample may jump to it from up to 0.8·radius away.
    FeatureParams far = params;
    far.maxLineDistance = std::max(params.maxLineDistance, 0.8 * params.radius);
    const std::size_t before = i > 0 && chainOfSample[i - 1] == chainOfSample[i] ? i - 1 : i;
    const std::size_t after = i + 1 < n && chainOfSample[i + 1] == chainOfSample[i] ? i + 1 : i;
    Eigen::Vector3d along = samples[after] - samples[before];
    if (along.norm() > 0) along.normalize();  // stays 0 for a lone sample: no jump then
    bool onCrease = false;
    const double hl = localSpacing(index, samples[i], h);
    for (const FeatureParams* prm : {&params, static_cast<const FeatureParams*>(&far)}) {
      moved[i] = samples[i];
      onCrease = true;
      for (int it = 0; it < 2 && onCrease; ++it) {  // re-centred once: the second fit is centred on the crease
        Crease c;
        onCrease = snapFit(cloud, index, moved[i], hl, params, it == 0 ? *prm : params, c, idx, d2);
        // A jump must land on a crease running along the chain (not on another crease meeting it at a corner).
        if (onCrease && prm == &far && std::abs(c.direction.dot(along)) < std::cos(params.maxChainTurn * kDeg))
          onCrease = false;
        if (onCrease) moved[i] = c.point, creaseDir[i] = c.direction;
      }
      if (onCrease) break;
    }
    if (!onCrease) moved[i] = samples[i];
    good[i] = onCrease ? 1 : 0;
    if (onCrease) return;
    // The looser thresholds of the VCM detector's lines (the chain already says a crease is here), trusted
    // only for a small correction: a sample extended past the feature would be pulled far.
    Crease c;
    if (snapFit(cloud, index, samples[i], hl, params, looseParams(params), c, idx, d2) &&
        (c.point - samples[i]).norm() <= 0.25 * hl) {
      moved[i] = c.point;
      creaseDir[i] = c.direction;
      good[i] = 1;
    }
  });
  // 2. A sample where no crease fits but whose chain neighbours (≤ 3 samples either way) do goes onto the
  // chord between them; the others (chain ends past the feature, corners where three sheets meet) are dropped.
  std::vector<char> keep(good);
  for (std::size_t i = 0; i < n; ++i) {
    if (good[i]) continue;
    std::size_t prev = n, next = n;
    for (std::size_t j = i; j-- > 0 && i - j <= 3 && chainOfSample[j] == chainOfSample[i];)
      if (good[j]) {
        prev = j;
        break;
      }
    for (std::size_t j = i + 1; j < n && j - i <= 3 && chainOfSample[j] == chainOfSample[i]; ++j)
      if (good[j]) {
        next = j;
        break;
      }
    if (prev == n || next == n) continue;
    const Eigen::Vector3d ab = moved[next] - moved[prev];
    // On a curved crease the chord cuts inside: its sagitta ≈ L·θ/8 (θ the turn between the two ends' crease
    // directions) must stay below the detector's residual bound.
    const double cosTurn = std::min(1.0, std::abs(creaseDir[prev].dot(creaseDir[next])));
    if (ab.norm() * std::acos(cosTurn) / 8.0 > params.maxResidual * h) continue;
    const double t = std::clamp((samples[i] - moved[prev]).dot(ab) / std::max(ab.squaredNorm(), 1e-300), 0.0, 1.0);
    const Eigen::Vector3d onChord = moved[prev] + t * ab;
    if ((onChord - samples[i]).norm() > params.maxLineDistance * h) continue;  // the neighbours disagree
    moved[i] = onChord;
    keep[i] = 1;
  }
  std::vector<Eigen::Vector3d> out;
  std::vector<std::uint32_t> owner;
  for (std::size_t i = 0; i < n; ++i)
    if (keep[i]) out.push_back(moved[i]), owner.push_back(chainOfSample[i]);
  traceChainEnds(cloud, index, h, params, out, owner);
  placeCreaseTips(cloud, index, h, params, out, owner);
  addCorners(cloud, index, h, params, out, owner);  // 4.
  addSheetCorners(cloud, index, h, params, out, owner, exec.threads);  // 4a.
  separateSamples(h, out, owner);
  fillCreaseGaps(cloud, index, h, params, out, owner, 6.0, exec.threads);
  refineOnCurvedSheets(cloud, index, h, params, out, exec.threads);
  dropSamples(ontoSheets(cloud, index, h, params, out, exec.threads), out, owner);  // 6b.
  separateSamples(h, out, owner);
  refillGaps(cloud, index, h, params, out, owner, exec.threads);  // 8.
  if (chainOut) *chainOut = std::move(owner);
  return out;
}

}  // namespace iires
