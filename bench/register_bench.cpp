// SPDX-License-Identifier: GPL-3.0-or-later
// register_bench: the registration acceptance trials (issues 6 and 21), iires-register vs Open3D baselines on
// the same inputs.
//
// Each trial: source and target sampled independently from a reference model at different densities, noise
// N(0, (0.33·l)²) along the normal (l = the clean cloud's mean nearest-neighbour spacing); the source is put
// under a random rotation (uniform on SO(3)), a scale in [0.2, 5] (log-uniform) and a translation of 1–3
// object diagonals. Partial scans: --cut F cuts the share F of the source off by a random plane, --target-cut F
// the share F of the target by another random plane (both clouds partial, different parts missing); --halves B
// makes source and target the two sides of one random plane sharing a band of the share B (two scans from
// opposite sides: each holds (1 + B)/2 of the surface);
// --outliers F adds F·n points spread uniformly over each cloud's bounding box grown by 10 %. iires runs at its
// defaults (no overlap hint) unless --overlap gives one. Success (DESIGN §7): rotation error < 5°, error of
// the mapped source centroid < 2 % of the target's diagonal, scale error < 2 %; the surface criterion (mean
// distance from the source mapped by the estimate to the model's surface < 1 % of the diagonal, and scale error
// < 2 %) decides on the models named by --symmetric (a symmetric pose puts the source on another, equally valid
// part of the surface). The surface is a dense noise-free sample of the model (200,000 points; a real scan's
// own points): the source's own samples would floor the distance at about half their spacing (5,000 points of
// pipe: spacing 2.1 % of the diagonal, so an exact symmetric pose measured 1.1 %).
//
// Prints key=value lines, one per model and method, and a summary per method.
// time_s is wall time per pair, cpu_s the process's user + system CPU time per pair (all threads; on a shared
// machine the honest measure of work). For iires the mean wall time of each stage is printed too.
//   register_bench [--models bunny00,armadillo,...] [--trials N] [--first-trial K] [--cut F] [--target-cut F] [--halves B]
//                  [--partial (= --cut 0.25)] [--outliers F] [--overlap F] [--symmetric knot1,...] [--seed S]
//                  [--threads T] [--methods iires,iires-euler,o3d-fpfh,o3d-fpfh-norm,o3d-icp]
//                  [--source-count N] [--target-count N] [--samples M] [--so3-count K] [--thin F] [--icp-candidates C]
//                  [--resample preprocess=0,intrinsic=0,maxPasses=4,...]
//                  [--search coarsePoints=96,coarseKeep=48,fullKeep=48,keep=12,minSeparationDeg=25,refineLevels=0,
//                            screenIterations=8,searchOverlaps=1:0.8:0.6,searchOverlapExponent=2,fitOverlapExponent=2.5,
//                            translationRadius=0.8,translationStep=0.4,translationPoints=48,translationRefineLevels=2,
//                            translationScales=1,fieldCells=32,fieldMargin=1,coarseOffsetRadius=0.4,
//                            coarseOffsetStep=0.4,coarseOffsetRefineLevels=1,
//                            openSideShift=0.4,openSideScaleSlope=0.3]
//                  [--verbose]
#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <memory>
#include <open3d/Open3D.h>
#include <random>
#include <sys/resource.h>
#include <sstream>
#include <string>
#include <vector>

#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "iires/register/registration.hpp"
#include "iires/sampling.hpp"

#include "bench_util.hpp"

namespace {

using Clock = std::chrono::steady_clock;

/// User + system CPU time of the process so far (all threads), seconds.
double cpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

using Vec = Eigen::Vector3d;
using Cloud = std::vector<Vec>;

using iires::bench::split;

struct Model {
  std::string name;
  iires::TriangleMesh mesh;  // empty for point sets
  iires::PointCloud points;  // point-set models (kitten): points with normals
};

/// A corpus mesh (meshes/NAME.off) or a real scan with normals (points_3/NAME.xyz or .ply: kitten, hippo1, ...).
Model loadModel(const std::string& name) {
  Model m;
  m.name = name;
  const std::string data = std::string(IIRES_DATA_DIR) + "/";
  for (const char* ext : {".xyz", ".ply"}) {
    const std::string path = data + "points_3/" + name + ext;
    if (!std::ifstream(path)) continue;
    m.points = iires::readPointCloud(path);
    if (!m.points.hasNormals()) throw std::invalid_argument(path + ": the noise model needs normals");
    return m;
  }
  m.mesh = iires::readMesh(data + "meshes/" + name + ".off");
  return m;
}

/// A dense noise-free sample of the model (200,000 points on a mesh; a point set's own points): the reference of
/// the clean surface error, which the source samples' spacing does not floor.
Cloud cleanSurface(const Model& m) {
  if (m.mesh.triangles.empty()) return m.points.points;
  iires::MeshSamplingParams sp;
  sp.count = 200000;
  return iires::sampleMesh(m.mesh, sp).points;
}

/// A noisy sample of the model: count points, noise N(0, (0.33 l)²) along the normal.
iires::PointCloud sampleModel(const Model& m, std::size_t count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  iires::PointCloud c;
  if (!m.mesh.triangles.empty()) {
    iires::MeshSamplingParams sp;
    sp.count = count;
    sp.seed = seed;
    c = iires::sampleMesh(m.mesh, sp);
  } else {  // point set: a random subset
    std::vector<std::size_t> idx(m.points.size());
    for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = i;
    for (std::size_t i = idx.size(); i > 1; --i) std::swap(idx[i - 1], idx[rng() % i]);
    idx.resize(std::min(count, idx.size()));
    for (auto i : idx) {
      c.points.push_back(m.points.points[i]);
      c.normals.push_back(m.points.normals[i]);
    }
  }
  const double l = iires::spacingStats(c.points).mean;
  std::normal_distribution<double> g(0.0, 0.33 * l);
  for (std::size_t i = 0; i < c.size(); ++i) c.points[i] += g(rng) * c.normals[i];
  c.normals.clear();
  return c;
}

Eigen::Matrix3d randomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Quaterniond q(g(rng), g(rng), g(rng), g(rng));
  return q.normalized().toRotationMatrix();
}

Cloud transformed(const Cloud& p, const Eigen::Matrix4d& T) {
  Cloud out(p.size());
  for (std::size_t i = 0; i < p.size(); ++i) out[i] = T.topLeftCorner<3, 3>() * p[i] + T.topRightCorner<3, 1>();
  return out;
}

/// A random plane normal (uniform on the sphere).
Vec randomNormal(std::mt19937_64& rng) {
  std::normal_distribution<double> g(0, 1);
  return Vec(g(rng), g(rng), g(rng)).normalized();
}

/// The points of @p c below (or, @p below false, above) the plane with normal @p n through the quantile @p share of
/// their heights along it: the share @p share of them (or 1 − share).
iires::PointCloud sideOfPlane(const iires::PointCloud& c, const Vec& n, double share, bool below) {
  std::vector<double> h;
  for (const auto& p : c.points) h.push_back(p.dot(n));
  std::vector<double> sorted = h;
  const auto k = std::min(sorted.size() - 1, static_cast<std::size_t>(share * static_cast<double>(sorted.size())));
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(k), sorted.end());
  iires::PointCloud kept;
  for (std::size_t i = 0; i < h.size(); ++i)
    if (below ? h[i] < sorted[k] : h[i] >= sorted[k]) kept.points.push_back(c.points[i]);
  return kept;
}

/// The points of @p c on the kept side of a random plane that cuts off the share @p share of them.
iires::PointCloud cutByPlane(const iires::PointCloud& c, double share, std::mt19937_64& rng) {
  return sideOfPlane(c, randomNormal(rng), 1.0 - share, true);
}

/// The two sides of one random plane sharing a band: @p source keeps the points below the plane's
/// (1 + band)/2 quantile, @p target those above its (1 − band)/2 quantile (quantiles of each cloud's own points),
/// so each keeps (1 + band)/2 of the surface and the two share the band (two scans from opposite sides).
void halvesByPlane(iires::PointCloud& source, iires::PointCloud& target, double band, std::mt19937_64& rng) {
  const Vec n = randomNormal(rng);
  source = sideOfPlane(source, n, 0.5 * (1 + band), true);
  target = sideOfPlane(target, n, 0.5 * (1 - band), false);
}

/// @p c plus share·n points uniform in its bounding box grown by 10 % of the diagonal on each side.
void addOutliers(iires::PointCloud& c, double share, std::mt19937_64& rng) {
  if (share <= 0) return;
  Eigen::AlignedBox3d box;
  for (const auto& p : c.points) box.extend(p);
  const double margin = 0.1 * box.diagonal().norm();
  std::uniform_real_distribution<double> u(0, 1);
  const auto count = static_cast<std::size_t>(share * static_cast<double>(c.size()));
  for (std::size_t i = 0; i < count; ++i) {
    Vec p;
    for (int d = 0; d < 3; ++d) p[d] = box.min()[d] - margin + u(rng) * (box.sizes()[d] + 2 * margin);
    c.points.push_back(p);
  }
}

struct Errors {
  double rotDeg = 180, trans = 1e9, scale = 1e9, surface = 1e9, seconds = 0, cpu = 0;
  bool ok = false, okSurface = false, failed = false;
  double overlap = 0;  // iires: the estimated overlap
};

/// @p surface: the model's clean surface (cleanSurface(); the target's coordinates), for the surface error.
Errors evaluate(const Eigen::Matrix4d& est, const Eigen::Matrix4d& truth, const Cloud& source,
                const iires::KnnIndex& surface, double diag, double seconds) {
  Errors e;
  e.seconds = seconds;
  const double se = est.topLeftCorner<3, 3>().col(0).norm(), st = truth.topLeftCorner<3, 3>().col(0).norm();
  if (!std::isfinite(se) || se <= 0) {
    e.failed = true;
    return e;
  }
  const Eigen::Matrix3d re = est.topLeftCorner<3, 3>() / se, rt = truth.topLeftCorner<3, 3>() / st;
  e.rotDeg = std::acos(std::clamp(((re.transpose() * rt).trace() - 1) / 2, -1.0, 1.0)) * 180 / M_PI;
  e.scale = std::abs(se / st - 1.0);
  Vec c = Vec::Zero();
  for (const auto& p : source) c += p;
  c /= static_cast<double>(source.size());
  const Vec ce = re * se * c + est.topRightCorner<3, 1>(), ct = rt * st * c + truth.topRightCorner<3, 1>();
  e.trans = (ce - ct).norm() / diag;
  const Cloud me = transformed(source, est);
  double sum = 0;
  for (const auto& p : me) {
    double d2 = 0;
    surface.nearest(p, &d2);
    sum += std::sqrt(d2);
  }
  e.surface = sum / static_cast<double>(me.size()) / diag;
  e.ok = e.rotDeg < 5 && e.trans < 0.02 && e.scale < 0.02;
  e.okSurface = e.surface < 0.01 && e.scale < 0.02;
  return e;
}

// ---------------------------------------------------------------- Open3D baselines
namespace o3r = open3d::pipelines::registration;

std::shared_ptr<open3d::geometry::PointCloud> toO3d(const Cloud& p) {
  return std::make_shared<open3d::geometry::PointCloud>(p);
}

/// Centroid + RMS radius of a raw cloud (the normalisation the issue mentions: "if first given the
/// normalisation").
std::pair<Vec, double> frame(const Cloud& p) {
  Vec c = Vec::Zero();
  for (const auto& x : p) c += x;
  c /= static_cast<double>(p.size());
  double s = 0;
  for (const auto& x : p) s += (x - c).squaredNorm();
  return {c, std::sqrt(s / static_cast<double>(p.size()))};
}

/// FPFH + RANSAC (with scaling) + ICP (with scaling), voxel size = voxelFrac × target diagonal for both.
Eigen::Matrix4d o3dFpfh(const Cloud& source, const Cloud& target, double voxel, std::uint64_t seed) {
  auto prep = [&](const Cloud& p) {
    auto down = toO3d(p)->VoxelDownSample(voxel);
    down->EstimateNormals(open3d::geometry::KDTreeSearchParamHybrid(2 * voxel, 30));
    auto f = o3r::ComputeFPFHFeature(*down, open3d::geometry::KDTreeSearchParamHybrid(5 * voxel, 100));
    return std::make_pair(down, f);
  };
  auto [sd, sf] = prep(source);
  auto [td, tf] = prep(target);
  open3d::utility::random::Seed(static_cast<int>(seed % 1000003));
  o3r::CorrespondenceCheckerBasedOnEdgeLength edge(0.9);
  o3r::CorrespondenceCheckerBasedOnDistance dist(1.5 * voxel);
  std::vector<std::reference_wrapper<const o3r::CorrespondenceChecker>> checkers{edge, dist};
  const auto ransac = o3r::RegistrationRANSACBasedOnFeatureMatching(
      *sd, *td, *sf, *tf, true, 1.5 * voxel, o3r::TransformationEstimationPointToPoint(true), 3, checkers,
      o3r::RANSACConvergenceCriteria(100000, 0.999));
  const auto icp = o3r::RegistrationICP(*toO3d(source), *toO3d(target), 1.5 * voxel, ransac.transformation_,
                                        o3r::TransformationEstimationPointToPoint(true),
                                        o3r::ICPConvergenceCriteria(1e-7, 1e-7, 60));
  return icp.transformation_;
}

Eigen::Matrix4d normalisedThen(const Cloud& source, const Cloud& target,
                               const std::function<Eigen::Matrix4d(const Cloud&, const Cloud&)>& fn) {
  const auto [cs, rs] = frame(source);
  const auto [ct, rt] = frame(target);
  Eigen::Matrix4d Ns = Eigen::Matrix4d::Identity(), Nt = Eigen::Matrix4d::Identity();
  Ns.topLeftCorner<3, 3>() /= rs;
  Ns.topRightCorner<3, 1>() = -cs / rs;
  Nt.topLeftCorner<3, 3>() /= rt;
  Nt.topRightCorner<3, 1>() = -ct / rt;
  const Eigen::Matrix4d Tn = fn(transformed(source, Ns), transformed(target, Nt));
  return Nt.inverse() * Tn * Ns;
}

Eigen::Matrix4d o3dIcp(const Cloud& source, const Cloud& target, double maxDist) {
  return o3r::RegistrationICP(*toO3d(source), *toO3d(target), maxDist, Eigen::Matrix4d::Identity(),
                              o3r::TransformationEstimationPointToPoint(true),
                              o3r::ICPConvergenceCriteria(1e-7, 1e-7, 100))
      .transformation_;
}

struct Tally {
  int trials = 0, ok = 0, okSurface = 0, okScored = 0, failed = 0, ambiguous = 0;
  std::vector<double> rot, trans, scale, seconds, cpu, overlap;
  std::vector<std::pair<std::string, double>> stages;  // summed wall time per stage (iires), in stage order
  void addStages(const std::vector<iires::StageTime>& timings) {
    for (const auto& st : timings) {
      auto it = std::find_if(stages.begin(), stages.end(), [&](const auto& x) { return x.first == st.name; });
      if (it == stages.end()) stages.emplace_back(st.name, st.seconds);
      else it->second += st.seconds;
    }
  }
  /// @p bySurface: the model is symmetric, its trials are scored by the surface criterion.
  void add(const Errors& e, bool bySurface) {
    ++trials;
    ok += e.ok;
    okScored += bySurface ? e.okSurface : e.ok;
    overlap.push_back(e.overlap);
    okSurface += e.okSurface;
    cpu.push_back(e.cpu);
    failed += e.failed;
    rot.push_back(e.rotDeg);
    trans.push_back(e.trans);
    scale.push_back(e.scale);
    seconds.push_back(e.seconds);
  }
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}
double mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / static_cast<double>(v.size());
}

/// success_scored: pose criterion, or the surface criterion on the --symmetric models (the acceptance figure).
void print(const std::string& model, const std::string& method, const Tally& t, bool partial) {
  std::printf(
      "model=%s method=%s partial=%d trials=%d success_scored=%.3f success=%.3f success_surface=%.3f ambiguous=%d "
      "failed=%d rot_err_deg_median=%.3g trans_err_median=%.3g scale_err_median=%.3g overlap_median=%.3g "
      "time_s_mean=%.3f time_s_median=%.3f cpu_s_mean=%.3f ok=%d ok_surface=%d\n",
      model.c_str(), method.c_str(), partial ? 1 : 0, t.trials, t.trials ? double(t.okScored) / t.trials : 0.0,
      t.trials ? double(t.ok) / t.trials : 0.0, t.trials ? double(t.okSurface) / t.trials : 0.0, t.ambiguous,
      t.failed, median(t.rot), median(t.trans), median(t.scale), median(t.overlap), mean(t.seconds),
      median(t.seconds), mean(t.cpu), t.ok, t.okSurface);
  if (!t.stages.empty()) {
    std::printf("stages model=%s method=%s partial=%d", model.c_str(), method.c_str(), partial ? 1 : 0);
    for (const auto& [name, sum] : t.stages) std::printf(" %s_s=%.4f", name.c_str(), sum / t.trials);
    std::printf("\n");
  }
  std::fflush(stdout);
}

/// The benchmark's command line.
struct Options {
  std::vector<std::string> models = {"bunny00", "armadillo", "fandisk", "hand", "kitten", "knot1"};
  std::vector<std::string> methods = {"iires", "o3d-fpfh", "o3d-fpfh-norm", "o3d-icp"};
  int trials = 50, firstTrial = 0, threads = 0;
  bool verbose = false;
  double cut = 0, targetCut = 0, outliers = 0, overlapHint = 0;  // 0 = no cut / no outliers / no hint
  double halves = -1;  // ≥ 0: the two sides of one plane sharing this band (--halves)
  std::vector<std::string> symmetric = {"knot1"};
  std::uint64_t seed = 1;
  std::size_t sourceCount = 5000, targetCount = 30000;
  iires::reg::RegistrationParams reg;  // iires' settings (--samples, --resample, --search, ...); seed per trial
};

/// --resample key=value,...: the registration's resampler settings.
void parseResampleKeys(const std::string& list, iires::ResampleParams& rp) {
  for (const auto& kv : split(list)) {
    const auto eq = kv.find('=');
    const std::string key = kv.substr(0, eq);
    const double v = std::stod(kv.substr(eq + 1));
    if (key == "preprocess") rp.preprocess = v != 0;
    else if (key == "intrinsic") rp.intrinsic = v != 0;
    else if (key == "maxPasses") rp.maxPasses = static_cast<int>(v);
    else if (key == "relaxPerPass") rp.relaxPerPass = static_cast<int>(v);
    else if (key == "maxRelaxIterations") rp.maxRelaxIterations = static_cast<int>(v);
    else if (key == "relaxPatience") rp.relaxPatience = static_cast<int>(v);
    else if (key == "candidateFactor") rp.candidateFactor = v;
    else throw std::invalid_argument("unknown resample key " + key);
  }
}

/// --search key=value,...: the rotation search's settings (lists separated by ':').
void parseSearchKeys(const std::string& list, iires::reg::RegistrationParams& p) {
  iires::reg::RotationSearchParams& sp = p.search;
  for (const auto& kv : split(list)) {
    const auto eq = kv.find('=');
    const std::string key = kv.substr(0, eq);
    if (key == "searchOverlaps" || key == "translationScales") {
      std::vector<double>& values = key == "searchOverlaps" ? p.searchOverlaps : sp.translationScales;
      values.clear();
      std::stringstream ss(kv.substr(eq + 1));
      for (std::string f; std::getline(ss, f, ':');) values.push_back(std::stod(f));
      continue;
    }
    const double v = std::stod(kv.substr(eq + 1));
    if (key == "coarsePoints") sp.coarsePoints = static_cast<std::size_t>(v);
    else if (key == "coarseKeep") sp.coarseKeep = static_cast<std::size_t>(v);
    else if (key == "fullKeep") sp.fullKeep = static_cast<std::size_t>(v);
    else if (key == "minSeparationDeg") sp.minSeparationDeg = v;
    else if (key == "refineLevels") sp.refineLevels = static_cast<int>(v);
    else if (key == "screenIterations") p.screenIterations = static_cast<int>(v);
    else if (key == "searchOverlapExponent") p.searchOverlapExponent = v;
    else if (key == "fitOverlapExponent") p.fitOverlapExponent = v;
    else if (key == "keep") sp.keep = static_cast<std::size_t>(v);
    else if (key == "translationRadius") sp.translationRadius = v;
    else if (key == "translationStep") sp.translationStep = v;
    else if (key == "translationPoints") sp.translationPoints = static_cast<std::size_t>(v);
    else if (key == "translationRefineLevels") sp.translationRefineLevels = static_cast<int>(v);
    else if (key == "fieldCells") sp.fieldCells = static_cast<std::size_t>(v);
    else if (key == "fieldMargin") sp.fieldMargin = v;
    else if (key == "coarseOffsetRadius") sp.coarseOffsetRadius = v;
    else if (key == "coarseOffsetStep") sp.coarseOffsetStep = v;
    else if (key == "openSideShift") sp.openSideShift = v;
    else if (key == "openSideScaleSlope") sp.openSideScaleSlope = v;
    else if (key == "coarseOffsetRefineLevels") sp.coarseOffsetRefineLevels = static_cast<int>(v);
    else throw std::invalid_argument("unknown search key " + key);
  }
}

/// @throws std::invalid_argument for an unknown argument or a missing value.
Options parseOptions(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    if (a == "--models") o.models = split(next());
    else if (a == "--methods") o.methods = split(next());
    else if (a == "--trials") o.trials = std::stoi(next());
    else if (a == "--threads") o.threads = std::stoi(next());
    else if (a == "--seed") o.seed = std::stoull(next());
    else if (a == "--source-count") o.sourceCount = std::stoul(next());
    else if (a == "--target-count") o.targetCount = std::stoul(next());
    else if (a == "--samples") o.reg.samples = std::stoul(next());
    else if (a == "--so3-count") o.reg.so3Count = std::stoul(next());
    else if (a == "--thin") o.reg.maxInputPerSample = std::stoul(next());
    else if (a == "--icp-candidates") o.reg.icpCandidates = std::stoul(next());
    else if (a == "--first-trial") o.firstTrial = std::stoi(next());
    else if (a == "--resample") parseResampleKeys(next(), o.reg.resample);
    else if (a == "--search") parseSearchKeys(next(), o.reg);
    else if (a == "--partial") o.cut = 0.25;
    else if (a == "--cut") o.cut = std::stod(next());
    else if (a == "--target-cut") o.targetCut = std::stod(next());
    else if (a == "--halves") o.halves = std::stod(next());
    else if (a == "--outliers") o.outliers = std::stod(next());
    else if (a == "--overlap") o.overlapHint = std::stod(next());
    else if (a == "--symmetric") o.symmetric = split(next());
    else if (a == "--verbose") o.verbose = true;
    else throw std::invalid_argument("unknown argument " + a);
  }
  if (o.halves > 1) throw std::invalid_argument("--halves: the shared band is a share of the surface, at most 1");
  return o;
}

/// One trial's inputs: the source moved by a random similarity M (with and without its outliers), the target,
/// and the truth T_target_source = M⁻¹.
struct Trial {
  Cloud source, sourceSurface;
  iires::PointCloud target;
  Eigen::Matrix4d truth;
  double diag = 0, scale = 1;
};

Trial makeTrial(const Model& model, const std::string& name, int trial, const Options& o) {
  std::mt19937_64 rng(o.seed * 1000003 + std::hash<std::string>{}(name) % 100000 + trial);
  const bool swap = trial % 2 == 1;  // alternate which cloud is the dense one
  iires::PointCloud src = sampleModel(model, swap ? o.targetCount : o.sourceCount, rng());
  Trial t;
  t.target = sampleModel(model, swap ? o.sourceCount : o.targetCount, rng());
  t.diag = iires::bboxDiagonal(t.target.points);
  if (o.cut > 0) src = cutByPlane(src, o.cut, rng);
  if (o.targetCut > 0) t.target = cutByPlane(t.target, o.targetCut, rng);
  if (o.halves >= 0) halvesByPlane(src, t.target, o.halves, rng);
  const std::size_t sourceSurfacePoints = src.size();
  addOutliers(src, o.outliers, rng);
  addOutliers(t.target, o.outliers, rng);
  std::uniform_real_distribution<double> u(0, 1);
  const Eigen::Matrix3d R = randomRotation(rng);
  t.scale = std::exp(std::log(0.2) + u(rng) * (std::log(5.0) - std::log(0.2)));
  std::normal_distribution<double> g(0, 1);
  const Vec shift = Vec(g(rng), g(rng), g(rng)).normalized() * t.diag * (1 + 2 * u(rng));
  Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
  M.topLeftCorner<3, 3>() = t.scale * R;
  M.topRightCorner<3, 1>() = shift;
  t.truth = M.inverse();
  t.source = transformed(src.points, M);
  // The errors are measured on the source's surface points (its outliers have no true position).
  t.sourceSurface.assign(t.source.begin(), t.source.begin() + static_cast<std::ptrdiff_t>(sourceSurfacePoints));
  return t;
}

/// What one method estimated on one trial.
struct Estimate {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  bool ambiguous = false;
  double overlap = 0;
  std::vector<iires::StageTime> timings;  // iires only
};

/// @throws std::invalid_argument for an unknown method; other exceptions are the method's failures.
Estimate runMethod(const std::string& method, const Trial& t, int trial, const Options& o) {
  Estimate e;
  const std::uint64_t seed = o.seed + static_cast<std::uint64_t>(trial);
  const Cloud& target = t.target.points;
  if (method == "iires" || method == "iires-euler") {
    iires::reg::RegistrationParams p = o.reg;
    p.seed = seed;
    if (o.overlapHint > 0) p.overlap = o.overlapHint;
    if (method == "iires-euler") p.grid = iires::reg::RotationGridType::kEuler;
    iires::PointCloud sc;
    sc.points = t.source;
    const auto r = iires::reg::registerClouds(sc, t.target, p, iires::Execution{o.threads});
    e.T = r.T_target_source;
    e.ambiguous = r.ambiguous;
    e.overlap = r.sourceOverlap;
    e.timings = r.timings;
    if (o.verbose) {
      std::printf("stages");
      for (const auto& st : r.timings) std::printf(" %s=%.3f", st.name.c_str(), st.seconds);
      std::printf(" queries=%zu icp_iterations=%d rank=%zu second_ratio=%.3f\n", r.pointQueries, r.icpIterations,
                  r.candidateRank, r.secondBestScoreRatio);
    }
  } else if (method == "o3d-fpfh") {
    e.T = o3dFpfh(t.source, target, t.diag / 50, seed);
  } else if (method == "o3d-fpfh-norm") {
    e.T = normalisedThen(t.source, target, [&](const Cloud& a, const Cloud& b) {
      return o3dFpfh(a, b, iires::bboxDiagonal(b) / 50, seed);
    });
  } else if (method == "o3d-icp") {
    e.T = o3dIcp(t.source, target, t.diag / 10);
  } else {
    throw std::invalid_argument("unknown method " + method);
  }
  return e;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  try {
    o = parseOptions(argc, argv);
    for (const auto& method : o.methods)
      if (method != "iires" && method != "iires-euler" && method != "o3d-fpfh" && method != "o3d-fpfh-norm" &&
          method != "o3d-icp")
        throw std::invalid_argument("unknown method " + method);
  } catch (const std::exception& ex) {
    std::cerr << ex.what() << "\n";
    return 2;
  }
  const bool partial = o.cut > 0 || o.targetCut > 0 || o.halves >= 0;
  std::printf("config cut=%.3f target_cut=%.3f halves=%.3f outliers=%.3f overlap_hint=%.3f\n", o.cut, o.targetCut,
              o.halves, o.outliers, o.overlapHint);
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  std::map<std::string, Tally> overall;
  for (const auto& name : o.models) {
    const Model model = loadModel(name);
    const Cloud clean = cleanSurface(model);
    const iires::KnnIndex surface(clean);
    const bool bySurface = std::find(o.symmetric.begin(), o.symmetric.end(), name) != o.symmetric.end();
    std::map<std::string, Tally> tally;
    for (int trial = o.firstTrial; trial < o.firstTrial + o.trials; ++trial) {
      const Trial t = makeTrial(model, name, trial, o);
      for (const auto& method : o.methods) {
        const auto t0 = Clock::now();
        const double cpu0 = cpuSeconds();
        Estimate est;
        try {
          est = runMethod(method, t, trial, o);
        } catch (const std::exception& ex) {
          std::cerr << name << " trial " << trial << " " << method << ": " << ex.what() << "\n";
          est.T = Eigen::Matrix4d::Constant(std::nan(""));
        }
        const double secs = std::chrono::duration<double>(Clock::now() - t0).count();
        Errors e = evaluate(est.T, t.truth, t.sourceSurface, surface, t.diag, secs);
        e.cpu = cpuSeconds() - cpu0;
        e.overlap = est.overlap;
        for (Tally* tl : {&tally[method], &overall[method]}) {
          tl->addStages(est.timings);
          tl->add(e, bySurface);
          tl->ambiguous += est.ambiguous;
        }
        if (o.verbose)
          std::printf("trial model=%s method=%s trial=%d scale=%.3f rot_err=%.3f trans_err=%.4f scale_err=%.4f "
                      "surface_err=%.4f ok=%d ok_surface=%d ambiguous=%d overlap=%.3f time_s=%.3f\n",
                      name.c_str(), method.c_str(), trial, t.scale, e.rotDeg, e.trans, e.scale, e.surface,
                      e.ok ? 1 : 0, e.okSurface ? 1 : 0, est.ambiguous ? 1 : 0, est.overlap, secs);
      }
    }
    for (const auto& method : o.methods) print(name, method, tally[method], partial);
  }
  for (const auto& method : o.methods) print("all", method, overall[method], partial);
  return 0;
}
