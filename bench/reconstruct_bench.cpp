// reconstruct_bench: issue 7's side-by-side table (the paper's Tables 5–6 protocol). For each model: a dense
// area-uniform sampling of the true mesh → isotropic resampling to N (iires) → the same N points meshed by
//   iires local (the whole pipeline from the dense input, as iires-reconstruct runs it; its resampling is
//   deterministic, so its points are the ones the others get), iires + CGAL advancing front, Open3D ball
//   pivoting, Open3D Poisson;
// and, on request, input-advancing-front: CGAL's advancing front on the model's input itself, no resampling
// (for hand-vertices the mesh through exactly the true vertices: how close an interpolation of the input
// alone gets to the true mesh);
// each method runs in a child process (Debian's Open3D Poisson aborts on some models) and prints one
// key=value line: quality (Q, angles), topology, Hausdorff to the TRUE mesh (% of its diagonal), time.
//
// Usage: reconstruct_bench [--data DIR] [--models a,b,c] [--counts 10000,20000] [--dense 100000]
//                          [--methods local,advancing-front,bpa,poisson,input-advancing-front] [--threads T]
//                          [--seed S] [--dump DIR]
// --seed: the sampleMesh seed of the dense input (default 3); --dump DIR writes each local mesh to
// DIR/MODEL_N_sSEED.off.
// (internally: --child METHOD --cloud FILE --truth MESH --spacing L --n N runs one method and prints its line)
// Extra model "hand-vertices": the 1,197 vertices of CGAL's hand mesh (a sparse, uneven scan) upsampled to N.
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <iomanip>
#include <iostream>
#include <memory>
#include <numeric>
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/utility/Logging.h>
#include <sstream>
#include <string>
#include <vector>

#include "iires/io.hpp"
#include "iires/metrics.hpp"
#include "iires/reconstruct/reconstruct.hpp"
#include "iires/resample.hpp"
#include "iires/sampling.hpp"

#include "bench_util.hpp"

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

using iires::bench::split;

/// The line a method reports: quality and topology of its mesh, distance to the true surface, time.
std::string describe(const iires::TriangleMesh& mesh, const iires::TriangleMesh& truth, double seconds, int threads) {
  iires::MeshQualityParams qp;
  qp.threads = threads;
  const iires::MeshQuality q = iires::evaluateMesh(mesh, nullptr, qp);
  const iires::SurfaceDistance d = iires::surfaceDistance(mesh, truth, qp);
  std::ostringstream os;
  os << "vertices=" << q.vertices << " faces=" << q.faces << " q_avg=" << q.qualityMean << " q_min=" << q.qualityMin
     << " min_angle_avg=" << q.minAngleMean << " pct_angle_lt30=" << 100.0 * q.shareBelow30
     << " boundary_edges=" << q.boundaryEdges << " boundary_loops=" << q.boundaryLoops
     << " nonmanifold_edges=" << q.nonManifoldEdges << " nonmanifold_vertices=" << q.nonManifoldVertices
     << " components=" << q.components << " euler=" << q.euler << " closed=" << q.closed << " oriented=" << q.oriented
     << " genus=" << q.genus << " hausdorff_pct_diag=" << 100.0 * d.relativeHausdorff()
     << " mesh_to_truth_pct_diag=" << 100.0 * d.forwardMax / d.diagonal
     << " truth_to_mesh_pct_diag=" << 100.0 * d.backwardMax / d.diagonal
     << " mean_dist_pct_diag=" << 100.0 * d.relativeMean() << " time_s=" << seconds;
  return os.str();
}

/// The input of a model: a dense area-uniform sampling of the true mesh without normals (a scan), or for the
/// sparse model the mesh's own vertices.
iires::PointCloud modelInput(const iires::TriangleMesh& truth, bool sparse, std::size_t dense, unsigned seed) {
  iires::PointCloud input;
  if (sparse) {
    input.points = truth.vertices;
  } else {
    iires::MeshSamplingParams sp;
    sp.count = dense;
    sp.seed = seed;
    input = iires::sampleMesh(truth, sp);
    input.normals.clear();  // a scan has no normals: the pipeline estimates them
  }
  return input;
}

std::string runMethod(const std::string& method, const iires::PointCloud& samples, const iires::TriangleMesh& truth,
                      double spacing, std::size_t n, bool sparse, std::size_t dense, int threads, unsigned seed,
                      const std::string& dump) {
  const auto t = Clock::now();
  iires::TriangleMesh mesh;
  if (method == "local" || method == "advancing-front" || method == "input-advancing-front") {
    iires::ReconstructParams p;
    p.evaluate = false;
    p.threads = threads;
    p.method = iires::parseReconstructMethod(method == "local" ? method : "advancing-front");
    iires::ReconstructResult r;
    if (method == "local") {  // the whole pipeline, as iires-reconstruct runs it
      p.targetCount = n;
      r = iires::reconstruct(modelInput(truth, sparse, dense, seed), p);
      if (r.samples.points != samples.points) return "status=error message=\"resampling differs from the parent's\"";
    } else {  // the resampled points, or (input-advancing-front: an interpolation floor) the input itself
      p.resample = false;
      r = iires::reconstruct(method == "advancing-front" ? samples : modelInput(truth, sparse, dense, seed), p);
    }
    mesh = r.mesh;
    if (!dump.empty()) iires::writeMesh(dump, mesh);
    return describe(mesh, truth, r.meshingSeconds(), threads) +
           " holes_filled=" + std::to_string(r.holes.filled) + " holes_kept=" + std::to_string(r.holes.kept) +
           " large_holes_filled=" + std::to_string(r.largeHoles.filled) +
           " large_holes_kept=" + std::to_string(r.largeHoles.kept);
  }
  open3d::geometry::PointCloud pcd;
  pcd.points_ = samples.points;
  pcd.normals_ = samples.normals;
  std::shared_ptr<open3d::geometry::TriangleMesh> o3d;
  if (method == "bpa") {
    o3d = open3d::geometry::TriangleMesh::CreateFromPointCloudBallPivoting(
        pcd, {0.75 * spacing, 1.0 * spacing, 1.5 * spacing, 2.0 * spacing});
  } else if (method == "poisson") {
    o3d = std::get<0>(open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson(pcd, 8, 0.0f, 1.1f, false, threads));
  } else {
    return "error=unknown_method";
  }
  const double seconds = since(t);
  mesh.vertices = o3d->vertices_;
  mesh.triangles = o3d->triangles_;
  return describe(mesh, truth, seconds, threads);
}

/// Run one method in a fresh process (fork + exec of this binary with --child): libgomp is not fork-safe once
/// the parent has used OpenMP, and Debian's Open3D Poisson aborts on some models. Returns the child's line, or a
/// status when it crashed.
std::string isolated(const std::string& self, const std::string& method, const std::string& cloudFile,
                     const std::string& truthFile, double spacing, const std::string& n, bool sparse,
                     std::size_t dense, int threads, unsigned seed, const std::string& dump) {
  std::ostringstream cmd;
  cmd << "'" << self << "' --child " << method << " --cloud '" << cloudFile << "' --truth '" << truthFile
      << "' --spacing " << std::setprecision(17) << spacing << " --n " << n << " --sparse " << sparse
      << " --dense " << dense << " --threads " << threads << " --seed " << seed;
  if (!dump.empty() && method == "local") cmd << " --dump '" << dump << "'";
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

}  // namespace

int main(int argc, char** argv) {
  std::string data = IIRES_BENCH_DATA_DIR, models = "bunny00,armadillo,hand,fandisk,knot1,hand-vertices";
  std::string counts = "10000", methods = "local,advancing-front,bpa,poisson";
  std::size_t dense = 100000;
  int threads = 0;
  std::string child, cloudFile, truthFile;
  double spacingArg = 0;
  std::size_t nArg = 0;
  bool sparseArg = false;
  unsigned seed = 3;
  std::string dump;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--child") child = v;
    else if (k == "--cloud") cloudFile = v;
    else if (k == "--truth") truthFile = v;
    else if (k == "--spacing") spacingArg = std::stod(v);
    else if (k == "--n") nArg = std::stoul(v);
    else if (k == "--sparse") sparseArg = v == "1";
    else if (k == "--data") data = v;
    else if (k == "--models") models = v;
    else if (k == "--counts") counts = v;
    else if (k == "--methods") methods = v;
    else if (k == "--dense") dense = std::stoul(v);
    else if (k == "--threads") threads = std::stoi(v);
    else if (k == "--seed") seed = static_cast<unsigned>(std::stoul(v));
    else if (k == "--dump") dump = v;
    else {
      std::cerr << "unknown option " << k << "\n";
      return 2;
    }
  }
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  if (!child.empty()) {
    try {
      std::cout << "status=ok " << runMethod(child, iires::readPointCloud(cloudFile), iires::readMesh(truthFile),
                                              spacingArg, nArg, sparseArg, dense, threads, seed, dump)
                << std::endl;
    } catch (const std::exception& e) {
      std::cout << "status=error message=\"" << e.what() << "\"" << std::endl;
    }
    return 0;
  }
  char tmpl[] = "/tmp/reconstruct_bench_XXXXXX";
  if (!mkdtemp(tmpl)) return 1;
  const std::string tmp = tmpl;
  for (const std::string& model : split(models)) {
    const bool sparse = model == "hand-vertices";
    const std::string file = data + "/meshes/" + (sparse ? std::string("hand") : model) + ".off";
    const iires::TriangleMesh truth = iires::readMesh(file);
    const iires::PointCloud input = modelInput(truth, sparse, dense, seed);
    for (const std::string& c : split(counts)) {
      iires::ResampleParams rp = iires::meshResampling();  // the resampling reconstruct() does
      rp.targetCount = std::stoul(c);
      rp.threads = threads;
      const auto t = Clock::now();
      const iires::ResampleResult rs = iires::resample(input, rp);
      const double resampleSeconds = since(t);
      const double spacing = rs.spacing.mean;
      std::cout << "model=" << model << " n=" << c << " method=resample input_points=" << input.size()
                << " spacing_cv=" << rs.spacing.cv << " time_s=" << resampleSeconds << std::endl;
      const std::string cloudFile = tmp + "/samples.ply";
      iires::writePointCloud(cloudFile, rs.cloud);
      for (const std::string& m : split(methods))
        std::cout << "model=" << model << " n=" << c << " method=" << m << " "
                  << isolated(argv[0], m, cloudFile, file, spacing, c, sparse, dense, threads, seed,
                              dump.empty() ? std::string() : dump + "/" + model + "_" + c + "_s" + std::to_string(seed) + ".off")
                  << std::endl;
      std::remove(cloudFile.c_str());
    }
  }
  rmdir(tmp.c_str());
  return 0;
}
