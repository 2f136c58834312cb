// SPDX-License-Identifier: GPL-3.0-or-later
// Sharp-edge benchmark (issue 5; the paper's Table 4 protocol): iires isotropic and --sharp-edges against CGAL
// WLOP and an EAR-style CGAL pipeline (WLOP → bilateral smoothing → edge-aware upsampling) on the same dense
// sampling of a CAD mesh, N = 10k and 20k. Prints one key=value line per (model, input, N, method):
//   edge_max_per_spacing: max distance from the reference sharp edges (mesh edges with dihedral angle above
//     --dihedral, default 30°, sampled every 0.01 mean spacings) to the nearest output point, over the output's
//     mean NN spacing;
//   err_mean_pct / err_max_pct: distance of the output to the mesh, % of the bounding-box diagonal;
//   cv: NN-spacing cv; cv_sheet: the same along the surface (a neighbour on a facing sheet of the true mesh, as
//     across a plate thinner than the spacing, passed over: iires::sheetNeighbourDistances);
//   free_cv (iires_sharp): cv_sheet of the free samples (the held feature samples excluded).
// --noise S moves the input points along the mesh normal by Gaussian noise of σ = S mean input spacings.
// Usage: sharp_edge_bench MESH INPUT_COUNT N [N ...] [--density-ratio R] [--threads T] [--dihedral DEG]
//        [--noise S] [--methods iires,iires_sharp,cgal_wlop,cgal_ear]   (default: all four) [--dump K]
// --dump K: for the iires methods, print to stderr the K worst spots of the edge coverage (reference-edge points
//   farthest from the output, at least 2 spacings apart), each with its distance to the nearest sharp-edge
//   corner (a vertex of the sharp-edge graph with degree ≠ 2) and the nearest output points (F = a held
//   feature sample), their distance to the edges and to the mesh — to see where and why the edge max is set;
//   and the output point farthest from the mesh (held or free, its distance to the edges and to a corner); with
//   the isotropic method run too, every held sample farther from the mesh than the isotropic run's err_max.
#define CGAL_EIGEN3_ENABLED 1
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/bilateral_smooth_point_set.h>
#include <CGAL/edge_aware_upsample_point_set.h>
#include <CGAL/property_map.h>
#include <CGAL/wlop_simplify_and_regularize_point_set.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <iterator>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "iires/features.hpp"
#include "iires/io.hpp"
#include "iires/knn.hpp"
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
  std::vector<double> angles;  ///< --dump only: each edge's dihedral angle, degrees
};

/// The dihedral angle (degrees) of each of @p edges in @p mesh (the larger one where more than two faces meet).
std::vector<double> edgeAngles(const iires::TriangleMesh& mesh, const std::vector<iires::Segment>& edges) {
  std::map<std::pair<std::tuple<double, double, double>, std::tuple<double, double, double>>, std::vector<Eigen::Vector3d>> faces;
  auto key = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    auto ta = std::make_tuple(a.x(), a.y(), a.z()), tb = std::make_tuple(b.x(), b.y(), b.z());
    return ta < tb ? std::make_pair(ta, tb) : std::make_pair(tb, ta);
  };
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d &a = mesh.vertices[t[0]], &b = mesh.vertices[t[1]], &c = mesh.vertices[t[2]];
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    faces[key(a, b)].push_back(n);
    faces[key(b, c)].push_back(n);
    faces[key(c, a)].push_back(n);
  }
  std::vector<double> out;
  for (const auto& e : edges) {
    const auto& ns = faces[key(e[0], e[1])];
    double worst = 0;
    for (std::size_t a = 0; a < ns.size(); ++a)
      for (std::size_t b = a + 1; b < ns.size(); ++b)
        worst = std::max(worst, std::acos(std::clamp(ns[a].dot(ns[b]), -1.0, 1.0)) * 180 / M_PI);
    out.push_back(worst);
  }
  return out;
}

/// Each of @p pts's distance to its nearest neighbour on its own sheet of the true mesh.
std::vector<double> sheetSpacing(const std::vector<Eigen::Vector3d>& pts, const Reference& ref) {
  std::vector<Eigen::Vector3d> normals(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) normals[i] = ref.mesh->normal(pts[i]);
  return iires::sheetNeighbourDistances(pts, normals);
}

/// One key=value line of a method's output @p pts; @p nearest: sheetSpacing() of pts.
void report(const std::string& prefix, const std::string& method, const std::vector<Eigen::Vector3d>& pts,
            double seconds, const Reference& ref, const std::vector<double>& nearest, const std::string& extra = "") {
  const auto spacing = iires::spacingStats(pts);
  const auto err = ref.mesh->distances(pts);
  const auto edge = iires::coverage(iires::sampleSegments(ref.edges, 0.01 * spacing.mean), pts);
  std::printf(
      "%s method=%s points=%zu time_s=%.2f cv=%.4f cv_sheet=%.4f err_mean_pct=%.4f err_max_pct=%.4f "
      "edge_max_per_spacing=%.3f edge_mean_per_spacing=%.3f%s\n",
      prefix.c_str(), method.c_str(), pts.size(), seconds, spacing.cv, iires::summariseSpacing(nearest).cv,
      100 * err.mean / ref.mesh->diagonal(), 100 * err.max / ref.mesh->diagonal(), edge.max / spacing.mean,
      edge.mean / spacing.mean, extra.c_str());
  std::fflush(stdout);
}

void report(const std::string& prefix, const std::string& method, const std::vector<Eigen::Vector3d>& pts,
            double seconds, const Reference& ref) {
  report(prefix, method, pts, seconds, ref, sheetSpacing(pts, ref));
}

/// " feature_samples=K free_cv=C": the held samples' count and the along-the-surface NN-spacing cv of the
/// others (@p nearest: every output point's sheetSpacing(), its nearest neighbour on its own sheet).
std::string freeSpacing(const std::vector<double>& nearest, const std::vector<std::uint32_t>& fixedIndices) {
  std::vector<char> held(nearest.size(), 0);
  for (std::uint32_t i : fixedIndices) held[i] = 1;
  std::vector<double> free;
  for (std::size_t i = 0; i < nearest.size(); ++i)
    if (!held[i]) free.push_back(nearest[i]);
  char buf[96];
  std::snprintf(buf, sizeof buf, " feature_samples=%zu free_cv=%.4f", fixedIndices.size(),
                iires::summariseSpacing(free).cv);
  return buf;
}

/// The --dump report (see the header): the @p k worst spots of the edge coverage of @p pts;
/// @p fixedIndices are the held samples; @p isoMax (≥ 0: the isotropic run's err_max, absolute) lists the held
/// samples farther than it from the mesh.
void dumpWorst(const std::vector<Eigen::Vector3d>& pts, const std::vector<std::uint32_t>& fixedIndices,
               const Reference& ref, int k, double isoMax) {
  std::vector<char> held(pts.size(), 0);
  for (std::uint32_t i : fixedIndices) held[i] = 1;
  const double sp = iires::spacingStats(pts).mean;
  const auto samples = iires::sampleSegments(ref.edges, 0.01 * sp);
  const iires::KnnIndex index(pts);
  std::vector<std::pair<double, std::size_t>> dist(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    double d2 = 0;
    index.nearest(samples[i], &d2);
    dist[i] = {std::sqrt(d2), i};
  }
  std::sort(dist.begin(), dist.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  // Corners of the sharp-edge graph: vertices of degree ≠ 2, or where the two edges turn by more than 30°.
  std::map<std::tuple<double, double, double>, std::vector<Eigen::Vector3d>> out;
  for (const auto& e : ref.edges)
    for (int v = 0; v < 2; ++v) out[{e[v].x(), e[v].y(), e[v].z()}].push_back((e[1 - v] - e[v]).normalized());
  std::vector<Eigen::Vector3d> corners;
  for (const auto& [v, dirs] : out)
    if (dirs.size() != 2 || -dirs[0].dot(dirs[1]) < std::cos(30.0 * M_PI / 180))
      corners.emplace_back(std::get<0>(v), std::get<1>(v), std::get<2>(v));
  auto toCorner = [&](const Eigen::Vector3d& p) {  // "inf": a closed edge without corners
    double d = std::numeric_limits<double>::infinity();
    for (const auto& c : corners) d = std::min(d, (c - p).norm());
    return d;
  };
  {  // the output point farthest from the mesh (it sets err_max)
    std::size_t worst = 0;
    double worstD = -1;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const double d = ref.mesh->distances({pts[i]}).max;
      if (d > worstD) worstD = d, worst = i;
    }
    const Eigen::Vector3d& p = pts[worst];
    std::fprintf(stderr, "  err max %.4f %% of the diagonal (%.3f sp) at (%.5f %.5f %.5f): %s, %.2f sp from the edges, %.2f sp from a corner\n",
                 100 * worstD / ref.mesh->diagonal(), worstD / sp, p.x(), p.y(), p.z(), held[worst] ? "held" : "free",
                 iires::distanceToSegments(p, ref.edges) / sp, toCorner(p) / sp);
  }
  if (isoMax >= 0) {  // the held samples that set err_max above the isotropic run's
    std::size_t above = 0;
    for (std::uint32_t i : fixedIndices) {
      const Eigen::Vector3d& p = pts[i];
      const double d = ref.mesh->distance(p);
      if (d <= isoMax) continue;
      ++above;
      std::fprintf(stderr, "  held above the isotropic err_max: %.4f %% at (%.5f %.5f %.5f), %.2f sp from the edges, %.2f sp from a corner\n",
                   100 * d / ref.mesh->diagonal(), p.x(), p.y(), p.z(), iires::distanceToSegments(p, ref.edges) / sp,
                   toCorner(p) / sp);
    }
    std::fprintf(stderr, "  %zu held samples above the isotropic err_max (%.4f %%)\n", above,
                 100 * isoMax / ref.mesh->diagonal());
  }
  std::vector<Eigen::Vector3d> shown;
  for (const auto& [d, i] : dist) {
    if (static_cast<int>(shown.size()) >= k || d < 0.3 * sp) break;
    const Eigen::Vector3d& q = samples[i];
    bool near = false;
    for (const auto& s : shown) near = near || (s - q).norm() < 2 * sp;
    if (near) continue;
    shown.push_back(q);
    double corner = std::numeric_limits<double>::infinity();  // "inf": a closed edge without corners
    Eigen::Vector3d cp = q;
    for (const auto& c : corners)
      if ((c - q).norm() < corner) corner = (c - q).norm(), cp = c;
    double dihedral = 0;  // of the reference edge the spot lies on
    for (std::size_t e = 0; e < ref.edges.size(); ++e)
      if (iires::distanceToSegments(q, {ref.edges[e]}) < 1e-9 * sp) dihedral = std::max(dihedral, ref.angles[e]);
    std::fprintf(stderr, "  worst %.3f sp at (%.5f %.5f %.5f), dihedral %.0f deg, nearest edge corner %.2f sp; near:",
                 d / sp, q.x(), q.y(), q.z(), dihedral, corner / sp);
    std::vector<std::uint32_t> idx;
    std::vector<double> d2;
    index.knn(q, 4, idx, d2);
    for (std::size_t t = 0; t < idx.size(); ++t) {
      const Eigen::Vector3d& p = pts[idx[t]];
      const double toMesh = ref.mesh->distances({p}).max;
      std::fprintf(stderr, " [%s %.2f sp, edge %.2f, mesh %.3f, corner %.2f]", held[idx[t]] ? "F" : "free",
                   std::sqrt(d2[t]) / sp, iires::distanceToSegments(p, ref.edges) / sp, toMesh / sp,
                   (p - cp).norm() / sp);
    }
    std::fprintf(stderr, "\n");
    // The held samples within 3 spacings of the spot along its edge: (position along the edge, off the edge).
    Eigen::Vector3d dir = Eigen::Vector3d::UnitX();
    for (const auto& e : ref.edges)
      if (iires::distanceToSegments(q, {e}) < 1e-9 * sp && (e[1] - e[0]).norm() > 0) dir = (e[1] - e[0]).normalized();
    index.radius(q, 3 * sp, idx, d2);
    std::vector<std::pair<double, double>> along;
    for (std::uint32_t j : idx)
      if (held[j]) along.emplace_back((pts[j] - q).dot(dir) / sp, iires::distanceToSegments(pts[j], ref.edges) / sp);
    std::sort(along.begin(), along.end());
    std::fprintf(stderr, "    held along the edge (sp, off):");
    for (const auto& [t, off] : along) std::fprintf(stderr, " %.2f/%.2f", t, off);
    std::fprintf(stderr, "\n");
  }
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
  int dump = 0;
  double dihedral = 30.0, noise = 0.0;
  const iires::bench::GridArgs args = iires::bench::parseGridArgs(
      argc, argv, 1.0,
      "sharp_edge_bench MESH INPUT_COUNT N [N ...] [--density-ratio R] [--threads T] [--dihedral DEG] "
      "[--noise S] [--methods iires,iires_sharp,cgal_wlop,cgal_ear] [--dump K]",
      [&](const std::string& arg, int& a) {
        if (a + 1 >= argc) return false;
        if (arg == "--dump") dump = std::stoi(argv[++a]);
        else if (arg == "--dihedral") dihedral = std::stod(argv[++a]);
        else if (arg == "--noise") noise = std::stod(argv[++a]);
        else if (arg == "--methods") methods = argv[++a];
        else return false;
        return true;
      });
  const std::size_t inputCount = args.inputCount;
  const double ratio = args.ratio;
  const int threads = args.threads;
  const iires::TriangleMesh mesh = iires::readMesh(args.meshPath);
  const iires::PointCloud cloud = iires::bench::scanLikeSampling(mesh, inputCount, ratio, noise);
  const iires::MeshDistance distance(mesh);
  Reference ref{&distance, iires::sharpMeshEdges(mesh, dihedral), {}};
  if (dump > 0) ref.angles = edgeAngles(mesh, ref.edges);
  const std::string name = args.name();
  auto run = [&](const std::string& method) { return ("," + methods + ",").find("," + method + ",") != std::string::npos; };
  const std::vector<Point> cgalInput = toCgal(cloud.points);

  for (std::size_t n : args.counts) {
    char buf[160];
    std::snprintf(buf, sizeof buf, "model=%s input=%zu density_ratio=%g noise=%g dihedral=%g N=%zu", name.c_str(),
                  inputCount, ratio, noise, dihedral, n);
    const std::string prefix = buf;
    double isoMax = -1;  // the isotropic run's err_max (absolute), for --dump
    for (const bool sharp : {false, true}) {
      if (!run(sharp ? "iires_sharp" : "iires")) continue;
      iires::ResampleParams p;
      p.targetCount = n;
      p.sharpEdges = sharp;
      const double t = now();
      const auto r = iires::resample(cloud, p, iires::Execution{threads});
      const double seconds = now() - t;
      const std::vector<double> nearest = sheetSpacing(r.cloud.points, ref);  // once for both summaries
      report(prefix, sharp ? "iires_sharp" : "iires", r.cloud.points, seconds, ref, nearest,
             sharp ? freeSpacing(nearest, r.fixedIndices) : "");
      if (dump > 0 && !sharp) isoMax = ref.mesh->distances(r.cloud.points, threads).max;
      if (dump > 0) dumpWorst(r.cloud.points, r.fixedIndices, ref, dump, sharp ? isoMax : -1);
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
