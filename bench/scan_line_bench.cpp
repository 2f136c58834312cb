// SPDX-License-Identifier: GPL-3.0-or-later
// Scanner samplings: points dense along scan lines and sparse across them, generated with fixed seeds
// (tests/shapes.hpp), positions only (like a raw .xyz scan), resampled — and with --mesh reconstructed — with the
// default parameters (the CLIs' defaults). Prints one key=value line per (case, N).
// Usage: scan_line_bench CASE [N ...] [--seed S] [--threads T] [--mesh] [--write-input FILE.xyz]
//   CASE: lines — 50 parallel lines 0.02 apart on a gently curved sheet, points 0.002 apart along them;
//         rings — a rotating scanner's rings on the ground, 0.15 apart near the sensor and 1.1 apart at the
//                 outer ones, points 0.015–0.05 apart along them;
//         floor — a floor seen from one scanner 1 above its corner, 60,000 points whose density falls with the
//                 range (the far corner 14 times more sparsely spaced than the median);
//         slices:MESH — a profile scanner's slices of a closed mesh: 60 planes across its longest axis, points
//                 a tenth of the planes' distance apart along each contour (random, 3 % jitter), positions only.
// Columns: points, cv (nearest-neighbour spacing cv), components (the geodesic coordinates' parts; the truth is
// 1), outer_share_err (rings: the share of the points beyond radius 7 against that band's share of the area,
// in % of it), time_s; with --mesh: mesh_parts, q_avg, q_min, lt30 (% of triangles with an angle under 30°).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "iires/io.hpp"
#include "iires/reconstruct/reconstruct.hpp"
#include "iires/resample.hpp"
#include "shapes.hpp"

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

constexpr double kOuterRadius = 7.0;  // rings: the band whose share of the points is checked

/// rings: the band beyond kOuterRadius's share of the ground the rings cover.
double outerAreaShare() {
  const double inner = 1.7 / std::tan(30.0 * M_PI / 180.0), outer = 1.7 / std::tan(10.0 * M_PI / 180.0);
  return (outer * outer - kOuterRadius * kOuterRadius) / (outer * outer - inner * inner);
}

double outerShareError(const iires::PointCloud& c) {
  std::size_t far = 0;
  for (const auto& p : c.points) far += p.head<2>().norm() > kOuterRadius;
  const double share = static_cast<double>(far) / static_cast<double>(c.size());
  return 100.0 * (share - outerAreaShare()) / outerAreaShare();
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: scan_line_bench CASE [N ...] [--seed S] [--threads T] [--mesh] [--write-input F]\n");
    return 2;
  }
  const std::string name = argv[1];
  std::vector<std::size_t> ns;
  int threads = 0;
  bool mesh = false;
  std::string writeInput;
  std::uint64_t seed = 1;
  for (int a = 2; a < argc; ++a) {
    const std::string arg = argv[a];
    if (arg == "--threads" && a + 1 < argc) {
      threads = std::stoi(argv[++a]);
    } else if (arg == "--seed" && a + 1 < argc) {
      seed = std::stoull(argv[++a]);
    } else if (arg == "--write-input" && a + 1 < argc) {
      writeInput = argv[++a];
    } else if (arg == "--mesh") {
      mesh = true;
    } else {
      ns.push_back(std::stoul(arg));
    }
  }
  const bool rings = name == "rings", floor = name == "floor", slices = name.rfind("slices:", 0) == 0;
  if (name != "lines" && !rings && !floor && !slices) {
    std::fprintf(stderr, "scan_line_bench: error: unknown case '%s'\n", name.c_str());
    return 2;
  }
  const iires::PointCloud cloud = rings    ? iires::test::groundRings(seed)
                                  : floor  ? iires::test::floorFromCorner(60000, seed)
                                  : slices ? iires::test::sliceContours(iires::readMesh(name.substr(7)), 60, seed)
                                           : iires::test::scanLineCloud(seed);
  if (!writeInput.empty()) iires::writePointCloud(writeInput, cloud);
  const iires::Execution exec{threads};
  for (std::size_t n : ns) {
    std::printf("case=%s seed=%llu input=%zu N=%zu", name.c_str(), static_cast<unsigned long long>(seed), cloud.size(),
                n);
    try {
      const double t0 = now();
      if (mesh) {
        iires::ReconstructParams p;
        p.targetCount = n;
        const iires::ReconstructResult r = iires::reconstruct(cloud, p, exec);
        const auto& q = r.quality;
        std::printf(" points=%zu cv=%.4f components=%zu mesh_parts=%zu q_avg=%.3f q_min=%.3f lt30=%.2f time_s=%.3f",
                    r.samples.size(), r.resampling.spacing.cv, r.resampling.components, q.components, q.qualityMean,
                    q.qualityMin, 100.0 * q.shareBelow30, now() - t0);
        if (rings) std::printf(" outer_share_err=%.1f", outerShareError(r.samples));
      } else {
        iires::ResampleParams p;
        p.targetCount = n;
        const iires::ResampleResult r = iires::resample(cloud, p, exec);
        std::printf(" points=%zu cv=%.4f components=%zu time_s=%.3f", r.cloud.size(), r.spacing.cv, r.components,
                    now() - t0);
        if (rings) std::printf(" outer_share_err=%.1f", outerShareError(r.cloud));
      }
    } catch (const std::exception& e) {  // a row that failed is a result too: say so and go on
      std::printf(" status=failed error=\"%s\"", e.what());
    }
    std::printf("\n");
    std::fflush(stdout);
  }
  return 0;
}
