// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file features.hpp
/// @brief Sharp-feature detection, feature polylines and their samples (DESIGN §3 step 9): the samples
/// become the resampler's fixed samples (ResampleParams::fixedSamples), so CAD creases stay crisp.
///
/// Two detectors, both on a cloud with oriented normals; lengths in spacings use the local spacing where the
/// sampling is sparser than h (the mean distance to the 6 nearest points), so every neighbourhood holds about
/// as many points on a non-uniform scan.
///  - FeatureDetector::NormalVariation (default): the neighbours within `radius` spacings are split into two
///    clusters by their normals (2-means), a plane is fitted to each cluster, and the point is a feature point
///    when the planes meet at ≥ `angle` degrees, both fit well (RMS residual ≤ `maxResidual` spacings) and the
///    point lies within `maxLineDistance` spacings of their intersection line (the crease).
///  - FeatureDetector::Vcm: the Voronoi covariance measure (Mérigot, Ovsjanikov, Guibas 2011) as CGAL's
///    compute_vcm + vcm_is_on_feature_edge. Slower; cleaner chains where time allows.
///
/// Chains: the detected points with a valid crease are projected onto it, linked into a minimum spanning
/// forest and peeled into longest paths; short paths are dropped. sampleFeatureChains() places samples along
/// the chains; snapToCreases() puts them exactly on the creases, traces the chains into their corners and adds
/// the corners — the samples the resampler holds with `--sharp-edges`.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "iires/execution.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief Which sharp-feature test detectFeatures() uses.
enum class FeatureDetector {
  NormalVariation,  ///< two-plane split of the neighbours' normals (default)
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
  /// local spacings: snapToCreases() keeps a bend (1×), a crease fit's point, a corner or a gap's sample (1.5×),
  /// a traced sample (2×) this close to the input
  double maxOffCrease = 1.0;

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
FeatureResult detectFeatures(const PointCloud& cloud, const FeatureParams& params = {}, const Execution& exec = {});

/// @brief Samples along @p chains at arc-length spacing ≈ @p spacing (each chain split into
/// max(1, round(L/spacing)) equal pieces, ends included for open chains), each on its crease line; samples
/// closer than spacing/2 to a sample of an earlier (longer) chain are dropped, so chains meeting at a corner
/// do not crowd it. Gaps along a chain are ≤ 1.5·spacing.
/// @param[out] chainOfSample (optional) the chain index of each sample
/// @note O(total chain vertices + samples). Deterministic.
std::vector<Eigen::Vector3d> sampleFeatureChains(const std::vector<FeatureChain>& chains, double spacing,
                                                 std::vector<std::uint32_t>* chainOfSample = nullptr);

/// @brief Put chain samples exactly on the creases of @p cloud (sheet-plane intersections), for the
/// resampler to hold: each sample moves onto the intersection of its two sheets' local plane fits (or onto the
/// chord of its chain's fitted neighbours, or is dropped where it would sit off the surface); the chains' ends
/// are traced along their creases into corners and tips; corners where two chains' lines meet and gaps along
/// the chains get samples; samples on curved sheets move onto the crease of two bending height fields. The
/// steps and their thresholds are described in crease_snap.cpp.
/// @param chainOfSample the chain index of each sample (sampleFeatureChains' output: a chain's samples are
///     consecutive and in order)
/// @param spacing the input spacing h (FeatureResult::spacing)
/// @param[out] chainOut (optional) the chain index of each returned sample (a corner: one of its two chains)
/// @return the kept, traced and tip samples, chain by chain in order, then the corners of step 4 and their gap
/// samples, then the samples of step 5, then those of step 8 (gaps the last moves opened)
/// @note O(samples · m log n + ends² + traced · samples), m the neighbours in the radius. Deterministic for any
/// thread count.
std::vector<Eigen::Vector3d> snapToCreases(const PointCloud& cloud, const std::vector<Eigen::Vector3d>& samples,
                                           const std::vector<std::uint32_t>& chainOfSample, double spacing,
                                           const FeatureParams& params, const Execution& exec = {},
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
