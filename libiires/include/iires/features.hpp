// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file features.hpp
/// @brief Sharp-feature detection, feature polylines and their samples (DESIGN §3 step 9): the samples
/// become the resampler's fixed samples (ResampleParams::fixedSamples), so CAD creases stay crisp.
///
/// Two detectors, both on a cloud with oriented normals:
/// Lengths in spacings use the local spacing where the sampling is sparser than h (the mean distance to the 6
/// nearest points, when larger than h), so every neighbourhood holds about as many points on a non-uniform scan.
///  - FeatureDetector::NormalVariation (default): the neighbours within `radius` spacings are split into two
///    clusters by their normals (2-means), a plane is fitted to each cluster's positions (refined by
///    reassigning points to the nearer plane), and the point is a feature point when the planes meet at
///    ≥ `angle` degrees, both fit well (RMS residual ≤ `maxResidual` spacings) and the point lies within
///    `maxLineDistance` spacings of their intersection line (the crease).
///  - FeatureDetector::Vcm: the Voronoi covariance measure (Mérigot, Ovsjanikov, Guibas 2011) as CGAL's
///    compute_vcm + vcm_is_on_feature_edge: covariance of each point's Voronoi cell clipped by a ball of
///    radius `vcmOffset`, summed over `vcmConvolution`, feature when λ_mid/(λ0+λ1+λ2) ≥ `vcmThreshold`.
/// Measured on fandisk, joint and anchor (100k points by sampleMesh, PCA+MST normals, reference = mesh edges
/// with dihedral angle > 45°; precision: detections within 1.5 h of an edge, recall: points within 0.5 h
/// detected; `IIRES_COMPARE_DETECTORS=1 features_test --gtest_filter='Cad*'`), raw detector / after chaining:
///   fandisk  NV P .975 R .940 / P .974 R .983   VCM P .813 R .979 / P .999 R .986
///   joint    NV P .998 R .950 / P .991 R .953   VCM P .814 R .994 / P .999 R .981
///   anchor   NV P .974 R .960 / P .961 R .883   VCM P .808 R .976 / P .989 R .948
/// (NV re-measured with the local spacing; VCM from before it.)
/// and NV takes ~0.9 s per model on 2 cores, VCM ~15 s. NV is the default: better raw precision and F-score,
/// 15× faster (the resampler's budget is ~1 s for 100k points); VCM gives cleaner chains where time allows.
///
/// Chains: the detected points with a valid crease are projected onto it, linked into a minimum spanning
/// forest (edges ≤ `chainRadius` spacings, crease directions compatible), and each tree is peeled into
/// longest paths; paths shorter than `minChainLength` spacings (spurs, isolated detections) are dropped.
/// sampleFeatureChains() places samples along the chains at a fixed arc-length spacing, on the crease;
/// snapToCreases() then moves each onto its two sheets' local plane intersection (or drops it where it would sit
/// off the surface), traces the chains' ends along their creases into the corners (and the corners' other
/// creases) and adds corner samples — the samples the resampler holds with `--sharp-edges`.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "iires/types.hpp"

namespace iires {

/// @brief Which sharp-feature test detectFeatures() uses.
enum class FeatureDetector {
  NormalVariation,  ///< two-plane split of the neighbours' normals (default: see the measurements above)
  Vcm,              ///< Voronoi covariance measure, as CGAL's vcm_is_on_feature_edge
};

/// @brief Parameters of detectFeatures(). Lengths are in units of the input spacing h (see `spacing`).
struct FeatureParams {
  FeatureDetector detector = FeatureDetector::NormalVariation;  ///< see FeatureDetector
  /// Input spacing h, absolute units; 0 = estimate it as the median over points of the mean distance to the
  /// 6 nearest neighbours (≈ 1/√density; the lattice spacing of a regular sampling).
  double spacing = 0.0;
  double radius = 2.5;          ///< neighbourhood radius for the two-plane fit, spacings (≥ 1)
  double angle = 30.0;          ///< degrees: min angle between the two planes' normals (a crease's sharpness)
  double maxResidual = 0.12;    ///< spacings: max RMS distance of a cluster's points to its plane
  double maxLineDistance = 0.75;  ///< spacings: feature points lie at most this far from the crease line
  double minClusterShare = 0.15;  ///< each of the two planes holds at least this share of the neighbours
  double vcmOffset = 4.0;       ///< spacings: CGAL's offset_radius (ball clipping each Voronoi cell)
  double vcmConvolution = 2.0;  ///< spacings: CGAL's convolution_radius (0 = no convolution)
  double vcmThreshold = 0.16;   ///< CGAL's example threshold on λ_mid/(λ0+λ1+λ2)
  double chainRadius = 3.0;     ///< spacings: longest link between two chained feature points
  double maxChainTurn = 35.0;   ///< degrees: linked points' crease directions (and the link) agree this well
  double minChainLength = 6.0;  ///< spacings: shorter chains and spurs are dropped
  double sampleSpacing = 0.0;   ///< absolute units: spacing of the chain samples; 0 = do not sample
  double snapSigma = 1.5;       ///< spacings: Gaussian width of the local plane fits of snapToCreases()
  double maxOffCrease = 1.0;    ///< spacings: snapToCreases() adds a corner only this close to an input point
  int threads = 0;              ///< 0 = all cores; results do not depend on it

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief One feature polyline; every vertex lies on its local crease line (the two planes' intersection).
struct FeatureChain {
  std::vector<Eigen::Vector3d> points;      ///< ordered vertices, ≥ 2
  std::vector<Eigen::Vector3d> directions;  ///< unit crease direction at each vertex
  bool closed = false;                      ///< the last vertex links back to the first
  double length = 0;                        ///< arc length (with the closing segment when closed)
};

/// @brief What detectFeatures() found.
struct FeatureResult {
  double spacing = 0;                        ///< h used (given or estimated)
  /// Input points the detector flagged (raw test result), increasing.
  std::vector<std::uint32_t> detectedIndices;
  std::size_t creasePoints = 0;              ///< of those, with a valid crease line (the chain input)
  /// The feature points: input points within maxLineDistance spacings of a chain (after isolated detections
  /// were dropped and chains were extended into their corners), increasing. Use these to mark input points.
  std::vector<std::uint32_t> featureIndices;
  std::vector<FeatureChain> chains;          ///< longest first
  std::vector<Eigen::Vector3d> samples;      ///< chain samples put on the creases by snapToCreases() (when params.sampleSpacing > 0)
  std::vector<std::uint32_t> sampleChain;    ///< chain index of each sample
  double detectSeconds = 0, chainSeconds = 0, sampleSeconds = 0;  ///< wall times per stage
};

/// @brief Detect sharp-feature points, build the feature chains and (if params.sampleSpacing > 0) sample them
/// (sampleFeatureChains() then snapToCreases()).
/// @param cloud points with oriented unit normals (estimateNormals() when it has none)
/// @throws InputError when the cloud has fewer than 8 points; std::invalid_argument for bad parameters.
/// @note NormalVariation: O(n m log n), m the neighbours in the radius. Vcm: a 3-D Delaunay triangulation
/// (sequential, CGAL) plus one half-space intersection per point. Deterministic for any thread count.
FeatureResult detectFeatures(const PointCloud& cloud, const FeatureParams& params = {});

/// @brief Samples along @p chains at arc-length spacing ≈ @p spacing (each chain split into
/// max(1, round(L/spacing)) equal pieces, ends included for open chains), each on its crease line; samples
/// closer than spacing/2 to a sample of an earlier (longer) chain are dropped, so chains meeting at a corner
/// do not crowd it. Gaps along a chain are ≤ 1.5·spacing.
/// @param[out] chainOfSample (optional) the chain index of each sample
/// @note O(total chain vertices + samples). Deterministic.
std::vector<Eigen::Vector3d> sampleFeatureChains(const std::vector<FeatureChain>& chains, double spacing,
                                                 std::vector<std::uint32_t>* chainOfSample = nullptr);

/// @brief Put chain samples exactly on the creases of @p cloud (sheet-plane intersections), for the
/// resampler to hold.
///  1. At each sample x, the neighbours within params.radius spacings are split into two sheets as in the
///     normal-variation test, a plane is fitted to each with weights exp(−d²/σ²) (d the distance to x, σ =
///     params.snapSigma spacings: local planes, so curved sheets bias the line less than the detector's
///     unweighted fit), and x moves to the nearest point of the two planes' intersection; once more from there.
///     Where no crease lies within maxLineDistance, x may jump to one up to 0.8·radius away that runs along
///     its chain (within maxChainTurn); failing that, a looser fit (any angle, 2× residual, half the cluster
///     share) may correct it by at most h/4.
///  2. A sample where that fit fails the detector's thresholds goes onto the chord between the nearest fitted
///     samples of its chain (at most 3 away on each side) if the chord's sagitta, L·θ/8 (θ the turn between the
///     two fits' crease directions), is below maxResidual spacings; otherwise it is dropped (a chain end
///     extended past the feature would sit off the surface; a chord across a bend would cut inside it).
///  3. Tracing: each chain's samples are split where samples were dropped (gaps over 1.6 × the chain's median
///     spacing), and every piece's ends (a lone sample: both ways along its own crease) are continued along the
///     crease: step one spacing along the last crease direction, fit the two sheets there (the snap fit; on the
///     half-ball behind the prediction where the full ball fails), place the sample one step on along the fitted
///     line; stop where the fit fails (over one or two failed steps the trace may resume), where the fit lands
///     more than half a step (+ h/4) off the prediction, or where a sample is already within 0.75 steps (the gap
///     is bridged). Near a corner the points ahead that neither plane explains (3·maxResidual off both, a normal
///     unlike both) fit a third plane: the corner is the three planes' intersection (refined by reassigning the
///     points around it to the nearest plane, twice), the gap to it is filled, and the corner's two other creases
///     (the third plane with each sheet, on the side where the sheet lies) are followed along those planes while
///     the points around stay explained by them, handing over to the stepped fit once it holds. Traced
///     branches get chain indices after the given ones. Sequential in a fixed order: deterministic.
///  3b. Tips: two open ends whose crease lines (each the last fit that holds within 3 samples of the end,
///     its planes refitted without the points off both) share a plane and converge at 8°–maxChainTurn,
///     meeting ahead of both within 6·radius spacings, are continued on those lines to the tip: the common
///     point of the shared plane and the two other sheets' planes, refitted on the points around it (a step
///     in a surface fading out, as fandisk's wedge: two creases end at one point without a third crease).
///  4. Where two chains' end lines (at least 13° apart), continued, meet within 3·radius spacings of both ends and within
///     params.maxOffCrease spacings of an input point, and no sample is within half a spacing of it (tracing
///     placed most corners already), a corner sample is added there, and the gap from each of those chain ends
///     to the corner gets samples at the chain's spacing on the straight line.
///  5. Gaps: two samples 1.5–6 × the chains' median spacing apart with no sample between them (within 0.45 × their
///     distance of the midpoint and half a spacing of their line) get samples at ≤ that spacing between them: on
///     the snap fit's crease where it runs along them and near their chord, else on the fitted crease line of
///     either, else on the chord where the samples on either side run on in line with it (within 20°; one side
///     suffices up to 4.5 spacings); a gap where none holds (two creases meeting) stays open.
///  6. Curved sheets: a plane fitted to a sheet that curves along the crease (a plate meeting a cylinder) lies
///     off it, and so does the planes' line. Every sample whose looser snap fit (as in 1) puts the planes'
///     line within maxLineDistance/2 local spacings of it moves to the crease of the two sheets fitted as
///     height fields over those planes, bending along the crease (h = c0 + c1·u + c2·v + c3·u², u along it),
///     on the 40 nearest input points (each to the nearer sheet; points over 3·maxResidual off both left out,
///     the others weighted down by their distance), if both fit within maxResidual, under 10 % of the points
///     are left out (more: a third sheet, as at a corner) and the move is at most maxLineDistance local spacings.
/// @param chainOfSample the chain index of each sample (sampleFeatureChains' output: a chain's samples are
///     consecutive and in order)
/// @param spacing the input spacing h (FeatureResult::spacing)
/// @param[out] chainOut (optional) the chain index of each returned sample (a corner: one of its two chains)
/// @return the kept, traced and tip samples, chain by chain in order, then the corners of step 4 and their gap
/// samples, then the samples of step 5
/// @note O(samples · m log n + ends² + traced · samples), m the neighbours in the radius. Deterministic for any
/// thread count.
std::vector<Eigen::Vector3d> snapToCreases(const PointCloud& cloud, const std::vector<Eigen::Vector3d>& samples,
                                           const std::vector<std::uint32_t>& chainOfSample, double spacing,
                                           const FeatureParams& params,
                                           std::vector<std::uint32_t>* chainOut = nullptr);

/// @brief A reference sharp edge (a mesh edge).
using Segment = std::array<Eigen::Vector3d, 2>;

/// @brief Mesh edges whose two faces' normals differ by more than @p minAngleDegrees (the reference sharp
/// edges of the CAD benchmarks use 45°), plus boundary edges when @p includeBoundary.
/// @note O(F log F).
std::vector<Segment> sharpMeshEdges(const TriangleMesh& mesh, double minAngleDegrees = 45.0,
                                    bool includeBoundary = false);

/// @brief Precision/recall of detected feature points against reference edges.
struct FeatureScore {
  double precision = 0;  ///< detected points within `tolerance` of a reference edge / detected points
  double recall = 0;     ///< points within `band` of a reference edge that were detected / such points
  std::size_t detected = 0, nearEdge = 0;
};

/// @brief Score @p featureIndices of @p points against @p edges. Distances to the edges are exact.
/// @param tolerance absolute: a detection this close to an edge is a true positive (e.g. 1.5·h)
/// @param band absolute: points this close to an edge should be detected (e.g. 0.5·h)
/// @note O(n log E) with a k-d tree on densified edges, then exact segment distances.
FeatureScore scoreFeatures(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<std::uint32_t>& featureIndices, const std::vector<Segment>& edges,
                           double tolerance, double band, int threads = 0);

/// @brief Points along @p edges at most @p step apart, both ends of every edge included (e.g. to measure how
/// well a cloud covers the reference sharp edges with coverage() from metrics.hpp).
/// @param[out] owner (optional) the edge index of each point
/// @throws std::invalid_argument when step ≤ 0. @note O(total length / step).
std::vector<Eigen::Vector3d> sampleSegments(const std::vector<Segment>& edges, double step,
                                            std::vector<std::uint32_t>* owner = nullptr);

/// @brief Exact distance from @p p to the nearest of @p edges (brute force; for tests and reports).
double distanceToSegments(const Eigen::Vector3d& p, const std::vector<Segment>& edges);

/// @brief The spacing estimate detectFeatures() uses: median over points of the mean distance to the 6
/// nearest neighbours. @note O(n log n). Deterministic.
double estimateSpacing(const std::vector<Eigen::Vector3d>& points, int threads = 0);

}  // namespace iires
