// SPDX-License-Identifier: GPL-3.0-or-later
// denoise_bench: iires pre-processing (outliers eq. 4–5 + MLS denoising eq. 1–3) against CGAL's
// jet_smooth_point_set and bilateral_smooth_point_set, side by side on the same inputs (paper §6.1 protocol).
//
// For each model: a dense uniform sampling of the mesh (sampleMesh, face normals), l = mean distance to the
// 6 nearest samples, then per case: offsets along the true normal of magnitude uniform in [0, a·l] (sign
// random: --sign symmetric, the default; or always + with --sign onesided, which is sampleMesh's convention
// and leaves a mean offset a·l/2 that no smoother can remove), optionally a share of outliers moved ±[3, 6]·l
// along the normal. Every method gets the same noisy cloud with the same normals (--normals estimated, the
// default: PCA + MST from iires::estimateNormals on the noisy cloud, as a scan would have; or sampled: the
// true face normals). Metric: mean distance of the output to the reference mesh / bounding-box diagonal; on
// models with sharp edges (dihedral angle > 45°) also for the points whose clean position is within 2·l of
// one.
//
// Output: one key=value line per (model, case, method), then a speed line (200k points, --threads).
#define CGAL_EIGEN3_ENABLED 1
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/bilateral_smooth_point_set.h>
#include <CGAL/jet_smooth_point_set.h>
#include <CGAL/property_map.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <map>
#include <numeric>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "iires/denoise.hpp"
#include "iires/features.hpp"
#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/metrics.hpp"
#include "iires/normals.hpp"
#include "iires/outliers.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/preprocess.hpp"
#include "iires/sampling.hpp"

#include "bench_util.hpp"

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CPoint = Kernel::Point_3;
using CVector = Kernel::Vector_3;
using PointNormal = std::pair<CPoint, CVector>;
using Clock = std::chrono::steady_clock;

double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Options {
  std::vector<std::string> models{"bunny00", "armadillo", "hand", "fandisk"};
  std::size_t count = 100000;
  double outlierFraction = 0.02;
  bool symmetric = true;
  bool estimatedNormals = true;
  std::size_t speedCount = 200000;
  int threads = 2;
  int cgalK = 24;
  std::vector<double> noises{0.33, 0.66};
  iires::PreprocessParams pre;  ///< iires settings (defaults unless overridden by --dn-* flags)
  bool cgal = true;
};

using iires::bench::split;

struct Error {
  double mean = 0, edge = 0;
};

Error measure(const iires::MeshDistance& md, const std::vector<Eigen::Vector3d>& pts,
              const std::vector<std::uint8_t>& nearEdge, int threads) {
  std::vector<double> d(pts.size());
  iires::parallelFor(pts.size(), threads, [&](std::size_t i) { d[i] = md.distance(pts[i]); });
  Error e;
  double edgeSum = 0;
  std::size_t edgeCount = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    e.mean += d[i];
    if (!nearEdge.empty() && nearEdge[i]) edgeSum += d[i], ++edgeCount;
  }
  e.mean /= static_cast<double>(pts.size());
  e.edge = edgeCount ? edgeSum / static_cast<double>(edgeCount) : 0.0;
  return e;
}

std::vector<PointNormal> toCgal(const iires::PointCloud& c) {
  std::vector<PointNormal> out(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    out[i].first = CPoint(c.points[i].x(), c.points[i].y(), c.points[i].z());
    if (c.hasNormals()) out[i].second = CVector(c.normals[i].x(), c.normals[i].y(), c.normals[i].z());
  }
  return out;
}

std::vector<Eigen::Vector3d> fromCgal(const std::vector<PointNormal>& c) {
  std::vector<Eigen::Vector3d> out(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) out[i] = {c[i].first.x(), c[i].first.y(), c[i].first.z()};
  return out;
}

/// @return false (after printing the usage) on an unknown argument. @throws std::invalid_argument for a missing
/// value.
bool parseOptions(int argc, char** argv, Options& opt) {
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    auto value = [&]() -> std::string {
      if (a + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      return argv[++a];
    };
    if (arg == "--models") opt.models = split(value());
    else if (arg == "--count") opt.count = std::stoul(value());
    else if (arg == "--outliers") opt.outlierFraction = std::stod(value());
    else if (arg == "--sign") opt.symmetric = value() != "onesided";
    else if (arg == "--normals") opt.estimatedNormals = value() != "sampled";
    else if (arg == "--speed-count") opt.speedCount = std::stoul(value());
    else if (arg == "--threads") opt.threads = std::stoi(value());
    else if (arg == "--dn-k") opt.pre.denoise.neighbours = std::stoi(value());
    else if (arg == "--dn-kernel") opt.pre.denoise.kernelNeighbour = std::stoi(value());
    else if (arg == "--dn-iterations") opt.pre.denoise.iterations = std::stoi(value());
    else if (arg == "--dn-sharpness") opt.pre.denoise.sharpnessAngle = std::stod(value());
    else if (arg == "--dn-degree") opt.pre.denoise.degree = std::stoi(value());
    else if (arg == "--no-cgal") opt.cgal = false;
    else if (arg == "--noises") {
      opt.noises.clear();
      for (const auto& s : split(value())) opt.noises.push_back(std::stod(s));
    } else {
      std::fprintf(
          stderr,
          "usage: denoise_bench [--models a,b] [--count N] [--outliers F] [--sign symmetric|onesided]\n"
          "       [--normals estimated|sampled] [--noises 0.33,0.66] [--speed-count N] [--threads T]\n");
      return false;
    }
  }
  return true;
}

/// One model's clean sampling, its spacing l and which points lie within 2·l of a sharp edge (dihedral > 45°).
struct ModelCase {
  std::string name;
  iires::TriangleMesh mesh;
  iires::PointCloud clean;
  double l = 0;
  std::vector<std::uint8_t> nearEdge;  // empty: no sharp edge
  std::size_t edgePoints = 0;
};

ModelCase loadCase(const std::string& model, const Options& opt) {
  ModelCase c;
  c.name = model;
  c.mesh = iires::readMesh(std::string(IIRES_DATA_DIR) + "/meshes/" + model + ".off");
  iires::MeshSamplingParams sp;
  sp.count = opt.count;
  sp.seed = 7;
  c.clean = iires::sampleMesh(c.mesh, sp);
  c.l = iires::meanNeighbourSpacing(c.clean.points, 6, opt.threads);
  const auto edges = iires::sampleSegments(iires::sharpMeshEdges(c.mesh, 45.0), 0.25 * c.l);
  if (!edges.empty()) {
    const iires::KnnIndex edgeTree(edges);
    c.nearEdge.assign(c.clean.size(), 0);
    for (std::size_t i = 0; i < c.clean.size(); ++i) {
      double d2 = 0;
      edgeTree.nearest(c.clean.points[i], &d2);
      c.nearEdge[i] = std::sqrt(d2) <= 2.0 * c.l ? 1 : 0;
      c.edgePoints += c.nearEdge[i];
    }
  }
  return c;
}

/// The noisy input: offsets along the true normal of magnitude uniform in [0, noise·l] (random sign unless
/// one-sided), and a share of outliers moved ±[3, 6]·l along it (marked in @p injected).
iires::PointCloud noisyInput(const ModelCase& c, double noise, double outlierFraction, bool symmetric,
                             std::vector<std::uint8_t>& injected) {
  const std::size_t n = c.clean.size();
  std::mt19937_64 rng(1000 + static_cast<std::uint64_t>(noise * 100) + (outlierFraction > 0 ? 1 : 0));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  iires::PointCloud noisy = c.clean;
  injected.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    const double sign = symmetric && unit(rng) < 0.5 ? -1.0 : 1.0;
    noisy.points[i] += sign * unit(rng) * noise * c.l * c.clean.normals[i];
  }
  const auto outliers = static_cast<std::size_t>(std::llround(outlierFraction * static_cast<double>(n)));
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  for (std::size_t k = 0; k < outliers; ++k) {
    std::swap(order[k], order[std::uniform_int_distribution<std::size_t>(k, n - 1)(rng)]);
    const std::size_t i = order[k];
    injected[i] = 1;
    const double sign = unit(rng) < 0.5 ? -1.0 : 1.0;
    noisy.points[i] = c.clean.points[i] + sign * (3.0 + 3.0 * unit(rng)) * c.l * c.clean.normals[i];
  }
  return noisy;
}

/// iires' pre-processing (outliers pulled, then MLS denoising) on @p noisy, with the outlier detection's recall
/// and false-positive rate (a detection-only run of the same rule) appended to the report line.
template <typename Report>
void runIires(const ModelCase& c, const iires::PointCloud& noisy, const std::vector<std::uint8_t>& injected,
              double normalSeconds, const Options& opt, const iires::MeshDistance& md, Report&& report) {
  const std::size_t n = c.clean.size();
  const iires::PreprocessParams& pp = opt.pre;
  const iires::Execution exec{opt.threads};
  const auto t0 = Clock::now();
  const iires::PreprocessResult r = iires::preprocess(noisy, pp, exec);
  const double seconds = since(t0);
  iires::OutlierParams op = pp.outliers;
  op.mode = iires::OutlierMode::kKeep;
  const iires::OutlierResult det = iires::processOutliers(noisy, op, exec);
  const auto outliers = static_cast<std::size_t>(std::count(injected.begin(), injected.end(), 1));
  std::size_t truePos = 0;
  for (std::uint32_t i : det.outliers) truePos += injected[i];
  const std::size_t falsePos = det.found - truePos;
  std::size_t within = 0;
  for (std::size_t i = 0; i < n; ++i)
    if (injected[i] && md.distance(r.cloud.points[i]) <= c.l) ++within;
  std::ostringstream extra;
  extra.precision(4);
  extra << " found=" << det.found << " injected=" << outliers;
  if (outliers) extra << " recall=" << double(truePos) / double(outliers);
  extra << " false_pos_rate=" << double(falsePos) / double(n - outliers);
  if (outliers) extra << " pulled_within_l=" << double(within) / double(outliers);
  extra << " normals_s=" << normalSeconds;
  report("iires", r.cloud.points, seconds, extra.str());
}

/// One model, every noise level (with and without outliers): the input, iires, CGAL jet and bilateral smoothing.
void runModel(const ModelCase& c, const Options& opt) {
  const iires::MeshDistance md(c.mesh);
  const double diag = md.diagonal(), l = c.l;
  const int T = opt.threads;
  std::printf("model=%s points=%zu l=%.6g l_over_diag=%.6g edge_points=%zu\n", c.name.c_str(), c.clean.size(), l,
              l / diag, c.edgePoints);
  std::fflush(stdout);
  for (double noise : opt.noises) {
    for (double outlierFraction : {0.0, opt.outlierFraction}) {
      std::vector<std::uint8_t> injected;
      iires::PointCloud noisy = noisyInput(c, noise, outlierFraction, opt.symmetric, injected);
      double normalSeconds = 0;
      if (opt.estimatedNormals) {
        const auto t0 = Clock::now();
        noisy.normals = iires::estimateNormals(noisy.points, {}, iires::Execution{T});
        normalSeconds = since(t0);
      }
      const std::string tag = "model=" + c.name + " noise=" + std::to_string(noise).substr(0, 4) +
                              " outliers=" + std::to_string(outlierFraction).substr(0, 5);
      auto report = [&](const char* method, const std::vector<Eigen::Vector3d>& pts, double seconds,
                        const std::string& extra) {
        const Error e = measure(md, pts, c.nearEdge, T);
        std::printf("%s method=%s mean_err_diag=%.4e mean_err_l=%.4f", tag.c_str(), method, e.mean / diag,
                    e.mean / l);
        if (c.edgePoints) std::printf(" edge_err_diag=%.4e edge_err_l=%.4f", e.edge / diag, e.edge / l);
        std::printf(" time_s=%.3f%s\n", seconds, extra.c_str());
        std::fflush(stdout);
      };
      report("input", noisy.points, 0.0, "");
      runIires(c, noisy, injected, normalSeconds, opt, md, report);
      if (opt.cgal) {
        // CGAL jet smoothing, k = 24, documented defaults (degree_fitting 2, degree_monge 2).
        auto pts = toCgal(noisy);
        auto t0 = Clock::now();
        CGAL::jet_smooth_point_set<CGAL::Sequential_tag>(
            pts, static_cast<unsigned>(opt.cgalK),
            CGAL::parameters::point_map(CGAL::First_of_pair_property_map<PointNormal>()));
        report("cgal_jet", fromCgal(pts), since(t0), "");
        // CGAL bilateral smoothing, k = 24, documented defaults (sharpness_angle 30°), one call.
        pts = toCgal(noisy);
        t0 = Clock::now();
        CGAL::bilateral_smooth_point_set<CGAL::Sequential_tag>(
            pts, static_cast<unsigned>(opt.cgalK),
            CGAL::parameters::point_map(CGAL::First_of_pair_property_map<PointNormal>())
                .normal_map(CGAL::Second_of_pair_property_map<PointNormal>()));
        report("cgal_bilateral", fromCgal(pts), since(t0), "");
      }
      if (opt.outlierFraction <= 0) break;
    }
  }
}

/// Speed: --speed-count points of bunny00 with 0.33·l noise and 2 % outliers, no normals; denoising and the full
/// pre-processing on --threads cores, wall and process CPU time (on a shared machine CPU / threads is the
/// quiet-machine wall time).
void runSpeed(const Options& opt) {
  const int T = opt.threads;
  const iires::TriangleMesh mesh = iires::readMesh(std::string(IIRES_DATA_DIR) + "/meshes/bunny00.off");
  iires::MeshSamplingParams sp;
  sp.count = opt.speedCount;
  sp.seed = 9;
  const iires::PointCloud clean = iires::sampleMesh(mesh, sp);
  const double l = iires::meanNeighbourSpacing(clean.points, 6, T);
  sp.noise = 0.33 * l;
  sp.gaussianNoise = false;
  sp.outlierFraction = 0.02;
  sp.outlierMin = 3 * l;
  sp.outlierMax = 6 * l;
  iires::PointCloud noisy = iires::sampleMesh(mesh, sp);
  noisy.normals.clear();
  const iires::Execution exec{T};
  auto run = [&](const char* what, auto&& fn) {
    const auto t0 = Clock::now();
    const std::clock_t c0 = std::clock();
    fn();
    std::printf(" %s_s=%.3f %s_cpu_s=%.3f", what, since(t0), what,
                static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
  };
  std::printf("speed points=%zu threads=%d", noisy.size(), T);
  iires::DenoiseResult d;
  run("denoise", [&] { d = iires::denoise(noisy, opt.pre.denoise, exec); });
  std::printf(" neighbours_s=%.3f sweeps_s=%.3f orient_s=%.3f iterations=%d", d.neighbourSeconds, d.sweepSeconds,
              d.orientSeconds, d.iterations);
  iires::PreprocessResult r;
  run("preprocess", [&] { r = iires::preprocess(noisy, opt.pre, exec); });
  std::printf(" outliers_s=%.3f denoise_in_preprocess_s=%.3f\n", r.outlierSeconds, r.denoiseSeconds);
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parseOptions(argc, argv, opt)) return 2;
  std::printf("config count=%zu outliers=%.3f sign=%s normals=%s threads=%d cgal_k=%d\n", opt.count,
              opt.outlierFraction, opt.symmetric ? "symmetric" : "onesided",
              opt.estimatedNormals ? "estimated" : "sampled", opt.threads, opt.cgalK);
  for (const std::string& model : opt.models) runModel(loadCase(model, opt), opt);
  if (opt.speedCount > 0) runSpeed(opt);
  return 0;
}
