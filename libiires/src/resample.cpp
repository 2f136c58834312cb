// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/resample.hpp"

#include "iires/attributes.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>

#include "iires/detail/json.hpp"
#include "iires/knn.hpp"
#include "iires/normals.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/detail/stage_clock.hpp"
#include "iires/validate.hpp"
#include "resampler.hpp"
#include "voxel_thin.hpp"

namespace iires {
namespace {

constexpr std::size_t kPreprocessMinPoints = 25;  // fewer points are resampled without pre-processing

using detail::initialCandidates;
using detail::Resampler;
using detail::Samples;
using detail::voxelThin;

using Clock = std::chrono::steady_clock;

// With sharp edges the MLS fits weight each input point by its normal's agreement with the estimate's
// (MlsParams::normalSigma): a free sample beside a crease is fitted to its own face, not to a rounding of it.
constexpr double kSharpNormalSigma = 0.5;

/// The points (and normals) of @p cloud at @p indices, in that order.
PointCloud select(const PointCloud& cloud, const std::vector<std::uint32_t>& indices) {
  PointCloud out;
  out.points.reserve(indices.size());
  for (std::uint32_t i : indices) out.points.push_back(cloud.points[i]);
  if (cloud.hasNormals()) {
    out.normals.reserve(indices.size());
    for (std::uint32_t i : indices) out.normals.push_back(cloud.normals[i]);
  }
  return out;
}

/// The input's attributes at the output points, from input neighbours on the same sheet (near the output point's
/// tangent plane, and accepted by the intrinsic rule when the run used it).
std::vector<PointAttribute> carryAttributes(const PointCloud& input, const std::vector<Eigen::Vector3d>& output,
                                            const std::vector<Eigen::Vector3d>& normals, const NeighbourRule* rule,
                                            const Execution& exec) {
  SameSheet sameSheet;
  if (const auto* intrinsic = dynamic_cast<const IntrinsicRule*>(rule))
    sameSheet = [intrinsic](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return intrinsic->acceptPoints(a, b); };
  return interpolateAttributes(input, output, normals, sameSheet, {}, exec);
}

/// Exit 0 promises points on the input's surface: the box they must lie in. Each axis of the bounding box of the
/// working cloud and of the samples the caller holds (@p held: on the surface too; a tile's context samples reach
/// past its points) is enlarged by a tenth of its own extent but by at most three output spacings (@p spacing; a
/// sample 20 units off a ribbon 2 wide is off the surface, however long the ribbon), and in any case by the
/// input's @p resolution (MlsSurface::resolution(): at the rim of a plate or a fold a few spacings thick a sample
/// may sit 0.6 input spacings out, and a sparse sampling of a sphere misses its extremes by the sphere's sag over
/// the holes between its points, whatever N is asked for), never more than half the extent.
Eigen::AlignedBox3d inputBox(const std::vector<Eigen::Vector3d>& input, double spacing, double resolution,
                             const std::vector<Eigen::Vector3d>& held = {}) {
  Eigen::AlignedBox3d box;
  for (const Eigen::Vector3d& p : input) box.extend(p);
  for (const Eigen::Vector3d& p : held) box.extend(p);
  const Eigen::Vector3d extent = box.sizes();
  const Eigen::Vector3d resolved = (0.5 * extent).cwiseMin(resolution);
  const Eigen::Vector3d margin =
      (0.1 * extent).cwiseMin(3 * spacing).cwiseMax(resolved).array() + 1e-9 * extent.norm();  // 1e-9: rounding
  box.min() -= margin;
  box.max() += margin;
  return box;
}

/// A sample outside inputBox() has left the surface (projection diverged on a degenerate cloud), and the run
/// fails instead of writing it.
void checkWithinInput(const std::vector<Eigen::Vector3d>& samples, const std::vector<Eigen::Vector3d>& input,
                      const std::vector<Eigen::Vector3d>& held, double spacing, double resolution) {
  const Eigen::AlignedBox3d box = inputBox(input, spacing, resolution, held);
  std::size_t outside = 0;
  double worst = 0;
  for (const Eigen::Vector3d& p : samples) {
    if (box.contains(p) && p.allFinite()) continue;
    ++outside;
    worst = std::max(worst, p.allFinite() ? box.exteriorDistance(p) : std::numeric_limits<double>::infinity());
  }
  if (outside > 0) {
    std::ostringstream os;
    os << "resampling failed: " << outside << " output points left the input's bounding box (by up to " << worst
       << "; the output spacing is " << spacing << "): the surface could not be followed";
    throw std::runtime_error(os.str());
  }
}

/// The cloud the stages work on: voxel-thinned first when it is far denser than the output (so every O(n)
/// stage works on ≈ maxInputPerSample·N points, never fewer than kMinWorkingPoints: small N keep a fine
/// surface), then in Morton order (every stage loops over the points querying their neighbours: in that order
/// those stay in cache).
PointCloud workingCloud(PointCloud cloud, const ResampleParams& params, const Execution& exec,
                        const StageClock& clock) {
  constexpr std::size_t kMinWorkingPoints = 60000;
  const std::size_t workingTarget = std::max(
      kMinWorkingPoints, params.maxInputPerSample * (params.targetCount + params.contextSamples.size()));
  if (params.maxInputPerSample > 0 && cloud.size() > workingTarget) {
    const auto t = clock.begin("thin");
    const std::size_t target = workingTarget;
    // Intrinsic control: cells near two sheets (layers as far apart as the sheet rule's gap) keep all their
    // points, so that no later stage sees the sheets merged.
    cloud = select(cloud, voxelThin(cloud.points, cloud.normals, target,
                                    bboxDiagonal(cloud.points) / std::sqrt(static_cast<double>(target)), 0,
                                    exec.threads, 0.0,
                                    params.intrinsic ? params.preprocessing.sheet.gapSpacings : 0.0));
    clock.end("thin", t);
  }
  return select(cloud, mortonOrder(cloud.points, exec.threads));
}

/// The samples `--sharp-edges` holds: the feature chains sampled at edgeRatio × the output spacing (coarser when
/// they would take over half of N) and put exactly on the creases; sets featurePoints and featureSamples (how
/// many of them fit beside the caller's fixed samples). A sample the crease fits put off the sampled surface is
/// dropped, and the free samples cover its place: outside the box every output point must lie in (inputBox() at
/// 0.8 of the target spacing), as on a degenerate or sparse cloud a line fitted past its end, or past the input's
/// local extent (by kHeldBeyond) and farther from every input point than the kernel width there (the nearest
/// input point's distance to its 8th neighbour: the MLS surface ends about there), as a crease traced past the end
/// of a scan or a corner where the fitted planes of a face the scan never saw meet. A corner of a closed part lies
/// within 0.4–0.96 of that from its input points (the corpus at 1× and 5×), and a crease sample in a gap of the
/// sampling within the input's extent.
std::vector<Eigen::Vector3d> creaseSamples(const PointCloud& cloud, const MlsSurface& surface,
                                           const ResampleParams& params, const Execution& exec,
                                           ResampleResult& result) {
  constexpr double kHeldBeyond = 0.25;  // kernel widths past the input neighbours' hull (MlsSurface::project)
  const double area = surface.area();
  const FeatureParams& fp = params.features;
  const FeatureResult features = detectFeatures(cloud, fp, exec);
  const double l0 = std::sqrt(2.0 * area / (std::sqrt(3.0) * static_cast<double>(params.targetCount)));
  std::vector<std::uint32_t> chainOf;
  std::vector<Eigen::Vector3d> onEdges = sampleFeatureChains(features.chains, params.edgeRatio * l0, &chainOf);
  if (onEdges.size() + params.fixedSamples.size() > params.targetCount / 2)  // never let edges take over N
    onEdges = sampleFeatureChains(features.chains, params.edgeRatio * l0 * 2.0 *
                                                       static_cast<double>(onEdges.size()) /
                                                       static_cast<double>(params.targetCount), &chainOf);
  onEdges = snapToCreases(cloud, onEdges, chainOf, features.spacing, fp, exec);  // exactly on the creases
  const Eigen::AlignedBox3d box = inputBox(cloud.points, 0.8 * l0, surface.resolution());
  const auto offTheSurface = [&](const Eigen::Vector3d& q) {
    if (!box.contains(q)) return true;
    double beyond = 0;
    surface.project(q, nullptr, nullptr, nullptr, nullptr, 0, &beyond);
    if (!(beyond > kHeldBeyond)) return false;
    // The local kernel width, unclamped (MlsSurface clamps it to a quantile: on the sparse side of a density
    // gradient that is narrower than the spacing there): the nearest input point's distance to its 8th neighbour.
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    if (surface.index().knn(q, 1, idx, d2) < 1) return false;
    const double toInput = d2[0];
    const std::size_t k = surface.index().knn(cloud.points[idx[0]], MlsSurface::kWidthNeighbours, idx, d2);
    return k == MlsSurface::kWidthNeighbours && toInput > d2[k - 1];
  };
  onEdges.erase(std::remove_if(onEdges.begin(), onEdges.end(), offTheSurface), onEdges.end());
  result.featurePoints = features.featureIndices.size();
  result.featureSamples = std::min(onEdges.size(), params.targetCount - params.fixedSamples.size());
  return onEdges;
}

/// Curvature mode's report: output points and mean spacing per level (each output point takes the level of
/// its nearest working-cloud point, found in @p working).
void reportLevels(const CurvatureResult& curvature, const KnnIndex& working, ResampleResult& result) {
  const std::size_t levels = curvature.pointsPerLevel.size();
  result.pointsPerLevel.assign(levels, 0);
  result.spacingPerLevel.assign(levels, 0.0);
  const KnnIndex out(result.cloud.points);
  std::vector<std::uint32_t> idx;
  std::vector<double> d2;
  for (const Eigen::Vector3d& p : result.cloud.points) {
    const auto level = static_cast<std::size_t>(curvature.level[working.nearest(p)]);
    ++result.pointsPerLevel[level];
    if (out.knn(p, 2, idx, d2) == 2) result.spacingPerLevel[level] += std::sqrt(d2[1]);
  }
  for (std::size_t q = 0; q < levels; ++q)
    if (result.pointsPerLevel[q]) result.spacingPerLevel[q] /= static_cast<double>(result.pointsPerLevel[q]);
}

/// The sheet rule (intrinsic control from the first graph on): filters @p neighbours so that every stage below
/// reads neighbours on each point's own sheet only; a cloud without normals gets them from that graph,
/// estimated and oriented. Pre-processing reads them oriented: its bilateral weights then tell a sheet facing
/// the other way across a gap the rule's rows still span (two noisy sheets six spacings apart: without them
/// three sweeps pulled both 0.1 spacing towards each other, 3.6 % of the points beyond 0.1 gap). Sets
/// result.sheets; returns which points have another sheet near (the MLS surface's gate).
std::vector<std::uint8_t> sheetRule(PointCloud& cloud, NeighbourTable& neighbours, const SheetParams& params,
                                    const Execution& exec, const StageClock& clock, ResampleResult& result) {
  const auto t = clock.begin("sheets");
  std::vector<std::uint8_t> near;
  std::vector<Eigen::Vector3d> normals;
  const bool given = cloud.hasNormals();  // kept, or oriented where they were not consistently
  result.sheets =
      separateSheets(cloud.points, neighbours, normals, params, exec, given ? &cloud.normals : nullptr, &near);
  cloud.normals = std::move(normals);
  clock.end("sheets", t);
  return near;
}

/// The working cloud's unit normals: estimated and oriented where none were given; given ones normalised and,
/// where their signs disagree, oriented (the sheet rule, when it ran, did that already).
void workingNormals(PointCloud& cloud, const NormalParams& params, bool sheetRuleRan, const Execution& exec) {
  if (!cloud.hasNormals()) {
    cloud.normals = estimateNormals(cloud.points, params, exec);
    return;
  }
  for (auto& nrm : cloud.normals) nrm.normalize();
  if (!sheetRuleRan) repairOrientation(cloud.points, cloud.normals, params.k, exec.threads);
}

/// The input's attributes are interpolated onto the output at the end, from the input as given (the stages
/// merge, thin, move and drop points): its positions and attributes, the attributes taken out of @p cloud.
PointCloud takeAttributes(PointCloud& cloud) {
  PointCloud source;
  if (cloud.attributes.empty()) return source;
  source.points = cloud.points;
  source.attributes = std::move(cloud.attributes);
  cloud.attributes.clear();
  return source;
}

/// A doubled cloud (withoutNearDuplicates()) loses its twins; the tree and the table (@p k columns) are rebuilt
/// on the rest. A cloud that is not doubled is left as it is.
void mergeTwins(PointCloud& cloud, std::optional<KnnIndex>& index, std::optional<NeighbourTable>& neighbours,
                std::size_t k, const Execution& exec, ResampleResult& result) {
  const auto kept = withoutNearDuplicates(*neighbours, cloud.points, exec.threads);
  if (kept.size() == cloud.size()) return;
  result.nearDuplicatesMerged = cloud.size() - kept.size();
  neighbours.reset();
  cloud = select(cloud, kept);
  result.thinnedPoints = cloud.size();
  index.emplace(cloud.points);
  neighbours.emplace(*index, cloud.points, k, exec.threads);
}

/// After pre-processing moved or dropped points: the later stages' table (@p laterK columns) on the final
/// positions, through the sheet rule (@p params; null: it did not run) again, on rows as long as the first time
/// (@p tableK: shorter ones would not reach a sheet as far off); returns which points have another sheet near.
std::vector<std::uint8_t> refilter(const PointCloud& cloud, std::optional<KnnIndex>& index,
                                   std::optional<NeighbourTable>& neighbours, std::size_t tableK, std::size_t laterK,
                                   const SheetParams* params, const Execution& exec) {
  index.emplace(cloud.points);
  neighbours.emplace(*index, cloud.points, tableK, exec.threads);
  std::vector<std::uint8_t> near;
  std::vector<Eigen::Vector3d> normals;
  if (params) separateSheets(cloud.points, *neighbours, normals, *params, exec, &cloud.normals, &near);
  neighbours->truncate(laterK);
  return near;
}

/// The pre-processing's parameters within resample(): the sheet rule with the intrinsic neighbourhoods, and with sharp
/// edges a noisy input's sweeps keeping apart the faces of every crease the feature stage is to hold.
PreprocessParams preprocessParams(const ResampleParams& params) {
  PreprocessParams pp = params.preprocessing;
  pp.sheets = params.intrinsic;
  if (params.sharpEdges && pp.denoise.sharpnessAngle > 0 && pp.denoise.laterSharpnessAngle == 0)
    pp.denoise.laterSharpnessAngle = std::min(pp.denoise.sharpnessAngle, params.features.angle);
  return pp;
}

}  // namespace

void ResampleParams::validate() const {
  if (targetCount < 1) throw std::invalid_argument("the requested point count N must be at least 1");
  if (neighbours < 6 || neighbours > 64) throw std::invalid_argument("neighbours must be in [6, 64]");
  if (!(splitRatio > 1.0)) throw std::invalid_argument("splitRatio must be > 1");
  if (!(collapseRatio > 0.0 && collapseRatio < 1.0)) throw std::invalid_argument("collapseRatio must be in (0, 1)");
  if (maxPasses < 0 || relaxPerPass < 0 || maxRelaxIterations < 0 || relaxPatience < 1)
    throw std::invalid_argument("pass and iteration counts must be >= 0 (patience >= 1)");
  if (!(overRelaxation >= 1.0 && overRelaxation < 2.0)) throw std::invalid_argument("overRelaxation must be in [1, 2)");
  if (!(maxEditShare >= 0.0 && maxEditShare <= 0.5)) throw std::invalid_argument("maxEditShare must be in [0, 0.5]");
  if (maxInputPerSample > 0 && maxInputPerSample < 4) throw std::invalid_argument("maxInputPerSample must be 0 or >= 4");
  if (!(candidateFactor >= 1.0)) throw std::invalid_argument("candidateFactor must be >= 1");
  if (mls.k < 3) throw std::invalid_argument("mls.k must be >= 3");
  if (mode == ResampleMode::kCurvature) curvature.validate();
  if (sharpEdges && !(edgeRatio >= 0.1 && edgeRatio <= 4.0))
    throw std::invalid_argument("edgeRatio (--edge-ratio) must be in [0.1, 4], got " + std::to_string(edgeRatio));
  if (ringEdges && !contextSamples.empty())
    throw std::invalid_argument("ring edges are not available with context samples");
  if (fixedSamples.size() > targetCount)
    throw std::invalid_argument("more fixed samples than the requested point count");
}

std::string ResampleResult::toJson() const {
  detail::JsonWriter j;
  j.beginObject(true).member("input_points", inputPoints).member("duplicates_merged", duplicatesMerged);
  j.member("near_duplicates_merged", nearDuplicatesMerged).member("given_normals_replaced", givenNormalsReplaced);
  j.member("requested_points", requestedPoints).member("output_points", outputPoints);
  j.member("working_points", thinnedPoints).member("scan_line_points", scanLinePoints);
  j.member("initial_samples", initialSamples).member("passes", passes);
  j.member("relax_iterations", relaxIterations).member("splits", splits).member("collapses", collapses);
  j.member("target_length", targetLength).member("components", components).member("satellites", satellites);
  j.key("sheets").embed(sheets.toJson());
  j.member("feature_points", featurePoints).member("feature_samples", featureSamples);
  j.array("points_per_level", pointsPerLevel).array("spacing_per_level", spacingPerLevel);
  j.key("preprocess").embed(preprocessing.toJson());
  j.key("spacing").beginObject().member("mean", spacing.mean).member("min", spacing.min);
  j.member("max", spacing.max).member("cv", spacing.cv).endObject();
  j.key("time_s").beginObject();
  for (const StageTime& t : timings) j.member(t.name, t.seconds);
  j.endObject().endObject();
  return j.str() + "\n";
}

ResampleResult resample(PointCloud cloud, const ResampleParams& params, const Execution& exec) {
  params.validate();
  exec.validate();
  const auto start = Clock::now();
  ResampleResult result;
  result.requestedPoints = params.targetCount;
  result.inputPoints = cloud.size();
  const StageClock clock(result.timings, exec.progress);
  const PointCloud attributeSource = takeAttributes(cloud);

  auto t = clock.begin("validate");
  result.duplicatesMerged = validateCloud(cloud, 4, "input", exec.threads).duplicatesMerged;
  checkSamplesASurface(cloud.points, "input", exec.threads);
  clock.end("validate", t);

  cloud = workingCloud(std::move(cloud), params, exec, clock);
  result.thinnedPoints = cloud.size();

  const bool preprocessing = params.preprocess && cloud.size() >= kPreprocessMinPoints;
  PreprocessParams pp = preprocessParams(params);
  const GeodesicParams& gp = params.geodesic;
  // One k-NN search for every stage that reads the working cloud's neighbours (pre-processing, the geodesic
  // graph, the MLS kernel widths) while pre-processing keeps the positions; one k-d tree for it and the MLS.
  t = clock.begin("neighbours");
  std::optional<KnnIndex> index(std::in_place, cloud.points);
  // Columns read after pre-processing (the geodesic graph, the MLS kernel widths); pre-processing reads more.
  const std::size_t laterK =
      std::max(params.intrinsic ? static_cast<std::size_t>(gp.k) + 1 : 0, MlsSurface::kWidthNeighbours);
  const std::size_t tableK = std::max(preprocessing ? preprocessNeighbours(pp) : std::size_t{0}, laterK);
  std::optional<NeighbourTable> neighbours(std::in_place, *index, cloud.points, tableK, exec.threads);
  mergeTwins(cloud, index, neighbours, tableK, exec, result);
  clock.end("neighbours", t);
  const SheetParams& sp = params.preprocessing.sheet;
  const bool sheets = params.intrinsic && cloud.size() > static_cast<std::size_t>(sp.pcaNeighbours);
  std::vector<std::uint8_t> nearSheets;  // per point of the final working cloud (the MLS surface's gate)
  // Given normals that do not describe the points' surface (tangent to it, random) are estimated like absent ones.
  result.givenNormalsReplaced =
      cloud.hasNormals() && !givenNormalsDescribeSurface(cloud.points, cloud.normals, *neighbours, exec.threads);
  if (result.givenNormalsReplaced) cloud.normals.clear();
  // Normals the sheet rule estimates give way to the denoiser's fits on a clean input; given ones are kept.
  pp.denoise.keepGivenNormals = pp.denoise.keepGivenNormals && cloud.hasNormals();
  if (sheets) nearSheets = sheetRule(cloud, *neighbours, sp, exec, clock, result);
  if (preprocessing) {
    t = clock.begin("preprocess");
    result.preprocessing = iires::preprocess(cloud, pp, exec, &*neighbours);
    if (result.preprocessing.positionsKept()) {
      cloud.normals = std::move(result.preprocessing.cloud.normals);
      neighbours->truncate(laterK);  // memory (5M points: 26 → 17 columns)
    } else {  // moved or dropped points: the table and the tree no longer match them
      neighbours.reset();
      index.reset();
      cloud = std::move(result.preprocessing.cloud);
      nearSheets = refilter(cloud, index, neighbours, sheets ? tableK : laterK, laterK, sheets ? &sp : nullptr, exec);
    }
    result.preprocessing.cloud = {};
    clock.end("preprocess", t);
  }
  if (neighbours) result.scanLinePoints = neighbours->linePoints();
  // The geodesic graph builds a k-d tree of these (Z-ordered) points as well and hands it to the surface: one
  // tree, not two (memory at 5M).
  const bool geodesicRule = !params.neighbourRule && params.intrinsic;
  if (geodesicRule) index.reset();

  t = clock.begin("normals");
  workingNormals(cloud, params.normals, sheets, exec);
  clock.end("normals", t);

  // What does not need the geodesic coordinates: the MLS surface (on the geodesic graph's k-d tree with the
  // geodesic rule) and the initial candidates. It runs where the geodesic satellite sweeps (serial per
  // component) leave threads idle.
  std::optional<MlsSurface> surface;
  std::vector<std::uint32_t> candidates;
  auto independent = [&](int threads, const KnnIndex* pointIndex, const std::vector<float>& samplingScales) {
    auto t = clock.begin("surface");
    MlsParams mp = params.mls;
    if (!params.intrinsic) mp.sheetGap = 0;  // straight-line neighbourhoods
    if (params.sharpEdges && mp.normalSigma == 0) mp.normalSigma = kSharpNormalSigma;
    result.nearSheets = nearSheets;
    surface.emplace(cloud.points, cloud.normals, mp, Execution{threads}, index ? &*index : pointIndex,
                    neighbours ? &*neighbours : nullptr, std::move(nearSheets),
                    samplingScales.empty() ? nullptr : &samplingScales);
    neighbours.reset();  // read by nothing after the surface and the geodesic graph (memory at 5M)
    clock.end("surface", t);
    t = clock.begin("candidates");
    candidates = initialCandidates(cloud, *surface, params, threads);
    clock.end("candidates", t);
  };

  std::shared_ptr<NeighbourRule> rule = params.neighbourRule;
  if (geodesicRule) {
    t = clock.begin("geodesic");  // includes the independent stages where they ran during its sweeps
    result.geodesic = std::make_shared<const GeodesicCoordinates>(cloud, gp, exec,
                                                                  neighbours ? &*neighbours : nullptr, independent);
    rule = std::make_shared<IntrinsicRule>(result.geodesic, params.intrinsicRule, exec, result.nearSheets);
    result.components = result.geodesic->components();
    result.satellites = result.components * static_cast<std::size_t>(gp.satellites);
    clock.end("geodesic", t);
  } else {
    independent(exec.threads, nullptr, {});
  }
  if (!rule) rule = std::make_shared<EuclideanRule>();

  std::optional<CurvatureResult> curvature;
  if (params.mode == ResampleMode::kCurvature) {
    t = clock.begin("curvature");
    curvature = computeCurvature(cloud.points, cloud.normals, params.curvature, exec);  // eq. (8)–(10)
    clock.end("curvature", t);
  }
  ResampleParams local = params;  // sharp edges add fixed samples
  if (params.sharpEdges) {
    t = clock.begin("features");
    const auto onEdges = creaseSamples(cloud, *surface, params, exec, result);
    local.fixedSamples.insert(local.fixedSamples.end(), onEdges.begin(),
                              onEdges.begin() + static_cast<long>(result.featureSamples));
    clock.end("features", t);
  }

  Resampler resampler(cloud.points, cloud.normals, *surface, local, exec, *rule,
                      curvature ? &curvature->sizeFactor : nullptr);
  t = clock.begin("initialise");
  Samples s = resampler.initialise(candidates, result);
  clock.end("initialise", t);

  t = clock.begin("resample");
  resampler.run(s, result);
  clock.end("resample", t);

  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.fixed[i] == Samples::kContext) continue;  // held for the neighbours' sake, not output
    if (s.fixed[i]) result.fixedIndices.push_back(static_cast<std::uint32_t>(result.cloud.size()));
    result.cloud.points.push_back(s.pos[i]);
    result.cloud.normals.push_back(s.nrm[i]);
  }
  t = clock.begin("report");
  result.spacing = spacingStats(result.cloud.points, exec.threads);
  checkWithinInput(result.cloud.points, cloud.points, params.contextSamples, result.spacing.mean,
                   surface->resolution());
  if (curvature) reportLevels(*curvature, surface->index(), result);
  clock.end("report", t);
  if (!attributeSource.attributes.empty()) {
    t = clock.begin("attributes");
    result.cloud.attributes =
        carryAttributes(attributeSource, result.cloud.points, result.cloud.normals, rule.get(), exec);
    clock.end("attributes", t);
  }
  result.outputPoints = result.cloud.size();
  clock.end("total", start);
  return result;
}

}  // namespace iires
