// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/register/registration.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

#include "iires/detail/json.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/register/hausdorff.hpp"
#include "iires/register/open_side.hpp"
#include "iires/validate.hpp"

namespace iires::reg {

namespace {

constexpr std::size_t kMinPoints = 10;
/// Residual RMS below this (normalised units: unit RMS radius) is rounding noise, e.g. identical clouds.
constexpr double kRoundingFloor = 1e-12;
/// The final ICP of an estimated overlap keeps this share of the estimated pairs (both directions).
constexpr double kPolishShare = 0.9;

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

/// Centroid and RMS radius about it (paper ref. [9]: normalise position and scale).
struct Frame {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double radius = 1.0;
};

Frame frameOf(const std::vector<Eigen::Vector3d>& p) {
  Frame f;
  for (const auto& x : p) f.centroid += x;
  f.centroid /= static_cast<double>(p.size());
  double s = 0;
  for (const auto& x : p) s += (x - f.centroid).squaredNorm();
  f.radius = std::sqrt(s / static_cast<double>(p.size()));
  return f;
}

std::vector<Eigen::Vector3d> normalised(const std::vector<Eigen::Vector3d>& p, const Frame& f) {
  std::vector<Eigen::Vector3d> out(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) out[i] = (p[i] - f.centroid) / f.radius;
  return out;
}

/// Ratio of the smallest to the largest eigenvalue of the covariance (0 for a plane).
double flatness(const std::vector<Eigen::Vector3d>& p) {
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (const auto& x : p) m += x;
  m /= static_cast<double>(p.size());
  for (const auto& x : p) c += (x - m) * (x - m).transpose();
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c).eigenvalues();
  return ev(2) > 0 ? std::max(0.0, ev(0)) / ev(2) : 0.0;
}

/// Trimmed RMS of nearest distances from @p from to @p to (the ⌈overlap·n⌉ nearest).
double trimmedRms(const std::vector<Eigen::Vector3d>& from, const KnnIndex& to, double overlap, int threads) {
  std::vector<double> d2(from.size());
  parallelFor(from.size(), threads, [&](std::size_t i) { to.nearest(from[i], &d2[i]); });
  const std::size_t keep = from.size() - allowedOutliers(from.size(), overlap);
  std::nth_element(d2.begin(), d2.begin() + static_cast<std::ptrdiff_t>(keep - 1), d2.end());
  double s = 0;
  for (std::size_t i = 0; i < keep; ++i) s += d2[i];
  return std::sqrt(s / static_cast<double>(keep));
}

std::vector<Eigen::Vector3d> applied(const std::vector<Eigen::Vector3d>& p, const Eigen::Matrix4d& T) {
  std::vector<Eigen::Vector3d> out(p.size());
  const Eigen::Matrix3d m = T.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = T.topRightCorner<3, 1>();
  for (std::size_t i = 0; i < p.size(); ++i) out[i] = m * p[i] + t;
  return out;
}

/// At most @p maxCount points of @p cloud: a seeded random subset (Fisher–Yates on the first maxCount slots),
/// in input order. Normals are dropped; the cloud is returned unchanged when it is small enough.
PointCloud randomSubset(const PointCloud& cloud, std::size_t maxCount, std::uint64_t seed) {
  if (maxCount == 0 || cloud.size() <= maxCount) return cloud;
  std::vector<std::size_t> idx(cloud.size());
  for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
  std::mt19937_64 rng(seed);
  for (std::size_t i = 0; i < maxCount; ++i) std::swap(idx[i], idx[i + static_cast<std::size_t>(rng() % (idx.size() - i))]);
  idx.resize(maxCount);
  std::sort(idx.begin(), idx.end());
  PointCloud out;
  out.points.reserve(maxCount);
  for (std::size_t i : idx) out.points.push_back(cloud.points[i]);
  if (cloud.hasNormals())
    for (std::size_t i : idx) out.normals.push_back(cloud.normals[i]);
  return out;
}

/// Drop resampled points that are not finite or lie far outside the input's bounding box (grown by 10 % of
/// its diagonal): a failed MLS projection of one sample must not decide the normalisation. Returns how many.
std::size_t dropStraySamples(std::vector<Eigen::Vector3d>& samples, const std::vector<Eigen::Vector3d>& input) {
  Eigen::AlignedBox3d box;
  for (const auto& p : input) box.extend(p);
  const double margin = 0.1 * box.diagonal().norm();
  box.min().array() -= margin;
  box.max().array() += margin;
  const std::size_t before = samples.size();
  samples.erase(std::remove_if(samples.begin(), samples.end(),
                               [&](const Eigen::Vector3d& p) { return !p.allFinite() || !box.contains(p); }),
                samples.end());
  return before - samples.size();
}

ResampleResult resampleFor(const PointCloud& cloud, const RegistrationParams& params, const Execution& exec,
                           const char* what) {
  ResampleParams rp = params.resample;
  rp.targetCount = params.samples;
  rp.seed = params.seed;
  const std::string stage = std::string("resample ") + what;
  Execution inner{exec.threads, {}};
  if (exec.progress) {
    exec.report(stage, 0.0);
    // The resampler's own stages are short except its main loop ("resample"), which is reported through.
    inner.progress = [&](const std::string& name, double fraction) {
      if (name == "resample") exec.report(stage, fraction);
    };
  }
  try {
    return resample(cloud, rp, inner);
  } catch (const InputError& e) {
    throw InputError(std::string(what) + ": " + e.what());
  }
}

/// How well a pose fits, in normalised units (lower is better), and the overlaps it implies.
struct PoseScore {
  double score = std::numeric_limits<double>::infinity();
  double sourceOverlap = 1, targetOverlap = 1;
};

/// Symmetric score of a pose T of the normalised source S against the normalised target: the RMS of the two
/// directions' distances, trimmed to the given overlap, or, with the overlap unknown, each direction's
/// fractional RMSD (its own overlap estimate). Symmetric, so a shrunken source that covers only part of the
/// target does not win.
PoseScore scorePose(const std::vector<Eigen::Vector3d>& ns, const std::vector<Eigen::Vector3d>& nt,
                    const KnnIndex& targetTree, const Eigen::Matrix4d& T, const RegistrationParams& params,
                    int threads) {
  const std::vector<Eigen::Vector3d> moved = applied(ns, T);
  const KnnIndex movedTree(moved);
  PoseScore out;
  if (params.overlap > 0.0) {
    const double a = trimmedRms(moved, targetTree, params.overlap, threads);
    const double b = trimmedRms(nt, movedTree, params.overlap, threads);
    out.score = std::sqrt(0.5 * (a * a + b * b));
    out.sourceOverlap = out.targetOverlap = params.overlap;
    return out;
  }
  auto direction = [&](const std::vector<Eigen::Vector3d>& from, const KnnIndex& to, double* overlap) {
    std::vector<double> d2(from.size());
    parallelFor(from.size(), threads, [&](std::size_t i) { to.nearest(from[i], &d2[i]); });
    std::sort(d2.begin(), d2.end());
    const double minOverlap = *std::min_element(params.searchOverlaps.begin(), params.searchOverlaps.end());
    const FractionalFit fit = fractionalRmsd(d2, minOverlap, params.fitOverlapExponent, kRoundingFloor);
    *overlap = static_cast<double>(fit.keep) / static_cast<double>(from.size());
    return fit.score;
  };
  const double a = direction(moved, targetTree, &out.sourceOverlap);
  const double b = direction(nt, movedTree, &out.targetOverlap);
  out.score = std::sqrt(0.5 * (a * a + b * b));
  return out;
}

/// The search's candidates refined by ICP and scored; best = the lowest score.
struct Refined {
  std::vector<IcpResult> icp;
  std::vector<PoseScore> score;
  std::size_t best = 0;
};

/// ICP (with scale unless rigid) from each of the best few candidates for screenIterations, scored by
/// scorePose(); the best continues to convergence. A known overlap < 1 trims the pairs in both directions; an
/// unknown one is estimated in every iteration (fractional RMSD, both directions).
Refined refineCandidates(const std::vector<Eigen::Vector3d>& ns, const std::vector<Eigen::Vector3d>& nt,
                         const KnnIndex& sourceTree, const KnnIndex& targetTree, const RotationSearchResult& found,
                         const IcpRims& rims, const RegistrationParams& params, const Execution& exec) {
  IcpParams ip = params.icp;
  const bool estimate = params.overlap == 0.0;
  ip.overlap = estimate ? 1.0 : params.overlap;
  ip.estimateOverlap = estimate;
  ip.minOverlap = estimate ? *std::min_element(params.searchOverlaps.begin(), params.searchOverlaps.end()) : 1.0;
  ip.overlapExponent = params.fitOverlapExponent;
  ip.estimateScale = params.estimateScale;
  ip.bidirectional = ip.bidirectional || params.overlap < 1.0;  // partial scans: both directions
  const std::size_t nc = std::min(params.icpCandidates, found.candidates.size());
  Refined out;
  out.icp.resize(nc);
  out.score.resize(nc);
  IcpParams screen = ip;
  screen.maxIterations = params.screenIterations;
  for (std::size_t c = 0; c < nc; ++c) {
    exec.report("icp", static_cast<double>(c) / static_cast<double>(nc + 1));
    Eigen::Matrix4d init = Eigen::Matrix4d::Identity();
    init.topLeftCorner<3, 3>() = found.candidates[c].scale * found.candidates[c].rotation;
    init.topRightCorner<3, 1>() = found.candidates[c].translation;
    out.icp[c] = similarityIcp(ns, nt, targetTree, init, screen, exec, &sourceTree, rims);
    out.score[c] = scorePose(ns, nt, targetTree, out.icp[c].T_target_source, params, exec.threads);
  }
  for (std::size_t c = 1; c < nc; ++c)
    if (out.score[c].score < out.score[out.best].score) out.best = c;
  IcpResult& best = out.icp[out.best];
  if (!best.converged) {  // the winner continues to convergence
    const int screened = best.iterations;
    best = similarityIcp(ns, nt, targetTree, best.T_target_source, ip, exec, &sourceTree, rims);
    best.iterations += screened;
  }
  if (estimate) {
    // Polish with the estimated overlaps, trimmed a little further and held fixed: pairs beyond the overlap
    // (at a cut's edge) bias the scale and the position, while dropping a few true pairs costs little
    // (trimmed ICP practice).
    IcpParams polish = ip;
    polish.estimateOverlap = false;
    polish.overlap = kPolishShare * best.overlap;
    polish.reverseOverlap = kPolishShare * best.reverseOverlap;
    const int before = best.iterations;
    const double forward = best.overlap, reverse = best.reverseOverlap;
    best = similarityIcp(ns, nt, targetTree, best.T_target_source, polish, exec, &sourceTree, rims);
    best.iterations += before;
    best.overlap = forward;
    best.reverseOverlap = reverse;
  }
  out.score[out.best] = scorePose(ns, nt, targetTree, best.T_target_source, params, exec.threads);
  exec.report("icp", 1.0);
  return out;
}

/// A similarity Tn = (σR | τ) between the normalised clouds in original units: with s_n = (s − c_s)/r_s and
/// t = r_t t_n + c_t, t = (σ r_t / r_s) R s + (c_t + r_t τ − (σ r_t / r_s) R c_s). R is re-orthonormalised
/// (Umeyama's is orthonormal up to rounding).
Eigen::Matrix4d toOriginalUnits(const Eigen::Matrix4d& Tn, double sigma, const Frame& fs, const Frame& ft) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(Tn.topLeftCorner<3, 3>() / sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
  const double scale = sigma * ft.radius / fs.radius;
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = scale * R;
  T.topRightCorner<3, 1>() = ft.centroid + ft.radius * Tn.topRightCorner<3, 1>() - scale * R * fs.centroid;
  return T;
}

std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream s;
  s << std::setprecision(12) << v;
  return s.str();
}

/// The runner-up (the best refined candidate at least 10 degrees away from the result), the score ratio, and
/// the ambiguity flags (another pose within the tolerance; a planar cloud). Needs r.score and r.planar.
void setRunnerUp(RegistrationResult& r, const Refined& refined, const Frame& fs, const Frame& ft,
                 const RegistrationParams& params) {
  const IcpResult& icp = refined.icp[refined.best];
  const Eigen::Matrix3d Rbest = icp.T_target_source.topLeftCorner<3, 3>() / icp.scale;
  double second = std::numeric_limits<double>::infinity();
  for (std::size_t c = 0; c < refined.icp.size(); ++c) {
    if (c == refined.best) continue;
    const Eigen::Matrix3d Rc = refined.icp[c].T_target_source.topLeftCorner<3, 3>() / refined.icp[c].scale;
    if (rotationAngle(Rbest, Rc) >= 10.0 * M_PI / 180.0 && refined.score[c].score < second) {
      second = refined.score[c].score;
      r.runnerUpScore = second;
      r.runnerUpTransform = toOriginalUnits(refined.icp[c].T_target_source, refined.icp[c].scale, fs, ft);
    }
  }
  r.secondBestScoreRatio = std::isfinite(second) && r.score > 0 ? second / r.score : 0.0;
  if (std::isfinite(second) && second <= r.score * (1.0 + params.ambiguityTolerance)) {
    r.ambiguous = true;
    r.ambiguityReason = "another pose fits within " + num(100 * params.ambiguityTolerance) +
                        "% (symmetric shape?)";
  }
  if (r.planar) {
    r.ambiguous = true;
    r.ambiguityReason = r.ambiguityReason.empty() ? std::string("planar cloud: mirrored poses fit equally well")
                                                  : r.ambiguityReason + "; planar cloud";
  }
}

/// Distances between the aligned source samples (@p source mapped by r.T_target_source) and the target's:
/// Hausdorff, Hausdorff trimmed to the overlaps, and the overlap share.
void measureAlignment(RegistrationResult& r, const std::vector<Eigen::Vector3d>& source,
                      const std::vector<Eigen::Vector3d>& target, int threads) {
  const std::vector<Eigen::Vector3d> aligned = applied(source, r.T_target_source);
  r.hausdorff = hausdorffDistance(aligned, target, 1.0, threads);
  // trimmed to the overlaps (estimated or given), each direction its own
  const KnnIndex alignedTree(aligned), targetSamples(target);
  r.hausdorffTrimmed = std::max(directedHausdorff(aligned, targetSamples, r.sourceOverlap, threads),
                                directedHausdorff(target, alignedTree, r.targetOverlap, threads));
  // overlap share: aligned source samples with a target sample within one sample spacing
  const double l = spacingStats(target, threads).mean;
  std::vector<char> near(aligned.size());
  parallelFor(aligned.size(), threads, [&](std::size_t i) {
    double d2 = 0;
    targetSamples.nearest(aligned[i], &d2);
    near[i] = d2 <= l * l;
  });
  r.overlapShare = static_cast<double>(std::count(near.begin(), near.end(), 1)) / static_cast<double>(near.size());
}

}  // namespace

ResampleParams RegistrationParams::defaultResample() {
  ResampleParams p;
  p.preprocess = false;
  p.intrinsic = false;
  p.maxPasses = 0;
  p.maxRelaxIterations = 0;
  return p;
}

void RegistrationParams::validate() const {
  if (samples < 50) throw std::invalid_argument("registration: samples (M) must be at least 50");
  if (eulerSteps < 1) throw std::invalid_argument("registration: eulerSteps must be at least 1");
  if (so3Count < 1) throw std::invalid_argument("registration: so3Count must be at least 1");
  if (!(overlap >= 0.0 && overlap <= 1.0))
    throw std::invalid_argument("registration: overlap must be 0 (estimate) or in (0, 1], got " +
                                std::to_string(overlap));
  if (searchOverlaps.empty() || searchOverlaps.size() > 16)
    throw std::invalid_argument("registration: searchOverlaps needs between 1 and 16 levels");
  for (double f : searchOverlaps)
    if (!(f > 0.0 && f <= 1.0)) throw std::invalid_argument("registration: searchOverlaps must lie in (0, 1]");
  if (!(searchOverlapExponent >= 0.0) || !(fitOverlapExponent >= 0.0))
    throw std::invalid_argument("registration: the overlap exponents must be >= 0");
  if (icpCandidates < 1) throw std::invalid_argument("registration: icpCandidates must be at least 1");
  if (screenIterations < 1) throw std::invalid_argument("registration: screenIterations must be at least 1");
  if (maxInputPerSample != 0 && maxInputPerSample < 2)
    throw std::invalid_argument("registration: maxInputPerSample must be 0 (never thin) or at least 2");
  if (!(ambiguityTolerance >= 0.0)) throw std::invalid_argument("registration: ambiguityTolerance must be >= 0");
  search.validate();
  icp.validate();
  outliers.validate();
}

PointCloud transformCloud(const PointCloud& cloud, const Eigen::Matrix4d& T) {
  PointCloud out;
  out.points = applied(cloud.points, T);
  if (cloud.hasNormals()) {
    const Eigen::Matrix3d m = T.topLeftCorner<3, 3>();
    const Eigen::Matrix3d n = m.inverse().transpose();
    out.normals.reserve(cloud.normals.size());
    for (const auto& v : cloud.normals) out.normals.push_back((n * v).normalized());
  }
  out.attributes = cloud.attributes;  // colours, intensities, labels do not depend on the frame
  return out;
}

std::string formatTransform(const Eigen::Matrix4d& T) {
  std::ostringstream s;
  s << std::setprecision(17);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) s << (c ? " " : "") << (T(r, c) == 0.0 ? 0.0 : T(r, c));
    s << "\n";
  }
  return s.str();
}

RegistrationResult registerClouds(const PointCloud& sourceIn, const PointCloud& targetIn,
                                  const RegistrationParams& requested, const Execution& exec) {
  requested.validate();
  exec.validate();
  // M above both input sizes adds no information (and a huge M costs hours): cap it at the larger input,
  // never below the default.
  RegistrationParams params = requested;
  params.samples = std::min(requested.samples, std::max({RegistrationParams{}.samples, sourceIn.size(), targetIn.size()}));
  const auto tTotal = Clock::now();
  RegistrationResult r;
  auto stage = [&](const char* name, Clock::time_point t) { r.timings.push_back({name, since(t)}); };

  // 1. Validate: empty, NaN/Inf, too few distinct points, collinear, a volume → InputError naming the cloud.
  auto t = Clock::now();
  PointCloud source = sourceIn, target = targetIn;
  validateCloud(source, kMinPoints, "source", exec.threads);
  validateCloud(target, kMinPoints, "target", exec.threads);
  // On the clouds as given: the working clouds resampled below may be too small for the check.
  checkSamplesASurface(source.points, "source", exec.threads);
  checkSamplesASurface(target.points, "target", exec.threads);
  r.sourcePoints = sourceIn.size();
  r.targetPoints = targetIn.size();
  r.samples = params.samples;
  r.samplesRequested = requested.samples;
  stage("validate", t);

  // 2. Cheap thinning of dense inputs to maxInputPerSample·M points, then resample both to the same M
  // isotropic points: centroid and RMS radius no longer depend on density.
  t = Clock::now();
  const std::size_t workingCap = params.maxInputPerSample * params.samples;
  // The same seed for both: the subset depends on the cloud, not on its role, so that identical inputs give
  // identical working clouds (and the identity).
  source = randomSubset(source, workingCap, params.seed);
  target = randomSubset(target, workingCap, params.seed);
  source = cleanOutliers(source, params.outliers, exec, &r.outliersFound);
  target = cleanOutliers(target, params.outliers, exec, &r.outliersFound);
  r.sourceWorkingPoints = source.size();
  r.targetWorkingPoints = target.size();
  stage("thin", t);
  t = Clock::now();
  ResampleResult rs = resampleFor(source, params, exec, "source");
  r.strayDropped = dropStraySamples(rs.cloud.points, source.points);
  stage("resample_source", t);
  t = Clock::now();
  ResampleResult rt = resampleFor(target, params, exec, "target");
  r.strayDropped += dropStraySamples(rt.cloud.points, target.points);
  stage("resample_target", t);
  if (rs.cloud.size() < kMinPoints || rt.cloud.size() < kMinPoints)
    throw InputError(std::string(rs.cloud.size() < kMinPoints ? "source" : "target") +
                     ": too few usable points after resampling");

  // 3. Normalise: centroid → origin, unit RMS radius.
  t = Clock::now();
  Frame fs = frameOf(rs.cloud.points);
  const Frame ft = frameOf(rt.cloud.points);
  // Rigid: one common unit for both clouds, so σ = 1 in the normalised frame is scale 1 in original units.
  if (!params.estimateScale) fs.radius = ft.radius;
  if (!(fs.radius > 0)) throw InputError("source: zero or non-finite extent after resampling");
  if (!(ft.radius > 0)) throw InputError("target: zero or non-finite extent after resampling");
  r.sourceRadius = fs.radius;
  r.targetRadius = ft.radius;
  const std::vector<Eigen::Vector3d> ns = normalised(rs.cloud.points, fs), nt = normalised(rt.cloud.points, ft);
  r.planar = std::min(flatness(ns), flatness(nt)) < params.planarityThreshold;
  stage("normalise", t);

  // 4. Rotation search, eq. (11)–(12).
  t = Clock::now();
  const bool estimate = params.overlap == 0.0;
  RotationSearchParams sp = params.search;
  sp.overlaps = estimate ? params.searchOverlaps : std::vector<double>{params.overlap};
  sp.overlapExponent = params.searchOverlapExponent;
  sp.seed = params.seed;
  sp.keep = std::max(sp.keep, params.icpCandidates);
  const KnnIndex sourceTree(ns), targetTree(nt);
  const OpenSide sourceSide = openSide(ns, sourceTree, {}, exec.threads);
  const OpenSide targetSide = openSide(nt, targetTree, {}, exec.threads);
  sp.sourceOpenSide = sourceSide.direction;
  sp.targetOpenSide = targetSide.direction;
  r.sourceRimPoints = sourceSide.rimPoints;
  r.targetRimPoints = targetSide.rimPoints;
  const RotationSearch search(ns, nt, sp, exec);
  const std::vector<Eigen::Matrix3d> grid = rotationGrid(params.grid, params.eulerSteps, params.so3Count);
  const RotationSearchResult found = search.search(grid);
  r.grid = toString(params.grid);
  r.gridSize = grid.size();
  r.exactEvaluations = found.exactEvaluations;
  r.pointQueries = found.pointQueries;
  r.fieldQueries = found.fieldQueries;
  stage("search", t);
  if (found.candidates.empty()) throw std::runtime_error("rotation search found no candidate");

  // 5. ICP from each of the best few candidates, ranked by the symmetric score.
  t = Clock::now();
  const auto flags = [](const OpenSide& side) { return side.rim.empty() ? nullptr : &side.rim; };
  const Refined refined =
      refineCandidates(ns, nt, sourceTree, targetTree, found, {flags(sourceSide), flags(targetSide)}, params, exec);
  stage("icp", t);

  // 6. The result, the runner-up and the ambiguity flags; back to original units.
  t = Clock::now();
  const std::size_t best = refined.best;
  const IcpResult& icp = refined.icp[best];
  const Eigen::Matrix4d& Tn = icp.T_target_source;
  r.score = refined.score[best].score;
  r.sourceOverlap = refined.score[best].sourceOverlap;
  r.targetOverlap = refined.score[best].targetOverlap;
  setRunnerUp(r, refined, fs, ft, params);
  r.T_target_source = toOriginalUnits(Tn, icp.scale, fs, ft);
  r.scale = icp.scale * ft.radius / fs.radius;
  r.rotation = r.T_target_source.topLeftCorner<3, 3>() / r.scale;
  r.translation = r.T_target_source.topRightCorner<3, 1>();
  const Eigen::AngleAxisd aa(r.rotation);
  r.rotationAngleDeg = aa.angle() * 180.0 / M_PI;
  r.rotationAxis = aa.axis();
  r.rmse = icp.rmse * ft.radius;
  r.icpIterations = icp.iterations;
  r.icpConverged = icp.converged;
  r.bestCandidate = found.candidates[best].gridIndex;
  r.candidateRank = best;
  r.normalisedEnergy = found.candidates[best].energy;
  measureAlignment(r, rs.cloud.points, rt.cloud.points, exec.threads);
  stage("evaluate", t);
  stage("total", tTotal);
  return r;
}

std::string RegistrationResult::toJson() const {
  detail::JsonWriter j(12);
  const auto vector = [&](const Eigen::Vector3d& v) {
    j.beginArray();
    for (int k = 0; k < 3; ++k) j.value(v[k]);
    j.endArray();
  };
  const auto matrix = [&](std::string_view name, const Eigen::Matrix4d& T) {
    j.key(name).beginArray();
    for (int i = 0; i < 4; ++i) {
      j.beginArray();
      for (int k = 0; k < 4; ++k) j.value(T(i, k));
      j.endArray();
    }
    j.endArray();
  };
  j.beginObject(true);
  matrix("transform", T_target_source);
  j.member("scale", scale).key("rotation").beginArray();
  for (int i = 0; i < 3; ++i) vector(rotation.row(i).transpose());
  j.endArray().member("rotation_angle_deg", rotationAngleDeg).key("rotation_axis");
  vector(rotationAxis);
  j.key("translation");
  vector(translation);
  j.member("rmse", rmse).member("hausdorff", hausdorff).member("hausdorff_trimmed", hausdorffTrimmed);
  j.member("overlap_share", overlapShare).member("source_overlap", sourceOverlap);
  j.member("target_overlap", targetOverlap).member("score", score);
  matrix("runner_up_transform", runnerUpTransform);
  j.member("runner_up_score", runnerUpScore).member("normalised_energy", normalisedEnergy).member("grid", grid);
  j.member("grid_size", gridSize).member("best_candidate", bestCandidate).member("candidate_rank", candidateRank);
  j.member("icp_iterations", icpIterations).member("icp_converged", icpConverged);
  j.member("exact_evaluations", exactEvaluations).member("point_queries", pointQueries);
  j.member("field_queries", fieldQueries);
  j.member("ambiguous", ambiguous).member("planar", planar).member("ambiguity_reason", ambiguityReason);
  j.member("second_best_score_ratio", secondBestScoreRatio);
  j.member("source_points", sourcePoints).member("target_points", targetPoints);
  j.member("source_working_points", sourceWorkingPoints).member("target_working_points", targetWorkingPoints);
  j.member("source_rim_points", sourceRimPoints).member("target_rim_points", targetRimPoints);
  j.member("stray_samples_dropped", strayDropped).member("outliers_found", outliersFound);
  j.member("samples", samples).member("samples_requested", samplesRequested);
  j.member("source_radius", sourceRadius).member("target_radius", targetRadius);
  j.key("timings").beginObject();
  for (const StageTime& t : timings) j.member(t.name + "_s", t.seconds);
  j.endObject().endObject();
  return j.str() + "\n";
}

}  // namespace iires::reg
