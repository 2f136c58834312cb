// SPDX-License-Identifier: GPL-3.0-or-later
// reconstruct_bench: the side-by-side reconstruction table (issues 7 and 20). For each model: a dense sampling of
// the true mesh (area-uniform, or with a density gradient along the longest axis) without normals, like a scan —
// or a real point set of the corpus as it is — → isotropic resampling to N (iires) → the same N points meshed by
//   local: the whole iires pipeline from the dense input, as iires-reconstruct runs it (its resampling is
//     deterministic, so its points are the ones the others get);
//   advancing-front: CGAL's advancing front on those points;   bpa / poisson: Open3D ball pivoting / Poisson;
//   input-advancing-front: CGAL's advancing front on the dense input itself (no resampling; run once per model,
//     on the first N only, since it does not depend on N);
// each method in a child process (Debian's Open3D Poisson aborts on some models), printing one key=value line:
// validity (self-intersecting face pairs, non-manifold edges/vertices, orientation, closure, genus per the quality
// report, boundary loops), triangle shape (Q, angles), both Hausdorff directions to the TRUE mesh (real point sets:
// to the input cloud), the share of the input farther than 2 mesh spacings from the mesh, and time (meshing only,
// after resampling; for local also the validity stage's share of it).
//
// Usage: reconstruct_bench [--data DIR] [--models a,b,c] [--points kitten.xyz,hippo1.ply] [--counts 10000,30000]
//                          [--point-counts 5000] [--dense 100000] [--density-ratio 1] [--methods local,
//                          advancing-front,bpa,poisson,input-advancing-front] [--threads T] [--seed S] [--dump DIR]
// Issue 20's grid: --models closed --points real --dense 200000 --counts 10000,30000 --density-ratio 1 (then 4)
// --methods local,advancing-front,bpa,poisson,input-advancing-front.
// --models: meshes/NAME.off of the data directory ("closed": the closed 2-manifold corpus; "none": no meshes;
// "hand-vertices": the 1,197 vertices of CGAL's hand mesh as the input); --points: points_3/FILE inputs
// ("real": the corpus's real point sets; "none", the default: none), resampled to each of --point-counts.
// --seed: the sampleMesh seed of the dense input (default 3; issue 20's runs use 1, as `iires-sample-mesh
// --seed 1`); --dump DIR writes each local mesh to DIR/MODEL_N.off.
// (internally: --child METHOD --input FILE --cloud FILE --truth MESH|"" --spacing L --n N runs one method)
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <memory>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/utility/Logging.h>
#include <sstream>
#include <string>
#include <vector>

#include "iires/io.hpp"
#include "iires/reconstruct/reconstruct.hpp"
#include "iires/resample.hpp"
#include "iires/sampling.hpp"

#include "bench_util.hpp"

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

using iires::bench::split;

/// The closed 2-manifold meshes of the corpus (DEVELOPERS.md / the preamble's list).
const char* kClosedCorpus =
    "fandisk,joint,bunny00,armadillo,hand,knot1,knot2,eight,3torus,double-torus-example,cactus,couplingdown,part,"
    "dragknob,spool,cross,tripod,cube,beam,handle,helmet,retinal,boeing,pipe,itemb,u,sphere,ellipsoid,larger_sphere";
/// The real point sets of the corpus.
const char* kRealPoints = "kitten.xyz,hippo1.ply,hippo2.ply,building.ply,sphere_20k.xyz,before_upsample.xyz";

/// The line a method reports. @p truth may be empty (a real point set): distances then go to @p input.
std::string describe(const iires::TriangleMesh& mesh, const iires::TriangleMesh& truth, const iires::PointCloud& input,
                     double seconds, int threads) {
  const iires::Execution exec{threads};
  const iires::MeshQuality q = iires::evaluateMesh(mesh, &input, {}, exec);
  double toTruth = q.distance.forwardMax, fromTruth = q.distance.backwardMax, diagonal = q.distance.diagonal,
         mean = q.distance.mean;
  if (!truth.triangles.empty()) {
    const iires::SurfaceDistance d = iires::surfaceDistance(mesh, truth, {}, exec);
    toTruth = d.forwardMax, fromTruth = d.backwardMax, diagonal = d.diagonal, mean = d.mean;
  }
  std::ostringstream os;
  os << "vertices=" << q.vertices << " faces=" << q.faces << " self_intersections=" << q.selfIntersections
     << " nonmanifold_edges=" << q.nonManifoldEdges << " nonmanifold_vertices=" << q.nonManifoldVertices
     << " oriented=" << q.oriented << " closed=" << q.closed << " components=" << q.components
     << " closed_components=" << q.closedComponents << " euler=" << q.euler
     << " genus=" << (q.genus >= 0 ? std::to_string(q.genus) : std::string("na"))
     << " boundary_edges=" << q.boundaryEdges << " boundary_loops=" << q.boundaryLoops
     << " degenerate_faces=" << q.degenerateFaces << " valid=" << q.valid() << " q_avg=" << q.qualityMean
     << " q_min=" << q.qualityMin << " min_angle_avg=" << q.minAngleMean << " pct_angle_lt30=" << 100.0 * q.shareBelow30
     << " reference=" << (truth.triangles.empty() ? "input" : "mesh")
     << " hausdorff_pct_diag=" << 100.0 * std::max(toTruth, fromTruth) / diagonal
     << " mesh_to_truth_pct_diag=" << 100.0 * toTruth / diagonal
     << " truth_to_mesh_pct_diag=" << 100.0 * fromTruth / diagonal << " mean_dist_pct_diag=" << 100.0 * mean / diagonal
     << " uncovered=" << q.uncovered << " uncovered_pct=" << 100.0 * q.uncoveredShare << " time_s=" << seconds;
  return os.str();
}

/// The dense input of a model: a sampling of the true mesh without normals (a scan), or for "hand-vertices" the
/// mesh's own vertices.
iires::PointCloud modelInput(const iires::TriangleMesh& truth, bool sparse, std::size_t dense, double ratio,
                             unsigned seed) {
  iires::PointCloud input;
  if (sparse) {
    input.points = truth.vertices;
    return input;
  }
  iires::MeshSamplingParams sp;
  sp.count = dense;
  sp.densityRatio = ratio;
  sp.seed = seed;
  input = iires::sampleMesh(truth, sp);
  input.normals.clear();
  return input;
}

/// What one child process runs: one method on the parent's files.
struct ChildJob {
  std::string method, inputFile, cloudFile, truthFile, dump;
  double spacing = 0;
  std::size_t n = 0;
  int threads = 0;
};

std::string runMethod(const ChildJob& job) {
  const iires::PointCloud input = iires::readPointCloud(job.inputFile);
  const iires::PointCloud samples = iires::readPointCloud(job.cloudFile);
  const iires::TriangleMesh truth = job.truthFile.empty() ? iires::TriangleMesh{} : iires::readMesh(job.truthFile);
  const auto t = Clock::now();
  iires::TriangleMesh mesh;
  const std::string& method = job.method;
  if (method == "local" || method == "advancing-front" || method == "input-advancing-front") {
    iires::ReconstructParams p;
    p.evaluate = false;
    const iires::Execution exec{job.threads};
    p.method = iires::parseReconstructMethod(method == "local" ? method : "advancing-front");
    iires::ReconstructResult r;
    if (method == "local") {  // the whole pipeline, as iires-reconstruct runs it
      p.targetCount = job.n;
      r = iires::reconstruct(input, p, exec);
      if (r.samples.points != samples.points) return "status=error message=\"resampling differs from the parent's\"";
    } else {  // the resampled points, or (input-advancing-front) the input itself
      p.resample = false;
      r = iires::reconstruct(method == "advancing-front" ? samples : input, p, exec);
    }
    mesh = r.mesh;
    if (!job.dump.empty()) iires::writeMesh(job.dump, mesh);
    double validity = 0;
    for (const auto& s : r.timings)
      if (s.name == "validity") validity = s.seconds;
    const double meshing = r.meshingSeconds();
    std::ostringstream extra;
    extra << " holes_filled=" << r.holes.filled << " holes_kept=" << r.holes.kept
          << " large_holes_filled=" << r.largeHoles.filled << " large_holes_kept=" << r.largeHoles.kept
          << " large_holes_unsupported=" << r.largeHoles.unsupported
          << " validity_s=" << validity << " validity_pct_of_meshing="
          << (meshing > validity ? 100.0 * validity / (meshing - validity) : 0.0)
          << " si_found=" << r.validity.intersectingPairs << " repair_removed=" << r.validity.facesRemoved
          << " repair_added=" << r.validity.facesAdded << " repair_unfilled=" << r.validity.removedWithoutFill;
    return describe(mesh, truth, input, meshing, job.threads) + extra.str();
  }
  open3d::geometry::PointCloud pcd;
  pcd.points_ = samples.points;
  pcd.normals_ = samples.normals;
  std::shared_ptr<open3d::geometry::TriangleMesh> o3d;
  const double s = job.spacing;
  if (method == "bpa") {
    o3d = open3d::geometry::TriangleMesh::CreateFromPointCloudBallPivoting(pcd, {0.75 * s, 1.0 * s, 1.5 * s, 2.0 * s});
  } else if (method == "poisson") {
    o3d = std::get<0>(
        open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson(pcd, 8, 0.0f, 1.1f, false, job.threads));
  } else {
    return "status=error message=\"unknown method\"";
  }
  const double seconds = since(t);
  mesh.vertices = o3d->vertices_;
  mesh.triangles = o3d->triangles_;
  return describe(mesh, truth, input, seconds, job.threads);
}

/// Run one method in a fresh process (popen of this binary with --child): libgomp is not fork-safe once the
/// parent has used OpenMP, and Debian's Open3D Poisson aborts on some models. Returns the child's line, or a
/// status when it crashed.
std::string isolated(const std::string& self, const ChildJob& job) {
  std::ostringstream cmd;
  cmd << "'" << self << "' --child " << job.method << " --input '" << job.inputFile << "' --cloud '" << job.cloudFile
      << "' --truth '" << job.truthFile << "' --spacing " << std::setprecision(17) << job.spacing << " --n " << job.n
      << " --threads " << job.threads;
  if (!job.dump.empty() && job.method == "local") cmd << " --dump '" << job.dump << "'";
  cmd << " 2>/dev/null";
  std::FILE* pipe = popen(cmd.str().c_str(), "r");
  if (!pipe) return "status=popen_failed";
  std::string out;
  char buf[4096];
  std::size_t r;
  while ((r = std::fread(buf, 1, sizeof buf, pipe)) > 0) out.append(buf, r);
  const int status = pclose(pipe);
  while (!out.empty() && out.back() == '\n') out.pop_back();
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0 && !out.empty()) return out;
  if (WIFSIGNALED(status) || (WIFEXITED(status) && WEXITSTATUS(status) >= 128))
    return "status=crashed exit=" + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status));
  return "status=failed exit=" + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1);
}

/// One model or point set: its dense input, resampled to each N, every method on it.
struct Case {
  std::string name, truthFile;  // truthFile empty: a real point set
  iires::PointCloud input;
};

void runCase(const Case& c, const std::vector<std::string>& counts, const std::vector<std::string>& methods,
             double ratio, int threads, const std::string& self, const std::string& tmp, const std::string& dump) {
  // A true mesh that intersects itself (a tail through a body) has a genus of its combinatorics, not of the surface
  // its samples show: no genus to compare with, but a closed mesh is still expected.
  std::string genusTruth = "na", truthClosed = "na";
  if (!c.truthFile.empty()) {
    const iires::MeshQuality tq = iires::evaluateMesh(iires::readMesh(c.truthFile));
    truthClosed = tq.closed ? "1" : "0";
    if (tq.genus >= 0 && tq.closed && tq.selfIntersections == 0) genusTruth = std::to_string(tq.genus);
  }
  const std::string inputFile = tmp + "/input.ply", cloudFile = tmp + "/samples.ply";
  iires::writePointCloud(inputFile, c.input);
  bool first = true;
  for (const std::string& count : counts) {
    iires::ResampleParams rp = iires::meshResampling();  // the resampling reconstruct() does
    rp.targetCount = std::stoul(count);
    const auto t = Clock::now();
    const std::string head = "model=" + c.name + " density_ratio=" + (c.truthFile.empty() ? "real" : std::to_string(ratio).substr(0, 3)) +
                             " input_points=" + std::to_string(c.input.size()) + " n=" + count + " genus_truth=" + genusTruth +
                             " truth_closed=" + truthClosed;
    iires::ResampleResult rs;
    try {  // an input the resampler refuses (exit 1 or 2 from the CLI) is a row, not the end of the run
      rs = iires::resample(c.input, rp, iires::Execution{threads});
    } catch (const std::exception& e) {
      std::cout << head << " method=resample status=error message=\"" << e.what() << "\"" << std::endl;
      continue;
    }
    std::cout << head << " method=resample spacing_cv=" << rs.spacing.cv << " time_s=" << since(t) << std::endl;
    iires::writePointCloud(cloudFile, rs.cloud);
    for (const std::string& m : methods) {
      if (m == "input-advancing-front" && !first) continue;  // independent of N
      ChildJob job{m, inputFile, cloudFile, c.truthFile, "", rs.spacing.mean, std::stoul(count), threads};
      if (!dump.empty()) job.dump = dump + "/" + c.name + "_" + count + ".off";
      std::cout << head << " method=" << m << " " << isolated(self, job) << std::endl;
    }
    first = false;
  }
  std::remove(cloudFile.c_str());
  std::remove(inputFile.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  std::string data = IIRES_BENCH_DATA_DIR, models = "bunny00,armadillo,hand,fandisk,knot1,hand-vertices";
  std::string points = "none", counts = "10000", pointCounts = "5000", methods = "local,advancing-front,bpa,poisson";
  std::size_t dense = 100000;
  double ratio = 1.0;
  int threads = 0;
  unsigned seed = 3;
  std::string dump;
  ChildJob child;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--child") child.method = v;
    else if (k == "--input") child.inputFile = v;
    else if (k == "--cloud") child.cloudFile = v;
    else if (k == "--truth") child.truthFile = v;
    else if (k == "--spacing") child.spacing = std::stod(v);
    else if (k == "--n") child.n = std::stoul(v);
    else if (k == "--data") data = v;
    else if (k == "--models") models = v;
    else if (k == "--points") points = v;
    else if (k == "--counts") counts = v;
    else if (k == "--point-counts") pointCounts = v;
    else if (k == "--methods") methods = v;
    else if (k == "--dense") dense = std::stoul(v);
    else if (k == "--density-ratio") ratio = std::stod(v);
    else if (k == "--threads") threads = std::stoi(v);
    else if (k == "--seed") seed = static_cast<unsigned>(std::stoul(v));
    else if (k == "--dump") child.dump = dump = v;
    else {
      std::cerr << "unknown option " << k << "\n";
      return 2;
    }
  }
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  if (!child.method.empty()) {
    child.threads = threads;
    try {
      const std::string row = runMethod(child);  // before the status: a throw must not leave "status=ok" behind
      std::cout << "status=ok " << row << std::endl;
    } catch (const std::exception& e) {
      std::cout << "status=error message=\"" << e.what() << "\"" << std::endl;
    }
    return 0;
  }
  char tmpl[] = "/tmp/reconstruct_bench_XXXXXX";
  if (!mkdtemp(tmpl)) return 1;
  const std::string tmp = tmpl;
  const std::vector<std::string> countList = split(counts), methodList = split(methods);
  if (models == "closed") models = kClosedCorpus;
  if (points == "real") points = kRealPoints;
  for (const std::string& model : split(models == "none" ? std::string() : models)) {
    const bool sparse = model == "hand-vertices";
    Case c;
    c.name = model;
    c.truthFile = data + "/meshes/" + (sparse ? std::string("hand") : model) + ".off";
    try {
      c.input = modelInput(iires::readMesh(c.truthFile), sparse, dense, ratio, seed);
    } catch (const std::exception& e) {
      std::cout << "model=" << model << " status=error message=\"" << e.what() << "\"" << std::endl;
      continue;
    }
    runCase(c, countList, methodList, ratio, threads, argv[0], tmp, dump);
  }
  for (const std::string& file : split(points == "none" ? std::string() : points)) {
    Case c;
    c.name = file.substr(0, file.find('.'));
    try {
      c.input = iires::readPointCloud(data + "/points_3/" + file);
    } catch (const std::exception& e) {
      std::cout << "model=" << c.name << " status=error message=\"" << e.what() << "\"" << std::endl;
      continue;
    }
    runCase(c, split(pointCounts), methodList, ratio, threads, argv[0], tmp, dump);
  }
  rmdir(tmp.c_str());
  return 0;
}
