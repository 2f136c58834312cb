// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file resample.hpp
/// @brief Isotropic resampling to exactly N points on the MLS surface of a cloud (paper §4.1, DESIGN §3).

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "iires/curvature.hpp"
#include "iires/execution.hpp"
#include "iires/features.hpp"
#include "iires/geodesic.hpp"
#include "iires/intrinsic.hpp"
#include "iires/metrics.hpp"
#include "iires/mls.hpp"
#include "iires/neighbourhood.hpp"
#include "iires/normals.hpp"
#include "iires/preprocess.hpp"
#include "iires/sheets.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief Isotropic: one target spacing everywhere; Curvature: denser where the surface bends (paper §4.2).
enum class ResampleMode { kIsotropic, kCurvature };

/// @brief Parameters of resample(). Defaults in brackets are the paper's where it gives one.
struct ResampleParams {
  std::size_t targetCount = 10000;  ///< N, the exact number of output points (≥ 1)
  ResampleMode mode = ResampleMode::kIsotropic;  ///< `--mode isotropic|curvature`
  CurvatureParams curvature;        ///< curvature mode: eq. 8–10 (levels, ratios flat → curved)
  /// detect sharp features and keep samples on them (`--sharp-edges`); the MLS fits then weight the input points
  /// by their normals (mls.normalSigma 0.5 unless set), so the free samples beside a crease keep to their face,
  /// and on a noisy input the denoiser keeps apart faces meeting at features.angle or more
  /// (preprocessing.denoise.laterSharpnessAngle, unless set)
  bool sharpEdges = false;
  FeatureParams features;           ///< the feature detector and its chains
  double edgeRatio = 0.5;           ///< spacing of the samples on feature lines, in units of l, [0.1, 4] (`--edge-ratio`)
  int neighbours = 14;              ///< Euclidean candidates per sample for its 1-ring (≥ 6)
  double splitRatio = 1.6;          ///< split edges longer than splitRatio·l [paper 1.6; Botsch–Kobbelt 4/3]
  double collapseRatio = 0.8;       ///< collapse edges shorter than collapseRatio·l [0.8]
  int maxPasses = 5;                ///< split/collapse + relaxation passes at N (count control, then clean-up; up
                                    ///< to 8× as many while the spacing still evens out by 5 % a pass)
  int relaxPerPass = 2;             ///< Lloyd iterations after each pass's edge operations
  double maxEditShare = 0.01;       ///< at N, a pass replaces at most this share of samples (collapse + split)
  int maxRelaxIterations = 8;       ///< cap on the final Lloyd relaxation iterations (run in rounds of 4)
  int relaxPatience = 1;            ///< stop the final relaxation after this many rounds without a better CV
  double overRelaxation = 1.5;      ///< Lloyd step factor ω: move to p + ω(c − p); 1 = plain Lloyd, < 2
  double candidateFactor = 3.0;     ///< density initialisation keeps ≈ this × N voxel cells, then eliminates to N
  /// Inputs with more than this × N points are voxel-thinned to about that many first (one point per cell, the
  /// nearest its centre; never below 60,000): the surface stays sampled several times finer than the output
  /// (its spacing ≤ 0.4 of the output's), and every stage before the resampling loop costs O(N) instead of
  /// O(input). 0 = never thin (the MLS surface of every input point; measured 25–50 % lower mean error, same
  /// uniformity, 1.7× the time at 100k → 10k).
  std::size_t maxInputPerSample = 6;
  /// Pre-processing of the input before anything else (paper §3.1): outliers pulled back (or removed/kept)
  /// and MLS denoising. Skipped for clouds too small for it (fewer than 25 points).
  bool preprocess = true;
  PreprocessParams preprocessing;   ///< its parameters (`--outliers`, `--no-denoise`)
  MlsParams mls;                    ///< the surface every sample is projected onto
  NormalParams normals;             ///< used when the input has no normals
  std::uint64_t seed = 0;           ///< the initial candidates' voxel grid offset and elimination ties; same seed → same output
  /// Intrinsic control (paper §3.2): neighbours must also be consistent in geodesic coordinates and lie on
  /// the same component, so samples never link across a thin gap or between objects. false = Euclidean.
  bool intrinsic = true;
  GeodesicParams geodesic;          ///< graph and satellites of the geodesic coordinates (built on the input)
  IntrinsicParams intrinsicRule;    ///< tolerances of the intrinsic neighbour test
  /// A custom neighbour rule for 1-rings; overrides `intrinsic` when set. See neighbourhood.hpp.
  std::shared_ptr<NeighbourRule> neighbourRule;
  /// Fill ResampleResult::ringEdges (the output's 1-rings cost one more pass over the samples: ~2 % of a run).
  bool ringEdges = false;
  /// Samples that are kept exactly as given (never moved or removed) and count towards N (DESIGN §9).
  std::vector<Eigen::Vector3d> fixedSamples;
  /// Samples of finished neighbouring regions (a tile's neighbours, DESIGN §9): held like fixedSamples, so the
  /// free samples keep their spacing to them, but not counted in N and not part of the output.
  std::vector<Eigen::Vector3d> contextSamples;

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief Wall time of one pipeline stage.
struct StageTime {
  std::string name;
  double seconds = 0;
};

/// @brief What resample() produced, with diagnostics.
struct ResampleResult {
  PointCloud cloud;                  ///< exactly requestedPoints points, with unit normals
  std::size_t inputPoints = 0;       ///< points read
  std::size_t duplicatesMerged = 0;  ///< exact duplicates merged during validation
  std::size_t nearDuplicatesMerged = 0;  ///< points a hair from an earlier one merged (withoutNearDuplicates())
  /// the input's normals were set aside and estimated: they do not describe the points' surface
  /// (givenNormalsDescribeSurface(): tangent to it, or random)
  bool givenNormalsReplaced = false;
  std::size_t requestedPoints = 0;   ///< N
  std::size_t outputPoints = 0;      ///< points output: cloud.size(), also once a caller has moved the cloud out
  std::size_t thinnedPoints = 0;     ///< input points the pipeline worked on (after validation and thinning)
  std::size_t scanLinePoints = 0;    ///< of those, points on scan lines (neighbours taken across the lines too)
  std::size_t initialSamples = 0;    ///< samples after density initialisation
  int passes = 0;                    ///< count-control passes run
  int relaxIterations = 0;           ///< Lloyd relaxation iterations run in total
  std::size_t splits = 0, collapses = 0;  ///< edge operations applied
  double targetLength = 0;           ///< final target edge length l
  SpacingStats spacing;              ///< nearest-neighbour spacing of the output
  /// Edges present in both endpoints' tangent-plane Delaunay 1-rings of the output (indices into cloud, a < b);
  /// empty unless ResampleParams::ringEdges.
  std::vector<std::array<std::uint32_t, 2>> ringEdges;
  /// What pre-processing did (its cloud left empty: the cleaned input is not kept); all zero when skipped.
  PreprocessResult preprocessing;
  std::vector<std::size_t> pointsPerLevel;  ///< curvature mode: output points per level, flat → curved
  std::vector<double> spacingPerLevel;      ///< curvature mode: mean nearest-neighbour spacing per level
  std::size_t featurePoints = 0;     ///< sharp edges: input points detected on features
  std::size_t featureSamples = 0;    ///< sharp edges: samples held on the feature lines (part of the N)
  /// Indices into cloud of the held samples (ResampleParams::fixedSamples and the feature samples), increasing.
  std::vector<std::uint32_t> fixedIndices;
  std::size_t components = 0;        ///< connected components of the input (intrinsic control), else 0
  /// The sheet rule on the working cloud (intrinsic control): neighbour pairs found across a gap, near-contact
  /// zones and the pairs of sheets kept apart; all zero without intrinsic control.
  SheetReport sheets;
  /// Per point of the geodesic coordinates' cloud (the working cloud), 1 where the sheet rule found another
  /// sheet near (intrinsic control); else empty.
  std::vector<std::uint8_t> nearSheets;
  std::size_t satellites = 0;        ///< geodesic satellites in all (3 per component)
  /// The geodesic coordinates of the input (intrinsic control), e.g. for writeGeodesicPly; else null.
  std::shared_ptr<const GeodesicCoordinates> geodesic;
  std::vector<StageTime> timings;    ///< per stage, in order; the last is "total"

  /// @brief The report as a JSON object (input_points, output_points, passes, time_s, spacing, ...).
  std::string toJson() const;
};

/// @brief Resample @p input to exactly params.targetCount points, uniformly spaced on its MLS surface.
///
/// Pipeline: validate (merge duplicates) → pre-processing (outliers, MLS denoising) → normals (PCA + MST
/// orientation, unless given or produced by denoising) → MLS surface →
/// geodesic coordinates and the intrinsic neighbour rule (unless switched off) → density initialisation (voxel cells, then weighted sample elimination down to N; or all points when
/// upsampling) → passes of split/collapse on the tangent-plane Delaunay 1-ring edges with target length l
/// (count control: l = mean edge · √(|S|/N)) and Lloyd relaxation in each sample's tangent-plane Voronoi cell,
/// projecting onto the MLS surface after every move → exact-count finish → Lloyd relaxation to convergence.
/// @throws InputError for an unusable cloud (empty, NaN, < 4 distinct points, collinear);
/// std::invalid_argument for bad parameters.
/// @note Deterministic: same input, params and seed give the same output for any thread count.
/// Cost O(n log n) on the input plus O(N k) per pass. Taken by value: pass an rvalue (std::move) when the
/// caller no longer needs the cloud, and the pipeline works in its memory instead of a copy.
/// @param exec threads and progress reports (stages "validate", "preprocess", "normals", "surface", "geodesic",
/// "initialise", "resample", ...); the output does not depend on it
ResampleResult resample(PointCloud input, const ResampleParams& params, const Execution& exec = {});

}  // namespace iires
