// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The pieces the feature pipeline's units share (detection, chains, crease tracing and snapping): the local
// two-plane crease fit and its helpers. Internal to libiires.

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <utility>
#include <vector>

#include "iires/features.hpp"
#include "iires/knn.hpp"
#include "iires/types.hpp"

namespace iires::detail {

constexpr double kDeg = M_PI / 180.0;
constexpr std::size_t kMaxFitPoints = 200;  // a snap fit uses at most this many input points, the nearest

/// The crease at a point: the intersection line of two fitted planes.
struct Crease {
  bool valid = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< the query point projected onto the line
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  Eigen::Vector3d normalA = Eigen::Vector3d::Zero(), normalB = Eigen::Vector3d::Zero();  ///< the two planes
  double offsetA = 0, offsetB = 0;                                                      ///< normal·x = offset
};

/// The spacing the fits at @p y work with: the global spacing @p h, or the local one (mean distance to the 6
/// nearest points) where the sampling is sparser, so a neighbourhood of `radius` spacings always holds about
/// the same number of points (non-uniform scans: a fixed radius leaves the sparse parts with too few).
double localSpacing(const KnnIndex& index, const Eigen::Vector3d& y, double h);

/// localSpacing()'s reading before its floor: the mean of the first 6 distances above 0 of a k-NN search's
/// squared distances @p d2 (nearest first); 0 if there are none.
double meanNearestDistance(const std::vector<double>& d2);

/// How far @p y lies off the input (@p cloud, indexed by @p index): its distance to the nearest input point over
/// the local spacing there, read at that input point (floor @p h). Read at y itself, the spacing grows with y's
/// distance from the input, and a point far off would still count as near.
double offInput(const PointCloud& cloud, const KnnIndex& index, const Eigen::Vector3d& y, double h);

/// Plane through the (weighted) centroid of @p pts (indices into @p points) by PCA; returns the (weighted) RMS
/// residual. @p sigma > 0: point q has weight exp(−|q − p|²/σ²); 0 = all weights 1.
double fitPlane(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
                const Eigen::Vector3d& p, double sigma, const Eigen::Vector3d& hint, Eigen::Vector3d& normal,
                double& offset);

/// The point of the line {x : na·x = oa, nb·x = ob} (unit normals) nearest @p p: x = p + α na + β nb.
Eigen::Vector3d lineNearest(const Eigen::Vector3d& na, double oa, const Eigen::Vector3d& nb, double ob,
                            const Eigen::Vector3d& p);

/// Two-plane fit of the neighbourhood @p nbr of the point @p p (the normal-variation test). Returns whether the
/// point is on a crease by the thresholds in @p prm; fills @p crease. @p sigma > 0: the plane fits weight each
/// point by exp(−d²/σ²), d its distance to p (local planes: less bias from curved sheets); 0 = unweighted.
bool twoPlaneTest(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                  const Eigen::Vector3d& p, const std::vector<std::uint32_t>& nbr, double h, const FeatureParams& prm,
                  Crease& crease, double sigma = 0);

/// The snap fit at @p y: twoPlaneTest() with thresholds @p prm on the input points within params.radius local
/// spacings @p hl of y (the kMaxFitPoints nearest) on a sheet through y (keepSheetsThrough), weighted at
/// params.snapSigma·hl; false as well where the crease's point lies over 1.5·maxOffCrease local spacings off the
/// input (offInput). @p idx keeps that neighbourhood for a caller that refits part of it; @p d2 is scratch.
bool snapFit(const PointCloud& cloud, const KnnIndex& index, const Eigen::Vector3d& y, double hl,
             const FeatureParams& params, const FeatureParams& prm, Crease& c, std::vector<std::uint32_t>& idx,
             std::vector<double>& d2);

/// The looser thresholds of the VCM detector's lines, for a snap fit where a chain already says a crease is:
/// any angle over 1°, twice the residual, half the cluster share.
FeatureParams looseParams(const FeatureParams& params);

/// The crease at @p y running along ±@p dir (within params.maxChainTurn): the snap fit, else two planes fitted
/// on the points behind y only (an end where the crease stops ahead, or another crease crowds the ball ahead),
/// its point on the input as snapFit()'s; @p oneSided says the second held. @p idx keeps the ball, @p d2 and
/// @p behind are scratch.
bool creaseAlong(const PointCloud& cloud, const KnnIndex& index, const Eigen::Vector3d& y,
                 const Eigen::Vector3d& dir, double hl, const FeatureParams& params, Crease& c,
                 std::vector<std::uint32_t>& idx, std::vector<double>& d2, std::vector<std::uint32_t>& behind,
                 bool& oneSided);

/// Each of @p idx to the nearest of three planes (n·x = o), if within @p tol of it: @p part[k] for plane k.
void partitionByPlanes(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& idx,
                       const Eigen::Vector3d (&n)[3], const double (&o)[3], double tol,
                       std::vector<std::uint32_t> (&part)[3]);

/// [first, last] of each run of consecutive samples with the same @p owner (one chain's samples), in order.
std::vector<std::pair<std::size_t, std::size_t>> ownerRuns(const std::vector<std::uint32_t>& owner);

/// Chains (paths of crease points, finished: fitted, trimmed, joined, extended to their corners) from the
/// feature points @p x0 with crease directions @p d0.
std::vector<FeatureChain> buildChains(const std::vector<Eigen::Vector3d>& x0,
                                      const std::vector<Eigen::Vector3d>& d0, double h, const FeatureParams& prm,
                                      int threads);

/// Continue every open run of chain samples (@p out, consecutive samples of one chain in @p owner) along its
/// crease: from the end sample, step forward by the run's end spacing, fit the two sheets' local planes there
/// (the snap fit) and put the next sample on their intersection, while the fit passes the detector's thresholds,
/// its crease runs along the run (within maxChainTurn) and the new sample is not within 0.75 steps of a sample
/// already placed (then the gap to another chain, or to the run's own other end, is bridged). Where the full
/// ball fails, the two sheets are fitted on the half-ball behind the prediction; if the points ahead that
/// neither plane explains fit a third plane, the crease ends at a corner on it: the gap to the corner is filled,
/// a corner sample placed, and the corner's two other creases (the third plane's intersections with the two
/// sheets, on the side where each sheet lies) are followed as new runs: along the known planes while the points
/// around stay explained by them and both planes' sheets have input points just ahead (a sheet that ends, as a
/// short crease's, leaves the line off the surface), handing over to the stepped fit once it holds. Fills the
/// stretches of a crease the detector missed, brings the ends into their corners and recovers short creases
/// between corners.
/// A trace stops where its next sample would lie over 2·maxOffCrease local spacings off the input (offInput): a
/// line followed past the input's end. New runs get chain indices after the existing ones. Sequential in a
/// fixed order (each trace sees the samples placed before it): deterministic.
void traceChainEnds(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                    std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner);

/// Step 3b of snapToCreases(): tips. Two creases that share a sheet and run into one point at a small angle
/// (8°–maxChainTurn; a step in a surface fading out, as fandisk's wedge at (0.072 0.035 −0.046), 18°) end
/// there without a third crease. Within a few spacings of the tip both creases lie in every fit's
/// neighbourhood, so the traces stop about a neighbourhood apart, and step 4's end lines (through the last
/// two samples, bent by the other crease) meet short of the tip. Here each open end's crease is the last fit
/// that holds at the end sample or up to 3 samples back (the full ball, else the half-ball behind), its
/// planes refitted without the points off both (refitPlanesRobust: the other crease's far sheet). Two ends
/// whose lines converge, share a plane (each end within maxLineDistance of one of the other's planes) and
/// meet (within half a spacing) ahead of both (within 6·radius local spacings) have their tip there, refined
/// as the common point of the shared plane and the two other sheets' planes refitted (Gaussian-weighted) on
/// the points around it, up to 4 times while a refit moves it by 0.1–1 spacing. Both ends are continued to
/// the tip on the straight line at their step (the second one's samples within half a step of the first's
/// left out, close to the tip) unless a placed sample lies on the way (within half a step: another crease
/// between them) or the tip or a sample on the way is farther than maxOffCrease local spacings from the input (a
/// line cutting across a bend of a curved crease, or a hole in the scan). The samples are inserted after their
/// ends, so the runs end at the tip and step 4 adds no corner there. Ends are paired greedily in order:
/// deterministic.
void placeCreaseTips(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                     std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner);

/// Step 5 of snapToCreases(): fill the gaps the tracing and the corners leave between neighbouring samples.
/// Two samples a, b more than 1.5 × the chains' median spacing (`step`) and at most @p maxGap steps apart, with
/// no other sample within 0.45 × their distance of their midpoint and half a step of the line a–b (nothing lies
/// between them), get samples at ≤ step on the crease between them, each
///  - at the snap fit's crease point near its chord point (the fitted crease running along a→b within
///    maxChainTurn, its point within 0.3 step of the chord), else
///  - on the fitted crease line of a or b where that line runs along a→b and passes within 0.1 step of the
///    chord point, else
///  - on the chord itself where the creases of a and b run on in line through them: a sample of a's own chain
///    0.5–1.6 steps behind a (and one of b's behind b) lies within 20° (or 0.15 step) of the line a–b (both for
///    gaps over 4.5 steps; one of them suffices for shorter ones, as next to a corner, where the corner sample
///    has no neighbour in line). Another chain's sample in line proves nothing: where creases crowd (a faceted
///    arc beside other creases, couplingdown) one may lie in line by chance while a's crease bends away, and
///    the chord then cuts across the bend, up to 0.9 output spacings off the surface.
///    This fills the holes where no two-plane fit holds (a plane beside a small-radius cylinder, a corner's
///    neighbourhood), which the tracing cannot step through.
/// A gap where one new sample has none of these is left open (two creases meeting, not one). Each new sample
/// lies within 1.5·maxOffCrease (local) spacings of an input point (an edge point of a random sampling may have
/// none within one spacing). In sample order, each gap seeing the samples added before it (the fills are found
/// on @p threads threads, the gaps then taken in order): deterministic for any thread count. The new samples are
/// appended, owned by a's chain.
void fillCreaseGaps(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                    std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner, double maxGap = 6.0,
                    int threads = 1);

/// Step 6b of snapToCreases(): each held sample in @p out that lies off the surface moves onto it. The input
/// points within params.radius local spacings of the sample (at least the 40 nearest) are modelled as one, two
/// or three planar sheets (a face, a crease, a corner or a band): the input normals clustered (a third sheet
/// where a normal leaves the plane of the first two by the detector's angle, or lies between them by that angle
/// from both: a chamfer or small fillet narrower than the fits, where no input point lies within 0.2 local
/// spacings of the first two's line; where three do not fit, two), a plane
/// fitted to each cluster and the points reassigned to the nearest plane; the model holds where each plane fits
/// within maxResidual and 90 % of the points lie within 3·maxResidual of one. Where none holds (a corner where
/// more faces meet, or whose faces are too small in those points), the 80 nearest points are modelled as the
/// three to five planes found greedily in them (the tangent plane explaining most points not yet explained).
/// Each sheet covers the cells of its plane, cut by the lines where it meets the other sheets, that its points
/// within the radius lie in (a half-plane at a crease, a wedge at a corner, a band's strip). A sample
/// farther than 0.3 local spacings from every sheet, or any distance where the model has a band (the two faces'
/// line, where the crease fits put samples, is then off the surface), moves to the nearest point of them (a
/// crease line or corner where that is nearest) if that is at most 2 local spacings away and nearer the input
/// (the mean distance to the 6 nearest input points drops). Returns which samples to drop: those off every
/// crease (where no model, or only one sheet, fits and two planes fitted there, the snap fit with loose
/// thresholds, meet under the crease angle) and those over 0.3 local spacings off the model whose move the input
/// does not confirm.
/// Deterministic, in parallel over the samples.
std::vector<char> ontoSheets(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                             std::vector<Eigen::Vector3d>& out, int threads);

/// The samples of @p out (and their entries of @p owner) that @p drop flags removed, the others kept in order.
void dropSamples(const std::vector<char>& drop, std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner);

/// Step 4a of snapToCreases(): corners of up to five faces. At each end of a run of chain samples in @p out
/// (consecutive samples of one chain in @p owner), and on ahead of it a local spacing at a time (up to 8 times),
/// the input is modelled as planar sheets (the three to five planes found greedily first, then as ontoSheets()
/// does) until three or more fit with normals that span space (a corner, not a fan of faces around one line).
/// Their common point (least squares), if within 4 of the run's steps of the end, within 1.5·maxOffCrease
/// local spacings of an input point (offInput, as step 4's corners) and where the end's run leads (within
/// maxChainTurn), gets a corner sample
/// owned by the end's chain, unless a sample lies within half a step of it (a corner placed already, which then
/// stands for it); the gap from the end to the corner is filled on the straight line at the run's step.
/// Deterministic: the models in parallel, the samples added in end order.
void addSheetCorners(const PointCloud& cloud, const KnnIndex& index, double h, const FeatureParams& params,
                     std::vector<Eigen::Vector3d>& out, std::vector<std::uint32_t>& owner, int threads);

}  // namespace iires::detail
