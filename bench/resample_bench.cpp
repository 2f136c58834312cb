// SPDX-License-Identifier: GPL-3.0-or-later
// Resampling benchmark: iires vs Open3D farthest-point and voxel down-sampling on the same non-uniform dense
// sampling of a CGAL model, in one run. Prints one key=value line per (model, input, N, method).
// Usage: resample_bench MESH INPUT_COUNT N [N ...] [--density-ratio R] [--fps-limit X] [--threads T] [--no-peers]
//        [--split-x X]
// --split-x X adds share_beyond (the share of the output with x > X: a second object placed there) and
// area_beyond (the same share of a uniform sampling of the mesh: the area share an isotropic output has).
#include <open3d/geometry/PointCloud.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "iires/io.hpp"
#include "iires/metrics.hpp"
#include "iires/resample.hpp"
#include "iires/sampling.hpp"

#include "bench_util.hpp"

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

/// Share of @p pts with x > @p split.
double shareBeyond(const std::vector<Eigen::Vector3d>& pts, double split) {
  std::size_t m = 0;
  for (const auto& p : pts) m += p.x() > split;
  return pts.empty() ? 0.0 : static_cast<double>(m) / static_cast<double>(pts.size());
}

void report(const std::string& prefix, const std::string& method, const std::vector<Eigen::Vector3d>& pts,
            double seconds, const iires::MeshDistance& mesh, const std::vector<Eigen::Vector3d>& reference,
            const std::string& extra = "") {
  const auto spacing = iires::spacingStats(pts);
  const auto err = mesh.distances(pts);
  const auto cover = iires::coverage(reference, pts);
  std::printf(
      "%s method=%s points=%zu time_s=%.3f cv=%.4f err_mean_pct=%.4f err_max_pct=%.4f cov99_per_spacing=%.3f%s\n",
      prefix.c_str(), method.c_str(), pts.size(), seconds, spacing.cv, 100 * err.mean / mesh.diagonal(),
      100 * err.max / mesh.diagonal(), cover.p99 / spacing.mean, extra.c_str());
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
  double fpsLimit = 2e10, split = std::nan("");
  bool peers = true;
  const iires::bench::GridArgs args = iires::bench::parseGridArgs(
      argc, argv, 5.0,
      "resample_bench MESH INPUT_COUNT N [N ...] [--density-ratio R] [--fps-limit X] [--threads T] [--no-peers] "
      "[--split-x X]",
      [&](const std::string& arg, int& a) {
        if (arg == "--no-peers") {
          peers = false;
          return true;
        }
        if (arg == "--split-x" && a + 1 < argc) {
          split = std::stod(argv[++a]);
          return true;
        }
        if (arg != "--fps-limit" || a + 1 >= argc) return false;
        fpsLimit = std::stod(argv[++a]);
        return true;
      });
  const std::size_t inputCount = args.inputCount;
  const double ratio = args.ratio;
  const int threads = args.threads;
  const iires::TriangleMesh mesh = iires::readMesh(args.meshPath);
  const iires::PointCloud cloud = iires::bench::scanLikeSampling(mesh, inputCount, ratio);
  iires::MeshSamplingParams rp;
  rp.count = 300000;
  rp.seed = 2;
  const auto reference = iires::sampleMesh(mesh, rp).points;
  const iires::MeshDistance distance(mesh);
  const std::string name = args.name();
  // The split's extra fields for a method's output.
  const double areaBeyond = shareBeyond(reference, split);
  auto beyond = [&](const std::vector<Eigen::Vector3d>& pts) {
    if (std::isnan(split)) return std::string();
    char buf[96];
    std::snprintf(buf, sizeof buf, " share_beyond=%.4f area_beyond=%.4f", shareBeyond(pts, split), areaBeyond);
    return std::string(buf);
  };

  open3d::geometry::PointCloud o3d;
  o3d.points_ = cloud.points;
  for (std::size_t n : args.counts) {
    const std::string prefix = "model=" + name + " input=" + std::to_string(inputCount) + " N=" + std::to_string(n);
    iires::ResampleParams p;
    p.targetCount = n;
    double t = now();
    const auto r = iires::resample(cloud, p, iires::Execution{threads});
    const double seconds = now() - t;
    std::string stages = " working=" + std::to_string(r.thinnedPoints);  // then the time per stage
    for (const auto& s : r.timings)
      if (s.name != "total") stages += " t_" + s.name + "=" + std::to_string(s.seconds).substr(0, 6);
    report(prefix, "iires", r.cloud.points, seconds, distance, reference, beyond(r.cloud.points) + stages);
    if (!peers) continue;
    if (static_cast<double>(n) * static_cast<double>(inputCount) <= fpsLimit) {
      t = now();
      const auto fps = o3d.FarthestPointDownSample(n);
      const double fpsSeconds = now() - t;
      report(prefix, "open3d_fps", fps->points_, fpsSeconds, distance, reference, beyond(fps->points_));
    } else {
      std::printf("%s method=open3d_fps skipped=n*N>%.0g\n", prefix.c_str(), fpsLimit);
    }
    // Voxel down-sampling cannot hit N exactly: bisect the voxel size until the count is within 2 % of N.
    double lo = 1e-6 * distance.diagonal(), hi = 0.5 * distance.diagonal();
    std::shared_ptr<open3d::geometry::PointCloud> voxel;
    t = now();
    for (int it = 0; it < 40; ++it) {
      const double mid = std::sqrt(lo * hi);
      voxel = o3d.VoxelDownSample(mid);
      const double got = static_cast<double>(voxel->points_.size());
      if (std::abs(got - static_cast<double>(n)) <= 0.02 * static_cast<double>(n)) break;
      (got > static_cast<double>(n) ? lo : hi) = mid;
    }
    const double voxelSeconds = now() - t;
    report(prefix, "open3d_voxel", voxel->points_, voxelSeconds, distance, reference, beyond(voxel->points_));
  }
  return 0;
}
