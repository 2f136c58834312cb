// SPDX-License-Identifier: GPL-3.0-or-later
// iires-sample-mesh: draw a (noisy, non-uniform, outlier-ridden) test cloud from a mesh (DESIGN §7).
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "common.hpp"
#include "iires/metrics.hpp"
#include "iires/io.hpp"
#include "iires/knn.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/sampling.hpp"

namespace {

/// Memory one sample costs (position, normal, triangle id, k-NN index for l, the written buffer), generously.
constexpr std::size_t kBytesPerPoint = 512;

int run(int argc, char** argv) {
  CLI::App app{
      "Sample points on a triangle mesh: uniform or non-uniform density, noise along the normal, "
      "outliers. Spacing-relative amplitudes use l = mean distance to the 6 nearest samples of the "
      "noise-free cloud (paper §6.1)."};
  app.set_version_flag("--version", iires::tools::versionString());
  std::string meshPath, outputPath;
  iires::MeshSamplingParams params;
  long long count = 0;  // signed, so that a negative count is an error rather than a huge unsigned value
  double noiseSpacing = 0, outlierMinSpacing = 0, outlierMaxSpacing = 0;
  bool uniformNoise = false;
  app.add_option("MESH", meshPath, "input mesh (.ply .obj .off .stl)")->required();
  app.add_option("OUTPUT", outputPath,
                 "output cloud (.ply .xyz .xyzn), with normals where the format has them")
      ->required();
  app.add_option("-n,--count", count, "number of points (at least 1)")->required();
  app.add_option("--density-ratio", params.densityRatio, "densest/sparsest density along the longest axis")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e6));
  auto* noise = app.add_option("--noise", params.noise, "noise amplitude along the normal (absolute)")
                    ->check(CLI::NonNegativeNumber);
  auto* noiseRel = app.add_option("--noise-spacing", noiseSpacing, "noise amplitude in units of l")
                       ->check(CLI::NonNegativeNumber)
                       ->excludes(noise);
  app.add_flag("--uniform-noise", uniformNoise,
               "noise uniform in [0, amplitude] instead of N(0, amplitude²)");
  auto* fraction = app.add_option("--outliers", params.outlierFraction, "share of points made outliers")
                       ->check(CLI::Range(0.0, 1.0));
  auto* outMin = app.add_option("--outlier-min", params.outlierMin, "smallest outlier offset (absolute)")
                     ->check(CLI::NonNegativeNumber);
  auto* outMax = app.add_option("--outlier-max", params.outlierMax, "largest outlier offset (absolute)")
                     ->check(CLI::NonNegativeNumber);
  auto* outMinRel = app.add_option("--outlier-min-spacing", outlierMinSpacing, "smallest outlier offset / l")
                        ->check(CLI::NonNegativeNumber)
                        ->excludes(outMin);
  auto* outMaxRel = app.add_option("--outlier-max-spacing", outlierMaxSpacing, "largest outlier offset / l")
                        ->check(CLI::NonNegativeNumber)
                        ->excludes(outMax);
  app.add_option("--seed", params.seed, "random seed; same seed, same cloud")->capture_default_str()
        ->check(iires::tools::seedValidator());
  if (const int code = iires::tools::parseArgs(app, argc, argv); code != iires::tools::kContinue) return code;
  if (count < 1) throw std::invalid_argument("-n/--count must be at least 1, got " + std::to_string(count));
  iires::tools::checkCount("-n/--count", count, kBytesPerPoint);
  iires::tools::checkOutputPath(outputPath, {meshPath});
  params.count = static_cast<std::size_t>(count);
  if (*fraction && params.outlierFraction > 0 && !*outMax && !*outMaxRel)
    throw std::invalid_argument("--outliers needs --outlier-max or --outlier-max-spacing");
  params.gaussianNoise = !uniformNoise;
  if (!*fraction)
    iires::tools::refuseFlags(app, {"--outlier-min", "--outlier-max", "--outlier-min-spacing", "--outlier-max-spacing"},
                "no --outliers (no point is made an outlier)");
  if (!*noise && !*noiseRel) iires::tools::refuseFlags(app, {"--uniform-noise"}, "no --noise or --noise-spacing");

  const iires::TriangleMesh mesh = iires::readMesh(meshPath);
  double l = 0;
  if (*noiseRel || *outMinRel || *outMaxRel) {
    iires::MeshSamplingParams clean = params;  // same seed: the surface samples below are these ones
    clean.noise = clean.outlierFraction = 0;
    l = iires::meanNeighbourSpacing(iires::sampleMesh(mesh, clean).points);
    if (*noiseRel) params.noise = noiseSpacing * l;
    if (*outMinRel) params.outlierMin = outlierMinSpacing * l;
    if (*outMaxRel) params.outlierMax = outlierMaxSpacing * l;
  }
  const iires::PointCloud cloud = iires::sampleMesh(mesh, params);
  iires::writePointCloud(outputPath, cloud);
  std::printf("%s: %zu points from %zu triangles; noise %g (%s), outliers %g in [%g, %g]", outputPath.c_str(),
              cloud.size(), mesh.triangles.size(), params.noise, uniformNoise ? "uniform" : "gaussian",
              params.outlierFraction, params.outlierMin, params.outlierMax);
  if (l > 0) std::printf("; l = %g", l);
  std::printf("\n");
  return iires::tools::kOk;
}

}  // namespace

int main(int argc, char** argv) {
  return iires::tools::guardedMain("iires-sample-mesh", [&] { return run(argc, argv); });
}
