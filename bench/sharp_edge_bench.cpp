// Sharp-edge benchmark (issue 5; the paper's Table 4 protocol): iires isotropic and --sharp-edges against CGAL
// WLOP and an EAR-style CGAL pipeline (WLOP → bilateral smoothing → edge-aware upsampling) on the same dense
// sampling of a CAD mesh, N = 10k and 20k. Prints one key=value line per (model, input, N, method):
//   edge_max_per_spacing: max distance from the reference sharp edges (mesh edges with dihedral angle > 45°,
//     sampled every 0.01 mean spacings) to the nearest output point, over the output's mean NN spacing;
//   err_mean_pct / err_max_pct: distance of the output to the mesh, % of the bounding-box diagonal.
// Usage: sharp_edge_bench MESH INPUT_COUNT N [N ...] [--density-ratio R] [--threads T]
//        [--methods iires,iires_sharp,cgal_wlop,cgal_ear]   (default: all four)
#define CGAL_EIGEN3_ENABLED 1
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/bilateral_smooth_point_set.h>
#include <CGAL/edge_aware_upsample_point_set.h>
#include <CGAL/property_map.h>
#include <CGAL/wlop_simplify_and_regularize_point_set.h>

#include <chrono>
#include <cstdio>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "iires/features.hpp"
#include "iires/io.hpp"
#include "iires/metrics.hpp"
#include "iires/normals.hpp"
#include "iires/resample.hpp"
#include "iires/sampling.hpp"

#include "bench_util.hpp"

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using PointNormal = std::pair<Point, Vector>;

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

struct Reference {
  const iires::MeshDistance* mesh;
  std::vector<iires::Segment> edges;
};

void report(const std::string& prefix, const std::string& method, const std::vector<Eigen::Vector3d>& pts,
            double seconds, const Reference& ref, const std::string& extra = "") {
  const auto spacing = iires::spacingStats(pts);
  const auto err = ref.mesh->distances(pts);
  const auto edge = iires::coverage(iires::sampleSegments(ref.edges, 0.01 * spacing.mean), pts);
  std::printf(
      "%s method=%s points=%zu time_s=%.2f cv=%.4f err_mean_pct=%.4f err_max_pct=%.4f edge_max_per_spacing=%.3f "
      "edge_mean_per_spacing=%.3f%s\n",
      prefix.c_str(), method.c_str(), pts.size(), seconds, spacing.cv, 100 * err.mean / ref.mesh->diagonal(),
      100 * err.max / ref.mesh->diagonal(), edge.max / spacing.mean, edge.mean / spacing.mean, extra.c_str());
  std::fflush(stdout);
}

std::vector<Point> toCgal(const std::vector<Eigen::Vector3d>& pts) {
  std::vector<Point> out;
  out.reserve(pts.size());
  for (const auto& p : pts) out.emplace_back(p.x(), p.y(), p.z());
  return out;
}

std::vector<Eigen::Vector3d> fromCgal(const std::vector<Point>& pts) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(pts.size());
  for (const auto& p : pts) out.emplace_back(p.x(), p.y(), p.z());
  return out;
}

/// CGAL WLOP with its documented defaults (neighbor radius 8 × average spacing, 35 iterations) down to n points.
std::vector<Point> wlop(const std::vector<Point>& input, std::size_t n) {
  std::vector<Point> pts = input, out;
  // WLOP keeps ⌊|input|·percentage/100⌋ points: ask for a hair more so rounding does not lose one.
  const double pct = 100.0 * (static_cast<double>(n) + 0.5) / static_cast<double>(pts.size());
  CGAL::wlop_simplify_and_regularize_point_set<CGAL::Parallel_if_available_tag>(
      pts, std::back_inserter(out), CGAL::parameters::select_percentage(pct));
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::string methods = "iires,iires_sharp,cgal_wlop,cgal_ear";
  const iires::bench::GridArgs args = iires::bench::parseGridArgs(
      argc, argv, 1.0,
      "sharp_edge_bench MESH INPUT_COUNT N [N ...] [--density-ratio R] [--threads T] "
      "[--methods iires,iires_sharp,cgal_wlop,cgal_ear]",
      [&](const std::string& arg, int& a) {
        if (arg != "--methods" || a + 1 >= argc) return false;
        methods = argv[++a];
        return true;
      });
  const std::size_t inputCount = args.inputCount;
  const double ratio = args.ratio;
  const int threads = args.threads;
  const iires::TriangleMesh mesh = iires::readMesh(args.meshPath);
  const iires::PointCloud cloud = iires::bench::scanLikeSampling(mesh, inputCount, ratio);
  const iires::MeshDistance distance(mesh);
  const Reference ref{&distance, iires::sharpMeshEdges(mesh, 45.0)};
  const std::string name = args.name();
  auto run = [&](const std::string& method) { return ("," + methods + ",").find("," + method + ",") != std::string::npos; };
  const std::vector<Point> cgalInput = toCgal(cloud.points);

  for (std::size_t n : args.counts) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "model=%s input=%zu density_ratio=%g N=%zu", name.c_str(), inputCount, ratio, n);
    const std::string prefix = buf;
    for (const bool sharp : {false, true}) {
      if (!run(sharp ? "iires_sharp" : "iires")) continue;
      iires::ResampleParams p;
      p.targetCount = n;
      p.threads = threads;
      p.sharpEdges = sharp;
      const double t = now();
      const auto r = iires::resample(cloud, p);
      report(prefix, sharp ? "iires_sharp" : "iires", r.cloud.points, now() - t, ref,
             sharp ? " feature_samples=" + std::to_string(r.featureSamples) : "");
    }
    double t = now();
    if (run("cgal_wlop")) {
      const std::vector<Point> simplified = wlop(cgalInput, n);
      report(prefix, "cgal_wlop", fromCgal(simplified), now() - t, ref);
    }
    if (!run("cgal_ear")) continue;
    // EAR-style (Huang et al. 2013, CGAL's building blocks): WLOP to N/2, PCA + MST normals, bilateral
    // smoothing (sharpness 30°, k = 24), then edge-aware upsampling back to N (sharpness 30°, defaults).
    t = now();
    const std::vector<Point> half = wlop(cgalInput, n / 2);
    const std::vector<Eigen::Vector3d> halfPts = fromCgal(half);
    const std::vector<Eigen::Vector3d> halfNrm = iires::estimateNormals(halfPts);
    std::vector<PointNormal> pn;
    for (std::size_t i = 0; i < half.size(); ++i) pn.emplace_back(half[i], Vector(halfNrm[i].x(), halfNrm[i].y(), halfNrm[i].z()));
    const auto pmap = CGAL::First_of_pair_property_map<PointNormal>();
    const auto nmap = CGAL::Second_of_pair_property_map<PointNormal>();
    CGAL::bilateral_smooth_point_set<CGAL::Parallel_if_available_tag>(
        pn, 24, CGAL::parameters::point_map(pmap).normal_map(nmap).sharpness_angle(30.0));
    std::vector<PointNormal> added;
    CGAL::edge_aware_upsample_point_set<CGAL::Parallel_if_available_tag>(
        pn, std::back_inserter(added),
        CGAL::parameters::point_map(pmap).normal_map(nmap).sharpness_angle(30.0).number_of_output_points(n));
    std::vector<Point> ear;
    for (const auto& x : pn) ear.push_back(x.first);
    for (const auto& x : added) ear.push_back(x.first);
    report(prefix, "cgal_ear", fromCgal(ear), now() - t, ref);
  }
  return 0;
}
