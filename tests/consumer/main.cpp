// SPDX-License-Identifier: GPL-3.0-or-later
// Uses the installed iires libraries: resample a sphere to exactly 200 points, mesh it, measure the mesh,
// compare two clouds with the Hausdorff distance. Exits 0 and prints "consumer ok" when all is as expected.
#include <cmath>
#include <cstdio>

#include <iires/io.hpp>
#include <iires/reconstruct/mesh_quality.hpp>
#include <iires/reconstruct/reconstruct.hpp>
#include <iires/register/hausdorff.hpp>
#include <iires/resample.hpp>

int main() {
  iires::PointCloud sphere;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < 1000; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / 1000.0, r = std::sqrt(1.0 - z * z);
    sphere.points.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  iires::ResampleParams params;
  params.targetCount = 200;
  const iires::Execution oneThread{1};
  const iires::ResampleResult resampled = iires::resample(sphere, params, oneThread);
  if (resampled.cloud.size() != 200) {
    std::fprintf(stderr, "resample gave %zu points\n", resampled.cloud.size());
    return 1;
  }
  iires::ReconstructParams rp;
  rp.targetCount = 200;
  const iires::ReconstructResult mesh = iires::reconstruct(sphere, rp, oneThread);
  const iires::MeshQuality quality = iires::evaluateMesh(mesh.mesh);
  const double h = iires::reg::hausdorffDistance(resampled.cloud.points, sphere.points);
  std::printf("resampled %zu points (spacing cv %.3f); mesh %zu faces (Q mean %.3f); hausdorff %.4f\n",
              resampled.cloud.size(), resampled.spacing.cv, quality.faces, quality.qualityMean, h);
  if (quality.faces == 0 || !(h < 0.2)) return 1;
  std::printf("consumer ok\n");
  return 0;
}
